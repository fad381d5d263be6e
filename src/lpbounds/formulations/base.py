r"""The base of every LP formulation: data ``min c'x s.t. A x >= b`` -> cvxpy -> certified result.

Following cvxpy's split of building data, calling the solver and mapping the result
back, a :class:`Formulation` is built from sparse data ``(A, b, c)`` and exposes it as
the cvxpy problem :attr:`Formulation.problem`, written in the paper's symbols: one named
``cp.Variable`` per symbol (``v``, ``V``, ``v_1..v_L``, ``z``, ``r``, ``w``: the columns of
``A`` split into :attr:`Formulation.variables`) and one named constraint group per
equation (``bellman`` for eq. 9, ...: the rows of ``A`` split into
:attr:`Formulation.constraints`), each group ONE sparse vector constraint (never one
Python object per row). ``A``, ``b``, ``c`` stay available as the stacked data; ``x`` and
the duals ``y`` of a result are the variables and the groups' duals stacked in that
order. :meth:`Formulation.solve` returns an :class:`LPResult` whose every number lpbounds
computes itself from the returned point:

* the **certificate** (:mod:`lpbounds.certification.certificate`): for an LP of Bellman rows (ELP,
  RLP, SLP, IB, UBLP, LBLP) a bracket ``lower_values <= exact optimum <= upper_values``
  that holds in floating point, whatever the solver claimed, and the bracket on the
  exact optimal objective; the **status** is decided from it
  (:class:`~lpbounds.status.Status`: OPTIMAL when the certified error is within
  ``accuracy`` relative to ``max|R| / (1 - lambda)``, INACCURATE with its still valid
  bracket otherwise);
* ``primal_residual = max_r (b - A x)_r^+``, ``dual_residual = ||A' y - c||_inf`` and
  ``gap = |c'x - b'y|`` for the returned duals ``y >= 0`` (cvxpy's sign convention for
  ``>=`` rows), reported beside it.

Nor is "infeasible" or "unbounded" taken from the solver where the structure excludes it:
each formulation says, as class data, whether it is feasible and bounded by construction
(:attr:`Formulation.feasible_by_construction`, :attr:`Formulation.bounded_by_construction`,
with the reason); such a claim is the solver's failure (SOLVER_ERROR, or the returned
point judged by its certificate), noted in ``extra["solver_claim"]`` and
``extra["message"]``. An LP of a discounted MDP whose rewards or cost lie outside
:data:`~lpbounds.tolerances.LP_DATA_BAND` is scaled by powers of two before the solver sees
it, and its point and duals scaled back exactly (:meth:`Formulation.solve`, "Scaling").

Sign conventions: ``y_r >= 0`` is the multiplier of row ``r`` of ``A x >= b``; at an
optimum ``A' y = c`` (stationarity), ``y' (A x - b) = 0`` (complementarity). For Bellman
rows, the duals spread over (state, action) pairs are the paper's ``mu_u^i(x)``.

A user's own constraints on the named variables go through ``solve(extra_constraints=[...])``
(research modifications, docs/research.md): the same checks, with the certificate reported
only where it still applies (see :meth:`Formulation.solve`).
"""

from __future__ import annotations

import copy
import time
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..certification.certificate import Certificate, contraction_modulus, dual_objective_bound
from ..errors import SolverError, SolverNotInstalledError, ValidationError
from ..status import Status
from ..tolerances import LP_CERT_RTOL, LP_DATA_BAND, LP_OBJECTIVE_MAX, LP_VALUE_SCALE_MAX
from ..validation import as_float_array, check_bool, check_choice, check_int, check_real
from .highs import (
    CvxpyHighs,
    pass_lp,
    quiet_highs,
    run_highs,
    set_basis,
    set_options,
    silence_highs_banner,
    solver_output,
    status_of,
)
from .results import LPResult

if TYPE_CHECKING:  # annotations only: python-flint loads when exact arithmetic is asked for
    from ..exact.lp import ExactLP

# HiGHS prints its banner on stdout the first time a process constructs a Highs object,
# whatever the options (cvxpy passes log_to_console=verbose only afterwards). Nothing
# happens at import: Formulation.__init__ takes that first construction
# (silence_highs_banner, 3 ms, once per process), so the banner goes to the lpbounds log
# and no solve of a model built here prints it, not even a user's own problem.solve(solver="HIGHS").

__all__ = [
    "BACKENDS",
    "Backend",
    "CvxpyBackend",
    "Formulation",
    "HighspyBackend",
    "LPResult",
    "Status",
    "aggregated_cost",
    "check_cost",
    "installed_lp_solvers",
    "resolve_solver",
]


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


def installed_lp_solvers() -> list[str]:
    """The LP-capable cvxpy solvers installed here, HiGHS and Clarabel first.

    Read from cvxpy's solver classes at run time
    (:func:`lpbounds.formulations.solvers.lp_capable_solvers`), not from a hand-kept list.
    """
    from .solvers import lp_capable_solvers

    return list(lp_capable_solvers())


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
    c = as_float_array(what, cost)
    if c.shape != (n,):
        raise ValidationError(f"{what} must have length {n}; got shape {c.shape}")
    if (c < 0).any():
        i = int(np.flatnonzero(c < 0)[0])
        raise ValidationError(f"{what}[{i}] = {c[i]} is negative; costs must be >= 0")
    return c


#: cvxpy's statuses in lpbounds' vocabulary, before the certificate has its say.
_STATUS = {
    cp.OPTIMAL: Status.OPTIMAL,
    cp.OPTIMAL_INACCURATE: Status.INACCURATE,
    cp.USER_LIMIT: Status.LIMIT,
    cp.INFEASIBLE: Status.INFEASIBLE,
    cp.INFEASIBLE_INACCURATE: Status.INFEASIBLE,
    cp.UNBOUNDED: Status.UNBOUNDED,
    cp.UNBOUNDED_INACCURATE: Status.UNBOUNDED,
}


def _check_accuracy(accuracy: Any) -> float:
    if isinstance(accuracy, (bool, np.bool_)) or not isinstance(
        accuracy, (int, float, np.integer, np.floating)
    ):
        raise ValidationError(f"accuracy must be a positive number; got {accuracy!r}")
    acc = float(accuracy)
    if not (np.isfinite(acc) and acc > 0):
        raise ValidationError(f"accuracy must be a positive finite number; got {accuracy!r}")
    return acc


#: Solver options whose meaning cvxpy fixes across solvers: checked here, so a negative
#: time limit is a clear error rather than a solver's rejection after the model is built.
_POSITIVE_REAL_OPTIONS = ("time_limit",)
_POSITIVE_INT_OPTIONS = ("max_iters", "max_iter")


def _check_common_options(options: dict[str, Any]) -> None:
    for key in _POSITIVE_REAL_OPTIONS:
        if key in options:
            check_real(key, options[key], lo=0.0, lo_open=True)
    for key in _POSITIVE_INT_OPTIONS:
        if key in options:
            check_int(key, options[key], lo=1)


