"""A solver's word is not a status: "infeasible" and "unbounded" against the LP's structure,
and the power-of-two scaling that keeps the solvers near unit scale.

Every Bellman-row LP is feasible and bounded by construction (a constant vector is
feasible, every feasible point dominates the least one), so a solver's "infeasible" or
"unbounded" there is a solver failure (SOLVER_ERROR, or a certified point's own status),
never a status of the LP. The reference values are computed here by dense policy iteration
in plain numpy (no lpbounds code), and the cases are those of the issue: Clarabel's false
"infeasible" at rewards x1e10, its "unbounded" at discount 0.9999 and rewards x1e6,
HiGHS failing inside cvxpy on rewards above its infinity (1e20).
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

import lpbounds as lb
from lpbounds.formulations import ALP, ELP, RLP, installed_lp_solvers
from lpbounds.formulations import base as base_mod
from lpbounds.formulations.highs import HighsRun
from lpbounds.status import Status

HAVE_CLARABEL = "CLARABEL" in installed_lp_solvers()
needs_clarabel = pytest.mark.skipif(not HAVE_CLARABEL, reason="Clarabel not installed")


# ---------------------------------------------------------------- independent V*
def _dense(mdp: lb.FiniteMDP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(P, R, allowed)``: P of shape (n, A, n) from the raw successor arrays."""
    succ = np.asarray(mdp.successors)
    n, n_act, n_out = succ.shape
    probs = np.broadcast_to(np.asarray(mdp.probabilities, dtype=np.float64), succ.shape)
    p = np.zeros((n, n_act, n))
    x, u, _ = np.meshgrid(np.arange(n), np.arange(n_act), np.arange(n_out), indexing="ij")
    np.add.at(p, (x, u, succ), probs)
    return p, np.asarray(mdp.rewards, dtype=np.float64), np.asarray(mdp.allowed)


def policy_iteration(mdp: lb.FiniteMDP) -> np.ndarray:
    """V* by dense policy iteration: ``(I - lambda P_pi) V = R_pi``, greedy improvement."""
    p, r, allowed = _dense(mdp)
    lam = float(mdp.discount)
    n = r.shape[0]
    idx = np.arange(n)
    pol = np.argmax(np.where(allowed, r, -np.inf), axis=1)
    for _ in range(200):
        v = np.linalg.solve(np.eye(n) - lam * p[idx, pol], r[idx, pol])
        q = np.where(allowed, r + lam * p @ v, -np.inf)
        best = q.max(axis=1)
        # keep the current action unless another is better beyond round-off
        keep = q[idx, pol] >= best - 1e-13 * np.abs(best).max()
        new = np.where(keep, pol, np.argmax(q, axis=1))
        if (new == pol).all():
            return v
        pol = new
    raise AssertionError("policy iteration did not converge")


def scaled(mdp: lb.FiniteMDP, factor: float) -> lb.FiniteMDP:
    """The same MDP with every reward times ``factor``."""
    return lb.FiniteMDP(
        mdp.successors, mdp.probabilities, mdp.rewards * factor, mdp.discount, mdp.allowed
    )


def assert_certified(res, vref: np.ndarray, mdp: lb.FiniteMDP, width_rtol: float) -> None:
    """The bracket contains the reference and is narrow relative to max|R| / (1 - lambda)."""
    scale = float(np.abs(mdp.rewards).max()) / (1.0 - mdp.discount)
    slack = 1e-12 * scale  # the dense solve's own rounding
    assert (res.lower_values <= vref + slack).all(), "the lower bound is above V*"
    assert (res.upper_values >= vref - slack).all(), "the upper bound is below V*"
    width = float((res.upper_values - res.lower_values).max())
    assert width <= width_rtol * scale, f"bracket width {width:.3e} vs scale {scale:.3e}"


# ---------------------------------------------------------------- (a) false "infeasible"
@needs_clarabel
def test_clarabel_false_infeasible_at_rewards_1e10():
    mdp = scaled(lb.garnet(5, 2, 2, 0.9, seed=1), 1e10)
    # what Clarabel itself says on the LP as written (cvxpy alone, no lpbounds judgement)
    raw = ELP(mdp)
    raw.problem.solve(solver="CLARABEL")
    assert raw.problem.status == cp.INFEASIBLE
    # lpbounds with scaling off: the claim is recorded, the status is not INFEASIBLE
    off = ELP(mdp)
    off._scaling = False
    res_off = off.solve("CLARABEL", raise_on_failure=False)
    assert res_off.status is Status.SOLVER_ERROR
    assert res_off.extra["solver_claim"] == "infeasible"
    assert "impossible" in res_off.extra["message"]
    # scaled: Clarabel solves it, and the certified bracket holds V* tightly
    res = ELP(mdp).solve("CLARABEL", raise_on_failure=False)
    assert res.status is Status.OPTIMAL, res.extra
    assert res.extra["lp_scaling"]["b"] > 0
    assert_certified(res, policy_iteration(mdp), mdp, width_rtol=2e-6)


