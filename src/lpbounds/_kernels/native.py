"""The Bellman-row sweeps compiled ahead of time, run on threads.

The hot loops of exact DP on a row system (:class:`lpbounds.rows.BellmanRows`: the
improvement sweep, the policy-evaluation sweep, the gather of a policy's rows) and the
successor check of :class:`~lpbounds.model.mdp.FiniteMDP` are C functions in
:mod:`lpbounds._kernels.rowsweeps`, built when lpbounds is installed. Each works on one
range of owners and releases the GIL; the functions here split the owners into one range
per thread (equal shares of rows), run the first range on the calling thread and the
others on a pool, and combine the ranges' extremes (exact minima and maxima, so the
split changes no number).

Why C compiled at install, as every kernel of lpbounds is (``extensions``): when these
sweeps were numba's, a process that solved one mid-size model paid about 0.2 s to import
numba and 0.3-0.4 s for its first call of a cached kernel (its typing and target
registries, and an import of :mod:`scipy.linalg` for its BLAS check) — more than the
solve of a 256,000-state model takes (``docs/benchmarks.md``, "Peers: exact DP"). These
sweeps need neither, and run faster than their numba versions did (2.9 against 4.9 ms for
an improvement sweep of the 256,000 x 3 x 5 garnet on two threads: the loop over a shared
distribution's outcomes is unrolled).

The arithmetic is that of the numpy twins (:mod:`lpbounds._kernels.twins`), so the
numbers are bit-identical to theirs and to what the numba versions gave
(``tests/dp/test_fast_paths.py``).

The C functions check every index they read, so that no input reaches memory outside its
array when :mod:`lpbounds._kernels.rowsweeps` is called directly (the row systems built by
lpbounds are valid by construction; ``tests/kernels/test_native_bounds.py`` fuzzes the rest): an
``indptr`` outside ``[0, R]`` or decreasing raises ValueError, a target outside ``v`` or a
row of ``rows`` / ``sel`` outside the rows IndexError, naming the entry. The owners are
swept in blocks of 256; a target is checked as it is read (a branch never taken on valid
rows, on which no load waits), except in the improvement sweep with a shared distribution,
which the branch slows by half and which checks its block's targets first (a branch-free
scan, the block then swept from cache). The numbers are unchanged. Measured beside the
sweeps (2026-12-03, the 256,000 x 3 x 5 garnet, one range on one thread, CPU time, 80
interleaved calls of the unchecked and the checked builds, on a shared 2-core machine):
the checks add 12 % to an improvement sweep and 8 % to a policy sweep with a shared
distribution (7.96 against 7.07 ms, 3.89 against 3.64 ms), 10 % and 14 % with one
distribution per row (12.56 against 11.43 ms, 6.69 against 5.85 ms); ``solve_exact`` of
that garnet (MPI, two threads, 16 interleaved solves) 11 % and 14 % (0.189 against 0.172
s, 0.416 against 0.380 s); repeated runs varied by about 5 points. Checking every block
first instead cost 26-48 % of the shared sweeps; checking during every loop, 113 % of the
shared improvement sweep.

Threads, ranges and the pool are :mod:`lpbounds._kernels.threads`' (``get_threads`` /
``set_threads`` are re-exported here).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .extensions import rowsweeps as _c
from .threads import default_threads, get_threads, run_ranges, set_threads, split_ranges

__all__ = [
    "bellman_max_stats",
    "check_successors",
    "default_threads",
    "gather_rows",
    "get_threads",
    "policy_sweep_stats",
    "set_threads",
]


def _i8(a: Any) -> np.ndarray:
    """An index input as the C functions read it (no copy when it already is one)."""
    return np.ascontiguousarray(a, dtype=np.int64)


def _f8(a: Any) -> np.ndarray:
    """A float input as the C functions read it (no copy when it already is one)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def _extremes(pairs: list[tuple[float, float]]) -> tuple[float, float]:
    return min(p[0] for p in pairs), max(p[1] for p in pairs)


def bellman_max_stats(
    indptr: np.ndarray, reward: np.ndarray, targets: np.ndarray, probs: np.ndarray,
    discount: float, v: np.ndarray, out: np.ndarray, arg: np.ndarray,
) -> tuple[float, float]:  # fmt: skip
    """``out[i] = max_r q_r`` over owner ``i``'s rows, ``arg[i]`` the first maximising row;
    returns the min and max of ``out - v`` (one range of owners per thread)."""
    indptr = _i8(indptr)
    args = (indptr, _f8(reward), targets, probs, float(discount), _f8(v), out, arg)
    bounds = split_ranges(indptr.shape[0] - 1, indptr)
    return _extremes(run_ranges(_c.bellman_max_stats, args, bounds))


def policy_sweep_stats(
    rows: np.ndarray | None, reward: np.ndarray, targets: np.ndarray, probs: np.ndarray,
    discount: float, v: np.ndarray, out: np.ndarray,
) -> tuple[float, float]:  # fmt: skip
    """``out[i] = q_{rows[i]}(v)`` (one policy-evaluation sweep; ``rows`` None: ``q_i``, the
    rows packed one per owner); returns the min and max of ``out - v``. Raises IndexError
    for an entry of ``rows`` that is not a row."""
    rows = None if rows is None else _i8(rows)
    n = out.shape[0] if rows is None else rows.shape[0]
    args = (rows, _f8(reward), targets, probs, float(discount), _f8(v), out)
    return _extremes(run_ranges(_c.policy_sweep_stats, args, split_ranges(n)))


def gather_rows(
    sel: np.ndarray, reward: np.ndarray, targets: np.ndarray, probs: np.ndarray,
    out_reward: np.ndarray, out_targets: np.ndarray, out_probs: np.ndarray, copy_probs: bool,
) -> None:  # fmt: skip
    """Row ``sel[i]`` into slot ``i`` of the ``out_*`` arrays (``out_probs`` only when
    ``copy_probs``; a shared distribution is not copied)."""
    sel = _i8(sel)
    args = (sel, _f8(reward), targets, probs, out_reward, out_targets, out_probs, bool(copy_probs))
    run_ranges(_c.gather_rows, args, split_ranges(sel.shape[0]))


def check_successors(succ: np.ndarray, allow: np.ndarray, n: int) -> tuple[int, int, int]:
    """Out-of-range successors of an MDP: (count on allowed pairs, first flat index, count
    elsewhere), for :class:`lpbounds.model.mdp.FiniteMDP`; one pass, no temporaries (but a
    C-contiguous copy of a strided ``succ``)."""
    succ, allow = np.ascontiguousarray(succ), np.ascontiguousarray(allow, dtype=np.bool_)
    parts = run_ranges(_c.check_successors, (succ, allow, int(n)), split_ranges(succ.shape[0]))
    firsts = [p[1] for p in parts if p[1] >= 0]
    return sum(p[0] for p in parts), (firsts[0] if firsts else -1), sum(p[2] for p in parts)
