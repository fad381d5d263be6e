r"""Matrix-free exact DP for the patrol model: sweeps that compute the dynamics on the fly.

The array path (:meth:`PatrolModel.mdp` and :class:`lpbounds.rows.PostDecisionRows`)
stores ``(m + 1)`` successors per state and action; at 6 stations (534,773,760 states)
those arrays alone would take about 32 GB. The sweeps here store nothing per state but
the value vectors: each state's components, its successors, its rewards and (for the
bounds) its partition are computed from the state index inside compiled kernels, a block
of states at a time, with the model's own encoding and dynamics
(``model.decode_kernel``, ``model.successor_kernel``) and partitions
(:func:`lpbounds.patrol.partitions.state_partition_kernel`). A block is decoded by rows of
``Gamma + 1`` consecutive states, which differ in one delay only (:func:`_decode_rows`).

Speed: a sweep costs 100-200 ns of one core per state (measured on the paper's instance,
2-core machine, idle to loaded), so at 6 stations about a minute per sweep on two idle
cores; ``benchmarks/bench_beyond.py`` records it.

Same numbers as the array path
------------------------------
Every Q-value is computed with the array path's arithmetic, in its order:
``W = sum_l p_l v(g_l)`` accumulated from ``0.0`` over ``l = 0..m``, then
``q = R_u(x) + lambda W`` with ``R_u(x)`` the float :meth:`PatrolModel.rewards` stores;
the maximum keeps the first maximising action; a sweep returns the extremes of
``T v - v``. :class:`MatrixFreePatrol` implements the sweep protocol
(:class:`lpbounds.rows.SweepOperator`), so :func:`solve_vstar` and
:func:`evaluate_policy` run the very loops of :func:`lpbounds.solve_exact` and
:func:`lpbounds.evaluate_policy`'s iterative method (:func:`lpbounds.dp.mpi_loop`,
:func:`lpbounds.dp.evaluation_loop`: the same ``eval_sweeps`` rule, the Porteus shift
carried as a scalar offset, the thread choice), with the default tolerance
``dp_default_tol``, and both return the array path's vectors bit for bit
(``tests/patrol/test_matrix_free.py`` checks it; ``benchmarks/bench_beyond.py`` on the
paper's instance). Only the memory differs: the loops keep two value vectors (4.3 GB each
at 6 stations) and form ``u + c`` in place, and the policy is int8.

Certificate
-----------
``V*`` is certified as every exact-DP result is: the residual ``||T V - V||_inf`` is
measured by a full max sweep on the returned vector and turned into
:func:`lpbounds.tolerances.error_bound` (``(residual + rounding slack) / (1 - lambda)``);
the status is :attr:`Status.OPTIMAL` when the residual reached the tolerance.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from numba import njit, prange

from ..dp import DPResult, PolicyEvaluation, check_eval_sweeps, evaluation_loop, mpi_loop
from ..errors import ConvergenceError, ValidationError
from ..rows import PolicySweeps
from ..stochastic import RowSums, row_sums
from ..tolerances import GREEDY_TIE_RTOL, dp_default_tol, error_bound
from ..validation import check_int
from .model import PatrolModel, decode_kernel, successor_kernel
from .params import PatrolParams
from .partitions import block_sizes, state_partition_kernel

__all__ = [
    "BLOCK",
    "MatrixFreePatrol",
    "check_finite",
    "evaluate_policy",
    "solve_vstar",
]

_OPTS: dict[str, Any] = {"cache": True, "nogil": True, "fastmath": False}

#: States decoded together into a thread's buffers (small enough to stay in L1/L2).
BLOCK: int = 512

# indices into the integer geometry vector the kernels take
_N, _M, _D, _G, _RADIX, _NTRAVEL, _EMPTY, _TBS, _LBS, _ROW = range(10)


# ---------------------------------------------------------------------- kernels
@njit(**_OPTS)
def _buffers(block, m):  # pragma: no cover - compiled
    """One thread's block buffers: decoded components ``l, w, d, tau``, the state indices
    ``xs``, their compacted copies ``cl, cw, cd, ctau`` and index list ``sel``, and one
    successor block per action."""
    ints = np.empty((8, block), np.int64)
    tau = np.empty((block, m), np.int16)
    ctau = np.empty((block, m), np.int16)
    succ = np.empty((3, block, m + 1), np.int64)
    return ints, tau, ctau, succ


@njit(**_OPTS)
def _decode_rows(start, nb, geo, stations, ints, tau, ctau):  # pragma: no cover - compiled
    """Decode states ``start .. start + nb - 1`` into buffer rows ``0 .. nb - 1``.

    The encoding is mixed radix with a delay as its last digit (:mod:`.model`), so the
    ``Gamma + 1`` consecutive states of a *row* (``start`` and ``nb`` are multiples of the
    row length ``geo[_ROW]``) share every component but that delay, which runs 0, 1, ...
    along the row. ``model.decode_kernel`` decodes the first two states of each row
    (where they differ is the delay that runs) and the rest of the row is copied: 8-15
    times fewer integer divisions than decoding every state. Uses ``ints[0]`` and
    ``ints[5:8]``, ``ctau`` as scratch.
    """
    xs, l, w, d = ints[0], ints[1], ints[2], ints[3]
    big_r = geo[_ROW]
    m = geo[_M]
    if big_r == 1:
        for i in range(nb):
            xs[i] = start + i
        decode_kernel(
            xs[:nb],
            geo[_NTRAVEL],
            geo[_RADIX],
            m,
            geo[_D],
            stations,
            l[:nb],
            w[:nb],
            d[:nb],
            tau[:nb],
        )
        return
    n2 = 2 * (nb // big_r)
    for q in range(n2):  # the first two states of each row
        xs[q] = start + (q // 2) * big_r + q % 2
    l2, w2, d2 = ints[5], ints[6], ints[7]
    decode_kernel(
        xs[:n2],
        geo[_NTRAVEL],
        geo[_RADIX],
        m,
        geo[_D],
        stations,
        l2[:n2],
        w2[:n2],
        d2[:n2],
        ctau[:n2],
    )
    for r in range(n2 // 2):
        a = 2 * r
        last = 0
        for j in range(m):
            if ctau[a, j] != ctau[a + 1, j]:
                last = j
        for t in range(big_r):
            i = r * big_r + t
            l[i] = l2[a]
            w[i] = w2[a]
            d[i] = d2[a]
            for j in range(m):
                tau[i, j] = ctau[a, j]
            tau[i, last] = t


@njit(**_OPTS)
def _successors(geo, sp, wt, wl, ints, tau, nb, action, out):  # pragma: no cover
    """``model.successor_kernel`` on buffer rows ``0 .. nb - 1`` into ``out[:nb]``."""
    successor_kernel(
        ints[1][:nb],
        ints[2][:nb],
        ints[3][:nb],
        tau[:nb],
        action,
        geo[_N],
        geo[_D],
        geo[_G],
        geo[_RADIX],
        geo[_NTRAVEL],
        sp,
        wt,
        wl,
        out[:nb],
    )


@njit(**_OPTS)
def _successors_of(geo, sp, wt, wl, ints, tau, ctau, ns, action, out):  # pragma: no cover
    """``model.successor_kernel`` on the ``ns`` buffer rows listed in ``ints[4]`` (copied
    together first: the kernel takes arrays) into ``out[:ns]``."""
    sel, cl, cw, cd = ints[4], ints[5], ints[6], ints[7]
    l, w, d = ints[1], ints[2], ints[3]
    for q in range(ns):
        i = sel[q]
        cl[q] = l[i]
        cw[q] = w[i]
        cd[q] = d[i]
        for j in range(tau.shape[1]):
            ctau[q, j] = tau[i, j]
    successor_kernel(
        cl[:ns],
        cw[:ns],
        cd[:ns],
        ctau[:ns],
        action,
        geo[_N],
        geo[_D],
        geo[_G],
        geo[_RADIX],
        geo[_NTRAVEL],
        sp,
        wt,
        wl,
        out[:ns],
    )


@njit(**_OPTS)
def _loiter_allowed(geo, station_pos, li, di, tau, i):  # pragma: no cover - compiled
    """:meth:`PatrolModel.allowed`'s loiter column for one decoded state."""
    k = station_pos[li]
    if k < 0 or di >= geo[_D]:
        return False
    return di >= 1 or tau[i, k] > 0 or geo[_EMPTY] != 0


