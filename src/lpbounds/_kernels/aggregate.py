"""Fast construction of aggregated Bellman rows (the RLP's ``f-bar`` rows), used by
:meth:`lpbounds.rows.BellmanRows.aggregate`.

One compiled pass per exact row maps the owner and targets to partitions, merges equal
targets (summing their probabilities in outcome order), sorts them, drops zero
probabilities, and computes ``owner * A + action`` and a 64-bit hash of the canonical
successor distribution. A counting sort by ``owner * A + action`` (the order a row system
needs) followed by a parallel sort of each bucket by hash puts identical rows next to
each other. Adjacent rows with equal hashes are compared entry by entry; if two
different rows ever share a hash, the caller falls back to an exact sort of the full
rows, so the result never depends on the hash.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

_OPTS: dict[str, Any] = {"cache": True, "nogil": True}


@njit(parallel=True, **_OPTS)
def canonical_rows(
    labels, state, action, succ, probs, n_actions, out_owner, out_t, out_p, out_oa, out_key, nchunks
):  # pragma: no cover - compiled
    """Aggregated, canonical rows, their ``owner * A + action`` and hash (module docstring)."""
    n_rows, n_out = succ.shape
    size = (n_rows + nchunks - 1) // nchunks
    mult = np.uint64(0x9E3779B97F4A7C15)
    scale = 9007199254740992.0  # 2**53: probabilities in [0, 1] to integers for the hash
    for c in prange(nchunks):
        t = np.empty(n_out, dtype=out_t.dtype)
        p = np.empty(n_out, dtype=np.float64)
        for r in range(c * size, min(n_rows, (c + 1) * size)):
            for ll in range(n_out):
                t[ll] = labels[succ[r, ll]]
                p[ll] = probs[r, ll]
            for a in range(1, n_out):  # stable insertion sort by target
                tk = t[a]
                pk = p[a]
                b = a - 1
                while b >= 0 and t[b] > tk:
                    t[b + 1] = t[b]
                    p[b + 1] = p[b]
                    b -= 1
                t[b + 1] = tk
                p[b + 1] = pk
            k = 0
            for a in range(n_out):
                if p[a] == 0.0:
                    continue
                if k > 0 and out_t[r, k - 1] == t[a]:
                    out_p[r, k - 1] += p[a]
                else:
                    out_t[r, k] = t[a]
                    out_p[r, k] = p[a]
                    k += 1
            if k == 0:
                out_t[r, 0] = t[0]
                out_p[r, 0] = 0.0
                k = 1
            for a in range(k, n_out):
                out_t[r, a] = out_t[r, 0]
                out_p[r, a] = 0.0
            o = labels[state[r]]
            out_owner[r] = o
            h = np.uint64(0x2545F4914F6CDD1D)
            for a in range(n_out):
                h = (h ^ np.uint64(out_t[r, a])) * mult
                h ^= h >> np.uint64(32)
                h = (h ^ np.uint64(out_p[r, a] * scale)) * mult
                h ^= h >> np.uint64(29)
            out_oa[r] = np.int64(o) * n_actions + action[r]
            out_key[r] = h


@njit(parallel=True, **_OPTS)
def mark_groups(order, oa, key, t, pbits, new, nchunks):  # pragma: no cover - compiled
    """``new[i]``: sorted row ``i`` starts a group (a new ``oa`` bucket, or a different row).

    Returns True if two different rows of one bucket share a hash (a collision).
    """
    n = order.shape[0]
    n_out = t.shape[1]
    size = (n + nchunks - 1) // nchunks
    bad = np.zeros(nchunks, dtype=np.bool_)
    for c in prange(nchunks):
        for i in range(c * size, min(n, (c + 1) * size)):
            if i == 0:
                new[i] = True
                continue
            a = order[i]
            b = order[i - 1]
            if oa[a] != oa[b] or key[a] != key[b]:
                new[i] = True
                continue
            same = True
            for ll in range(n_out):
                if t[a, ll] != t[b, ll] or pbits[a, ll] != pbits[b, ll]:
                    same = False
            new[i] = not same
            if not same:
                bad[c] = True
    return bad.any()


@njit(**_OPTS)
def bucket_order(oa, n_buckets):  # pragma: no cover - compiled
    """Stable counting sort of the rows by ``oa``: ``(order, bucket offsets)``."""
    n = oa.shape[0]
    offsets = np.zeros(n_buckets + 1, dtype=np.int64)
    for r in range(n):
        offsets[oa[r] + 1] += 1
    for b in range(n_buckets):
        offsets[b + 1] += offsets[b]
    pos = offsets[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for r in range(n):
        b = oa[r]
        order[pos[b]] = r
        pos[b] += 1
    return order, offsets


@njit(parallel=True, **_OPTS)
def sort_buckets(order, offsets, key):  # pragma: no cover - compiled
    """Sort each bucket ``order[offsets[b]:offsets[b+1]]`` by ``key`` (in place)."""
    n_buckets = offsets.shape[0] - 1
    for b in prange(n_buckets):
        lo = offsets[b]
        hi = offsets[b + 1]
        if hi - lo > 1:
            idx = order[lo:hi].copy()
            perm = np.argsort(key[idx], kind="mergesort")
            for k in range(hi - lo):
                order[lo + k] = idx[perm[k]]


@njit(parallel=True, **_OPTS)
def merge_groups(
    order, starts, reward, use_max, owner, action, t, p, group, red, g_owner, g_action, g_t, g_p
):  # pragma: no cover - compiled
    """Per group (rows ``order[starts[g]:starts[g+1]]``): the extreme reward, the group id
    of each row and the group's representative row (its first)."""
    n_groups = starts.shape[0] - 1
    n_out = t.shape[1]
    for g in prange(n_groups):
        lo = starts[g]
        hi = starts[g + 1]
        first = order[lo]
        best = reward[first]
        for k in range(lo, hi):
            r = order[k]
            group[r] = g
            if use_max:
                best = max(best, reward[r])
            else:
                best = min(best, reward[r])
        red[g] = best
        g_owner[g] = owner[first]
        g_action[g] = action[first]
        for ll in range(n_out):
            g_t[g, ll] = t[first, ll]
            g_p[g, ll] = p[first, ll]
