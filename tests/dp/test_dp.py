"""Exact DP against closed forms, a direct linear solve, and plain-numpy references.

Every result's certificate is held to its promise both ways (``tests/_independent``, numpy
only): the true error against an independent ``V*`` is within ``error_bound``, AND
``error_bound`` is no larger than the residual of the returned vector (recomputed there)
implies, ``(residual + rounding) / (1 - lambda)``; an OPTIMAL result's bound is within
``(tol + rounding) / (1 - lambda)``. So neither a wrong bound nor an inflated one passes.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypothesis import given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.dp import exact_rows
from lpbounds.errors import ConvergenceError, ValidationError
from lpbounds.tolerances import DP_NOISE_ULPS
from tests import _independent as ind
from tests.conftest import reference_bellman, reference_solve, two_state_closed_form, two_state_mdp

EPS = float(np.finfo(np.float64).eps)

METHODS = ["mpi", "vi", "pi"]


def dense(mdp):
    """``(P, R, allowed, discount)`` of ``mdp`` as the arrays of tests/_independent."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    return P, mdp.rewards, mdp.allowed, mdp.discount


def check_dp(res, mdp, reference=None, reference_err=None, what=""):
    """``res`` (a DPResult of ``mdp``) both ways, against V* by dense policy iteration
    unless a reference is given (tests/_independent.assert_dp_certificate)."""
    tv = ind.successor_bellman(mdp.successors, mdp.probabilities_full(), mdp.rewards,
                               mdp.allowed, mdp.discount, res.values)  # fmt: skip
    if reference is None:
        ref = ind.policy_iteration(*dense(mdp))
        reference, reference_err = ref.values, ref.error
    ind.assert_dp_certificate(
        res, tv, mdp.discount, reference=reference, reference_err=reference_err or 0.0, what=what
    )


def direct_policy_value(mdp, policy):
    """V_pi by a sparse LU of (I - lam P_pi) V = R_pi built from to_matrices()."""
    P, R = mdp.to_matrices(disallowed_reward=-1e9)
    n = mdp.n_states
    rows = sp.vstack([P[policy[x]][x] for x in range(n)]).tocsc()
    a = sp.identity(n, format="csc") - mdp.discount * rows
    return spla.spsolve(a, R[np.arange(n), policy])


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("discount", [0.0, 0.5, 0.9, 0.99])
def test_two_state_closed_form(method, discount):
    res = lb.solve_exact(two_state_mdp(discount), method)
    want = two_state_closed_form(discount)
    np.testing.assert_allclose(res.values, want, rtol=1e-9, err_msg=f"{method} lam={discount}")
    assert res.residual <= res.tol
    # the closed form is exact up to one rounding: its own error a few ulps
    check_dp(res, two_state_mdp(discount), want, 4 * np.finfo(float).eps * want.max(), method)
    # at lam = 0.5 staying (1/(1-lam) = 2) beats moving (lam * 4 = 2)? a tie: lowest action
    expected_action = 0 if 1.0 / (1 - discount) >= discount * 2 / (1 - discount) else 1
    assert res.policy[0] == expected_action


def test_two_state_chain_with_probabilities():
    # state 0: reward r, to 1 w.p. p else stay; state 1: absorbing with reward s
    lam, p, r, s = 0.8, 0.3, 1.0, 5.0
    succ = np.array([[[1, 0]], [[1, 1]]])
    probs = np.array([[[p, 1 - p]], [[0.5, 0.5]]])
    mdp = lb.FiniteMDP(succ, probs, np.array([[r], [s]]), lam)
    v1 = s / (1 - lam)
    v0 = (r + lam * p * v1) / (1 - lam * (1 - p))
    for m in METHODS:
        res = lb.solve_exact(mdp, m)
        err = np.abs(res.values - [v0, v1]).max()
        assert err <= res.error_bound, (m, err, res.error_bound)
        check_dp(res, mdp, np.array([v0, v1]), 1e-14 * v1, m)
        tight = lb.solve_exact(mdp, m, tol=1e-13)
        np.testing.assert_allclose(tight.values, [v0, v1], rtol=1e-12)
        check_dp(tight, mdp, np.array([v0, v1]), 1e-14 * v1, m)


