"""The bridge from the float solvers to :mod:`lpbounds.exact` (``arithmetic="rational"``):
the model's certificate data, the exact engine's progress as a callback, and the
:class:`~lpbounds.dp.DPResult` of an exact fixed point."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ValidationError
from ..model.mdp import FiniteMDP
from ..rows import BellmanRows
from ..status import Status
from .greedy import policy_out
from .operators import Callback, Model, exact_rows
from .results import DPResult

if TYPE_CHECKING:  # annotations only: python-flint loads when exact arithmetic is asked for
    from ..exact.fixed_point import ExactFixedPoint

__all__ = ["exact_callback", "exact_model", "exact_result"]


def exact_model(model: Model) -> tuple[dict[str, Any], dict[str, Any], str]:
    """The certificate model data, the rows' spec and their name (for the size error)."""
    from ..exact.files import mdp_data, rows_data

    if isinstance(model, FiniteMDP):
        return mdp_data(model), {"rows": "ELP"}, "the MDP's states"
    if isinstance(model, BellmanRows):
        return rows_data(model), {"rows": "ROWS"}, "the row system's variables"
    raise ValidationError(f"expected a FiniteMDP or BellmanRows; got {type(model).__name__}")


def exact_result(
    model: Model, fp: ExactFixedPoint, fl: DPResult, t0: float, method: str
) -> DPResult:
    """The DPResult of an exact fixed point: ``values`` its nearest doubles, ``error_bound``
    their exact distance from it rounded up, ``residual`` the float residual of ``values``
    (of ``T``, or of the game's ``G`` when ``fp.game``)."""
    values = fp.values.to_floats()
    err = float(fp.values.max_abs_error(values))  # rounded to nearest: one step up covers it
    rows = exact_rows(model)
    tv, _ = rows.apply_maxmin(values) if fp.game else rows.apply_max(values)
    return DPResult(
        values=values,
        policy=fp.policy if fp.game else policy_out(model, rows, fp.policy),
        policy_rows=fp.policy,
        residual=float(np.abs(tv - values).max(initial=0.0)),
        error_bound=float(np.nextafter(err, np.inf)) if err > 0 else 0.0,
        tol=fl.tol,
        iterations=fp.iterations,
        sweeps=fl.sweeps,
        seconds=time.perf_counter() - t0,
        method=method,
        status=Status.OPTIMAL,
        history=list(fp.history),
        rational_values=fp.values,
        arithmetic="rational",
    )


def exact_callback(callback: Callback | None) -> Callable[[Any], None] | None:
    """The exact engine's progress events as ``callback(iteration, residual)`` calls (one
    per exact improvement check)."""
    if callback is None:
        return None

    def relay(event: Any) -> None:
        if event.stage == "improve":
            callback(event.iteration, event.residual)

    return relay
