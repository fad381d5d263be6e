r"""Certified brackets on the exact optimum of a Bellman row system, from a point alone.

Every LP lpbounds builds from Bellman rows (ELP, RLP, SLP, IB, UBLP, LBLP) has as its
exact optimum the least feasible point ``v*``, the fixed point of the max over the rows
``(Tv)(i) = max_{r of i} q_r(v)`` (Fact 1 of :mod:`lpbounds.rows.system`); the disjunctive NLP's
is the fixed point of the max-min ``G`` (Fact 2). :func:`certify` turns *any* point ``v``
-- an LP solver's answer, whatever the solver claimed -- into a bracket
``lower <= v* <= upper`` that holds in floating point.

**The argument.** Let ``s_r = sum_l p_{r,l}`` and ``kappa = lambda max_r s_r < 1``. For a
constant ``c >= 0``, every row satisfies ``q_r(v + c) = q_r(v) + lambda s_r c``, so
``T(v + c) <= Tv + kappa c`` and ``T(v - c) >= Tv - kappa c`` (the same for ``G``: max and
min keep both inequalities). With ``d+ = max_i (Tv - v)_i^+`` and ``d- = max_i (v - Tv)_i^+``:

* ``u = v + d+/(1 - kappa)`` has ``Tu <= Tv + kappa d+/(1-kappa) <= v + d+ + kappa
  d+/(1-kappa) = u``, so ``u >= Tu >= T^2 u -> v*`` (``T`` is monotone): ``v* <= u``;
* ``l = v - d-/(1 - kappa)`` has ``Tl >= l`` likewise, so ``l <= v*``.

A feasible point (``d+ = 0``) is therefore its own upper bound, as it must be.

**Rounding.** ``Tv`` is computed in floating point. Each ``q_r`` is a sum of ``L + 1``
terms times ``lambda``; its computed value is within ``gamma (|R_r| + kappa max|v|)`` of
the exact one, ``gamma = (L + 3) eps`` (any summation order, with or without FMA). The
subtraction ``Tv - v`` adds ``eps (max|Tv| + max|v|)``; merging rows (aggregation) adds
at most ``L eps kappa max|v|`` through rounded merged probabilities. The certificate adds
all of these as ``margin`` (doubled, and with the smallest normal number so that
underflow is covered), bounds ``s_r`` from above by ``(1 + (L + 1) eps)`` times its
computed value, divides by ``1 - kappa`` rounded down, and rounds ``v +- c`` outward by one
ulp (``np.nextafter``). ``docs/tolerances.md`` works an example through.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from ..errors import ValidationError
from ..rows import BellmanRows
from ..stochastic import bellman_margin

__all__ = [
    "Certificate",
    "certify",
    "contraction_modulus",
    "dual_objective_bound",
    "objective_bracket",
]

_EPS = float(np.finfo(np.float64).eps)
_TINY = float(np.finfo(np.float64).tiny)

Operator = Literal["max", "maxmin"]


@dataclass(frozen=True)
class Certificate:
    """A bracket ``lower <= v* <= upper`` on the exact optimum, valid in floating point.

    Attributes
    ----------
    lower, upper : ndarray
        Per variable.
    residual_up, residual_down : float
        ``d+ = max (Tv - v)^+`` and ``d- = max (v - Tv)^+`` as computed.
    margin : float
        The rounding allowance added to each (absolute).
    modulus : float
        ``kappa``, the certified contraction modulus (``lambda`` times the largest row
        sum, rounded up).
    error_bound : float
        ``max(max(upper - v), max(v - lower))``: a bound on ``||v - v*||_inf``.
    reward_absmax : float
        ``max |R|`` over the rows (the scale of the problem: ``|v*| <= max|R| / (1 - kappa)``).
    """

    lower: np.ndarray
    upper: np.ndarray
    residual_up: float
    residual_down: float
    margin: float
    modulus: float
    error_bound: float
    reward_absmax: float

    @property
    def width(self) -> float:
        """``max(upper - lower)``."""
        return float(np.max(self.upper - self.lower, initial=0.0))

    @property
    def residual(self) -> float:
        """``||Tv - v||_inf`` as computed."""
        return max(self.residual_up, self.residual_down)

    def relative_error(self) -> float:
        """``error_bound`` relative to ``max|R| / (1 - kappa)``, computed without overflow.

        0 when the rewards are all 0 and the point is exact; ``inf`` when the rewards are
        0 and it is not.
        """
        num = self.error_bound * (1.0 - self.modulus)
        if self.reward_absmax > 0:
            return num / self.reward_absmax
        return 0.0 if num <= self.margin else float("inf")

    def is_accurate(self, rtol: float) -> bool:
        """True when the computed residual is within ``rtol * max|R|`` (so the certified
        error is within ``rtol * max|R| / (1 - kappa)`` plus the rounding allowance)."""
        return bool(self.residual <= rtol * self.reward_absmax)

    def objective_bracket(self, cost: Any) -> tuple[float, float]:
        """``[c'lower, c'upper]`` rounded outward, a bracket on ``c'v*`` for ``c >= 0``."""
        return objective_bracket(cost, self.lower, self.upper)


