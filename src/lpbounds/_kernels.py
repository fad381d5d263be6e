"""Compiled inner loops over Bellman rows (numba).

Every kernel works on a row system in CSR form (see :mod:`lpbounds.rows`): rows of owner
``i`` are ``indptr[i]:indptr[i+1]``; row ``r`` reads
``q_r = reward[r] + discount * sum_l probs[r, l] * v[targets[r, l]]``. ``probs`` may be
a read-only broadcast view (stride 0) when all rows share one distribution.

These are the fast paths; :mod:`tests.test_kernels` checks each against plain numpy.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

_OPTS = {"cache": True, "nogil": True, "fastmath": False}


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
def bellman_max(indptr, reward, targets, probs, discount, v, out, arg):  # pragma: no cover
    """``out[i] = max_r q_r`` over owner ``i``'s rows; ``arg[i]`` = first maximising row."""
    n = indptr.shape[0] - 1
    n_out = targets.shape[1]
    for i in prange(n):
        best = -np.inf
        best_r = -1
        for r in range(indptr[i], indptr[i + 1]):
            acc = 0.0
            for ll in range(n_out):
                acc += probs[r, ll] * v[targets[r, ll]]
            q = reward[r] + discount * acc
            if q > best:
                best = q
                best_r = r
        out[i] = best
        arg[i] = best_r


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
def policy_sweep(rows, reward, targets, probs, discount, v, out):  # pragma: no cover
    """``out[i] = q_{rows[i]}(v)``: one sweep of policy evaluation (one row per owner)."""
    n = rows.shape[0]
    n_out = targets.shape[1]
    for i in prange(n):
        r = rows[i]
        acc = 0.0
        for ll in range(n_out):
            acc += probs[r, ll] * v[targets[r, ll]]
        out[i] = reward[r] + discount * acc


@njit(parallel=True, **_OPTS)
def canonicalize(targets, probs, out_t, out_p):  # pragma: no cover
    """Sort each row's outcomes by target, merge equal targets, drop zero probabilities.

    Unused slots get the row's first target and probability 0, so two rows with the
    same successor distribution become bit-for-bit identical.
    """
    n_rows, n_out = targets.shape
    for r in prange(n_rows):
        t = np.empty(n_out, dtype=targets.dtype)
        p = np.empty(n_out, dtype=np.float64)
        for ll in range(n_out):
            t[ll] = targets[r, ll]
            p[ll] = probs[r, ll]
        # insertion sort by target (stable: equal targets keep outcome order)
        for a in range(1, n_out):
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
        if k == 0:  # cannot happen for a probability vector; keep the row valid anyway
            out_t[r, 0] = t[0]
            out_p[r, 0] = 0.0
            k = 1
        for a in range(k, n_out):
            out_t[r, a] = out_t[r, 0]
            out_p[r, a] = 0.0


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


@njit(parallel=True, **_OPTS)
def bellman_max_stats(
    indptr, reward, targets, probs, discount, v, out, arg, nchunks
):  # pragma: no cover
    """:func:`bellman_max` that also returns ``min`` and ``max`` of ``out - v`` (one pass)."""
    n = indptr.shape[0] - 1
    n_out = targets.shape[1]
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
            best_r = -1
            for r in range(indptr[i], indptr[i + 1]):
                acc = 0.0
                for ll in range(n_out):
                    acc += probs[r, ll] * v[targets[r, ll]]
                q = reward[r] + discount * acc
                if q > best:
                    best = q
                    best_r = r
            out[i] = best
            arg[i] = best_r
            d = best - v[i]
            lc = min(lc, d)
            hc = max(hc, d)
        lo[c] = lc
        hi[c] = hc
    return lo.min(), hi.max()


@njit(parallel=True, **_OPTS)
def policy_sweep_stats(rows, reward, targets, probs, discount, v, out, nchunks):  # pragma: no cover
    """:func:`policy_sweep` that also returns ``min`` and ``max`` of ``out - v`` (one pass)."""
    n = rows.shape[0]
    n_out = targets.shape[1]
    lo = np.full(nchunks, np.inf)
    hi = np.full(nchunks, -np.inf)
    size = (n + nchunks - 1) // nchunks
    for c in prange(nchunks):
        start = c * size
        end = min(n, start + size)
        lc = np.inf
        hc = -np.inf
        for i in range(start, end):
            r = rows[i]
            acc = 0.0
            for ll in range(n_out):
                acc += probs[r, ll] * v[targets[r, ll]]
            q = reward[r] + discount * acc
            out[i] = q
            d = q - v[i]
            lc = min(lc, d)
            hc = max(hc, d)
        lo[c] = lc
        hi[c] = hc
    return lo.min(), hi.max()