@dataclass
class _Run:
    """What one call of the solver returned, before lpbounds judges it."""

    solver: str
    options: dict[str, Any]
    status: Status
    message: str
    x: np.ndarray | None
    y: np.ndarray | None
    compile_seconds: float
    solve_seconds: float
    iterations: int | None
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class _Scaling:
    """The powers of two an LP is scaled by before the solver sees it.

    The solver gets ``min (c 2**-kc)'x'  s.t.  A x' >= b 2**-kb``, whose optimum is
    ``x' = x* 2**-kb`` with duals ``y' = y* 2**-kc``: :meth:`unscale` multiplies them back.
    Multiplying by a power of two is exact in binary floating point (barring overflow and
    underflow, which only an entry far outside the others' range meets; the certificate,
    computed on the original rows from the unscaled point, judges the result either way).
    """

    kb: int = 0
    kc: int = 0

    @property
    def applied(self) -> bool:
        """True when the solver sees data other than the formulation's own."""
        return bool(self.kb or self.kc)

    def data(self, form: Formulation) -> tuple[np.ndarray, np.ndarray]:
        """``(b, c)`` as the solver sees them (the formulation's own arrays when 0)."""
        b = form.b if not self.kb else np.ldexp(form.b, -self.kb)
        c = form.c if not self.kc else np.ldexp(form.c, -self.kc)
        return b, c

    def unscale(self, run: _Run) -> None:
        """The run's point and duals back in the formulation's units (in place)."""
        if run.x is not None and self.kb:
            run.x = np.ldexp(run.x, self.kb)
        if run.y is not None and self.kc:
            run.y = np.ldexp(run.y, self.kc)


_NO_SCALING = _Scaling()


def _scale_exponent(absmax: float, discount: float) -> int:
    """0 when ``absmax`` (``max|b|`` or ``max|c|``) is ordinary, else the power of two that
    brings it into [1, 2).

    Ordinary: within :data:`~lpbounds.tolerances.LP_DATA_BAND` and with ``absmax / (1 -
    discount)`` (the scale of the values, or of the duals) at most
    :data:`~lpbounds.tolerances.LP_VALUE_SCALE_MAX`.
    """
    if not (np.isfinite(absmax) and absmax > 0.0):
        return 0
    lo, hi = LP_DATA_BAND
    if lo <= absmax <= hi and absmax <= LP_VALUE_SCALE_MAX * (1.0 - discount):
        return 0
    return int(np.frexp(absmax)[1]) - 1


#: The constraint types ``extra_constraints`` accepts: what ``<=``, ``>=`` and ``==`` build.
_EXTRA_TYPES = (cp.constraints.Inequality, cp.constraints.Equality)


@dataclass
class _ExtraData:
    """An extra constraint read back after a solve: ``expr(x) = J x + e`` (``<= 0`` or ``== 0``)."""

    residual: float
    dual: np.ndarray
    jac_t: sp.csr_matrix  # J', shape (N, size of the constraint)
    offset: np.ndarray  # e


def _split(spec: list[tuple[str, int]], total: int, what: str) -> dict[str, slice]:
    """Consecutive slices of ``total`` entries, one per named size, checked."""
    out: dict[str, slice] = {}
    start = 0
    for name, size in spec:
        if not isinstance(name, str) or not name or name in out:
            raise ValidationError(f"{what} names must be distinct non-empty strings; got {name!r}")
        n = check_int(f"size of {what} {name!r}", size, lo=0)
        out[name] = slice(start, start + n)
        start += n
    if start != total:
        raise ValidationError(f"the {what} sizes add up to {start}; the data has {total}")
    return out


def _add(terms: list[Any]) -> Any:
    """The sum of cvxpy expressions (one term: itself, so the expression stays as built)."""
    out = terms[0]
    for t in terms[1:]:
        out = out + t
    return out


# ---------------------------------------------------------------------------- backends
class Backend:
    """One way of handing a formulation to an LP solver (cvxpy's ``apply`` / ``solve_via_data``
    / ``invert`` split, as one small class per route).

    :meth:`run` calls the solver on the formulation's LP and returns what came back as a
    :class:`_Run` (status in :class:`~lpbounds.status.Status`, the point ``x`` and the duals
    ``y >= 0`` of the rows of ``A x >= b``, or ``None``, in the units the solver saw: the
    data scaled by ``scaling``); :meth:`Formulation.solve` scales them back and judges them
    the same way whatever the backend. An exception of the solver is a SOLVER_ERROR run,
    never raised (:meth:`Formulation.solve` raises only if asked to). The backends are the
    values of :data:`BACKENDS`.
    """

    name: str = ""

    def run(
        self,
        form: Formulation,
        solver: str,
        verbose: bool,
        options: dict[str, Any],
        problem: cp.Problem,
        basis: Any = None,
        scaling: _Scaling = _NO_SCALING,
    ) -> _Run:
        raise NotImplementedError


def _crashed(solver: str, options: dict[str, Any], exc: BaseException, seconds: float) -> _Run:
    """The run of a solver that raised ``exc``: SOLVER_ERROR, the exception named."""
    msg = f"{solver} raised {type(exc).__name__}: {exc}"
    return _Run(solver, options, Status.SOLVER_ERROR, msg, None, None, 0.0, seconds, None)


class CvxpyBackend(Backend):
    """Through cvxpy (:attr:`Formulation.problem`, any installed LP solver, extra constraints).

    HiGHS goes through :class:`~lpbounds.formulations.highs.CvxpyHighs`, cvxpy's own HiGHS
    interface with the rows handed over as ``A x >= b``, as ``backend="highspy"`` does
    (cvxpy's stock interface writes ``-A x <= -b``, on which HiGHS' interior point method
    takes a different number of iterations: 42 instead of 30 on the paper's UBLP). The
    point, the duals and ``constraint.dual_value`` are as with ``solver="HIGHS"``, and a
    HiGHS limit keeps its name (TIME_LIMIT, ITERATION_LIMIT) instead of cvxpy's USER_LIMIT.
    """

    name = "cvxpy"

    def run(
        self,
        form: Formulation,
        solver: str,
        verbose: bool,
        options: dict[str, Any],
        problem: cp.Problem,
        basis: Any = None,
        scaling: _Scaling = _NO_SCALING,
    ) -> _Run:
        """Call the solver through cvxpy on ``problem`` (already scaled: ``scaling`` is only
        a record here); map its status; keep any point it returned."""
        adapter = (
            form.highs_adapter() if solver == "HIGHS" and not problem.is_mixed_integer() else None
        )
        t0 = time.perf_counter()
        try:
            # solver_output: HiGHS' banner to the log, not stdout, unless verbose (_quiet)
            with warnings.catch_warnings(), solver_output(verbose) as verbose:
                # cvxpy's "Solution may be inaccurate": the certificate judges that instead
                warnings.filterwarnings("ignore", message="Solution may be inaccurate")
                problem.solve(solver=adapter or solver, verbose=verbose, **_canon(options))
        except cp.SolverError as exc:
            return _Run(solver, options, Status.SOLVER_ERROR, str(exc), None, None, 0.0,
                        time.perf_counter() - t0, None)  # fmt: skip
        except (ValueError, TypeError, ArithmeticError) as exc:
            msg = f"cvxpy or {solver} rejected the problem or an option: {exc}"
            return _Run(solver, options, Status.SOLVER_ERROR, msg, None, None, 0.0,
                        time.perf_counter() - t0, None)  # fmt: skip
        except Exception as exc:  # a solver's crash on a well-formed LP: a result, not an abort
            return _crashed(solver, options, exc, time.perf_counter() - t0)
        status = _STATUS.get(problem.status, Status.SOLVER_ERROR)
        if adapter is not None and status is Status.LIMIT:
            status = status_of(adapter.model_status, status)
        x = form.point()  # kept whatever the status: solve() decides what it is worth
        y = form.stacked_duals(problem.constraints[: len(form.constraints)])
        stats = problem.solver_stats
        compile_s = float(getattr(problem, "compilation_time", None) or 0.0)
        solve_s = float(stats.solve_time) if stats and stats.solve_time else 0.0
        return _Run(
            solver=solver,
            options=options,
            status=status,
            message=str(problem.status),
            x=x,
            y=None if y is None else np.maximum(y, 0.0),
            compile_seconds=compile_s,
            solve_seconds=solve_s if solve_s else time.perf_counter() - t0 - compile_s,
            iterations=(int(stats.num_iters) if stats and stats.num_iters is not None else None),
            extra={} if adapter is None else {"highs_status": adapter.model_status},
        )


