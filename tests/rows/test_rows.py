"""BellmanRows: exact and aggregated rows against loop-based references; operators; LP data."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.errors import ValidationError
from tests.conftest import reference_bellman


def reference_aggregate(mdp, part, reduce="max"):
    """Distinct (owner, action, successor distribution) -> extreme reward, by plain loops."""
    p = np.broadcast_to(mdp.probabilities, mdp.successors.shape)
    out: dict = {}
    for x in range(mdp.n_states):
        for u in range(mdp.n_actions):
            if not mdp.allowed[x, u]:
                continue
            if reduce == "min" and not mdp.allowed[part.labels == part.labels[x], u].all():
                continue  # the NLP keeps (i, u) only if u is allowed on all of S_i
            dist: dict = {}
            for ll in range(mdp.n_outcomes):
                if p[x, u, ll] > 0:
                    k = int(part.labels[mdp.successors[x, u, ll]])
                    dist[k] = dist.get(k, 0.0) + float(p[x, u, ll])
            key = (int(part.labels[x]), u, tuple(sorted(dist.items())))
            r = float(mdp.rewards[x, u])
            if key not in out:
                out[key] = r
            else:
                out[key] = max(out[key], r) if reduce == "max" else min(out[key], r)
    return out


def rows_as_dict(rows):
    out = {}
    probs = np.asarray(rows.probs)
    for r in range(rows.n_rows):
        dist = {}
        for ll in range(rows.n_outcomes):
            if probs[r, ll] > 0:
                k = int(rows.targets[r, ll])
                dist[k] = dist.get(k, 0.0) + float(probs[r, ll])
        key = (int(rows.owner[r]), int(rows.action[r]), tuple(sorted(dist.items())))
        assert key not in out, "a merged row system must not repeat a row"
        out[key] = float(rows.reward[r])
    return out


def _assert_same_rows(got, want):
    assert set(got) == set(want)
    for key in want:
        assert got[key] == pytest.approx(want[key], abs=0), key


@pytest.mark.parametrize("reduce", ["max", "min"])
@pytest.mark.parametrize("shared", [True, False])
def test_aggregate_matches_loop_reference(reduce, shared):
    # few partitions and integer rewards make merges (and reward ties) frequent
    mdp = lb.garnet(150, 3, 3, 0.9, seed=8, shared_probabilities=shared, allowed_fraction=0.8)
    mdp = lb.FiniteMDP(
        mdp.successors, mdp.probabilities, np.round(mdp.rewards * 3), 0.9, mdp.allowed
    )
    part = lb.random_partition(150, 3, seed=1)
    rows = lb.BellmanRows.aggregate(mdp, part, reduce=reduce)
    want = reference_aggregate(mdp, part, reduce)
    # both sum a target's probabilities in outcome order, so they agree to the bit
    _assert_same_rows(rows_as_dict(rows), want)
    if shared:  # with one distribution per pair no two rows coincide
        assert rows.n_rows < mdp.n_pairs  # merging happened


def test_pair_map_points_every_pair_to_its_row():
    mdp = lb.garnet(30, 2, 2, 0.9, seed=2, shared_probabilities=True)
    part = lb.random_partition(30, 3, seed=2)
    rows = lb.BellmanRows.aggregate(mdp, part)
    xs, us = np.nonzero(mdp.allowed)
    r = rows.pair_row[xs, us]
    assert (r >= 0).all()
    np.testing.assert_array_equal(rows.owner[r], part.labels[xs])
    np.testing.assert_array_equal(rows.action[r], us)
    # a tight pair has the row's reward; a non-tight one a strictly smaller one
    tight = rows.pair_tight[xs, us]
    np.testing.assert_array_equal(rows.reward[r][tight], mdp.rewards[xs, us][tight])
    assert (rows.reward[r][~tight] > mdp.rewards[xs, us][~tight]).all()
    # spreading duals conserves their total over tight pairs and zeroes the others
    y = np.random.default_rng(0).random(rows.n_rows)
    mu = rows.pair_values(y)
    assert mu.sum() == pytest.approx(y.sum())
    assert (mu[xs, us][~tight] == 0).all()


def test_exact_rows_and_operators_match_numpy(small_mdp):
    rows = lb.BellmanRows.from_mdp(small_mdp)
    v = np.random.default_rng(1).normal(size=small_mdp.n_states)
    q = reference_bellman(small_mdp, v)
    np.testing.assert_allclose(rows.q_values(v), q[small_mdp.allowed], rtol=1e-14)
    tv, arg = rows.apply_max(v)
    np.testing.assert_allclose(tv, q.max(axis=1), rtol=1e-14)
    np.testing.assert_array_equal(rows.action[arg], q.argmax(axis=1))
    a, b = rows.constraint_matrix()
    # A v - b = v(owner) - q
    np.testing.assert_allclose(a @ v - b, v[rows.owner] - rows.q_values(v), atol=1e-12)
    sel = arg
    np.testing.assert_allclose(rows.evaluate_rows(sel, v), tv, rtol=1e-14)
    p = rows.transition_matrix(sel).toarray()
    np.testing.assert_allclose(p.sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(rows.reward[sel] + 0.9 * p @ v, tv, rtol=1e-13)


def test_maxmin_operator_matches_loops():
    mdp = lb.garnet(25, 3, 2, 0.8, seed=4)
    part = lb.random_partition(25, 5, seed=4)
    rows = lb.BellmanRows.aggregate(mdp, part, reduce="min")
    w = np.random.default_rng(2).normal(size=5)
    q = rows.q_values(w)
    want = np.full(5, -np.inf)
    for i in range(5):
        for u in range(3):
            sel = (rows.owner == i) & (rows.action == u)
            if sel.any():
                want[i] = max(want[i], q[sel].min())
    got, arg = rows.apply_maxmin(w)
    np.testing.assert_allclose(got, want, rtol=1e-14)
    np.testing.assert_allclose(q[arg], got, rtol=1e-14)


@pytest.fixture(params=["numpy", "compiled"])
def kernels(request, monkeypatch):
    """Run a test on each kernel path: the library on the numpy twins or on the C kernels
    (every call's work split over the threads); yields the two modules that path calls:
    (aggregation kernels, sweep kernels)."""
    from lpbounds._kernels import ckernels as _kernels
    from lpbounds._kernels import dispatch as _backend
    from lpbounds._kernels import twins as _npkernels

    if request.param == "compiled":
        monkeypatch.setattr(_kernels, "PARALLEL_READS", 0)
        return _kernels, _kernels
    monkeypatch.setattr(_backend, "kernels", lambda: _npkernels)
    monkeypatch.setattr(_backend, "row_sweeps", lambda: _npkernels)
    return _npkernels, _npkernels


def test_key_collisions_fall_back_to_exact_grouping(monkeypatch, kernels):
    agg, sweep = kernels
    mdp = lb.garnet(40, 2, 3, 0.9, seed=6, shared_probabilities=True)
    part = lb.random_partition(40, 5, seed=6)
    honest = lb.BellmanRows.aggregate(mdp, part)
    # pretend the fast path saw a collision, then make every row's fallback hash collide too
    monkeypatch.setattr(agg, "mark_groups", lambda *args: True)

    def constant_hash(owner, action, targets, probbits, out):
        out[:] = 7

    monkeypatch.setattr(sweep, "hash_rows", constant_hash)
    collided = lb.BellmanRows.aggregate(mdp, part)
    assert rows_as_dict(collided) == rows_as_dict(honest)
    np.testing.assert_array_equal(collided.indptr, honest.indptr)
    # every pair maps to a row with the same content (row order within a block may differ)
    xs, us = np.nonzero(mdp.allowed)

    def content(rows, r):
        p = np.asarray(rows.probs)[r]
        return (rows.owner[r], rows.action[r], rows.reward[r], tuple(rows.targets[r][p > 0]))

    for x, u in zip(xs, us, strict=True):
        assert content(collided, collided.pair_row[x, u]) == content(honest, honest.pair_row[x, u])
    np.testing.assert_array_equal(collided.pair_tight, honest.pair_tight)


def test_mark_groups_detects_equal_keys_of_different_rows(kernels):
    agg, _ = kernels
    # rows 0-2 share a hash; rows 1 and 2 differ (a collision); row 3 is another bucket
    # with the same content and hash as row 0 (never merged across buckets)
    oa = np.array([4, 4, 4, 6])
    key = np.array([5, 5, 5, 5], dtype=np.uint64)
    t = np.array([[0, 1], [0, 1], [0, 2], [0, 1]], dtype=np.int32)
    pbits = np.zeros((4, 2), dtype=np.int64)
    new = np.empty(4, dtype=bool)
    order = np.arange(4)
    assert agg.mark_groups(order, oa, key, t, pbits, new)
    np.testing.assert_array_equal(new, [True, False, True, True])
    assert not agg.mark_groups(order[:2], oa, key, t, pbits, new)


def test_from_arrays_validation():
    with pytest.raises(ValidationError, match="variable 1 owns no Bellman row"):
        lb.BellmanRows.from_arrays([0, 0], [0, 1], [1.0, 2.0], [[0], [0]], [1.0], 0.9, 2)
    with pytest.raises(ValidationError, match="out of range"):
        lb.BellmanRows.from_arrays([0], [0], [1.0], [[3]], [1.0], 0.9, 2)
    with pytest.raises(ValidationError, match=r"probs\[0, :\] sum to 0.7, not 1"):
        lb.BellmanRows.from_arrays([0], [0], [1.0], [[0, 0]], [0.5, 0.2], 0.9, 1)
    rows = lb.BellmanRows.from_arrays(
        [1, 0, 1], [1, 0, 0], [1, 2, 3], [[0], [1], [1]], [1.0], 0.5, 2
    )
    np.testing.assert_array_equal(rows.owner, [0, 1, 1])
    np.testing.assert_array_equal(rows.action, [0, 0, 1])
    np.testing.assert_array_equal(rows.indptr, [0, 1, 3])


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(2, 25),
    a=st.integers(1, 3),
    ll=st.integers(1, 4),
    m=st.integers(1, 6),
    seed=st.integers(0, 10_000),
)
def test_aggregated_rows_hold_every_pair_inequality(n, a, ll, m, seed):
    """Property: for any v, the merged rows imply every unmerged aggregated inequality."""
    m = min(m, n)
    mdp = lb.garnet(n, a, ll, 0.7, seed=seed)
    part = lb.random_partition(n, m, seed=seed)
    rows = lb.BellmanRows.aggregate(mdp, part)
    v = np.random.default_rng(seed).normal(size=m)
    merged_q = rows.q_values(v)
    # the unmerged aggregated row of each pair, computed directly
    p = np.broadcast_to(mdp.probabilities, mdp.successors.shape)
    pair_q = mdp.rewards + 0.7 * (p * v[part.labels[mdp.successors]]).sum(axis=2)
    xs, us = np.nonzero(mdp.allowed)
    assert np.all(merged_q[rows.pair_row[xs, us]] >= pair_q[xs, us] - 1e-12)
    # and the row system's max operator equals the max over pairs per partition
    tv, _ = rows.apply_max(v)
    want = np.full(m, -np.inf)
    np.maximum.at(want, part.labels[xs], pair_q[xs, us])
    np.testing.assert_allclose(tv, want, rtol=1e-12, atol=1e-12)
