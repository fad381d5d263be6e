"""The Porteus shift of the sweep loops and the Porteus bounds (paper Sec. 3.3).

:class:`PorteusShift` is the offset algebra of an iterate ``u + c`` that every loop of
:mod:`lpbounds.dp` carries (the MacQueen/Porteus extrapolation, :mod:`lpbounds.dp.loop`);
:func:`porteus_bounds` gives the bracket ``lower <= V_pi <= V* <= upper`` of a candidate
``V`` (:class:`PorteusBounds`), rounded so that it holds in floating point.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..stochastic import RowSums, bellman_margin
from ..tolerances import DP_OFFSET_CARRY_SHARE, GREEDY_TIE_RTOL, offset_folds
from ..validation import check_vector
from .greedy import greedy_rows, policy_out
from .operators import Model, exact_rows

__all__ = ["PorteusBounds", "PorteusShift", "porteus_bounds"]


class PorteusShift:
    """The Porteus offset algebra of an iterate ``v = u + c``, shared by every sweep loop.

    Given the extremes ``lo, hi`` of ``T u - u`` (``T`` a max, game or fixed-policy
    operator of rows whose exact sums lie in ``[1 - delta, 1 + delta]``),
    :meth:`step` returns the residual of ``v`` and the offset after the sweep.
    ``T(v) = T u + lambda c`` holds for stochastic rows; in general each row gains
    ``lambda s_r c``, so the residual extremes of ``v`` are those of ``T u - u`` less
    ``(1 - lambda) c``, within ``lambda |c| delta``, which :meth:`step` adds to the
    residual it returns: the residual is a bound on the true one, whatever the rows.

    Two modes (:data:`~lpbounds.tolerances.DP_OFFSET_ROWSUM_ATOL` decides):

    * rows stochastic to rounding (``delta`` at most that, every model whose rows were
      normalised): the offset is carried as a scalar (``u + c`` formed once, at the
      end) and the shift is ``lambda / (1 - lambda)`` times the residual's midpoint;
    * rows that are not (accepted sums ``1 +- 1e-9``): :meth:`settle` adds the offset to
      the iterate after every sweep, so ``c`` is 0 at each sweep and the residual is
      exactly the computed one, and the shift uses the mean effective discount
      ``kappa_m = lambda (lo + hi) / 2`` of the rows: ``kappa_m / (1 - kappa_m)``. The
      constant error mode then contracts by ``lambda (s_r - (lo + hi)/2) / (1 - kappa_m)
      < 1`` whenever ``lambda hi < 1``, which the model's validation guarantees.
    """

    def __init__(self, discount: float, sums: RowSums, tol: float = np.inf) -> None:
        self.lam = float(discount)
        self.delta = sums.delta
        self.fold = offset_folds(self.delta)
        # the most a carried offset may add to the residual (DP_OFFSET_CARRY_SHARE)
        self.carry_limit = DP_OFFSET_CARRY_SHARE * float(tol)
        if self.fold:
            km = self.lam * 0.5 * (sums.lo + sums.hi)
            self.gain = km / (1.0 - km)
        else:
            self.gain = self.lam / (1.0 - self.lam)

    def step(self, c: float, lo: float, hi: float, extrapolate: bool) -> tuple[float, float]:
        """``(residual of u + c, offset after the sweep)`` from the extremes of ``T u - u``."""
        lam = self.lam
        lo -= (1.0 - lam) * c
        hi -= (1.0 - lam) * c
        c_next = lam * c + (self.gain * 0.5 * (lo + hi) if extrapolate else 0.0)
        res = max(-lo, hi)
        if c != 0.0 and self.delta > 0.0:
            res += lam * abs(c) * self.delta
        return res, c_next

    def settle(self, u: np.ndarray, c: float) -> float:
        """The offset to carry into the next sweep: ``c``, or 0 after ``u += c`` (folding).

        The offset is folded when the rows are not stochastic to rounding, and also when
        carrying it would add more than ``DP_OFFSET_CARRY_SHARE`` of the tolerance to the
        next residual (``lambda |c| delta``), so that residual can still reach it.
        """
        if c != 0.0 and (self.fold or self.lam * abs(c) * self.delta > self.carry_limit):
            u += c
            return 0.0
        return c


@dataclass
class PorteusBounds:
    r"""The Porteus (1975) bounds from a candidate value vector ``V`` (paper Sec. 3.3).

    With ``alpha = T V - V`` and ``pi`` greedy w.r.t. ``V``:
    ``lower_paper = V + min(alpha) / (1 - lambda) <= lower = T V + lambda/(1-lambda) min(alpha)
    <= V_pi <= V* <= upper = T V + lambda/(1-lambda) max(alpha)``.

    For rows whose exact sums lie in ``[lo, hi]`` (:class:`lpbounds.stochastic.RowSums`;
    ``lo = hi = 1`` is the textbook case) each ``lambda`` above is ``lambda s``, with
    the ``s`` in ``{lo, hi}`` that makes the bound weakest: ``T^{k+1} V - T^k V >= a``
    implies ``T^{k+2} V - T^{k+1} V >= lambda s a`` for ``s = lo`` when ``a >= 0`` and
    ``s = hi`` when ``a < 0`` (and the mirror image above), so the tail of the series
    sums to ``a lambda s / (1 - lambda s)``.

    In floating point: ``alpha``'s extremes are widened by the rounding allowance of a
    computed ``T V - V`` (:func:`lpbounds.stochastic.bellman_margin`), every factor is
    rounded away from the bound and the bounds are rounded outward by one ulp, so they
    hold for the exact ``V_pi`` and ``V*`` of the stored rows (tested against exact
    rational arithmetic in ``tests/dp/test_row_sums.py``).
    """

    lower: np.ndarray
    lower_paper: np.ndarray
    upper: np.ndarray
    policy: np.ndarray
    alpha_min: float
    alpha_max: float


class _PorteusTail:
    """``sum_{k>=1} a (lambda s)^k = a lambda s / (1 - lambda s)`` rounded the safe way.

    ``s`` is the end of the rows' certified sums ``[lo, hi]`` that makes the tail weakest
    (see :class:`PorteusBounds`), each factor rounded away from the bound's side by a few
    ulps, so the result is a lower (upper) bound on the exact tail in floating point.
    """

    def __init__(self, discount: float, sums: RowSums) -> None:
        e = float(np.finfo(np.float64).eps)
        k_small = discount * sums.lo * (1.0 - 2.0 * e)  # kappa rounded down / up
        k_big = min(discount * sums.hi * (1.0 + 2.0 * e), 1.0)
        self.f_small = k_small / (1.0 - k_small) * (1.0 - 4.0 * e)  # lambda s / (1 - lambda s)
        self.f_big = k_big / ((1.0 - k_big) * (1.0 - 2.0 * e)) * (1.0 + 4.0 * e)
        self.g_small = 1.0 / (1.0 - k_small) * (1.0 - 4.0 * e)  # 1 / (1 - lambda s)
        self.g_big = 1.0 / ((1.0 - k_big) * (1.0 - 2.0 * e)) * (1.0 + 4.0 * e)
        self.e = e

    def lower(self, a: float, paper: bool = False) -> float:
        """A value at most the exact tail of ``a`` (``a / (1 - lambda s)`` with ``paper``)."""
        f = (
            (self.g_small if a >= 0 else self.g_big)
            if paper
            else (self.f_small if a >= 0 else self.f_big)
        )
        t = a * f
        return t - abs(t) * 2.0 * self.e

    def upper(self, a: float) -> float:
        """A value at least the exact tail of ``a``."""
        t = a * (self.f_big if a >= 0 else self.f_small)
        return t + abs(t) * 2.0 * self.e


def porteus_bounds(model: Model, values: Any) -> PorteusBounds:
    """The Porteus bounds of :class:`PorteusBounds` for a candidate ``V`` (finite, else
    :class:`~lpbounds.errors.ValidationError`)."""
    rows = exact_rows(model)
    v = check_vector("values", values, rows.n_vars)
    sums = rows.row_sums()
    sel, tv = greedy_rows(rows, v, GREEDY_TIE_RTOL)
    # the lower bounds use the chosen policy's own Q-values, so a tie within
    # GREEDY_TIE_RTOL cannot make them invalid
    tpi = rows.evaluate_rows(sel, v)
    alpha = tpi - v
    a_lo = float(alpha.min())
    a_hi = float((tv - v).max())
    kappa = sums.modulus(rows.discount)
    m = bellman_margin(
        rows.n_outcomes, float(np.abs(rows.reward).max(initial=0.0)), kappa,
        float(np.abs(v).max(initial=0.0)), float(np.abs(tv).max(initial=0.0)),
    )  # fmt: skip
    tail = _PorteusTail(rows.discount, sums)
    down, up = -np.inf, np.inf
    return PorteusBounds(
        lower=np.nextafter(tpi - m + tail.lower(a_lo - m), down),
        lower_paper=np.nextafter(v + tail.lower(a_lo - m, paper=True), down),
        upper=np.nextafter(tv + m + tail.upper(a_hi + m), up),
        policy=policy_out(model, rows, sel),
        alpha_min=a_lo,
        alpha_max=a_hi,
    )
