r""":func:`solve_game`: the fixed point of the game operator ``G`` (Fact 2 of
:mod:`lpbounds.rows.system`), the least element of the disjunctive NLP's feasible set."""

from __future__ import annotations

import time
from typing import Any, Literal

from ..errors import ValidationError
from ..rows import BellmanRows
from ..validation import check_bool, check_choice, check_int
from .loop import mpi_loop
from .operators import Callback, check_callback, default_tol, initial_vector, modulus
from .rational import exact_callback, exact_result
from .results import DPResult

__all__ = ["solve_game"]


def solve_game(
    rows: BellmanRows,
    *,
    tol: float | None = None,
    max_iter: int = 100_000,
    initial: Any = None,
    callback: Callback | None = None,
    raise_on_failure: bool = True,
    arithmetic: Literal["float", "rational"] = "float",
    size_limit: int | None = None,
) -> DPResult:
    r"""Fixed point of ``(Gw)(i) = max_u min_{r in (i, u)} q_r(w)`` (Fact 2 of
    :mod:`lpbounds.rows.system`).

    The least element of the disjunctive NLP's feasible set (eq. 25) when ``rows`` are
    the NLP's terms (``BellmanRows.aggregate(mdp, partition, reduce="min")``): the value
    of the zero-sum game in which the controller picks the action and an adversary the
    state of the partition. Value iteration with the Porteus shift (valid for ``G``:
    monotone, and ``G(w + c) = Gw + lambda c``); stops when ``||Gw - w||_inf <= tol``.

    With ``arithmetic="rational"`` the float value iteration runs first and starts exact
    strategy iteration (:func:`lpbounds.exact.game_fixed_point`) on the rows as stored
    (each double taken exactly); the result is as :func:`~lpbounds.dp.solve_exact`'s with
    ``arithmetic="rational"`` (``rational_values``, exact ``error_bound``), ``size_limit``
    the most variables solved together.

    Returns
    -------
    DPResult
        ``policy``/``policy_rows``: the minimising row of the first maximising action.
    """
    t0 = time.perf_counter()
    if not isinstance(rows, BellmanRows):
        raise ValidationError(f"rows must be a BellmanRows system; got {type(rows).__name__}")
    check_choice("arithmetic", arithmetic, ("float", "rational"))
    if arithmetic == "rational":
        return _solve_game_rational(rows, callback, size_limit, t0, tol=tol, max_iter=max_iter,
                                    initial=initial, raise_on_failure=raise_on_failure)  # fmt: skip
    tol_ = default_tol(rows, tol)
    max_iter = check_int("max_iter", max_iter, lo=1)
    raise_on_failure = check_bool("raise_on_failure", raise_on_failure)
    check_callback(callback)
    v = initial_vector(initial, rows.n_vars)
    run = mpi_loop(rows, v, tol_, max_iter, 0, True, callback, game=True)
    return run.finish("game-vi", run.arg, run.arg, tol_, modulus(rows), t0, raise_on_failure)


def _solve_game_rational(
    rows: BellmanRows, callback: Callback | None, size_limit: int | None, t0: float,
    **float_options: Any,
) -> DPResult:  # fmt: skip
    """``solve_game(..., arithmetic="rational")``: the float solve, then exact strategy
    iteration on the rows as stored (their groups: the rows' (owner, action))."""
    from ..exact.files import rows_data
    from ..exact.fixed_point import game_fixed_point
    from ..exact.system import ExactRows

    check_callback(callback)
    fl = solve_game(rows, **float_options)
    er = ExactRows.build(rows_data(rows), {"rows": "ROWS"})
    fp = game_fixed_point(
        er,
        fl.values,
        callback=exact_callback(callback),
        size_limit=size_limit,
        what="the game's variables",
    )
    return exact_result(rows, fp, fl, t0, "game-vi+exact-strategy-iteration")
