"""The C row kernels (:mod:`lpbounds._kernels.ckernels`) against their numpy twins, bit for bit.

The twins (:mod:`lpbounds._kernels.twins`) are the reference arithmetic; the C functions
claim the same numbers, and the same choices (first maximising row or action, group
marks, orders), for every layout the library passes them: int32 and int64 indices,
shared (a stride-0 view) or per-row probabilities, masks, ties, zero probabilities and
repeated targets, rewards coded in uint8 / uint16 / uint32, and any split of the work over
one or two threads (every call split, however small: ``PARALLEL_READS`` is 0 here). Each
index they read is checked: the tests at the end plant a bad one in every argument that
holds indices and expect a typed error naming it, never a crash. The solves built on
these kernels are compared with the twins end to end in ``tests/dp/test_fast_paths.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lpbounds._kernels import ckernels as C
from lpbounds._kernels import threads as pool
from lpbounds._kernels import twins as T

SETTINGS = settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
INDEX = st.sampled_from([np.int32, np.int64])


def bits(x) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64).view(np.int64)


def same(a, b) -> bool:
    """Equal dtypes and entries, floats bit for bit (signed zeros included)."""
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    if a.dtype.kind == "f":
        return np.array_equal(bits(a), bits(b))
    return np.array_equal(a, b)


@pytest.fixture(params=[1, 2], ids=["1 thread", "2 threads"])
def threads(request, monkeypatch):
    """One thread, or two with every call's work split in two ranges."""
    if request.param > pool.default_threads():
        pytest.skip("one CPU")
    monkeypatch.setattr(C, "PARALLEL_READS", 0)
    before = pool.get_threads()
    pool.set_threads(request.param)
    yield request.param
    pool.set_threads(before)


# ---------------------------------------------------------------------- generators
def row_system(rng, n: int, max_rows: int, n_out: int, shared: bool, idx, ties: bool):
    """Owners with 1..max_rows rows sorted by action (actions repeat: the game operator's
    groups), targets in [0, n), probabilities shared (a broadcast view) or per row with
    zeros; with ``ties``, few distinct rewards and values (equal Q-values)."""
    counts = rng.integers(1, max_rows + 1, size=n)
    indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    n_rows = int(indptr[-1])
    action = np.concatenate([np.sort(rng.integers(0, 3, size=c)) for c in counts]).astype(np.int32)
    targets = rng.integers(0, n, size=(n_rows, n_out)).astype(idx)
    if ties:
        reward = rng.integers(-2, 3, size=n_rows) / 2.0
        v = rng.integers(-2, 3, size=n).astype(float)
    else:
        reward = rng.normal(size=n_rows) * 10.0 ** rng.integers(-3, 4, size=n_rows)
        v = rng.normal(size=n) * 100
    if shared:
        p = rng.random(n_out) + 0.01
        probs = np.broadcast_to(p / p.sum(), (n_rows, n_out))
    else:
        p = rng.random((n_rows, n_out)) * (rng.random((n_rows, n_out)) < 0.8)
        p[:, 0] += 0.01
        probs = p / p.sum(axis=1, keepdims=True)
    return indptr, action, reward, targets, probs, v


def post_decision(rng, n: int, n_act: int, n_out: int, idx, frac: float):
    """Successors in post-decision form (``succ[x, u] = g[f0[x, u]]``) with a mask."""
    g = rng.integers(0, n, size=(n, n_out))
    g[:, 0] = np.arange(n)
    succ = g[rng.integers(0, n, size=(n, n_act))].astype(idx)
    allowed = rng.random((n, n_act)) < frac
    allowed[np.arange(n), rng.integers(0, n_act, size=n)] = True
    return succ, allowed


