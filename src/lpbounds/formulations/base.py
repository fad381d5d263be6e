r"""The base of every LP formulation: data ``min c'x s.t. A x >= b`` -> cvxpy -> result.

Following cvxpy's split of building data, calling the solver and mapping the result
back, a :class:`Formulation` is built from sparse data ``(A, b, c)`` (one vector
constraint ``A @ x >= b``, never one Python constraint per row), exposes the cvxpy
problem as :attr:`Formulation.problem`, and :meth:`Formulation.solve` returns an
:class:`LPResult` whose every number lpbounds checks itself:

* ``primal_residual = max_r (b - A x)_r^+`` on the returned ``x`` (not the solver's
  claim); the solve fails unless it is at most ``residual_rtol * max(1, ||b||_inf)``;
* ``dual_residual = ||A' y - c||_inf`` and ``gap = |c'x - b'y|`` for the returned
  duals ``y >= 0`` (cvxpy's sign convention for ``>=`` rows), reported beside it.

Sign conventions: ``y_r >= 0`` is the multiplier of row ``r`` of ``A x >= b``; at an
optimum ``A' y = c`` (stationarity), ``y' (A x - b) = 0`` (complementarity). For Bellman
rows, the duals spread over (state, action) pairs are the paper's ``mu_u^i(x)``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..errors import SolverError, SolverNotInstalledError, ValidationError
from ..tolerances import LP_RESIDUAL_RTOL

__all__ = [
    "Formulation",
    "LPResult",
    "Status",
    "aggregated_cost",
    "check_cost",
    "installed_lp_solvers",
    "resolve_solver",
]


class Status(str, Enum):
    """Outcome of a solve, as lpbounds judges it."""

    OPTIMAL = "optimal"
    INACCURATE = "optimal_inaccurate"
    INFEASIBLE = "infeasible"
    UNBOUNDED = "unbounded"
    RESIDUAL_TOO_LARGE = "residual_too_large"
    SOLVER_ERROR = "solver_error"

    def __str__(self) -> str:
        return self.value


#: Install command of each solver lpbounds knows how to name.
INSTALL_HINTS: dict[str, str] = {
    "HIGHS": "pip install highspy",
    "CLARABEL": "pip install clarabel",
    "SCIPY": "pip install scipy",
    "GLPK": "pip install cvxopt",
    "GLPK_MI": "pip install cvxopt",
    "CVXOPT": "pip install cvxopt",
    "ECOS": "pip install ecos",
    "SCS": "pip install scs",
    "OSQP": "pip install osqp",
    "PDLP": "pip install ortools",
    "GLOP": "pip install ortools",
    "CBC": "pip install cylp",
    "GUROBI": "pip install gurobipy (and a licence)",
    "MOSEK": "pip install mosek (and a licence)",
    "COPT": "pip install coptpy",
    "XPRESS": "pip install xpress",
    "CPLEX": "pip install cplex",
    "PIQP": "pip install piqp",
    "QOCO": "pip install qoco",
    "CUOPT": "pip install cuopt",
}

#: cvxpy solvers that accept an LP (quadratic-only or conic-only names excluded).
LP_CAPABLE: tuple[str, ...] = (
    "HIGHS",
    "CLARABEL",
    "SCIPY",
    "GLPK",
    "CVXOPT",
    "ECOS",
    "SCS",
    "OSQP",
    "PDLP",
    "GLOP",
    "CBC",
    "GUROBI",
    "MOSEK",
    "COPT",
    "XPRESS",
    "CPLEX",
    "PIQP",
    "QOCO",
)


def installed_lp_solvers() -> list[str]:
    """The LP-capable cvxpy solvers installed here, HiGHS and Clarabel first."""
    have = set(cp.installed_solvers())
    return [s for s in LP_CAPABLE if s in have]


def resolve_solver(name: str) -> str:
    """Canonical cvxpy name of ``name`` (case-insensitive), or a clear error.

    Raises
    ------
    SolverNotInstalledError
        Naming the install command when the solver is known but missing, or the
        installed solvers when the name is unknown.
    """
    if not isinstance(name, str) or not name:
        raise ValidationError(f"solver must be a name such as 'HIGHS'; got {name!r}")
    key = name.upper()
    if key in cp.installed_solvers():
        return key
    if key in INSTALL_HINTS:
        raise SolverNotInstalledError(
            f"solver {key} is not installed; install it with: {INSTALL_HINTS[key]}"
        )
    raise SolverNotInstalledError(
        f"unknown solver {name!r}; installed LP solvers: {', '.join(installed_lp_solvers())}"
    )


def aggregated_cost(mdp: Any, partition: Any, cost: Any, partition_cost: Any) -> np.ndarray:
    """``c-bar(i) = sum_{x in S_i} c(x)`` from a per-state ``cost``, or ``partition_cost`` as given.

    The objective of every formulation over partitions (RLP eq. 9, SLP eq. 12, NLP eq. 24):
    validated, with the partition checked against the MDP.
    """
    if partition.n_states != mdp.n_states:
        raise ValidationError(
            f"the partition has {partition.n_states} states but the MDP has {mdp.n_states}"
        )
    if cost is not None and partition_cost is not None:
        raise ValidationError("give cost (per state) or partition_cost (per partition), not both")
    if partition_cost is not None:
        return check_cost(partition_cost, partition.n_partitions, "partition_cost")
    c = check_cost(cost, mdp.n_states)
    return np.bincount(partition.labels, weights=c, minlength=partition.n_partitions)


def check_cost(cost: Any, n: int, what: str = "cost") -> np.ndarray:
    """A validated non-negative cost vector of length ``n`` (default: all ones)."""
    if cost is None:
        return np.ones(n)
    c = np.asarray(cost, dtype=np.float64)
    if c.shape != (n,):
        raise ValidationError(f"{what} must have length {n}; got shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValidationError(f"{what} must be finite")
    if (c < 0).any():
        i = int(np.flatnonzero(c < 0)[0])
        raise ValidationError(f"{what}[{i}] = {c[i]} is negative; costs must be >= 0")
    return c


@dataclass
class LPResult:
    """The result of solving a formulation (one type for every formulation).

    Attributes
    ----------
    formulation : str
        "ELP", "RLP", "SLP", "IB", "LLP", "ALP", "UBLP", "LBLP", ...
    status : Status
    objective : float
        ``c'x`` at the returned point (computed by lpbounds).
    x : ndarray
        The full primal vector of the LP.
    values : ndarray
        The value variables: per state for ELP, per partition for RLP/SLP/UBLP/LBLP,
        ``v_1`` for IB (all blocks in ``blocks``), the weights ``r`` for ALP.
    state_values : ndarray or None
        ``Phi v`` per state, where the formulation has a state space.
    duals : ndarray
        ``y >= 0``, one per row of ``A x >= b``.
    mu : ndarray or None
        Duals spread over (state, action) pairs (shape (n, A)): the paper's ``mu``.
    solver : str
    solver_options : dict
    compile_seconds, solve_seconds : float
        cvxpy's compilation time and the solver's own time.
    iterations : int or None
    primal_residual : float
        ``max (b - A x)^+``, computed here.
    residual_tol : float
        The tolerance ``primal_residual`` was checked against (absolute).
    dual_residual : float
        ``||A'y - c||_inf``.
    gap : float
        ``|c'x - b'y|``.
    extra : dict
        Formulation-specific data (e.g. IB's blocks).
    """

    formulation: str
    status: Status
    objective: float
    x: np.ndarray
    values: np.ndarray
    state_values: np.ndarray | None
    duals: np.ndarray
    mu: np.ndarray | None
    solver: str
    solver_options: dict[str, Any]
    compile_seconds: float
    solve_seconds: float
    iterations: int | None
    primal_residual: float
    residual_tol: float
    dual_residual: float
    gap: float
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when the status is OPTIMAL (residual within tolerance)."""
        return self.status is Status.OPTIMAL


_STATUS = {
    cp.OPTIMAL: Status.OPTIMAL,
    cp.OPTIMAL_INACCURATE: Status.INACCURATE,
    cp.INFEASIBLE: Status.INFEASIBLE,
    cp.INFEASIBLE_INACCURATE: Status.INFEASIBLE,
    cp.UNBOUNDED: Status.UNBOUNDED,
    cp.UNBOUNDED_INACCURATE: Status.UNBOUNDED,
}


class Formulation:
    r"""``min c'x  s.t.  A x >= b`` as a cvxpy problem, with honest result checks.

    Subclasses compute ``(A, b, c)`` from the model and override :meth:`_interpret`
    to map ``x`` and the duals back to values, state values and ``mu``.

    Parameters
    ----------
    A : scipy.sparse matrix (R, N)
    b : ndarray (R,)
    c : ndarray (N,)
    name : str
        The paper's name of the formulation.
    """

    name: str = "LP"

    def __init__(self, A: sp.spmatrix, b: np.ndarray, c: np.ndarray, name: str | None = None):
        if name is not None:
            self.name = name
        self.A = sp.csr_matrix(A)
        self.b = np.asarray(b, dtype=np.float64)
        self.c = np.asarray(c, dtype=np.float64)
        n_rows, n_cols = self.A.shape
        if self.b.shape != (n_rows,) or self.c.shape != (n_cols,):
            raise ValidationError(
                f"{self.name}: A is {self.A.shape}, b {self.b.shape}, c {self.c.shape}"
            )
        self.variable = cp.Variable(n_cols, name="x")
        self.constraint = self.A @ self.variable >= self.b
        self.problem = cp.Problem(cp.Minimize(self.c @ self.variable), [self.constraint])

    # ------------------------------------------------------------------ interface
    def _interpret(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
        """``(values, state_values, mu, extra)`` from the primal ``x`` and duals ``y``."""
        return x, None, None, {}

    def solve(
        self,
        solver: str = "HIGHS",
        *,
        residual_rtol: float = LP_RESIDUAL_RTOL,
        raise_on_failure: bool = True,
        verbose: bool = False,
        **solver_options: Any,
    ) -> LPResult:
        """Solve with ``solver`` (any installed cvxpy LP solver) and check the result.

        Parameters
        ----------
        solver : str
            "HIGHS" (default), "CLARABEL", "SCIPY", "GLPK", "ECOS", "SCS", ...
        residual_rtol : float
            The primal residual must be at most ``residual_rtol * max(1, ||b||_inf)``.
        raise_on_failure : bool
            Raise :class:`~lpbounds.errors.SolverError` unless the result is OPTIMAL
            (default); otherwise return it with its status.
        verbose : bool
            Print the solver's log.
        **solver_options
            Passed to the solver through cvxpy. HiGHS' own ``solver`` option clashes
            with this method's ``solver`` argument, so HiGHS options go in a dict:
            ``highs_options={"solver": "ipm", "run_crossover": "on"}`` for its interior
            point method with crossover (faster than its simplex on large RLPs).

        Returns
        -------
        LPResult
        """
        name = resolve_solver(solver)
        t0 = time.perf_counter()
        try:
            self.problem.solve(solver=name, verbose=verbose, **solver_options)
        except cp.SolverError as exc:
            return self._failed(
                name, solver_options, Status.SOLVER_ERROR, str(exc), t0, raise_on_failure
            )
        except (ValueError, TypeError) as exc:
            raise SolverError(f"{self.name} with {name}: bad solver option: {exc}") from exc
        status = _STATUS.get(self.problem.status, Status.SOLVER_ERROR)
        x = self.variable.value
        y = self.constraint.dual_value
        if x is None or status in (Status.INFEASIBLE, Status.UNBOUNDED, Status.SOLVER_ERROR):
            return self._failed(
                name, solver_options, status, str(self.problem.status), t0, raise_on_failure
            )
        x = np.asarray(x, dtype=np.float64).ravel()
        y = (
            np.zeros(self.A.shape[0])
            if y is None
            else np.maximum(np.asarray(y, dtype=np.float64).ravel(), 0.0)
        )
        ax = self.A @ x
        primal = float(max(0.0, (self.b - ax).max(initial=0.0)))
        tol = residual_rtol * max(1.0, float(np.abs(self.b).max(initial=0.0)))
        dual_res = float(np.abs(self.A.T @ y - self.c).max(initial=0.0))
        obj = float(self.c @ x)
        gap = abs(obj - float(self.b @ y))
        if status is Status.OPTIMAL and primal > tol:
            status = Status.RESIDUAL_TOO_LARGE
        stats = self.problem.solver_stats
        compile_s = float(getattr(self.problem, "compilation_time", None) or 0.0)
        solve_s = float(stats.solve_time) if stats and stats.solve_time else 0.0
        values, state_values, mu, extra = self._interpret(x, y)
        result = LPResult(
            formulation=self.name,
            status=status,
            objective=obj,
            x=x,
            values=values,
            state_values=state_values,
            duals=y,
            mu=mu,
            solver=name,
            solver_options=dict(solver_options),
            compile_seconds=compile_s,
            solve_seconds=solve_s if solve_s else time.perf_counter() - t0 - compile_s,
            iterations=(int(stats.num_iters) if stats and stats.num_iters is not None else None),
            primal_residual=primal,
            residual_tol=tol,
            dual_residual=dual_res,
            gap=gap,
            extra=extra,
        )
        if raise_on_failure and status is not Status.OPTIMAL:
            raise SolverError(
                f"{self.name} with {name}: status {status.value}; primal residual "
                f"{primal:.3e} (tolerance {tol:.3e}), dual residual {dual_res:.3e}, gap {gap:.3e}"
            )
        return result

    def _failed(
        self,
        solver: str,
        options: dict[str, Any],
        status: Status,
        message: str,
        t0: float,
        raise_on_failure: bool,
    ) -> LPResult:
        if raise_on_failure:
            raise SolverError(f"{self.name} with {solver}: {status.value} ({message})")
        n_rows, n_cols = self.A.shape
        nan = np.full(n_cols, np.nan)
        return LPResult(
            formulation=self.name,
            status=status,
            objective=float("nan"),
            x=nan,
            values=nan,
            state_values=None,
            duals=np.full(n_rows, np.nan),
            mu=None,
            solver=solver,
            solver_options=dict(options),
            compile_seconds=0.0,
            solve_seconds=time.perf_counter() - t0,
            iterations=None,
            primal_residual=float("nan"),
            residual_tol=float("nan"),
            dual_residual=float("nan"),
            gap=float("nan"),
            extra={"message": message},
        )

    def __repr__(self) -> str:
        return f"{type(self).__name__}(rows={self.A.shape[0]}, variables={self.A.shape[1]})"
