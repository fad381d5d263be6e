r""":func:`solve_exact`: Bellman's equation (eq. 3) solved to a stated residual, or exactly.

It takes either a :class:`~lpbounds.model.mdp.FiniteMDP` or a
:class:`~lpbounds.rows.BellmanRows` system (an MDP whose actions at ``i`` are the rows
of ``i``), so the same code computes ``V*`` and the exact, solver-free counterparts of
the LPs (RLP's least feasible point is the fixed point of its rows, Fact 1 in
:mod:`lpbounds.rows.system`). The methods: the MPI loop (:mod:`lpbounds.dp.loop`; value
iteration is its case without evaluation sweeps), policy iteration and inexact policy
iteration (:mod:`lpbounds.dp.policy_iteration`), and ``arithmetic="rational"``
(:mod:`lpbounds.dp.rational`).

Stopping rule and error bound
-----------------------------
The solvers stop when the Bellman residual of the vector they return,
``||T V - V||_inf``, is at most ``tol`` (default ``DP_RTOL * max|R|``, at least a rounding
floor: :func:`lpbounds.tolerances.dp_default_tol`), and report that residual, measured
on the returned vector. It implies

* ``||V - V*||_inf <= residual / (1 - kappa)`` (reported as ``error_bound``), and
* ``||T V - V*||_inf <= kappa / (1 - kappa) * residual`` for one more application of T,

where ``kappa = lambda max_r sum_l p_{r,l}`` (rounded up, :func:`~lpbounds.dp.modulus`) is
the contraction modulus of the rows *as stored*: ``lambda`` itself when every row sums to
one, larger for accepted rows summing to ``1 + 1e-9`` (``docs/tolerances.md``, "Row sums").
"""

from __future__ import annotations

import time
from typing import Any, Literal

import numpy as np

from ..errors import ValidationError
from ..rows import PostDecisionRows
from ..validation import check_bool, check_choice, check_int
from .greedy import policy_out
from .loop import check_eval_sweeps, mpi_loop
from .operators import (
    Callback,
    Model,
    check_callback,
    default_tol,
    exact_rows,
    initial_vector,
    modulus,
    post_decision_rows,
)
from .policy_iteration import inexact_pi, policy_iteration
from .rational import exact_callback, exact_model, exact_result
from .results import DPResult

__all__ = ["Method", "solve_exact"]

#: The methods of :func:`solve_exact`.
Method = Literal["mpi", "vi", "pi", "ipi"]