def post_form(kern, succ, allowed, idx):
    """``(seen, post_id, outcomes, first)`` built by ``kern``'s passes."""
    n, n_act, n_out = succ.shape
    seen = np.zeros(n, dtype=bool)
    kern.ps_mark(succ, allowed, seen)
    post = np.flatnonzero(seen)
    post_id = np.full(n, -1, dtype=idx)
    post_id[post] = np.arange(post.size, dtype=idx)
    outcomes = np.empty((post.size, n_out), dtype=succ.dtype)
    first = np.empty((n, n_act), dtype=idx)
    kern.ps_fill(succ, allowed, post_id, outcomes, first)
    return seen, post_id, outcomes, first


# ---------------------------------------------------------------------- row kernels
@SETTINGS
@given(
    n=st.integers(1, 60), max_rows=st.integers(1, 6), n_out=st.integers(1, 10),
    shared=st.booleans(), idx=INDEX, ties=st.booleans(), seed=st.integers(0, 2**32 - 1),
    lam=st.sampled_from([0.0, 0.5, 0.9, 0.999]),
)  # fmt: skip
def test_property_q_values_and_game_operator_equal_twins(
    threads, n, max_rows, n_out, shared, idx, ties, seed, lam
):
    rng = np.random.default_rng(seed)
    indptr, action, reward, targets, probs, v = row_system(
        rng, n, max_rows, n_out, shared, idx, ties
    )
    got, want = np.empty(reward.size), np.empty(reward.size)
    C.q_values(reward, targets, probs, lam, v, got)
    T.q_values(reward, targets, probs, lam, v, want)
    assert same(got, want)
    out_c, arg_c = np.empty(n), np.empty(n, dtype=np.int64)
    out_t, arg_t = np.empty(n), np.empty(n, dtype=np.int64)
    C.bellman_maxmin(indptr, action, reward, targets, probs, lam, v, out_c, arg_c)
    T.bellman_maxmin(indptr, action, reward, targets, probs, lam, v, out_t, arg_t)
    assert same(out_c, out_t) and same(arg_c, arg_t)


def test_game_operator_against_a_plain_loop(threads):
    """max over each owner's actions of the min over that action's rows, ties to the first."""
    rng = np.random.default_rng(7)
    indptr, action, reward, targets, probs, v = row_system(rng, 40, 7, 3, False, np.int32, True)
    q = np.empty(reward.size)
    C.q_values(reward, targets, probs, 0.9, v, q)
    out, arg = np.empty(40), np.empty(40, dtype=np.int64)
    C.bellman_maxmin(indptr, action, reward, targets, probs, 0.9, v, out, arg)
    for i in range(40):
        rows = range(indptr[i], indptr[i + 1])
        groups: dict[int, list[int]] = {}
        for r in rows:
            groups.setdefault(int(action[r]), []).append(r)
        best, best_r = -np.inf, -1
        for a in sorted(groups):
            low_r = min(groups[a], key=lambda r: (q[r], r))
            if q[low_r] > best:
                best, best_r = q[low_r], low_r
        assert out[i] == best and arg[i] == best_r, i


@SETTINGS
@given(
    n_rows=st.integers(0, 200), n_out=st.integers(1, 6), idx=INDEX, act64=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)  # fmt: skip
def test_property_hash_rows_equals_twin(threads, n_rows, n_out, idx, act64, seed):
    rng = np.random.default_rng(seed)
    owner = rng.integers(0, 2**31 - 1, size=n_rows).astype(idx)
    action = rng.integers(0, 5, size=n_rows).astype(np.int64 if act64 else np.int32)
    targets = rng.integers(0, 2**31 - 1, size=(n_rows, n_out)).astype(idx)
    pbits = rng.random((n_rows, n_out)).view(np.int64)
    got, want = np.empty(n_rows, dtype=np.uint64), np.empty(n_rows, dtype=np.uint64)
    C.hash_rows(owner, action, targets, pbits, got)
    T.hash_rows(owner, action, targets, pbits, want)
    assert same(got, want)


