"""Every built-in claim of ``lpbounds verify`` on a planted violation of known size.

A claim is planted false in one of three ways, each with a size known from the plant:

* the LP the claim solves is the LP of the model with every reward lowered by ``delta``
  (its optimum is the true one minus ``S = delta / (1 - lambda)``, exactly for stochastic
  rows): the claim must be *violated* and its ``deviation`` (the distance of the interval
  midpoints) must be ``S`` (``S sum(c)`` for an objective) up to the intervals' widths;
* the exact side (:class:`lpbounds.studies.verify` computes ``V*`` and RLP's ``v*`` once per
  instance) is moved by a constant: the solver-free claims must see it;
* the brackets compared are given directly (across solvers, Remark 2, the comparisons).

The control of each plant, the same call without it, is ``test_normal_run_all_holds`` in
tests/studies/test_verify.py (every record *holds* on the same instance).
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np
import pytest

import lpbounds as lb
import lpbounds.studies.verify as verify
from lpbounds.certification.checks import combine, compare_at_least, compare_equal
from lpbounds.formulations import ELP, IB, LLP, RLP, SLP
from lpbounds.status import Verdict
from lpbounds.studies.claims import BuiltinClaim, Conjecture, run_claims
from tests import _independent as ind

DELTA = 0.05


@pytest.fixture(scope="module")
def inst():
    mdp = lb.garnet(16, 2, 3, 0.9, seed=9, allowed_fraction=0.8)
    return verify.VerifyInstance("tiny", mdp, lb.random_partition(16, 4, seed=2))


@pytest.fixture(scope="module")
def refs(inst):
    """The exact side of the instance as the checks compute it (one cost)."""
    return verify._references(inst, 1, 0, 1e-6)


def lowered(mdp: lb.FiniteMDP, delta: float = DELTA) -> lb.FiniteMDP:
    """The model with every reward lowered by ``delta``."""
    r = np.where(mdp.allowed, mdp.rewards - delta, 0.0)
    return lb.FiniteMDP(mdp.successors, mdp.probabilities, r, mdp.discount, allowed=mdp.allowed)


def wrong(cls):
    """``cls`` built on the lowered model: an LP whose optimum is the true one minus S."""

    def init(self, mdp, *args, **kwargs):
        cls.__init__(self, lowered(mdp), *args, **kwargs)

    return type(f"Wrong{cls.__name__}", (cls,), {"__init__": init})


def record(recs, check, claim, solver="HIGHS"):
    out = [r for r in recs if (r["check"], r["claim"], r["solver"]) == (check, claim, solver)]
    assert len(out) == 1, (check, claim, solver, [(r["check"], r["claim"]) for r in recs])
    return out[0]


def assert_size(rec, expected):
    """``violated``, with ``deviation`` = ``expected`` up to the two intervals' widths at the
    deciding entry (the midpoints may sit anywhere inside them)."""
    assert rec["verdict"] == "violated", rec
    lo, hi = rec["lp_interval"]
    elo, ehi = rec["exact_interval"]
    slack = (hi - lo) + (ehi - elo) + 1e-9 * expected
    assert abs(rec["deviation"] - expected) <= slack, (rec["deviation"], expected, slack)


def shift(inst) -> float:
    return DELTA / (1.0 - inst.mdp.discount)


# ---------------------------------------------------------------------- claims with an LP
def test_lemma1_on_an_elp_of_lowered_rewards(inst, refs, monkeypatch):
    """ELP of the lowered model: ``optimum = exact`` and ``optimal value = c'(exact)`` are
    violated by S and ``S sum(c)``; the RLP claims of Theorem 1 still hold."""
    monkeypatch.setattr(verify, "ELP", wrong(ELP))
    recs = verify.verify_instance(inst, ["HIGHS"], n_costs=1, checks=["Lemma 1", "Theorem 1"])
    assert_size(record(recs, "Lemma 1", "optimum = exact (c > 0)"), shift(inst))
    total = shift(inst) * float(refs.costs[0].sum())
    assert_size(record(recs, "Lemma 1", "optimal value = c'(exact)"), total)
    assert record(recs, "Theorem 1", "optimum = exact (c > 0)")["verdict"] == "holds"


def test_theorem1_on_an_rlp_of_lowered_rewards(inst, refs, monkeypatch):
    """RLP of the lowered model: its optimum, its optimal value and its certified feasible
    point are all below ``v*`` by S (``S sum(c)`` for the value)."""
    monkeypatch.setattr(verify, "RLP", wrong(RLP))
    recs = verify.verify_instance(inst, ["HIGHS"], n_costs=1, checks=["Theorem 1"])
    assert_size(record(recs, "Theorem 1", "optimum = exact (c > 0)"), shift(inst))
    total = shift(inst) * float(refs.costs[0].sum())
    assert_size(record(recs, "Theorem 1", "optimal value = c'(exact)"), total)
    assert_size(record(recs, "Theorem 1", "feasible points >= v*"), shift(inst))


def test_lemma2_on_an_slp_of_lowered_rewards(inst, monkeypatch):
    """SLP(mu-bar) of the lowered model and its reduced MDP: both S below Lemma 2's
    prediction from the true duals."""
    monkeypatch.setattr(verify, "SLP", wrong(SLP))
    recs = verify.verify_instance(inst, ["HIGHS"], n_costs=1, checks=["Lemma 2"])
    assert_size(record(recs, "Lemma 2", "SLP(mu-bar) = v*"), shift(inst))
    assert_size(record(recs, "Lemma 2", "reduced MDP value = v*"), shift(inst))


def test_theorem2_on_ib_and_llp_of_lowered_rewards(inst, monkeypatch):
    """IB and LLP of the lowered model: every IB block S below ``v*`` (the LP and its
    exact fixed point), the certified feasible points too, LLP's ``v`` as well."""
    monkeypatch.setattr(verify, "IB", wrong(IB))
    monkeypatch.setattr(verify, "LLP", wrong(LLP))
    recs = verify.verify_instance(inst, ["HIGHS"], n_costs=1, checks=["Theorem 2"])
    assert_size(record(recs, "Theorem 2", "IB blocks = v*"), shift(inst))
    assert_size(record(recs, "Theorem 2", "IB feasible point >= v*"), shift(inst))
    assert_size(record(recs, "Theorem 2", "LLP v >= v*"), shift(inst))
    exact = record(recs, "Theorem 2", "fixed point of IB = (v*, ..., v*)", "exact")
    assert_size(exact, shift(inst))


