r"""The matrix-free patrol sweeps: the state space walked in index order, in C.

The state encoding of :mod:`lpbounds.patrol.model` is mixed radix: a *plane* of states
(travel: one ``(l, w)``; loiter: one ``(station, d)``) is a counter over the delays, the
last station's delay (in a loiter plane: the last other station's) its fast digit. So
the states of one *row* (``Gamma + 1`` consecutive indices, the fast digit ``t`` running
``0..Gamma``) share every component but that digit, and the row after a row is the
counter plus one. No state index is decoded but a chunk's first:

* a *cursor* holds the plane and the delays of the current row (``cursor_at`` decodes
  a chunk's first state, ``advance`` moves to the next row, carrying digits); what
  depends on the plane alone (components, the successor planes' first indices, the loiter
  rule) is a table built once per model (:func:`geometry`);
* ``row_setup`` turns the row into, per action ``a`` and outcome ``o`` (``o = 0`` no
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

The kernels are C (:mod:`lpbounds._kernels.patrolsweeps`, ``patrolsweeps.c``: the walk's
helpers ``cursor_at``, ``advance``, ``row_setup`` and the sums, term for term the numba
kernels they replaced, so every number is theirs), built when lpbounds is installed. Work
is split into ``nchunks`` chunks of consecutive whole rows; each C call walks a range of
chunks with the GIL released, and the functions here run one range per thread
(:mod:`lpbounds._kernels.threads`), each chunk's statistics in its own row, reduced in
chunk order (so the numbers depend on ``nchunks``, never on the threads). A chunk walks its
rows in order, so its reads move forward through the one to three planes of ``v`` that its
plane's successors lie in, and a row's sums (``3 (Gamma + 1)`` floats) stay in the
first-level cache. Each call checks the geometry against its definition and the arrays'
shapes and entries (a TypeError or ValueError naming the argument, never a wild read).

Every name here is public for :mod:`lpbounds.patrol.matrix_free`, this module's one user.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .._kernels.extensions import patrolsweeps as _c
from .._kernels.threads import run_ranges, split_ranges
from .params import PatrolParams
from .partitions import block_sizes

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
    "Geometry",
    "check_policy_pass",
    "decode_range",
    "geometry",
    "greedy_pass",
    "labels_pass",
    "max_sweep",
    "policy_sweep",
    "reward_absmax_pass",
    "successor_range",
    "vsub_pass",
]

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

#: Columns of the plane table (:func:`geometry`): the plane's ``l, w, d``, the station
#: position of ``l`` (-1: none), the station of the fast digit (-1: none, a 1-station
#: loiter plane), the loiter rule, the first index of each action's successor plane, and
#: the first state of the plane.
PLANE_FIELDS: tuple[str, ...] = ("l", "w", "d", "k", "last", "loiter", "b0", "b1", "b2", "x0")

#: Loiter rules: never, at every state, from fast digit 1 on (the own delay is the fast
#: digit), when the own delay (a slower digit) is positive.
_NEVER, _ALWAYS, _FROM_ONE, _BY_DELAY = 0, 1, 2, 3


#: The arrays of :func:`geometry`, in order: geo, planes, sp, weights, probs, inc, pent.
Geometry = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def geometry(params: PatrolParams) -> Geometry:
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


# ---------------------------------------------------------------------- ranges
def _chunks(func: Callable[..., Any], args: tuple[Any, ...], nchunks: int) -> list[Any]:
    """``func(*args, nchunks, c0, c1)`` on one range of the ``nchunks`` chunks per thread;
    the ranges' results in chunk order."""
    nchunks = int(nchunks)
    return run_ranges(func, (*args, nchunks), split_ranges(nchunks))


def _extremes(parts: list[tuple[float, float]]) -> tuple[float, float]:
    """The ranges' (min, max) combined in chunk order: the first of the extremes, as the
    per-chunk fold in C (as numba's ``min``, ``max`` were before it)."""
    return min(p[0] for p in parts), max(p[1] for p in parts)


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
def max_sweep(
    geo: np.ndarray, planes: np.ndarray, sp: np.ndarray, weights: np.ndarray,
    probs: np.ndarray, inc: np.ndarray, pent: np.ndarray, lam: float, v: np.ndarray,
    out: np.ndarray, arg: np.ndarray, nchunks: int,
) -> tuple[float, float]:  # fmt: skip
    """``out = T v`` (first maximising action in ``arg``, int8); returns min, max of ``out - v``."""
    args = (geo, planes, sp, weights, probs, inc, pent, float(lam), v, out, arg)
    return _extremes(_chunks(_c.max_sweep, args, nchunks))


def policy_sweep(
    geo: np.ndarray, planes: np.ndarray, sp: np.ndarray, weights: np.ndarray,
    probs: np.ndarray, inc: np.ndarray, pent: np.ndarray, lam: float, act: np.ndarray,
    v: np.ndarray, out: np.ndarray, nchunks: int,
) -> tuple[float, float]:  # fmt: skip
    """``out = T_pi v`` for the actions ``act`` (int8); returns min, max of ``out - v``.
    A ValueError names the first state whose action is not allowed there."""
    args = (geo, planes, sp, weights, probs, inc, pent, float(lam), act, v, out)
    return _extremes(_chunks(_c.policy_sweep, args, nchunks))