# ---------------------------------------------------------------- (b) false "unbounded"
@needs_clarabel
def test_clarabel_false_unbounded_at_discount_09999():
    mdp = scaled(lb.garnet(5, 2, 2, 0.9999, seed=6, reward_range=(-1.0, 1.0)), 1e6)
    raw = ELP(mdp)
    raw.problem.solve(solver="CLARABEL")
    assert raw.problem.status == cp.UNBOUNDED
    off = ELP(mdp)
    off._scaling = False
    res_off = off.solve("CLARABEL", raise_on_failure=False)
    assert res_off.status is Status.SOLVER_ERROR
    assert res_off.extra["solver_claim"] == "unbounded"
    assert "bounded" in res_off.extra["message"]
    res = ELP(mdp).solve("CLARABEL", raise_on_failure=False)
    assert res.status is not Status.UNBOUNDED and res.status.has_point
    assert_certified(res, policy_iteration(mdp), mdp, width_rtol=1e-4)


# ---------------------------------------------------------------- (c) above HiGHS' infinity
@pytest.mark.parametrize("backend", ["cvxpy", "highspy"])
def test_rewards_above_highs_infinity(backend):
    mdp = scaled(lb.garnet(6, 2, 2, 0.9, seed=3, reward_range=(0.5, 1.0)), 1e21)
    res = ELP(mdp).solve("HIGHS", backend=backend, raise_on_failure=False)
    assert res.status is Status.OPTIMAL, res.extra
    assert_certified(res, policy_iteration(mdp), mdp, width_rtol=1e-9)


def test_cost_1e300_is_solved():
    """cvxpy's "Cannot unpack invalid solution" on a cost of 1e300: the cost is scaled."""
    mdp = lb.garnet(6, 2, 2, 0.9, seed=3)
    res = ELP(mdp, cost=np.full(6, 1e300)).solve("HIGHS", raise_on_failure=False)
    assert res.status is Status.OPTIMAL, res.extra
    assert_certified(res, policy_iteration(mdp), mdp, width_rtol=1e-9)


def test_unrepresentable_objective_is_a_validation_error():
    mdp = scaled(lb.garnet(6, 2, 2, 0.9, seed=3), 1e200)
    with pytest.raises(lb.ValidationError, match="cost"):
        ELP(mdp, cost=np.full(6, 1e200)).solve("HIGHS", raise_on_failure=False)


# ---------------------------------------------------------------- (d) monkeypatched claims
def _claiming(claim: str):
    """A stand-in for ``cvxpy.Problem.solve`` that says ``claim`` and returns no point."""

    def solve(self, *args, **kwargs):
        if claim == "raise":
            raise RuntimeError("the solver crashed")
        for var in self.variables():
            var.value = None
        self._status = claim
        return np.inf if claim == cp.INFEASIBLE else -np.inf

    return solve


@pytest.mark.parametrize("claim", [cp.INFEASIBLE, cp.UNBOUNDED, cp.INFEASIBLE_INACCURATE])
def test_a_false_claim_through_cvxpy_is_a_solver_error(monkeypatch, claim):
    form = ELP(lb.garnet(8, 2, 2, 0.9, seed=0))
    monkeypatch.setattr(cp.Problem, "solve", _claiming(claim))
    res = form.solve("HIGHS", raise_on_failure=False)
    assert res.status is Status.SOLVER_ERROR
    word = "unbounded" if claim == cp.UNBOUNDED else "infeasible"
    assert res.extra["solver_claim"] == word
    assert word in res.extra["message"] and "impossible" in res.extra["message"]
    with pytest.raises(lb.SolverError, match="impossible"):
        form.solve("HIGHS")


def test_a_raising_solver_is_a_solver_error(monkeypatch):
    form = RLP(lb.garnet(8, 2, 2, 0.9, seed=0), lb.random_partition(8, 3, seed=1))
    monkeypatch.setattr(cp.Problem, "solve", _claiming("raise"))
    res = form.solve("HIGHS", raise_on_failure=False)
    assert res.status is Status.SOLVER_ERROR
    assert "RuntimeError" in res.extra["message"] and "crashed" in res.extra["message"]