@njit(**_OPTS)
def _select_loiter(geo, sp, ints, tau, nb):  # pragma: no cover - compiled
    """List the buffer rows where loitering is allowed in ``ints[4]``; return how many."""
    sel, l, d = ints[4], ints[1], ints[3]
    ns = 0
    for i in range(nb):
        if _loiter_allowed(geo, sp, l[i], d[i], tau, i):
            sel[ns] = i
            ns += 1
    return ns


@njit(**_OPTS)
def _select_action(act, b0, nb, action, ints):  # pragma: no cover - compiled
    """List the buffer rows whose state has ``act[x] == action`` in ``ints[4]``."""
    sel = ints[4]
    ns = 0
    for i in range(nb):
        if act[b0 + i] == action:
            sel[ns] = i
            ns += 1
    return ns


@njit(inline="always", **_OPTS)
def _expect(succ, i, probs, v):  # pragma: no cover - compiled
    """``sum_l probs[l] v[succ[i, l]]`` in the array path's order (from 0.0)."""
    acc = 0.0
    for ll in range(probs.size):
        acc += probs[ll] * v[succ[i, ll]]
    return acc


@njit(inline="always", **_OPTS)
def _expect_lifted(succ, i, probs, labels, w):  # pragma: no cover - compiled
    """``sum_l probs[l] w[labels[succ[i, l]]]``: the expectation of a lifted partition vector."""
    acc = 0.0
    for ll in range(probs.size):
        acc += probs[ll] * w[labels[succ[i, ll]]]
    return acc


@njit(inline="always", **_OPTS)
def _penalty(rho, gamma, tau, i):  # pragma: no cover - compiled
    """``-rho min(taubar, Gamma)``, the float :meth:`PatrolModel.rewards` computes."""
    tb = 0
    for j in range(tau.shape[1]):
        if tau[i, j] > tb:
            tb = tau[i, j]
    return -rho * np.float64(min(tb, gamma))


