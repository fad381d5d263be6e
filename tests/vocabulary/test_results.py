"""The result base :class:`lpbounds.results.Result` on the three result types (DP, RLP, NLP).

The displays are checked for what they promise (one line without arrays, the status in
the summary and the HTML, one table row per value inside its bracket); DP's bracket is
checked against ``V*`` from a dense policy iteration in ``tests/_independent`` (numpy
only) and, entry by entry, in exact rational arithmetic.
"""

from __future__ import annotations

from fractions import Fraction
from html.parser import HTMLParser

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.certification.checks import dp_interval
from lpbounds.dp import DPResult, evaluate_policy, solve_exact
from lpbounds.formulations import NLP, RLP
from lpbounds.formulations.nlp.results import NLPResult
from lpbounds.formulations.results import LPResult
from lpbounds.results import Result, outward_bracket
from lpbounds.status import Status
from tests import _independent as ind

EPS = float(np.finfo(np.float64).eps)


@pytest.fixture(scope="module")
def mdp() -> lb.FiniteMDP:
    return lb.garnet(30, 3, 4, 0.9, seed=0)


@pytest.fixture(scope="module")
def part() -> lb.Partition:
    return lb.random_partition(30, 5, seed=0)


@pytest.fixture(scope="module")
def v_star(mdp) -> ind.Reference:
    """V* by Howard's policy iteration with dense numpy solves (the optimal policy's
    linear system solved directly), with its own error bound."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    return ind.policy_iteration(P, mdp.rewards, mdp.allowed, mdp.discount)


@pytest.fixture(scope="module")
def results(mdp, part) -> dict[str, Result]:
    nlp = NLP(mdp, part)
    return {
        "dp": solve_exact(mdp),
        "rlp": RLP(mdp, part).solve(),
        "nlp": nlp.solve("strategy-iteration"),
        # stopped by its round limit with the certified bracket closed: OPTIMAL
        "nlp-rounds": nlp.solve("cutting-planes", max_iter=2, raise_on_failure=False),
        # stopped by its round limit with a valid, wide bracket: not OPTIMAL
        "nlp-limit": nlp.solve(
            "cutting-planes", cuts="monotone", max_iter=1, raise_on_failure=False
        ),
    }


KINDS = ["dp", "rlp", "nlp", "nlp-rounds", "nlp-limit"]


def test_the_three_types_share_the_base(results):
    assert isinstance(results["dp"], DPResult) and isinstance(results["dp"], Result)
    assert isinstance(results["rlp"], LPResult) and isinstance(results["rlp"], Result)
    assert isinstance(results["nlp"], NLPResult) and isinstance(results["nlp"], Result)
    assert results["nlp-limit"].status is not Status.OPTIMAL, "the limit run closed its bracket"


@pytest.mark.parametrize("kind", KINDS)
def test_ok_is_the_one_predicate(results, kind):
    r = results[kind]
    assert r.ok is (r.status is Status.OPTIMAL)
    if hasattr(type(r), "converged"):  # the alias on DP and NLP results
        assert r.converged is r.ok
    assert r.ok is (kind != "nlp-limit"), r.summary()


@pytest.mark.parametrize("kind", KINDS)
def test_repr_is_one_short_line_without_arrays(results, kind):
    r = results[kind]
    text = repr(r)
    assert "\n" not in text and "[" not in text and len(text) < 200, text
    assert text.startswith(type(r).__name__ + "(")
    assert f"status={r.status.value}" in text
    assert f"values={r.values.size}" in text


@pytest.mark.parametrize("kind", KINDS)
def test_summary_says_the_status(results, kind):
    r = results[kind]
    text = r.summary()
    lines = text.splitlines()
    assert 3 <= len(lines) <= 15, text
    assert f"status: {r.status.value}" in text
    assert ("NOT converged" in text) is (not r.ok), text


@pytest.mark.parametrize("kind", ["nlp-rounds", "nlp-limit"])
def test_nlp_summary_does_not_call_a_limit_a_convergence(results, kind):
    """A round limit is a stop reason, whatever the status; the status line alone says
    whether the bracket is certified (the old one-liner said "converged (max_rounds)")."""
    r = results[kind]
    assert r.stop_reason == "max_rounds"
    assert r.ok is (kind == "nlp-rounds"), "the fixture's runs changed status"
    text = r.summary()
    assert f"status: {r.status.value}" in text
    assert "method stopped: max_rounds" in text
    assert "converged (max_rounds)" not in text and "converged" not in text.replace(
        "NOT converged", ""
    ), text


def test_nlp_width_names_the_bracket_width(results):
    for kind in ("nlp", "nlp-rounds", "nlp-limit"):
        r = results[kind]
        assert r.width == r.gap == r.upper_bound - r.lower_bound


class _Table(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.stack: list[str] = []
        self.cells: list[str] = []
        self.tags: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.stack.append(tag)
        self.tags.append(tag)

    def handle_endtag(self, tag):
        assert self.stack and self.stack[-1] == tag, f"</{tag}> closes <{self.stack[-1:]}>"
        self.stack.pop()

    def handle_data(self, data):
        if self.stack and self.stack[-1] in ("td", "th", "caption"):
            self.cells.append(data)


@pytest.mark.parametrize("kind", KINDS)
def test_html_is_a_table_with_the_status(results, kind):
    r = results[kind]
    page = r._repr_html_()
    parser = _Table()
    parser.feed(page)
    parser.close()
    assert parser.stack == [], "unclosed tags"
    assert parser.tags[0] == "table" and "tr" in parser.tags
    assert "status" in parser.cells
    assert any(c.startswith(r.status.value) for c in parser.cells), parser.cells


def test_html_escapes(results):
    r = results["rlp"]
    saved = dict(r.extra)
    try:
        r.extra["message"] = "<b>x & y</b>"
        page = r._repr_html_()
    finally:
        r.extra.clear()
        r.extra.update(saved)
    assert "<b>" not in page and "&lt;b&gt;x &amp; y&lt;/b&gt;" in page


@pytest.mark.parametrize("kind", KINDS)
def test_to_pandas_one_row_per_value_inside_the_bracket(results, kind):
    r = results[kind]
    df = r.to_pandas()
    assert len(df) == r.values.size
    np.testing.assert_array_equal(df["value"].to_numpy(), r.values)
    lo, hi = df["lower"].to_numpy(), df["upper"].to_numpy()
    assert np.isfinite(lo).all() and np.isfinite(hi).all()
    assert (lo <= df["value"]).all() and (df["value"] <= hi).all()
    np.testing.assert_array_equal(lo, r.lower_values)
    np.testing.assert_array_equal(hi, r.upper_values)
    if kind == "dp":
        np.testing.assert_array_equal(df["policy"].to_numpy(), r.policy)


@pytest.mark.parametrize("rtol", [None, 1e-4])
def test_dp_bracket_contains_v_star_and_is_tight(mdp, v_star, rtol):
    scale = np.abs(mdp.rewards).max() / (1 - mdp.discount)
    r = solve_exact(mdp, tol=None if rtol is None else rtol * scale)
    lo, hi = r.lower_values, r.upper_values
    # the reference's own (generous) error is below the DP's: 1e-11 against 3.4e-11 at the
    # default tolerance (DP_RTOL max|R|), 1e-11 against 1e-4 x scale at rtol 1e-4
    assert v_star.error < 0.5 * r.error_bound
    # V* lies in [v_star - error, v_star + error]: the bracket must meet that interval
    assert (lo <= v_star.values + v_star.error).all(), (lo - v_star.values).max()
    assert (v_star.values - v_star.error <= hi).all(), (v_star.values - hi).max()
    # not vacuous: no wider than 2 error_bound plus a few ulps of the values
    width = hi - lo
    ulps = 4 * EPS * np.maximum(1.0, np.abs(r.values) + r.error_bound)
    assert (width > 0).all()
    assert (width <= 2 * r.error_bound + ulps).all(), (width - 2 * r.error_bound).max()
    # rounded outward in exact arithmetic, entry by entry
    e = Fraction(r.error_bound)
    for v, a, b in zip(r.values, lo, hi, strict=True):
        assert Fraction(a) <= Fraction(v) - e and Fraction(v) + e <= Fraction(b)
    # the same numbers as the checks' DP interval
    clo, chi = dp_interval(r)
    np.testing.assert_array_equal(lo, clo)
    np.testing.assert_array_equal(hi, chi)


def test_policy_evaluation_bracket_contains_v_pi(mdp, v_star):
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    ref = ind.policy_value(P, mdp.rewards, v_star.policy, mdp.discount)
    scale = np.abs(mdp.rewards).max() / (1 - mdp.discount)
    ev = evaluate_policy(mdp, v_star.policy, method="iterative", tol=1e-6 * scale)
    assert ref.error < 0.05 * ev.error_bound
    assert (ev.lower_values <= ref.values - ref.error).all()
    assert (ref.values + ref.error <= ev.upper_values).all()
    assert (ev.upper_values - ev.lower_values <= 2 * ev.error_bound + 4 * EPS * scale).all()


def test_outward_bracket_rounds_outward_in_exact_arithmetic():
    rng = np.random.default_rng(0)
    v = rng.standard_normal(500) * 10.0 ** rng.integers(-5, 5, 500)
    for e in (0.1, 1e-7, 3.3e-12):
        lo, hi = outward_bracket(v, e)
        fe = Fraction(e)
        assert all(Fraction(a) <= Fraction(x) - fe for a, x in zip(lo, v, strict=True))
        assert all(Fraction(b) >= Fraction(x) + fe for b, x in zip(hi, v, strict=True))
    lo, hi = outward_bracket(v, float("inf"))
    assert (lo == -np.inf).all() and (hi == np.inf).all()


def test_lp_without_bracket_has_nan_bounds_in_the_table(results):
    r = results["rlp"]
    bare = LPResult(**{**r.__dict__, "lower_values": None, "upper_values": None})
    df = bare.to_pandas()
    assert df["lower"].isna().all() and df["upper"].isna().all()
    assert "bracket width: max(upper - lower) = none" in bare.summary()
