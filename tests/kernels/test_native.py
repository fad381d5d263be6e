"""The C row sweeps (:mod:`lpbounds._kernels.native`) against their numpy twins, bit for bit.

The twins (:mod:`lpbounds._kernels.twins`) are the reference arithmetic; the C functions
claim the same numbers for every layout they accept: int32 and int64 targets, a shared
distribution (a stride-0 view, the unrolled loops for 1-8 outcomes) or one per row, 9 and
more outcomes (the general loop), and any split of the owners over threads. The solves
built on them are compared in ``tests/dp/test_fast_paths.py``.
"""

from __future__ import annotations

import multiprocessing
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lpbounds._kernels import dispatch, native
from lpbounds._kernels import rowsweeps as C
from lpbounds._kernels import twins as T


def bits(x) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64).view(np.int64)


def random_rows(n: int, max_rows: int, n_out: int, shared: bool, t64: bool, seed: int):
    """A row system: owners with 1..max_rows rows (no row system has an owner without),
    targets in [0, n), rewards on a wide scale, probabilities shared (a broadcast view)
    or one distribution per row."""
    rng = np.random.default_rng(seed)
    counts = rng.integers(1, max_rows + 1, size=n)
    indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    n_rows = int(indptr[-1])
    targets = rng.integers(0, n, size=(n_rows, n_out)).astype(np.int64 if t64 else np.int32)
    reward = rng.normal(size=n_rows) * 10.0 ** rng.integers(-3, 4, size=n_rows)
    if shared:
        p = rng.random(n_out) + 0.01
        probs = np.broadcast_to(p / p.sum(), (n_rows, n_out))
    else:
        p = rng.random((n_rows, n_out)) + 0.01
        probs = p / p.sum(axis=1, keepdims=True)
    v = rng.normal(size=n) * 100
    return indptr, reward, targets, probs, v


@pytest.fixture(params=[1, 2], ids=["1 thread", "2 threads"])
def threads(request):
    """Run on one thread and on two (the owners split in two ranges)."""
    before = native.get_threads()
    if request.param > native.default_threads():
        pytest.skip("one CPU")
    native.set_threads(request.param)
    yield request.param
    native.set_threads(before)


def max_both(indptr, reward, targets, probs, lam, v):
    n = indptr.size - 1
    got = []
    for mod in (T, native):
        out, arg = np.full(n, np.nan), np.full(n, -7, dtype=np.int64)
        lo, hi = mod.bellman_max_stats(indptr, reward, targets, probs, lam, v, out, arg)
        got.append((out, arg, float(lo), float(hi)))
    return got


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 60),
    max_rows=st.integers(1, 4),
    n_out=st.integers(1, 11),
    shared=st.booleans(),
    t64=st.booleans(),
    lam=st.sampled_from([0.0, 0.5, 0.9, 0.999]),
    seed=st.integers(0, 10**6),
)
def test_property_native_max_sweep_equals_twin(n, max_rows, n_out, shared, t64, lam, seed):
    indptr, reward, targets, probs, v = random_rows(n, max_rows, n_out, shared, t64, seed)
    for k in sorted({1, min(2, native.default_threads())}):
        native.set_threads(k)
        try:
            (oa, aa, la, ha), (ob, ab, lb_, hb) = max_both(indptr, reward, targets, probs, lam, v)
        finally:
            native.set_threads(native.default_threads())
        assert np.array_equal(bits(oa), bits(ob)), "T v differs"
        assert np.array_equal(aa, ab), "the maximising rows differ"
        assert (la, ha) == (lb_, hb)


def test_native_max_sweep_against_a_plain_loop(threads):
    # an independent loop, row by row: the value, the first maximising row, the extremes
    indptr, reward, targets, probs, v = random_rows(40, 3, 5, True, False, seed=1)
    (_, _, _, _), (out, arg, lo, hi) = max_both(indptr, reward, targets, probs, 0.9, v)
    for i in range(40):
        rows = range(indptr[i], indptr[i + 1])
        qs = []
        for r in rows:
            acc = 0.0
            for ll in range(5):
                acc += float(probs[r, ll]) * float(v[targets[r, ll]])
            qs.append(float(reward[r]) + 0.9 * acc)
        assert out[i] == max(qs) and arg[i] == indptr[i] + int(np.argmax(qs))
    d = out - v
    assert lo == d.min() and hi == d.max()


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 60),
    n_out=st.integers(1, 11),
    shared=st.booleans(),
    t64=st.booleans(),
    seed=st.integers(0, 10**6),
)
def test_property_native_policy_sweep_and_gather_equal_twins(n, n_out, shared, t64, seed):
    _, reward, targets, probs, v = random_rows(n, 3, n_out, shared, t64, seed)
    rng = np.random.default_rng(seed + 1)
    sel = rng.integers(0, max(1, reward.size), size=n).astype(np.int64)
    if reward.size == 0:
        return
    res = []
    for mod in (T, native):
        out = np.full(n, np.nan)
        lo, hi = mod.policy_sweep_stats(sel, reward, targets, probs, 0.95, v, out)
        g_rew, g_t = np.empty(n), np.empty((n, n_out), dtype=targets.dtype)
        g_p = np.empty((n, n_out))
        mod.gather_rows(sel, reward, targets, probs, g_rew, g_t, g_p, not shared)
        res.append((out, float(lo), float(hi), g_rew, g_t, g_p if not shared else None))
    (oa, la, ha, ra, ta, pa), (ob, lb_, hb, rb, tb, pb) = res
    assert np.array_equal(bits(oa), bits(ob)) and (la, ha) == (lb_, hb)
    assert np.array_equal(bits(ra), bits(rb)) and np.array_equal(ta, tb)
    if pa is not None:
        assert np.array_equal(bits(pa), bits(pb))
    # the packed rows (rows=None: row i of the gathered arrays) give the same sweep
    packed_p = np.broadcast_to(probs[0], (n, n_out)) if shared else pb
    for mod in (T, native):
        out = np.full(n, np.nan)
        lo, hi = mod.policy_sweep_stats(None, rb, tb, packed_p, 0.95, v, out)
        assert np.array_equal(bits(out), bits(ob)) and (float(lo), float(hi)) == (lb_, hb)