# ---------------------------------------------------------------------- post-decision form
@SETTINGS
@given(
    n=st.integers(1, 80), n_act=st.integers(1, 4), n_out=st.integers(1, 9), idx=INDEX,
    first_idx=INDEX, frac=st.sampled_from([1.0, 0.6]), seed=st.integers(0, 2**32 - 1),
)  # fmt: skip
def test_property_post_decision_passes_equal_twins(
    threads, n, n_act, n_out, idx, first_idx, frac, seed
):
    rng = np.random.default_rng(seed)
    succ, allowed = post_decision(rng, n, n_act, n_out, idx, frac)
    got = post_form(C, succ, allowed, first_idx)
    want = post_form(T, succ, allowed, first_idx)
    for name, x, y in zip(("seen", "post_id", "outcomes", "first"), got, want, strict=True):
        assert same(x, y), name
    _, _, outcomes, first = got
    assert C.ps_verify(succ, first, outcomes) == T.ps_verify(succ, first, outcomes) == 0
    # one pair's tuple changed: both reject the form, whichever thread meets it
    xs, us = np.nonzero(allowed)
    k = rng.integers(xs.size)
    bad = succ.copy()
    bad[xs[k], us[k], -1] = (bad[xs[k], us[k], -1] + 1) % n
    if n > 1:
        assert C.ps_verify(bad, first, outcomes) == T.ps_verify(bad, first, outcomes) == 1
    # the row of each state's action in the rows of BellmanRows.from_mdp
    act = np.array([rng.choice(np.flatnonzero(allowed[x])) for x in range(n)], dtype=np.int8)
    row_start = np.zeros(n, dtype=np.int64)
    np.cumsum(allowed.sum(axis=1)[:-1], out=row_start[1:])
    rc, rt = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    C.ps_rows(allowed, row_start, act, rc)
    T.ps_rows(allowed, row_start, act, rt)
    assert same(rc, rt)


@SETTINGS
@given(
    n=st.integers(1, 80), n_act=st.integers(1, 4), n_out=st.integers(1, 9), idx=INDEX,
    frac=st.sampled_from([1.0, 0.6]), codes=st.sampled_from([None, np.uint8, np.uint16, np.uint32]),
    arg64=st.booleans(), ties=st.booleans(), lam=st.sampled_from([0.0, 0.9, 0.999]),
    seed=st.integers(0, 2**32 - 1),
)  # fmt: skip
def test_property_post_decision_sweeps_equal_twins(
    threads, n, n_act, n_out, idx, frac, codes, arg64, ties, lam, seed
):
    rng = np.random.default_rng(seed)
    succ, allowed = post_decision(rng, n, n_act, n_out, idx, frac)
    _, _, outcomes, first = post_form(T, succ, allowed, idx)
    p = rng.random(n_out) + 0.01
    p /= p.sum()
    v = rng.integers(-2, 3, size=n).astype(float) if ties else rng.normal(size=n) * 100
    wc, wt = np.empty(outcomes.shape[0]), np.empty(outcomes.shape[0])
    C.ps_expect(outcomes, p, v, wc)
    T.ps_expect(outcomes, p, v, wt)
    assert same(wc, wt)
    pool = rng.integers(-3, 4, size=200) / 4.0 if ties else rng.normal(size=200)
    reward = np.where(allowed, pool[rng.integers(0, 200, size=(n, n_act))], 0.0)  # <= 201 values
    adt = np.int64 if arg64 else np.int8
    out_c, arg_c, out_t, arg_t = np.empty(n), np.zeros(n, adt), np.empty(n), np.zeros(n, adt)
    if codes is None:
        sc = C.ps_max_stats(first, reward, wt, lam, v, out_c, arg_c)
        st_ = T.ps_max_stats(first, reward, wt, lam, v, out_t, arg_t)
    else:
        code, table = np.empty((n, n_act), dtype=codes), np.empty(256)
        count = C.reward_codes(reward, 256, code, table)
        assert count > 0 and same(table[code], reward)
        sc = C.ps_max_stats_coded(first, code, table[:count], wt, lam, v, out_c, arg_c)
        st_ = T.ps_max_stats_coded(first, code, table[:count], wt, lam, v, out_t, arg_t)
    assert same(out_c, out_t) and same(arg_c, arg_t) and sc == st_
    if codes is None:
        sc = C.ps_policy_stats(first, reward, arg_c, wt, lam, v, out_c)
        st_ = T.ps_policy_stats(first, reward, arg_c, wt, lam, v, out_t)
    else:
        sc = C.ps_policy_stats_coded(first, code, table[:count], arg_c, wt, lam, v, out_c)
        st_ = T.ps_policy_stats_coded(first, code, table[:count], arg_c, wt, lam, v, out_t)
    assert same(out_c, out_t) and sc == st_


