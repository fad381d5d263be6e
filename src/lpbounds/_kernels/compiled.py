"""Compiled inner loops over Bellman rows (numba).

Every kernel works on a row system in CSR form (see :mod:`lpbounds.rows`): rows of owner
``i`` are ``indptr[i]:indptr[i+1]``; row ``r`` reads
``q_r = reward[r] + discount * sum_l probs[r, l] * v[targets[r, l]]``. ``probs`` may be
a read-only broadcast view (stride 0) when all rows share one distribution.

These are the fast paths for large models; :mod:`lpbounds._kernels.twins` has a numpy twin of
each, with the same arithmetic, used below :data:`lpbounds._kernels.dispatch.SMALL_READS` reads per
sweep; ``tests/test_fast_paths.py`` checks that both give the same numbers. The improvement
and evaluation sweeps of exact DP on rows, their policy gather and the successor check are
C instead (:mod:`lpbounds._kernels.native`: a one-model process then needs no numba).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

_OPTS: dict[str, Any] = {"cache": True, "nogil": True, "fastmath": False}


@njit(parallel=True, **_OPTS)
def q_values(reward, targets, probs, discount, v, out):  # pragma: no cover - compiled
    """``out[r] = reward[r] + discount * sum_l probs[r, l] v[targets[r, l]]``."""
    n_rows, n_out = targets.shape
    for r in prange(n_rows):
        acc = 0.0
        for ll in range(n_out):
            acc += probs[r, ll] * v[targets[r, ll]]
        out[r] = reward[r] + discount * acc


@njit(parallel=True, **_OPTS)
def bellman_maxmin(
    indptr, action, reward, targets, probs, discount, v, out, arg
):  # pragma: no cover
    """Stochastic-game operator: max over actions of min over the rows of each action.

    Rows of one owner must be sorted by action; ``arg[i]`` is the minimising row of the
    first maximising action.
    """
    n = indptr.shape[0] - 1
    n_out = targets.shape[1]
    for i in prange(n):
        best = -np.inf
        best_r = -1
        r = indptr[i]
        end = indptr[i + 1]
        while r < end:
            a = action[r]
            low = np.inf
            low_r = r
            while r < end and action[r] == a:
                acc = 0.0
                for ll in range(n_out):
                    acc += probs[r, ll] * v[targets[r, ll]]
                q = reward[r] + discount * acc
                if q < low:
                    low = q
                    low_r = r
                r += 1
            if low > best:
                best = low
                best_r = low_r
        out[i] = best
        arg[i] = best_r


@njit(parallel=True, **_OPTS)
def hash_rows(owner, action, targets, probbits, out):  # pragma: no cover
    """A 64-bit hash of (owner, action, targets, probabilities' bits) per row."""
    n_rows, n_out = targets.shape
    mult = np.uint64(0x9E3779B97F4A7C15)
    for r in prange(n_rows):
        h = np.uint64(0x2545F4914F6CDD1D)
        h = (h ^ np.uint64(owner[r])) * mult
        h ^= h >> np.uint64(31)
        h = (h ^ np.uint64(action[r])) * mult
        h ^= h >> np.uint64(29)
        for ll in range(n_out):
            h = (h ^ np.uint64(targets[r, ll])) * mult
            h ^= h >> np.uint64(32)
            h = (h ^ np.uint64(probbits[r, ll])) * mult
            h ^= h >> np.uint64(27)
        out[r] = h


# ---------------------------------------------------------------------- post-decision form
# Fast path of :class:`lpbounds.rows.PostDecisionRows`: when every allowed pair's outcome
# tuple is a function of its first successor ``y = f(x, u, Y_0)``, a sweep computes
# ``w[k] = sum_l probs[l] v[outcomes[k, l]]`` once per distinct ``y`` and then
# ``q(x, u) = reward[x, u] + discount * w[first[x, u]]``. The arithmetic (summation order,
# one multiply-add per outcome from 0.0, then ``reward + discount * acc``) is that of the
# row kernels above, so both paths give bit-identical numbers.


@njit(parallel=True, **_OPTS)
def ps_mark(succ, allowed, seen):  # pragma: no cover
    """``seen[succ[x, u, 0]] = True`` for every allowed pair (benign same-value races)."""
    n, n_act, _ = succ.shape
    for x in prange(n):
        for a in range(n_act):
            if allowed[x, a]:
                seen[succ[x, a, 0]] = True


@njit(parallel=True, **_OPTS)
def ps_fill(succ, allowed, post_id, outcomes, first):  # pragma: no cover
    """``first[x, u] = post_id[y]`` (-1 if disallowed) and ``outcomes[post_id[y]] = succ[x, u]``.

    Pairs with the same ``y`` but different tuples may race; :func:`ps_verify` then
    rejects the form, whichever write won.
    """
    n, n_act, n_out = succ.shape
    for x in prange(n):
        for a in range(n_act):
            if allowed[x, a]:
                k = post_id[succ[x, a, 0]]
                first[x, a] = k
                for ll in range(n_out):
                    outcomes[k, ll] = succ[x, a, ll]
            else:
                first[x, a] = -1


@njit(parallel=True, **_OPTS)
def ps_verify(succ, first, outcomes, nchunks):  # pragma: no cover
    """Number of chunks holding an allowed pair whose tuple differs from its ``outcomes`` row."""
    n, n_act, n_out = succ.shape
    bad = np.zeros(nchunks, dtype=np.int64)
    size = (n + nchunks - 1) // nchunks
    for c in prange(nchunks):
        start = c * size
        end = min(n, start + size)
        for x in range(start, end):
            for a in range(n_act):
                k = first[x, a]
                if k < 0:
                    continue
                for ll in range(n_out):
                    if outcomes[k, ll] != succ[x, a, ll]:
                        bad[c] = 1
                if bad[c]:
                    break
            if bad[c]:
                break
    return bad.sum()


@njit(parallel=True, **_OPTS)
def ps_expect(outcomes, probs, v, w):  # pragma: no cover
    """``w[k] = sum_l probs[l] v[outcomes[k, l]]``: the expected next value after ``y_k``."""
    n_post, n_out = outcomes.shape
    for k in prange(n_post):
        acc = 0.0
        for ll in range(n_out):
            acc += probs[ll] * v[outcomes[k, ll]]
        w[k] = acc


@njit(parallel=True, **_OPTS)
def ps_max_stats(first, reward, w, discount, v, out, arg, nchunks):  # pragma: no cover
    """``out[x] = max_u reward[x, u] + discount w[first[x, u]]``, first maximising action in
    ``arg``; returns ``min`` and ``max`` of ``out - v``."""
    n, n_act = first.shape
    lo = np.full(nchunks, np.inf)
    hi = np.full(nchunks, -np.inf)
    size = (n + nchunks - 1) // nchunks
    for c in prange(nchunks):
        start = c * size
        end = min(n, start + size)
        lc = np.inf
        hc = -np.inf
        for i in range(start, end):
            best = -np.inf
            best_a = -1
            for a in range(n_act):
                k = first[i, a]
                if k >= 0:
                    q = reward[i, a] + discount * w[k]
                    if q > best:
                        best = q
                        best_a = a
            out[i] = best
            arg[i] = best_a
            d = best - v[i]
            lc = min(lc, d)
            hc = max(hc, d)
        lo[c] = lc
        hi[c] = hc
    return lo.min(), hi.max()


@njit(parallel=True, **_OPTS)
def ps_policy_stats(first, reward, act, w, discount, v, out, nchunks):  # pragma: no cover
    """``out[x] = reward[x, a] + discount w[first[x, a]]`` with ``a = act[x]``; returns the
    extremes of ``out - v``."""
    n = first.shape[0]
    lo = np.full(nchunks, np.inf)
    hi = np.full(nchunks, -np.inf)
    size = (n + nchunks - 1) // nchunks
    for c in prange(nchunks):
        start = c * size
        end = min(n, start + size)
        lc = np.inf
        hc = -np.inf
        for i in range(start, end):
            a = act[i]
            q = reward[i, a] + discount * w[first[i, a]]
            out[i] = q
            d = q - v[i]
            lc = min(lc, d)
            hc = max(hc, d)
        lo[c] = lc
        hi[c] = hc
    return lo.min(), hi.max()


@njit(parallel=True, **_OPTS)
def ps_rows(allowed, row_start, act, out):  # pragma: no cover
    """Row index (of :meth:`BellmanRows.from_mdp`) of the pair ``(x, act[x])``."""
    n = act.shape[0]
    for x in prange(n):
        r = row_start[x]
        for a in range(act[x]):
            if allowed[x, a]:
                r += 1
        out[x] = r


@njit(**_OPTS)
def reward_codes(reward, bits, max_codes, codes, table):  # pragma: no cover
    """Dictionary-encode ``reward`` (2-D): ``table[codes[x, u]] == reward[x, u]`` bit for bit.

    Returns the number of distinct values, or -1 as soon as there are more than
    ``max_codes`` (``codes`` is then partly written). ``bits`` is ``reward`` viewed as
    int64: an open-addressing hash on the float's bits (so ``-0.0`` and ``0.0`` stay
    distinct and every value is exact).
    """
    n, n_act = reward.shape
    size = 1
    while size < 4 * max_codes:
        size *= 2
    keys = np.empty(size, dtype=np.int64)
    vals = np.full(size, -1, dtype=np.int64)
    mask = size - 1
    count = 0
    for x in range(n):
        for a in range(n_act):
            b = bits[x, a]
            h = (np.uint64(b) * np.uint64(0x9E3779B97F4A7C15)) >> np.uint64(40)
            j = np.int64(h) & mask
            while vals[j] >= 0 and keys[j] != b:
                j = (j + 1) & mask
            if vals[j] < 0:
                if count >= max_codes:
                    return -1
                keys[j] = b
                vals[j] = count
                table[count] = reward[x, a]
                count += 1
            codes[x, a] = vals[j]
    return count


@njit(parallel=True, **_OPTS)
def ps_max_stats_coded(first, codes, table, w, discount, v, out, arg, nchunks):  # pragma: no cover
    """:func:`ps_max_stats` with rewards ``table[codes[x, u]]`` (fewer bytes per sweep)."""
    n, n_act = first.shape
    lo = np.full(nchunks, np.inf)
    hi = np.full(nchunks, -np.inf)
    size = (n + nchunks - 1) // nchunks
    for c in prange(nchunks):
        start = c * size
        end = min(n, start + size)
        lc = np.inf
        hc = -np.inf
        for i in range(start, end):
            best = -np.inf
            best_a = -1
            for a in range(n_act):
                k = first[i, a]
                if k >= 0:
                    q = table[codes[i, a]] + discount * w[k]
                    if q > best:
                        best = q
                        best_a = a
            out[i] = best
            arg[i] = best_a
            d = best - v[i]
            lc = min(lc, d)
            hc = max(hc, d)
        lo[c] = lc
        hi[c] = hc
    return lo.min(), hi.max()


@njit(parallel=True, **_OPTS)
def ps_policy_stats_coded(
    first, codes, table, act, w, discount, v, out, nchunks
):  # pragma: no cover
    """:func:`ps_policy_stats` with rewards ``table[codes[x, u]]``."""
    n = first.shape[0]
    lo = np.full(nchunks, np.inf)
    hi = np.full(nchunks, -np.inf)
    size = (n + nchunks - 1) // nchunks
    for c in prange(nchunks):
        start = c * size
        end = min(n, start + size)
        lc = np.inf
        hc = -np.inf
        for i in range(start, end):
            a = act[i]
            q = table[codes[i, a]] + discount * w[first[i, a]]
            out[i] = q
            d = q - v[i]
            lc = min(lc, d)
            hc = max(hc, d)
        lo[c] = lc
        hi[c] = hc
    return lo.min(), hi.max()
