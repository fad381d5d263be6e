"""Every printed LP bound is a bound, and no looser than its point allows.

V* comes from dense policy iteration in plain numpy (``tests/_independent``: no lpbounds
code), with its own error bound from its Bellman residual. The brackets must hold on random
MDPs with action masks, discounts up to 0.9999, reward scales 1e-6..1e6, random partitions
and costs with zeros, for every installed solver of the battery, whatever status the solver
reported; and each must be as narrow as the returned point's residual (recomputed here)
implies, an OPTIMAL one within its requested accuracy. The regression cases are those of
the hostile-input review (a 202-state queue at 0.99, garnets with rewards of 1e-6).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.formulations import ALP, ELP, IB, RLP, installed_lp_solvers
from lpbounds.formulations.alp import soft_aggregation_basis
from lpbounds.status import Status
from tests import _independent as ind

SOLVERS = [s for s in ("HIGHS", "CLARABEL", "SCS") if s in installed_lp_solvers()]


# ---------------------------------------------------------------- independent V*
def _vstar(succ, probs, rewards, allowed, discount):
    """``(V*, err)`` by dense policy iteration in numpy; ``err`` bounds ``|V - V*|``."""
    ref = ind.policy_iteration(ind.dense_transitions(succ, probs), rewards, allowed, discount)
    return ref.values, ref.error


def _random_mdp(rng, n, n_act, n_out, discount, scale):
    succ = rng.integers(0, n, size=(n, n_act, n_out))
    probs = rng.dirichlet(np.ones(n_out), size=(n, n_act))
    rewards = scale * rng.uniform(-1, 1, size=(n, n_act))
    allowed = rng.random((n, n_act)) < 0.6
    allowed[np.arange(n), rng.integers(0, n_act, size=n)] = True
    return succ, probs, rewards, allowed


def _model(succ, probs, rewards, allowed, discount):
    return lb.FiniteMDP(succ, probs, np.where(allowed, rewards, 0.0), discount, allowed=allowed)


#: A result without a point is accepted only here: first-order and interior-point solvers
#: at discount >= 0.999, where SCS has stopped with a solver error on a 3-state RLP at
#: 0.9999 (measured 2026-12; the LP is feasible and bounded, Fact 1). It must then say so
#: (SOLVER_ERROR) and carry no bracket. INFEASIBLE or UNBOUNDED is never accepted: every
#: LP here is feasible (V* is a feasible point) and bounded (c >= 0, v >= v*).
NO_POINT_ALLOWED = {"CLARABEL", "SCS"}


def _solve(form, solver, discount, what):
    res = form.solve(solver, raise_on_failure=False)
    if res.status.has_point:
        return res
    assert res.status not in (Status.INFEASIBLE, Status.UNBOUNDED), (
        f"{what} {solver}: {res.status} claimed for a feasible, bounded Bellman-row LP"
    )
    assert solver in NO_POINT_ALLOWED and discount >= 0.999, f"{what} {solver}: {res.status}"
    assert res.status is Status.SOLVER_ERROR and res.lower_values is None, res.status
    assert res.upper_values is None and res.objective_bracket is None
    return None


def _check_brackets(mdp, part, cost, solver, vstar, err):
    """ELP brackets V*, RLP's brackets v* (and lift above V*), IB's block 1 likewise; each
    no wider than its point's residual implies and, when OPTIMAL, within its accuracy."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    R, allowed, lam, labels = mdp.rewards, mdp.allowed, mdp.discount, part.labels
    r_abs = float(np.abs(R[allowed]).max())
    n_out = mdp.n_outcomes
    c = np.ones(mdp.n_states) if cost is None else cost
    cbar = np.bincount(labels, weights=c, minlength=part.n_partitions)
    common = {"discount": lam, "reward_absmax": r_abs, "n_terms": n_out}
    vref = ind.rlp_optimum(P, R, allowed, lam, labels)

    elp = _solve(ELP(mdp, cost), solver, lam, "ELP")
    if elp is not None:
        tv = ind.bellman(P, R, allowed, lam, elp.values)
        status = ind.assert_bracket(
            elp, point=elp.values, t_point=tv, optimum=vstar, optimum_err=err,
            judged="both" if (c > 0).all() else "upper",
            reward_floor=ind.reward_floor(R, allowed), what=f"ELP {solver}", **common,
        )  # fmt: skip
        # the objective bracket is c'[lower, upper] (its lower end perhaps raised by weak
        # duality): no wider than c'(ceil - floor); OPTIMAL: each side within the accuracy
        floor, ceil, _, _ = ind.bracket_limits(elp.values, tv, lam, r_abs, n_out)
        width = float(c @ (ceil - floor))
        if status == "optimal":
            slack = ind.rounding_slack(r_abs, np.r_[elp.values, tv], n_out)
            width = min(width, 2 * float(c.sum()) * (elp.accuracy * r_abs + slack) / (1 - lam))
        limit = width * (1 + ind.REL) + 1e-300
        ind.assert_objective_bracket(elp.objective_bracket, c, vstar, err, limit, "ELP objective")

    judged = "both" if (cbar > 0).all() else "upper"
    floor_rlp = ind.reward_floor(R, allowed, labels)
    rlp = _solve(RLP(mdp, part, cost), solver, lam, "RLP")
    if rlp is not None:
        ind.assert_bracket(
            rlp, point=rlp.values, t_point=ind.rlp_operator(P, R, allowed, lam, labels, rlp.values),
            optimum=vref.values, optimum_err=vref.error, judged=judged, reward_floor=floor_rlp,
            what=f"RLP {solver}", **common,
        )  # fmt: skip
        assert (part.lift(rlp.upper_values) >= vstar - err).all(), "RLP upper bound below V*"

    ib = _solve(IB(mdp, part, 2, cost), solver, lam, "IB")
    if ib is not None:
        ind.assert_bracket(
            ib, point=ib.x, t_point=ind.ib_operator(P, R, allowed, lam, labels, ib.x, 2),
            optimum=np.tile(vref.values, 2), optimum_err=vref.error, judged=judged,
            reward_floor=floor_rlp, what=f"IB {solver}", **common,
        )  # fmt: skip
        assert (part.lift(ib.upper_values) >= vstar - err).all(), "IB upper bound below V*"