@pytest.mark.parametrize("seed", range(4))
def test_methods_agree_with_direct_solve(seed):
    mdp = lb.garnet(80, 3, 4, 0.95, seed=seed, allowed_fraction=0.7)
    results = {m: lb.solve_exact(mdp, m) for m in METHODS}
    ref = reference_solve(mdp)
    indep = ind.policy_iteration(*dense(mdp))
    for m, res in results.items():
        assert res.converged
        assert np.abs(res.values - ref).max() <= res.error_bound + 1e-10, m
        check_dp(res, mdp, indep.values, indep.error, m)
        # the reported residual is the true residual of the returned vector
        q = reference_bellman(mdp, res.values)
        assert np.abs(q.max(axis=1) - res.values).max() == pytest.approx(res.residual, abs=1e-12)
        # the greedy policy's value, by an independent direct solve, is V* (unique optimum)
        v_pi = direct_policy_value(mdp, res.policy)
        np.testing.assert_allclose(v_pi, ref, atol=1e-8)


@pytest.mark.parametrize("method", ["vi", "mpi"])
def test_error_bound_bounds_the_error(method):
    mdp = lb.garnet(60, 2, 3, 0.9, seed=11)
    exact = reference_solve(mdp)
    for tol in (1e-1, 1e-3, 1e-6):
        res = lb.solve_exact(mdp, method, tol=tol, extrapolate=False)
        err = np.abs(res.values - exact).max()
        assert res.residual <= tol
        assert err <= res.error_bound * (1 + 1e-12), (tol, err, res.error_bound)
        check_dp(res, mdp, what=f"{method} tol={tol}")  # and no looser than the residual
        # and the lambda/(1-lambda) bound holds for one more application of T
        tv = reference_bellman(mdp, res.values).max(axis=1)
        assert np.abs(tv - exact).max() <= 0.9 / 0.1 * res.residual * (1 + 1e-12)


def test_extrapolation_reduces_sweeps_not_accuracy():
    mdp = lb.garnet(200, 3, 5, 0.99, seed=3)
    plain = lb.solve_exact(mdp, "vi", extrapolate=False)
    fast = lb.solve_exact(mdp, "vi")
    assert fast.sweeps < plain.sweeps / 5
    exact = reference_solve(mdp)
    assert np.abs(fast.values - exact).max() <= fast.error_bound
    check_dp(fast, mdp, what="vi extrapolated")
    check_dp(plain, mdp, what="vi plain")


def test_convergence_error_names_the_residual():
    mdp = lb.garnet(30, 2, 2, 0.99, seed=1)
    with pytest.raises(ConvergenceError, match="residual"):
        lb.solve_exact(mdp, "vi", max_iter=2, extrapolate=False)
    res = lb.solve_exact(mdp, "vi", max_iter=2, extrapolate=False, raise_on_failure=False)
    assert not res.converged and res.residual > res.tol
    check_dp(res, mdp, what="stopped at max_iter")  # wide, but exactly as its residual says


def test_bad_arguments():
    mdp = two_state_mdp()
    with pytest.raises(ValidationError, match="unknown method"):
        lb.solve_exact(mdp, "newton")
    with pytest.raises(ValidationError, match="tol"):
        lb.solve_exact(mdp, tol=-1.0)
    with pytest.raises(ValidationError, match="not allowed in state 1"):
        lb.evaluate_policy(mdp, np.array([0, 1]))
    with pytest.raises(ValidationError, match="not an action index"):
        lb.evaluate_policy(mdp, np.array([0, 5]))
    with pytest.raises(ValidationError, match="expected a vector of length 2"):
        lb.greedy_policy(mdp, np.zeros(3))


