"""The property tests draw the same examples every run (issue 35: "no kill by luck")."""

from __future__ import annotations

import os

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st


@pytest.mark.skipif(
    os.environ.get("HYPOTHESIS_PROFILE", "lpbounds-ci") != "lpbounds-ci",
    reason="another hypothesis profile was asked for",
)
def test_property_tests_draw_the_same_examples_every_run():
    """tests/conftest.py loads the derandomized profile: a property test run twice (as CI
    and a laptop would, in any order, on any worker) sees the same examples, and keeps no
    example database between runs."""
    assert settings().derandomize and settings().database is None
    seen: list[int] = []

    @settings(max_examples=25)
    @given(st.integers(0, 2**62))
    def draw(x: int) -> None:
        seen.append(x)

    draw()
    first = list(seen)
    seen.clear()
    draw()
    assert seen == first and len(set(first)) > 10