def objective_bracket(cost: Any, lower: np.ndarray, upper: np.ndarray) -> tuple[float, float]:
    """``[c'lower, c'upper]`` with the summation's rounding error added outward (``c >= 0``)."""
    c = np.asarray(cost, dtype=np.float64)
    n = c.size + 1
    lo_terms = c * lower
    hi_terms = c * upper
    lo = float(lo_terms.sum())
    hi = float(hi_terms.sum())
    lo -= n * _EPS * float(np.abs(lo_terms).sum()) + _TINY
    hi += n * _EPS * float(np.abs(hi_terms).sum()) + _TINY
    return float(np.nextafter(lo, -np.inf)), float(np.nextafter(hi, np.inf))


def dual_objective_bound(
    A: Any,
    b: np.ndarray,
    c: np.ndarray,
    y: Any,
    lower: np.ndarray,
    upper: np.ndarray,
    row_rounding: float = 0.0,
) -> float:
    r"""A rigorous lower bound on ``c'v*`` from any multipliers ``y`` (weak duality on a box).

    For ``y >= 0`` and ``r = A'y - c``, the optimum ``v*`` satisfies ``A v* >= b`` and lies
    in ``[lower, upper]`` (the certificate), so ``c'v* = y'A v* - r'v* >= b'y - sum_j |r_j|
    max(|lower_j|, |upper_j|)``. Where a cost is 0 the box may be wide but ``r`` is then
    tiny, so this bound certifies the objective where the point itself is not unique.

    Rounding: ``|fl(A'y) - A'y| <= (k + 2) eps (|A|'y + |c|)`` with ``k`` the most entries
    of a column, ``|fl(b'y) - b'y| <= (R + 2) eps |b|'y``, the last sum is inflated by
    ``(N + 3) eps`` relative, and ``(k + 3) eps y'(|b| + |A| |v|)`` covers the rounding of
    the rows into ``(A, b)`` (``v*`` satisfies the rows exactly, ``A v* >= b`` only up to
    that); the bound is then rounded down. ``-inf`` when nothing can be said (non-finite
    duals or box).

    ``row_rounding`` (``rho``) covers what that last term cannot: rows whose stored ``(A,
    b)`` are not the exact rows ``(A~, b~)`` the optimum satisfies beyond the rounding of
    their own entries, i.e. ``sum_j |A_rj - A~_rj| <= 2 rho`` and ``|b_r - b~_r| <= rho
    max|b|`` for every row: ``rho sum(y) (max|b| + 2 max|v|)`` is subtracted. Bellman rows
    need it: ``A = E - lambda P`` is formed in floating point, and where a row reads its own
    variable the entry ``1 - lambda p`` cancels (its rounding is ``eps`` of 1, not of
    ``|1 - lambda p|``: at discount 0.9999 a self-loop's entry is ``1e-4`` and its relative
    error ``1e-12``); aggregated rows also sum probabilities in floating point. Found by
    exact arithmetic (tests/exact): an RLP at discount 0.9999 whose bound was ``1.5e-13``
    relative above the exact optimum with ``rho = 0``.
    """
    yy = np.asarray(y, dtype=np.float64)
    if (
        yy.shape != (A.shape[0],)
        or not np.all(np.isfinite(yy))
        or not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper)))
    ):
        return -float("inf")
    yy = np.maximum(yy, 0.0)
    bb = np.asarray(b, dtype=np.float64)
    k = int(np.diff(A.tocsc().indptr).max(initial=0))
    a_abs = abs(A)
    resid = np.abs(A.T @ yy - c) + (k + 2) * _EPS * (a_abs.T @ yy + np.abs(c))
    size = np.maximum(np.abs(lower), np.abs(upper))
    corr = float((resid * size).sum()) * (1.0 + (c.size + 3) * _EPS)
    corr += (k + 3) * _EPS * float(yy @ (np.abs(bb) + a_abs @ size))
    if row_rounding:
        b_max, v_max = float(np.abs(bb).max(initial=0.0)), float(size.max(initial=0.0))
        corr += float(row_rounding) * float(yy.sum()) * (b_max + 2.0 * v_max) * (1.0 + 8 * _EPS)
    by = float(bb @ yy) - (bb.size + 2) * _EPS * float(np.abs(bb) @ yy)
    out = by - corr - _TINY
    return float(np.nextafter(out, -np.inf)) if np.isfinite(out) else -float("inf")