@pytest.mark.parametrize("method", ["direct", "iterative"])
def test_policy_evaluation(method):
    mdp = lb.garnet(70, 3, 3, 0.9, seed=9)
    pol = np.random.default_rng(0).integers(0, 3, 70)
    ev = lb.evaluate_policy(mdp, pol, method=method)
    want = direct_policy_value(mdp, pol)
    assert np.abs(ev.values - want).max() <= ev.error_bound + 1e-12
    assert ev.residual <= 1e-10 * mdp.reward_absmax / 0.1 + 1e-15
    # both ways against V_pi by a dense solve (tests/_independent), at the default tol
    ref = ind.policy_value(dense(mdp)[0], mdp.rewards, pol, 0.9)
    t_pi = ind.policy_operator(mdp.successors, mdp.probabilities_full(), mdp.rewards, pol,
                               0.9, ev.values)  # fmt: skip
    ind.assert_dp_certificate(ev, t_pi, 0.9, reference=ref.values, reference_err=ref.error,
                              tol=1e-10 * mdp.reward_absmax / 0.1, what=method)  # fmt: skip


def test_greedy_tie_rule_lowest_action():
    # two identical actions everywhere: every Q-value ties, the lowest index wins
    succ = np.array([[[1], [1], [0]], [[0], [0], [1]]])
    rewards = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 1.0]])
    mdp = lb.FiniteMDP(succ, [1.0], rewards, 0.5)
    v = lb.solve_exact(mdp).values
    np.testing.assert_array_equal(lb.greedy_policy(mdp, v), [0, 0])
    # a difference below the documented tie tolerance still counts as a tie
    eps = 0.1 * lb.tolerances.GREEDY_TIE_RTOL
    mdp2 = lb.FiniteMDP(succ, [1.0], rewards + np.array([[0, eps, 0], [0, 0, 0]]), 0.5)
    assert lb.greedy_policy(mdp2, v)[0] == 0
    mdp3 = lb.FiniteMDP(succ, [1.0], rewards + np.array([[0, 1e-6, 0], [0, 0, 0]]), 0.5)
    assert lb.greedy_policy(mdp3, v)[0] == 1


def test_porteus_bounds_sandwich():
    mdp = lb.garnet(60, 3, 3, 0.9, seed=12)
    exact = reference_solve(mdp)
    v = exact + np.random.default_rng(3).normal(scale=0.5, size=60)
    pb = lb.porteus_bounds(mdp, v)
    v_pi = direct_policy_value(mdp, pb.policy)
    tol = 1e-9
    assert np.all(pb.lower_paper <= pb.lower + tol)
    assert np.all(pb.lower <= v_pi + tol)
    assert np.all(v_pi <= exact + tol)
    assert np.all(exact <= pb.upper + tol)
    check_porteus(mdp, v, pb)


def check_porteus(mdp, v, pb):
    """The Porteus bounds both ways, from an independent dense V* and V_pi and the formulas
    recomputed here: ``lower = T_pi V + lambda/(1-lambda) min(T_pi V - V) <= V_pi <= V* <=
    upper = T V + lambda/(1-lambda) max(T V - V)``, and no wider than those formulas up to
    rounding (a bracket of +-inf, or a doubled tail, fails)."""
    P, R, allowed, lam = dense(mdp)
    vstar = ind.policy_iteration(P, R, allowed, lam)
    vpi = ind.policy_value(P, R, pb.policy, lam)
    assert np.isfinite(pb.lower).all() and np.isfinite(pb.upper).all()
    assert (pb.lower <= vpi.values + vpi.error).all(), "Porteus lower bound above V_pi"
    assert (vpi.values <= vstar.values + vstar.error + vpi.error).all()
    assert (vstar.values - vstar.error <= pb.upper).all(), "Porteus upper bound below V*"
    tv = ind.bellman(P, R, allowed, lam, v)
    tpi = ind.policy_operator(mdp.successors, mdp.probabilities_full(), R, pb.policy, lam, v)
    k = lam / (1 - lam)
    slack = ind.rounding_slack(R, np.r_[v, tv], mdp.n_outcomes) / (1 - lam)
    assert (pb.upper <= tv + k * (tv - v).max() + slack).all(), "upper wider than Porteus"
    assert (pb.lower >= tpi + k * (tpi - v).min() - slack).all(), "lower wider than Porteus"
    paper = v + (tpi - v).min() / (1 - lam)
    assert (pb.lower_paper >= paper - slack).all() and (pb.lower_paper <= paper + slack).all()
    # the width is what the span of T V - V makes it: tight
    width = float((pb.upper - pb.lower).max())
    span = float((tv - v).max() - (tpi - v).min())
    assert width <= float((tv - tpi).max()) + k * span + 2 * slack


