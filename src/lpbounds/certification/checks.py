r"""Certified intervals and the three-valued comparison of two of them.

Shared by :mod:`lpbounds.studies.verify` (theorem verdicts) and :mod:`lpbounds.studies.compare` (the
``certified_error`` column of ``lpbounds compare``); it imports only the certificate,
status and row modules, so neither of those two imports the other.

* :func:`lp_bracket` -- the certified bracket ``lower <= exact optimum <= upper`` of an
  LP of Bellman rows from a returned point, preferring the fields the result already
  carries (``certificate``, else ``lower_values``/``upper_values``), else computing it
  with :func:`lpbounds.certification.certificate.certify` on the formulation's ``rows``;
* :func:`lp_objective_bracket` -- a certified bracket on the LP's optimal *objective*
  that stays narrow when the optimum is not unique (a cost with zeros), from the
  certified feasible point above and weak duality below;
* :func:`dp_interval` -- ``[values - error_bound, values + error_bound]`` of an exact DP
  solve, rounded outward;
* :func:`compare_equal`, :func:`compare_at_least` -- the verdicts
  (:class:`~lpbounds.status.Verdict`) of an equality and of an inequality claim between
  two interval vectors.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..results import outward_bracket
from ..status import Verdict
from .certificate import certify, dual_objective_bound, objective_bracket

__all__ = [
    "Bracket",
    "Comparison",
    "combine",
    "compare_at_least",
    "compare_equal",
    "dp_interval",
    "lp_bracket",
    "lp_objective_bracket",
    "separation",
]

_TINY = float(np.finfo(np.float64).tiny)
_ORDER = {Verdict.HOLDS: 0, Verdict.INCONCLUSIVE: 1, Verdict.VIOLATED: 2}


@dataclass(frozen=True)
class Bracket:
    """A certified bracket ``lower <= exact optimum <= upper`` over an LP's variables.

    Attributes
    ----------
    lower, upper : ndarray
        Per variable of the row system (all blocks for IB).
    point : ndarray
        The returned point the bracket was certified from.
    error_bound : float
        A bound on ``max |point - exact optimum|``.
    """

    lower: np.ndarray
    upper: np.ndarray
    point: np.ndarray
    error_bound: float

    @property
    def width(self) -> float:
        """``max(upper - lower)``."""
        return float(np.max(self.upper - self.lower, initial=0.0))


def lp_bracket(formulation: Any, result: Any) -> Bracket:
    """The certified bracket of an LP result of Bellman rows (ELP, RLP, SLP, IB, UBLP, LBLP).

    Prefers what the result carries: its ``certificate`` (over every variable of the row
    system, e.g. all of IB's blocks), else its ``lower_values``/``upper_values``; a result
    with neither (older results, or one built by hand) is certified here with
    ``certify(formulation.rows, result.x)``. A result without a point (``x`` not finite)
    gets ``(-inf, inf)``.

    Parameters
    ----------
    formulation : RowsLP
        Has ``rows`` (a :class:`~lpbounds.rows.BellmanRows`).
    result : LPResult
    """
    x = np.asarray(result.x, dtype=np.float64)
    cert = getattr(result, "certificate", None)
    if cert is not None and np.shape(cert.lower) == x.shape:
        return Bracket(cert.lower, cert.upper, x, float(cert.error_bound))
    lo = getattr(result, "lower_values", None)
    hi = getattr(result, "upper_values", None)
    if lo is not None and hi is not None and np.shape(lo) == x.shape:
        lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
        err = float(max(np.max(hi - x, initial=0.0), np.max(x - lo, initial=0.0)))
        return Bracket(lo, hi, x, err if np.isfinite(err) else float("inf"))
    c = certify(formulation.rows, x)
    return Bracket(c.lower, c.upper, x, float(c.error_bound))


def lp_objective_bracket(formulation: Any, result: Any, bracket: Bracket) -> tuple[float, float]:
    r"""A certified ``[lo, hi]`` on the optimal objective ``c'v*`` of an LP of Bellman rows.

    **Above**: ``bracket.upper`` satisfies every row (the certificate's ``u``), so it is
    feasible and ``c'v* <= c'upper`` (``c >= 0``).

    **Below**, the larger of ``c'lower`` and the weak-duality bound: for the returned
    duals ``y >= 0`` and ``r = A'y - c``, the optimum ``v*`` satisfies ``A v* >= b``, so
    ``c'v* = y'A v* - r'v* >= b'y - sum_j |r_j| max(|lower_j|, |upper_j|)`` (``v*`` lies in
    the bracket). This stays tight when ``c`` has zeros and the returned point is a
    non-unique optimum far from ``v*`` in the zero-cost entries (then ``c'lower`` is
    loose). Rounding: ``|fl(A'y) - A'y| <= (k + 2) eps (|A|'y + |c|)`` with ``k`` the most
    entries of a column, ``|fl(b'y) - b'y| <= (R + 2) eps |b|'y``, the last sum is
    inflated by ``(N + 3) eps`` relative, and ``(k + 3) eps y'(|b| + |A| |v|)`` covers the
    rounding of the rows into ``(A, b)`` (``v*`` satisfies the rows exactly, ``A v* >= b``
    only up to that); every bound is then rounded outward.
    """
    c = np.asarray(formulation.c, dtype=np.float64)
    lo, hi = objective_bracket(c, bracket.lower, bracket.upper)
    y = getattr(result, "duals", np.array([]))
    a, b = formulation.A, formulation.b
    rho = float(getattr(formulation, "row_rounding", 0.0))  # stored rows vs exact ones
    return max(lo, dual_objective_bound(a, b, c, y, bracket.lower, bracket.upper, rho)), hi


def dp_interval(dp_result: Any) -> tuple[np.ndarray, np.ndarray]:
    """``[values - error_bound, values + error_bound]`` of a :func:`~lpbounds.dp.solve_exact`
    result, rounded outward by one ulp."""
    return outward_bracket(dp_result.values, float(dp_result.error_bound))


@dataclass(frozen=True)
class Comparison:
    """The verdict of one claim between an interval vector ``a`` and a reference ``b``.

    Attributes
    ----------
    verdict : Verdict
    width : float
        Equality: the largest ``|a - b|`` the intervals allow (``max(a_hi, b_hi) -
        min(a_lo, b_lo)`` over entries). Inequality: the widest of the two intervals.
    deviation : float
        Equality: ``max |mid(a) - mid(b)|``. Inequality ``a >= b``: ``max (mid(b) -
        mid(a))^+``.
    accuracy : float
        The requested accuracy (absolute, in value units).
    index : int
        The deciding entry: the most separated one (a counterexample when violated),
        else the widest.
    a_interval, b_interval : tuple of float
        Both intervals at ``index``.
    """

    verdict: Verdict
    width: float
    deviation: float
    accuracy: float
    index: int
    a_interval: tuple[float, float]
    b_interval: tuple[float, float]


def _prepare(a_lo: Any, a_hi: Any, b_lo: Any, b_hi: Any) -> tuple[np.ndarray, ...]:
    arrs = [np.atleast_1d(np.asarray(t, dtype=np.float64)) for t in (a_lo, a_hi, b_lo, b_hi)]
    shape = np.broadcast_shapes(*(t.shape for t in arrs))
    return tuple(np.broadcast_to(t, shape).ravel() for t in arrs)


def _nan_to_wide(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A NaN end says nothing: widen it to infinity."""
    return np.where(np.isnan(lo), -np.inf, lo), np.where(np.isnan(hi), np.inf, hi)


def _intervals(a_lo: Any, a_hi: Any, b_lo: Any, b_hi: Any) -> tuple[np.ndarray, ...]:
    """The four interval ends as flat float arrays of one shape, NaN ends widened."""
    a_lo, a_hi, b_lo, b_hi = _prepare(a_lo, a_hi, b_lo, b_hi)
    a_lo, a_hi = _nan_to_wide(a_lo, a_hi)
    b_lo, b_hi = _nan_to_wide(b_lo, b_hi)
    return a_lo, a_hi, b_lo, b_hi


def _make(
    verdict: Verdict, width: float, dev: float, accuracy: float, idx: int, arrs: tuple
) -> Comparison:
    a_lo, a_hi, b_lo, b_hi = arrs
    return Comparison(
        verdict,
        float(width),
        float(dev),
        float(accuracy),
        int(idx),
        (float(a_lo[idx]), float(a_hi[idx])),
        (float(b_lo[idx]), float(b_hi[idx])),
    )


def _mid(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", over="ignore"):
        return lo / 2 + hi / 2


def compare_equal(a_lo: Any, a_hi: Any, b_lo: Any, b_hi: Any, accuracy: float) -> Comparison:
    """Verdict of the claim ``a = b`` (entry by entry) from certified intervals.

    *violated* iff some entry's intervals are disjoint (the claim is proven false there);
    *holds* iff not violated and the largest difference the intervals allow is within
    ``accuracy``; *inconclusive* otherwise.
    """
    arrs = _intervals(a_lo, a_hi, b_lo, b_hi)
    a_lo, a_hi, b_lo, b_hi = arrs
    if a_lo.size == 0:
        return Comparison(Verdict.HOLDS, 0.0, 0.0, float(accuracy), 0, (0.0, 0.0), (0.0, 0.0))
    with np.errstate(invalid="ignore", over="ignore"):
        sep = np.maximum(a_lo - b_hi, b_lo - a_hi)  # > 0: disjoint
        span = np.maximum(a_hi, b_hi) - np.minimum(a_lo, b_lo)
        dev = float(np.max(np.abs(_mid(a_lo, a_hi) - _mid(b_lo, b_hi)), initial=0.0))
    width = float(np.max(span, initial=0.0))
    if np.any(sep > 0):
        return _make(Verdict.VIOLATED, width, dev, accuracy, int(np.argmax(sep)), arrs)
    verdict = Verdict.HOLDS if width <= accuracy else Verdict.INCONCLUSIVE
    return _make(verdict, width, dev, accuracy, int(np.argmax(span)), arrs)


def compare_at_least(a_lo: Any, a_hi: Any, b_lo: Any, b_hi: Any, accuracy: float) -> Comparison:
    """Verdict of the claim ``a >= b`` (entry by entry) from certified intervals.

    *violated* iff some entry has ``a_hi < b_lo`` (proven ``a < b`` there); *holds* iff
    every entry has ``a_lo >= b_hi - accuracy`` (proven ``a >= b - accuracy``);
    *inconclusive* otherwise.
    """
    arrs = _intervals(a_lo, a_hi, b_lo, b_hi)
    a_lo, a_hi, b_lo, b_hi = arrs
    if a_lo.size == 0:
        return Comparison(Verdict.HOLDS, 0.0, 0.0, float(accuracy), 0, (0.0, 0.0), (0.0, 0.0))
    with np.errstate(invalid="ignore", over="ignore"):
        proven_short = b_lo - a_hi  # > 0: a < b proven
        shortfall = b_hi - a_lo  # <= accuracy everywhere: a >= b - accuracy proven
        width = float(np.max(np.maximum(a_hi - a_lo, b_hi - b_lo), initial=0.0))
        dev = float(np.max(np.maximum(_mid(b_lo, b_hi) - _mid(a_lo, a_hi), 0.0), initial=0.0))
    if np.any(proven_short > 0):
        return _make(Verdict.VIOLATED, width, dev, accuracy, int(np.argmax(proven_short)), arrs)
    verdict = Verdict.HOLDS if np.all(shortfall <= accuracy) else Verdict.INCONCLUSIVE
    return _make(verdict, width, dev, accuracy, int(np.argmax(shortfall)), arrs)


def separation(c: Comparison) -> float:
    """How far a comparison's deciding intervals are apart: ``max(a_lo - b_hi, b_lo -
    a_hi)`` at its ``index`` (positive for a *violated* one: the proven size of the
    violation there, which is the largest over its entries)."""
    (a_lo, a_hi), (b_lo, b_hi) = c.a_interval, c.b_interval
    with np.errstate(invalid="ignore", over="ignore"):
        sep = max(a_lo - b_hi, b_lo - a_hi)
    return float(sep) if np.isfinite(sep) else float("inf")


def combine(comparisons: list[Comparison]) -> Comparison:
    """One comparison for several (e.g. one per cost): the worst one, by verdict
    (violated > inconclusive > holds); among violated ones the most violated (the largest
    :func:`separation`), otherwise the largest ``width / accuracy``; the first of equals."""

    def badness(c: Comparison) -> tuple[int, float]:
        if c.verdict is Verdict.VIOLATED:
            return _ORDER[c.verdict], separation(c)
        return _ORDER[c.verdict], c.width / max(c.accuracy, _TINY)

    return max(comparisons, key=badness)