def test_native_check_successors_equals_twin(threads):
    rng = np.random.default_rng(3)
    for dtype in (np.int32, np.int64):
        succ = rng.integers(-2, 12, size=(29, 3, 4)).astype(dtype)
        allow = rng.random((29, 3)) < 0.6
        want = T.check_successors(succ, allow, 10)
        assert native.check_successors(succ, allow, 10) == want
        assert want[0] > 0 and want[2] > 0  # both kinds occur: the test can fail
        # a strided view (FiniteMDP checks the caller's array before copying it)
        view = np.concatenate([succ, succ], axis=2)[:, :, ::2]
        assert native.check_successors(view, allow, 10) == T.check_successors(view, allow, 10)
        ok = rng.integers(0, 10, size=(29, 3, 4)).astype(dtype)
        assert native.check_successors(ok, allow, 10) == (0, -1, 0)


def test_native_sweeps_refuse_what_they_cannot_read():
    indptr, reward, targets, probs, v = random_rows(10, 2, 3, True, False, seed=0)
    out, arg = np.empty(10), np.empty(10, dtype=np.int64)
    with pytest.raises(TypeError, match="arg"):
        a32 = arg.astype(np.int32)
        C.bellman_max_stats(indptr, reward, targets, probs, 0.9, v, out, a32, 0, 10)
    with pytest.raises(TypeError, match="out"):
        C.bellman_max_stats(indptr, reward, targets, probs, 0.9, v, out[::2], arg, 0, 5)
    with pytest.raises(TypeError, match="out"):
        ro = np.empty(10)
        ro.flags.writeable = False
        C.bellman_max_stats(indptr, reward, targets, probs, 0.9, v, ro, arg, 0, 10)
    with pytest.raises(TypeError, match="targets"):
        C.bellman_max_stats(indptr, reward, targets.astype(float), probs, 0.9, v, out, arg, 0, 10)
    with pytest.raises(TypeError, match="v"):  # the other byte order: not read as numbers
        swapped = v.astype(v.dtype.newbyteorder())
        C.bellman_max_stats(indptr, reward, targets, probs, 0.9, swapped, out, arg, 0, 10)
    with pytest.raises(ValueError, match="range"):
        C.bellman_max_stats(indptr, reward, targets, probs, 0.9, v, out, arg, 0, 11)
    with pytest.raises(IndexError, match=r"rows\[3\] = 99"):
        sel = np.zeros(10, np.int64)
        sel[3] = 99
        native.policy_sweep_stats(sel, reward, targets, probs, 0.9, v, out)
    with pytest.raises(IndexError, match=r"sel\[0\] = -1"):
        g = np.empty((10, 3), dtype=targets.dtype)
        native.gather_rows(-np.ones(10, np.int64), reward, targets, probs, out, g, g, False)
    with pytest.raises(ValueError, match="rows differ"):
        sel = np.zeros(10, np.int64)
        C.policy_sweep_stats(sel, reward[:-1], targets, probs, 0.9, v, out, 0, 10)


def test_thread_count_is_shared_by_every_c_kernel():
    # dispatch's count drives every C kernel: after set_threads(1) the native sweeps and the
    # row kernels (lpbounds._kernels.ckernels) run on one thread; restored after
    from lpbounds._kernels import ckernels, threads

    before = dispatch.get_threads()
    assert before == native.get_threads() == threads.get_threads()
    try:
        dispatch.set_threads(1)
        assert native.get_threads() == 1 and dispatch.get_threads() == 1
        assert threads.split_ranges(10 * ckernels.PARALLEL_READS).size == 2  # one range
    finally:
        dispatch.set_threads(before)
    assert dispatch.get_threads() == before
    with pytest.raises(ValueError, match="threads"):
        native.set_threads(native.default_threads() + 1)


def _sweep_in_child(n: int) -> float:
    native.set_threads(min(2, native.default_threads()))
    indptr, reward, targets, probs, v = random_rows(n, 3, 5, True, False, seed=4)
    out, arg = np.empty(n), np.empty(n, dtype=np.int64)
    return native.bellman_max_stats(indptr, reward, targets, probs, 0.9, v, out, arg)[1]


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this platform")
def test_a_forked_child_makes_its_own_pool():
    """The pool's threads do not survive a fork: a child that reused the parent's pool would
    wait for ever on the range it submitted. It makes its own (and gets the same number)."""
    want = _sweep_in_child(5_000)  # the parent's pool now exists
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(1) as pool:
        got = pool.apply_async(_sweep_in_child, (5_000,)).get(timeout=120)
    assert got == want