def test_no_action_gives_minus_inf_and_no_row(threads):
    """act = -1, what the max sweep writes where no action beats -inf (overflowing iterates):
    the policy sweep gives -inf there and the row map -1, as the twins do, so a solve that
    overflows ends in its ConvergenceError (tests/dp/test_dp.py); other bad actions raise."""
    rng = np.random.default_rng(4)
    succ, allowed = post_decision(rng, 30, 3, 2, np.int32, 0.7)
    _, _, outcomes, first = post_form(T, succ, allowed, np.int32)
    act = np.array([rng.choice(np.flatnonzero(allowed[x])) for x in range(30)], dtype=np.int8)
    act[[0, 17]] = -1
    reward, w, v = rng.normal(size=(30, 3)), rng.normal(size=outcomes.shape[0]), np.zeros(30)
    got, want = np.empty(30), np.empty(30)
    sc = C.ps_policy_stats(first, reward, act, w, 0.9, v, got)
    st_ = T.ps_policy_stats(first, reward, act, w, 0.9, v, want)
    assert same(got, want) and sc == st_ and got[17] == -np.inf and sc[0] == -np.inf
    code, table = np.empty((30, 3), np.uint8), np.empty(90)
    count = C.reward_codes(reward, 90, code, table)
    sc = C.ps_policy_stats_coded(first, code, table[:count], act, w, 0.9, v, got)
    st_ = T.ps_policy_stats_coded(first, code, table[:count], act, w, 0.9, v, want)
    assert same(got, want) and sc == st_
    row_start = np.zeros(30, dtype=np.int64)
    np.cumsum(allowed.sum(axis=1)[:-1], out=row_start[1:])
    rc, rt = np.empty(30, np.int64), np.empty(30, np.int64)
    C.ps_rows(allowed, row_start, act, rc)
    T.ps_rows(allowed, row_start, act, rt)
    assert same(rc, rt) and rc[0] == rc[17] == -1
    act[5] = -2
    with pytest.raises(IndexError, match=r"act\[5\] = -2 is outside \[0, 3\)"):
        C.ps_policy_stats(first, reward, act, w, 0.9, v, got)
    with pytest.raises(IndexError, match=r"act\[5\] = -2"):
        C.ps_rows(allowed, row_start, act, rc)


@SETTINGS
@given(
    n=st.integers(0, 40), n_act=st.integers(1, 4), distinct=st.integers(1, 300),
    max_codes=st.integers(0, 300), dtype=st.sampled_from([np.uint8, np.uint16, np.uint32]),
    seed=st.integers(0, 2**32 - 1),
)  # fmt: skip
def test_property_reward_codes_equal_twin(n, n_act, distinct, max_codes, dtype, seed):
    """The same codes (first appearance), table and count; -1 past max_codes; -0.0 and 0.0
    two values."""
    rng = np.random.default_rng(seed)
    values = np.concatenate([[0.0, -0.0, np.inf], rng.normal(size=distinct)])
    reward = values[rng.integers(0, values.size, size=(n, n_act))]
    max_codes = min(max_codes, np.iinfo(dtype).max + 1)
    results = []
    for kern in (C, T):
        codes, table = np.zeros((n, n_act), dtype=dtype), np.full(max(max_codes, 1), np.nan)
        count = kern.reward_codes(reward, max_codes, codes, table)
        results.append((count, codes, table))
    (kc, cc, tc), (kt, ct, tt) = results
    n_distinct = np.unique(reward.view(np.int64)).size
    assert kc == kt == (n_distinct if n_distinct <= max_codes else -1)
    if kc >= 0:
        assert same(cc, ct) and same(tc[:kc], tt[:kc]) and same(tc[cc], reward)