def test_porteus_bounds_at_vstar_are_tight():
    """At (an accurate) V* the bounds close to the rounding allowance around V*."""
    mdp = lb.garnet(60, 3, 3, 0.9, seed=12)
    ref = ind.policy_iteration(*dense(mdp))
    pb = lb.porteus_bounds(mdp, ref.values)
    check_porteus(mdp, ref.values, pb)
    assert float((pb.upper - pb.lower).max()) <= 2 * ref.error


def test_solve_on_rows_equals_aggregated_fixed_point_definition(small_mdp, small_partition):
    rows = lb.BellmanRows.aggregate(small_mdp, small_partition)
    fp = lb.solve_exact(rows)
    tv, _ = rows.apply_max(fp.values)
    assert np.abs(tv - fp.values).max() == pytest.approx(fp.residual, abs=1e-13)
    # an upper bound on V* (Lemma 3 / Theorem 1)
    assert np.all(small_partition.lift(fp.values) >= reference_solve(small_mdp) - fp.error_bound)
    # the certificate both ways against RLP's v* by dense policy iteration over its rows
    P, R, allowed, lam = dense(small_mdp)
    labels = small_partition.labels
    ref = ind.rlp_optimum(P, R, allowed, lam, labels)
    t = ind.rlp_operator(P, R, allowed, lam, labels, fp.values)
    ind.assert_dp_certificate(fp, t, lam, reference=ref.values, reference_err=ref.error)


def test_game_value_is_below_min_vstar(small_mdp, small_partition):
    rows = lb.BellmanRows.aggregate(small_mdp, small_partition, reduce="min")
    g = lb.solve_game(rows)
    gw, _ = rows.apply_maxmin(g.values)
    assert np.abs(gw - g.values).max() <= g.tol
    vmin = small_partition.aggregate(reference_solve(small_mdp), "min")
    assert np.all(g.values <= vmin + g.error_bound)
    # the certificate both ways against w* by strategy iteration (tests/_independent)
    P, R, allowed, lam = dense(small_mdp)
    labels = small_partition.labels
    ref = ind.nlp_optimum(P, R, allowed, lam, labels)
    t = ind.nlp_operator(P, R, allowed, lam, labels, g.values)
    ind.assert_dp_certificate(g, t, lam, reference=ref.values, reference_err=ref.error)


@settings(max_examples=20, deadline=None)
@given(
    n=st.integers(1, 30),
    a=st.integers(1, 3),
    ll=st.integers(1, 4),
    lam=st.sampled_from([0.0, 0.3, 0.9, 0.97]),
    seed=st.integers(0, 10_000),
)
def test_property_all_methods_agree(n, a, ll, lam, seed):
    mdp = lb.garnet(n, a, ll, lam, seed=seed, allowed_fraction=0.75)
    ref = reference_solve(mdp)
    indep = ind.policy_iteration(*dense(mdp))
    for m in METHODS:
        res = lb.solve_exact(mdp, m)
        assert np.abs(res.values - ref).max() <= res.error_bound + 1e-9 * max(1, abs(ref).max())
        check_dp(res, mdp, indep.values, indep.error, m)


