"""RationalVector: the exact vector every exact answer is, checked against Fractions."""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.exact import check
from lpbounds.exact.rationals import RationalVector, fraction_text, rational, solve_rational

FRACS = st.lists(st.fractions(max_denominator=10**30), min_size=1, max_size=8)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(FRACS, st.lists(st.floats(-1e6, 1e6), min_size=8, max_size=8))
def test_vector_against_fractions(values, approx):
    v = RationalVector.from_fractions(values)
    assert list(v) == values and v[len(values) - 1] == values[-1] and v[:2] == values[:2]
    a = np.array(approx[: len(values)])
    assert v.max_abs_error(a) == max(
        abs(Fraction(float(t)) - f) for t, f in zip(a, values, strict=True)
    )
    assert v.to_floats().tolist() == [float(f) for f in values]  # correctly rounded
    lo, hi = np.minimum(a, v.to_floats()), np.maximum(a, v.to_floats())
    inside = all(
        Fraction(float(s)) <= f <= Fraction(float(t))
        for s, f, t in zip(lo, values, hi, strict=True)
    )
    assert v.within(lo, hi) == inside
    assert RationalVector.from_json(json.loads(json.dumps(v.to_json()))) == v


def test_huge_integers_are_written_in_hex_and_read_back():
    big = Fraction(7**9000, 3**8000 + 1)  # beyond Python's 4,300-digit decimal limit
    v = RationalVector.from_fractions([big, Fraction(1, 3)])
    data = json.loads(json.dumps(v.to_json()))
    assert data["den"].startswith("0x") and RationalVector.from_json(data) == v
    text = fraction_text(big)
    assert check.rat(text) == big and rational(text) == big
    assert "exact:" in check.show(big)  # messages never print 9000 digits


def test_bracket_comparisons_are_exact_at_the_last_bit():
    x = Fraction(1, 3)
    v = RationalVector.from_fractions([x])
    below, above = float(x), np.nextafter(float(x), 1.0)
    assert Fraction(below) < x < Fraction(above)
    assert v.within([below], [above]) and not v.within([above], [above])
    assert not v.within([-np.inf], [below]) and v.within([-np.inf], [np.inf])
    assert not v.within([np.nan], [1.0])


def test_rational_refuses_what_has_no_exact_value():
    for bad in (float("nan"), float("inf"), "1/0", "abc", None):
        with pytest.raises(ValidationError):
            rational(bad)
    assert rational(0.1) == Fraction(3602879701896397, 2**55)


def test_solve_rational_and_a_singular_system():
    a = [[Fraction(2), Fraction(1)], [Fraction(1), Fraction(3)]]
    assert solve_rational(a, [Fraction(1), Fraction(2)]) == [Fraction(1, 5), Fraction(3, 5)]
    assert solve_rational([[Fraction(1), Fraction(2)], [Fraction(2), Fraction(4)]], [1, 2]) is None


def test_engine_reports_progress_per_component_and_per_check():
    from lpbounds.exact.files import mdp_data
    from lpbounds.exact.fixed_point import least_fixed_point
    from lpbounds.exact.system import ExactRows

    mdp = lb.garnet(30, 2, 2, 0.9, seed=9)
    events = []
    rows = ExactRows.build(mdp_data(mdp), {"rows": "ELP"})
    fp = least_fixed_point(rows, callback=events.append)
    stages = [e.stage for e in events]
    assert "evaluate" in stages and stages[-1] == "improve"
    evals = [e for e in events if e.stage == "evaluate"]
    assert all(0 < e.done <= e.total == 30 for e in evals) and evals[-1].done == 30
    assert events[-1].residual == 0.0 and fp.iterations == events[-1].iteration
