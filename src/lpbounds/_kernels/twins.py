"""Plain-numpy twins of the C kernels of :mod:`lpbounds._kernels.ckernels` and
:mod:`lpbounds._kernels.native`: the reference the tests compare them with.

Each function is the reference of one C kernel: an intended parallel, not a duplicate
(``duplicates`` lists their shared signatures; they stay, and the tests compare the two bit
for bit). Each has the name, arguments and outputs of its C twin and the same
arithmetic: a row's value is ``acc = 0.0; acc += probs[r, l] * v[targets[r, l]]`` for
``l = 0, 1, ...`` (one multiply and one add per outcome, in outcome order, no fused
multiply-add), then ``reward[r] + discount * acc``; a max (min) keeps the *first* row or
action that attains it and never picks a NaN; the residual extremes ignore NaNs. So the
two return the same numbers (up to the sign of a zero residual extreme), which
``tests/kernels/test_ckernels.py``, ``tests/kernels/test_native.py`` and
``tests/dp/test_fast_paths.py`` check bit for bit on random models with action masks
(kernel by kernel, and whole solves with the library running on the twins); the rounding analysis of
:mod:`lpbounds.certification.certificate` and :func:`lpbounds.tolerances.error_bound`
covers both.

Loops run over the (few) outcomes or actions, never over states or rows: a sweep costs a
few numpy calls per outcome. The library itself always runs the C kernels (faster at
every size, :mod:`lpbounds._kernels.dispatch`); these are written to be read and checked.
"""

from __future__ import annotations

from typing import Any

import numpy as np

_INF = np.inf
_MULT = np.uint64(0x9E3779B97F4A7C15)
_SEED = np.uint64(0x2545F4914F6CDD1D)


# ---------------------------------------------------------------------- shared steps
def _expect(targets: np.ndarray, probs: Any, v: np.ndarray) -> np.ndarray:
    """``sum_l probs[:, l] * v[targets[:, l]]``, summed in outcome order from 0.0."""
    acc = np.zeros(targets.shape[0])
    for ll in range(targets.shape[1]):
        acc += probs[:, ll] * v[targets[:, ll]]
    return acc


def _q(
    reward: np.ndarray, targets: np.ndarray, probs: Any, discount: float, v: np.ndarray
) -> np.ndarray:
    return reward + discount * _expect(targets, probs, v)


def _extremes(d: np.ndarray) -> tuple[float, float]:
    """``(min d, max d)`` ignoring NaNs (``(inf, -inf)`` if none), as the kernels do."""
    return float(np.fmin.reduce(d, initial=_INF)), float(np.fmax.reduce(d, initial=-_INF))


def _first_max(q: np.ndarray, starts: np.ndarray, n_items: int) -> tuple[np.ndarray, np.ndarray]:
    """Per segment ``starts[i]:starts[i+1]`` of ``q`` (none empty): the first index whose
    value is the segment's largest non-NaN value above ``-inf``, else -1; and that value
    (``-inf`` where none)."""
    qn = np.where(q > -_INF, q, -_INF)
    best = np.maximum.reduceat(qn, starts)
    seg = np.repeat(np.arange(starts.size), np.diff(np.append(starts, n_items)))
    cand = (qn == best[seg]) & (qn > -_INF)
    first = np.minimum.reduceat(np.where(cand, np.arange(n_items), n_items), starts)
    found = first < n_items
    idx = np.where(found, first, -1)
    val = np.where(found, q[np.where(found, first, 0)], -_INF)
    return idx, val


