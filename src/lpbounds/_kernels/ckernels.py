"""The Bellman-row kernels compiled ahead of time, run on threads.

Q-values and the game operator of a row system (:class:`lpbounds.rows.BellmanRows`), the
row hashes of its exact grouping, the passes and sweeps of the post-decision form
(:class:`lpbounds.rows.PostDecisionRows`), its reward codes, and the aggregation of rows
(:meth:`lpbounds.rows.BellmanRows.aggregate`: canonical rows, counting sort, bucket sorts,
group marks and merges) are C functions in :mod:`lpbounds._kernels.rowkernels`
(``rowkernels.c``), built when lpbounds is installed, as the row sweeps of exact DP are
(:mod:`lpbounds._kernels.native`). Each works on one range of its owners, rows, states,
buckets or groups and releases the GIL; the functions here cut the work into one range
per thread (:func:`lpbounds._kernels.threads.split_ranges`, equal shares of rows where the
owners' rows differ in number), run them on the one pool
(:func:`lpbounds._kernels.threads.run_ranges`) and combine the ranges' results (exact
minima and maxima, any-of flags), so the split changes no number. ``bucket_order`` and
``reward_codes`` are one serial pass (their results depend on the order of the whole pass).

Every function has the name, arguments and outputs of its numpy twin in
:mod:`lpbounds._kernels.twins` and the same arithmetic (``tests/kernels/test_ckernels.py`` compares
them bit for bit); they replaced numba kernels that computed the same numbers, and need no
JIT compiler: a first call costs what any call does. Indices read from the
arrays are checked in C: an index outside its array raises IndexError naming the argument
and the entry (never a read outside the buffers).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .extensions import rowkernels as _c
from .threads import run_ranges, split_ranges

__all__ = [
    "PARALLEL_READS",
    "bellman_maxmin",
    "bucket_order",
    "canonical_rows",
    "hash_rows",
    "mark_groups",
    "merge_groups",
    "ps_expect",
    "ps_fill",
    "ps_mark",
    "ps_max_stats",
    "ps_max_stats_coded",
    "ps_policy_stats",
    "ps_policy_stats_coded",
    "ps_rows",
    "ps_verify",
    "q_values",
    "reward_codes",
    "sort_buckets",
]

#: A call that reads fewer values than this runs as one range on the calling thread:
#: handing ranges to the pool costs 20-50 us (measured on two cores), more than such a
#: call takes on one thread (about 1-3 ns a value).
PARALLEL_READS: int = 65_536


def _bounds(n: int, reads: int, offsets: np.ndarray | None = None) -> np.ndarray:
    """Range bounds over ``n`` items: one range below :data:`PARALLEL_READS`, else one per
    thread (equal shares of ``offsets``' rows when given)."""
    if reads < PARALLEL_READS:
        return np.array([0, n], dtype=np.int64)
    return split_ranges(n, offsets)


def _f8(a: Any) -> np.ndarray:
    """A float input as C reads it (no copy when it already is one)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def _i8(a: Any) -> np.ndarray:
    """An int64 index input as C reads it (no copy when it already is one)."""
    return np.ascontiguousarray(a, dtype=np.int64)


def _c_order(a: Any) -> np.ndarray:
    """An integer input C-contiguous, its dtype kept (no copy when it already is)."""
    return np.ascontiguousarray(a)


def _probs(probs: Any) -> np.ndarray:
    """Probabilities as float64, a strided (broadcast) view kept as it is."""
    return np.asarray(probs, dtype=np.float64)


def _extremes(pairs: list[tuple[float, float]]) -> tuple[float, float]:
    return min(p[0] for p in pairs), max(p[1] for p in pairs)


# ---------------------------------------------------------------------- row kernels
def q_values(
    reward: Any, targets: Any, probs: Any, discount: float, v: Any, out: np.ndarray
) -> None:
    """``out[r] = reward[r] + discount * sum_l probs[r, l] v[targets[r, l]]``."""
    targets = _c_order(targets)
    args = (_f8(reward), targets, _probs(probs), float(discount), _f8(v), out)
    run_ranges(_c.q_values, args, _bounds(targets.shape[0], targets.size))


def bellman_maxmin(
    indptr: Any, action: Any, reward: Any, targets: Any, probs: Any, discount: float, v: Any,
    out: np.ndarray, arg: np.ndarray,
) -> None:  # fmt: skip
    """Stochastic-game operator: ``out[i]`` the max over the actions of owner ``i``'s rows
    (sorted by action) of the min of ``q_r`` over that action's rows; ``arg[i]`` the
    minimising row of the first maximising action."""
    indptr, targets = _i8(indptr), _c_order(targets)
    args = (
        indptr, np.ascontiguousarray(action, dtype=np.int32), _f8(reward), targets,
        _probs(probs), float(discount), _f8(v), out, arg,
    )  # fmt: skip
    bounds = _bounds(indptr.shape[0] - 1, targets.size, indptr)
    run_ranges(_c.bellman_maxmin, args, bounds)


def hash_rows(owner: Any, action: Any, targets: Any, probbits: Any, out: np.ndarray) -> None:
    """A 64-bit hash of (owner, action, targets, probabilities' bits) per row."""
    targets = _c_order(targets)
    args = (_c_order(owner), _c_order(action), targets, _c_order(probbits), out)
    run_ranges(_c.hash_rows, args, _bounds(targets.shape[0], targets.size))


# ---------------------------------------------------------------------- post-decision form
def ps_mark(succ: Any, allowed: Any, seen: np.ndarray) -> None:
    """``seen[succ[x, u, 0]] = True`` for every allowed pair."""
    succ = _c_order(succ)
    args = (succ, np.ascontiguousarray(allowed, dtype=np.bool_), seen)
    run_ranges(_c.ps_mark, args, _bounds(succ.shape[0], succ.size))


def ps_fill(succ: Any, allowed: Any, post_id: Any, outcomes: np.ndarray, first: np.ndarray) -> None:
    """``first[x, u] = post_id[succ[x, u, 0]]`` (-1 if disallowed) and the outcome tuples
    ``outcomes[first[x, u]] = succ[x, u]`` (pairs with one post-decision state and
    different tuples race: :func:`ps_verify` then rejects the form, whichever write won)."""
    succ = _c_order(succ)
    args = (succ, np.ascontiguousarray(allowed, dtype=np.bool_), _c_order(post_id), outcomes, first)
    run_ranges(_c.ps_fill, args, _bounds(succ.shape[0], succ.size))


def ps_verify(succ: Any, first: Any, outcomes: Any) -> int:
    """1 if some allowed pair's tuple differs from its ``outcomes`` row, else 0."""
    succ = _c_order(succ)
    args = (succ, _c_order(first), _c_order(outcomes))
    return int(any(run_ranges(_c.ps_verify, args, _bounds(succ.shape[0], succ.size))))


def ps_expect(outcomes: Any, probs: Any, v: Any, w: np.ndarray) -> None:
    """``w[k] = sum_l probs[l] v[outcomes[k, l]]``: the expected next value after ``y_k``."""
    outcomes = _c_order(outcomes)
    args = (outcomes, _f8(probs), _f8(v), w)
    run_ranges(_c.ps_expect, args, _bounds(outcomes.shape[0], outcomes.size))


def ps_max_stats(
    first: Any, reward: Any, w: Any, discount: float, v: Any, out: np.ndarray, arg: np.ndarray
) -> tuple[float, float]:
    """``out[x] = max_u reward[x, u] + discount w[first[x, u]]``, the first maximising
    action in ``arg``; returns the min and max of ``out - v``."""
    first = _c_order(first)
    args = (first, _f8(reward), _f8(w), float(discount), _f8(v), out, arg)
    return _extremes(run_ranges(_c.ps_max_stats, args, _bounds(first.shape[0], first.size)))


def ps_policy_stats(
    first: Any, reward: Any, act: Any, w: Any, discount: float, v: Any, out: np.ndarray
) -> tuple[float, float]:
    """``out[x] = reward[x, a] + discount w[first[x, a]]`` with ``a = act[x]``, ``-inf``
    where ``a = -1`` (no action: :func:`ps_max_stats`' ``arg`` where none beats ``-inf``);
    returns the min and max of ``out - v``."""
    first = _c_order(first)
    args = (first, _f8(reward), _c_order(act), _f8(w), float(discount), _f8(v), out)
    return _extremes(run_ranges(_c.ps_policy_stats, args, _bounds(first.shape[0], first.shape[0])))


def ps_max_stats_coded(
    first: Any, codes: Any, table: Any, w: Any, discount: float, v: Any, out: np.ndarray,
    arg: np.ndarray,
) -> tuple[float, float]:  # fmt: skip
    """:func:`ps_max_stats` with rewards ``table[codes[x, u]]`` (fewer bytes per sweep)."""
    first = _c_order(first)
    args = (first, _c_order(codes), _f8(table), _f8(w), float(discount), _f8(v), out, arg)
    bounds = _bounds(first.shape[0], first.size)
    return _extremes(run_ranges(_c.ps_max_stats_coded, args, bounds))


def ps_policy_stats_coded(
    first: Any, codes: Any, table: Any, act: Any, w: Any, discount: float, v: Any,
    out: np.ndarray,
) -> tuple[float, float]:  # fmt: skip
    """:func:`ps_policy_stats` with rewards ``table[codes[x, u]]``."""
    first = _c_order(first)
    args = (
        first, _c_order(codes), _f8(table), _c_order(act), _f8(w), float(discount), _f8(v), out,
    )  # fmt: skip
    bounds = _bounds(first.shape[0], first.shape[0])
    return _extremes(run_ranges(_c.ps_policy_stats_coded, args, bounds))


def ps_rows(allowed: Any, row_start: Any, act: Any, out: np.ndarray) -> None:
    """Row index (of :meth:`BellmanRows.from_mdp`) of the pair ``(x, act[x])``; -1 where
    ``act[x] = -1`` (no action)."""
    allowed = np.ascontiguousarray(allowed, dtype=np.bool_)
    args = (allowed, _i8(row_start), _c_order(act), out)
    run_ranges(_c.ps_rows, args, _bounds(allowed.shape[0], allowed.size))


def reward_codes(reward: Any, max_codes: int, codes: np.ndarray, table: np.ndarray) -> int:
    """Dictionary-encode ``reward`` (2-D): ``table[codes[x, u]] == reward[x, u]`` bit for bit,
    the codes numbering the distinct values in order of first appearance.

    Returns the number of distinct values, or -1 as soon as there are more than
    ``max_codes`` (``codes`` is then partly written). Values are told apart by their bits
    (``-0.0`` and ``0.0`` get two codes, every value is exact).
    """
    return int(_c.reward_codes(_f8(reward), int(max_codes), codes, table))


# ---------------------------------------------------------------------- aggregation
def canonical_rows(
    labels: Any, state: Any, action: Any, succ: Any, probs: Any, n_actions: int,
    out_owner: np.ndarray, out_t: np.ndarray, out_p: np.ndarray, out_oa: np.ndarray,
    out_key: np.ndarray,
) -> None:  # fmt: skip
    """Aggregated, canonical rows, their ``owner * A + action`` and hash: targets mapped to
    partitions and stably sorted, equal targets merged (probabilities summed in sorted
    order), zero probabilities dropped (see :meth:`lpbounds.rows.BellmanRows.aggregate`)."""
    succ = _c_order(succ)
    args = (
        _c_order(labels), _c_order(state), _c_order(action), succ, _probs(probs),
        int(n_actions), out_owner, out_t, out_p, out_oa, out_key,
    )  # fmt: skip
    run_ranges(_c.canonical_rows, args, _bounds(succ.shape[0], succ.size))


def mark_groups(order: Any, oa: Any, key: Any, t: Any, pbits: Any, new: np.ndarray) -> bool:
    """``new[i]``: sorted row ``i`` starts a group (a new ``oa`` bucket, or a different row).

    Returns True if two different rows of one bucket share a hash (a collision).
    """
    order, t = _i8(order), _c_order(t)
    args = (order, _i8(oa), _c_order(key), t, _c_order(pbits), new)
    return any(
        run_ranges(_c.mark_groups, args, _bounds(order.shape[0], order.shape[0] * t.shape[1]))
    )


def bucket_order(oa: Any, n_buckets: int) -> tuple[np.ndarray, np.ndarray]:
    """Stable counting sort of the rows by ``oa``: ``(order, bucket offsets)``."""
    oa = _i8(oa)
    order = np.empty(oa.shape[0], dtype=np.int64)
    offsets = np.empty(int(n_buckets) + 1, dtype=np.int64)
    _c.bucket_order(oa, order, offsets)
    return order, offsets


def sort_buckets(order: np.ndarray, offsets: Any, key: Any) -> None:
    """Sort each bucket ``order[offsets[b]:offsets[b+1]]`` by ``key``, stably (in place)."""
    offsets = _i8(offsets)
    args = (order, offsets, _c_order(key))
    run_ranges(_c.sort_buckets, args, _bounds(offsets.shape[0] - 1, order.shape[0], offsets))


def merge_groups(
    order: Any, starts: Any, reward: Any, use_max: bool, owner: Any, action: Any, t: Any,
    p: Any, group: np.ndarray, red: np.ndarray, g_owner: np.ndarray, g_action: np.ndarray,
    g_t: np.ndarray, g_p: np.ndarray,
) -> None:  # fmt: skip
    """Per group (rows ``order[starts[g]:starts[g+1]]``): the extreme reward, the group id
    of each row and the group's representative row (its first)."""
    order, starts, t = _i8(order), _i8(starts), _c_order(t)
    args = (
        order, starts, _f8(reward), bool(use_max), _c_order(owner), _c_order(action), t,
        _f8(p), group, red, g_owner, g_action, g_t, g_p,
    )  # fmt: skip
    bounds = _bounds(starts.shape[0] - 1, t.size, starts)
    run_ranges(_c.merge_groups, args, bounds)