@st.composite
def _cases(draw):
    n = draw(st.integers(2, 12))
    n_act = draw(st.integers(1, 3))
    n_out = draw(st.integers(1, 3))
    discount = draw(st.sampled_from([0.0, 0.5, 0.9, 0.99, 0.999, 0.9999]))
    scale = 10.0 ** draw(st.integers(-6, 6))
    seed = draw(st.integers(0, 2**31 - 1))
    m = draw(st.integers(1, n))
    zeros = draw(st.booleans())
    solver = draw(st.sampled_from(SOLVERS))
    return n, n_act, n_out, discount, scale, seed, m, zeros, solver


def _run_case(case):
    n, n_act, n_out, discount, scale, seed, m, zeros, solver = case
    rng = np.random.default_rng(seed)
    succ, probs, rewards, allowed = _random_mdp(rng, n, n_act, n_out, discount, scale)
    mdp = _model(succ, probs, rewards, allowed, discount)
    part = lb.random_partition(n, m, seed=seed % 1000)
    cost = rng.uniform(0, 1, n) * (rng.random(n) < 0.6) if zeros else None
    vstar, err = _vstar(succ, probs, rewards, allowed, discount)
    _check_brackets(mdp, part, cost, solver, vstar, err)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_cases())
def test_brackets_hold_on_random_masked_mdps(case):
    _run_case(case)


@pytest.mark.slow
@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_cases())
def test_brackets_hold_on_random_masked_mdps_many(case):
    _run_case(case)


# ---------------------------------------------------------------- regression cases
def _queue(capacity=201, discount=0.99):
    """A controlled single-server queue: state = customers (0..capacity), action = service
    rate (slow, medium, fast); an arrival with probability 0.3, a departure with the
    service probability; reward = -(holding cost 1 per customer + service cost)."""
    n = capacity + 1
    service = np.array([0.2, 0.4, 0.6])
    cost = np.array([0.0, 2.0, 5.0])
    x = np.arange(n)
    succ = np.empty((n, 3, 3), dtype=np.int64)
    probs = np.empty((n, 3, 3))
    for u, q in enumerate(service):
        succ[:, u, 0] = np.minimum(x + 1, capacity)  # arrival, no departure
        succ[:, u, 1] = np.maximum(x - 1, 0)  # departure, no arrival
        succ[:, u, 2] = x  # both or neither
        probs[:, u] = [0.3 * (1 - q), q * 0.7, 1 - 0.3 * (1 - q) - 0.7 * q]
    rewards = -(x[:, None] + cost[None, :]).astype(float)
    return succ, probs, rewards, np.ones((n, 3), dtype=bool), discount


def _elp_checked(succ, probs, rewards, allowed, lam, solver):
    """ELP solved with ``solver``, its bracket held to both promises; (result, V*, err)."""
    mdp = _model(succ, probs, rewards, allowed, lam)
    vstar, err = _vstar(succ, probs, rewards, allowed, lam)
    res = ELP(mdp).solve(solver, raise_on_failure=False)
    P = ind.dense_transitions(succ, probs)
    ind.assert_bracket(
        res, point=res.values, t_point=ind.bellman(P, rewards, allowed, lam, res.values),
        discount=lam, reward_absmax=float(np.abs(rewards[allowed]).max()),
        n_terms=succ.shape[2], optimum=vstar, optimum_err=err,
        reward_floor=ind.reward_floor(rewards, allowed), what=f"ELP {solver}",
    )  # fmt: skip
    return res, vstar, err


