r"""Parameters of the perimeter alert patrol problem (paper Section 4.1, 5 and Appendix A).

:class:`PatrolParams` holds every number of the model under the paper's names, with the
paper's example as defaults (N = 15 nodes, stations (0, 3, 7, 11), D = 5, Gamma = 15,
rho = 0.005, lambda = 0.9, alpha = 1/60, and the operator model of Appendix A with
p = 0.01, a = c = 0.5, b = g = 0.45, mu1 = mu2 = 1). ``docs/patrol-model.md`` (the
project's model specification) settles the paper's ambiguities; the one model choice it
leaves open is :attr:`PatrolParams.allow_empty_loiter`.

Counts (paper eq. 27 and 28)::

    |S| = 2 N (Gamma+1)^m + D m (Gamma+1)^(m-1)
    M   = 2 N + 2 N (2^m - 1) Gamma + m D + m D (2^(m-1) - 1) Gamma

Information gain (Appendix A, natural log): with ``P = P_TR(d) = a + b (1 - e^{-mu1 d})``
and ``Q = P_FTR(d) = c + g (1 - e^{-mu2 d})``, ``I(d) = I(X; Z)`` is the mutual
information between the alert's nature ``X`` (threat with prior ``p``) and the
operator's report ``Z``::

    I(d) = p P log(P / z1) + p (1-P) log((1-P) / z2)
         + (1-p)(1-Q) log((1-Q) / z1) + (1-p) Q log(Q / z2),
    z1 = p P + (1-p)(1-Q),  z2 = p (1-P) + (1-p) Q,

with ``0 log(0/.) = 0``. ``I(0) = 0`` exactly when ``a + c = 1`` (an uninformed operator,
as in the paper); in general ``I(0) >= 0`` and only the increments ``I(d+1) - I(d)``
enter the reward.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ValidationError

__all__ = ["PatrolParams"]

#: Largest Gamma accepted: delays are stored as int16 in the vectorised model.
GAMMA_MAX = 32_000


def _plogratio(weight: np.ndarray, num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """``weight * log(num / den)`` with the convention ``0 * log(.) = 0``."""
    out = np.zeros(np.broadcast(weight, num, den).shape)
    pos = np.broadcast_to(weight > 0, out.shape)
    w, n, d = (np.broadcast_to(a, out.shape) for a in (weight, num, den))
    out[pos] = w[pos] * np.log(n[pos] / d[pos])
    return out


@dataclass(frozen=True)
class PatrolParams:
    """The patrol model's parameters, named as in the paper (validated on construction).

    Parameters
    ----------
    N : int
        Number of perimeter nodes ``0..N-1`` (a ring).
    stations : tuple of int
        The alert stations ``Omega`` (distinct nodes); their order fixes the order of
        ``tau_1..tau_m``, ``A_1..A_m`` and of the outcomes ``Y_1..Y_m``.
    D : int
        Maximum dwell (number of loiters) at a station.
    Gamma : int
        Delay cap: ``tau_j <= Gamma``.
    rho : float
        Weight of the delay penalty ``rho * min(taubar, Gamma)``.
    discount : float
        ``lambda`` in ``[0, 1)``.
    alpha : float
        Poisson alert rate per unit time; ``p_0 = exp(-alpha)``, ``p_k = (1 - p_0) / m``.
    p_threat, a, b, c, g, mu1, mu2 : float
        Operator model of Appendix A (prior of a real threat, confusion-matrix
        parameters with ``0 < a + b <= 1``, ``0 < c + g <= 1``, rates ``mu >= 0``).
    allow_empty_loiter : bool
        False (default, the project's specification): loitering (u = 0) at a station
        with ``d = 0`` needs an unserviced alert there (``tau_l > 0``). True: the
        paper's literal text, u = 0 at any station while ``d < D``.
    """

    N: int = 15
    stations: tuple[int, ...] = (0, 3, 7, 11)
    D: int = 5
    Gamma: int = 15
    rho: float = 0.005
    discount: float = 0.9
    alpha: float = 1.0 / 60.0
    p_threat: float = 0.01
    a: float = 0.5
    b: float = 0.45
    c: float = 0.5
    g: float = 0.45
    mu1: float = 1.0
    mu2: float = 1.0
    allow_empty_loiter: bool = False
    _station_pos: tuple[int, ...] = field(init=False, repr=False, compare=False)

    # ------------------------------------------------------------------ validation
    def __post_init__(self) -> None:
        for name in ("N", "D", "Gamma"):
            object.__setattr__(self, name, self._int(name, getattr(self, name), 1))
        if self.Gamma > GAMMA_MAX:
            raise ValidationError(f"Gamma = {self.Gamma} exceeds the supported {GAMMA_MAX}")
        st = self.stations
        if isinstance(st, (str, bytes)) or not hasattr(st, "__iter__"):
            raise ValidationError(f"stations must be a sequence of node indices; got {st!r}")
        st = tuple(self._int(f"stations[{k}]", s, 0) for k, s in enumerate(st))
        if not st:
            raise ValidationError("stations must name at least one node")
        for k, s in enumerate(st):
            if s >= self.N:
                raise ValidationError(f"stations[{k}] = {s} is not a node 0..N-1 (N = {self.N})")
        if len(set(st)) != len(st):
            raise ValidationError(f"stations must be distinct; got {st}")
        object.__setattr__(self, "stations", st)
        for name in ("rho", "discount", "alpha", "p_threat", "a", "b", "c", "g", "mu1", "mu2"):
            object.__setattr__(self, name, self._float(name, getattr(self, name)))
        if self.rho < 0:
            raise ValidationError(f"rho must be >= 0; got {self.rho}")
        if not 0.0 <= self.discount < 1.0:
            raise ValidationError(f"discount must lie in [0, 1); got {self.discount}")
        if self.alpha <= 0:
            raise ValidationError(f"alpha (alert rate) must be > 0; got {self.alpha}")
        if not 0.0 < self.p_threat < 1.0:
            raise ValidationError(f"p_threat must lie in (0, 1); got {self.p_threat}")
        for name in ("a", "b", "c", "g", "mu1", "mu2"):
            if getattr(self, name) < 0:
                raise ValidationError(f"{name} must be >= 0; got {getattr(self, name)}")
        if not 0.0 < self.a + self.b <= 1.0:
            raise ValidationError(
                f"need 0 < a + b <= 1 (Appendix A); got a + b = {self.a + self.b}"
            )
        if not 0.0 < self.c + self.g <= 1.0:
            raise ValidationError(
                f"need 0 < c + g <= 1 (Appendix A); got c + g = {self.c + self.g}"
            )
        if not isinstance(self.allow_empty_loiter, (bool, np.bool_)):
            raise ValidationError(
                f"allow_empty_loiter must be true or false; got {self.allow_empty_loiter!r}"
            )
        object.__setattr__(self, "allow_empty_loiter", bool(self.allow_empty_loiter))
        pos = [-1] * self.N
        for k, s in enumerate(st):
            pos[s] = k
        object.__setattr__(self, "_station_pos", tuple(pos))

    @staticmethod
    def _int(name: str, value: Any, minimum: int) -> int:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
            raise ValidationError(f"{name} must be an integer; got {value!r}")
        if int(value) < minimum:
            raise ValidationError(f"{name} must be >= {minimum}; got {value}")
        return int(value)

    @staticmethod
    def _float(name: str, value: Any) -> float:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            raise ValidationError(f"{name} must be a number; got {value!r}")
        v = float(value)
        if not math.isfinite(v):
            raise ValidationError(f"{name} must be finite; got {value!r}")
        return v

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> PatrolParams:
        """Parameters from a TOML ``[model]`` table (keys named as in the paper).

        Keys: ``N, stations, D, Gamma, rho, discount, alpha, p_threat, a, b, c, g, mu1,
        mu2, allow_empty_loiter``; a missing key takes the paper's value, an unknown key
        (a typo) raises :class:`~lpbounds.errors.ValidationError` naming it. ``kind`` is
        ignored.
        """
        from ..model.instances import check_keys

        defaults = {f.name: f.default for f in dataclasses.fields(cls) if f.init}
        values = check_keys(table, defaults, "model")
        return cls(**values)

    def replace(self, **changes: Any) -> PatrolParams:
        """A copy with some parameters changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_table(self) -> dict[str, Any]:
        """The parameters as a TOML-style ``[model]`` table (``kind = "patrol"``)."""
        out: dict[str, Any] = {"kind": "patrol"}
        for f in dataclasses.fields(self):
            if f.init:
                v = getattr(self, f.name)
                out[f.name] = list(v) if isinstance(v, tuple) else v
        return out

    # ------------------------------------------------------------------ derived
    @property
    def m(self) -> int:
        """Number of stations ``m = |Omega|``."""
        return len(self.stations)

    @property
    def station_pos(self) -> np.ndarray:
        """``station_pos[l]``: position ``k`` of node ``l`` in ``stations``, or -1."""
        return np.array(self._station_pos, dtype=np.int64)

    @property
    def n_states(self) -> int:
        """``|S| = 2 N (Gamma+1)^m + D m (Gamma+1)^(m-1)`` (eq. 27), an exact int."""
        r = self.Gamma + 1
        return 2 * self.N * r**self.m + self.D * self.m * r ** (self.m - 1)

    @property
    def n_partitions(self) -> int:
        """``M = 2N + 2N(2^m - 1)Gamma + mD + mD(2^(m-1) - 1)Gamma`` (eq. 28), an exact int."""
        n, m, d, g = self.N, self.m, self.D, self.Gamma
        return 2 * n + 2 * n * (2**m - 1) * g + m * d + m * d * (2 ** (m - 1) - 1) * g

    def alert_probabilities(self) -> np.ndarray:
        """``[p_0, p_1, ..., p_m]`` (eq. 21): ``p_0 = e^{-alpha}``, ``p_k = (1 - p_0) / m``."""
        p_alert = -math.expm1(-self.alpha)
        out = np.full(self.m + 1, p_alert / self.m)
        out[0] = math.exp(-self.alpha)
        return out

    def report_probabilities(self, d: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(P_TR(d), P_FTR(d))`` of Appendix A, eq. (A.2)."""
        dd = np.asarray(d, dtype=np.float64)
        p_tr = self.a + self.b * (-np.expm1(-self.mu1 * dd))
        p_ftr = self.c + self.g * (-np.expm1(-self.mu2 * dd))
        return p_tr, p_ftr

    def information(self, d: Any) -> np.ndarray:
        """``I(d)``: mutual information (nats) between threat and report after ``d`` loiters.

        Vectorised over ``d`` (any real ``d >= 0``); see the module docstring.
        """
        dd = np.asarray(d, dtype=np.float64)
        if np.any(dd < 0) or not np.all(np.isfinite(dd)):
            raise ValidationError("dwell d must be finite and >= 0")
        p = self.p_threat
        big_p, big_q = self.report_probabilities(dd)
        z1 = p * big_p + (1 - p) * (1 - big_q)
        z2 = p * (1 - big_p) + (1 - p) * big_q
        total = (
            _plogratio(p * big_p, big_p, z1)
            + _plogratio(p * (1 - big_p), 1 - big_p, z2)
            + _plogratio((1 - p) * (1 - big_q), 1 - big_q, z1)
            + _plogratio((1 - p) * big_q, big_q, z2)
        )
        return total.reshape(dd.shape) if dd.ndim else np.asarray(total)

    def information_increments(self) -> np.ndarray:
        """``I(d+1) - I(d)`` for ``d = 0..D-1``: the loiter reward before the penalty."""
        info = self.information(np.arange(self.D + 1))
        return np.diff(info)
