"""The one thread pool and thread count of lpbounds' compiled kernels.

Every compiled kernel works on one range of its owners (states, rows, outcomes) and
releases the GIL; :func:`split_ranges` cuts the owners into one range per thread and
:func:`run_ranges` runs the first range on the calling thread and the others on a pool
made once per process (a forked child makes its own). The thread count is
:func:`get_threads`: ``NUMBA_NUM_THREADS`` if set (numba's rule, kept so a user's setting
still applies), else the CPUs this process may run on; :func:`set_threads` changes it.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as _wait
from typing import Any

import numpy as np

__all__ = [
    "default_threads",
    "get_threads",
    "run_ranges",
    "set_threads",
    "split_ranges",
    "workers",
]


def default_threads() -> int:
    """numba's default thread count: ``NUMBA_NUM_THREADS``, else the usable CPUs."""
    env = os.environ.get("NUMBA_NUM_THREADS", "").strip()
    if env.isdigit() and int(env) > 0:
        return int(env)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - no sched_getaffinity (macOS, Windows)
        return max(1, os.cpu_count() or 1)


_threads: int | None = None  # None: default_threads()
_pool: ThreadPoolExecutor | None = None
_pool_pid = -1  # the process that made the pool (a forked child makes its own)


def get_threads() -> int:
    """Threads the sweeps of this module use."""
    return default_threads() if _threads is None else _threads


def set_threads(k: int) -> None:
    """Use ``k`` threads (1 to :func:`default_threads`, as numba allows)."""
    global _threads
    limit = default_threads()
    if not 1 <= int(k) <= limit:
        raise ValueError(f"threads must be between 1 and {limit}; got {k}")
    _threads = int(k)


def workers() -> ThreadPoolExecutor:
    """The pool of the ranges after the first (made once per process)."""
    global _pool, _pool_pid
    if _pool is None or _pool_pid != os.getpid():
        _pool = ThreadPoolExecutor(
            max_workers=max(1, default_threads() - 1), thread_name_prefix="lpbounds-sweep"
        )
        _pool_pid = os.getpid()
    return _pool


def run_ranges(func: Callable[..., Any], args: tuple[Any, ...], bounds: np.ndarray) -> list[Any]:
    """``func(*args, start, end)`` for each consecutive pair of ``bounds``; results in order.

    The first range runs here, the others on the pool; all are waited for before this
    returns or raises (a Ctrl-C while they run leaves no thread writing into the arrays).
    """
    edges = [int(b) for b in bounds]
    if len(edges) <= 2:
        return [func(*args, edges[0], edges[-1])]
    pool = workers()
    futures: list[Future[Any]] = [
        pool.submit(func, *args, a, b) for a, b in itertools.pairwise(edges[1:])
    ]
    try:
        first = func(*args, edges[0], edges[1])
    finally:
        _wait(futures)
    return [first, *(f.result() for f in futures)]


def split_ranges(n: int, indptr: np.ndarray | None = None) -> np.ndarray:
    """Range bounds over ``n`` owners, one range per thread: equal numbers of rows
    (``indptr``) or of owners."""
    k = min(get_threads(), max(1, n))
    share = np.arange(k + 1, dtype=np.int64)
    if indptr is None:
        return share * n // k
    # integer targets: a float array would make searchsorted convert all of indptr; the
    # targets below indptr[-1] give owners in [0, n], in order
    cuts = np.searchsorted(indptr, share * int(indptr[-1]) // k)
    cuts[0], cuts[-1] = 0, n
    return cuts
