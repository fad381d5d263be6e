r"""The one HiGHS layer: every ``highspy`` call of lpbounds goes through this module.

Only this module constructs ``highspy.Highs`` (:func:`quiet_highs`) and maps HiGHS' model
statuses to :class:`~lpbounds.status.Status` (:data:`STATUS_MAP`, :func:`status_of`).

Models. :func:`highs_lp` builds a :class:`highspy.HighsLp` from a formulation's stored data
``(A, b, c)`` (``A`` CSR): rows ``b <= A x <= +inf``, columns free, the matrix column-wise
(HiGHS' own storage). :func:`pass_lp` passes the same LP to a ``Highs`` through HiGHS'
array interface (ten times faster than filling a ``HighsLp`` at 10M nonzeros).
:func:`pass_bounded_lp` passes a general ``row_lower <= A x <= row_upper``, ``col_lower <=
x <= col_upper`` (row-wise, as the NLP's cut loop builds it); :func:`add_rows` appends rows
to a passed model, :func:`clear_model` empties a ``Highs`` for reuse, :func:`set_basis`
hands it a starting basis (:func:`tight_basis`), :func:`write_lp` writes a model file.

One solve. :func:`set_options` passes options by name, :func:`run_highs` runs and reads
back a :class:`HighsRun` (status, point, duals, objective, iteration counts).
:class:`CvxpyHighs` is the cvxpy solver adapter the cvxpy path uses for HiGHS.

The banner. HiGHS (highspy 1.16) prints its banner ("Running HiGHS 1.16.0 ... Copyright
...") from C++ on the process's standard output the first time a ``highspy.Highs`` object
is constructed, before any option (``output_flag``, ``log_to_console``) can be set, and
neither an option nor an environment variable turns it off. cvxpy's HiGHS interface
constructs two such objects per solve, so every process that solves with HiGHS printed it
once, whatever ``verbose`` said. It is printed once per process only, so
:func:`silence_highs_banner` constructs one ``Highs`` with the C-level standard output
captured (:func:`lpbounds.formulations.quiet.captured_fds`) and sends the text to the
``lpbounds`` logger at DEBUG; afterwards the options do the rest (cvxpy passes
``log_to_console=verbose``, :func:`quiet_highs` sets ``output_flag=False``). Nothing
happens at import: the first :class:`~lpbounds.formulations.base.Formulation` or
:class:`~lpbounds.formulations.nlp.problem.NLP` built, and every :func:`quiet_highs` and
:func:`solver_output`, call it first (idempotent), so no solve of a model built by
lpbounds prints the banner, even a user's own ``lp.problem.solve(solver="HIGHS")``.
:func:`solver_output` is the one call solver wrappers make around a solve.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import scipy.sparse as sp
from cvxpy.reductions.solvers.conic_solvers.highs_conif import HIGHS as _CvxpyHIGHS

from ..errors import SolverError, ValidationError
from ..status import Status
from .quiet import captured_fds, solver_output_shown

__all__ = [
    "STATUS_MAP",
    "CvxpyHighs",
    "HighsRun",
    "accepted_option_values",
    "add_rows",
    "clear_model",
    "highs_banner_silenced",
    "highs_lp",
    "pass_bounded_lp",
    "pass_lp",
    "quiet_highs",
    "run_highs",
    "set_basis",
    "set_options",
    "silence_highs_banner",
    "solver_output",
    "status_of",
    "tight_basis",
    "write_lp",
]


# ---------------------------------------------------------------------------- the banner
_lock = threading.Lock()
_banner_done = False


def silence_highs_banner() -> None:
    """Print HiGHS' once-per-process banner into the log instead of stdout (idempotent;
    nothing when highspy is not installed or after
    :func:`~lpbounds.formulations.quiet.show_solver_output`).

    Called lazily, never at import: by the first
    :class:`~lpbounds.formulations.base.Formulation` or
    :class:`~lpbounds.formulations.nlp.problem.NLP` constructed and by :func:`quiet_highs`
    and :func:`solver_output` (3 ms, once), so no HiGHS solve of a model built with
    lpbounds prints the banner, even a user's own ``lp.problem.solve(solver="HIGHS")``.
    """
    global _banner_done
    if _banner_done or solver_output_shown():
        return
    with _lock:
        if _banner_done:
            return
        try:
            import highspy
        except ImportError:
            _banner_done = True
            return
        with captured_fds((1,)):
            highspy.Highs()
        _banner_done = True


def highs_banner_silenced() -> bool:
    """Whether :func:`silence_highs_banner` has taken HiGHS' banner in this process (so a
    ``highspy.Highs`` has been constructed here); ``False`` right after import."""
    return _banner_done


@contextlib.contextmanager
def solver_output(verbose: bool = False) -> Iterator[bool]:
    """Wrap a solver call: the solver prints nothing it was not asked for.

    ``with solver_output(verbose) as verbose: problem.solve(..., verbose=verbose)``. The
    value is ``verbose`` or the command line's ``--verbose``
    (:func:`~lpbounds.formulations.quiet.show_solver_output`): then the solver prints its
    banner and log as it likes; otherwise HiGHS' banner is silenced first (the solvers'
    own logs are off through their options, which cvxpy sets from ``verbose``).
    """
    show = bool(verbose or solver_output_shown())
    if not show:
        silence_highs_banner()
    yield show


def quiet_highs() -> Any:
    """A ``highspy.Highs`` with ``output_flag`` off, its banner in the log rather than on
    stdout (unless :func:`~lpbounds.formulations.quiet.show_solver_output`); a caller that
    wants HiGHS' log turns ``output_flag`` back on. The only constructor of ``Highs`` in
    lpbounds."""
    import highspy

    if not solver_output_shown():
        silence_highs_banner()
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    return h


# ---------------------------------------------------------------------------- models


def highs_lp(A: sp.spmatrix | sp.sparray, b: np.ndarray, c: np.ndarray) -> Any:
    """``min c'x  s.t.  A x >= b``, ``x`` free, as a ``highspy.HighsLp``.

    Parameters
    ----------
    A : scipy.sparse matrix (R, N)
        The rows (any sparse format; converted to CSC, indices sorted).
    b : ndarray (R,)
        Row lower bounds (``row_upper = +inf``).
    c : ndarray (N,)
        Column costs (``col_lower = -inf``, ``col_upper = +inf``).

    Returns
    -------
    highspy.HighsLp
        Ready for ``Highs.passModel``; its row duals are ``>= 0`` at an optimum in
        HiGHS' sign convention for a minimisation with ``>=`` rows.
    """
    import highspy

    d = _LpArrays.of(A, b, c)
    lp = highspy.HighsLp()
    lp.num_col_ = d.n_cols
    lp.num_row_ = d.n_rows
    lp.col_cost_ = d.cost
    lp.col_lower_ = d.col_lower
    lp.col_upper_ = d.col_upper
    lp.row_lower_ = d.row_lower
    lp.row_upper_ = d.row_upper
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.num_col_ = d.n_cols
    lp.a_matrix_.num_row_ = d.n_rows
    lp.a_matrix_.start_ = d.start
    lp.a_matrix_.index_ = d.index
    lp.a_matrix_.value_ = d.value
    return lp


@dataclass
class _LpArrays:
    """``min c'x s.t. row_lower <= A x <= row_upper, col_lower <= x <= col_upper`` as the
    arrays HiGHS takes (``A`` column-wise, int32 indices)."""

    n_rows: int
    n_cols: int
    cost: np.ndarray
    col_lower: np.ndarray
    col_upper: np.ndarray
    row_lower: np.ndarray
    row_upper: np.ndarray
    start: np.ndarray
    index: np.ndarray
    value: np.ndarray

    @classmethod
    def of(cls, A: Any, b: Any, c: Any) -> _LpArrays:
        """``A x >= b``, ``x`` free."""
        import highspy

        a = sp.csc_matrix(A)
        if not a.has_sorted_indices:
            a = a.sorted_indices()
        n_rows, n_cols = a.shape
        bb = np.ascontiguousarray(b, dtype=np.float64)
        cc = np.ascontiguousarray(c, dtype=np.float64)
        if bb.shape != (n_rows,) or cc.shape != (n_cols,):
            raise ValueError(f"A is {a.shape}, b {bb.shape}, c {cc.shape}")
        inf = highspy.kHighsInf
        return cls(
            int(n_rows), int(n_cols), cc, np.full(n_cols, -inf), np.full(n_cols, inf), bb,
            np.full(n_rows, inf), a.indptr.astype(np.int32), a.indices.astype(np.int32),
            np.ascontiguousarray(a.data, dtype=np.float64),
        )  # fmt: skip

    def pass_to(self, h: Any) -> None:
        """``h.passModel`` from the arrays (numpy buffers: 10x faster than filling a
        ``HighsLp``, whose vectors pybind11 converts element by element; 1 s against 10 s
        for the paper's ELP). Raises :class:`SolverError` if HiGHS rejects the model."""
        import highspy

        status = h.passModel(
            self.n_cols, self.n_rows, int(self.index.size), int(highspy.MatrixFormat.kColwise),
            int(highspy.ObjSense.kMinimize), 0.0, self.cost, self.col_lower, self.col_upper,
            self.row_lower, self.row_upper, self.start, self.index, self.value,
            np.zeros(self.n_cols, dtype=np.int32),  # every column continuous
        )  # fmt: skip
        if status == highspy.HighsStatus.kError:
            raise SolverError("HiGHS rejected the LP (passModel returned kError)")


def pass_lp(h: Any, A: Any, b: Any, c: Any) -> None:
    """Pass ``min c'x s.t. A x >= b`` (``x`` free) to the ``Highs`` object ``h``: the same LP
    as :func:`highs_lp`, through HiGHS' array interface (no ``HighsLp`` in between)."""
    _LpArrays.of(A, b, c).pass_to(h)


def pass_bounded_lp(
    h: Any,
    c: np.ndarray,
    A: sp.spmatrix | sp.sparray,
    row_lower: np.ndarray,
    row_upper: np.ndarray,
    col_lower: np.ndarray,
    col_upper: np.ndarray,
) -> None:
    """Pass ``min c'x s.t. row_lower <= A x <= row_upper, col_lower <= x <= col_upper``
    (infinite sides allowed) to the ``Highs`` object ``h``.

    The matrix goes row-wise (``A`` as CSR, indices sorted) in a ``highspy.HighsLp``: the
    route the NLP's cut loop has always taken (its LPs are small; :func:`pass_lp` is the
    fast route for the formulations' ``A x >= b``).

    Raises
    ------
    SolverError
        If HiGHS rejects the model (``passModel`` returns ``kError``).
    """
    import highspy

    a = A.tocsr()
    a.sort_indices()
    lp = highspy.HighsLp()
    lp.num_col_ = int(a.shape[1])
    lp.num_row_ = int(a.shape[0])
    lp.col_cost_ = np.asarray(c, dtype=np.float64)
    lp.col_lower_ = np.asarray(col_lower, dtype=np.float64)
    lp.col_upper_ = np.asarray(col_upper, dtype=np.float64)
    lp.row_lower_ = np.asarray(row_lower, dtype=np.float64)
    lp.row_upper_ = np.asarray(row_upper, dtype=np.float64)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.num_col_ = lp.num_col_
    lp.a_matrix_.num_row_ = lp.num_row_
    lp.a_matrix_.start_ = a.indptr.astype(np.int32)
    lp.a_matrix_.index_ = a.indices.astype(np.int32)
    lp.a_matrix_.value_ = a.data.astype(np.float64)
    if h.passModel(lp) == highspy.HighsStatus.kError:
        raise SolverError("HiGHS rejected the LP (passModel returned kError)")


def add_rows(h: Any, A: Any, lower: np.ndarray, upper: np.ndarray | None = None) -> None:
    """Append the rows ``lower <= A x <= upper`` (``A`` dense or sparse, one row each;
    ``upper`` default ``+inf``) to the model passed to ``h``; the next :func:`run_highs`
    warm-starts from the last basis."""
    a = sp.csr_matrix(A)
    a.sort_indices()
    h.addRows(
        a.shape[0],
        np.asarray(lower, dtype=np.float64),
        np.full(a.shape[0], np.inf) if upper is None else np.asarray(upper, dtype=np.float64),
        int(a.nnz),
        a.indptr[:-1].astype(np.int32),
        a.indices.astype(np.int32),
        a.data.astype(np.float64),
    )


def clear_model(h: Any) -> None:
    """Empty the ``Highs`` object ``h`` (its options kept) for the next model."""
    h.clearModel()


def set_basis(h: Any, basis: Any) -> None:
    """Hand ``h`` a starting basis (:func:`tight_basis`).

    Raises
    ------
    SolverError
        If HiGHS rejects it.
    """
    import highspy

    if h.setBasis(basis) == highspy.HighsStatus.kError:
        raise SolverError("HiGHS rejected the starting basis")


def write_lp(A: Any, b: Any, c: Any, path: Path) -> tuple[bool, bool]:
    """Write ``min c'x s.t. A x >= b`` (``x`` free, :func:`highs_lp`) to the model file
    ``path`` with HiGHS (the format from the suffix: ``.mps``, ``.lp``).

    Returns
    -------
    (accepted, written) : (bool, bool)
        Whether HiGHS accepted the model (``passModel`` not ``kError``; nothing is written
        otherwise) and whether ``writeModel`` reported success. ``kWarning`` counts as
        success: HiGHS names the unnamed columns ``c0..`` and rows ``r0..``. The caller
        words the failure (:mod:`lpbounds.studies.export`).
    """
    import highspy

    h = quiet_highs()
    if h.passModel(highs_lp(A, b, c)) == highspy.HighsStatus.kError:
        return False, False
    return True, h.writeModel(str(path)) != highspy.HighsStatus.kError


def accepted_option_values(option: str, values: tuple[Any, ...]) -> tuple[Any, ...]:
    """The ``values`` of the HiGHS option ``option`` that the installed highspy accepts
    (``setOptionValue`` returns ``kOk``), in the order given."""
    import highspy

    h = quiet_highs()  # no banner on stdout
    return tuple(v for v in values if h.setOptionValue(option, v) == highspy.HighsStatus.kOk)


# ---------------------------------------------------------------------------- one run
#: HiGHS' model statuses (``HighsModelStatus`` member names) in lpbounds' vocabulary, before
#: the certificate has its say: the one place they are mapped (:func:`status_of`). Every
#: member of highspy 1.16's ``HighsModelStatus`` is listed; the statuses with no point
#: (not yet solved, an error of the load, model, presolve, solve or postsolve, an empty
#: model, out of memory) are SOLVER_ERROR, as is a name a later highspy adds.
STATUS_MAP: dict[str, Status] = {
    "kNotset": Status.SOLVER_ERROR,
    "kLoadError": Status.SOLVER_ERROR,
    "kModelError": Status.SOLVER_ERROR,
    "kPresolveError": Status.SOLVER_ERROR,
    "kSolveError": Status.SOLVER_ERROR,
    "kPostsolveError": Status.SOLVER_ERROR,
    "kModelEmpty": Status.SOLVER_ERROR,
    "kMemoryLimit": Status.SOLVER_ERROR,
    "kOptimal": Status.OPTIMAL,
    "kTimeLimit": Status.TIME_LIMIT,
    "kIterationLimit": Status.ITERATION_LIMIT,
    "kObjectiveBound": Status.LIMIT,
    "kObjectiveTarget": Status.LIMIT,
    "kSolutionLimit": Status.LIMIT,
    "kInterrupt": Status.LIMIT,
    "kHighsInterrupt": Status.LIMIT,
    "kUnknown": Status.INACCURATE,
    "kInfeasible": Status.INFEASIBLE,
    "kUnboundedOrInfeasible": Status.INFEASIBLE,
    "kUnbounded": Status.UNBOUNDED,
}


def status_of(model_status: str, default: Status = Status.SOLVER_ERROR) -> Status:
    """The :class:`~lpbounds.status.Status` of a HiGHS model status (its member name, as
    ``Highs.getModelStatus().name``); ``default`` for a name not in :data:`STATUS_MAP`."""
    return STATUS_MAP.get(model_status, default)


@dataclass
class HighsRun:
    """What one ``Highs.run()`` returned.

    ``status`` maps HiGHS' model status (``model_status``, its name) through
    :func:`status_of`; ``x`` and ``y`` (row duals, ``>= 0`` on ``>=`` rows of a
    minimisation) are ``None`` when HiGHS has no valid primal solution (a limit hit before
    the first iterate, an error), ``y`` also when HiGHS has no valid dual solution.

    Two iteration counts, kept apart because lpbounds reports both: ``iterations`` is the
    sum of HiGHS' simplex, IPM, crossover and PDLP counts (each clipped at 0: HiGHS reports
    -1 for a method it did not run), what an :class:`~lpbounds.formulations.LPResult`
    reports; ``simplex_iterations`` is HiGHS' ``simplex_iteration_count`` as HiGHS gives
    it, what the NLP's cut loop counts. ``objective`` is HiGHS' own objective value
    (``info.objective_function_value``, not certified).
    """

    status: Status
    model_status: str
    x: np.ndarray | None
    y: np.ndarray | None
    iterations: int
    seconds: float
    objective: float = float("nan")
    simplex_iterations: int = 0


def set_options(h: Any, options: dict[str, Any], verbose: bool) -> None:
    """Pass ``options`` to HiGHS by name (``highs_options={...}`` unpacked, as cvxpy does).

    Raises
    ------
    ValidationError
        Naming the option HiGHS rejects (unknown name or a value of the wrong type or range).
    """
    h.setOptionValue("output_flag", bool(verbose))
    for key, value in _unpacked(options).items():
        ok = _option_ok(h, key, value)
        if not ok:
            raise ValidationError(
                f"HiGHS rejected the option {key}={value!r} (unknown name, or a value of "
                "the wrong type or range; HiGHS' options: https://ergo-code.github.io/HiGHS/"
                "dev/options/definitions/)"
            )


def _unpacked(options: dict[str, Any]) -> dict[str, Any]:
    """``options`` with the entries of ``highs_options`` moved to the top level (as cvxpy)."""
    opts = dict(options)
    opts.update(opts.pop("highs_options", None) or {})
    return opts


def _option_ok(h: Any, key: str, value: Any) -> bool:
    import highspy

    if isinstance(value, (bool, np.bool_)):
        value = bool(value)
    elif isinstance(value, (np.integer,)):
        value = int(value)
    elif isinstance(value, (np.floating,)):
        value = float(value)
    try:
        return bool(h.setOptionValue(str(key), value) != highspy.HighsStatus.kError)
    except (TypeError, ValueError):
        return False


def run_highs(h: Any) -> HighsRun:
    """Run the model passed to ``h`` and read back its status, point, duals, objective and
    iteration counts (:class:`HighsRun`)."""
    t0 = time.perf_counter()
    h.run()
    seconds = time.perf_counter() - t0
    name = h.getModelStatus().name
    sol = h.getSolution()
    info = h.getInfo()
    iters = sum(
        max(0, int(getattr(info, k)))
        for k in (
            "simplex_iteration_count", "ipm_iteration_count", "crossover_iteration_count",
            "pdlp_iteration_count",
        )
    )  # fmt: skip
    has_x = bool(sol.value_valid)
    x = np.array(sol.col_value, dtype=np.float64) if has_x else None
    y = np.array(sol.row_dual, dtype=np.float64) if has_x and sol.dual_valid else None
    return HighsRun(
        status_of(name), name, x, y, iters, seconds,
        objective=float(info.objective_function_value),
        simplex_iterations=int(info.simplex_iteration_count),
    )  # fmt: skip


def tight_basis(n_rows: int, n_cols: int, tight_rows: np.ndarray) -> Any:
    """The basis of a policy: every column basic, ``tight_rows`` at their lower bound.

    For a row system with one tight row per variable (the rows a policy picks), the
    other rows' slacks are basic: ``n_cols + (n_rows - len(tight_rows)) = n_rows`` basic
    variables, and the basis matrix is ``I - lambda P_pi`` on the tight rows (nonsingular
    for ``lambda < 1``). Its primal solution is the policy's value, its dual solution the
    policy's discounted occupation measure ``(I - lambda P_pi)^{-T} c``; for an optimal
    policy both are feasible, so the simplex method stops at once (see
    :meth:`lpbounds.formulations.RowsLP.solve`, ``warm_start="policy"``).
    """
    import highspy

    k = highspy.HighsBasisStatus
    tight = np.asarray(tight_rows, dtype=np.int64)
    if tight.shape != (n_cols,):
        raise ValidationError(
            f"a basis needs one tight row per variable ({n_cols}); got {tight.shape}"
        )
    code = np.zeros(n_rows, dtype=np.int8)
    code[tight] = 1
    if int(code.sum()) != n_cols:
        raise ValidationError("the tight rows of a basis must be distinct")
    pick = np.array([k.kBasic, k.kLower], dtype=object)
    basis = highspy.HighsBasis()
    basis.col_status = list(np.full(n_cols, k.kBasic, dtype=object))
    basis.row_status = list(pick[code])
    basis.valid = True
    return basis


# ---------------------------------------------------------------------------- cvxpy adapter
def _dual_ray(h: Any, n_rows: int) -> tuple[Any, bool, np.ndarray]:
    """HiGHS' dual ray of an infeasible LP in cvxpy's row sense (``<=``; ours are ``>=``).
    highspy before 1.8 has no ``getDualRay``: then no ray (NaN), which newer cvxpy reads
    as dual values it cannot certify and 1.6 does not read at all."""
    if not hasattr(h, "getDualRay"):
        return None, False, np.full(n_rows, np.nan)
    st, has_ray, ray = h.getDualRay()
    return st, bool(has_ray), -np.asarray(ray, dtype=np.float64)


class CvxpyHighs(_CvxpyHIGHS):
    """cvxpy's HiGHS interface, passing the inequality rows as ``>=`` rows.

    cvxpy's cone form is ``A_d x <= b_d`` (``A x >= b`` becomes ``-A x <= -b``), and its
    HiGHS interface hands HiGHS exactly that: rows ``-inf <= -A x <= -b``. The LP is the
    same, but HiGHS' interior point method (IPX) is sensitive to the sense of the rows: on
    the paper's UBLP it takes 42 iterations on the ``<=`` rows and 30 on ``A x >= b``
    (on its RLP 27 and 42: the direction depends on the instance). This adapter writes the
    rows as ``-A_d x >= -b_d`` (``A x >= b`` again, equality rows unchanged), so the cvxpy
    path and ``backend="highspy"`` run HiGHS on the same LP, and maps the row duals back
    to cvxpy's sign, so ``constraint.dual_value`` is as with ``solver="HIGHS"``.
    LP only (no integer variables); :meth:`model_status` keeps HiGHS' own status, which
    cvxpy folds into ``USER_LIMIT`` for every limit.
    """

    def __init__(self) -> None:
        super().__init__()
        self.model_status: str = "kNotset"

    def name(self) -> str:
        return "HIGHS_ROWS"

    def solve_via_data(
        self,
        data: dict[str, Any],
        warm_start: bool,
        verbose: bool,
        solver_opts: dict[str, Any],
        solver_cache: Any = None,
    ) -> dict[str, Any]:
        import cvxpy.settings as s
        from cvxpy.error import SolverError as CvxpySolverError
        from cvxpy.reductions.solvers.conic_solvers.conic_solver import dims_to_solver_dict

        if data.get(s.BOOL_IDX) or data.get(s.INT_IDX):
            raise CvxpySolverError("HIGHS_ROWS solves LPs only")
        n_eq = int(dims_to_solver_dict(data[s.DIMS])[s.EQ_DIM])
        b = np.asarray(data[s.B], dtype=np.float64)
        lp = _LpArrays.of(-data[s.A], -b, data[s.C])
        if n_eq:
            lp.row_upper[:n_eq] = -b[:n_eq]
        if data.get(s.LOWER_BOUNDS) is not None:
            lp.col_lower = np.asarray(data[s.LOWER_BOUNDS], dtype=np.float64)
        if data.get(s.UPPER_BOUNDS) is not None:
            lp.col_upper = np.asarray(data[s.UPPER_BOUNDS], dtype=np.float64)
        h = quiet_highs()
        set_options(h, solver_opts, verbose)  # a ValidationError is a ValueError, as cvxpy expects
        lp.pass_to(h)
        h.run()
        sol = h.getSolution()
        self.model_status = h.getModelStatus().name
        results: dict[str, Any] = {
            # cvxpy's invert negates row_dual (its <= rows); ours are >= rows
            "solution": SimpleNamespace(
                col_value=sol.col_value, row_dual=-np.asarray(sol.row_dual, dtype=np.float64)
            ),
            "info": h.getInfo(),
            "model_status": self.model_status,
            "run_time": h.getRunTime(),
        }
        if self.model_status == "kInfeasible":
            results["dual_ray"] = _dual_ray(h, b.size)
        return results
