r"""The perimeter alert patrol MDP (paper Section 4.1), vectorised over states.

State ``x = (l, w, d, tau_1..tau_m)``:

* travel states (``d = 0``): any node ``l``, ``w = +1`` (clockwise) or ``-1``, every
  ``tau_j`` in ``0..Gamma``;
* loiter states (``d = 1..D``): ``l`` a station, ``w = +1``, ``tau_l = 0`` (the own
  alert is being serviced), the other ``tau_j`` in ``0..Gamma``.

Encoding (0-based): travel states first, ``x = (2 l + [w = -1]) (Gamma+1)^m + sum_j
tau_j (Gamma+1)^(m-1-j)``; then loiter states, ``x = T + (k D + d - 1) (Gamma+1)^(m-1) +``
the delays of the other stations in the same mixed radix, ``k`` the position of ``l`` in
``stations`` and ``T = 2 N (Gamma+1)^m``. Hence eq. (27).

Actions (index: u): 0: ``u = +1`` "continue", 1: ``u = -1`` "reverse", 2: ``u = 0``
"loiter". Outcomes: 0: no alert (``p_0 = e^{-alpha}``), ``k = 1..m``: one new alert at the
``k``-th station (``p_k = (1 - p_0) / m``). Dynamics (eq. 20, as settled by the
specification):

* ``u != 0``: ``l' = (l + w u) mod N``, ``w' = w u``, ``d' = 0``;
* ``u = 0``: ``l' = l``, ``w' = +1``, ``d' = d + 1``;
* every station ``j``: ``tau_j' = 0`` if ``u = 0`` and ``j = l``; else
  ``min(tau_j + 1, Gamma)`` if ``tau_j > 0``; else 1 if the outcome is a new alert at
  ``j``; else 0. (A new alert at the station being loitered at is absorbed.)

Allowed actions: ``u = +-1`` always; ``u = 0`` only at a station with ``d < D`` and, when
``d = 0``, only if ``tau_l > 0`` (unless ``allow_empty_loiter``).

Reward (eq. 23 with ``min`` for the printed ``max``, see the specification):
``R_u(x) = [I(d+1) - I(d)] [u = 0] - rho min(taubar, Gamma)``, ``taubar = max_j tau_j``.
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import numpy as np

from .._kernels.extensions import patrolsweeps as _c
from .._kernels.threads import run_ranges, split_ranges
from ..errors import ValidationError
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from .params import PatrolParams
from .partitions import partition_components as _partition_components
from .partitions import partition_index as _partition_index

__all__ = ["ACTION_NAMES", "ACTION_U", "PatrolModel", "decode_kernel", "successor_kernel"]

#: Action names in index order.
ACTION_NAMES: tuple[str, str, str] = ("continue", "reverse", "loiter")
#: The paper's control value ``u`` of each action index.
ACTION_U: tuple[int, int, int] = (1, -1, 0)

_TAU = np.int16  # delays fit: Gamma <= params.GAMMA_MAX


def decode_kernel(
    x: np.ndarray, n_travel: int, radix: int, m: int, n_big_d: int, stations: np.ndarray,
    l: np.ndarray, w: np.ndarray, d: np.ndarray, tau: np.ndarray,
) -> None:  # fmt: skip
    """Decode state indices ``x`` into their components, in place (compiled: C, one range of
    states per thread).

    The model's encoding; the matrix-free sweeps (:mod:`lpbounds.patrol.sweeps`) and the
    greedy simulation (:mod:`lpbounds.patrol.greedy_mc`) decode states with the same
    formulas in their own C (``patrol.h``).

    Parameters
    ----------
    x : numpy.ndarray
        State indices (int64).
    n_travel : int
        Number of travelling states (``2 N radix**m``); indices from it on are loiters.
    radix : int
        ``Gamma + 1``.
    m : int
        Number of stations.
    n_big_d : int
        ``D``, the largest dwell.
    stations : numpy.ndarray
        Node of each station (int64).
    l, w, d : numpy.ndarray
        Outputs (int64), one entry per state: location, heading (+1 / -1), dwell.
    tau : numpy.ndarray
        Output (int16), shape ``(x.size, m)``: the delays.

    Raises
    ------
    ValueError
        An entry of ``x`` is not a state of the encoding (named).
    """
    args = (x, int(n_travel), int(radix), int(m), int(n_big_d), stations, l, w, d, tau)
    run_ranges(_c.decode_states, args, split_ranges(x.shape[0]))


def successor_kernel(
    l: np.ndarray, w: np.ndarray, d: np.ndarray, tau: np.ndarray, action: int, n_nodes: int,
    n_big_d: int, gamma: int, radix: int, n_travel: int, station_pos: np.ndarray,
    w_travel: np.ndarray, w_loiter: np.ndarray, out: np.ndarray,
) -> None:  # fmt: skip
    """Successor indices of decoded states under one action, into ``out`` (compiled: C,
    one range of states per thread).

    The model's dynamics (the same formulas as the C of :mod:`lpbounds.patrol.sweeps` and
    :mod:`lpbounds.patrol.greedy_mc`). Row ``i`` of ``out`` (shape ``(l.size, m + 1)``)
    holds the successor with no new alert (column 0) and with an alert at station ``j``
    (column ``j + 1``).

    Parameters
    ----------
    l, w, d, tau : numpy.ndarray
        Decoded states (:func:`decode_kernel`: int64, ``tau`` int16).
    action : int
        Action index (0 continue, 1 reverse, 2 loiter).
    n_nodes, n_big_d, gamma, radix, n_travel : int
        The encoding's sizes: nodes ``N``, ``D``, ``Gamma``, ``Gamma + 1``, travelling states.
    station_pos : numpy.ndarray
        Station number of each node (where the UAV loiters).
    w_travel, w_loiter : numpy.ndarray
        Index weights of the delays in travelling and loitering states.
    out : numpy.ndarray
        Output, int64.

    Raises
    ------
    ValueError
        A state whose ``l`` is not a node, or (loiter) not a station with ``d < D`` (named).
    """
    args = (
        l, w, d, tau, int(action), int(n_nodes), int(n_big_d), int(gamma), int(radix),
        int(n_travel), station_pos, w_travel, w_loiter, out,
    )  # fmt: skip
    run_ranges(_c.successor_states, args, split_ranges(l.shape[0]))


class PatrolModel:
    """The patrol MDP of one :class:`PatrolParams`: encoding, dynamics, MDP and partition.

    Parameters
    ----------
    params : PatrolParams, optional
        Default: the paper's example.

    Notes
    -----
    Everything is vectorised over states (no Python loop over states); the paper's
    instance (2,048,000 states) builds in well under a second.
    """

    def __init__(self, params: PatrolParams | None = None) -> None:
        self.params = PatrolParams() if params is None else params
        p = self.params
        self.m = p.m
        self.radix = p.Gamma + 1
        self.n_travel = 2 * p.N * self.radix**self.m
        self._mdp: FiniteMDP | None = None
        self._partition: Partition | None = None
        # mixed-radix weights of the delays: travel states, and loiter states at station k
        self.w_travel = (self.radix ** np.arange(self.m - 1, -1, -1)).astype(np.int64)
        wl = np.zeros((self.m, self.m), dtype=np.int64)
        for k in range(self.m):
            others = [j for j in range(self.m) if j != k]
            for pos, j in enumerate(others):
                wl[k, j] = self.radix ** (self.m - 2 - pos)
        self.w_loiter = wl
        self.station_pos = p.station_pos
        self.stations = np.asarray(p.stations, dtype=np.int64)

    def __repr__(self) -> str:
        return f"PatrolModel(n_states={self.n_states}, n_partitions={self.n_partitions})"

    # ------------------------------------------------------------------ sizes
    @property
    def n_states(self) -> int:
        """``|S|`` (eq. 27)."""
        return self.params.n_states

    @property
    def n_partitions(self) -> int:
        """``M`` (eq. 28)."""
        return self.params.n_partitions

    # ------------------------------------------------------------------ encoding
    def encode(self, l: Any, w: Any, d: Any, tau: Any, check: bool = True) -> np.ndarray:
        """State indices of the components (vectorised; ``tau`` has shape (k, m)).

        Raises ValidationError (naming the first bad state) for components that are not a
        state of the model, unless ``check=False``.
        """
        l = np.asarray(l, dtype=np.int64).reshape(-1)
        w = np.asarray(w, dtype=np.int64).reshape(-1)
        d = np.asarray(d, dtype=np.int64).reshape(-1)
        tau = np.asarray(tau)
        if tau.ndim == 1 and tau.size == self.m and l.size == 1:
            tau = tau[None, :]
        if tau.shape != (l.size, self.m) or w.size != l.size or d.size != l.size:
            raise ValidationError(
                f"encode needs l, w, d of one length k and tau of shape (k, {self.m}); got "
                f"{l.shape}, {w.shape}, {d.shape}, {tau.shape}"
            )
        tau = tau.astype(np.int64)
        if check:
            self._check_components(l, w, d, tau)
        travel = d == 0
        k = self.station_pos[np.clip(l, 0, self.params.N - 1)]
        kk = np.maximum(k, 0)
        idx_t = (2 * l + (w < 0)) * self.radix**self.m + tau @ self.w_travel
        code_l = np.einsum("ij,ij->i", tau, self.w_loiter[kk])
        idx_l = self.n_travel + (kk * self.params.D + d - 1) * self.radix ** (self.m - 1) + code_l
        return np.where(travel, idx_t, idx_l)

    def _check_components(
        self, l: np.ndarray, w: np.ndarray, d: np.ndarray, tau: np.ndarray
    ) -> None:
        p = self.params
        k = self.station_pos[np.clip(l, 0, p.N - 1)]
        own = np.zeros(l.size, dtype=np.int64)
        at = k >= 0
        own[at] = tau[np.flatnonzero(at), k[at]]
        bad = {
            "l outside 0..N-1": (l < 0) | (l >= p.N),
            "w not +1 or -1": (w != 1) & (w != -1),
            "d outside 0..D": (d < 0) | (d > p.D),
            "a delay outside 0..Gamma": ((tau < 0) | (tau > p.Gamma)).any(axis=1),
            "d >= 1 at a node that is not a station": (d >= 1) & ~at,
            "d >= 1 with w = -1 (loiter states have w = +1)": (d >= 1) & (w != 1),
            "d >= 1 with tau > 0 at the own station": (d >= 1) & (own != 0),
        }
        for what, mask in bad.items():
            if mask.any():
                i = int(np.flatnonzero(mask)[0])
                raise ValidationError(
                    f"components {i} (l={l[i]}, w={w[i]}, d={d[i]}, tau={tau[i].tolist()}) "
                    f"are not a state: {what}"
                )

    def decode(self, x: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Components ``(l, w, d, tau)`` of state indices (``tau`` int16, shape (k, m))."""
        x = np.asarray(x, dtype=np.int64).reshape(-1)
        n = self.n_states
        if x.size and (x.min() < 0 or x.max() >= n):
            bad = int(x[(x < 0) | (x >= n)][0])
            raise ValidationError(f"state index {bad} is outside [0, {n})")
        l = np.empty(x.size, dtype=np.int64)
        w = np.empty(x.size, dtype=np.int64)
        d = np.empty(x.size, dtype=np.int64)
        tau = np.empty((x.size, self.m), dtype=_TAU)
        decode_kernel(
            x, self.n_travel, self.radix, self.m, self.params.D, self.stations, l, w, d, tau
        )
        return l, w, d, tau

    def state_components(self, dtype: Any = np.int32) -> np.ndarray:
        """Every state's components, an int array (n, 3 + m): l, w, d, tau_1..tau_m."""
        l, w, d, tau = self._all
        return np.column_stack([l, w, d, tau]).astype(dtype)

    @cached_property
    def _all(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return self.decode(np.arange(self.n_states, dtype=np.int64))

    # ------------------------------------------------------------------ dynamics
    def allowed(self, l: np.ndarray, d: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Allowed-action mask (k, 3) of states given by components."""
        p = self.params
        k = self.station_pos[l]
        at = k >= 0
        own = np.zeros(l.shape, dtype=bool)
        own[at] = tau[np.flatnonzero(at), k[at]] > 0
        loiter = at & (d < p.D) & ((d >= 1) | own | p.allow_empty_loiter)
        out = np.ones((l.size, 3), dtype=bool)
        out[:, 2] = loiter
        return out

    def _successors(
        self,
        l: np.ndarray,
        w: np.ndarray,
        d: np.ndarray,
        tau: np.ndarray,
        action: int,
    ) -> np.ndarray:
        """Next-state indices (k, m+1) for one action on states that allow it."""
        p = self.params
        if action not in (0, 1, 2):
            raise ValidationError(f"action index {action} is not 0, 1 or 2")
        l = np.ascontiguousarray(l, dtype=np.int64)
        if action == 2:
            k = self.station_pos[l]
            if (k < 0).any() or (d >= p.D).any():
                raise ValidationError("loiter is not allowed at some of the given states")
        out = np.empty((l.size, self.m + 1), dtype=np.int64)
        successor_kernel(
            l,
            np.ascontiguousarray(w, dtype=np.int64),
            np.ascontiguousarray(d, dtype=np.int64),
            np.ascontiguousarray(tau, dtype=_TAU),
            int(action),
            p.N,
            p.D,
            p.Gamma,
            self.radix,
            self.n_travel,
            self.station_pos,
            self.w_travel,
            self.w_loiter,
            out,
        )
        return out

    def step(self, x: Any, action_index: Any, outcome_index: Any) -> np.ndarray:
        """The dynamics ``f(x, u, Y_l)`` on arrays of states, actions and outcomes.

        Raises ValidationError if an action is not allowed in its state.
        """
        x, a, y = np.broadcast_arrays(
            np.asarray(x, dtype=np.int64),
            np.asarray(action_index, dtype=np.int64),
            np.asarray(outcome_index, dtype=np.int64),
        )
        shape = x.shape
        x, a, y = x.reshape(-1), a.reshape(-1), y.reshape(-1)
        if ((a < 0) | (a > 2)).any():
            raise ValidationError("action_index must be 0 (continue), 1 (reverse) or 2 (loiter)")
        if ((y < 0) | (y > self.m)).any():
            raise ValidationError(f"outcome_index must be in 0..{self.m}")
        l, w, d, tau = self.decode(x)
        ok = self.allowed(l, d, tau)[np.arange(x.size), a]
        if not ok.all():
            i = int(np.flatnonzero(~ok)[0])
            raise ValidationError(
                f"action {ACTION_NAMES[a[i]]} is not allowed in state {x[i]} "
                f"(l={l[i]}, w={w[i]}, d={d[i]}, tau={tau[i].tolist()})"
            )
        out = np.empty(x.size, dtype=np.int64)
        for act in range(3):
            sel = np.flatnonzero(a == act)
            if sel.size:
                nxt = self._successors(l[sel], w[sel], d[sel], tau[sel], act)
                out[sel] = nxt[np.arange(sel.size), y[sel]]
        return out.reshape(shape)

    def rewards(self, d: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """``R_u(x)`` (k, 3) of states given by ``d`` and ``tau`` (loiter column for d < D)."""
        p = self.params
        pen = -p.rho * np.minimum(tau.max(axis=1), p.Gamma).astype(np.float64)
        inc = np.append(p.information_increments(), 0.0)  # d = D: loiter not allowed
        out = np.empty((d.size, 3))
        out[:, 0] = pen
        out[:, 1] = pen
        out[:, 2] = pen + inc[d]
        return out

    # ------------------------------------------------------------------ the MDP
    def mdp(self) -> FiniteMDP:
        """The full MDP (cached): successors (n, 3, m+1), shared probabilities."""
        if self._mdp is None:
            self._mdp = self._build_mdp()
        return self._mdp

    def _build_mdp(self) -> FiniteMDP:
        n, m = self.n_states, self.m
        l, w, d, tau = self._all
        l64 = l.astype(np.int64)
        allowed = self.allowed(l64, d, tau)
        idt = np.int32 if n < 2**31 - 1 else np.int64
        succ = np.empty((n, 3, m + 1), dtype=idt)
        for act in (0, 1):
            succ[:, act, :] = self._successors(l64, w, d, tau, act)
        lo = np.flatnonzero(allowed[:, 2])
        succ[:, 2, :] = np.arange(n, dtype=idt)[:, None]
        succ[lo, 2, :] = self._successors(l64[lo], w[lo], d[lo], tau[lo], 2)
        rewards = self.rewards(d, tau)
        rewards[~allowed] = 0.0  # as FiniteMDP stores them, so it need not copy
        # the arrays were made here for the MDP: hand them over (no 2-3 GB copies at m = 5)
        return FiniteMDP(
            succ,
            self.params.alert_probabilities(),
            rewards,
            self.params.discount,
            allowed=allowed,
            action_names=ACTION_NAMES,
            copy=False,
        )

    # ------------------------------------------------------------------ partitions
    def partition_index(self, l: Any, w: Any, d: Any, A: Any, taubar: Any) -> np.ndarray:
        """Partition index of keys ``(l, w, d, A_1..A_m, taubar)`` (vectorised, validated)."""
        return _partition_index(self.params, l, w, d, A, taubar, check=True)

    def state_partition(self, x: Any) -> np.ndarray:
        """Partition index of states."""
        l, w, d, tau = self.decode(x)
        return _partition_index(self.params, l, w, d, tau > 0, tau.max(axis=1), check=False)

    def partition(self) -> Partition:
        """The partition of Section 4.2 (cached); asserts ``M`` = eq. (28)."""
        if self._partition is None:
            l, w, d, tau = self._all
            labels = _partition_index(self.params, l, w, d, tau > 0, tau.max(axis=1), check=False)
            part = Partition(labels, n_partitions=self.n_partitions)
            if part.n_partitions != self.params.n_partitions:  # pragma: no cover
                raise AssertionError("partition count differs from eq. (28)")
            self._partition = part
        return self._partition

    def partition_components(self) -> np.ndarray:
        """Every partition's key (M, 4 + m): l, w, d, A_1..A_m, taubar."""
        return _partition_components(self.params)