def test_highspy_claims_and_crashes(monkeypatch):
    mdp = lb.garnet(8, 2, 2, 0.9, seed=0)
    form = ELP(mdp)
    vref = policy_iteration(mdp)
    n_rows = form.A.shape[0]
    # "infeasible" with no point: a solver error
    monkeypatch.setattr(
        base_mod, "run_highs",
        lambda h: HighsRun(Status.INFEASIBLE, "kInfeasible", None, None, 3, 0.0),
    )  # fmt: skip
    res = form.solve("HIGHS", backend="highspy", raise_on_failure=False)
    assert res.status is Status.SOLVER_ERROR and res.extra["solver_claim"] == "infeasible"
    # "unbounded" with the exact optimum as its point: the certificate decides (OPTIMAL)
    monkeypatch.setattr(
        base_mod, "run_highs",
        lambda h: HighsRun(Status.UNBOUNDED, "kUnbounded", vref.copy(), np.zeros(n_rows), 3, 0.0),
    )  # fmt: skip
    res = form.solve("HIGHS", backend="highspy", raise_on_failure=False)
    assert res.status is Status.OPTIMAL and res.extra["solver_claim"] == "unbounded"
    # "infeasible" with a point 1 % off: its certified bracket, INACCURATE
    monkeypatch.setattr(
        base_mod, "run_highs",
        lambda h: HighsRun(Status.INFEASIBLE, "kInfeasible", 0.99 * vref, None, 3, 0.0),
    )  # fmt: skip
    res = form.solve("HIGHS", backend="highspy", raise_on_failure=False)
    assert res.status is Status.INACCURATE
    assert (res.lower_values <= vref + 1e-9).all() and (res.upper_values >= vref - 1e-9).all()

    def crash(h):
        raise RuntimeError("highspy crashed")

    monkeypatch.setattr(base_mod, "run_highs", crash)
    res = form.solve("HIGHS", backend="highspy", raise_on_failure=False)
    assert res.status is Status.SOLVER_ERROR and "crashed" in res.extra["message"]


def test_true_claims_pass_through(monkeypatch):
    """Where the LP need not be feasible (ALP with a basis lacking a Bellman-feasible
    direction, a modified problem), "infeasible" stays; "unbounded" never can (ALP is
    bounded by construction: every feasible Phi r dominates V*)."""
    mdp = lb.garnet(4, 1, 1, 0.9, seed=0, reward_range=(1.0, 2.0))
    phi = np.array([[1.0], [-1.0], [0.0], [0.0]])
    alp = ALP(mdp, phi)
    assert alp.bounded_by_construction and not alp.feasible_by_construction
    assert alp.solve(raise_on_failure=False).status is Status.INFEASIBLE
    soft = ALP(mdp, lb.formulations.soft_aggregation_basis(4, 2, seed=0))
    assert soft.feasible_by_construction
    monkeypatch.setattr(cp.Problem, "solve", _claiming(cp.UNBOUNDED))
    res = alp.solve(raise_on_failure=False)
    assert res.status is Status.SOLVER_ERROR and res.extra["solver_claim"] == "unbounded"


def test_compare_and_verify_count_a_false_claim_as_a_failure(monkeypatch):
    from lpbounds import verify
    from lpbounds.studies.compare import run_study

    monkeypatch.setattr(cp.Problem, "solve", _claiming(cp.INFEASIBLE))
    study = run_study(["garnet:30:4:2"], ["RLP"], ["CLARABEL"], jobs=1)
    row = study.frame.iloc[0]
    assert row["status"] == Status.SOLVER_ERROR.value and not row["accurate"]
    assert "impossible" in row["note"], row["note"]
    assert study.solver_summary().iloc[0]["failed"] == 1
    form = RLP(lb.garnet(8, 2, 2, 0.9, seed=0), lb.random_partition(8, 3, seed=1))
    res, msg = verify.try_solve(form, "HIGHS")
    assert res is None and "solver_error" in msg and "impossible" in msg


# ---------------------------------------------------------------- (e) ordinary models untouched
@pytest.mark.parametrize("solver", ["HIGHS", *(["CLARABEL"] if HAVE_CLARABEL else [])])
def test_ordinary_scale_is_bit_identical(solver):
    from lpbounds.tolerances import LP_DATA_BAND

    mdp = lb.garnet(30, 3, 3, 0.95, seed=4, reward_range=(-2.0, 50.0))
    assert LP_DATA_BAND[0] <= np.abs(mdp.rewards).max() <= LP_DATA_BAND[1]
    on = ELP(mdp).solve(solver, raise_on_failure=False)
    off_form = ELP(mdp)
    off_form._scaling = False
    off = off_form.solve(solver, raise_on_failure=False)
    assert "lp_scaling" not in on.extra
    assert np.array_equal(on.values, off.values) and np.array_equal(on.duals, off.duals)
    assert on.status is off.status


def test_patrol_ublp_is_bit_identical():
    from lpbounds.patrol import PatrolParams
    from lpbounds.patrol.bounds import UBLP
    from lpbounds.tolerances import LP_DATA_BAND

    params = PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4)
    form = UBLP(params)
    assert LP_DATA_BAND[0] <= np.abs(form.b).max() <= LP_DATA_BAND[1]
    on = form.solve(raise_on_failure=False)
    off_form = UBLP(params)
    off_form._scaling = False
    off = off_form.solve(raise_on_failure=False)
    assert "lp_scaling" not in on.extra and np.array_equal(on.values, off.values)
