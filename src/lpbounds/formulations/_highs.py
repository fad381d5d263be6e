r"""The highspy backend: ``min c'x s.t. A x >= b`` (x free) handed to HiGHS directly.

:func:`highs_lp` builds a :class:`highspy.HighsLp` from a formulation's stored data
``(A, b, c)`` (``A`` CSR): rows ``b <= A x <= +inf``, columns free, the matrix column-wise
(HiGHS' own storage). :func:`pass_lp` passes the same LP to a ``Highs`` through HiGHS'
array interface (ten times faster than filling a ``HighsLp`` at 10M nonzeros).
:func:`quiet_highs` is :func:`lpbounds._quiet.quiet_highs` (a ``Highs`` with its output
off), re-exported so a caller needs one import. :class:`CvxpyHighs` is the cvxpy solver
adapter the cvxpy path uses for HiGHS; :func:`run_highs`, :func:`set_options` and
:func:`tight_basis` are the steps of one solve.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np
import scipy.sparse as sp
from cvxpy.reductions.solvers.conic_solvers.highs_conif import HIGHS as _CvxpyHIGHS

from .._quiet import quiet_highs
from ..errors import SolverError, ValidationError
from ..status import Status

__all__ = [
    "STATUS_MAP",
    "CvxpyHighs",
    "HighsRun",
    "highs_lp",
    "pass_lp",
    "quiet_highs",
    "run_highs",
    "set_options",
    "tight_basis",
]


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


# ---------------------------------------------------------------------------- one run
#: HiGHS' model statuses in lpbounds' vocabulary (before the certificate has its say).
STATUS_MAP: dict[str, Status] = {
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


@dataclass
class HighsRun:
    """What one ``Highs.run()`` returned.

    ``status`` maps HiGHS' model status (``model_status``, its name) through
    :data:`STATUS_MAP` (anything else: SOLVER_ERROR); ``x`` and ``y`` (row duals, ``>= 0``
    on ``>=`` rows of a minimisation) are ``None`` when HiGHS has no valid primal
    solution (a limit hit before the first iterate, an error).
    """

    status: Status
    model_status: str
    x: np.ndarray | None
    y: np.ndarray | None
    iterations: int
    seconds: float


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
    """Run the model passed to ``h`` and read back its status, point and duals."""
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
    return HighsRun(STATUS_MAP.get(name, Status.SOLVER_ERROR), name, x, y, iters, seconds)


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


class CvxpyHighs(_CvxpyHIGHS):  # type: ignore[misc,valid-type]
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