@njit(inline="always", **_OPTS)
def _partition_of(geo, station_pos, ints, tau, i):  # pragma: no cover - compiled
    """The partition of buffer row ``i`` (:func:`.partitions.state_partition_kernel`)."""
    return state_partition_kernel(
        ints[1][i],
        ints[2][i],
        ints[3][i],
        tau[i],
        station_pos,
        geo[_N],
        geo[_D],
        geo[_G],
        geo[_TBS],
        geo[_LBS],
    )


@njit(**_OPTS)
def _chunk(n, nchunks, big_r, c):  # pragma: no cover - compiled
    """States ``[start, end)`` of chunk ``c``: consecutive, starting at a row boundary."""
    size = (n + nchunks - 1) // nchunks
    size = (size + big_r - 1) // big_r * big_r
    return min(n, c * size), min(n, (c + 1) * size)


@njit(parallel=True, **_OPTS)
def _sweep_max_kernel(
    geo, stations, sp, wt, wl, probs, inc, rho, lam, v, out, arg, nchunks, block
):  # pragma: no cover - compiled
    """``out = T v`` (first maximising action in ``arg``); returns min, max of ``out - v``."""
    n = v.size
    lo_c = np.full(nchunks, np.inf)
    hi_c = np.full(nchunks, -np.inf)
    for c in prange(nchunks):
        ints, tau, ctau, s = _buffers(block, geo[_M])
        sel = ints[4]
        lc, hc = np.inf, -np.inf
        start, end = _chunk(n, nchunks, geo[_ROW], c)
        for b0 in range(start, end, block):
            nb = min(block, end - b0)
            _decode_rows(b0, nb, geo, stations, ints, tau, ctau)
            _successors(geo, sp, wt, wl, ints, tau, nb, 0, s[0])
            _successors(geo, sp, wt, wl, ints, tau, nb, 1, s[1])
            ns = _select_loiter(geo, sp, ints, tau, nb)
            _successors_of(geo, sp, wt, wl, ints, tau, ctau, ns, 2, s[2])
            p = 0
            for i in range(nb):
                pen = _penalty(rho, geo[_G], tau, i)
                best = pen + lam * _expect(s[0], i, probs, v)
                best_a = 0
                q = pen + lam * _expect(s[1], i, probs, v)
                if q > best:
                    best, best_a = q, 1
                if p < ns and sel[p] == i:
                    q = (pen + inc[ints[3][i]]) + lam * _expect(s[2], p, probs, v)
                    p += 1
                    if q > best:
                        best, best_a = q, 2
                x = b0 + i
                out[x] = best
                arg[x] = best_a
                diff = best - v[x]
                lc = min(lc, diff)
                hc = max(hc, diff)
        lo_c[c] = lc
        hi_c[c] = hc
    return lo_c.min(), hi_c.max()


@njit(parallel=True, **_OPTS)
def _sweep_policy_kernel(
    geo, stations, sp, wt, wl, probs, inc, rho, lam, act, v, out, nchunks, block
):  # pragma: no cover - compiled
    """``out = T_pi v`` for the actions ``act``; returns min, max of ``out - v``."""
    n = v.size
    lo_c = np.full(nchunks, np.inf)
    hi_c = np.full(nchunks, -np.inf)
    for c in prange(nchunks):
        ints, tau, ctau, s = _buffers(block, geo[_M])
        sel, d = ints[4], ints[3]
        lc, hc = np.inf, -np.inf
        start, end = _chunk(n, nchunks, geo[_ROW], c)
        for b0 in range(start, end, block):
            nb = min(block, end - b0)
            _decode_rows(b0, nb, geo, stations, ints, tau, ctau)
            for a in range(3):
                ns = _select_action(act, b0, nb, a, ints)
                _successors_of(geo, sp, wt, wl, ints, tau, ctau, ns, a, s[a])
                for p in range(ns):
                    i = sel[p]
                    r = _penalty(rho, geo[_G], tau, i)
                    if a == 2:
                        r = r + inc[d[i]]
                    q = r + lam * _expect(s[a], p, probs, v)
                    x = b0 + i
                    out[x] = q
                    diff = q - v[x]
                    lc = min(lc, diff)
                    hc = max(hc, diff)
        lo_c[c] = lc
        hi_c[c] = hc
    return lo_c.min(), hi_c.max()


@njit(parallel=True, **_OPTS)
def _check_policy_kernel(geo, stations, sp, act, nchunks, block):  # pragma: no cover
    """First state whose action ``act[x]`` is a forbidden loiter, or -1 (``act`` is known
    to hold 0, 1 or 2)."""
    n = act.size
    first = np.full(nchunks, -1, np.int64)
    for c in prange(nchunks):
        ints, tau, ctau, _ = _buffers(block, geo[_M])
        start, end = _chunk(n, nchunks, geo[_ROW], c)
        for b0 in range(start, end, block):
            if first[c] >= 0:
                break
            nb = min(block, end - b0)
            _decode_rows(b0, nb, geo, stations, ints, tau, ctau)
            for i in range(nb):
                if act[b0 + i] == 2 and not _loiter_allowed(
                    geo, sp, ints[1][i], ints[3][i], tau, i
                ):
                    first[c] = b0 + i
                    break
    for c in range(nchunks):
        if first[c] >= 0:
            return first[c]
    return -1