# ---------------------------------------------------------------------- aggregation
def exact_rows(rng, n: int, n_act: int, n_out: int, shared: bool, idx, frac: float):
    """The exact rows of a masked random MDP, as BellmanRows.from_mdp lays them out:
    repeated targets, zero probabilities, shared (broadcast) or per-row distributions."""
    succ = rng.integers(0, n, size=(n, n_act, n_out))
    if n_out > 1:
        succ[:, :, -1] = succ[:, :, 0]
    allowed = rng.random((n, n_act)) < frac
    allowed[np.arange(n), rng.integers(0, n_act, size=n)] = True
    xs, us = np.nonzero(allowed)
    if shared:
        p = rng.random(n_out) * (rng.random(n_out) < 0.7)
        p[0] += 0.05
        probs = np.broadcast_to(p / p.sum(), (xs.size, n_out))
    else:
        p = rng.random((xs.size, n_out)) * (rng.random((xs.size, n_out)) < 0.7)
        p[:, 0] += 0.05
        probs = p / p.sum(axis=1, keepdims=True)
    reward = rng.integers(-3, 4, size=xs.size) / 2.0  # ties: equal rows merge
    reward[rng.random(xs.size) < 0.2] = -0.0  # and -0.0 ties 0.0: the first is kept
    return xs.astype(idx), us.astype(np.int32), reward, succ[xs, us].astype(idx), probs


def canonical(kern, labels, state, action, succ, probs, n_act):
    n_rows, n_out = succ.shape
    out = (
        np.empty(n_rows, dtype=labels.dtype), np.empty((n_rows, n_out), dtype=labels.dtype),
        np.empty((n_rows, n_out)), np.empty(n_rows, dtype=np.int64),
        np.empty(n_rows, dtype=np.uint64),
    )  # fmt: skip
    kern.canonical_rows(labels, state, action, succ, probs, n_act, *out)
    return out


@SETTINGS
@given(
    n=st.integers(1, 60), n_act=st.integers(1, 4), n_out=st.integers(1, 7),
    m=st.integers(1, 12), shared=st.booleans(), idx=INDEX, label_idx=INDEX,
    frac=st.sampled_from([1.0, 0.6]), seed=st.integers(0, 2**32 - 1),
)  # fmt: skip
def test_property_aggregation_kernels_equal_twins(
    threads, n, n_act, n_out, m, shared, idx, label_idx, frac, seed
):
    """canonical_rows, bucket_order, sort_buckets, mark_groups and merge_groups, one after
    the other as BellmanRows.aggregate runs them, each on the same inputs both ways."""
    rng = np.random.default_rng(seed)
    state, action, reward, succ, probs = exact_rows(rng, n, n_act, n_out, shared, idx, frac)
    labels = rng.integers(0, min(m, n), size=n).astype(label_idx)
    got = canonical(C, labels, state, action, succ, probs, n_act)
    want = canonical(T, labels, state, action, succ, probs, n_act)
    for name, x, y in zip(("owner", "t", "p", "oa", "key"), got, want, strict=True):
        assert same(x, y), name
    owner, t, p, oa, key = got
    order, offsets = C.bucket_order(oa, m * n_act)
    order_t, offsets_t = T.bucket_order(oa, m * n_act)
    assert same(order, order_t) and same(offsets, offsets_t)
    for k in (key, key % np.uint64(3)):  # the hashes, and few keys (ties: stability)
        a, b = order.copy(), order.copy()
        C.sort_buckets(a, offsets, k)
        T.sort_buckets(b, offsets, k)
        assert same(a, b)
    C.sort_buckets(order, offsets, key)
    n_rows = order.size
    for k in (key, key % np.uint64(2)):  # the hashes, and collisions of different rows
        new_c, new_t = np.empty(n_rows, dtype=bool), np.empty(n_rows, dtype=bool)
        flag_c = C.mark_groups(order, oa, k, t, p.view(np.int64), new_c)
        flag_t = T.mark_groups(order, oa, k, t, p.view(np.int64), new_t)
        assert flag_c == flag_t and same(new_c, new_t)
    C.mark_groups(order, oa, key, t, p.view(np.int64), new_c)
    starts = np.append(np.flatnonzero(new_c), n_rows).astype(np.int64)
    g = starts.size - 1
    for use_max in (True, False):
        outs = []
        for kern in (C, T):
            out = (
                np.empty(n_rows, dtype=np.int64), np.empty(g), np.empty(g, dtype=owner.dtype),
                np.empty(g, dtype=np.int32), np.empty((g, n_out), dtype=t.dtype),
                np.empty((g, n_out)),
            )  # fmt: skip
            kern.merge_groups(order, starts, reward, use_max, owner, action, t, p, *out)
            outs.append(out)
        for name, x, y in zip(("group", "red", "owner", "action", "t", "p"), *outs, strict=True):
            assert same(x, y), name


