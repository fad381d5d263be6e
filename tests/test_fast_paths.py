"""Every fast path of the DP core against the plain path and an independent reference.

The post-decision form (:class:`lpbounds.rows.PostDecisionRows`) is used automatically by
``solve_exact`` (VI/MPI), ``evaluate_policy`` (iterative) and ``bellman_residual`` on a
FiniteMDP that has it. Passing ``exact_rows(mdp)`` forces the plain row kernels. The fast
path claims the *same arithmetic*, so the tests below ask for bit-identical results, and
compare both with plain-numpy references from ``conftest``.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypothesis import given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.dp import exact_rows, post_decision_rows
from lpbounds.patrol import PatrolModel, PatrolParams
from lpbounds.rows import PostDecisionRows

from .conftest import reference_bellman, reference_solve


def post_decision_mdp(
    n: int, n_actions: int, n_out: int, discount: float, seed: int, allowed_fraction: float = 1.0
) -> lb.FiniteMDP:
    """A random MDP in post-decision form: ``succ[x, u] = g[f0[x, u]]`` with ``g[y, 0] = y``."""
    rng = np.random.default_rng(seed)
    g = rng.integers(0, n, size=(n, n_out))
    g[:, 0] = np.arange(n)
    f0 = rng.integers(0, n, size=(n, n_actions))
    p = rng.random(n_out) + 0.05
    allowed = rng.random((n, n_actions)) < allowed_fraction
    allowed[np.arange(n), rng.integers(0, n_actions, size=n)] = True
    rewards = rng.normal(size=(n, n_actions))
    return lb.FiniteMDP(g[f0], p / p.sum(), rewards, discount, allowed)


def small_patrol(**kw) -> lb.FiniteMDP:
    base = {"N": 8, "stations": (0, 3), "D": 3, "Gamma": 5}
    base.update(kw)
    return PatrolModel(PatrolParams(**base)).mdp()


PATROLS = [
    {},
    {"allow_empty_loiter": True},
    {"N": 7, "stations": (1, 3, 5), "D": 2, "Gamma": 4},
]


def assert_same_result(fast: lb.DPResult, plain: lb.DPResult, rows: lb.BellmanRows) -> None:
    assert np.array_equal(fast.values, plain.values), "fast path values differ from plain"
    assert np.array_equal(fast.policy_rows, plain.policy_rows), "policy rows differ"
    assert np.array_equal(fast.policy, rows.action[plain.policy_rows]), "actions differ"
    assert (fast.iterations, fast.sweeps) == (plain.iterations, plain.sweeps)
    assert fast.residual == plain.residual
    assert fast.error_bound == plain.error_bound
    assert fast.tol == plain.tol


@pytest.mark.parametrize("kw", PATROLS)
@pytest.mark.parametrize("method", ["vi", "mpi"])
def test_patrol_fast_solve_equals_plain_bit_for_bit(kw, method):
    mdp = small_patrol(**kw)
    assert post_decision_rows(mdp) is not None, "the patrol MDP has a post-decision form"
    rows = exact_rows(mdp)
    fast = lb.solve_exact(mdp, method)
    plain = lb.solve_exact(rows, method)
    assert_same_result(fast, plain, rows)
    # and both against an independent numpy value iteration, within the reported bound
    ref = reference_solve(mdp)
    err = np.abs(fast.values - ref).max()
    assert err <= fast.error_bound + 1e-12, f"|V - V*| = {err} > bound {fast.error_bound}"
    q = reference_bellman(mdp, fast.values)
    true_res = np.abs(q.max(axis=1) - fast.values).max()
    assert true_res == pytest.approx(fast.residual, abs=1e-13), "residual not the true one"


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("allowed_fraction", [1.0, 0.6])
def test_random_post_decision_mdp_equals_plain(seed, allowed_fraction):
    mdp = post_decision_mdp(300, 3, 4, 0.9, seed, allowed_fraction)
    ps = post_decision_rows(mdp)
    assert ps is not None
    rows = exact_rows(mdp)
    for method in ("vi", "mpi"):
        kw = {"eval_sweeps": 3, "tol": 1e-9, "initial": np.linspace(-1, 1, 300)}
        assert_same_result(
            lb.solve_exact(mdp, method, **kw), lb.solve_exact(rows, method, **kw), rows
        )
    # the form's operator against the plain numpy Bellman operator
    v = np.random.default_rng(seed).normal(size=mdp.n_states)
    out = np.empty_like(v)
    act = ps.new_arg()
    lo, hi = ps._sweep_max(v, out, act, 7)
    q = reference_bellman(mdp, v)
    np.testing.assert_allclose(out, q.max(axis=1), rtol=0, atol=1e-14, err_msg="T v")
    assert np.array_equal(act, q.argmax(axis=1)), "first maximising action"
    assert (lo, hi) == ((out - v).min(), (out - v).max())
    assert np.array_equal(ps.rows_of(act), rows.pair_row[np.arange(mdp.n_states), act])


@pytest.mark.parametrize("max_codes", [0, 8, 65_536])
def test_reward_storage_variants_equal_plain(monkeypatch, max_codes):
    # 0: float rewards; 8: too few codes for the rewards, so float; 65,536: uint16 codes
    monkeypatch.setattr(PostDecisionRows, "MAX_REWARD_CODES", max_codes)
    mdp = post_decision_mdp(400, 3, 3, 0.9, seed=9, allowed_fraction=0.7)
    ps = PostDecisionRows.detect(mdp)
    if max_codes < 400:
        assert ps.reward_codes is None
    else:
        assert ps.reward_codes.dtype == np.uint16
        assert np.array_equal(ps.reward_table[ps.reward_codes], mdp.rewards), "codes lossy"
    mdp.__dict__["_post_decision"] = ps
    rows = exact_rows(mdp)
    for method in ("vi", "mpi"):
        assert_same_result(lb.solve_exact(mdp, method), lb.solve_exact(rows, method), rows)


def test_patrol_rewards_are_coded_exactly():
    mdp = small_patrol()
    ps = post_decision_rows(mdp)
    assert ps.reward_codes is not None and ps.reward_codes.dtype == np.uint8
    assert np.array_equal(ps.reward_table[ps.reward_codes], mdp.rewards)
    # bit for bit, including the sign of zero
    assert np.array_equal(
        ps.reward_table[ps.reward_codes].view(np.int64), np.asarray(mdp.rewards).view(np.int64)
    )


def test_detection_rejects_mdps_without_the_form():
    assert post_decision_rows(lb.garnet(200, 3, 4, 0.9, seed=2, shared_probabilities=True)) is None
    assert post_decision_rows(lb.garnet(200, 3, 4, 0.9, seed=2)) is None  # per-pair probs
    # one changed outcome in one pair breaks the form: verification must notice
    good = post_decision_mdp(200, 3, 4, 0.9, seed=4)
    assert PostDecisionRows.detect(good) is not None
    succ = np.array(good.successors)
    x = int(np.flatnonzero(good.allowed[:, 1])[-1])
    succ[x, 1, 2] = (succ[x, 1, 2] + 1) % 200
    bad = lb.FiniteMDP(succ, good.probabilities, good.rewards, 0.9, good.allowed)
    shared = np.isin(bad.successors[:, :, 0], bad.successors[x, 1, 0]).sum()
    if shared > 1:  # another pair reaches the same post-decision state: must be rejected
        assert PostDecisionRows.detect(bad) is None
    # a disallowed pair's successors are never read
    succ2 = np.array(good.successors)
    allowed = np.array(good.allowed)
    allowed[0, 2] = False
    succ2[0, 2] = [5, 6, 7, 8]
    mdp2 = lb.FiniteMDP(succ2, good.probabilities, good.rewards, 0.9, allowed)
    assert PostDecisionRows.detect(mdp2) is not None


def test_detection_notices_a_single_inconsistent_pair():
    # two pairs with the same first successor and different tuples
    succ = np.array([[[1, 0]], [[1, 1]], [[2, 0]]])
    mdp = lb.FiniteMDP(succ, [0.5, 0.5], np.zeros((3, 1)), 0.9)
    assert PostDecisionRows.detect(mdp) is None


@pytest.mark.parametrize("kw", PATROLS[:2])
def test_fast_policy_evaluation_matches_direct_solve(kw):
    mdp = small_patrol(**kw)
    sol = lb.solve_exact(mdp)
    rng = np.random.default_rng(0)
    pol = np.array(sol.policy)
    flip = rng.random(mdp.n_states) < 0.3
    pol[flip & mdp.allowed[:, 1]] = 1  # another valid policy
    fast = lb.evaluate_policy(mdp, pol, method="iterative")
    # independent: sparse LU of (I - lam P_pi) V = R_pi from to_matrices()
    P, R = mdp.to_matrices(disallowed_reward=-1e9)
    n = mdp.n_states
    p_pi = sp.vstack([P[pol[x]][x] for x in range(n)]).tocsc()
    want = spla.spsolve(sp.identity(n, format="csc") - mdp.discount * p_pi, R[np.arange(n), pol])
    err = np.abs(fast.values - want).max()
    assert err <= fast.error_bound + 1e-12, f"|V - V_pi| = {err} > bound {fast.error_bound}"
    plain = lb.evaluate_policy(
        exact_rows(mdp), exact_rows(mdp).pair_row[np.arange(n), pol], method="iterative"
    )
    assert np.array_equal(fast.values, plain.values), "fast and plain evaluation differ"
    assert fast.residual == pytest.approx(plain.residual, abs=1e-15)
    with pytest.raises(lb.ValidationError, match="not allowed"):
        bad = np.array(pol)
        bad[int(np.flatnonzero(~mdp.allowed[:, 2])[0])] = 2
        lb.evaluate_policy(mdp, bad, method="iterative")


def test_fast_bellman_residual_equals_plain():
    mdp = small_patrol()
    v = np.random.default_rng(1).normal(size=mdp.n_states)
    fast = lb.bellman_residual(mdp, v)
    plain = lb.bellman_residual(exact_rows(mdp), v)
    ref = np.abs(reference_bellman(mdp, v).max(axis=1) - v).max()
    assert fast == plain
    assert fast == pytest.approx(ref, abs=1e-13)


@settings(max_examples=15, deadline=None)
@given(
    n=st.integers(2, 60),
    a=st.integers(1, 4),
    ll=st.integers(1, 4),
    lam=st.sampled_from([0.0, 0.5, 0.9, 0.97]),
    frac=st.sampled_from([1.0, 0.5]),
    seed=st.integers(0, 10_000),
)
def test_property_fast_equals_plain(n, a, ll, lam, frac, seed):
    mdp = post_decision_mdp(n, a, ll, lam, seed, frac)
    rows = exact_rows(mdp)
    for method in ("vi", "mpi"):
        assert_same_result(lb.solve_exact(mdp, method), lb.solve_exact(rows, method), rows)