# ---------------------------------------------------------------------- row kernels
def q_values(
    reward: np.ndarray,
    targets: np.ndarray,
    probs: Any,
    discount: float,
    v: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[r] = reward[r] + discount * sum_l probs[r, l] v[targets[r, l]]``."""
    out[:] = _q(reward, targets, probs, discount, v)


def bellman_maxmin(
    indptr: np.ndarray,
    action: np.ndarray,
    reward: np.ndarray,
    targets: np.ndarray,
    probs: Any,
    discount: float,
    v: np.ndarray,
    out: np.ndarray,
    arg: np.ndarray,
) -> None:
    """Stochastic-game operator: ``out[i]`` the max over the actions of owner ``i``'s rows
    (sorted by action) of the min of ``q_r`` over that action's rows; ``arg[i]`` the
    minimising row of the first maximising action."""
    n_rows = targets.shape[0]
    q = _q(reward, targets, probs, discount, v)
    starts = np.zeros(n_rows, dtype=bool)
    starts[indptr[:-1]] = True
    starts[1:] |= action[1:] != action[:-1]
    gstart = np.flatnonzero(starts)
    # min over each (owner, action) group: the first row attaining it (the group's first
    # row if every value is NaN or +inf, whose min is then +inf)
    qm = np.where(q < _INF, q, _INF)
    low = np.minimum.reduceat(qm, gstart)
    gid = np.cumsum(starts) - 1
    cand = (qm == low[gid]) & (qm < _INF)
    first = np.minimum.reduceat(np.where(cand, np.arange(n_rows), n_rows), gstart)
    low_r = np.where(first < n_rows, first, gstart)
    # max over the groups of each owner: the first group attaining it
    owner_groups = np.searchsorted(gstart, indptr[:-1])
    g_idx, g_val = _first_max(low, owner_groups, gstart.size)
    out[:] = g_val
    arg[:] = np.where(g_idx >= 0, low_r[np.maximum(g_idx, 0)], -1)


def hash_rows(
    owner: np.ndarray,
    action: np.ndarray,
    targets: np.ndarray,
    probbits: np.ndarray,
    out: np.ndarray,
) -> None:
    """A 64-bit hash of (owner, action, targets, probabilities' bits) per row."""
    with np.errstate(over="ignore"):
        h = np.full(owner.shape[0], _SEED, dtype=np.uint64)
        h = (h ^ owner.astype(np.uint64)) * _MULT
        h ^= h >> np.uint64(31)
        h = (h ^ action.astype(np.uint64)) * _MULT
        h ^= h >> np.uint64(29)
        for ll in range(targets.shape[1]):
            h = (h ^ targets[:, ll].astype(np.uint64)) * _MULT
            h ^= h >> np.uint64(32)
            h = (h ^ probbits[:, ll].astype(np.uint64)) * _MULT
            h ^= h >> np.uint64(27)
    out[:] = h


def bellman_max_stats(
    indptr: np.ndarray,
    reward: np.ndarray,
    targets: np.ndarray,
    probs: Any,
    discount: float,
    v: np.ndarray,
    out: np.ndarray,
    arg: np.ndarray,
) -> tuple[float, float]:
    """``out[i] = max_r q_r`` over owner ``i``'s rows, ``arg[i]`` the first maximising row;
    returns the extremes of ``out - v``."""
    q = _q(reward, targets, probs, discount, v)
    idx, val = _first_max(q, indptr[:-1], q.shape[0])
    out[:] = val
    arg[:] = idx
    return _extremes(out - v)


def policy_sweep_stats(
    rows: np.ndarray | None,
    reward: np.ndarray,
    targets: np.ndarray,
    probs: Any,
    discount: float,
    v: np.ndarray,
    out: np.ndarray,
) -> tuple[float, float]:
    """``out[i] = q_{rows[i]}(v)`` (``rows`` None: ``q_i``); returns the extremes of
    ``out - v``."""
    if rows is None:
        out[:] = reward + discount * _expect(targets, probs, v)
    else:
        out[:] = reward[rows] + discount * _expect(targets[rows], np.asarray(probs)[rows], v)
    return _extremes(out - v)


def gather_rows(
    sel: np.ndarray,
    reward: np.ndarray,
    targets: np.ndarray,
    probs: Any,
    out_reward: np.ndarray,
    out_targets: np.ndarray,
    out_probs: np.ndarray,
    copy_probs: bool,
) -> None:
    """Row ``sel[i]`` into slot ``i`` of the ``out_*`` arrays (``out_probs`` only when
    ``copy_probs``)."""
    out_reward[:] = reward[sel]
    out_targets[:] = targets[sel]
    if copy_probs:
        out_probs[:] = probs[sel]


def check_successors(succ: np.ndarray, allow: np.ndarray, n: int) -> tuple[int, int, int]:
    """Out-of-range successors: (count on allowed pairs, first flat index, count elsewhere)."""
    bad = (succ < 0) | (succ >= n)
    on_allowed = bad & allow[:, :, None]
    flat = np.flatnonzero(on_allowed)
    n_bad = int(flat.size)
    return n_bad, int(flat[0]) if n_bad else -1, int(bad.sum()) - n_bad


# ---------------------------------------------------------------------- post-decision form
def ps_mark(succ: np.ndarray, allowed: np.ndarray, seen: np.ndarray) -> None:
    """``seen[succ[x, u, 0]] = True`` for every allowed pair."""
    seen[succ[:, :, 0][allowed]] = True


def ps_fill(
    succ: np.ndarray,
    allowed: np.ndarray,
    post_id: np.ndarray,
    outcomes: np.ndarray,
    first: np.ndarray,
) -> None:
    """``first[x, u] = post_id[succ[x, u, 0]]`` (-1 if disallowed) and the outcome tuples."""
    k = post_id[succ[:, :, 0]]
    first[:] = np.where(allowed, k, -1)
    outcomes[k[allowed]] = succ[allowed]


def ps_verify(succ: np.ndarray, first: np.ndarray, outcomes: np.ndarray) -> int:
    """1 if some allowed pair's tuple differs from its ``outcomes`` row, else 0."""
    ok = first >= 0
    return int(not np.array_equal(outcomes[first[ok]], succ[ok]))


def ps_expect(outcomes: np.ndarray, probs: Any, v: np.ndarray, w: np.ndarray) -> None:
    """``w[k] = sum_l probs[l] v[outcomes[k, l]]``."""
    acc = np.zeros(outcomes.shape[0])
    for ll in range(outcomes.shape[1]):
        acc += probs[ll] * v[outcomes[:, ll]]
    w[:] = acc


def _ps_q(first: np.ndarray, reward: np.ndarray, w: np.ndarray, discount: float) -> np.ndarray:
    """``reward[x, u] + discount * w[first[x, u]]``, ``-inf`` on disallowed pairs."""
    ok = first >= 0
    return np.where(ok, reward + discount * w[np.where(ok, first, 0)], -_INF)


def _ps_max(q: np.ndarray, v: np.ndarray, out: np.ndarray, arg: np.ndarray) -> tuple[float, float]:
    qn = np.where(q > -_INF, q, -_INF)
    cand = (qn == qn.max(axis=1, initial=-_INF)[:, None]) & (qn > -_INF)
    has = cand.any(axis=1)
    a = cand.argmax(axis=1)
    out[:] = np.where(has, q[np.arange(q.shape[0]), a], -_INF)
    arg[:] = np.where(has, a, -1)
    return _extremes(out - v)


def _ps_policy(q_sel: np.ndarray, v: np.ndarray, out: np.ndarray) -> tuple[float, float]:
    out[:] = q_sel
    return _extremes(out - v)


def ps_max_stats(
    first: np.ndarray,
    reward: np.ndarray,
    w: np.ndarray,
    discount: float,
    v: np.ndarray,
    out: np.ndarray,
    arg: np.ndarray,
) -> tuple[float, float]:
    """``out[x] = max_u reward[x, u] + discount w[first[x, u]]``, the first maximising
    action in ``arg``; returns the extremes of ``out - v``."""
    return _ps_max(_ps_q(first, reward, w, discount), v, out, arg)


def ps_policy_stats(
    first: np.ndarray,
    reward: np.ndarray,
    act: np.ndarray,
    w: np.ndarray,
    discount: float,
    v: np.ndarray,
    out: np.ndarray,
) -> tuple[float, float]:
    """``out[x] = reward[x, a] + discount w[first[x, a]]`` with ``a = act[x]``; ``-inf``
    where ``a = -1`` (no action: :func:`ps_max_stats`' arg where none beats ``-inf``)."""
    x = np.arange(first.shape[0])
    return _ps_policy(_no_action(act, reward[x, act] + discount * w[first[x, act]]), v, out)


def _no_action(act: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``q`` with ``-inf`` where ``act`` is -1 (its entries there read the last action)."""
    return np.where(np.asarray(act) == -1, -_INF, q)


def ps_rows(allowed: np.ndarray, row_start: np.ndarray, act: np.ndarray, out: np.ndarray) -> None:
    """Row index (of :meth:`BellmanRows.from_mdp`) of the pair ``(x, act[x])``; -1 where
    ``act[x] = -1`` (no action)."""
    act = np.asarray(act, dtype=np.int64)
    before = np.cumsum(allowed, axis=1) - allowed  # allowed actions below each action
    out[:] = np.where(act == -1, -1, row_start + before[np.arange(act.shape[0]), act])


def reward_codes(reward: np.ndarray, max_codes: int, codes: np.ndarray, table: np.ndarray) -> int:
    """Dictionary-encode ``reward``: ``table[codes] == reward`` bit for bit, the codes
    numbering the distinct values (by their bits) in order of first appearance; the number
    of distinct values, or -1 if there are more than ``max_codes``."""
    bits = np.ascontiguousarray(reward, dtype=np.float64).view(np.int64).reshape(-1)
    uniq, first, inv = np.unique(bits, return_index=True, return_inverse=True)
    if uniq.size > max_codes:
        return -1
    by_first = np.argsort(first)  # code c is the c-th distinct value met
    rank = np.empty(uniq.size, dtype=np.int64)
    rank[by_first] = np.arange(uniq.size)
    codes[...] = rank[inv.reshape(-1)].reshape(codes.shape)
    table[: uniq.size] = uniq[by_first].view(np.float64)
    return int(uniq.size)


def ps_max_stats_coded(
    first: np.ndarray,
    codes: np.ndarray,
    table: np.ndarray,
    w: np.ndarray,
    discount: float,
    v: np.ndarray,
    out: np.ndarray,
    arg: np.ndarray,
) -> tuple[float, float]:
    """:func:`ps_max_stats` with rewards ``table[codes[x, u]]``."""
    return _ps_max(_ps_q(first, table[codes], w, discount), v, out, arg)


def ps_policy_stats_coded(
    first: np.ndarray,
    codes: np.ndarray,
    table: np.ndarray,
    act: np.ndarray,
    w: np.ndarray,
    discount: float,
    v: np.ndarray,
    out: np.ndarray,
) -> tuple[float, float]:
    """:func:`ps_policy_stats` with rewards ``table[codes[x, u]]``."""
    x = np.arange(first.shape[0])
    return _ps_policy(_no_action(act, table[codes[x, act]] + discount * w[first[x, act]]), v, out)


# ---------------------------------------------------------------------- aggregation
def canonical_rows(
    labels: np.ndarray,
    state: np.ndarray,
    action: np.ndarray,
    succ: np.ndarray,
    probs: Any,
    n_actions: int,
    out_owner: np.ndarray,
    out_t: np.ndarray,
    out_p: np.ndarray,
    out_oa: np.ndarray,
    out_key: np.ndarray,
) -> None:
    """Aggregated, canonical rows, their ``owner * A + action`` and hash: targets mapped to
    partitions and stably sorted, equal targets merged (probabilities summed in sorted
    order), zero probabilities dropped, each row padded with its first target at
    probability 0 (see :meth:`lpbounds.rows.BellmanRows.aggregate`)."""
    n_rows, n_out = succ.shape
    t = labels[succ]
    perm = np.argsort(t, axis=1, kind="stable")
    t = np.take_along_axis(t, perm, axis=1)
    p = np.take_along_axis(np.asarray(probs, dtype=np.float64), perm, axis=1)
    k = np.zeros(n_rows, dtype=np.int64)
    rows = np.arange(n_rows)
    for a in range(n_out):
        live = p[:, a] != 0.0
        prev = np.maximum(k - 1, 0)
        same = live & (k > 0) & (out_t[rows, prev] == t[:, a])
        out_p[rows[same], prev[same]] += p[same, a]
        new = live & ~same
        out_t[rows[new], k[new]] = t[new, a]
        out_p[rows[new], k[new]] = p[new, a]
        k += new
    empty = k == 0
    out_t[empty, 0] = t[empty, 0]
    out_p[empty, 0] = 0.0
    k[empty] = 1
    pad = np.arange(n_out)[None, :] >= k[:, None]
    out_t[pad] = np.broadcast_to(out_t[:, :1], out_t.shape)[pad]
    out_p[pad] = 0.0
    o = labels[state]
    out_owner[:] = o
    scale = 9007199254740992.0  # 2**53, as in the C kernel
    with np.errstate(over="ignore"):
        h = np.full(n_rows, _SEED, dtype=np.uint64)
        for a in range(n_out):
            h = (h ^ out_t[:, a].astype(np.uint64)) * _MULT
            h ^= h >> np.uint64(32)
            h = (h ^ (out_p[:, a] * scale).astype(np.uint64)) * _MULT
            h ^= h >> np.uint64(29)
    out_oa[:] = o.astype(np.int64) * n_actions + action
    out_key[:] = h


def mark_groups(
    order: np.ndarray,
    oa: np.ndarray,
    key: np.ndarray,
    t: np.ndarray,
    pbits: np.ndarray,
    new: np.ndarray,
) -> bool:
    """``new[i]``: sorted row ``i`` starts a group; True if two different rows of one bucket
    share a hash (a collision)."""
    n = order.shape[0]
    if n == 0:
        return False
    a, b = order[1:], order[:-1]
    bucket_differs = (oa[a] != oa[b]) | (key[a] != key[b])
    content_differs = (t[a] != t[b]).any(axis=1) | (pbits[a] != pbits[b]).any(axis=1)
    new[0] = True
    new[1:] = bucket_differs | content_differs
    return bool((~bucket_differs & content_differs).any())


def bucket_order(oa: np.ndarray, n_buckets: int) -> tuple[np.ndarray, np.ndarray]:
    """Stable sort of the rows by ``oa``: ``(order, bucket offsets)``."""
    order = np.argsort(oa, kind="stable").astype(np.int64)
    offsets = np.zeros(n_buckets + 1, dtype=np.int64)
    np.cumsum(np.bincount(oa, minlength=n_buckets), out=offsets[1:])
    return order, offsets


def sort_buckets(order: np.ndarray, offsets: np.ndarray, key: np.ndarray) -> None:
    """Sort each bucket ``order[offsets[b]:offsets[b+1]]`` by ``key``, stably (in place)."""
    bucket = np.repeat(np.arange(offsets.shape[0] - 1), np.diff(offsets))
    order[:] = order[np.lexsort((key[order], bucket))]


def merge_groups(
    order: np.ndarray,
    starts: np.ndarray,
    reward: np.ndarray,
    use_max: bool,
    owner: np.ndarray,
    action: np.ndarray,
    t: np.ndarray,
    p: np.ndarray,
    group: np.ndarray,
    red: np.ndarray,
    g_owner: np.ndarray,
    g_action: np.ndarray,
    g_t: np.ndarray,
    g_p: np.ndarray,
) -> None:
    """Per group (rows ``order[starts[g]:starts[g+1]]``): the extreme reward, the group id
    of each row and the group's representative row (its first)."""
    n_groups = starts.shape[0] - 1
    if n_groups == 0:
        return
    sizes = np.diff(starts)
    group[order] = np.repeat(np.arange(n_groups), sizes)
    reduce = np.maximum if use_max else np.minimum
    vals = reward[order]
    extreme = reduce.reduceat(vals, starts[:-1])
    # the first row attaining it (-0.0 and 0.0 tie: the first's sign, as the C kernel
    # keeps; numpy's maximum may return either)
    hit = vals == np.repeat(extreme, sizes)
    n = vals.shape[0]
    red[:] = vals[np.minimum.reduceat(np.where(hit, np.arange(n), n), starts[:-1])]
    first = order[starts[:-1]]
    g_owner[:] = owner[first]
    g_action[:] = action[first]
    g_t[:] = t[first]
    g_p[:] = p[first]
