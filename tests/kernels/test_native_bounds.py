"""The C row sweeps check their own indices: no input reaches memory outside its array.

:mod:`lpbounds._kernels.rowsweeps` is importable, so its functions can be called with any
arrays. A target outside ``v``, an ``indptr`` outside the rows or decreasing, an entry of
``rows`` / ``sel`` outside the rows must raise (IndexError / ValueError) and never crash the
interpreter. The fuzz runs in a child process, so that a crash fails the test (a signal
exit) instead of killing the test run; the messages are checked in this process.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from lpbounds._kernels import rowsweeps as C

FUZZ = textwrap.dedent(
    """
    import sys
    import numpy as np
    from lpbounds._kernels import rowsweeps as C

    rng = np.random.default_rng(int(sys.argv[1]))
    raised = ok = 0
    for case in range(int(sys.argv[2])):
        n = int(rng.integers(0, 40))
        L = int(rng.integers(0, 11))
        counts = rng.integers(0, 4, size=n)
        indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        R = int(indptr[-1]) + int(rng.integers(0, 3))
        t64 = bool(rng.integers(2))
        nv = max(n, int(rng.integers(0, 50)))
        targets = rng.integers(0, max(nv, 1), size=(R, L)).astype(np.int64 if t64 else np.int32)
        if nv == 0:
            targets[:] = 0
        shared = bool(rng.integers(2)) and L > 0
        if shared:
            probs = np.broadcast_to(np.full(L, 1.0 / L), (R, L))
        else:
            probs = rng.random((R, L))
        reward = rng.normal(size=R)
        v = rng.normal(size=nv)
        sel = rng.integers(0, max(R, 1), size=n).astype(np.int64)
        # one corruption per case (or none)
        kind = int(rng.integers(0, 9))
        big = [-1, -(2**31), 2**31 - 1, nv, nv + 1, 10**9, -(10**12), 2**62]
        value = big[int(rng.integers(len(big)))]
        if kind == 1 and targets.size:
            if not t64:
                value = int(np.clip(value, -(2**31), 2**31 - 1))
            targets[rng.integers(R), rng.integers(L)] = value
        elif kind == 2:
            indptr[rng.integers(indptr.size)] = value
        elif kind == 3 and n:
            sel[rng.integers(n)] = value
        elif kind == 4 and n > 1:
            indptr[1:-1] = indptr[1:-1][::-1]  # decreasing somewhere
        elif kind == 5:
            v = v[: max(0, nv - int(rng.integers(1, 5)))]
        elif kind == 6:
            indptr[-1] = R + int(rng.integers(1, 100))
        start = int(rng.integers(0, n + 1))
        end = int(rng.integers(start, n + 1))
        out = np.zeros(max(n, 0))
        arg = np.zeros(max(n, 0), dtype=np.int64)
        rows = (reward, targets, probs)
        gathered = (np.zeros(n), np.zeros((n, L), targets.dtype), np.zeros((n, L)), True)
        calls = [
            lambda: C.bellman_max_stats(indptr, *rows, 0.9, v, out, arg, start, end),
            lambda: C.policy_sweep_stats(sel, *rows, 0.9, v, out, start, end),
            lambda: C.policy_sweep_stats(None, *rows, 0.9, v, out, start, end),
            lambda: C.gather_rows(sel, *rows, *gathered, start, end),
        ]
        for call in calls:
            try:
                call()
                ok += 1
            except (IndexError, ValueError, TypeError):
                raised += 1
    print(ok, raised)
    """
)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fuzzed_indices_raise_and_never_crash(seed, tmp_path):
    """Thousands of calls with one index corrupted (targets, indptr, rows, sel, a short v):
    the child process ends normally (a crash would end it by a signal), and both calls
    that raise and calls that succeed were made."""
    script = tmp_path / "fuzz.py"
    script.write_text(FUZZ)
    proc = subprocess.run(
        [sys.executable, str(script), str(seed), "1500"], capture_output=True, text=True
    )
    assert proc.returncode == 0, (proc.returncode, proc.stderr[-2000:])
    ok, raised = (int(t) for t in proc.stdout.split())
    assert ok > 100 and raised > 100


def _rows(n=4, L=3, t64=False, shared=False):
    rng = np.random.default_rng(0)
    indptr = np.arange(0, 2 * n + 1, 2, dtype=np.int64)
    R = int(indptr[-1])
    targets = rng.integers(0, n, size=(R, L)).astype(np.int64 if t64 else np.int32)
    probs = np.broadcast_to(np.full(L, 1.0 / L), (R, L)) if shared else np.full((R, L), 1.0 / L)
    return indptr, rng.normal(size=R), targets, probs, rng.normal(size=n)


@pytest.mark.parametrize("t64", [False, True])
@pytest.mark.parametrize("shared", [False, True])
@pytest.mark.parametrize("bad", [-1, 4, 2**31 - 1, -(2**31)])
def test_a_target_outside_v_raises_naming_it(t64, shared, bad):
    indptr, reward, targets, probs, v = _rows(t64=t64, shared=shared)
    targets[5, 2] = bad
    out, arg = np.zeros(4), np.zeros(4, dtype=np.int64)
    msg = rf"targets\[5, 2\] = {bad} is not an entry of v \(0\.\.3\)"
    with pytest.raises(IndexError, match=msg):
        C.bellman_max_stats(indptr, reward, targets, probs, 0.9, v, out, arg, 0, 4)
    with pytest.raises(IndexError, match=msg):
        C.policy_sweep_stats(np.array([0, 1, 5, 2]), reward, targets, probs, 0.9, v, out, 0, 4)
    # a range that does not reach the bad row sweeps normally
    lo, hi = C.bellman_max_stats(indptr, reward, targets, probs, 0.9, v, out, arg, 0, 2)
    assert np.isfinite(lo) and np.isfinite(hi)


@pytest.mark.parametrize(("at", "value"), [(0, -1), (2, 1), (4, 9), (3, 100), (1, 5)])
def test_a_bad_indptr_raises_naming_the_entry(at, value):
    indptr, reward, targets, probs, v = _rows()
    indptr[at] = value
    out, arg = np.zeros(4), np.zeros(4, dtype=np.int64)
    with pytest.raises(ValueError, match=r"indptr\[\d\] = -?\d+: the rows of an owner"):
        C.bellman_max_stats(indptr, reward, targets, probs, 0.9, v, out, arg, 0, 4)


def test_no_entry_in_v_and_no_row():
    """``v`` empty: any target is outside it; no row at all: nothing is read (a shared
    distribution of zero rows is not read either)."""
    indptr, reward, targets, probs, v = _rows()
    out, arg = np.zeros(4), np.zeros(4, dtype=np.int64)
    with pytest.raises(ValueError, match="one entry per owner"):
        C.bellman_max_stats(indptr, reward, targets, probs, 0.9, v[:0], out, arg, 0, 4)
    lo, hi = C.bellman_max_stats(
        np.zeros(3, dtype=np.int64), np.zeros(0), np.zeros((0, 3), np.int32),
        np.broadcast_to(np.full(3, 1 / 3), (0, 3)), 0.9, np.zeros(2), np.zeros(2),
        np.zeros(2, dtype=np.int64), 0, 2,
    )  # fmt: skip
    assert (lo, hi) == (-np.inf, -np.inf) and np.array_equal(out, [0, 0, 0, 0])