def test_builtin_claims_of_a_campaign_carry_the_violation(inst, monkeypatch):
    """The same plant through :func:`lpbounds.studies.claims.run_claims` (how campaigns
    run the built-in claims): the records are verify's, with their sizes."""
    monkeypatch.setattr(verify, "RLP", wrong(RLP))
    recs = run_claims(inst, [BuiltinClaim("Theorem 1")], ["HIGHS"], n_costs=1)
    assert_size(record(recs, "Theorem 1", "optimum = exact (c > 0)"), shift(inst))
    assert all(r["error"] == "" for r in recs)


# ---------------------------------------------------------------------- solver-free claims
def _gap(inst):
    """``min_x (Phi v*)(x) - V*(x)`` and where, by dense policy iteration (no lpbounds)."""
    mdp, part = inst.mdp, inst.partition
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    vstar = ind.policy_iteration(P, mdp.rewards, mdp.allowed, mdp.discount).values
    vrlp = ind.rlp_optimum(P, mdp.rewards, mdp.allowed, mdp.discount, part.labels).values
    gap = vrlp[part.labels] - vstar
    return float(gap.min()), int(np.argmin(gap)), vrlp, P


def test_lemma1_exact_on_v_star_of_rlp_lowered_past_v_star(inst, refs):
    """RLP's ``v*`` lowered by (smallest gap ``Phi v* - V*``) + 1: ``Phi v* >= V*`` fails by
    1 at the state of the smallest gap."""
    g, x, _, _ = _gap(inst)
    planted = dataclasses.replace(refs, v_lo=refs.v_lo - (g + 1), v_hi=refs.v_hi - (g + 1))
    (rec,) = verify._exact_checks(inst, planted, ("Lemma 1",))
    assert rec["claim"] == "Phi v* >= V*" and rec["index"] == x
    assert_size(rec, 1.0)


def test_theorem1_exact_on_v_star_of_rlp_raised(inst, refs):
    """RLP's ``v*`` raised by 1: the certified iterates ``T^k u`` (``u = max R / (1 -
    lambda)``, feasible, decreasing to ``v*``) fall below it from some ``k`` on. The record
    is the most violated iterate's (``combine`` keeps the largest violation), the last one
    (``k = 50``), closest to ``v*``: its size ``max(v* + 1 - T^50 u)`` is the planted 1 less
    what is left of ``T^k u - v*``; the iterates computed here by tests/_independent's
    operator."""
    _, _, vrlp, P = _gap(inst)
    mdp, lab = inst.mdp, inst.partition.labels
    u = np.full(vrlp.size, float(mdp.rewards[mdp.allowed].max()) / (1.0 - mdp.discount))
    for _ in range(50):
        u = ind.rlp_operator(P, mdp.rewards, mdp.allowed, mdp.discount, lab, u)
    planted = dataclasses.replace(refs, v_lo=refs.v_lo + 1.0, v_hi=refs.v_hi + 1.0)
    (rec,) = verify._exact_checks(inst, planted, ("Theorem 1",))
    assert rec["claim"] == "feasible points >= v*"
    size = float((vrlp + 1.0 - u).max())
    assert 0.99 < size <= 1.0  # the planted shift, up to 0.9^50 of the start's gap
    assert_size(rec, size)