def test_canonical_rows_against_a_plain_loop(threads):
    """Targets mapped and sorted stably, equal ones merged in order, zeros dropped, padded."""
    labels = np.array([2, 0, 2, 1], dtype=np.int32)
    succ = np.array([[0, 1, 2, 3], [3, 3, 1, 1], [1, 1, 1, 1]], dtype=np.int32)
    probs = np.array([[0.25, 0.5, 0.25, 0.0], [0.0, 0.0, 0.5, 0.5], [0.0, 0.0, 0.0, 0.0]])
    owner, t, p, oa, _ = canonical(
        C, labels, np.array([0, 1, 3], np.int32), np.array([1, 0, 2], np.int32), succ, probs, 3
    )
    assert owner.tolist() == [2, 0, 1] and oa.tolist() == [7, 0, 5]
    assert t.tolist() == [[0, 2, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]]
    assert p.tolist() == [[0.5, 0.5, 0, 0], [1.0, 0, 0, 0], [0, 0, 0, 0]]


# ---------------------------------------------------------------------- bad input
def test_bad_indices_raise_index_errors_naming_the_entry(threads):
    """Every index the kernels read is checked: a planted bad one gives IndexError with the
    argument and the entry, on whichever thread meets it (never a read outside a buffer)."""
    rng = np.random.default_rng(1)
    indptr, action, reward, targets, probs, v = row_system(rng, 10, 3, 3, False, np.int32, False)
    out, arg = np.empty(reward.size), np.empty(10, dtype=np.int64)
    bad = targets.copy()
    bad[-1, 2] = 10
    with pytest.raises(
        IndexError, match=rf"targets\[{reward.size - 1}, 2\] = 10 is outside \[0, 10\)"
    ):
        C.q_values(reward, bad, probs, 0.9, v, out)
    bad[-1, 2] = -1
    with pytest.raises(IndexError, match=r"targets\[\d+, 2\] = -1"):
        C.bellman_maxmin(indptr, action, reward, bad, probs, 0.9, v, out[:10], arg)
    succ, allowed = post_decision(rng, 20, 2, 3, np.int32, 1.0)
    bad_succ = succ.copy()
    bad_succ[19, 1, 0] = 20
    with pytest.raises(IndexError, match=r"succ\[19, 1, 0\] = 20"):
        C.ps_mark(bad_succ, allowed, np.zeros(20, dtype=bool))
    _, post_id, outcomes, first = post_form(C, succ, allowed, np.int32)
    with pytest.raises(IndexError, match=r"succ\[19, 1, 0\] = 20"):
        C.ps_fill(bad_succ, allowed, post_id, outcomes.copy(), first.copy())
    stale = post_id.copy()
    stale[succ[0, 0, 0]] = outcomes.shape[0]
    with pytest.raises(IndexError, match=r"post_id\[\d+\] = \d+ is outside"):
        C.ps_fill(succ, allowed, stale, outcomes.copy(), first.copy())
    bad_first = first.copy()
    bad_first[5, 1] = outcomes.shape[0]
    with pytest.raises(IndexError, match=r"first\[5, 1\]"):
        C.ps_verify(succ, bad_first, outcomes)
    bad_oc = outcomes.copy()
    bad_oc[0, 2] = -5
    with pytest.raises(IndexError, match=r"outcomes\[0, 2\] = -5"):
        C.ps_expect(bad_oc, np.full(3, 1 / 3), np.zeros(20), np.empty(outcomes.shape[0]))
    w, rew, o20 = np.zeros(outcomes.shape[0]), np.zeros((20, 2)), np.empty(20)
    with pytest.raises(IndexError, match=r"first\[5, 1\]"):
        C.ps_max_stats(bad_first, rew, w, 0.9, np.zeros(20), o20, np.zeros(20, np.int8))
    act = np.zeros(20, dtype=np.int8)
    act[7] = 2
    with pytest.raises(IndexError, match=r"act\[7\] = 2 is outside \[0, 2\)"):
        C.ps_policy_stats(first, rew, act, w, 0.9, np.zeros(20), o20)
    with pytest.raises(IndexError, match=r"act\[7\] = 2"):
        C.ps_rows(allowed, np.zeros(20, np.int64), act, np.empty(20, np.int64))
    masked = first.copy()
    masked[3, 0] = -1
    with pytest.raises(IndexError, match=r"act\[3\] = 0 is not allowed"):
        C.ps_policy_stats(masked, rew, np.zeros(20, np.int8), w, 0.9, np.zeros(20), o20)
    codes = np.zeros((20, 2), dtype=np.uint8)
    codes[4, 1] = 3
    with pytest.raises(IndexError, match=r"codes\[4, 1\] = 3 is outside \[0, 3\)"):
        C.ps_max_stats_coded(first, codes, np.zeros(3), w, 0.9, np.zeros(20), o20, act.copy())
    with pytest.raises(IndexError, match=r"codes\[4, 1\] = 3"):
        C.ps_policy_stats_coded(
            first, codes, np.zeros(3), np.ones(20, np.int8), w, 0.9, np.zeros(20), o20
        )


