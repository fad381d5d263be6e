r"""The row-sum rule shared by every model and row system, and certified row-sum bounds.

A model (:class:`~lpbounds.model.mdp.FiniteMDP`) and a row system
(:class:`~lpbounds.rows.BellmanRows`) accept the same probabilities: each row's entries
are above ``-PROBABILITY_NEGATIVE_ATOL`` (and clipped to 0) and sum to one within
``PROBABILITY_SUM_ATOL``. Accepted rows are stored **as given**: a row summing to
``1 + 9e-10`` is that row, and every bound lpbounds reports holds for it
(``docs/tolerances.md``, "Row sums").

What the bounds need from the rows is :class:`RowSums`: certified bounds ``lo <= s_r <=
hi`` on the *exact* sums ``s_r = sum_l p_{r,l}`` of the stored entries. A sum computed
in floating point is within ``(L - 1) eps s_r`` of the exact one for ``L`` non-negative
terms (any summation order), so widening the computed extremes by ``(L + 3) eps``
(relative) covers it with room. From them:

* the contraction modulus of every Bellman operator of the rows in the max norm,
  ``kappa = lambda max_r s_r <= lambda hi`` (:meth:`RowSums.modulus`): an error bound is
  ``residual / (1 - kappa)``, never ``residual / (1 - lambda)`` unless every row sums to 1;
* ``delta = max(hi - 1, 1 - lo)``, how far the rows are from stochastic: the Porteus
  offset algebra ``T(v + c) = T v + lambda c`` holds up to ``lambda |c| delta``.

A model whose ``kappa`` is not below 1 has no discounted value (the rows are not a
contraction): :func:`check_rows` refuses it, naming the row.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import ValidationError
from .tolerances import PROBABILITY_NEGATIVE_ATOL, PROBABILITY_SUM_ATOL

__all__ = [
    "RowSums",
    "bellman_margin",
    "check_rows",
    "row_sums",
]

_EPS = float(np.finfo(np.float64).eps)
_TINY = float(np.finfo(np.float64).tiny)


@dataclass(frozen=True)
class RowSums:
    """Certified bounds on the exact row sums of stored probabilities.

    Attributes
    ----------
    computed_min, computed_max : float
        The extremes of the row sums as computed in floating point.
    n_outcomes : int
        ``L``, the number of terms of a row (sets the rounding allowance).
    """

    computed_min: float
    computed_max: float
    n_outcomes: int

    @property
    def rounding(self) -> float:
        """``(L + 3) eps``: the relative allowance between a computed and an exact sum."""
        return (max(1, self.n_outcomes) + 3) * _EPS

    @property
    def lo(self) -> float:
        """A lower bound on every exact row sum."""
        return max(self.computed_min, 0.0) * (1.0 - self.rounding)

    @property
    def hi(self) -> float:
        """An upper bound on every exact row sum."""
        return max(self.computed_max, 0.0) * (1.0 + self.rounding)

    @property
    def delta(self) -> float:
        """``max(hi - 1, 1 - lo)``: a bound on ``max_r |s_r - 1|``."""
        return max(self.hi - 1.0, 1.0 - self.lo, 0.0)

    def modulus(self, discount: float) -> float:
        """``lambda max_r s_r``, rounded up: the rows' contraction modulus (may be >= 1).

        Computed as ``lambda * computed_max * (1 + (L + 3) eps)``, the product the LP
        certificates have always used
        (:func:`lpbounds.certification.certificate.contraction_modulus`).
        """
        return float(discount) * max(self.computed_max, 0.0) * (1.0 + self.rounding)


def bellman_margin(
    n_outcomes: int, reward_absmax: float, kappa: float, v_absmax: float, tv_absmax: float
) -> float:
    """The rounding allowance on a computed ``T v - v`` (absolute, entry by entry).

    Each ``q_r(v)`` is a sum of ``L + 1`` terms times ``lambda``, within
    ``(L + 3) eps (|R_r| + kappa max|v|)`` of its exact value; the subtraction adds
    ``eps (max|Tv| + max|v|)``; merged (aggregated) rows add ``L eps kappa max|v|``.
    Doubled, plus a few of the smallest normal numbers for underflow. The allowance of
    :func:`lpbounds.certification.certificate.certify` and of :func:`lpbounds.porteus_bounds`.
    """
    return (
        2.0
        * (
            (n_outcomes + 3) * _EPS * (reward_absmax + kappa * v_absmax)
            + _EPS * (tv_absmax + v_absmax)
            + n_outcomes * _EPS * kappa * v_absmax
        )
        + 4.0 * _TINY
    )


def row_sums(probs: np.ndarray) -> RowSums:
    """:class:`RowSums` of an ``(R, L)`` array of row probabilities (or of one ``(L,)`` row).

    A broadcast view (one distribution shared by every row) is summed once.
    """
    p = np.asarray(probs)
    if p.ndim == 1:
        s = float(p.sum())
        return RowSums(s, s, int(p.size))
    n_out = int(p.shape[1]) if p.ndim == 2 else 0
    if p.size == 0:
        return RowSums(0.0, 0.0, n_out)
    if p.strides[0] == 0:  # one shared distribution
        s = float(p[0].sum())
        return RowSums(s, s, n_out)
    sums = p.sum(axis=1)
    return RowSums(float(sums.min()), float(sums.max()), n_out)


def check_rows(name: str, p: np.ndarray, discount: float, where: np.ndarray | None = None) -> None:
    """The row-sum rule: entries ``>= -PROBABILITY_NEGATIVE_ATOL``, each row summing to 1,
    and the effective discount ``discount * max row sum`` below 1 (one sum of the rows).

    Parameters
    ----------
    name : str
        The argument's name, used in the messages (``probabilities``, ``probs``).
    p : ndarray (..., L)
        Rows along the last axis; must be finite where checked.
    discount : float
        ``lambda``, in ``[0, 1)`` (checked by the caller).
    where : ndarray of bool (...), optional
        Only these rows are checked (the allowed pairs); default every row.

    Raises
    ------
    ValidationError
        Naming the first negative entry or the first row whose sum is off, with the
        number of such entries, or the row whose sum makes the effective discount >= 1.
    """
    neg = p < -PROBABILITY_NEGATIVE_ATOL
    if where is not None:
        neg &= where[..., None]
    if neg.any():
        idx = tuple(int(i) for i in np.unravel_index(int(np.flatnonzero(neg)[0]), p.shape))
        raise ValidationError(
            f"{name}[{', '.join(map(str, idx))}] = {p[idx]} is negative "
            f"({int(neg.sum())} such entries)"
        )
    sums = p.sum(axis=-1)
    off = np.abs(sums - 1.0) > PROBABILITY_SUM_ATOL
    if where is not None:
        off &= where
    if off.any():
        if p.ndim == 1:
            raise ValidationError(
                f"{name} sum to {float(sums):.12g}, not 1 (tolerance {PROBABILITY_SUM_ATOL:g})"
            )
        idx = tuple(int(i) for i in np.unravel_index(int(np.flatnonzero(off)[0]), sums.shape))
        raise ValidationError(
            f"{name}[{', '.join(map(str, idx))}, :] sum to {float(sums[idx]):.12g}, not 1 "
            f"(tolerance {PROBABILITY_SUM_ATOL:g}; {int(off.sum())} such rows)"
        )
    _check_effective_discount(name, np.asarray(sums), int(p.shape[-1]), discount, where)


def _check_effective_discount(
    name: str, sums: np.ndarray, n_out: int, discount: float, where: np.ndarray | None
) -> None:
    """Refuse rows whose effective discount ``lambda * max row sum`` is not below 1.

    Rows summing to ``1 + 9e-10`` pass the sum tolerance; with a discount of
    ``1 - 1e-10`` their operator is not a contraction and no discounted value exists.
    The test is the certified one (:meth:`RowSums.modulus` ``< 1``), so every model that
    passes can be certified. ``sums`` are :func:`check_rows`' row sums (``where``: the
    rows that count).
    """
    if where is not None:
        sums = np.where(where, sums, 0.0)
    flat = int(np.argmax(sums))
    s_max = float(sums.reshape(-1)[flat])
    rs = RowSums(s_max, s_max, n_out)
    if rs.modulus(discount) < 1.0:
        return
    if sums.ndim == 0:
        row = name
    else:
        idx = np.unravel_index(flat, sums.shape)
        row = f"{name}[{', '.join(str(int(i)) for i in idx)}, :]"
    raise ValidationError(
        f"the effective discount is not below 1: discount {discount!r} times the sum "
        f"{s_max!r} of {row} is {float(discount) * s_max!r} (with the rounding allowance "
        f"{rs.rounding:.1e}, {rs.modulus(discount)!r}); no discounted value exists. "
        "Normalise the rows or lower the discount"
    )