#: cvxpy's COO canonicalisation backend (cvxpy >= 1.7): it compiles ``A @ x >= b`` about
#: 20-30 % faster than the default (CPP) on a 614,400-row RLP (5.1 against 6.4 s, median of
#: 3 alternating runs); ``None`` where cvxpy has none.
_COO = getattr(cp.settings, "COO_CANON_BACKEND", None)


def _canon(options: dict[str, Any]) -> dict[str, Any]:
    """``options`` with ``canon_backend`` set to COO unless the caller chose one."""
    if _COO is None or "canon_backend" in options:
        return options
    return {**options, "canon_backend": _COO}


class HighspyBackend(Backend):
    """highspy directly on ``(A, b, c)`` (:func:`~lpbounds.formulations.highs.pass_lp`).

    HiGHS only, no extra constraints; options by HiGHS' own names (``time_limit``,
    ``highs_options={"solver": "ipm"}`` or ``solver``-free keys such as ``presolve="off"``);
    an optional starting basis (``warm_start="policy"``). ``compile_seconds`` is the time to
    build and pass the model, ``solve_seconds`` HiGHS' run.
    """

    name = "highspy"

    def run(
        self,
        form: Formulation,
        solver: str,
        verbose: bool,
        options: dict[str, Any],
        problem: cp.Problem,
        basis: Any = None,
        scaling: _Scaling = _NO_SCALING,
    ) -> _Run:
        t0 = time.perf_counter()
        with solver_output(verbose) as verbose:
            h = quiet_highs()
            set_options(h, options, verbose)  # a bad option is the caller's error: raised
            try:
                pass_lp(h, form.A, *scaling.data(form))
                if basis is not None:
                    try:
                        set_basis(h, basis)
                    except SolverError as exc:
                        raise SolverError(f"{form.name}: {exc}") from None
                compile_s = time.perf_counter() - t0
                hr = run_highs(h)
            except Exception as exc:  # HiGHS' rejection or crash: a result, not an abort
                return _crashed("HIGHS", options, exc, time.perf_counter() - t0)
        return _Run(
            solver="HIGHS",
            options=options,
            status=hr.status,
            message=hr.model_status,
            x=hr.x,
            y=None if hr.y is None else np.maximum(hr.y, 0.0),
            compile_seconds=compile_s,
            solve_seconds=hr.seconds,
            iterations=hr.iterations,
            extra={"highs_status": hr.model_status},
        )


#: The backends of :meth:`Formulation.solve` by name.
BACKENDS: dict[str, Backend] = {"cvxpy": CvxpyBackend(), "highspy": HighspyBackend()}