@njit(parallel=True, **_OPTS)
def _reward_absmax_kernel(geo, stations, sp, inc, rho, n, nchunks, block):  # pragma: no cover
    """``max |R_u(x)|`` over the allowed pairs (the scale of the default tolerance)."""
    best = np.zeros(nchunks)
    for c in prange(nchunks):
        ints, tau, ctau, _ = _buffers(block, geo[_M])
        bc = 0.0
        start, end = _chunk(n, nchunks, geo[_ROW], c)
        for b0 in range(start, end, block):
            nb = min(block, end - b0)
            _decode_rows(b0, nb, geo, stations, ints, tau, ctau)
            for i in range(nb):
                pen = _penalty(rho, geo[_G], tau, i)
                bc = max(bc, abs(pen))
                if _loiter_allowed(geo, sp, ints[1][i], ints[3][i], tau, i):
                    bc = max(bc, abs(pen + inc[ints[3][i]]))
        best[c] = bc
    return best.max()


@njit(parallel=True, **_OPTS)
def _labels_kernel(geo, stations, sp, labels, nchunks, block):  # pragma: no cover - compiled
    """``labels[x]``: the partition of every state (Section 4.2)."""
    n = labels.size
    for c in prange(nchunks):
        ints, tau, ctau, _ = _buffers(block, geo[_M])
        start, end = _chunk(n, nchunks, geo[_ROW], c)
        for b0 in range(start, end, block):
            nb = min(block, end - b0)
            _decode_rows(b0, nb, geo, stations, ints, tau, ctau)
            for i in range(nb):
                labels[b0 + i] = _partition_of(geo, sp, ints, tau, i)


@njit(parallel=True, **_OPTS)
def _decode_range_kernel(geo, stations, start, comps, nchunks, block):  # pragma: no cover
    """Components ``(l, w, d, tau)`` of states ``start ..`` as the sweeps decode them (the
    row decoding, for tests). ``start`` and ``len(comps)`` are multiples of the row."""
    n = comps.shape[0]
    m = geo[_M]
    for c in prange(nchunks):
        ints, tau, ctau, _ = _buffers(block, m)
        lo, hi = _chunk(n, nchunks, geo[_ROW], c)
        for b0 in range(lo, hi, block):
            nb = min(block, hi - b0)
            _decode_rows(start + b0, nb, geo, stations, ints, tau, ctau)
            for i in range(nb):
                comps[b0 + i, 0] = ints[1][i]
                comps[b0 + i, 1] = ints[2][i]
                comps[b0 + i, 2] = ints[3][i]
                for j in range(m):
                    comps[b0 + i, 3 + j] = tau[i, j]


# columns of the per-chunk statistics of the greedy pass
_F_UP_SUM, _F_UP_MAX, _F_UP_MIN, _F_LOW_SUM, _F_LOW_MAX, _F_LOW_MIN = range(6)
_F_GAP_SUM, _F_GAP_MAX, _F_LOSS_MAX = range(6, 9)
_I_UP_ARGMIN, _I_LOW_ARGMIN, _I_OPTIMAL, _I_DIFFERS, _I_SUBOPT = range(5)


@njit(**_OPTS)
def _greedy_state(i, p, ns, sel, s, probs, inc, d, pen, lam, v, labels, w_low, tie, qv, qw):
    # pragma: no cover - compiled
    """Q-values of ``v`` and of the lifted ``w_low`` at buffer row ``i`` (``qv``, ``qw``);
    returns the number of actions (3 when row ``i`` is the loiter list's entry ``p``)."""
    n_act = 3 if (p < ns and sel[p] == i) else 2
    for a in range(n_act):
        r = pen + inc[d[i]] if a == 2 else pen
        row = p if a == 2 else i
        qv[a] = r + lam * _expect(s[a], row, probs, v)
        qw[a] = r + lam * _expect_lifted(s[a], row, probs, labels, w_low)
    return n_act


