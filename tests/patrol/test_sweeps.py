"""The in-order walk of lpbounds.patrol.sweeps against the decode-per-state dynamics.

Every kernel walks the states in index order (a mixed-radix counter over the delays, the
successors of a row set up from the previous row's, the two headings at a node sharing
their sums). The reference here decodes every state on its own: the model's MDP arrays
(``PatrolModel.mdp``: ``decode_kernel`` and ``successor_kernel`` state by state), the
rewards ``PatrolModel.rewards`` and the partition ``PatrolModel.partition``, with the
sums formed in numpy in outcome order. The parameter sets are chosen to reach every
branch of the walk: one station (rows of one loiter state), ``Gamma = 1`` and ``2``
(rows of two and three states), a station at the last node (a loiter plane whose fast
digit has weight ``Gamma + 1`` in a travel successor), 4 to 6 stations (sums of 5 to 7
outcomes), two nodes, the empty loiter allowed; and chunk counts above the number of rows.
"""

from __future__ import annotations

import numpy as np
import pytest

from lpbounds import greedy_policy
from lpbounds.patrol import sweeps
from lpbounds.patrol.matrix_free import MatrixFreePatrol
from lpbounds.patrol.model import PatrolModel
from lpbounds.patrol.params import PatrolParams

PARAMS = {
    "two-stations": PatrolParams(N=5, stations=(0, 2), D=2, Gamma=6),
    "one-station": PatrolParams(N=4, stations=(1,), D=3, Gamma=5),
    "gamma-one": PatrolParams(N=4, stations=(0, 1, 3), D=1, Gamma=1),
    "last-node": PatrolParams(N=5, stations=(1, 4), D=3, Gamma=2),
    "four-stations": PatrolParams(N=6, stations=(0, 1, 3, 5), D=2, Gamma=3),
    "five-stations": PatrolParams(N=5, stations=(0, 1, 2, 3, 4), D=1, Gamma=2),
    "six-stations": PatrolParams(N=6, stations=(0, 1, 2, 3, 4, 5), D=2, Gamma=1),
    "two-nodes": PatrolParams(N=2, stations=(1,), D=2, Gamma=4),
    "empty-loiter": PatrolParams(N=3, stations=(0, 2), D=2, Gamma=4, allow_empty_loiter=True),
}
CHUNKS = (1, 3, 64)


@pytest.fixture(scope="module", params=list(PARAMS))
def case(request):
    params = PARAMS[request.param]
    pm = PatrolModel(params)
    return pm, pm.mdp(), sweeps.geometry(params)


def per_state_q(mdp, v):
    """Q-values from the decode-per-state arrays, sums from 0.0 in outcome order;
    ``-inf`` where an action is not allowed."""
    succ = mdp.successors.astype(np.int64)
    p = np.asarray(mdp.probabilities)
    acc = np.zeros(succ.shape[:2])
    for o in range(p.size):
        acc = acc + p[o] * v[succ[:, :, o]]
    return np.where(mdp.allowed, mdp.rewards + mdp.discount * acc, -np.inf)