def test_theorem2_exact_on_v_star_of_rlp_raised(inst, refs):
    """RLP's ``v*`` raised by 0.25: IB's exact fixed point ``(v*, ..., v*)`` is 0.25 from it."""
    planted = dataclasses.replace(refs, v_lo=refs.v_lo + 0.25, v_hi=refs.v_hi + 0.25)
    (rec,) = verify._exact_checks(inst, planted, ("Theorem 2",))
    assert_size(rec, 0.25)


def test_rlp_optima_agree_on_a_bracket_moved_by_a_half(inst, refs):
    """Two solvers' RLP brackets, one moved up by 0.5: they disagree by 0.5."""
    form = RLP(inst.mdp, inst.partition, refs.costs[0])
    res = form.solve("HIGHS")
    moved = dataclasses.replace(
        res,
        certificate=None,
        lower_values=res.lower_values + 0.5,
        upper_values=res.upper_values + 0.5,
    )
    (rec,) = verify._across_solvers("tiny", {"A": (form, res), "B": (form, moved)}, 1e-6)
    assert (rec["check"], rec["claim"], rec["solver"]) == ("Theorem 1", "RLP optima agree", "all")
    assert_size(rec, 0.5)
    (same,) = verify._across_solvers("tiny", {"A": (form, res), "B": (form, res)}, 1e-6)
    assert same["verdict"] == "holds" and same["deviation"] == 0.0


def test_remark2_verdict_is_the_certified_difference():
    """Remark 2 from given exact brackets: ``lo(OPT(c1 + c2)) - hi(OPT(c1)) - hi(OPT(c2))``
    is the deviation; positive is *holds*, otherwise *inconclusive* (never violated)."""
    b1, b2 = (Fraction(1), Fraction(2)), (Fraction(3), Fraction(4))
    tally = verify.Tally()
    rec = verify._remark2_record("i", "S", [b1, b2, (Fraction(13, 2), Fraction(7))], "", tally)
    assert (rec["verdict"], rec["deviation"], rec["width"]) == ("holds", 0.5, 1.0)
    rec = verify._remark2_record("i", "S", [b1, b2, (Fraction(23, 4), Fraction(7))], "", tally)
    assert (rec["verdict"], rec["deviation"]) == ("inconclusive", -0.25)
    rec = verify._remark2_record("i", "S", [b1, b2, (None, Fraction(7))], "no duals", tally)
    assert (rec["verdict"], rec["deviation"], rec["detail"]) == (
        "inconclusive",
        -np.inf,
        "no duals",
    )


# ---------------------------------------------------------------------- the comparisons
def test_comparisons_report_the_planted_sizes():
    """``a >= b`` with ``b`` above ``a`` by 1.5 at entry 1 (intervals of width 0.1): violated
    there, deviation 1.5, width 0.1; ``a = b`` off by 0.25 at entry 0: violated, deviation
    0.25; :func:`combine` keeps the violated one of several."""
    a_lo, a_hi = np.array([1.0, 0.0]), np.array([1.1, 0.1])
    up = np.array([-0.5, 1.5])
    ge = compare_at_least(a_lo, a_hi, a_lo + up, a_hi + up, 0.0)
    assert (ge.verdict, ge.index) == (Verdict.VIOLATED, 1)
    assert ge.deviation == pytest.approx(1.5) and ge.width == pytest.approx(0.1)
    eq = compare_equal(a_lo, a_hi, a_lo + np.array([0.25, 0.0]), a_hi + np.array([0.25, 0.0]), 1.0)
    assert (eq.verdict, eq.index) == (Verdict.VIOLATED, 0)
    assert eq.deviation == pytest.approx(0.25) and eq.width == pytest.approx(0.35)
    ok = compare_equal(a_lo, a_hi, a_lo, a_hi, 1.0)
    assert ok.verdict is Verdict.HOLDS and ok.deviation == 0.0
    assert combine([ok, eq, ok]) is eq


def test_a_conjecture_reports_the_planted_size(inst):
    """A conjecture comparing ``V*`` with ``V* + 1`` through :class:`Trial`: violated by 1."""

    def above_itself(trial):
        lo, hi = trial.vstar()
        return trial.at_least((lo, hi), (lo + 1.0, hi + 1.0))

    (rec,) = run_claims(inst, [Conjecture("V* >= V* + 1", above_itself, uses_solver=False)], [])
    assert rec["solver"] == "exact" and rec["error"] == ""
    assert_size(rec, 1.0)
