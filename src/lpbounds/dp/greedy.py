"""Greedy policies, the Bellman residual, and policies as arguments and as answers.

A policy is given and returned as actions per state for a
:class:`~lpbounds.model.mdp.FiniteMDP` and as rows per owner for a
:class:`~lpbounds.rows.BellmanRows` system (:func:`policy_out`, :func:`rows_of_policy`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ValidationError
from ..model.mdp import FiniteMDP
from ..rows import BellmanRows
from ..tolerances import GREEDY_TIE_RTOL
from ..validation import check_array, check_real, check_vector
from .operators import Model, exact_rows, post_decision_rows

__all__ = [
    "bellman_residual",
    "check_policy",
    "greedy_policy",
    "greedy_rows",
    "policy_out",
    "rows_of_policy",
]


def policy_out(model: Model, rows: BellmanRows, policy_rows: np.ndarray) -> np.ndarray:
    """Actions per state for an MDP, row indices for a row system."""
    if isinstance(model, FiniteMDP):
        return rows.action[policy_rows].astype(np.int64)
    return policy_rows


def check_policy(policy: Any, n: int, mdp: FiniteMDP | None = None) -> np.ndarray:
    """A policy as an integer array of length ``n``; for an MDP, an allowed action per state.

    Ranges are checked in the given dtype, before any narrowing cast.
    """
    pol = check_array("policy", policy, integer=True)
    if pol.shape != (n,) or pol.dtype.kind not in "iu":
        raise ValidationError(f"a policy must be {n} integers; got {pol.shape} {pol.dtype}")
    if mdp is not None:
        bad = (pol < 0) | (pol >= mdp.n_actions)
        if bad.any():
            x = int(np.flatnonzero(bad)[0])
            raise ValidationError(f"policy[{x}] = {int(pol[x])} is not an action index")
        ok = mdp.allowed[np.arange(n), pol]
        if not ok.all():
            x = int(np.flatnonzero(~ok)[0])
            raise ValidationError(f"policy[{x}] = {int(pol[x])} is not allowed in state {x}")
    return pol


def rows_of_policy(model: Model, rows: BellmanRows, policy: Any) -> np.ndarray:
    if isinstance(model, FiniteMDP):
        pol = check_policy(policy, rows.n_vars, model)
        assert rows.pair_row is not None
        return rows.pair_row[np.arange(rows.n_vars), pol]
    pol = check_policy(policy, rows.n_vars)
    bad = (pol < rows.indptr[:-1]) | (pol >= rows.indptr[1:])
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValidationError(f"policy[{i}] = {int(pol[i])} is not a row of owner {i}")
    return pol.astype(np.int64)


def greedy_rows(
    rows: BellmanRows, v: np.ndarray, tie_rtol: float, prefer: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Greedy rows w.r.t. ``v`` (ties: ``prefer`` if tied, else the lowest action) and ``T v``."""
    q = rows.q_values(v)
    best = np.maximum.reduceat(q, rows.indptr[:-1])
    thr = best - tie_rtol * np.maximum(1.0, np.abs(best))
    cand = q >= thr[rows.owner]
    idx = np.flatnonzero(cand)
    _, first = np.unique(rows.owner[idx], return_index=True)
    sel = idx[first]
    if prefer is not None:
        keep = cand[prefer]
        sel = np.where(keep, prefer, sel)
    return sel.astype(np.int64), best


def greedy_policy(model: Model, values: Any, tie_rtol: float = GREEDY_TIE_RTOL) -> np.ndarray:
    """A policy greedy w.r.t. ``values`` (paper Sec. 3.3 and eq. 30).

    Tie rule: every action whose Q-value is within
    ``tie_rtol * max(1, |max_u Q(x, u)|)`` of the maximum counts as tied, and the
    lowest action index among them is chosen (for a row system: the first row).

    Raises
    ------
    ValidationError
        If ``values`` has the wrong length or a NaN/inf entry (a NaN Q-value is never
        a maximum: the policy would silently miss states), or ``tie_rtol`` is not a
        finite number ``>= 0``.
    """
    rows = exact_rows(model)
    tie_rtol = check_real("tie_rtol", tie_rtol, lo=0.0)
    sel, _ = greedy_rows(rows, check_vector("values", values, rows.n_vars), tie_rtol)
    return policy_out(model, rows, sel)


def bellman_residual(model: Model, values: Any) -> float:
    """``||T V - V||_inf`` (``values`` must be finite: a NaN would be skipped by the max)."""
    ps = post_decision_rows(model)
    if ps is not None:
        v = check_vector("values", values, ps.n_vars)
        lo, hi = ps.sweep_max(v, ps.new_vector(), ps.new_arg())
        return max(-lo, hi)
    rows = exact_rows(model)
    v = check_vector("values", values, rows.n_vars)
    tv, _ = rows.apply_max(v)
    return float(np.abs(tv - v).max())