@settings(max_examples=20, deadline=None)
@given(
    n=st.integers(1, 40),
    a=st.integers(1, 4),
    ll=st.integers(1, 4),
    lam=st.sampled_from([0.0, 0.5, 0.9, 0.99]),
    frac=st.sampled_from([1.0, 0.6]),
    seed=st.integers(0, 10_000),
)
def test_property_every_eval_sweeps_is_certified(n, a, ll, lam, frac, seed):
    """MPI with any number of evaluation sweeps, fixed or "auto", stops at the same
    certified residual: each answer is within its error bound of V* from an independent
    direct solve, and its reported residual is the true one of the returned vector."""
    mdp = lb.garnet(n, a, ll, lam, seed=seed, allowed_fraction=frac)
    ref = reference_solve(mdp)
    indep = ind.policy_iteration(*dense(mdp))
    for m in ("auto", 0, 1, 5, 20):
        res = lb.solve_exact(mdp, eval_sweeps=m)
        assert res.converged and res.residual <= res.tol
        assert np.abs(res.values - ref).max() <= res.error_bound + 1e-9 * max(1, abs(ref).max())
        q = reference_bellman(mdp, res.values)
        assert np.abs(q.max(axis=1) - res.values).max() == pytest.approx(res.residual, abs=1e-12)
        check_dp(res, mdp, indep.values, indep.error, f"eval_sweeps={m}")


def test_auto_eval_sweeps_waits_for_a_settled_policy():
    """The "auto" rule: no evaluation sweeps after the first improvement or while more
    than AUTO_SETTLED of the states change their action; AUTO_EVAL_SWEEPS after."""
    from lpbounds.dp import AUTO_EVAL_SWEEPS, AUTO_SETTLED, EvalPlan

    n = 1000
    plan = EvalPlan("auto")
    arg = np.zeros(n, dtype=np.int64)
    assert plan.count(arg) == 0  # the first policy: every state "changed"
    arg[: int(AUTO_SETTLED * n) + 1] = 1
    assert plan.count(arg) == 0  # just above the threshold
    arg[: int(AUTO_SETTLED * n)] = 2
    assert plan.count(arg) == AUTO_EVAL_SWEEPS  # at it
    assert plan.count(arg) == AUTO_EVAL_SWEEPS  # unchanged
    fixed = EvalPlan(3)
    assert fixed.ever and fixed.count(arg) == 3 and fixed.count(arg + 1) == 3
    assert not EvalPlan(0).ever
    # on a model: sweeps = improvements + AUTO_EVAL_SWEEPS x (settled improvements), and
    # the first improvement is followed directly by the second
    mdp = lb.garnet(3000, 3, 4, 0.95, seed=7)
    seen: list[int] = []
    res = lb.solve_exact(mdp, callback=lambda it, r: seen.append(it))
    extra = res.sweeps - (res.iterations + 1)
    assert extra % AUTO_EVAL_SWEEPS == 0 and 0 < extra < AUTO_EVAL_SWEEPS * res.iterations
    assert seen == list(range(res.iterations + 1))
    # 3,000 states: the certificate against V* by value iteration on the successor arrays
    ref = ind.fixed_point(
        lambda v: ind.successor_bellman(mdp.successors, mdp.probabilities_full(),
                                        mdp.rewards, mdp.allowed, 0.95, v),
        res.values, 0.95,
    )  # fmt: skip
    check_dp(res, mdp, ref.values, ref.error, "auto")