# ---------------------------------------------------------------------- passes
def labels_pass(
    geo: np.ndarray, planes: np.ndarray, sp: np.ndarray, weights: np.ndarray,
    labels: np.ndarray, nchunks: int,
) -> None:  # fmt: skip
    """``labels[x]`` (int32 or int64): the partition of every state (Section 4.2)."""
    _chunks(_c.labels_pass, (geo, planes, sp, weights, labels), nchunks)


def decode_range(
    geo: np.ndarray, planes: np.ndarray, sp: np.ndarray, weights: np.ndarray, start0: int,
    comps: np.ndarray, nchunks: int,
) -> None:  # fmt: skip
    """Components ``(l, w, d, tau_1..tau_m)`` of states ``start0 ..`` as the walk sees
    them, into ``comps`` (int64; for tests: every state's, against the model's decoder)."""
    _chunks(_c.decode_range, (geo, planes, sp, weights, int(start0), comps), nchunks)


def successor_range(
    geo: np.ndarray, planes: np.ndarray, sp: np.ndarray, weights: np.ndarray, action: int,
    out: np.ndarray, nchunks: int,
) -> None:  # fmt: skip
    """The walk's successors of every state under ``action`` into ``out`` (n, m + 1), -1
    where the action is not allowed (for tests, against :func:`.model.successor_kernel`)."""
    _chunks(_c.successor_range, (geo, planes, sp, weights, int(action), out), nchunks)


def check_policy_pass(
    geo: np.ndarray, planes: np.ndarray, sp: np.ndarray, weights: np.ndarray, act: np.ndarray,
    nchunks: int,
) -> int:  # fmt: skip
    """First state whose action ``act[x]`` (int8) is a forbidden loiter, or -1."""
    firsts = _chunks(_c.check_policy_pass, (geo, planes, sp, weights, act), nchunks)
    return next((int(x) for x in firsts if x >= 0), -1)


def reward_absmax_pass(
    geo: np.ndarray, planes: np.ndarray, sp: np.ndarray, weights: np.ndarray, inc: np.ndarray,
    pent: np.ndarray, nchunks: int,
) -> float:  # fmt: skip
    """``max |R_u(x)|`` over the allowed pairs (the scale of the default tolerance)."""
    return max(_chunks(_c.reward_absmax_pass, (geo, planes, sp, weights, inc, pent), nchunks))


#: Columns of the greedy pass's per-chunk statistics (floats ``F_*``, integers ``I_*``).
F_UP_SUM, F_UP_MAX, F_UP_MIN, F_LOW_SUM, F_LOW_MAX, F_LOW_MIN = range(6)
F_GAP_SUM, F_GAP_MAX, F_LOSS_MAX = range(6, 9)
I_UP_ARGMIN, I_LOW_ARGMIN, I_OPTIMAL, I_DIFFERS, I_SUBOPT = range(5)


def greedy_pass(
    geo: np.ndarray, planes: np.ndarray, sp: np.ndarray, weights: np.ndarray,
    probs: np.ndarray, inc: np.ndarray, pent: np.ndarray, lam: float, v: np.ndarray,
    labels: np.ndarray, w_low: np.ndarray, v_up: np.ndarray, pistar: np.ndarray,
    tie_rtol: float, loss_tol: float, pi_s: np.ndarray, fstats: np.ndarray,
    istats: np.ndarray, nchunks: int,
) -> None:  # fmt: skip
    """One pass: ``pi_s`` greedy w.r.t. the lifted ``w_low`` (lowest action among those tied
    within ``tie_rtol``, as :func:`lpbounds.greedy_policy`), whether it is among ``v``'s
    optimal actions (tied within ``tie_rtol``), its one-step loss, and the gaps
    ``v_up - v``, ``v - w_low``, ``v_up - w_low`` at every state (per-chunk statistics in
    ``fstats`` (nchunks, 9), ``istats`` (nchunks, 5))."""
    args = (
        geo, planes, sp, weights, probs, inc, pent, float(lam), v, labels, w_low, v_up, pistar,
        float(tie_rtol), float(loss_tol), pi_s, fstats, istats,
    )  # fmt: skip
    _chunks(_c.greedy_pass, args, nchunks)


#: Columns of the V_sub pass's per-chunk statistics (floats ``S_*``, integers ``J_*``).
S_SUM, S_MAX, S_MIN, S_LOW_MIN = range(4)
J_ARGMAX, J_ARGMIN, J_LOW_ARGMIN = range(3)


def vsub_pass(
    geo: np.ndarray, planes: np.ndarray, sp: np.ndarray, weights: np.ndarray,
    vstar: np.ndarray, vsub: np.ndarray, w_low: np.ndarray, fstats: np.ndarray,
    istats: np.ndarray, nchunks: int,
) -> None:  # fmt: skip
    """Statistics of ``vstar - vsub`` (sum, max, min with their states) and the smallest
    ``vsub - w_low`` (the lifted lower bound) with its state, per chunk in ``fstats``
    (nchunks, 4) and ``istats`` (nchunks, 3)."""
    args = (geo, planes, sp, weights, vstar, vsub, w_low, fstats, istats)
    _chunks(_c.vsub_pass, args, nchunks)