@pytest.mark.parametrize("solver", SOLVERS)
def test_queue_at_discount_099(solver):
    """Every battery solver reaches the default accuracy here (measured: HiGHS 5e-14,
    Clarabel 7e-10, SCS 3e-10 relative residual): OPTIMAL, checked both ways."""
    succ, probs, rewards, allowed, lam = _queue()
    res, vstar, err = _elp_checked(succ, probs, rewards, allowed, lam, solver)
    assert res.status is Status.OPTIMAL, (res.status, res.relative_error)
    scale = np.abs(rewards).max() / (1 - lam)  # OPTIMAL: accuracy relative to max|R|/(1-lam)
    assert np.abs(res.values - vstar).max() <= res.accuracy * scale * (1 + 1e-9) + err


#: The status each battery solver honestly reaches on the 50-state garnet of
#: test_tiny_and_huge_reward_scales (measured 2026-12 with the LP data scaled into
#: tolerances.LP_DATA_BAND before the solver sees it). Every solver reaches the default
#: accuracy at rewards of 1e6 and 1e-6 (HiGHS 1e-13 .. 8e-11 relative, SCS 3e-9 .. 1.5e-8,
#: Clarabel 1e-8) except Clarabel at discount 0.9999 with rewards of 1e-6: it stops at a
#: certified relative error of 3e-3 (its interior-point tolerances against the near-singular
#: I - 0.9999 P), an honest INACCURATE. (Before the scaling every solver was INACCURATE at
#: 1e-6: its absolute tolerances, 1e-7 .. 1e-8, against a requested residual of 1e-12.)
TINY_HUGE_STATUS = {
    (solver, discount, scale): Status.OPTIMAL
    for solver in SOLVERS
    for discount, scale in ((0.9999, 1e-6), (0.9, 1e-6), (0.9, 1e6))
}
TINY_HUGE_STATUS["CLARABEL", 0.9999, 1e-6] = Status.INACCURATE


@pytest.mark.parametrize(("solver", "discount", "scale"), list(TINY_HUGE_STATUS))
def test_tiny_and_huge_reward_scales(solver, discount, scale):
    rng = np.random.default_rng(5)
    succ, probs, rewards, allowed = _random_mdp(rng, 50, 3, 3, discount, scale)
    allowed[:] = True
    res, vstar, err = _elp_checked(succ, probs, rewards, allowed, discount, solver)
    expected = TINY_HUGE_STATUS[solver, discount, scale]
    assert res.status is expected, (res.status, res.relative_error)
    bound = res.accuracy * np.abs(rewards).max() / (1 - discount)
    true_err = np.abs(res.values - vstar).max()
    if expected is Status.OPTIMAL:  # the accuracy promise, checked on every solver
        assert true_err <= bound * (1 + 1e-9) + err
    else:  # INACCURATE on purpose: the certified error really exceeds the request ...
        assert res.relative_error > res.accuracy and res.error_bound > bound
        # ... and the honest bracket is still a bound on V*, finite (checked above) and
        # as narrow as the point's residual allows; the true error is inside it
        assert true_err <= res.error_bound + err


def test_a_point_below_vstar_is_not_optimal():
    """An infeasible point (every value 1 % below V*) is certified INACCURATE-level: its
    upper bound is lifted above V*, never reported as a bound as it stands; and lifted no
    further than the point's residual (recomputed here) requires."""
    succ, probs, rewards, allowed, lam = _queue(capacity=30)
    mdp = _model(succ, probs, rewards, allowed, lam)
    vstar, err = _vstar(succ, probs, rewards, allowed, lam)
    from lpbounds.certification.certificate import certify
    from lpbounds.dp import exact_rows

    point = vstar - 0.01 * np.abs(vstar)
    cert = certify(exact_rows(mdp), point)
    assert not cert.is_accurate(1e-6)
    assert (cert.upper >= vstar - err).all() and (cert.lower <= vstar + err).all()
    tv = ind.bellman(ind.dense_transitions(succ, probs), rewards, allowed, lam, point)
    floor, ceil, d_up, _ = ind.bracket_limits(point, tv, lam, np.abs(rewards).max(), 3)
    assert (cert.upper <= ceil).all() and (cert.lower >= floor).all()
    assert cert.residual_up == pytest.approx(d_up, rel=1e-9)
    assert cert.error_bound <= max((ceil - point).max(), (point - floor).max())


