"""Which kernels run an operation: plain numpy for small models, compiled for large.

The row sweeps of exact DP and the successor check are C, built at install
(:mod:`lpbounds._kernels.native`: :func:`row_sweeps`). The other compiled kernels
(:mod:`lpbounds._kernels.compiled`, :mod:`lpbounds._kernels.aggregate`, the patrol's
matrix-free sweeps) are numba's: fast but they cost a compile on first use in a fresh
environment (about 20 s for a DP solve and an RLP on two cores; numba caches the machine
code afterwards), and importing numba alone takes a few tenths of a second. Their numpy
twins (:mod:`lpbounds._kernels.twins`) compute the same numbers with the same arithmetic
and need neither. An operation whose sweep reads fewer than :data:`SMALL_READS` values
uses the twins; larger ones use the compiled kernels, announced once per kernel group on
the ``lpbounds`` logger (WARNING, so it reaches stderr) when numba has not cached them yet.
"""

from __future__ import annotations

import logging
import os
import sys
from types import ModuleType
from typing import Any

from . import twins as _npkernels

__all__ = [
    "SMALL_READS",
    "aggregate_kernels",
    "get_threads",
    "is_compiled",
    "nchunks",
    "row_sweeps",
    "set_threads",
    "sweep_kernels",
]

log = logging.getLogger(__name__)

#: Operations reading fewer values than this per sweep (rows x outcomes, or the
#: post-decision form's outcomes plus pairs) use the numpy twins. A numpy sweep costs
#: about 10-20 ns per read, a compiled one 1-3 ns, so a DP solve of ~100 sweeps at this
#: size takes a fraction of a second either way, less than importing numba and loading
#: its cache (0.3-0.6 s), let alone compiling (2-8 s per kernel group, see below).
SMALL_READS: int = 200_000

#: Kernel groups: what they do, their first-compile seconds (range measured with an empty
#: cache on two cores, idle to loaded) and the kernels whose cache decides whether a
#: compile is announced. Groups that compile in under a second are not announced.
_GROUPS: dict[str, tuple[str, tuple[float, float], tuple[str, ...]]] = {
    "rows": (
        "Bellman-row kernels (Q-values, the game operator, row hashes)",
        (3.0, 6.0),
        ("q_values", "bellman_maxmin", "hash_rows"),
    ),
    "post-decision": (
        "post-decision sweeps",
        (3.0, 6.0),
        ("ps_mark", "ps_fill", "ps_verify", "ps_expect", "ps_max_stats", "ps_policy_stats"),
    ),
    "aggregate": (
        "row aggregation",
        (3.0, 8.0),
        ("canonical_rows", "bucket_order", "sort_buckets", "mark_groups", "merge_groups"),
    ),
}
_announced: set[str] = set()


def is_compiled(reads: int) -> bool:
    """True when an operation of ``reads`` values per sweep uses the compiled kernels."""
    return reads >= SMALL_READS


def sweep_kernels(reads: int, group: str = "rows") -> ModuleType:
    """The module of Bellman-sweep kernels for an operation of ``reads`` values per sweep:
    :mod:`lpbounds._kernels.twins` or :mod:`lpbounds._kernels.compiled`."""
    if not is_compiled(reads):
        return _npkernels
    from . import compiled as _kernels

    _announce(group, _kernels, reads)
    return _kernels


def row_sweeps(reads: int) -> ModuleType:
    """The improvement and evaluation sweeps of a row system, its policy gather and the
    successor check, for an operation of ``reads`` values per sweep:
    :mod:`lpbounds._kernels.twins` or :mod:`lpbounds._kernels.native` (C, no numba)."""
    if not is_compiled(reads):
        return _npkernels
    from . import native

    return native


def aggregate_kernels(reads: int) -> ModuleType:
    """The aggregation kernels (:mod:`lpbounds._kernels.aggregate` or their numpy twins)."""
    if not is_compiled(reads):
        return _npkernels
    from . import aggregate as _aggregate

    _announce("aggregate", _aggregate, reads)
    return _aggregate


def nchunks() -> int:
    """Work chunks of the numba kernels: a few per thread, for load balance (the numpy
    twins and the native sweeps ignore the number)."""
    return max(1, 8 * get_threads())


def get_threads() -> int:
    """Threads of the compiled kernels: numba's count once numba is imported (so that
    ``numba.set_num_threads`` limits lpbounds too), else the native sweeps' (numba's
    default rule, :func:`lpbounds._kernels.native.default_threads`). Never imports numba."""
    numba = sys.modules.get("numba")
    if numba is not None:
        return int(numba.get_num_threads())
    from . import native

    return native.get_threads()


def set_threads(k: int) -> None:
    """Run the compiled kernels on ``k`` threads: the native sweeps, and numba's kernels
    if numba is imported (never imports it)."""
    from . import native

    native.set_threads(k)
    numba = sys.modules.get("numba")
    if numba is not None:
        numba.set_num_threads(k)


def _announce(group: str, module: ModuleType, reads: int) -> None:
    """Log once per group and process when the group's kernels will be compiled now."""
    if group in _announced:
        return
    _announced.add(group)
    what, (low, high), names = _GROUPS[group]
    if high < 1.0 or not _needs_compile(module, names):
        return
    log.warning(
        "numba is compiling lpbounds' %s for this model (%s values per sweep, above the "
        "numpy path's %s): about %.0f-%.0f s on 2 cores, once; later runs load them from "
        "numba's cache",
        what,
        f"{reads:,}",
        f"{SMALL_READS:,}",
        low,
        high,
    )


def _needs_compile(module: ModuleType, names: tuple[str, ...]) -> bool:
    """True if none of the numba functions ``names`` of ``module`` (a kernel group) has a
    compiled version in this process or a cache index on disk: a fresh environment, where
    the whole group compiles.

    A group with some kernels cached has been compiled here before; a model rarely uses
    every kernel of its group (the game operator's ``bellman_maxmin`` is the NLP's only),
    and judging by each kernel announced a compile on every run with a warm cache. A
    kernel of such a group that a model uses for the first time compiles silently, in a
    second or two (a heuristic either way: an index without this signature also compiles
    silently).
    """
    cacheable = False  # kernels numba does not cache compile every run: nothing to announce
    for name in names:
        obj = getattr(module, name)
        if getattr(obj, "overloads", None):
            return False
        index = _numba_cache_index_path(obj)
        if index == _NO_CACHE:
            continue
        cacheable = True
        if index is not None and os.path.exists(index):
            return False
    return cacheable


#: :func:`_numba_cache_index_path` of a function that numba does not cache
_NO_CACHE = ""


def _numba_cache_index_path(dispatcher: Any) -> str | None:
    """Where numba keeps the on-disk cache index of a ``cache=True`` dispatcher.

    numba has no public API for this path: this function is the one place in lpbounds
    that reads numba's private dispatcher attributes (``_cache``, its ``_cache_file`` and
    that file's ``_index_path``), so that a change of numba's internals touches it alone.

    Parameters
    ----------
    dispatcher : numba.core.dispatcher.Dispatcher
        An ``@numba.njit(cache=True)`` function (any object is accepted).

    Returns
    -------
    str or None
        The index path; ``""`` when the object has no numba cache (not a dispatcher, or
        ``cache=False``); ``None`` when this numba version lays its cache out otherwise
        (callers then assume the function compiles).
    """
    cache: Any = getattr(dispatcher, "_cache", None)
    if cache is None:
        return _NO_CACHE
    try:
        return str(cache._cache_file._index_path)
    except AttributeError:  # another numba version
        return None