# ------------------------------------------------------- statuses, action masks, hostile starts
def test_status_is_the_single_source_of_truth():
    """OPTIMAL when the residual reached tol, ITERATION_LIMIT at max_iter; ``converged``
    is derived from the status (not a second stored flag that could disagree)."""
    import dataclasses

    from lpbounds.status import Status

    mdp = lb.garnet(30, 2, 2, 0.99, seed=1)
    done = lb.solve_exact(mdp, "vi")
    assert done.status is Status.OPTIMAL and done.converged and done.residual <= done.tol
    cut = lb.solve_exact(mdp, "vi", max_iter=2, extrapolate=False, raise_on_failure=False)
    assert cut.status is Status.ITERATION_LIMIT and not cut.converged
    assert cut.residual > cut.tol
    # the bound stays valid at the limit: V* from an independent solve is within it
    assert np.abs(cut.values - reference_solve(mdp)).max() <= cut.error_bound
    check_dp(done, mdp, what="done")
    check_dp(cut, mdp, what="cut")  # valid and exactly as wide as the residual makes it
    assert "converged" not in {f.name for f in dataclasses.fields(lb.DPResult)}
    game = lb.solve_game(lb.BellmanRows.aggregate(mdp, lb.random_partition(30, 4)))
    assert game.status is Status.OPTIMAL and game.converged


def test_values_near_the_float64_limit_are_exact_not_zero():
    """Rewards of 1e298 at discount 0.9 (|V*| up to 2e299): the scale is computed without
    overflow and the values are the closed form times 1e298 (they used to be 0 at 1e307
    with ``converged=True``)."""
    succ = np.array([[[0], [1]], [[1], [1]]])
    allowed = np.array([[True, True], [True, False]])
    for sign in (1.0, -1.0):
        rewards = sign * 1e298 * np.array([[1.0, 0.0], [2.0, 0.0]])
        mdp = lb.FiniteMDP(succ, [1.0], rewards, 0.9, allowed)
        for method in METHODS:
            res = lb.solve_exact(mdp, method)
            assert res.converged and np.all(np.isfinite(res.values))
            if sign > 0:
                want = two_state_closed_form(0.9) * 1e298
            else:  # both actions of state 0 are worth -1e298/(1-lam) paths; closed form
                want = np.array([max(-1.0 / 0.1, 0.9 * -2.0 / 0.1), -2.0 / 0.1]) * 1e298
            # the promise: within error_bound (about 1e-9 relative at the default tol)
            assert np.abs(res.values - want).max() <= res.error_bound, method
            assert res.error_bound <= 1e-8 * np.abs(want).max(), method
            check_dp(res, mdp, want, 4 * np.finfo(float).eps * np.abs(want).max(), method)


@pytest.mark.parametrize("scale", [1e307, 1e308, -1e308])
def test_rewards_whose_values_overflow_are_refused(scale):
    succ = np.array([[[0], [1]], [[1], [1]]])
    with pytest.raises(ValidationError, match=r"rewards: max\|R\|.*overflow"):
        lb.FiniteMDP(succ, [1.0], np.array([[1.0, 0.0], [0.5, 0.0]]) * scale, 0.9)
    with pytest.raises(ValidationError, match=r"reward: max\|R\|.*overflow"):
        lb.BellmanRows.from_arrays([0, 1], [0, 0], [scale, 0.0], [[0], [1]], [1.0], 0.9, 2)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_initial_must_be_finite(method, bad):
    mdp = two_state_mdp()
    with pytest.raises(ValidationError, match=r"initial\[1\] = .* is not finite"):
        lb.solve_exact(mdp, method, initial=[0.0, bad])
    with pytest.raises(ValidationError, match=r"initial\[0\] = .* is not finite"):
        lb.solve_game(exact_rows(mdp), initial=[bad, 0.0])


def test_overflowing_iterates_raise_instead_of_returning_nan():
    """Discount 1 - 1e-12 and a start of +-1e300: the Porteus shift lam/(1-lam) * span
    overflows. Even with raise_on_failure=False no result with NaN values is returned."""
    succ = np.array([[[1]], [[1]]])
    mdp = lb.FiniteMDP(succ, [1.0], [[0.0], [1.0]], 1 - 1e-12)
    with pytest.raises(ConvergenceError, match="non-finite values"):
        lb.solve_exact(mdp, "vi", initial=[1e300, -1e300], max_iter=50, raise_on_failure=False)


