"""The operator a model is swept as: its Bellman rows, their post-decision form, and the
argument checks every solver of :mod:`lpbounds.dp` shares.

Fast path
---------
Value iteration, MPI, iterative policy evaluation and :func:`~lpbounds.dp.bellman_residual`
on a :class:`~lpbounds.model.mdp.FiniteMDP` first look for its post-decision form
(:class:`~lpbounds.rows.PostDecisionRows`, verified on every pair, cached on the MDP by
:func:`post_decision_rows`): where it exists (the patrol model) a sweep reads far less
memory and the exact rows are never built. Its arithmetic is that of the rows, so the
results are the same numbers; ``tests/dp/test_fast_paths.py`` checks that. Pass the rows
(``exact_rows(mdp)``) to force the plain path.

Every sweep runs C kernels built at install (:mod:`lpbounds._kernels.dispatch`), at every
size: a first solve in a fresh environment compiles nothing. Their numpy twins, with the
same arithmetic and the same numbers, are the tests' reference.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import ValidationError
from ..model.mdp import FiniteMDP
from ..rows import BellmanRows, PostDecisionRows, SweepOperator
from ..tolerances import dp_default_tol
from ..validation import MAX_VALUE_SCALE, check_real, check_vector

__all__ = [
    "Callback",
    "Model",
    "check_callback",
    "default_tol",
    "exact_rows",
    "initial_vector",
    "modulus",
    "post_decision_rows",
]

#: What every solver of :mod:`lpbounds.dp` takes: an MDP, or a row system (an MDP whose
#: actions at ``i`` are the rows of ``i``).
Model = FiniteMDP | BellmanRows
#: ``callback(iteration, residual)``, called after each improvement step.
Callback = Callable[[int, float], None]


def exact_rows(model: Model) -> BellmanRows:
    """The Bellman rows of ``model`` (cached on a FiniteMDP; the rows themselves otherwise)."""
    if isinstance(model, BellmanRows):
        return model
    if not isinstance(model, FiniteMDP):
        raise ValidationError(f"expected a FiniteMDP or BellmanRows; got {type(model).__name__}")
    cached = model.__dict__.get("_exact_rows")
    if cached is None:
        cached = BellmanRows.from_mdp(model)
        model.__dict__["_exact_rows"] = cached
    return cached


def post_decision_rows(model: Model) -> PostDecisionRows | None:
    """The verified post-decision form of an MDP (cached on it), or ``None``.

    ``None`` for row systems and for MDPs without the form (see
    :class:`~lpbounds.rows.PostDecisionRows`).
    """
    if not isinstance(model, FiniteMDP):
        return None
    cached = model.__dict__.get("_post_decision")
    if cached is None:
        cached = PostDecisionRows.detect(model) or False
        model.__dict__["_post_decision"] = cached
    return cached if isinstance(cached, PostDecisionRows) else None


def default_tol(rows: BellmanRows | PostDecisionRows, tol: float | None) -> float:
    """``tol`` checked, or :func:`lpbounds.tolerances.dp_default_tol` of the rows."""
    if tol is not None:
        return check_real("tol", tol, lo=0.0, lo_open=True)
    if isinstance(rows, PostDecisionRows):
        # disallowed rewards are stored as 0, so this is max|R| over the allowed pairs,
        # the same number as on the exact rows; the outcomes per pair are those per row
        rmax, n_out = rows.reward_absmax, int(rows.outcomes.shape[1])
    else:
        rmax, n_out = float(np.abs(rows.reward).max(initial=0.0)), rows.n_outcomes
    tol_ = dp_default_tol(rmax, rows.discount, n_out, row_delta=rows.row_sums().delta)
    if not np.isfinite(tol_):  # refused by FiniteMDP / from_arrays (MAX_VALUE_SCALE)
        raise ValidationError(f"the value scale max|R| / (1 - discount) of {rmax} overflows")
    return tol_


def initial_vector(initial: Any, n: int) -> np.ndarray:
    """The starting vector: zeros, or ``initial`` checked and copied (once): an array of
    its own, which the loops overwrite.

    Its entries must be finite and within ``MAX_VALUE_SCALE`` (the largest accepted
    ``|V*|``): a starting point beyond every possible value only risks overflow.
    """
    if initial is None:
        return np.zeros(n)
    v = check_vector("initial", initial, n)
    big = np.abs(v) > MAX_VALUE_SCALE
    if big.any():
        i = int(np.flatnonzero(big)[0])
        raise ValidationError(
            f"initial[{i}] = {v[i]:.3g} exceeds {MAX_VALUE_SCALE:g} in magnitude "
            "(no value function is that large: lpbounds.validation.MAX_VALUE_SCALE)"
        )
    # a fresh array owns its data; ``initial`` itself or a view of the caller's buffer is copied
    return v if v is not initial and v.flags.owndata else v.copy()


def check_callback(callback: Any) -> None:
    if callback is not None and not callable(callback):
        raise ValidationError(f"callback must be callable or None; got {callback!r}")


def modulus(ops: SweepOperator) -> float:
    """``lambda max_r sum_l p_{r,l}`` rounded up: the contraction modulus the error bounds use."""
    return ops.row_sums().modulus(ops.discount)