class Formulation:
    r"""``min c'x  s.t.  A x >= b`` as a cvxpy problem in named variables, with certified results.

    Subclasses compute ``(A, b, c)`` from the model, name the blocks of its columns (the
    paper's variables) and of its rows (one constraint group per equation), override
    :meth:`_interpret` to map ``x`` and the duals back to values, state values and
    ``mu``, and :meth:`_certify` / :meth:`_bracket` to certify the returned point.

    Parameters
    ----------
    A : scipy.sparse matrix (R, N)
    b : ndarray (R,)
    c : ndarray (N,)
    name : str
        The paper's name of the formulation.
    variables : list of (str, int), optional
        The columns of ``A`` in consecutive blocks, one ``cp.Variable`` each (default one
        variable ``x``).
    groups : list of (str, int), optional
        The rows of ``A`` in consecutive blocks, one vector constraint each (default one
        group ``rows``). A group with no rows is left out.

    Attributes
    ----------
    problem : cvxpy.Problem
        ``min sum_k c_k' var_k  s.t.  sum_k A[g, k] var_k >= b[g]`` for each group ``g``
        (blocks of ``A`` that are all zero are left out of the sum).
    variables : dict of str to cvxpy.Variable
        The named variables, in the column order of ``A``.
    constraints : dict of str to cvxpy.Constraint
        The named constraint groups, in the row order of ``A``; each is one vector
        ``>=`` constraint, its ``dual_value`` the group's duals ``>= 0``.
    variable_columns, constraint_rows : dict of str to slice
        Where each variable / group sits in the stacked ``x`` / rows of ``A``.
    A, b, c : scipy.sparse.csr_matrix, ndarray, ndarray
        The stacked data.
    """

    name: str = "LP"
    #: What is weak about the partition, for the results' summary (set by a formulation
    #: over a partition: :func:`lpbounds.model.checks.sink_block_note`); None when nothing.
    partition_note: str | None = None
    #: Judge only the upper side of the certificate (formulations whose point dominates,
    #: rather than equals, the certified fixed point: ALP, LLP).
    upper_side_only: bool = False
    #: The LP has a feasible point whatever its data (within validation): a solver's
    #: "infeasible" is then impossible and is reported as that solver's failure
    #: (:meth:`solve`). False here: a general LP may be infeasible.
    feasible_by_construction: bool = False
    #: Why, for the result's note (a sentence; empty where not feasible by construction).
    feasibility_reason: str = ""
    #: The LP's objective is bounded below on its feasible set whatever its data: a
    #: solver's "unbounded" is impossible, also with extra constraints (they only shrink
    #: the feasible set).
    bounded_by_construction: bool = False
    #: Why (a sentence).
    boundedness_reason: str = ""
    #: Private switch: False hands the solver ``(A, b, c)`` exactly as built even outside
    #: :data:`~lpbounds.tolerances.LP_DATA_BAND` (for measuring what scaling does).
    _scaling: bool = True

    def __init__(
        self,
        A: sp.spmatrix,
        b: np.ndarray,
        c: np.ndarray,
        name: str | None = None,
        *,
        variables: list[tuple[str, int]] | None = None,
        groups: list[tuple[str, int]] | None = None,
    ):
        # the first model built takes HiGHS' once-per-process banner into the log (module
        # comment above; idempotent, nothing after the first call)
        silence_highs_banner()
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
        self.variable_columns = _split(variables or [("x", n_cols)], n_cols, "variable")
        rows = _split(groups or [("rows", n_rows)], n_rows, "constraint group")
        self.constraint_rows = {k: s for k, s in rows.items() if s.stop > s.start}
        self.variables = {
            k: cp.Variable(s.stop - s.start, name=k) for k, s in self.variable_columns.items()
        }
        self.constraints = {k: self._group(s) for k, s in self.constraint_rows.items()}
        self.problem = cp.Problem(
            cp.Minimize(self._objective(self.c)), list(self.constraints.values())
        )

    def _objective(self, c: np.ndarray) -> Any:
        """``sum_k c[cols_k] @ var_k``."""
        return _add([c[s] @ self.variables[k] for k, s in self.variable_columns.items()])

    def _group(self, rows: slice, b: np.ndarray | None = None) -> cp.Constraint:
        """``sum_k A[rows, cols_k] @ var_k >= b[rows]``: one sparse vector constraint
        (``b`` defaults to :attr:`b`; a scaled copy for :meth:`_scaled_problem`)."""
        n_rows, n_cols = self.A.shape
        a_g = self.A if rows.stop - rows.start == n_rows else self.A[rows]
        terms = []
        for k, cols in self.variable_columns.items():
            blk = a_g if cols.stop - cols.start == n_cols else a_g[:, cols]
            if blk.nnz:
                terms.append(blk @ self.variables[k])
        if not terms:  # an all-zero group: keep it (0 >= b), on the first variable
            k, cols = next(iter(self.variable_columns.items()))
            terms.append(a_g[:, cols] @ self.variables[k])
        return _add(terms) >= (self.b if b is None else b)[rows]

    # ------------------------------------------------------------------ interface
    def _interpret(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
        """``(values, state_values, mu, extra)`` from the primal ``x`` and duals ``y``."""
        return x, None, None, {}

    def _certify(self, x: np.ndarray) -> Certificate | None:
        """The certificate of the point ``x`` (``None``: this LP has no certificate)."""
        return None

    def _bracket(
        self, cert: Certificate
    ) -> tuple[np.ndarray, np.ndarray, tuple[float, float] | None]:
        """``(lower_values, upper_values, objective_bracket)`` from the certificate."""
        return cert.lower, cert.upper, cert.objective_bracket(self.c)

    def _accurate(
        self,
        cert: Certificate,
        accuracy: float,
        objective: float,
        bracket: tuple[float, float] | None,
    ) -> bool:
        """Whether the point is certified accurate, relative to the problem's scale.

        The point must be feasible to ``accuracy * max|R|`` (its Bellman residual upward,
        so ``upper_values`` is within ``accuracy * max|R| / (1 - lambda)`` of it), and
        either within the same of the least feasible point (downward residual) or, only
        where the optimum is not unique (a cost of zero: any feasible value of an unpriced
        variable is optimal), have an objective certified within ``accuracy * max|R| /
        (1 - lambda) * sum(c)`` of the optimum by the dual bound of the bracket. With every
        cost positive the optimum is the least feasible point, and OPTIMAL always means a
        certified error within ``accuracy * max|R| / (1 - lambda)`` entry by entry.
        """
        tol = accuracy * cert.reward_absmax
        if cert.residual_up > tol:
            return False
        if self.upper_side_only:
            return True
        if cert.residual_down <= tol:
            return True
        if bracket is None or bool((self.c > 0).all()):
            return False
        excess = (objective - bracket[0]) * (1.0 - cert.modulus)
        return bool(excess <= tol * float(self.c.sum()))

    # ------------------------------------------------------------------ scale and claims
    def _discount(self) -> float | None:
        """``lambda`` of the discounted MDP behind this LP; ``None`` (here) for an LP that is
        not one, which is then handed to the solver as built (no scaling, no checks)."""
        return None

    def _value_bound(self) -> float | None:
        """A bound on ``max|x|`` at the optimum, ``None`` where none is known (here)."""
        return None

    def _check_representable(self) -> None:
        """Refuse, before any solver, an LP whose objective or duals overflow float64.

        Scaling brings ``b`` and ``c`` to unit scale for the solver, but the result is
        reported in the formulation's units: ``|c'x| <= sum|c| max|x|`` and the duals sum
        to at most ``sum(c) / (1 - lambda)`` (the occupation measure of ``c``). Either
        beyond :data:`~lpbounds.tolerances.LP_OBJECTIVE_MAX` cannot be represented (with
        the certificate's sums), scaled or not. (The values themselves are within
        :data:`~lpbounds.validation.MAX_VALUE_SCALE`: the MDP refuses larger ones.)

        Raises
        ------
        ValidationError
            Naming the cost's total and the bound it breaks.
        """
        lam, vb = self._discount(), self._value_bound()
        if lam is None or vb is None:
            return
        csum = float(np.abs(self.c).sum())
        if not np.isfinite(csum):
            bad = "the cost's sum overflows float64"
        elif vb > 0 and csum > LP_OBJECTIVE_MAX / vb:
            bad = (
                f"the objective reaches sum(c) * max|x| = {csum:.3g} * {vb:.3g} (max|x| <= "
                "max|R| / (1 - lambda))"
            )
        elif csum > LP_OBJECTIVE_MAX * (1.0 - lam):
            bad = f"the duals reach sum(c) / (1 - lambda) = {csum:.3g} / {1.0 - lam:.3g}"
        else:
            return
        raise ValidationError(
            f"{self.name}: {bad}, beyond {LP_OBJECTIVE_MAX:.1e}: its objective and duals "
            "cannot be represented in float64 even after scaling; rescale the cost (a "
            "positive multiple of the cost gives the same optimal point)"
        )

    @property
    def row_rounding(self) -> float:
        """A bound ``rho`` on how far the stored rows ``(A, b)`` are from the exact rows of
        the LP they stand for, relative (see
        :func:`~lpbounds.certification.certificate.dual_objective_bound`): 0 here, where the
        data is the LP."""
        return 0.0

    def _rows_contract(self) -> bool:
        """Whether the row system behind the structural flags (``self.rows``, where the
        formulation has one) contracts, ``kappa = lambda max_r sum_l p_rl < 1``: rows may sum
        to ``1 + 1e-9`` (validation's tolerance), so a discount within 1e-9 of 1 can break
        the argument. Checked only when a solver makes a claim."""
        rows = getattr(self, "rows", None)
        if rows is None:
            return True
        try:
            contraction_modulus(rows)
        except ValidationError:
            return False
        return True

    def _scaling_of(self, extras: list[cp.Constraint]) -> _Scaling:
        """The powers of two ``b`` and ``c`` are scaled by for the solver (each separately).

        None (``_NO_SCALING``) for an LP that is not of a discounted MDP, with extra
        constraints (written by the user in the formulation's units), when the private
        switch :attr:`_scaling` is off, and when the data is ordinary
        (:func:`_scale_exponent`): such LPs reach the solver bit for bit as built.
        """
        lam = self._discount()
        if extras or lam is None or not self._scaling:
            return _NO_SCALING
        kb = _scale_exponent(float(np.abs(self.b).max(initial=0.0)), lam)
        kc = _scale_exponent(float(np.abs(self.c).max(initial=0.0)), lam)
        return _Scaling(kb, kc)

    def _scaled_problem(self, scaling: _Scaling) -> cp.Problem:
        """:attr:`problem` on the same variables with ``b`` and ``c`` scaled (built once per
        scaling and data: cvxpy then compiles it once)."""
        key = (scaling, id(self.A), id(self.b), id(self.c))
        cached = getattr(self, "_scaled_cache", None)
        if cached is None or cached[0] != key:
            b, c = scaling.data(self)
            groups = [self._group(rows, b) for rows in self.constraint_rows.values()]
            cached = self._scaled_cache = (key, cp.Problem(cp.Minimize(self._objective(c)), groups))
        return cached[1]

    def _store_values(self, x: np.ndarray, y_raw: np.ndarray | None) -> None:
        """After a scaled cvxpy solve: the variables and the groups' duals in this
        formulation's units, as after an unscaled one (``form.V.value``, ...)."""
        for k, cols in self.variable_columns.items():
            self.variables[k].value = x[cols]
        if y_raw is not None:
            for k, rows in self.constraint_rows.items():
                self.constraints[k].save_dual_value(y_raw[rows])

    def _judge_claim(self, run: _Run, modified: bool) -> None:
        """A solver's "infeasible" or "unbounded" where the structure excludes it (in place).

        Infeasible needs :attr:`feasible_by_construction` (and no extra constraints, which
        may make any LP infeasible); unbounded needs :attr:`bounded_by_construction`. Such a
        claim is the solver's failure: with a point, the point is judged by its certificate
        like any other (status OPTIMAL or INACCURATE); without one, SOLVER_ERROR. The
        claim is kept in ``extra["solver_claim"]`` and the reason in ``extra["message"]``.
        """
        if run.status is Status.INFEASIBLE and self.feasible_by_construction and not modified:
            claim, reason = "infeasible", self.feasibility_reason
        elif run.status is Status.UNBOUNDED and self.bounded_by_construction:
            claim, reason = "unbounded", self.boundedness_reason
        else:
            return
        if not self._rows_contract():
            return  # the structural argument needs kappa < 1; without it the claim may hold
        note = (
            f"{run.solver} claimed this {self.name} is {claim} (solver status "
            f"{run.message!r}), which is impossible: {reason}; counted as a failure of "
            f"{run.solver}"
        )
        run.status = Status.INACCURATE if run.x is not None else Status.SOLVER_ERROR
        run.message = note
        run.extra.update(solver_claim=claim, message=note)

    # ------------------------------------------------------------------ values
    def point(self) -> np.ndarray | None:
        """The variables' current values stacked as ``x`` (``None`` before a solve)."""
        parts = [v.value for v in self.variables.values()]
        if any(p is None for p in parts):
            return None
        return np.concatenate([np.asarray(p, dtype=np.float64).ravel() for p in parts])

    def stacked_duals(self, constraints: Any = None) -> np.ndarray | None:
        """The duals of ``constraints`` (default: the groups) stacked in row order, as
        cvxpy left them after a solve of :attr:`problem` (``None`` if any is unset)."""
        parts = []
        for con in self.constraints.values() if constraints is None else constraints:
            if con.dual_value is None:
                return None
            parts.append(np.asarray(con.dual_value, dtype=np.float64).ravel())
        return np.concatenate(parts) if parts else np.zeros(0)

    def group_duals(self, y: np.ndarray) -> dict[str, np.ndarray]:
        """The stacked duals ``y`` split into the named constraint groups."""
        return {k: y[s] for k, s in self.constraint_rows.items()}

    # ------------------------------------------------------------------ modifications
    def modified_problem(self, extra_constraints: Any) -> cp.Problem:
        """:attr:`problem` with ``extra_constraints`` added (validated; ``problem`` unchanged).

        Raises
        ------
        ValidationError
            Naming the entry: not a constraint built with ``<=``, ``>=`` or ``==``, not
            affine, already in the problem, or on a variable that is not one of
            :attr:`variables`.
        """
        extras = self._check_extras(extra_constraints)
        return cp.Problem(self.problem.objective, self.problem.constraints + extras)

    def _check_extras(self, extra_constraints: Any) -> list[cp.Constraint]:
        if extra_constraints is None:
            return []
        if isinstance(extra_constraints, cp.constraints.constraint.Constraint):
            extra_constraints = [extra_constraints]
        if not isinstance(extra_constraints, (list, tuple)):
            raise ValidationError(
                "extra_constraints must be a list of cvxpy constraints; got "
                f"{type(extra_constraints).__name__}"
            )
        own = {id(v) for v in self.variables.values()}
        have = {id(con) for con in self.problem.constraints}
        names = ", ".join(self.variables)
        for k, con in enumerate(extra_constraints):
            if not isinstance(con, _EXTRA_TYPES):
                raise ValidationError(
                    f"extra_constraints[{k}] must be a cvxpy constraint written with <=, >= or "
                    f"==; got {type(con).__name__}"
                )
            if not con.expr.is_affine():
                raise ValidationError(
                    f"extra_constraints[{k}] ({con}) is not affine: the problem must stay an LP"
                )
            if id(con) in have:
                raise ValidationError(f"extra_constraints[{k}] is already in {self.name}.problem")
            for var in con.variables():
                if id(var) not in own:
                    raise ValidationError(
                        f"extra_constraints[{k}] uses the variable {var.name()!r}, which is not "
                        f"a variable of this {self.name} (its variables: {names}); build the "
                        "constraint from formulation.variables"
                    )
        return list(extra_constraints)

    def _backend(
        self, backend: Any, solver: str, warm_start: Any, extras: list[cp.Constraint]
    ) -> Backend:
        """The :class:`Backend` named ``backend``, checked against the other arguments."""
        if not isinstance(backend, str) or backend not in BACKENDS:
            raise ValidationError(
                f"backend must be one of {', '.join(map(repr, BACKENDS))}; got {backend!r}"
            )
        if warm_start is not None and warm_start != "policy":
            raise ValidationError(f"warm_start must be None or 'policy'; got {warm_start!r}")
        if backend == "highspy":
            if solver != "HIGHS":
                raise ValidationError(
                    f"backend='highspy' solves with HiGHS only; got solver={solver!r}"
                )
            if extras:
                raise ValidationError(
                    "extra_constraints need backend='cvxpy' (backend='highspy' solves the "
                    "formulation's own rows A x >= b only)"
                )
        elif warm_start is not None:
            raise ValidationError("warm_start='policy' needs backend='highspy'")
        return BACKENDS[backend]

    def highs_adapter(self) -> CvxpyHighs:
        """This formulation's cvxpy HiGHS adapter
        (:class:`~lpbounds.formulations.highs.CvxpyHighs`), created on first use: one per
        formulation, because cvxpy caches the compiled problem per solver object, so a
        second solve does not compile again."""
        adapter = getattr(self, "_cvxpy_highs", None)
        if adapter is None:
            adapter = self._cvxpy_highs = CvxpyHighs()
        return adapter

    def policy_basis(self) -> Any:
        """A starting basis for HiGHS' simplex method (``warm_start="policy"``).

        Raises
        ------
        ValidationError
            Here: only Bellman-row LPs (:class:`~lpbounds.formulations.RowsLP`) have one.
        """
        raise ValidationError(
            f"warm_start='policy' needs a Bellman-row LP (ELP, RLP, SLP, IB, UBLP, LBLP); "
            f"{self.name} has no policy basis"
        )

    def _extra_data(self, extras: list[cp.Constraint], x: np.ndarray) -> list[_ExtraData]:
        """Each extra constraint as ``J x + e`` at the returned point, its residual and dual."""
        out = []
        for con in extras:
            expr = con.expr
            size = int(expr.size)
            grads = {id(k): g for k, g in (expr.grad or {}).items()}
            blocks = []
            for var in self.variables.values():
                g = grads.get(id(var))
                blocks.append(sp.csr_matrix((var.size, size)) if g is None else sp.csr_matrix(g))
            jac_t = sp.vstack(blocks, format="csr")
            value = np.asarray(expr.value, dtype=np.float64).ravel()
            dual = np.asarray(
                0.0 if con.dual_value is None else con.dual_value, dtype=np.float64
            ).ravel() * np.ones(size)
            if isinstance(con, cp.constraints.Inequality):
                dual = np.maximum(dual, 0.0)
            residual = float(np.max(np.asarray(con.violation(), dtype=np.float64), initial=0.0))
            out.append(_ExtraData(residual, dual, jac_t, value - jac_t.T @ x))
        return out

    # ------------------------------------------------------------------ solve
    def solve(
        self,
        solver: str = "HIGHS",
        *,
        backend: str = "cvxpy",
        warm_start: str | None = None,
        accuracy: float = LP_CERT_RTOL,
        raise_on_failure: bool = True,
        verbose: bool = False,
        extra_constraints: Any = None,
        arithmetic: str = "float",
        size_limit: int | None = None,
        **solver_options: Any,
    ) -> LPResult:
        """Solve with ``solver`` (any installed cvxpy LP solver) and certify the result.

        Parameters
        ----------
        solver : str
            "HIGHS" (default), "CLARABEL", "SCIPY", "GLPK", "ECOS", "SCS", ...
        backend : {"cvxpy", "highspy"}
            How the LP reaches the solver (:data:`BACKENDS`): through cvxpy and
            :attr:`problem` (default; every solver, ``extra_constraints``), or ``(A, b, c)``
            handed to highspy directly (``solver="HIGHS"`` only, no ``extra_constraints``;
            no cvxpy compilation). Both return the same :class:`LPResult`, judged the same
            way: the same point, the duals in the same sign convention.
        warm_start : {None, "policy"}
            Bellman-row LPs (:class:`~lpbounds.formulations.RowsLP`: ELP, RLP, SLP, IB,
            UBLP, LBLP) with ``backend="highspy"`` only: start HiGHS' simplex method from
            the basis of the optimal policy computed by exact DP (see
            :meth:`~lpbounds.formulations.RowsLP.policy_basis`); HiGHS then only checks
            optimality (0 iterations when the DP policy is optimal). The route for LPs too
            large for an interior point method within minutes (the ELP of the paper's
            instance: 4.65M rows in under a minute).
        accuracy : float
            Requested relative accuracy: the status is OPTIMAL when the certified error
            of the returned point is within ``accuracy * max|R| / (1 - lambda)`` (default
            :data:`~lpbounds.tolerances.LP_CERT_RTOL`); a less accurate point is
            INACCURATE and keeps its (valid, wider) bracket.
        raise_on_failure : bool
            Raise :class:`~lpbounds.errors.SolverError` unless the result is OPTIMAL
            (default); otherwise return it with its status.
        verbose : bool
            Print the solver's log.
        extra_constraints : list of cvxpy constraints, optional
            A research modification: affine constraints written with ``<=``, ``>=`` or
            ``==`` on this formulation's :attr:`variables` (``v[i] <= v[j]``, ...), added
            to :attr:`problem` for this solve only (:meth:`modified_problem`; the
            formulation itself is not changed). See "Modified problems" below.
        arithmetic : {"float", "rational"}
            ``"rational"``: after the solve, also the LP's exact optimum on the stored
            model (each double taken as the exact rational it is) with an exact primal
            point and an exact dual that prove it, checked in rationals; the float answer
            stays as it was and ``result.exact`` (:class:`lpbounds.exact.lp.ExactLP`) holds
            the exact one, the solver's exact error and whether its certified bracket held
            (:meth:`exact_optimum`). ELP, RLP, SLP, IB, ALP, LLP, UBLP and LBLP have it
            (and any :class:`~lpbounds.formulations.RowsLP`); not with
            ``extra_constraints``.
        size_limit : int, optional
            ``arithmetic="rational"``: the most variables one dense exact solve takes
            (default :data:`~lpbounds.tolerances.EXACT_MAX_VARIABLES`; :meth:`exact_optimum`).
        **solver_options
            Passed to the solver through cvxpy. HiGHS' own ``solver`` option clashes
            with this method's ``solver`` argument, so HiGHS options go in a dict:
            ``highs_options={"solver": "ipm", "run_crossover": "on"}`` for its interior
            point method with crossover (faster than its simplex on large RLPs).

        Returns
        -------
        LPResult

        Notes
        -----
        **Modified problems.** An added constraint can only shrink the feasible set
        ``F`` to ``F'``, so the modified optimum ``x'*`` is a point of ``F``. What
        lpbounds still certifies, from the returned point alone, is about the ORIGINAL
        row system: ``lower_values <= v* <= upper_values`` for the original optimum
        ``v*`` (the certificate takes any point). Hence ``upper_values`` stays a
        certified upper bound on ``V*`` where the formulation gives one (RLP, UBLP, IB,
        ALP, ELP; LBLP and SLP bound their own ``v*`` only), and, since ``v*`` is the
        least element of ``F`` and ``x'* in F``, ``lower_values`` and the lower end of
        ``objective_bracket`` are also certified lower bounds on the modified optimum
        (``objective_bracket = (lower, inf)``). Nothing solver-free bounds the modified
        optimum from above: the modified LP's optimum has no fixed-point counterpart, so
        ``error_bound`` is ``inf`` and the status is NOT decided by the original
        certificate's downward residual (which measures the distance to ``v*``, not to
        ``x'*``). Instead the status is OPTIMAL when, all computed by lpbounds from the
        returned point and the solver's duals of every constraint:

        * the point satisfies the original rows to ``residual_tol`` (the certificate's
          upward residual; ``primal_residual`` for an LP without a certificate);
        * each extra constraint's violation (``extra_residuals``) is within
          ``residual_tol``;
        * the duality gap of the modified LP is within ``accuracy`` of the objective's
          scale: with ``r = c - A'y + sum_k J_k' d_k`` (``d_k`` the duals of the extra
          constraints ``J_k x + e_k <= 0`` / ``== 0``) and ``D = b'y + sum_k d_k' e_k``,
          ``kkt_gap = |c'x - D| + ||r||_1 max|x| <= accuracy * sum(c) * max|R| / (1 -
          lambda)``. By weak duality ``c'x' >= D + r'x'`` for every feasible ``x'``, so this
          says the point is optimal up to that amount, *provided* ``max|x'*|`` is no larger
          than ``max|x|``: a check of the solver's answer, not a certificate.

        Otherwise INACCURATE (a limit status is kept). ``dual_residual`` is ``||r||_inf``
        and ``gap`` is ``|c'x - D|``; ``group_duals`` and ``mu`` are the modified LP's
        duals of the original groups, ``extra_duals`` those of the added constraints.

        **Scaling.** For an LP of a discounted MDP (ELP, RLP, SLP, IB, UBLP, LBLP, ALP, LLP)
        without extra constraints, ``b`` (the rewards) and ``c`` are each multiplied by a
        power of two, ``2**-kb`` and ``2**-kc``, so that the largest entry lies in [1, 2),
        unless it already lies in :data:`~lpbounds.tolerances.LP_DATA_BAND` with a value
        (or dual) scale ``max / (1 - lambda)`` of at most
        :data:`~lpbounds.tolerances.LP_VALUE_SCALE_MAX`: then the LP reaches the solver bit
        for bit as built. The solver's point and duals are multiplied back by ``2**kb`` and
        ``2**kc`` (exact in binary floating point) and everything above -- certificate,
        residuals, status -- is computed from them on the ORIGINAL rows. What cannot be
        represented even so (an objective or dual total beyond
        :data:`~lpbounds.tolerances.LP_OBJECTIVE_MAX`) is a ValidationError before the
        solver.

        **Solver claims.** A solver's "infeasible" on a formulation that is
        :attr:`feasible_by_construction` (without extra constraints), or "unbounded" on one
        that is :attr:`bounded_by_construction`, is impossible: the status is SOLVER_ERROR
        (or, where the solver returned a point anyway, that point's certified status), with
        the claim and the reason in ``extra``. An exception raised by the solver is a
        SOLVER_ERROR result; ``raise_on_failure`` decides whether it is raised as
        :class:`~lpbounds.errors.SolverError`.
        """
        acc = _check_accuracy(accuracy)
        raise_on_failure = check_bool("raise_on_failure", raise_on_failure)
        verbose = check_bool("verbose", verbose)
        _check_common_options(solver_options)
        extras = self._check_extras(extra_constraints)
        check_choice("arithmetic", arithmetic, ("float", "rational"))
        if arithmetic == "rational":
            if extras:
                raise ValidationError(
                    "arithmetic='rational' solves the formulation's own LP: not with "
                    "extra_constraints"
                )
            self.exact_size()  # no exact route: refused before the solver runs
        name = resolve_solver(solver)
        route = self._backend(backend, name, warm_start, extras)
        self._check_representable()
        basis, warm_extra = None, {}
        if warm_start is not None:
            t0 = time.perf_counter()
            basis = self.policy_basis()
            warm_extra = {"warm_start": warm_start, "warm_start_seconds": time.perf_counter() - t0}
            solver_options = {"solver": "simplex", **solver_options}
        run = self._run(route, name, verbose, solver_options, extras, basis)
        run.extra.update(warm_extra)
        if run.x is None:
            return self._failed(run, acc, raise_on_failure)
        result = self._judge(run, acc) if not extras else self._judge_modified(run, acc, extras)
        if raise_on_failure and result.status is not Status.OPTIMAL:
            what = (
                f"certified error {result.error_bound:.3e} (relative "
                f"{result.relative_error:.3e}, requested {acc:.1e})"
                if not extras
                else f"extra constraint residuals {list(result.extra_residuals)}, duality gap "
                f"(kkt_gap) {result.kkt_gap:.3e}, requested accuracy {acc:.1e}"
            )
            raise SolverError(
                f"{self.name} with {run.solver}: status {result.status.value}; {what}; primal "
                f"residual {result.primal_residual:.3e}, dual residual "
                f"{result.dual_residual:.3e}, gap {result.gap:.3e}"
            )
        if arithmetic == "rational":
            result.exact = self.exact_optimum(result, size_limit=size_limit)
        return result

    # ------------------------------------------------------------------ exact arithmetic
    def exact_size(self) -> tuple[int, str]:
        """``(variables, what)``: the variables of the exact system :meth:`exact_optimum`
        solves and its name (the words of a size error).

        Raises
        ------
        ValidationError
            Here: a formulation without an exact route (a plain :class:`Formulation`); called
            before the solver runs, so such a request fails before any work.
        """
        raise ValidationError(
            f"{self.name} has no exact route: arithmetic='rational' is implemented for ELP, "
            "RLP, SLP, IB, ALP, LLP, UBLP, LBLP and any RowsLP"
        )

    def exact_optimum(
        self,
        result: LPResult | None = None,
        *,
        size_limit: int | None = None,
        callback: Any = None,
    ) -> ExactLP:
        """The LP's exact optimum and the exact primal and dual that prove it.

        Parameters
        ----------
        result : LPResult, optional
            A float solve of this LP: its point chooses where the exact computation starts
            (it decides nothing), and the returned ExactLP records its exact error and
            whether its certified bracket held (:meth:`ExactLP.judge
            <lpbounds.exact.lp.ExactLP.judge>`).
        size_limit : int, optional
            The most variables one dense exact solve takes (default
            :data:`~lpbounds.tolerances.EXACT_MAX_VARIABLES`): a policy's largest strongly
            connected component, checked before it is solved.
        callback : callable(ExactProgress), optional
            Progress of the exact computation (:class:`lpbounds.exact.system.ExactProgress`).

        Returns
        -------
        ExactLP

        Raises
        ------
        SizeLimitError
            Above ``size_limit`` (before the exact solve).
        ValidationError
            For a formulation without an exact route.
        """
        self.exact_size()
        approx = None if result is None else result.x
        exact = self._exact_route(approx, size_limit, callback)
        if result is not None:
            exact = self.judge_exact(exact, result, size_limit=size_limit)
        return exact

    def judge_exact(
        self, exact: ExactLP, result: LPResult, *, size_limit: int | None = None
    ) -> ExactLP:
        """A copy of ``exact`` (this LP's exact optimum) judging the float ``result``: its
        exact error and whether its certified bracket held (on what the bracket is about:
        the optimum, or ``V*`` for ALP, RLP's ``v*`` for LLP)."""
        out = copy.copy(exact)
        out.judge(
            result.values,
            result.lower_values,
            result.upper_values,
            result.objective,
            self._exact_bracket_target(exact, size_limit),
        )
        return out

    def _exact_route(self, approx: Any, size_limit: int | None, callback: Any) -> ExactLP:
        """The exact optimum (hook; :meth:`exact_size` refuses where there is none)."""
        raise NotImplementedError

    def _exact_bracket_target(self, exact: ExactLP, size_limit: int | None) -> Any:
        """What the float result's certified bracket is about (hook): the exact optimum's
        ``values`` (``None``) unless the formulation's bracket is on something else."""
        return None

    def _run(
        self,
        route: Backend,
        solver: str,
        verbose: bool,
        options: dict[str, Any],
        extras: list[cp.Constraint],
        basis: Any,
    ) -> _Run:
        """One run of the solver on the (scaled) LP, its point and duals in this LP's units
        and its claim judged against the structure (:meth:`_judge_claim`); ``x`` is
        ``None`` unless the status keeps a point."""
        scaling = self._scaling_of(extras)
        if extras:
            problem = cp.Problem(self.problem.objective, self.problem.constraints + extras)
        else:
            problem = self._scaled_problem(scaling) if scaling.applied else self.problem
        run = route.run(self, solver, verbose, options, problem, basis, scaling)
        if scaling.applied:
            raw = None if route.name != "cvxpy" else self.stacked_duals(problem.constraints)
            scaling.unscale(run)
            if route.name == "cvxpy" and run.x is not None:
                self._store_values(run.x, None if raw is None else np.ldexp(raw, scaling.kc))
            run.extra["lp_scaling"] = {"b": scaling.kb, "c": scaling.kc}
        self._judge_claim(run, bool(extras))
        if not run.status.has_point:
            run.x = None
        return run

    def _judge(self, run: _Run, accuracy: float) -> LPResult:
        """The certified result of a run that returned a point."""
        assert run.x is not None
        x = run.x
        y = np.zeros(self.A.shape[0]) if run.y is None else run.y
        primal = float(max(0.0, (self.b - self.A @ x).max(initial=0.0)))
        dual_res = float(np.abs(self.A.T @ y - self.c).max(initial=0.0))
        obj = float(self.c @ x)
        gap = abs(obj - float(self.b @ y))
        cert = self._certify(x)
        lower: np.ndarray | None = None
        upper: np.ndarray | None = None
        bracket: tuple[float, float] | None = None
        if cert is not None:
            lower, upper, bracket = self._bracket(cert)
            if bracket is not None and run.y is not None:
                dual_lo = dual_objective_bound(
                    self.A, self.b, self.c, y, cert.lower, cert.upper, self.row_rounding
                )
                bracket = (max(bracket[0], dual_lo), bracket[1])
            tol = accuracy * cert.reward_absmax
            accurate = self._accurate(cert, accuracy, obj, bracket)
            err = cert.error_bound
        else:
            tol = accuracy * float(np.abs(self.b).max(initial=0.0))
            accurate = primal <= tol
            err = float("inf")
        return self._result(
            run, accuracy, x, y, obj, primal, tol, dual_res, gap, cert, accurate,
            lower=lower, upper=upper, error_bound=err, bracket=bracket,
        )  # fmt: skip

    def _judge_modified(self, run: _Run, accuracy: float, extras: list[cp.Constraint]) -> LPResult:
        """The result of a modified solve: feasibility and a duality-gap check (see solve)."""
        assert run.x is not None
        x = run.x
        y = np.zeros(self.A.shape[0]) if run.y is None else run.y
        data = self._extra_data(extras, x)
        primal = float(max(0.0, (self.b - self.A @ x).max(initial=0.0)))
        obj = float(self.c @ x)
        r = self.c - self.A.T @ y
        dual_obj = float(self.b @ y)
        for d in data:
            r = r + d.jac_t @ d.dual
            dual_obj += float(d.dual @ d.offset)
        gap = abs(obj - dual_obj)
        kkt = gap + float(np.abs(r).sum()) * float(np.abs(x).max(initial=0.0))
        cert = self._certify(x)
        lower: np.ndarray | None = None
        upper: np.ndarray | None = None
        bracket: tuple[float, float] | None = None
        if cert is not None:
            lower, upper, orig = self._bracket(cert)
            bracket = None if orig is None else (orig[0], float("inf"))
            tol = accuracy * cert.reward_absmax
            rows_ok = cert.residual_up <= tol
            scale = cert.reward_absmax / (1.0 - cert.modulus)
        else:
            tol = accuracy * float(np.abs(self.b).max(initial=0.0))
            rows_ok = primal <= tol
            scale = max(1.0, float(np.abs(x).max(initial=0.0)))
        weight = float(np.abs(self.c).sum()) or 1.0
        accurate = (
            rows_ok and all(d.residual <= tol for d in data) and kkt <= accuracy * scale * weight
        )
        result = self._result(
            run, accuracy, x, y, obj, primal, tol, float(np.abs(r).max(initial=0.0)), gap, cert,
            accurate, lower=lower, upper=upper, error_bound=float("inf"), bracket=bracket,
        )  # fmt: skip
        result.modified = True
        result.extra_residuals = tuple(d.residual for d in data)
        result.extra_duals = tuple(d.dual for d in data)
        result.kkt_gap = kkt
        return result

    def _result(
        self,
        run: _Run,
        accuracy: float,
        x: np.ndarray,
        y: np.ndarray,
        obj: float,
        primal: float,
        tol: float,
        dual_res: float,
        gap: float,
        cert: Certificate | None,
        accurate: bool,
        *,
        lower: np.ndarray | None,
        upper: np.ndarray | None,
        error_bound: float,
        bracket: tuple[float, float] | None,
    ) -> LPResult:
        status = run.status
        if status in (Status.OPTIMAL, Status.INACCURATE):
            status = Status.OPTIMAL if accurate else Status.INACCURATE
        values, state_values, mu, extra = self._interpret(x, y)
        # the solver's own word for its answer, beside lpbounds' status from the certificate
        extra = {**extra, "solver_status": run.message, **run.extra}
        if self.partition_note is not None:
            extra["partition_note"] = self.partition_note
        return LPResult(
            formulation=self.name,
            status=status,
            objective=obj,
            x=x,
            values=values,
            state_values=state_values,
            duals=y,
            mu=mu,
            solver=run.solver,
            solver_options=dict(run.options),
            compile_seconds=run.compile_seconds,
            solve_seconds=run.solve_seconds,
            iterations=run.iterations,
            primal_residual=primal,
            residual_tol=tol,
            dual_residual=dual_res,
            gap=gap,
            lower_values=lower,
            upper_values=upper,
            error_bound=error_bound,
            objective_bracket=bracket,
            certificate=cert,
            accuracy=accuracy,
            extra=extra,
            group_duals=self.group_duals(y),
        )

    def _failed(self, run: _Run, accuracy: float, raise_on_failure: bool) -> LPResult:
        if raise_on_failure:
            raise SolverError(f"{self.name} with {run.solver}: {run.status.value} ({run.message})")
        n_rows, n_cols = self.A.shape
        nan = np.full(n_cols, np.nan)
        return LPResult(
            formulation=self.name,
            status=run.status,
            objective=float("nan"),
            x=nan,
            values=nan,
            state_values=None,
            duals=np.full(n_rows, np.nan),
            mu=None,
            solver=run.solver,
            solver_options=dict(run.options),
            compile_seconds=run.compile_seconds,
            solve_seconds=run.solve_seconds,
            iterations=run.iterations,
            primal_residual=float("nan"),
            residual_tol=float("nan"),
            dual_residual=float("nan"),
            gap=float("nan"),
            accuracy=accuracy,
            extra={"message": run.message, **run.extra},
        )

    def __repr__(self) -> str:
        names = ", ".join(self.variables)
        groups = ", ".join(self.constraints)
        return (
            f"{type(self).__name__}(rows={self.A.shape[0]}, variables={self.A.shape[1]}: "
            f"{names}; constraint groups: {groups})"
        )