def test_bad_aggregation_inputs_raise_typed_errors(threads):
    rng = np.random.default_rng(2)
    state, action, reward, succ, probs = exact_rows(rng, 12, 2, 3, False, np.int32, 1.0)
    labels = rng.integers(0, 4, size=12).astype(np.int32)
    bad = succ.copy()
    bad[3, 1] = 12
    with pytest.raises(IndexError, match=r"succ\[3, 1\] = 12 is outside \[0, 12\)"):
        canonical(C, labels, state, action, bad, probs, 2)
    bad_state = state.copy()
    bad_state[-1] = -2
    with pytest.raises(IndexError, match=r"state\[\d+\] = -2"):
        canonical(C, labels, bad_state, action, succ, probs, 2)
    owner, t, p, oa, key = canonical(C, labels, state, action, succ, probs, 2)
    with pytest.raises(IndexError, match=r"oa\[\d+\] = \d+ is outside \[0, 7\)"):
        C.bucket_order(oa, 7)
    order, _ = C.bucket_order(oa, 8)
    wild = order.copy()
    wild[0] = order.size
    with pytest.raises(IndexError, match=rf"order\[0\] = {order.size}"):
        C.sort_buckets(wild, np.array([0, order.size], np.int64), key)
    with pytest.raises(ValueError, match=r"offsets\[1\] = .* non-decreasing"):
        C.sort_buckets(order.copy(), np.array([0, order.size + 1], np.int64), key)
    new = np.empty(order.size, dtype=bool)
    with pytest.raises(IndexError, match=rf"order\[0\] = {order.size}"):
        C.mark_groups(wild, oa, key, t, p.view(np.int64), new)
    n_rows, g = order.size, 2
    out = (
        np.empty(n_rows, np.int64), np.empty(g), np.empty(g, np.int32), np.empty(g, np.int32),
        np.empty((g, 3), np.int32), np.empty((g, 3)),
    )  # fmt: skip
    with pytest.raises(ValueError, match=r"starts\[1\] = 0 does not start or end a group"):
        C.merge_groups(order, np.array([0, 0, n_rows]), reward, True, owner, action, t, p, *out)
    with pytest.raises(IndexError, match=rf"order\[0\] = {n_rows}"):
        C.merge_groups(wild, np.array([0, 1, n_rows]), reward, True, owner, action, t, p, *out)
    # the game operator's offsets
    indptr = np.array([0, 2, 1], dtype=np.int64)
    with pytest.raises(ValueError, match=r"indptr\[2\] = 1 is not an offset of rows"):
        C.bellman_maxmin(
            indptr, action[:2], reward[:2], succ[:2], probs[:2], 0.9, np.zeros(12),
            np.empty(2), np.empty(2, np.int64),
        )  # fmt: skip