@njit(parallel=True, **_OPTS)
def _greedy_gap_kernel(
    geo,
    stations,
    sp,
    wt,
    wl,
    probs,
    inc,
    rho,
    lam,
    v,
    labels,
    w_low,
    v_up,
    pistar,
    tie_rtol,
    loss_tol,
    pi_s,
    fstats,
    istats,
    nchunks,
    block,
):  # pragma: no cover - compiled
    """One pass: ``pi_s`` greedy w.r.t. the lifted ``w_low`` (lowest action among those tied
    within ``tie_rtol``, as :func:`lpbounds.greedy_policy`), whether it is among ``v``'s
    optimal actions (tied within ``tie_rtol``), its one-step loss, and the gaps
    ``v_up - v``, ``v - w_low``, ``v_up - w_low`` at every state."""
    n = v.size
    for c in prange(nchunks):
        ints, tau, ctau, s = _buffers(block, geo[_M])
        sel, d = ints[4], ints[3]
        qv = np.empty(3)
        qw = np.empty(3)
        f = fstats[c]
        f[:] = 0.0
        for col in (_F_UP_MIN, _F_LOW_MIN):
            f[col] = np.inf
        for col in (_F_UP_MAX, _F_LOW_MAX, _F_GAP_MAX, _F_LOSS_MAX):
            f[col] = -np.inf
        st = istats[c]
        st[:] = 0
        start, end = _chunk(n, nchunks, geo[_ROW], c)
        for b0 in range(start, end, block):
            nb = min(block, end - b0)
            _decode_rows(b0, nb, geo, stations, ints, tau, ctau)
            _successors(geo, sp, wt, wl, ints, tau, nb, 0, s[0])
            _successors(geo, sp, wt, wl, ints, tau, nb, 1, s[1])
            ns = _select_loiter(geo, sp, ints, tau, nb)
            _successors_of(geo, sp, wt, wl, ints, tau, ctau, ns, 2, s[2])
            p = 0
            for i in range(nb):
                x = b0 + i
                pen = _penalty(rho, geo[_G], tau, i)
                n_act = _greedy_state(
                    i, p, ns, sel, s, probs, inc, d, pen, lam, v, labels, w_low, tie_rtol, qv, qw
                )
                if n_act == 3:
                    p += 1
                best_v = qv[:n_act].max()
                best_w = qw[:n_act].max()
                thr_w = best_w - tie_rtol * max(1.0, abs(best_w))
                a_s = 0
                while qw[a_s] < thr_w:
                    a_s += 1
                pi_s[x] = a_s
                if qv[a_s] >= best_v - tie_rtol * max(1.0, abs(best_v)):
                    st[_I_OPTIMAL] += 1
                loss = best_v - qv[a_s]
                f[_F_LOSS_MAX] = max(f[_F_LOSS_MAX], loss)
                if loss > loss_tol:
                    st[_I_SUBOPT] += 1
                if a_s != pistar[x]:
                    st[_I_DIFFERS] += 1
                k = labels[x]
                up = v_up[k] - v[x]
                low = v[x] - w_low[k]
                f[_F_UP_SUM] += up
                f[_F_UP_MAX] = max(f[_F_UP_MAX], up)
                if up < f[_F_UP_MIN]:
                    f[_F_UP_MIN] = up
                    st[_I_UP_ARGMIN] = x
                f[_F_LOW_SUM] += low
                f[_F_LOW_MAX] = max(f[_F_LOW_MAX], low)
                if low < f[_F_LOW_MIN]:
                    f[_F_LOW_MIN] = low
                    st[_I_LOW_ARGMIN] = x
                gap = v_up[k] - w_low[k]
                f[_F_GAP_SUM] += gap
                f[_F_GAP_MAX] = max(f[_F_GAP_MAX], gap)


_S_SUM, _S_MAX, _S_MIN, _S_LOW_MIN = range(4)
_J_ARGMAX, _J_ARGMIN, _J_LOW_ARGMIN = range(3)


@njit(parallel=True, **_OPTS)
def _vsub_kernel(
    geo, stations, sp, vstar, vsub, w_low, fstats, istats, nchunks, block
):  # pragma: no cover - compiled
    """Statistics of ``vstar - vsub`` (sum, max, min with their states) and the smallest
    ``vsub - w_low`` (the lifted lower bound) with its state."""
    n = vstar.size
    for c in prange(nchunks):
        ints, tau, ctau, _ = _buffers(block, geo[_M])
        f = fstats[c]
        f[_S_SUM] = 0.0
        f[_S_MAX] = -np.inf
        f[_S_MIN] = np.inf
        f[_S_LOW_MIN] = np.inf
        st = istats[c]
        st[:] = 0
        start, end = _chunk(n, nchunks, geo[_ROW], c)
        for b0 in range(start, end, block):
            nb = min(block, end - b0)
            _decode_rows(b0, nb, geo, stations, ints, tau, ctau)
            for i in range(nb):
                x = b0 + i
                diff = vstar[x] - vsub[x]
                f[_S_SUM] += diff
                if diff > f[_S_MAX]:
                    f[_S_MAX] = diff
                    st[_J_ARGMAX] = x
                if diff < f[_S_MIN]:
                    f[_S_MIN] = diff
                    st[_J_ARGMIN] = x
                k = _partition_of(geo, sp, ints, tau, i)
                low = vsub[x] - w_low[k]
                if low < f[_S_LOW_MIN]:
                    f[_S_LOW_MIN] = low
                    st[_J_LOW_ARGMIN] = x