def test_nan_values_are_refused_not_half_a_policy():
    """greedy_policy with a NaN used to return 5 actions for 10 states; porteus_bounds an
    empty policy. Now: a ValidationError naming the entry; finite values give n actions."""
    mdp = lb.garnet(10, 3, 2, 0.9, seed=2)
    v = reference_solve(mdp)
    assert lb.greedy_policy(mdp, v).shape == (10,)
    v[7] = np.nan
    for func in (lb.greedy_policy, lb.porteus_bounds, lb.bellman_residual):
        with pytest.raises(ValidationError, match=r"values\[7\] = nan"):
            func(mdp, v)
    for tie in (-1.0, np.nan, np.inf):
        with pytest.raises(ValidationError, match="tie_rtol"):
            lb.greedy_policy(mdp, np.zeros(10), tie_rtol=tie)


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 40),
    a=st.integers(1, 3),
    ll=st.integers(1, 4),
    lam=st.sampled_from([0.0, 0.5, 0.9, 0.99, 0.995, 0.999]),
    scale=st.sampled_from([1e-6, 1.0, 1e6]),
    signed=st.booleans(),
    frac=st.sampled_from([1.0, 0.6]),
    seed=st.integers(0, 10_000),
)
def test_property_default_bracket_contains_v_star(n, a, ll, lam, scale, signed, frac, seed):
    """The default ``solve_exact`` bracket ``[lower_values, upper_values]`` holds V* from an
    independent dense policy iteration (up to that reference's own certified error) at
    discounts up to 0.999 and reward scales 1e-6..1e6, and is not vacuous: its half-width
    is within 1e-10 of the value scale ``max|R| / (1 - lambda)`` (plus the error bound's
    absolute rounding slack for values below 1, and above discount 0.99 the periodic-chain
    floor of the default tolerance)."""
    rr = (-scale, scale) if signed else (0.0, scale)
    mdp = lb.garnet(n, a, ll, lam, seed=seed, allowed_fraction=frac, reward_range=rr)
    indep = ind.policy_iteration(*dense(mdp))
    res = lb.solve_exact(mdp)
    assert res.converged
    lo, hi = res.lower_values, res.upper_values
    assert np.all(lo - indep.error <= indep.values), "lower_values above V*"
    assert np.all(indep.values <= hi + indep.error), "upper_values below V*"
    rmax = float(np.abs(mdp.rewards[mdp.allowed]).max(initial=0.0))
    value_scale = rmax / (1.0 - lam)
    assert np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))
    # error_bound's rounding slack is ROUNDING_ULPS eps max(1, max|V|): absolute below
    # values of 1, hence the 1e-13 / (1 - lambda) term for the 1e-6 reward scale
    width_cap = 2e-10 * value_scale + 1e-13 / (1.0 - lam)
    # above 0.99 the default may be the periodic-chain floor DP_NOISE_ULPS eps max|R| /
    # (1 - lambda)^2 (a width of twice that over 1 - lambda)
    width_cap += 2.2 * DP_NOISE_ULPS * EPS * value_scale / (1.0 - lam) ** 2
    assert float((hi - lo).max()) <= width_cap, "a vacuous bracket"


@pytest.mark.parametrize("lam", [0.9, 0.99])
def test_default_accuracy_on_values_of_order_one(lam):
    """Values of order 1 at discounts up to 0.99 (rewards in [0, 1 - lambda]): the default
    V* passes a 1e-9 absolute cross-check against an independent dense solve."""
    mdp = lb.garnet(300, 3, 4, lam, seed=2, reward_range=(0.0, 1.0 - lam))
    indep = ind.policy_iteration(*dense(mdp))
    res = lb.solve_exact(mdp)
    assert np.abs(res.values - indep.values).max() <= 1e-9 - indep.error
    assert res.error_bound <= 1e-9
