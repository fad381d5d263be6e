"""The one thread pool and thread count of lpbounds' compiled kernels.

Every compiled kernel works on one range of its owners (states, rows, outcomes) and
releases the GIL; :func:`split_ranges` cuts the owners into one range per thread and
:func:`run_ranges` runs the first range on the calling thread and the others on a pool
made once per process (a forked child makes its own). The thread count is
:func:`get_threads`: the environment's ``LPBOUNDS_NUM_THREADS`` if set, else the CPUs this
process may run on; :func:`set_threads` changes it within the process.

``NUMBA_NUM_THREADS`` is still read when ``LPBOUNDS_NUM_THREADS`` is not set: the kernels
were numba's until issue 39, whose thread count that variable set, and job scripts that
limit lpbounds on a shared machine with it keep doing so (dropping it silently would give
such a job every CPU of the node). numba itself is no longer used.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as _wait
from typing import Any

import numpy as np

from ..errors import ValidationError

__all__ = [
    "THREAD_VARIABLES",
    "default_threads",
    "get_threads",
    "run_ranges",
    "set_threads",
    "split_ranges",
    "workers",
]


#: The environment variables that set the thread count, the first one set winning.
THREAD_VARIABLES: tuple[str, ...] = ("LPBOUNDS_NUM_THREADS", "NUMBA_NUM_THREADS")


def default_threads() -> int:
    """The thread count of the environment: the first of :data:`THREAD_VARIABLES` that is
    set (and not empty), else the CPUs this process may run on.

    Raises
    ------
    ValidationError
        When that variable is not a positive integer (a typo must not give a job every
        CPU of a shared machine).
    """
    for name in THREAD_VARIABLES:
        env = os.environ.get(name, "").strip()
        if not env:
            continue
        if not (env.isdigit() and int(env) > 0):
            raise ValidationError(
                f"{name} = {env!r}: the threads of lpbounds' kernels must be a positive integer"
            )
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
    """Use ``k`` threads (1 to :func:`default_threads`)."""
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
