"""The matrix-free patrol sweeps against the array path (the MDP's successor arrays):
the same V*, policy and V_pi bit for bit, the same partitions and components at every
state, and typed errors for a bad policy."""

from __future__ import annotations

import numpy as np
import pytest

from lpbounds import evaluate_policy, greedy_policy, solve_exact
from lpbounds._kernels.ckernels import PARALLEL_READS
from lpbounds.errors import ValidationError
from lpbounds.patrol import sweeps
from lpbounds.patrol.greedy_mc import partition_bounds
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.matrix_free import MatrixFreePatrol, solve_vstar
from lpbounds.patrol.matrix_free import evaluate_policy as mf_evaluate
from lpbounds.patrol.model import PatrolModel
from lpbounds.patrol.params import PatrolParams
from lpbounds.status import Status

#: the shipped small model (one range), one whose array-path sweeps split over the threads,
#: one station (rows of one state), and the paper's literal loiter rule
INSTANCES = {
    "small": params_from_instance("models/patrol-small.toml"),
    "compiled": PatrolParams(N=6, stations=(0, 2, 4), D=2, Gamma=11),
    "one-station": PatrolParams(N=4, stations=(1,), D=3, Gamma=5),
    "empty-loiter": PatrolParams(N=5, stations=(0, 2), D=2, Gamma=6, allow_empty_loiter=True),
}


@pytest.fixture(scope="module", params=list(INSTANCES))
def case(request):
    params = INSTANCES[request.param]
    pm = PatrolModel(params)
    return request.param, params, pm, pm.mdp(), MatrixFreePatrol(params)


def test_the_compiled_case_splits_over_the_threads():
    p = INSTANCES["compiled"]
    assert p.n_states * 3 * (p.m + 1) >= PARALLEL_READS


@pytest.mark.parametrize("eval_sweeps", ["auto", 5])
def test_vstar_bit_for_bit(case, eval_sweeps):
    _, _, _, mdp, mf = case
    ref = solve_exact(mdp, eval_sweeps=eval_sweeps)
    got = solve_vstar(mf, eval_sweeps=eval_sweeps)
    assert np.array_equal(got.values, ref.values)
    assert np.array_equal(got.policy.astype(np.int64), ref.policy)
    assert (got.iterations, got.sweeps) == (ref.iterations, ref.sweeps)
    assert got.residual == ref.residual
    assert got.error_bound == ref.error_bound
    assert got.tol == ref.tol
    assert got.status is Status.OPTIMAL
    assert got.history == ref.history


def test_value_iteration_and_a_given_tolerance(case):
    _, _, _, mdp, mf = case
    ref = solve_exact(mdp, "vi", tol=1e-7)
    got = solve_vstar(mf, eval_sweeps=0, tol=1e-7)
    assert np.array_equal(got.values, ref.values)
    assert got.sweeps == ref.sweeps


def test_iteration_limit_keeps_the_point(case):
    _, _, _, mdp, mf = case
    ref = solve_exact(mdp, max_iter=1, raise_on_failure=False)
    got = solve_vstar(mf, max_iter=1, raise_on_failure=False)
    assert got.status is Status.ITERATION_LIMIT
    assert np.array_equal(got.values, ref.values)
    assert got.error_bound == ref.error_bound


def test_policy_evaluation_bit_for_bit(case):
    _, params, pm, mdp, mf = case
    labels = pm.partition().labels
    pi_s = greedy_policy(mdp, partition_bounds(params).lower[labels])
    ref = evaluate_policy(mdp, pi_s, method="iterative")
    seen: list[tuple[int, float]] = []
    got = mf_evaluate(mf, pi_s, callback=lambda k, r: seen.append((k, r)))
    assert [k for k, _ in seen] == list(range(1, got.sweeps + 1))
    tol = mf.default_tol()  # the loop stops at the first sweep whose residual is <= tol
    assert seen[-1][1] <= tol and all(r > tol for _, r in seen[:-1])
    assert np.array_equal(got.values, ref.values)
    assert (got.residual, got.error_bound, got.sweeps) == (
        ref.residual,
        ref.error_bound,
        ref.sweeps,
    )


def test_partitions_components_and_reward_scale_at_every_state(case):
    _, _, pm, mdp, mf = case
    assert np.array_equal(mf.labels(), pm.partition().labels)
    comps = np.empty((mf.n_vars, 3 + pm.m), dtype=np.int64)
    sweeps.decode_range(*mf.geometry[:4], 0, comps, mf.nchunks())
    assert np.array_equal(comps, pm.state_components(np.int64))
    assert mf.reward_absmax == float(np.abs(mdp.rewards).max())


def test_one_max_sweep_against_the_successor_arrays(case):
    """``T v`` from the MDP's arrays, written here (sums in outcome order)."""
    _, _, _, mdp, mf = case
    rng = np.random.default_rng(5)
    v = rng.normal(size=mf.n_vars)
    succ, p = mdp.successors.astype(np.int64), np.asarray(mdp.probabilities)
    acc = np.zeros(succ.shape[:2])
    for ll in range(p.size):
        acc = acc + p[ll] * v[succ[:, :, ll]]
    q = np.where(mdp.allowed, mdp.rewards + mdp.discount * acc, -np.inf)
    out, arg = np.empty(mf.n_vars), np.zeros(mf.n_vars, dtype=np.int8)
    lo, hi = mf.sweep_max(v, out, arg)
    assert np.array_equal(out, q.max(axis=1))
    assert np.array_equal(arg, q.argmax(axis=1))
    assert (lo, hi) == ((out - v).min(), (out - v).max())


def test_a_bad_policy_is_named():
    params = INSTANCES["small"]
    mf = MatrixFreePatrol(params)
    pm = PatrolModel(params)
    pol = np.zeros(mf.n_vars, dtype=np.int64)
    x = int(np.flatnonzero(~pm.mdp().allowed[:, 2])[3])
    pol[x] = 2
    with pytest.raises(ValidationError, match=rf"policy\[{x}\] = 2 is not allowed in state {x}"):
        mf_evaluate(mf, pol)
    pol[x] = 3
    with pytest.raises(ValidationError, match=rf"policy\[{x}\] = 3 is not an action"):
        mf_evaluate(mf, pol)
    with pytest.raises(ValidationError, match="must be 320 integers"):
        mf_evaluate(mf, np.zeros(5, dtype=np.int64))
    with pytest.raises(ValidationError, match="must be 320 integers"):
        mf_evaluate(mf, np.zeros(mf.n_vars))
    with pytest.raises(ValidationError, match="tol must be a positive"):
        solve_vstar(mf, tol=0.0)
    with pytest.raises(ValidationError, match="eval_sweeps"):
        solve_vstar(mf, eval_sweeps=-1)