# ---------------------------------------------------------------------- solvers
def solve_exact(
    model: Model,
    method: Method = "mpi",
    *,
    tol: float | None = None,
    max_iter: int = 100_000,
    eval_sweeps: int | Literal["auto"] = "auto",
    extrapolate: bool = True,
    initial: Any = None,
    evaluation: Literal["auto", "direct", "iterative"] = "auto",
    callback: Callback | None = None,
    raise_on_failure: bool = True,
    arithmetic: Literal["float", "rational"] = "float",
    size_limit: int | None = None,
) -> DPResult:
    """Solve Bellman's equation (eq. 3) to a stated residual, or exactly.

    Parameters
    ----------
    model : FiniteMDP or BellmanRows
    method : {"mpi", "vi", "pi", "ipi"}
        Modified policy iteration (default: evaluation sweeps of the greedy policy
        after each improvement, see ``eval_sweeps``), value iteration, policy iteration
        (exact evaluation, see ``evaluation``; a policy is kept while it is tied
        within :data:`~lpbounds.tolerances.GREEDY_TIE_RTOL`), or inexact policy
        iteration (each greedy policy evaluated by GMRES to a fraction of the Bellman
        residual: see :mod:`lpbounds.dp.policy_iteration`; it is never
        chosen for you: MPI was faster on every large model measured).
    tol : float, optional
        Stop when ``||T V - V||_inf <= tol``; default ``1e-11 * max|R|``
        (:func:`lpbounds.tolerances.dp_default_tol`: ``DP_RTOL * max|R|``, never below
        the residual's rounding floors), so that the certified ``error_bound`` is about
        ``1e-11`` of the value scale ``max|R| / (1 - lambda)`` up to discount 0.99 (above,
        the floor of a periodic chain binds: about 4.4e-10 of it at 0.999).
    max_iter : int
        Limit on improvement steps.
    eval_sweeps : int or "auto"
        Evaluation sweeps per improvement step of MPI: a number (every step), or
        ``"auto"`` (default): :data:`~lpbounds.dp.AUTO_EVAL_SWEEPS` once the policy has
        settled, none while it changes (see "Evaluation sweeps of MPI" in
        :mod:`lpbounds.dp.loop`; the answer's certificate is the same either way).
    extrapolate : bool
        Use the Porteus/MacQueen constant shift (:mod:`lpbounds.dp.loop`).
    initial : array_like, optional
        Starting vector (default 0).
    evaluation : {"auto", "direct", "iterative"}
        Policy iteration's evaluation: sparse LU, sweeps, or LU up to 200,000 states
        (LU fills in on a random transition graph: see :func:`~lpbounds.dp.evaluate_policy`).
    callback : callable(iteration, residual), optional
        Called after each improvement step (progress bars).
    raise_on_failure : bool
        Raise :class:`~lpbounds.errors.ConvergenceError` at ``max_iter`` (default);
        otherwise return with ``status=Status.ITERATION_LIMIT`` (``converged=False``).
    arithmetic : {"float", "rational"}
        ``"rational"``: the stored model's exact ``V*`` (every double taken as the exact
        rational it is). The float solve runs first, as with ``"float"``, and its greedy
        policy starts exact policy iteration (:func:`lpbounds.exact.least_fixed_point`:
        rational evaluations, improvements checked exactly, verified by the certificate
        checker). The result's ``rational_values`` hold ``V*``, ``values`` its nearest
        doubles, ``error_bound`` their exact distance rounded up, ``residual`` the float
        residual of ``values``, ``policy`` an exactly optimal policy, ``iterations`` the
        exact evaluations; ``callback(iteration, residual)`` is called after each exact
        improvement check with its exact residual (0 at the end). The float path is
        unchanged by this option.
    size_limit : int, optional
        ``arithmetic="rational"``: the most states solved together (default
        :data:`~lpbounds.tolerances.EXACT_MAX_VARIABLES`): the largest strongly connected
        component of the float solve's policy, checked before any exact work (a model
        whose policy graph is a chain of small components passes at any size).

    Returns
    -------
    DPResult

    Raises
    ------
    ValidationError
        For a bad argument (checked once, before the first sweep): ``tol`` not a
        positive finite number, ``initial`` of the wrong length or with a NaN/inf
        entry, a non-integer ``max_iter``, an ``eval_sweeps`` neither a non-negative
        integer nor ``"auto"``, an unknown method or arithmetic.
    SizeLimitError
        ``arithmetic="rational"``: a policy component of more than ``size_limit`` states
        (after the float solve, before any exact work).
    ConvergenceError
        At ``max_iter`` with ``raise_on_failure``; or if the iterates overflow.
    """
    t0 = time.perf_counter()
    check_choice("arithmetic", arithmetic, ("float", "rational"))
    if arithmetic == "rational":
        return _solve_rational(
            model, callback, size_limit, t0, method, tol=tol, max_iter=max_iter,
            eval_sweeps=eval_sweeps, extrapolate=extrapolate, initial=initial,
            evaluation=evaluation, raise_on_failure=raise_on_failure,
        )  # fmt: skip
    if method not in ("mpi", "vi", "pi", "ipi"):
        raise ValidationError(f"unknown method {method!r}; use 'mpi', 'vi', 'pi' or 'ipi'")
    max_iter = check_int("max_iter", max_iter, lo=1)
    eval_sweeps = check_eval_sweeps(eval_sweeps)
    extrapolate = check_bool("extrapolate", extrapolate)
    raise_on_failure = check_bool("raise_on_failure", raise_on_failure)
    check_choice("evaluation", evaluation, ("auto", "direct", "iterative"))
    check_callback(callback)
    fast = post_decision_rows(model) if method != "pi" else None
    if fast is not None:
        return _solve_post_decision(
            model,
            fast,
            method,
            tol,
            max_iter,
            eval_sweeps,
            extrapolate,
            initial,
            callback,
            raise_on_failure,
            t0,
        )
    rows = exact_rows(model)
    tol_ = default_tol(rows, tol)
    v = initial_vector(initial, rows.n_vars)
    if method == "pi":
        run = policy_iteration(model, rows, v, tol_, max_iter, evaluation, callback)
    elif method == "ipi":
        run = inexact_pi(rows, v, tol_, max_iter, callback)
    else:
        m = eval_sweeps if method == "mpi" else 0
        run = mpi_loop(rows, v, tol_, max_iter, m, extrapolate, callback)
    return run.finish(
        method, policy_out(model, rows, run.arg), run.arg, tol_, modulus(rows), t0,
        raise_on_failure,
    )  # fmt: skip


def _solve_rational(
    model: Model,
    callback: Callback | None,
    size_limit: int | None,
    t0: float,
    method: Method,
    **float_options: Any,
) -> DPResult:
    """``solve_exact(..., arithmetic="rational")``: the float solve, then exact PI."""
    from ..exact.fixed_point import least_fixed_point
    from ..exact.system import ExactRows

    check_callback(callback)
    data, spec, what = exact_model(model)
    fl = solve_exact(model, method, **float_options)
    rows = ExactRows.build(data, spec)
    fp = least_fixed_point(rows, fl.policy_rows, callback=exact_callback(callback),
                           size_limit=size_limit, what=what)  # fmt: skip
    return exact_result(model, fp, fl, t0, f"{fl.method}+exact-pi")


def _solve_post_decision(
    model: Model,
    ps: PostDecisionRows,
    method: str,
    tol: float | None,
    max_iter: int,
    eval_sweeps: int | Literal["auto"],
    extrapolate: bool,
    initial: Any,
    callback: Callback | None,
    raise_on_failure: bool,
    t0: float,
) -> DPResult:
    """:func:`solve_exact` (VI/MPI/IPI) on the post-decision form; same iteration, same numbers."""
    tol_ = default_tol(ps, tol)
    v = initial_vector(initial, ps.n_vars)
    m = eval_sweeps if method == "mpi" else 0
    if method == "ipi":
        run = inexact_pi(ps, v, tol_, max_iter, callback)
    else:
        run = mpi_loop(ps, v, tol_, max_iter, m, extrapolate, callback)
    act = run.arg
    return run.finish(
        method, act.astype(np.int64), ps.rows_of(act), tol_, modulus(ps), t0, raise_on_failure
    )