def values(n, seed):
    """Random values with exact ties (multiples of 1/4) in half the states."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=n)
    tied = rng.random(n) < 0.5
    v[tied] = np.round(v[tied] * 4) / 4
    return v


def same_bits(a, b):
    return np.array_equal(np.asarray(a).view(np.int64), np.asarray(b).view(np.int64))


def test_the_walk_decodes_every_state(case):
    pm, _, geo = case
    want = pm.state_components(np.int64)
    n = pm.n_states
    for nchunks in CHUNKS:
        comps = np.empty((n, want.shape[1]), dtype=np.int64)
        sweeps.decode_range(*geo[:4], 0, comps, nchunks)
        assert np.array_equal(comps, want), nchunks
    start = 5  # not at a row boundary: the cursor decodes a state inside a row
    comps = np.empty((n - start, want.shape[1]), dtype=np.int64)
    sweeps.decode_range(*geo[:4], start, comps, 3)
    assert np.array_equal(comps, want[start:])


@pytest.mark.parametrize("action", [0, 1, 2])
def test_successors_at_every_state(case, action):
    _, mdp, geo = case
    want = mdp.successors[:, action, :].astype(np.int64)
    want[~mdp.allowed[:, action]] = -1
    for nchunks in CHUNKS:
        got = np.empty_like(want)
        sweeps.successor_range(*geo[:4], action, got, nchunks)
        assert np.array_equal(got, want), nchunks


def test_max_sweep_equals_the_decode_per_state_sweep(case):
    pm, mdp, geo = case
    for seed in (0, 1):
        v = values(pm.n_states, seed)
        q = per_state_q(mdp, v)
        want, want_arg = q.max(axis=1), q.argmax(axis=1)  # argmax: the first maximum
        for nchunks in CHUNKS:
            out = np.empty(pm.n_states)
            arg = np.full(pm.n_states, 7, dtype=np.int8)
            lo, hi = sweeps.max_sweep(*geo, mdp.discount, v, out, arg, nchunks)
            assert same_bits(out, want), nchunks
            assert np.array_equal(arg, want_arg), nchunks
            assert (lo, hi) == ((want - v).min(), (want - v).max())


def test_policy_sweep_equals_the_decode_per_state_sweep(case):
    pm, mdp, geo = case
    rng = np.random.default_rng(4)
    n = pm.n_states
    act = rng.integers(0, 2, size=n).astype(np.int8)
    act[mdp.allowed[:, 2] & (rng.random(n) < 0.5)] = 2
    v = values(n, 2)
    want = per_state_q(mdp, v)[np.arange(n), act]
    for nchunks in CHUNKS:
        out = np.empty(n)
        lo, hi = sweeps.policy_sweep(*geo, mdp.discount, act, v, out, nchunks)
        assert same_bits(out, want), nchunks
        assert (lo, hi) == ((want - v).min(), (want - v).max())


def test_labels_rewards_and_allowed_actions(case):
    pm, mdp, geo = case
    n = pm.n_states
    for nchunks in CHUNKS:
        labels = np.empty(n, dtype=np.int32)
        sweeps.labels_pass(*geo[:4], labels, nchunks)
        assert np.array_equal(labels, pm.partition().labels), nchunks
    _, _, _, _, _, inc, pent = geo
    absmax = sweeps.reward_absmax_pass(*geo[:4], inc, pent, 3)
    assert absmax == np.abs(mdp.rewards[mdp.allowed]).max()
    act = np.zeros(n, dtype=np.int8)
    assert sweeps.check_policy_pass(*geo[:4], act, 3) == -1
    forbidden = np.flatnonzero(~mdp.allowed[:, 2])
    if forbidden.size:  # the first forbidden loiter is named, whatever comes after it
        act[forbidden[-1]] = 2
        act[forbidden[forbidden.size // 2]] = 2
        for nchunks in CHUNKS:
            got = sweeps.check_policy_pass(*geo[:4], act, nchunks)
            assert got == forbidden[forbidden.size // 2], nchunks


def test_greedy_and_vsub_passes(case):
    """The greedy pass's policy is :func:`lpbounds.greedy_policy` of the lifted lower
    bound; its statistics and those of the V_sub pass are numpy's."""
    pm, mdp, _ = case
    mf = MatrixFreePatrol(pm.params)
    n, labels = pm.n_states, pm.partition().labels
    rng = np.random.default_rng(6)
    vstar = values(n, 3)
    w_low = rng.normal(size=pm.n_partitions) - 2.0
    v_up = w_low + 4.0 + rng.random(pm.n_partitions)
    pistar = per_state_q(mdp, vstar).argmax(axis=1).astype(np.int8)
    pi_s, st = mf.greedy_gap(vstar, pistar, w_low, v_up, loss_tol=1e-9)
    assert np.array_equal(pi_s, greedy_policy(mdp, w_low[labels]))
    up, low = v_up[labels] - vstar, vstar - w_low[labels]
    assert st["upper_min"] == up.min() and st["upper_argmin"] == int(np.argmin(up))
    assert st["lower_max"] == low.max() and st["lower_argmin"] == int(np.argmin(low))
    assert st["gap_max"] == (v_up - w_low)[labels].max()
    assert st["differs"] == int((pi_s != pistar).sum())
    q = per_state_q(mdp, vstar)
    loss = q.max(axis=1) - q[np.arange(n), pi_s]
    assert st["max_one_step_loss"] == loss.max()
    assert st["suboptimal"] == int((loss > 1e-9).sum())
    vsub = vstar - rng.random(n)
    vs = mf.vsub_stats(vstar, vsub, w_low)
    d = vstar - vsub
    assert (vs["max"], vs["argmax"]) == (d.max(), int(np.argmax(d)))
    assert (vs["min"], vs["argmin"]) == (d.min(), int(np.argmin(d)))
    lifted = vsub - w_low[labels]
    assert (vs["low_min"], vs["low_argmin"]) == (lifted.min(), int(np.argmin(lifted)))
    assert vs["mean"] == pytest.approx(d.mean(), rel=1e-12)