@pytest.mark.parametrize("solver", SOLVERS)
def test_alp_upper_values_bound_vstar(solver):
    """ALP's bracket is on V* per state; only its upper side is judged (the point is not a
    fixed point): OPTIMAL for every solver here, upper side within the accuracy."""
    rng = np.random.default_rng(3)
    succ, probs, rewards, allowed = _random_mdp(rng, 12, 2, 2, 0.95, 1.0)
    mdp = _model(succ, probs, rewards, allowed, 0.95)
    vstar, err = _vstar(succ, probs, rewards, allowed, 0.95)
    res = ALP(mdp, soft_aggregation_basis(12, 3, seed=1)).solve(solver, raise_on_failure=False)
    assert res.status is Status.OPTIMAL, res.status
    P = ind.dense_transitions(succ, probs)
    ind.assert_bracket(
        res, point=res.state_values,
        t_point=ind.bellman(P, mdp.rewards, allowed, 0.95, res.state_values), discount=0.95,
        reward_absmax=float(np.abs(mdp.rewards[allowed]).max()), n_terms=2, optimum=vstar,
        optimum_err=err, judged="upper", check_error_bound=False, what=f"ALP {solver}",
    )  # fmt: skip


def test_a_feasible_but_suboptimal_point_is_inaccurate_not_optimal():
    """A solver claiming OPTIMAL for a feasible point 1e-3 above the optimum (what a
    loosened optimality tolerance gave) is judged INACCURATE: optimality is certified,
    not only feasibility."""
    from lpbounds.formulations.base import _Run

    mdp = lb.garnet(30, 3, 3, 0.9, seed=2)
    succ, probs = mdp.successors, mdp.probabilities_full()
    vstar, err = _vstar(succ, probs, mdp.rewards, mdp.allowed, 0.9)
    form = ELP(mdp)
    P = ind.dense_transitions(succ, probs)
    for shift, expected in ((1e-3, Status.INACCURATE), (0.0, Status.OPTIMAL)):
        point = vstar + shift
        run = _Run("HIGHS", {}, Status.OPTIMAL, "optimal", point, None, 0.0, 0.0, None)
        res = form._judge(run, 1e-6)
        assert res.status is expected
        ind.assert_bracket(
            res, point=point, t_point=ind.bellman(P, mdp.rewards, mdp.allowed, 0.9, point),
            discount=0.9, reward_absmax=float(np.abs(mdp.rewards).max()), n_terms=3,
            optimum=vstar, optimum_err=err, what=f"shift {shift}",
        )  # fmt: skip


def test_with_positive_costs_optimal_means_entrywise_accuracy():
    """A feasible point above the optimum by 5x the requested accuracy at one state (and
    less elsewhere) has an objective within the requested accuracy times sum(c), yet is not
    the LP's optimum: with every cost positive OPTIMAL needs the entrywise certificate.

    The point is ``V* + delta h`` with ``h`` the value of reward 1 at state 0 alone:
    ``h >= lambda P_u h`` for every ``u``, so the point satisfies every Bellman row."""
    from lpbounds.formulations.base import _Run

    mdp = lb.garnet(30, 3, 3, 0.9, seed=2)
    succ, probs, allowed = mdp.successors, mdp.probabilities_full(), mdp.allowed
    vstar, _ = _vstar(succ, probs, mdp.rewards, allowed, 0.9)
    e0 = np.zeros(mdp.rewards.shape)
    e0[0] = 1.0
    h, _ = _vstar(succ, probs, e0, allowed, 0.9)
    r_max = np.abs(mdp.rewards).max()
    delta = 5 * 1e-6 * r_max
    v = vstar + delta * h
    form = ELP(mdp)
    duals = form.solve("HIGHS").duals  # optimal duals: the objective bound is then tight
    run = _Run("HIGHS", {}, Status.OPTIMAL, "optimal", v, duals, 0.0, 0.0, None)
    res = form._judge(run, 1e-6)
    lo, _ = res.objective_bracket
    assert (v.sum() - lo) * (1 - 0.9) <= 1e-6 * r_max * 30, "the objective is within accuracy"
    assert res.certificate.residual_up <= 1e-6 * r_max, "the point is feasible"
    assert res.status is Status.INACCURATE
    # the bracket around this feasible point: as its residual allows, containing V*
    ind.assert_bracket(
        res, point=v, t_point=ind.bellman(ind.dense_transitions(succ, probs), mdp.rewards,
                                          allowed, 0.9, v),
        discount=0.9, reward_absmax=float(r_max), n_terms=3, optimum=vstar,
        optimum_err=ind.policy_iteration(ind.dense_transitions(succ, probs), mdp.rewards,
                                         allowed, 0.9).error,
        what="V* + delta h",
    )  # fmt: skip
