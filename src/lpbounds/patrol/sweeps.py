r"""Compiled kernels of the matrix-free patrol sweeps: the state space walked in index order.

The state encoding of :mod:`lpbounds.patrol.model` is mixed radix: a *plane* of states
(travel: one ``(l, w)``; loiter: one ``(station, d)``) is a counter over the delays, the
last station's delay (in a loiter plane: the last other station's) its fast digit. So
the states of one *row* (``Gamma + 1`` consecutive indices, the fast digit ``t`` running
``0..Gamma``) share every component but that digit, and the row after a row is the
counter plus one. No state index is decoded but a chunk's first:

* a *cursor* holds the plane and the delays of the current row (:func:`cursor_at` decodes
  a chunk's first state, :func:`advance` moves to the next row, carrying digits); what
  depends on the plane alone (components, the successor planes' first indices, the loiter
  rule) is a table built once per model (:func:`geometry`);
* :func:`row_setup` turns the row into, per action ``a`` and outcome ``o`` (``o = 0`` no
  alert, ``o = j + 1`` an alert at station ``j``), the successor's index at ``t = 0``,
  ``rr[a, 0, o]``, and at ``t >= 1``, ``rr[a, 1, o] + f(t) gl[a]``: ``f(t) = min(t + 1,
  Gamma)`` is the fast digit's next delay and ``gl[a]`` its weight in the successor's
  encoding (a few integer operations per row, none per state);
* the per-row loops read, per outcome, the successors of the row's states: for
  ``t = 1..Gamma-1`` an arithmetic sequence of indices (``gl[a]`` apart, mostly 1), a
  loop over four states at a time, their sums in registers (vector operations);
* the max and policy sweeps take the two travel planes of a node, ``(l, +1)`` and
  ``(l, -1)``, together: "continue" from one and "reverse" from the other lead to the
  same successors (the array path's post-decision states), so one row of sums serves
  both planes' rows, and the work of a sweep is about that of the post-decision form.

The arithmetic is that of the array path (:class:`lpbounds.rows.PostDecisionRows` and
the row kernels): ``acc = 0.0; acc += p_o v(g_o)`` over the outcomes in order (the loop
over outcomes is outside the loop over the row's states, so every state still receives
its terms in outcome order), then ``q = R_u(x) + lambda acc`` with ``R_u(x)`` the float
:meth:`PatrolModel.rewards` stores (``-rho min(taubar, Gamma)``, the table ``pent``, plus
the information increment for a loiter); the maximum keeps the first maximising action.
A sum used twice (the two planes of a node, the states ``t = Gamma - 1`` and ``Gamma``,
which have the same successors) is one computation of the same terms in the same order.
The successor indices are those of :func:`lpbounds.patrol.model.successor_kernel`
(``tests/patrol/test_sweeps.py`` compares them, the sums, the partitions and the greedy
pass with the decode-per-state model at every state), so every value is the array
path's, bit for bit.

Work is split into ``nchunks`` chunks of consecutive whole rows (numba ``prange``); a
chunk walks its rows in order, so its reads move forward through the one to three planes
of ``v`` that its plane's successors lie in, and a row's sums (``3 (Gamma + 1)`` floats)
stay in the first-level cache. The walk's helpers are inlined into the kernels, and the
shared vectors are indexed, never sliced, inside the loops (a slice counts a reference,
an atomic operation, on memory every thread shares).

Every name here is public for :mod:`lpbounds.patrol.matrix_free`, this module's one user.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

from .params import PatrolParams
from .partitions import block_sizes, key_index_kernel

__all__ = [
    "F_GAP_MAX",
    "F_GAP_SUM",
    "F_LOSS_MAX",
    "F_LOW_MAX",
    "F_LOW_MIN",
    "F_LOW_SUM",
    "F_UP_MAX",
    "F_UP_MIN",
    "F_UP_SUM",
    "GEO_FIELDS",
    "I_DIFFERS",
    "I_LOW_ARGMIN",
    "I_OPTIMAL",
    "I_SUBOPT",
    "I_UP_ARGMIN",
    "J_ARGMAX",
    "J_ARGMIN",
    "J_LOW_ARGMIN",
    "PLANE_FIELDS",
    "S_LOW_MIN",
    "S_MAX",
    "S_MIN",
    "S_SUM",
    "advance",
    "check_policy_pass",
    "cursor_at",
    "decode_range",
    "geometry",
    "greedy_pass",
    "labels_pass",
    "max_sweep",
    "policy_sweep",
    "reward_absmax_pass",
    "row_setup",
    "successor_range",
    "vsub_pass",
]

_OPTS: dict[str, Any] = {"cache": True, "nogil": True, "fastmath": False}

#: Fields of the integer geometry vector ``geo``, in order (:func:`geometry`).
GEO_FIELDS: tuple[str, ...] = (
    "N",  # nodes
    "m",  # stations
    "D",  # largest dwell
    "Gamma",  # delay cap
    "R",  # radix Gamma + 1: the length of a row
    "T",  # travel states 2 N R^m (loiter indices start here)
    "tb_size",  # partition keys per travel block
    "lb_size",  # partition keys per loiter block
    "n",  # states
)
_N, _M, _D, _G, _R, _T, _TBS, _LBS, _NS = range(len(GEO_FIELDS))

#: Columns of the plane table (:func:`geometry`): the plane's ``l, w, d``, the station
#: position of ``l`` (-1: none), the station of the fast digit (-1: none, a 1-station
#: loiter plane), the loiter rule, the first index of each action's successor plane, and
#: the first state of the plane.
PLANE_FIELDS: tuple[str, ...] = ("l", "w", "d", "k", "last", "loiter", "b0", "b1", "b2", "x0")
_PL, _PW, _PD, _PK, _PLAST, _PLOITER, _PB0, _PB1, _PB2, _PX0 = range(len(PLANE_FIELDS))

#: Loiter rules: never, at every state, from fast digit 1 on (the own delay is the fast
#: digit), when the own delay (a slower digit) is positive.
_NEVER, _ALWAYS, _FROM_ONE, _BY_DELAY = 0, 1, 2, 3


def geometry(params: PatrolParams) -> tuple[np.ndarray, ...]:
    """The arrays every kernel takes, in order.

    Returns
    -------
    geo : ndarray of int64
        The sizes of :data:`GEO_FIELDS`.
    planes : ndarray of int64, shape (2 N + m D, len(PLANE_FIELDS))
        One row per plane (travel ``(l, w)`` in index order, then loiter ``(k, d)``).
    sp : ndarray of int64
        The station position of each node (-1: none).
    weights : ndarray of int64, shape (m + 1, m)
        The index weights of the delays in a successor: row ``k < m`` a loiter state at
        station ``k`` (the model's ``w_loiter``), row ``m`` a travel state (``w_travel``).
    probs : ndarray
        The alert distribution ``p_0..p_m``.
    inc : ndarray
        The loiter reward's increment per dwell ``d`` (0 at ``d = D``, no loiter).
    pent : ndarray
        ``-rho tb`` for ``tb = 0..Gamma``: the penalty as :meth:`PatrolModel.rewards`
        computes it.
    """
    from .model import PatrolModel

    pm = PatrolModel(params)
    p = pm.params
    m, n_nodes, big_d, r = p.m, p.N, p.D, p.Gamma + 1
    tb_size, lb_size = block_sizes(p)
    geo = np.array(
        [n_nodes, m, big_d, p.Gamma, r, pm.n_travel, tb_size, lb_size, p.n_states],
        dtype=np.int64,
    )
    sp = np.ascontiguousarray(pm.station_pos, dtype=np.int64)
    planes = np.zeros((2 * n_nodes + m * big_d, len(PLANE_FIELDS)), dtype=np.int64)
    for plane in range(planes.shape[0]):
        planes[plane] = _plane_row(plane, p, pm.n_travel, sp)
    weights = np.vstack([pm.w_loiter, pm.w_travel[None, :]]).astype(np.int64)
    inc = np.append(p.information_increments(), 0.0)
    pent = -p.rho * np.arange(p.Gamma + 1).astype(np.float64)
    return (
        geo,
        planes,
        sp,
        np.ascontiguousarray(weights),
        np.ascontiguousarray(p.alert_probabilities(), dtype=np.float64),
        np.ascontiguousarray(inc, dtype=np.float64),
        np.ascontiguousarray(pent, dtype=np.float64),
    )


def _plane_row(plane: int, p: PatrolParams, n_travel: int, sp: np.ndarray) -> list[int]:
    """One row of the plane table (:data:`PLANE_FIELDS`)."""
    m, n_nodes, big_d, r = p.m, p.N, p.D, p.Gamma + 1
    if plane < 2 * n_nodes:
        l, w, d = plane // 2, 1 - 2 * (plane % 2), 0
        k = int(sp[l])
        last = m - 1
        x0 = plane * r**m
    else:
        k, d = divmod(plane - 2 * n_nodes, big_d)
        d += 1
        l, w = int(p.stations[k]), 1
        last = m - 1 if k != m - 1 else m - 2
        x0 = n_travel + (k * big_d + d - 1) * r ** (m - 1)
    if k < 0 or d >= big_d:
        rule = _NEVER
    elif d >= 1 or p.allow_empty_loiter:
        rule = _ALWAYS
    else:
        rule = _FROM_ONE if k == last else _BY_DELAY
    bases = []
    for u in (1, -1):  # continue, reverse: a travel state
        w2 = w * u
        l2 = (l + w2) % n_nodes
        bases.append((2 * l2 + (1 if w2 < 0 else 0)) * r**m)
    bases.append(n_travel + (k * big_d + d) * r ** (m - 1) if rule != _NEVER else 0)
    return [l, w, d, k, last, rule, *bases, x0]


# ---------------------------------------------------------------------- the walk
@njit(inline="always", **_OPTS)
def _next_delay(t, gamma):  # pragma: no cover - compiled
    """``f(t)``: a delay after one step, 0 while no alert is pending."""
    return 0 if t == 0 else min(t + 1, gamma)


@njit(**_OPTS)
def cursor_at(x, geo, planes, tau):  # pragma: no cover - compiled
    """The plane of state ``x``; its delays into ``tau`` (every station, in station
    order; 0 at the own station of a loiter state)."""
    m, radix = geo[_M], geo[_R]
    if x < geo[_T]:
        rm = radix**m
        plane = x // rm
    else:
        rm1 = radix ** (m - 1)
        plane = 2 * geo[_N] + (x - geo[_T]) // rm1
    code = x - planes[plane, _PX0]
    own = planes[plane, _PK] if planes[plane, _PD] > 0 else -1
    for j in range(m - 1, -1, -1):
        if j == own:
            tau[j] = 0
        else:
            tau[j] = code % radix
            code //= radix
    return plane


@njit(inline="always", **_OPTS)
def advance(plane, tau, geo, planes):  # pragma: no cover - compiled
    """The next row after a finished one: its fast digit back to 0, the others counted
    up by one (carrying); past the plane's last row, the next plane. Returns the plane."""
    last = planes[plane, _PLAST]
    if last < 0:
        return plane + 1
    own = planes[plane, _PK] if planes[plane, _PD] > 0 else -1
    tau[last] = 0
    for j in range(last - 1, -1, -1):
        if j == own:
            continue  # the own station of a loiter plane: no digit
        tau[j] += 1
        if tau[j] < geo[_R]:
            return plane
        tau[j] = 0
    return plane + 1


@njit(inline="always", **_OPTS)
def row_setup(plane, tau, geo, planes, weights, rr, gl):  # pragma: no cover - compiled
    """The successors of the row at the cursor into ``rr`` and ``gl`` (see the module
    docstring), as :func:`.model.successor_kernel` computes them.

    Returns ``(last, t0, length, pmax, loiter, acode)``: the fast digit's station (-1:
    none), its value at the cursor, the states left in the row, the largest delay outside
    the fast digit, the loiter rule (never / always / from ``t = 1`` on) and the alert
    bits outside the fast digit (station 0 the most significant of ``m``).
    """
    m, gamma = geo[_M], geo[_G]
    last = planes[plane, _PLAST]
    k = planes[plane, _PK]
    loiter = planes[plane, _PLOITER]
    if loiter == _BY_DELAY:
        loiter = _ALWAYS if tau[k] > 0 else _NEVER
    pmax = 0
    acode = 0
    for j in range(m):
        if j != last:
            pmax = max(pmax, tau[j])
            if tau[j] > 0:
                acode |= 1 << (m - 1 - j)
    for a in range(3):
        if a == 2 and loiter == _NEVER:
            gl[a] = 0
            continue
        wrow = k if a == 2 else m
        rb = planes[plane, _PB0 + a]
        for j in range(m):
            if j != last:
                rb += _next_delay(tau[j], gamma) * weights[wrow, j]
        g = weights[wrow, last] if last >= 0 else 0
        gl[a] = g
        rr[a, 0, 0] = rb
        rr[a, 1, 0] = rb
        for j in range(m):
            if j == last:
                rr[a, 0, j + 1] = rb + g
                rr[a, 1, j + 1] = rb
            else:
                off = weights[wrow, j] if tau[j] == 0 else 0
                rr[a, 0, j + 1] = rb + off
                rr[a, 1, j + 1] = rb + off
    if last < 0:
        return last, 0, 1, pmax, loiter, acode
    t0 = tau[last]
    return last, t0, geo[_R] - t0, pmax, loiter, acode


@njit(inline="always", **_OPTS)
def _index(rr, gl, a, o, t, gamma):  # pragma: no cover - compiled
    """The successor of outcome ``o`` under action ``a`` at the row's fast digit ``t``."""
    if t == 0:
        return rr[a, 0, o]
    return rr[a, 1, o] + _next_delay(t, gamma) * gl[a]


@njit(inline="always", **_OPTS)
def _sums_unit(v, probs, rr, a, gamma, row):  # pragma: no cover - compiled
    """``row[t] = sum_o probs[o] v[rr[a, 1, o] + t + 1]`` for ``t = 1 .. Gamma - 1`` (fast
    digit weight 1), each sum from 0.0 in outcome order.

    Four states at a time, their four sums in registers across the outcomes (a form the
    compiler packs into vector operations); the indices are unsigned, so no check for a
    negative index is made per read."""
    n_out = probs.size
    t = 1
    while t + 4 <= gamma:
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        for o in range(n_out):
            po = probs[o]
            b = np.uint64(rr[a, 1, o] + t + 1)
            s0 += po * v[b]
            s1 += po * v[b + np.uint64(1)]
            s2 += po * v[b + np.uint64(2)]
            s3 += po * v[b + np.uint64(3)]
        row[t] = s0
        row[t + 1] = s1
        row[t + 2] = s2
        row[t + 3] = s3
        t += 4
    while t < gamma:
        s = 0.0
        for o in range(n_out):
            s += probs[o] * v[np.uint64(rr[a, 1, o] + t + 1)]
        row[t] = s
        t += 1


@njit(inline="always", **_OPTS)
def _add_strided(seg, v, probs, rr, a, base, g, cnt):  # pragma: no cover - compiled
    """``seg[j] += probs[o] v[rr[a, 1, o] + base + g j]`` for every outcome ``o`` in order."""
    for o in range(probs.size):
        po = probs[o]
        b = rr[a, 1, o] + base
        for j in range(cnt):
            seg[j] += po * v[b + g * j]


@njit(inline="always", **_OPTS)
def _sum_at(v, probs, rr, a, side, shift):  # pragma: no cover - compiled
    """``sum_o probs[o] v[rr[a, side, o] + shift]`` from 0.0 in outcome order."""
    s = 0.0
    for o in range(probs.size):
        s += probs[o] * v[rr[a, side, o] + shift]
    return s


@njit(inline="always", **_OPTS)
def _accumulate(v, probs, rr, gl, a, nb, gamma, row, seg):  # pragma: no cover - compiled
    """``row[t] = sum_o probs[o] v[succ(a, o, t)]`` for the ``nb`` states of a whole row
    (``nb = Gamma + 1``, or 1 in a row without a fast digit), each sum from 0.0 in outcome
    order (the array path's); ``seg`` is ``row[1:Gamma]``, made once per chunk.

    With ``g = gl[a]`` the fast digit's weight in the successor's encoding, the states
    ``t = 1 .. Gamma - 1`` read ``rr[a, 1, o] + (t + 1) g``: an arithmetic sequence
    (mostly ``g = 1``, consecutive indices). When ``g = 0`` (the loiter of a travel plane
    whose fast digit is the own station's delay) every state ``t >= 1`` has the same
    successors and one sum serves them all; the state ``t = Gamma`` has the successors of
    ``t = Gamma - 1`` (``f(Gamma) = f(Gamma - 1)`` when ``Gamma >= 2``) and its sum is
    copied. A copy is of a sum made of the same operations on the same values, so every
    entry is the array path's."""
    row[0] = _sum_at(v, probs, rr, a, 0, 0)
    if nb == 1:
        return
    g = gl[a]
    if g == 0:
        s = _sum_at(v, probs, rr, a, 1, 0)
        for t in range(1, nb):
            row[t] = s
        return
    if gamma == 1:  # the row is t = 0, 1 and f(1) = 1
        row[1] = _sum_at(v, probs, rr, a, 1, g)
        return
    if g == 1:  # the common case: consecutive indices
        _sums_unit(v, probs, rr, a, gamma, row)
    else:
        for j in range(gamma - 1):
            seg[j] = 0.0
        _add_strided(seg, v, probs, rr, a, 2 * g, g, gamma - 1)  # slot j is t = j + 1
    row[gamma] = row[gamma - 1]  # f(Gamma) = f(Gamma - 1) = Gamma


@njit(**_OPTS)
def _scratch(geo):  # pragma: no cover - compiled
    """A chunk's cursor delays, row successors, fast-digit weights and accumulators."""
    m, radix = geo[_M], geo[_R]
    return (
        np.zeros(m, np.int64),
        np.empty((3, 2, m + 1), np.int64),
        np.empty(3, np.int64),
        np.empty((3, radix)),
    )


@njit(**_OPTS)
def _chunk(n, nchunks, radix, c):  # pragma: no cover - compiled
    """States ``[start, end)`` of chunk ``c``: consecutive, starting at a row boundary."""
    size = (n + nchunks - 1) // nchunks
    size = (size + radix - 1) // radix * radix
    return min(n, c * size), min(n, (c + 1) * size)


@njit(inline="always", **_OPTS)
def _loiter_at(loiter, t):  # pragma: no cover - compiled
    return loiter == _ALWAYS or (loiter == _FROM_ONE and t >= 1)


@njit(inline="always", **_OPTS)
def _walk_start(geo, planes, n, nchunks, c, tau):  # pragma: no cover - compiled
    """States ``[start, end)`` of chunk ``c`` of ``n`` and the cursor's plane at ``start``
    (``tau`` set to its delays)."""
    start, end = _chunk(n, nchunks, geo[_R], c)
    plane = cursor_at(start, geo, planes, tau) if start < end else 0
    return start, end, plane


@njit(**_OPTS)  # not inlined: the parfor pass cannot match the views' shapes
def _row_views(acc, gamma):  # pragma: no cover - compiled
    """The accumulator rows ``acc[a]`` and their segments ``acc[a, 1:Gamma]``, made once per
    chunk (a view per row would count references to ``acc`` from every thread)."""
    return (acc[0], acc[1], acc[2]), (acc[0, 1:gamma], acc[1, 1:gamma], acc[2, 1:gamma])


@njit(inline="always", **_OPTS)
def _sums(v, probs, rr, gl, nb, gamma, q, seg, used):  # pragma: no cover - compiled
    """The row's sums ``q[a]`` (:func:`_accumulate`) of the actions whose bit ``1 << a`` is
    set in ``used``."""
    if used & 1:
        _accumulate(v, probs, rr, gl, 0, nb, gamma, q[0], seg[0])
    if used & 2:
        _accumulate(v, probs, rr, gl, 1, nb, gamma, q[1], seg[1])
    if used & 4:
        _accumulate(v, probs, rr, gl, 2, nb, gamma, q[2], seg[2])


# ---------------------------------------------------------------------- sweeps
# The sweeps walk *units*: unit ``u < N R^m`` is a pair of travel states at one node, the
# state ``x = u + (u // R^m) R^m`` of plane ``(l, +1)`` and the state ``x + R^m`` of plane
# ``(l, -1)`` with the same delays; from ``N R^m`` on, unit ``u`` is the loiter state
# ``u + N R^m``. The two states of a pair share every successor: "continue" from
# ``(l, +1)`` and "reverse" from ``(l, -1)`` both lead to ``(l + 1, +1)``, the other two
# moves to ``(l - 1, -1)``, the loiter of both to ``(station, 1)``, and the delays move
# alike. So a pair's row needs the sums of two or three actions, not of five or six: the
# sums are the same operations on the same values as the array path's post-decision
# values ``W`` (:class:`lpbounds.rows.PostDecisionRows`), so the same numbers.
@njit(**_OPTS)
def _unit_chunk(geo, nchunks, c):  # pragma: no cover - compiled
    """Units ``[start, end)`` of chunk ``c`` and the state of unit ``start``."""
    half = geo[_T] // 2
    start, end = _chunk(geo[_NS] - half, nchunks, geo[_R], c)
    rm = half // geo[_N]
    x = start + (start // rm) * rm if start < half else start + half
    return start, end, x, rm


@njit(inline="always", **_OPTS)
def _next_row(plane, tau, geo, planes, x, rm):  # pragma: no cover - compiled
    """The cursor's next unit row: the plane and first state (past a pair's ``(l, +1)``
    plane, the next node's, skipping its ``(l, -1)`` twin)."""
    plane = advance(plane, tau, geo, planes)
    if plane < 2 * geo[_N] and plane % 2 == 1:
        return plane + 1, x + rm
    return plane, x


@njit(inline="always", **_OPTS)
def _max_row(x, nb, pmax, loiter, inc_d, pent, lam, qa, qb, ql, v, out, arg, lc, hc):
    # pragma: no cover - compiled
    """The max over the actions of the whole row of states ``x ..``, whose "continue"
    sums are ``qa`` and "reverse" sums ``qb``; returns the running extremes of ``out - v``.
    (The shared vectors are indexed, not sliced: a slice per row would count references
    to them from every thread.)"""
    for t in range(nb):
        pen = pent[max(pmax, t)]
        best = pen + lam * qa[t]
        best_a = 0
        q = pen + lam * qb[t]
        if q > best:
            best, best_a = q, 1
        if _loiter_at(loiter, t):
            q = (pen + inc_d) + lam * ql[t]
            if q > best:
                best, best_a = q, 2
        xi = np.uint64(x + t)  # unsigned: no negative-index check
        out[xi] = best
        arg[xi] = best_a
        diff = best - v[xi]
        lc = min(lc, diff)
        hc = max(hc, diff)
    return lc, hc


@njit(parallel=True, **_OPTS)
def max_sweep(
    geo, planes, sp, weights, probs, inc, pent, lam, v, out, arg, nchunks
):  # pragma: no cover - compiled
    """``out = T v`` (first maximising action in ``arg``); returns min, max of ``out - v``."""
    gamma = geo[_G]
    lo_c = np.full(nchunks, np.inf)
    hi_c = np.full(nchunks, -np.inf)
    for c in prange(nchunks):
        tau, rr, gl, acc = _scratch(geo)
        q, seg = _row_views(acc, gamma)
        q0, q1, q2 = q
        u, end, x, rm = _unit_chunk(geo, nchunks, c)
        lc, hc = np.inf, -np.inf
        plane = cursor_at(x, geo, planes, tau) if u < end else 0
        while u < end:  # whole rows: chunks start at row boundaries
            _, _, nb, pmax, loiter, _ = row_setup(plane, tau, geo, planes, weights, rr, gl)
            inc_d = inc[planes[plane, _PD]]
            _sums(v, probs, rr, gl, nb, gamma, q, seg, 3 if loiter == _NEVER else 7)
            lc, hc = _max_row(x, nb, pmax, loiter, inc_d, pent, lam, q0, q1, q2, v, out, arg,
                              lc, hc)  # fmt: skip
            if plane < 2 * geo[_N]:  # the (l, -1) twin: its moves swap the two sums
                lc, hc = _max_row(x + rm, nb, pmax, loiter, inc_d, pent, lam, q1, q0, q2, v,
                                  out, arg, lc, hc)  # fmt: skip
            u += nb
            x += nb
            if u < end:
                plane, x = _next_row(plane, tau, geo, planes, x, rm)
        lo_c[c] = lc
        hi_c[c] = hc
    return lo_c.min(), hi_c.max()


@njit(inline="always", **_OPTS)
def _used(act, x, nb, twin):  # pragma: no cover - compiled
    """Bit ``a`` set if a state ``x ..`` of the row takes the action whose sum is ``acc[a]``
    (``twin``: the states of an ``(l, -1)`` plane, whose moves swap the sums)."""
    used = 0
    for i in range(nb):
        a = act[x + i]
        used |= 1 << (1 - a if twin and a < 2 else a)
    return used


@njit(inline="always", **_OPTS)
def _policy_row(x, nb, pmax, inc_d, pent, lam, act, acc, twin, v, out, lc, hc):
    # pragma: no cover - compiled
    """``out = T_pi v`` on the whole row of states ``x ..``; returns the running extremes."""
    for t in range(nb):
        xi = np.uint64(x + t)  # unsigned: no negative-index check
        a = act[xi]
        r = pent[max(pmax, t)]
        if a == 2:
            r = r + inc_d
        q = r + lam * acc[1 - a if twin and a < 2 else a, t]
        out[xi] = q
        diff = q - v[xi]
        lc = min(lc, diff)
        hc = max(hc, diff)
    return lc, hc


@njit(parallel=True, **_OPTS)
def policy_sweep(
    geo, planes, sp, weights, probs, inc, pent, lam, act, v, out, nchunks
):  # pragma: no cover - compiled
    """``out = T_pi v`` for the actions ``act``; returns min, max of ``out - v``."""
    gamma = geo[_G]
    lo_c = np.full(nchunks, np.inf)
    hi_c = np.full(nchunks, -np.inf)
    for c in prange(nchunks):
        tau, rr, gl, acc = _scratch(geo)
        q, seg = _row_views(acc, gamma)
        u, end, x, rm = _unit_chunk(geo, nchunks, c)
        lc, hc = np.inf, -np.inf
        plane = cursor_at(x, geo, planes, tau) if u < end else 0
        while u < end:  # whole rows: chunks start at row boundaries
            _, _, nb, pmax, _, _ = row_setup(plane, tau, geo, planes, weights, rr, gl)
            inc_d = inc[planes[plane, _PD]]
            pair = plane < 2 * geo[_N]
            used = _used(act, x, nb, False)
            if pair:
                used |= _used(act, x + rm, nb, True)
            _sums(v, probs, rr, gl, nb, gamma, q, seg, used)
            lc, hc = _policy_row(x, nb, pmax, inc_d, pent, lam, act, acc, False, v, out, lc, hc)
            if pair:
                lc, hc = _policy_row(x + rm, nb, pmax, inc_d, pent, lam, act, acc, True, v, out,
                                     lc, hc)  # fmt: skip
            u += nb
            x += nb
            if u < end:
                plane, x = _next_row(plane, tau, geo, planes, x, rm)
        lo_c[c] = lc
        hi_c[c] = hc
    return lo_c.min(), hi_c.max()


# ---------------------------------------------------------------------- passes
@njit(inline="always", **_OPTS)
def _label(geo, planes, sp, plane, acode, last, t, pmax):  # pragma: no cover - compiled
    """Partition of the row's state at fast digit ``t`` (:func:`.partitions.key_index_kernel`)."""
    if last >= 0 and t > 0:
        acode |= 1 << (geo[_M] - 1 - last)
    return key_index_kernel(
        planes[plane, _PL], planes[plane, _PW], planes[plane, _PD], acode, max(pmax, t), sp,
        geo[_N], geo[_D], geo[_G], geo[_TBS], geo[_LBS], geo[_M],
    )  # fmt: skip


@njit(parallel=True, **_OPTS)
def labels_pass(geo, planes, sp, weights, labels, nchunks):  # pragma: no cover - compiled
    """``labels[x]``: the partition of every state (Section 4.2)."""
    n = labels.size
    for c in prange(nchunks):
        tau, rr, gl, _ = _scratch(geo)
        x, end, plane = _walk_start(geo, planes, n, nchunks, c, tau)
        while x < end:
            last, t0, length, pmax, _, acode = row_setup(plane, tau, geo, planes, weights, rr, gl)
            nb = min(length, end - x)
            for i in range(nb):
                labels[x + i] = _label(geo, planes, sp, plane, acode, last, t0 + i, pmax)
            x += nb
            if x < end:
                plane = advance(plane, tau, geo, planes)


@njit(parallel=True, **_OPTS)
def decode_range(geo, planes, sp, weights, start0, comps, nchunks):  # pragma: no cover
    """Components ``(l, w, d, tau_1..tau_m)`` of states ``start0 ..`` as the walk sees
    them (for tests: every state's, against the model's decoder)."""
    n = comps.shape[0]
    m = geo[_M]
    for c in prange(nchunks):
        tau, rr, gl, _ = _scratch(geo)
        lo, hi = _chunk(n, nchunks, 1, c)
        x = lo
        plane = cursor_at(start0 + x, geo, planes, tau) if x < hi else 0
        while x < hi:
            last, t0, length, _, _, _ = row_setup(plane, tau, geo, planes, weights, rr, gl)
            nb = min(length, hi - x)
            for i in range(nb):
                comps[x + i, 0] = planes[plane, _PL]
                comps[x + i, 1] = planes[plane, _PW]
                comps[x + i, 2] = planes[plane, _PD]
                for j in range(m):
                    comps[x + i, 3 + j] = tau[j]
                if last >= 0:
                    comps[x + i, 3 + last] = t0 + i
            x += nb
            if x < hi:
                plane = advance(plane, tau, geo, planes)


@njit(parallel=True, **_OPTS)
def successor_range(geo, planes, sp, weights, action, out, nchunks):  # pragma: no cover
    """The walk's successors of every state under ``action`` into ``out`` (n, m + 1), -1
    where the action is not allowed (for tests, against :func:`.model.successor_kernel`)."""
    n = out.shape[0]
    gamma = geo[_G]
    for c in prange(nchunks):
        tau, rr, gl, _ = _scratch(geo)
        x, end, plane = _walk_start(geo, planes, n, nchunks, c, tau)
        while x < end:
            _, t0, length, _, loiter, _ = row_setup(plane, tau, geo, planes, weights, rr, gl)
            nb = min(length, end - x)
            for i in range(nb):
                ok = action < 2 or _loiter_at(loiter, t0 + i)
                for o in range(out.shape[1]):
                    out[x + i, o] = _index(rr, gl, action, o, t0 + i, gamma) if ok else -1
            x += nb
            if x < end:
                plane = advance(plane, tau, geo, planes)


@njit(parallel=True, **_OPTS)
def check_policy_pass(geo, planes, sp, weights, act, nchunks):  # pragma: no cover
    """First state whose action ``act[x]`` is a forbidden loiter, or -1 (``act`` is known
    to hold 0, 1 or 2)."""
    n = act.size
    first = np.full(nchunks, -1, np.int64)
    for c in prange(nchunks):
        tau, rr, gl, _ = _scratch(geo)
        x, end, plane = _walk_start(geo, planes, n, nchunks, c, tau)
        while x < end and first[c] < 0:
            _, t0, length, _, loiter, _ = row_setup(plane, tau, geo, planes, weights, rr, gl)
            nb = min(length, end - x)
            for i in range(nb):
                if act[x + i] == 2 and not _loiter_at(loiter, t0 + i):
                    first[c] = x + i
                    break
            x += nb
            if x < end:
                plane = advance(plane, tau, geo, planes)
    for c in range(nchunks):
        if first[c] >= 0:
            return first[c]
    return -1


@njit(parallel=True, **_OPTS)
def reward_absmax_pass(geo, planes, sp, weights, inc, pent, nchunks):  # pragma: no cover
    """``max |R_u(x)|`` over the allowed pairs (the scale of the default tolerance)."""
    n = geo[_NS]
    best = np.zeros(nchunks)
    for c in prange(nchunks):
        tau, rr, gl, _ = _scratch(geo)
        start, end = _chunk(n, nchunks, geo[_R], c)
        bc = 0.0
        x = start
        plane = cursor_at(x, geo, planes, tau) if x < end else 0
        while x < end:
            _, t0, length, pmax, loiter, _ = row_setup(plane, tau, geo, planes, weights, rr, gl)
            nb = min(length, end - x)
            inc_d = inc[planes[plane, _PD]]
            for i in range(nb):
                t = t0 + i
                pen = pent[max(pmax, t)]
                bc = max(bc, abs(pen))
                if _loiter_at(loiter, t):
                    bc = max(bc, abs(pen + inc_d))
            x += nb
            if x < end:
                plane = advance(plane, tau, geo, planes)
        best[c] = bc
    return best.max()


#: Columns of the greedy pass's per-chunk statistics (floats ``F_*``, integers ``I_*``).
F_UP_SUM, F_UP_MAX, F_UP_MIN, F_LOW_SUM, F_LOW_MAX, F_LOW_MIN = range(6)
F_GAP_SUM, F_GAP_MAX, F_LOSS_MAX = range(6, 9)
I_UP_ARGMIN, I_LOW_ARGMIN, I_OPTIMAL, I_DIFFERS, I_SUBOPT = range(5)


@njit(**_OPTS)
def _greedy_init(f, st):  # pragma: no cover - compiled
    f[:] = 0.0
    for col in (F_UP_MIN, F_LOW_MIN):
        f[col] = np.inf
    for col in (F_UP_MAX, F_LOW_MAX, F_GAP_MAX, F_LOSS_MAX):
        f[col] = -np.inf
    st[:] = 0


@njit(inline="always", **_OPTS)
def _greedy_record(
    x, qv, qw, n_act, k, v, w_low, v_up, pistar, tie_rtol, loss_tol, pi_s, f, st
):  # pragma: no cover - compiled
    """``pi_s[x]`` (greedy w.r.t. ``qw``, the lowest action among ties) and the state's
    share of the statistics (``k`` its partition)."""
    best_v = qv[:n_act].max()
    best_w = qw[:n_act].max()
    thr_w = best_w - tie_rtol * max(1.0, abs(best_w))
    a_s = 0
    while qw[a_s] < thr_w:
        a_s += 1
    pi_s[x] = a_s
    if qv[a_s] >= best_v - tie_rtol * max(1.0, abs(best_v)):
        st[I_OPTIMAL] += 1
    loss = best_v - qv[a_s]
    f[F_LOSS_MAX] = max(f[F_LOSS_MAX], loss)
    if loss > loss_tol:
        st[I_SUBOPT] += 1
    if a_s != pistar[x]:
        st[I_DIFFERS] += 1
    up = v_up[k] - v[x]
    low = v[x] - w_low[k]
    f[F_UP_SUM] += up
    f[F_UP_MAX] = max(f[F_UP_MAX], up)
    if up < f[F_UP_MIN]:
        f[F_UP_MIN] = up
        st[I_UP_ARGMIN] = x
    f[F_LOW_SUM] += low
    f[F_LOW_MAX] = max(f[F_LOW_MAX], low)
    if low < f[F_LOW_MIN]:
        f[F_LOW_MIN] = low
        st[I_LOW_ARGMIN] = x
    gap = v_up[k] - w_low[k]
    f[F_GAP_SUM] += gap
    f[F_GAP_MAX] = max(f[F_GAP_MAX], gap)


@njit(parallel=True, **_OPTS)
def greedy_pass(
    geo,
    planes,
    sp,
    weights,
    probs,
    inc,
    pent,
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
):  # pragma: no cover - compiled
    """One pass: ``pi_s`` greedy w.r.t. the lifted ``w_low`` (lowest action among those tied
    within ``tie_rtol``, as :func:`lpbounds.greedy_policy`), whether it is among ``v``'s
    optimal actions (tied within ``tie_rtol``), its one-step loss, and the gaps
    ``v_up - v``, ``v - w_low``, ``v_up - w_low`` at every state (per-chunk statistics in
    ``fstats``, ``istats``)."""
    n = v.size
    gamma = geo[_G]
    for c in prange(nchunks):
        tau, rr, gl, acc = _scratch(geo)
        q, seg = _row_views(acc, gamma)
        qv = np.empty(3)
        qw = np.empty(3)
        f = fstats[c]
        st = istats[c]
        _greedy_init(f, st)
        x, end, plane = _walk_start(geo, planes, n, nchunks, c, tau)
        while x < end:  # whole rows: chunks start at row boundaries
            _, _, nb, pmax, loiter, _ = row_setup(plane, tau, geo, planes, weights, rr, gl)
            inc_d = inc[planes[plane, _PD]]
            _sums(v, probs, rr, gl, nb, gamma, q, seg, 3 if loiter == _NEVER else 7)
            for t in range(nb):
                pen = pent[max(pmax, t)]
                n_act = 3 if _loiter_at(loiter, t) else 2
                for a in range(n_act):
                    r = pen + inc_d if a == 2 else pen
                    qv[a] = r + lam * acc[a, t]
                    lifted = 0.0
                    for o in range(probs.size):
                        lifted += probs[o] * w_low[labels[_index(rr, gl, a, o, t, gamma)]]
                    qw[a] = r + lam * lifted
                xi = x + t
                _greedy_record(
                    xi, qv, qw, n_act, labels[xi], v, w_low, v_up, pistar, tie_rtol, loss_tol,
                    pi_s, f, st,
                )  # fmt: skip
            x += nb
            if x < end:
                plane = advance(plane, tau, geo, planes)


#: Columns of the V_sub pass's per-chunk statistics (floats ``S_*``, integers ``J_*``).
S_SUM, S_MAX, S_MIN, S_LOW_MIN = range(4)
J_ARGMAX, J_ARGMIN, J_LOW_ARGMIN = range(3)


@njit(parallel=True, **_OPTS)
def vsub_pass(
    geo, planes, sp, weights, vstar, vsub, w_low, fstats, istats, nchunks
):  # pragma: no cover - compiled
    """Statistics of ``vstar - vsub`` (sum, max, min with their states) and the smallest
    ``vsub - w_low`` (the lifted lower bound) with its state."""
    n = vstar.size
    for c in prange(nchunks):
        tau, rr, gl, _ = _scratch(geo)
        f = fstats[c]
        f[S_SUM] = 0.0
        f[S_MAX] = -np.inf
        f[S_MIN] = np.inf
        f[S_LOW_MIN] = np.inf
        st = istats[c]
        st[:] = 0
        x, end, plane = _walk_start(geo, planes, n, nchunks, c, tau)
        while x < end:
            last, t0, length, pmax, _, acode = row_setup(plane, tau, geo, planes, weights, rr, gl)
            nb = min(length, end - x)
            for i in range(nb):
                xi = x + i
                diff = vstar[xi] - vsub[xi]
                f[S_SUM] += diff
                if diff > f[S_MAX]:
                    f[S_MAX] = diff
                    st[J_ARGMAX] = xi
                if diff < f[S_MIN]:
                    f[S_MIN] = diff
                    st[J_ARGMIN] = xi
                k = _label(geo, planes, sp, plane, acode, last, t0 + i, pmax)
                low = vsub[xi] - w_low[k]
                if low < f[S_LOW_MIN]:
                    f[S_LOW_MIN] = low
                    st[J_LOW_ARGMIN] = xi
            x += nb
            if x < end:
                plane = advance(plane, tau, geo, planes)