# ---------------------------------------------------------------------- the model
class MatrixFreePatrol:
    """The patrol MDP of one :class:`PatrolParams` as compiled sweeps (nothing stored per state).

    Parameters
    ----------
    params : PatrolParams, optional
        Default: the paper's example.

    Notes
    -----
    The state encoding, the dynamics and the partitions are those of
    :class:`~lpbounds.patrol.model.PatrolModel` (whose geometry arrays this class takes);
    the sweeps run in parallel over chunks of consecutive states (numba ``prange``).
    """

    def __init__(self, params: PatrolParams | None = None) -> None:
        pm = PatrolModel(params)
        p = pm.params
        self.params = p
        self.model = pm
        self.n_vars = int(p.n_states)
        self.discount = float(p.discount)
        tb_size, lb_size = block_sizes(p)
        self._geo = np.array(
            [
                p.N,
                p.m,
                p.D,
                p.Gamma,
                pm.radix,
                pm.n_travel,
                int(p.allow_empty_loiter),
                tb_size,
                lb_size,
                pm.radix if p.m >= 2 else 1,
            ],
            dtype=np.int64,
        )
        self._stations = np.ascontiguousarray(pm.stations, dtype=np.int64)
        self._sp = np.ascontiguousarray(pm.station_pos, dtype=np.int64)
        self._wt = np.ascontiguousarray(pm.w_travel, dtype=np.int64)
        self._wl = np.ascontiguousarray(pm.w_loiter, dtype=np.int64)
        self._probs = np.ascontiguousarray(p.alert_probabilities(), dtype=np.float64)
        # the loiter reward's increment per dwell d (d = D: loiter not allowed)
        self._inc = np.append(p.information_increments(), 0.0)
        self._rho = float(p.rho)
        self._reward_absmax: float | None = None
        row = int(self._geo[_ROW])
        self._block = max(1, BLOCK // row) * row  # whole rows

    def __repr__(self) -> str:
        return f"MatrixFreePatrol(n_states={self.n_vars:,}, m={self.params.m})"

    #: The sweeps are compiled (for :func:`lpbounds.dp.threads_for`, which runs sweeps of
    #: fewer than ``SERIAL_SWEEP_READS`` reads on one thread, as the array path does).
    compiled: bool = True

    @property
    def n_rows(self) -> int:
        """State-action pairs at most (three actions per state): the size of a sweep."""
        return 3 * self.n_vars

    @property
    def n_outcomes(self) -> int:
        """Outcomes per pair, ``m + 1``."""
        return self.params.m + 1

    @property
    def sweep_reads(self) -> int:
        """Values a sweep reads at most, ``n_rows * n_outcomes`` (the thread rule of
        :func:`lpbounds.dp.threads_for`, as for the array path's rows)."""
        return self.n_rows * self.n_outcomes

    @staticmethod
    def nchunks() -> int:
        """Work chunks per sweep (a few per numba thread)."""
        from .._kernels.dispatch import nchunks

        return nchunks()

    def _common(self) -> tuple[Any, ...]:
        return (
            self._geo,
            self._stations,
            self._sp,
            self._wt,
            self._wl,
            self._probs,
            self._inc,
            self._rho,
            self.discount,
        )

    @property
    def reward_absmax(self) -> float:
        """``max |R_u(x)|`` over the allowed pairs (one pass over the states, cached)."""
        if self._reward_absmax is None:
            self._reward_absmax = float(
                _reward_absmax_kernel(
                    self._geo,
                    self._stations,
                    self._sp,
                    self._inc,
                    self._rho,
                    self.n_vars,
                    self.nchunks(),
                    self._block,
                )
            )
        return self._reward_absmax

    def row_sums(self) -> RowSums:
        """Certified bounds on the exact sum of the alert distribution ``p_l``."""
        return row_sums(self._probs)

    def modulus(self) -> float:
        """The contraction modulus ``lambda sum_l p_l`` (rounded up) of the error bounds."""
        return self.row_sums().modulus(self.discount)

    def default_tol(self) -> float:
        """:func:`lpbounds.solve_exact`'s default (:func:`lpbounds.tolerances.dp_default_tol`)."""
        return dp_default_tol(self.reward_absmax, self.discount, self.n_outcomes)

    # ------------------------------------------------------------------ sweep protocol
    def new_vector(self) -> np.ndarray:
        """An uninitialised float64 vector over the states."""
        return np.empty(self.n_vars)

    def new_arg(self) -> np.ndarray:
        """A zeroed array for the chosen action of every state (int8)."""
        return np.zeros(self.n_vars, dtype=np.int8)

    def new_work(self) -> None:
        """No scratch array: the sweeps keep their buffers per thread, a block at a time."""
        return None

    def evaluator(self, work: np.ndarray | None = None) -> PolicySweeps:
        """Evaluation sweeps of one policy at a time (in place: nothing to pack)."""
        return PolicySweeps(self)

    def sweep_max(
        self,
        v: np.ndarray,
        out: np.ndarray,
        arg: np.ndarray,
        *,
        work: np.ndarray | None = None,
        nchunks: int | None = None,
    ) -> tuple[float, float]:
        """``out = T v``, the first maximising action in ``arg`` (int8); returns the min and
        max of ``out - v`` (``work`` is unused; ``nchunks`` default :meth:`nchunks`)."""
        nc = self.nchunks() if nchunks is None else nchunks
        lo, hi = _sweep_max_kernel(*self._common(), v, out, arg, nc, self._block)
        return float(lo), float(hi)

    def sweep_policy(
        self,
        sel: np.ndarray,
        v: np.ndarray,
        out: np.ndarray,
        *,
        work: np.ndarray | None = None,
        nchunks: int | None = None,
    ) -> tuple[float, float]:
        """``out = T_pi v`` for the actions ``sel`` (int8); returns min and max of ``out - v``."""
        nc = self.nchunks() if nchunks is None else nchunks
        lo, hi = _sweep_policy_kernel(*self._common(), sel, v, out, nc, self._block)
        return float(lo), float(hi)

    # ------------------------------------------------------------------ passes
    def labels(self) -> np.ndarray:
        """The partition of every state, int32 (computed, as the model's :meth:`partition`)."""
        out = np.empty(self.n_vars, dtype=np.int32)
        _labels_kernel(self._geo, self._stations, self._sp, out, self.nchunks(), self._block)
        return out

    def check_policy(self, policy: Any) -> np.ndarray:
        """``policy`` as an int8 array of allowed actions, or a ValidationError naming the
        first state where it is not one."""
        pol = np.asarray(policy)
        if pol.shape != (self.n_vars,) or pol.dtype.kind not in "iu":
            raise ValidationError(
                f"a policy must be {self.n_vars} integers; got {pol.shape} {pol.dtype}"
            )
        if pol.size and (pol.min() < 0 or pol.max() > 2):
            x = int(np.flatnonzero((pol < 0) | (pol > 2))[0])
            raise ValidationError(f"policy[{x}] = {int(pol[x])} is not an action index 0..2")
        act = np.ascontiguousarray(pol, dtype=np.int8)
        x = int(
            _check_policy_kernel(
                self._geo, self._stations, self._sp, act, self.nchunks(), self._block
            )
        )
        if x >= 0:
            raise ValidationError(f"policy[{x}] = {int(act[x])} is not allowed in state {x}")
        return act

    def greedy_gap(
        self,
        vstar: np.ndarray,
        pistar: np.ndarray,
        w_low: np.ndarray,
        v_up: np.ndarray,
        loss_tol: float,
        tie_rtol: float = GREEDY_TIE_RTOL,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """One pass: ``pi_s`` greedy w.r.t. the lifted ``w_low`` and the gap statistics.

        Parameters
        ----------
        vstar : ndarray
            ``V*`` over the states.
        pistar : ndarray of int
            ``V*``'s policy (counts where ``pi_s`` differs from it).
        w_low, v_up : ndarray
            Lower and upper bounds per partition.
        loss_tol : float
            A one-step loss ``max_u Q*(x, u) - Q*(x, pi_s(x))`` above it counts as
            certainly suboptimal.
        tie_rtol : float
            Ties as in :func:`lpbounds.greedy_policy` (lowest action among them).

        Returns
        -------
        pi_s : ndarray of int8
        stats : dict
            ``upper_*`` (``v_up - V*``), ``lower_*`` (``V* - w_low``), ``gap_*``
            (``v_up - w_low``): max, mean, min with its state; ``optimal``, ``differs``,
            ``suboptimal`` (state counts) and ``max_one_step_loss``.
        """
        labels = self.labels()
        nch = self.nchunks()
        f = np.empty((nch, 9))
        st = np.empty((nch, 5), dtype=np.int64)
        pi_s = np.empty(self.n_vars, dtype=np.int8)
        _greedy_gap_kernel(
            *self._common(),
            vstar,
            labels,
            np.ascontiguousarray(w_low, dtype=np.float64),
            np.ascontiguousarray(v_up, dtype=np.float64),
            np.ascontiguousarray(pistar, np.int8),
            float(tie_rtol),
            float(loss_tol),
            pi_s,
            f,
            st,
            nch,
            self._block,
        )
        del labels
        return pi_s, _reduce_greedy(f, st, self.n_vars)

    def vsub_stats(self, vstar: np.ndarray, vsub: np.ndarray, w_low: np.ndarray) -> dict[str, Any]:
        """Max, mean and min of ``vstar - vsub`` and the smallest ``vsub - w_low`` (the lifted
        lower bound), each with its state, in one pass."""
        nch = self.nchunks()
        f = np.empty((nch, 4))
        st = np.empty((nch, 3), dtype=np.int64)
        _vsub_kernel(
            self._geo,
            self._stations,
            self._sp,
            vstar,
            vsub,
            np.ascontiguousarray(w_low, dtype=np.float64),
            f,
            st,
            nch,
            self._block,
        )
        c_max = int(np.argmax(f[:, _S_MAX]))
        c_min = int(np.argmin(f[:, _S_MIN]))
        c_low = int(np.argmin(f[:, _S_LOW_MIN]))
        return {
            "max": float(f[c_max, _S_MAX]),
            "argmax": int(st[c_max, _J_ARGMAX]),
            "mean": float(f[:, _S_SUM].sum() / self.n_vars),
            "min": float(f[c_min, _S_MIN]),
            "argmin": int(st[c_min, _J_ARGMIN]),
            "low_min": float(f[c_low, _S_LOW_MIN]),
            "low_argmin": int(st[c_low, _J_LOW_ARGMIN]),
        }


def _reduce_greedy(f: np.ndarray, st: np.ndarray, n: int) -> dict[str, Any]:
    """Merge the greedy pass's per-chunk statistics (:meth:`MatrixFreePatrol.greedy_gap`)."""
    up_c = int(np.argmin(f[:, _F_UP_MIN]))
    low_c = int(np.argmin(f[:, _F_LOW_MIN]))
    up_mean = float(f[:, _F_UP_SUM].sum() / n)
    low_mean = float(f[:, _F_LOW_SUM].sum() / n)
    gap_mean = float(f[:, _F_GAP_SUM].sum() / n)
    return {
        "upper_max": float(f[:, _F_UP_MAX].max()),
        "upper_mean": up_mean,
        "upper_min": float(f[up_c, _F_UP_MIN]),
        "upper_argmin": int(st[up_c, _I_UP_ARGMIN]),
        "lower_max": float(f[:, _F_LOW_MAX].max()),
        "lower_mean": low_mean,
        "lower_min": float(f[low_c, _F_LOW_MIN]),
        "lower_argmin": int(st[low_c, _I_LOW_ARGMIN]),
        "gap_max": float(f[:, _F_GAP_MAX].max()),
        "gap_mean": gap_mean,
        "upper_share": up_mean / gap_mean if gap_mean > 0 else float("nan"),
        "lower_share": low_mean / gap_mean if gap_mean > 0 else float("nan"),
        "optimal": int(st[:, _I_OPTIMAL].sum()),
        "differs": int(st[:, _I_DIFFERS].sum()),
        "suboptimal": int(st[:, _I_SUBOPT].sum()),
        "max_one_step_loss": float(f[:, _F_LOSS_MAX].max()),
    }


# ---------------------------------------------------------------------- solvers
Callback = Callable[[int, float], None]


def _absmax(v: np.ndarray) -> float:
    """``max |v|`` without a temporary of the vector's size."""
    return max(abs(float(v.max(initial=0.0))), abs(float(v.min(initial=0.0))))


def check_finite(what: str, v: np.ndarray, res: float) -> float:
    """``max |v|``, or a ConvergenceError naming ``what`` when it or ``res`` is not finite.

    No temporary of the vector's size (a 6-station vector is 4.3 GB).
    """
    vmax = _absmax(v)
    if not (np.isfinite(vmax) and np.isfinite(res)):
        raise ConvergenceError(
            f"{what} produced non-finite values (max|V| = {vmax}, residual {res})"
        )
    return vmax


def solve_vstar(
    mf: MatrixFreePatrol,
    *,
    eval_sweeps: int | Literal["auto"] = "auto",
    max_iter: int = 100_000,
    tol: float | None = None,
    callback: Callback | None = None,
    raise_on_failure: bool = True,
) -> DPResult:
    """``V*`` by modified policy iteration from 0: :func:`lpbounds.solve_exact`'s loop
    (:func:`lpbounds.dp.mpi_loop`: same numbers, bit for bit), in two value vectors.

    Parameters
    ----------
    mf : MatrixFreePatrol
    eval_sweeps : int or "auto"
        Evaluation sweeps per improvement step, as in :func:`lpbounds.solve_exact`
        (default ``"auto"``: none while the policy changes).
    max_iter : int
        Limit on improvement steps.
    tol : float, optional
        Stop when ``||T V - V||_inf <= tol``; default :meth:`MatrixFreePatrol.default_tol`.
    callback : callable(iteration, residual), optional
        Called after each improvement step.
    raise_on_failure : bool
        Raise ConvergenceError at ``max_iter`` (else return ``Status.ITERATION_LIMIT``).

    Returns
    -------
    DPResult
        ``policy`` is int8 (the first maximising action), and ``policy_rows`` is the same
        array: the operator's choices are its actions (it stores no rows).
    """
    t0 = time.perf_counter()
    eval_sweeps = check_eval_sweeps(eval_sweeps)
    max_iter = check_int("max_iter", max_iter, lo=1)
    tol_ = mf.default_tol() if tol is None else float(tol)
    if not tol_ > 0:
        raise ValidationError(f"tol must be a positive number; got {tol!r}")
    run = mpi_loop(mf, np.zeros(mf.n_vars), tol_, max_iter, eval_sweeps, True, callback)
    return run.finish("mpi", run.arg, run.arg, tol_, mf.modulus(), t0, raise_on_failure)


def evaluate_policy(
    mf: MatrixFreePatrol,
    policy: Any,
    *,
    tol: float | None = None,
    max_sweeps: int = 1_000_000,
    callback: Callback | None = None,
) -> PolicyEvaluation:
    """``V_pi`` by extrapolated evaluation sweeps: :func:`lpbounds.evaluate_policy`'s
    iterative method (:func:`lpbounds.dp.evaluation_loop`: same numbers, bit for bit), in
    two value vectors.

    The residual is measured by one more sweep on the returned vector; the error bound is
    :func:`lpbounds.tolerances.error_bound` of it. ``callback(sweep, residual)``, if given,
    is called after every sweep (progress of a long evaluation).

    Raises
    ------
    ValidationError
        ``policy`` is not one allowed action per state (names the first bad state).
    ConvergenceError
        The residual did not reach ``tol`` in ``max_sweeps`` sweeps.
    """
    t0 = time.perf_counter()
    act = mf.check_policy(policy)
    tol_ = mf.default_tol() if tol is None else float(tol)
    run = evaluation_loop(mf, act, tol_, max_sweeps, callback)
    res = run.residual
    vmax = check_finite("matrix-free policy evaluation", run.values, res)
    if res > tol_:
        raise ConvergenceError(f"policy evaluation stopped with residual {res:.3e} > {tol_:.3e}")
    return PolicyEvaluation(
        values=run.values,
        residual=res,
        error_bound=error_bound(res, vmax, mf.modulus()),
        method="iterative (matrix-free)",
        sweeps=run.sweeps,
        seconds=time.perf_counter() - t0,
    )