def test_wrong_dtypes_and_shapes_raise_typed_errors():
    rng = np.random.default_rng(3)
    indptr, action, reward, targets, probs, v = row_system(rng, 5, 2, 2, False, np.int32, False)
    out = np.empty(reward.size)
    with pytest.raises(TypeError, match=r"targets: expected a 2-dimensional integer array"):
        C.q_values(reward, targets.astype(float), probs, 0.9, v, out)
    with pytest.raises(TypeError, match=r"out: expected a 1-dimensional float64 array"):
        C.q_values(reward, targets, probs, 0.9, v, out.astype(np.float32))
    with pytest.raises(TypeError, match=r"out: expected a writable array"):
        ro = np.empty(reward.size)
        ro.flags.writeable = False
        C.q_values(reward, targets, probs, 0.9, v, ro)
    with pytest.raises(ValueError, match="out needs one entry per row"):
        C.q_values(reward, targets, probs, 0.9, v, out[:-1])
    with pytest.raises(ValueError, match="rows differ"):
        C.q_values(reward[:-1], targets, probs, 0.9, v, out[:-1])
    with pytest.raises(TypeError, match=r"out: not C-contiguous"):
        C.q_values(reward, targets, probs, 0.9, v, np.empty(2 * reward.size)[::2])
    succ, allowed = post_decision(rng, 6, 2, 2, np.int32, 1.0)
    with pytest.raises(TypeError, match=r"first: expected a 2-dimensional integer array"):
        C.ps_fill(succ, allowed, np.arange(6, dtype=np.int32), np.empty((6, 2), np.int32),
                  np.empty((6, 2), np.int64))  # fmt: skip
    with pytest.raises(ValueError, match=r"max_codes: more codes than the dtype"):
        C.reward_codes(np.zeros((3, 2)), 257, np.empty((3, 2), np.uint8), np.empty(257))
    with pytest.raises(TypeError, match=r"codes: expected a 2-dimensional unsigned integer array"):
        C.reward_codes(np.zeros((3, 2)), 4, np.empty((3, 2), np.int16), np.empty(4))
    from lpbounds._kernels import rowkernels

    with pytest.raises(ValueError, match=r"range \[0, 9\) is not within \[0, 5\]"):
        rowkernels.bellman_maxmin(
            indptr, action, reward, targets, probs, 0.9, v, np.empty(5), np.empty(5, np.int64),
            0, 9,
        )  # fmt: skip