def contraction_modulus(rows: BellmanRows) -> float:
    """``lambda * max_r sum_l p_{r,l}``, rounded up; an error if it is not below 1."""
    sums = rows.row_sums()
    kappa = sums.modulus(rows.discount)
    if not kappa < 1.0:
        raise ValidationError(
            f"cannot certify: discount {rows.discount} times the largest row sum "
            f"{sums.computed_max!r} is not below 1, so the rows are not a contraction"
        )
    return kappa


def certify(rows: BellmanRows, v: Any, operator: Operator = "max") -> Certificate:
    """The certified bracket on the exact optimum of ``rows`` from the point ``v``.

    Parameters
    ----------
    rows : BellmanRows
    v : array_like (rows.n_vars,)
        Any point (need not be feasible). A non-finite entry gives the bracket
        ``(-inf, inf)`` (nothing can be certified from it).
    operator : {"max", "maxmin"}
        ``"max"`` for the LPs (Fact 1), ``"maxmin"`` for the disjunctive NLP (Fact 2).

    Returns
    -------
    Certificate
    """
    if operator not in ("max", "maxmin"):
        raise ValidationError(f"operator must be 'max' or 'maxmin'; got {operator!r}")
    vv = np.ascontiguousarray(v, dtype=np.float64)
    if vv.shape != (rows.n_vars,):
        raise ValidationError(f"expected a point of length {rows.n_vars}; got shape {vv.shape}")
    kappa = contraction_modulus(rows)
    r_abs = float(np.abs(rows.reward).max(initial=0.0))
    if not np.all(np.isfinite(vv)):
        return _nothing(rows.n_vars, kappa, r_abs)
    tv, _ = rows.apply_max(vv) if operator == "max" else rows.apply_maxmin(vv)
    if not np.all(np.isfinite(tv)):
        return _nothing(rows.n_vars, kappa, r_abs)
    diff = tv - vv
    d_up = float(max(0.0, diff.max(initial=0.0)))
    d_down = float(max(0.0, -diff.min(initial=0.0)))
    v_abs = float(np.abs(vv).max(initial=0.0))
    tv_abs = float(np.abs(tv).max(initial=0.0))
    n_out = rows.n_outcomes
    margin = bellman_margin(n_out, r_abs, kappa, v_abs, tv_abs)
    one_minus = (1.0 - kappa) * (1.0 - 2.0 * _EPS)
    c_up = (d_up + margin) / one_minus * (1.0 + 4.0 * _EPS)
    c_down = (d_down + margin) / one_minus * (1.0 + 4.0 * _EPS)
    upper = np.nextafter(vv + c_up, np.inf)
    lower = np.nextafter(vv - c_down, -np.inf)
    err = float(max(np.max(upper - vv, initial=0.0), np.max(vv - lower, initial=0.0)))
    return Certificate(
        lower=lower,
        upper=upper,
        residual_up=d_up,
        residual_down=d_down,
        margin=margin,
        modulus=kappa,
        error_bound=err,
        reward_absmax=r_abs,
    )


def _nothing(n: int, kappa: float, r_abs: float) -> Certificate:
    inf = float("inf")
    return Certificate(
        lower=np.full(n, -inf),
        upper=np.full(n, inf),
        residual_up=inf,
        residual_down=inf,
        margin=inf,
        modulus=kappa,
        error_bound=inf,
        reward_absmax=r_abs,
    )
