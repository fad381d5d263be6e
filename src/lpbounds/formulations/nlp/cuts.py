r"""Balas' disjunctive cutting planes for the NLP (eq. 25): master LP, cut-generating LP, loop.

The NLP's feasible set is ``F = {w : w(i) >= min_{t in (i,u)} q_t(w) for every (i, u)}``
with ``q_t(w) = rho_t + lambda sum_l p_{t,l} w(k_{t,l})``; each (i, u) with ``T >= 2``
terms is the disjunction ``OR_t  a_t'w >= b_t`` (``a_t = e_i - lambda P_t``, ``b_t = rho_t``).
The (i, u) are those of ``nlp.rows``: with action sets, only the ``u`` allowed at every
state of ``S_i`` ("Action sets" in :mod:`lpbounds.rows.aggregation`), so the master, the
CGLP and the box ``[min rho, max rho] / (1 - lambda)`` are all built from the masked rows.

The loop's own bracket (master bound, strategy values) is reported in the log and in
``NLPResult.extra["method_bracket"]``; the result's certified bounds come from the
returned incumbent alone (:meth:`lpbounds.formulations.nlp.problem.NLP.certify`).

Master LP (a relaxation of ``F`` intersected with the box, valid for ``w*``)
    ``min c'w  s.t.  G w >= h,  lo <= w <= hi`` where ``G w >= h`` holds the (i, u) with a
    single term (ordinary rows) and the cuts added so far, and ``lo = min rho / (1 -
    lambda)``, ``hi = max rho / (1 - lambda)`` (``w*`` is the value of a game with rewards
    ``rho``, so it lies in the box).

Cut-generating LP (lift-and-project, Balas 1979; Balas, Ceria & Cornuejols 1993)
    For a disjunction violated by the master's point ``wbar``, with the master's
    polyhedron written as ``Gf w >= hf`` (``G``, then the box as ``I w >= lo``,
    ``-I w >= -hi``; by default ``G`` keeps only the single-term rows and the cuts binding
    at ``wbar``, ``cglp_rows="binding"``)::

        min   wbar'alpha - beta
        s.t.  alpha = Gf'u_t + v_t a_t            for every term t   (Farkas)
              beta <= hf'u_t + v_t b_t            for every term t
              sum_t (1'u_t + v_t) = 1             (the normalisation)
              u_t >= 0, v_t >= 0;  alpha, beta free.

    Every feasible ``(alpha, beta)`` gives ``alpha'w >= beta`` valid on each term's
    polyhedron ``Q_t = {Gf w >= hf, a_t'w >= b_t}``, hence on their union; a negative
    optimum is the deepest cut (under this normalisation) separating ``wbar``.

Making the cuts valid (``/work/shared/notes/nlp-cutting-planes.md``)
    With this normalisation the CGLP's ``alpha`` are tiny (1e-6..1e-8), so the solver's
    absolute tolerances are large relative errors in ``beta``: cuts taken straight from
    it were measured to cut off the optimum. Each cut is therefore

    1. rescaled to ``max_j |alpha_j| = 1``;
    2. given the right-hand side ``beta = min_t L_t`` where ``L_t`` is a *weak-duality*
       lower bound on ``min {alpha'w : w in Q_t}``: solve that LP (one per term; the T
       LPs are independent and are solved together as one block-diagonal LP) and, from
       any multipliers ``y >= 0`` of its rows ``A_t w >= r_t`` (clipped to ``>= 0``),
       ``L_t = r_t'y + sum_j min((alpha - A_t'y)_j lo_j, (alpha - A_t'y)_j hi_j)``.
       That holds for *every* ``y >= 0`` (Lagrangian relaxation over the box), so it
       does not depend on the solver's accuracy, and equals the minimum when ``y`` is
       optimal. ``Q_t`` is never empty: ``w = hi 1`` satisfies every row (``hi(1 -
       lambda) = max rho``) and therefore every valid cut.
    3. lowered by ``NLP_CUT_SAFETY_RTOL * max(1, |beta|)`` for rounding.

    Every master optimum is then a lower bound on ``c'w*``; it is reported through the
    same weak-duality bound on the master (never the solver's objective value).

The upper side of the bracket: at each master point ``wbar`` the minimiser's strategy
``sigma(i,u) = argmin_t q_t(wbar)`` is evaluated exactly (the least element of its row
system, Fact 1 in :mod:`lpbounds.rows.system`); that point is feasible for the NLP (after the
``residual / (1 - lambda)`` shift that makes it so in floating point), so ``c'`` of it is
an upper bound.

Solvers: :class:`NLPMaster`, :class:`CutGeneratingLP` and :class:`TermLP` are cvxpy model
classes (:class:`~lpbounds.formulations.base.Formulation`) built from the same sparse
data as the loop's HiGHS models; ``backend="highspy"`` keeps one persistent HiGHS master
(cuts are appended, the simplex warm-starts) and solves the CGLP and term LPs with
``highspy`` directly, ``backend="cvxpy"`` solves every LP cold through cvxpy (any
installed LP solver; much slower). The tests check one against the other.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ...errors import SolverError, ValidationError
from ...status import Status
from ...tolerances import (
    NLP_CUT_MIN_DEPTH_RTOL,
    NLP_CUT_SAFETY_RTOL,
    NLP_HIGHS_FEAS_TOL,
    NLP_VIOLATION_RTOL,
)
from ..base import Formulation, resolve_solver
from ..highs import (
    add_rows,
    clear_model,
    pass_bounded_lp,
    quiet_highs,
    run_highs,
    set_options,
)
from .results import NLPIteration
from .stop import StopReason

if TYPE_CHECKING:
    from .problem import NLP

__all__ = [
    "CutGeneratingLP",
    "CutLoopOutput",
    "GeneralLP",
    "HighsSolution",
    "LPData",
    "NLPMaster",
    "PersistentMaster",
    "TermLP",
    "cutting_planes",
    "highs_solve",
    "loop_highs",
    "weak_duality_bound",
]

INF = np.inf
#: The CGLP normalisations (see :func:`cglp_data`).
NORMALIZATIONS: tuple[str, ...] = ("multipliers", "alpha")


# ---------------------------------------------------------------------- LP data
@dataclass
class LPData:
    """``min c'x  s.t.  row_lo <= A x <= row_hi,  col_lo <= x <= col_hi`` (inf allowed)."""

    c: np.ndarray
    A: sp.csr_matrix
    row_lo: np.ndarray
    row_hi: np.ndarray
    col_lo: np.ndarray
    col_hi: np.ndarray

    def to_geq(self) -> tuple[sp.csr_matrix, np.ndarray]:
        """The same polyhedron as ``A' x >= b'`` (finite sides only), for :class:`Formulation`."""
        n = self.A.shape[1]
        eye = sp.identity(n, format="csr")
        parts_a, parts_b = [], []
        for mat, lo, hi in ((self.A, self.row_lo, self.row_hi), (eye, self.col_lo, self.col_hi)):
            fl, fh = np.isfinite(lo), np.isfinite(hi)
            if fl.any():
                parts_a.append(mat[np.flatnonzero(fl)])
                parts_b.append(lo[fl])
            if fh.any():
                parts_a.append(-mat[np.flatnonzero(fh)])
                parts_b.append(-hi[fh])
        return sp.vstack(parts_a, format="csr"), np.concatenate(parts_b)


def weak_duality_bound(data: LPData, row_dual: np.ndarray) -> float:
    r"""A lower bound on ``min c'x`` over ``data`` (``>=`` rows and a finite box), from any duals.

    For rows ``A x >= r`` (``row_hi = inf``) and ``lo <= x <= hi``, every ``y >= 0`` gives
    ``min c'x >= r'y + sum_j min((c - A'y)_j lo_j, (c - A'y)_j hi_j)`` (Lagrangian
    relaxation of the rows over the box), whatever the solver's accuracy; ``y`` is the
    solver's row duals clipped to ``>= 0``. Equals the optimum at exact optimal duals.
    """
    if np.isfinite(data.row_hi).any() or not (
        np.isfinite(data.col_lo).all() and np.isfinite(data.col_hi).all()
    ):
        raise ValidationError("weak_duality_bound needs >= rows and a finite box")
    y = np.maximum(np.asarray(row_dual, dtype=np.float64), 0.0)
    red = data.c - data.A.T @ y
    return float(data.row_lo @ y + np.minimum(red * data.col_lo, red * data.col_hi).sum())


# ---------------------------------------------------------------------- highspy
@dataclass
class HighsSolution:
    """What the loop needs from one LP solve (highspy, or cvxpy for ``backend="cvxpy"``).

    ``status`` is lpbounds' :class:`~lpbounds.status.Status` (HiGHS' model status mapped
    by :func:`lpbounds.formulations.highs.status_of`; ``model_status`` keeps HiGHS' own
    name, empty for a cvxpy solve). ``objective`` is the solver's own (not certified).
    ``iterations`` is HiGHS' ``simplex_iteration_count`` (``HighsRun.simplex_iterations``;
    cvxpy: the solver's count), the loop's count since it was written: not the sum over
    HiGHS' methods that an LP result reports. ``x`` and ``row_dual`` are ``nan`` where
    HiGHS has no valid primal or dual solution (never read unless ``status`` is OPTIMAL).
    """

    status: Status
    x: np.ndarray
    row_dual: np.ndarray
    objective: float
    iterations: int
    model_status: str = ""


def loop_highs() -> Any:
    """A quiet ``Highs`` (:func:`~lpbounds.formulations.highs.quiet_highs`) set up for the
    loop's LPs: presolve off, feasibility tolerances :data:`NLP_HIGHS_FEAS_TOL`."""
    h = quiet_highs()  # output_flag off, and HiGHS' banner to the log, not stdout
    # the loop's LPs are small and solved thousands of times: presolve costs more than
    # it saves (measured on a 250-cut master: 5x on the joint term LP, 2x on the CGLP)
    set_options(
        h,
        {
            "presolve": "off",
            "primal_feasibility_tolerance": NLP_HIGHS_FEAS_TOL,
            "dual_feasibility_tolerance": NLP_HIGHS_FEAS_TOL,
        },
        verbose=False,
    )
    return h


def _pass(h: Any, data: LPData) -> None:
    pass_bounded_lp(h, data.c, data.A, data.row_lo, data.row_hi, data.col_lo, data.col_hi)


def _solution(h: Any, n_cols: int, n_rows: int) -> HighsSolution:
    """Run ``h`` (:func:`~lpbounds.formulations.highs.run_highs`) and read the loop's view."""
    run = run_highs(h)
    return HighsSolution(
        status=run.status,
        x=run.x if run.x is not None else np.full(n_cols, np.nan),
        row_dual=run.y if run.y is not None else np.full(n_rows, np.nan),
        objective=run.objective,
        iterations=run.simplex_iterations,
        model_status=run.model_status,
    )


def highs_solve(data: LPData, h: Any = None) -> HighsSolution:
    """Solve ``data`` cold with highspy (:func:`loop_highs`); ``h``: a ``Highs`` to reuse."""
    if h is None:
        h = loop_highs()
    else:
        clear_model(h)
    _pass(h, data)
    n_rows, n_cols = data.A.shape
    return _solution(h, n_cols, n_rows)


class PersistentMaster:
    """The master LP as one HiGHS model; cuts are appended and the simplex warm-starts.

    Attributes
    ----------
    data : LPData
        The master so far (its rows: the single-term rows, then the cuts).
    h : highspy.Highs
        The HiGHS model of ``data`` (:func:`loop_highs`).
    """

    def __init__(self, data: LPData) -> None:
        self.data = data
        self.h = loop_highs()
        _pass(self.h, data)

    def add_cuts(self, alpha: np.ndarray, beta: np.ndarray) -> None:
        """Append the cuts ``alpha w >= beta`` (one per row of ``alpha``)."""
        add_rows(self.h, alpha, beta)
        self.data = _append_rows(self.data, alpha, beta)

    def solve(self) -> HighsSolution:
        """Run HiGHS on the master as it stands (warm-started from the last basis)."""
        n_rows, n_cols = self.data.A.shape
        return _solution(self.h, n_cols, n_rows)


def _append_rows(data: LPData, alpha: np.ndarray, beta: np.ndarray) -> LPData:
    return LPData(
        c=data.c,
        A=sp.vstack([data.A, sp.csr_matrix(alpha)], format="csr"),
        row_lo=np.concatenate([data.row_lo, beta]),
        row_hi=np.concatenate([data.row_hi, np.full(len(beta), INF)]),
        col_lo=data.col_lo,
        col_hi=data.col_hi,
    )


# ---------------------------------------------------------------------- model data
def master_data(
    c: np.ndarray, G: sp.csr_matrix, h: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> LPData:
    """``min c'w  s.t.  G w >= h,  lo <= w <= hi``."""
    return LPData(
        c=np.asarray(c, dtype=np.float64),
        A=sp.csr_matrix(G),
        row_lo=np.asarray(h, dtype=np.float64),
        row_hi=np.full(G.shape[0], INF),
        col_lo=np.asarray(lo, dtype=np.float64),
        col_hi=np.asarray(hi, dtype=np.float64),
    )


def cglp_data(
    wbar: np.ndarray,
    G: sp.csr_matrix,
    h: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    a_terms: sp.csr_matrix,
    b_terms: np.ndarray,
    normalization: str = "multipliers",
) -> LPData:
    """The lift-and-project CGLP (module docstring) in variables ``[alpha, beta, (u_t, v_t)_t]``.

    The master polyhedron is ``Gf w >= hf`` with ``Gf = [G; I; -I]``, ``hf = [h; lo; -hi]``.
    ``normalization="multipliers"``: ``sum_t (1'u_t + v_t) = 1``; ``"alpha"``: ``-1 <=
    alpha <= 1`` instead (the optimum is then the violation of the cut in the units of
    ``max|alpha| = 1``, the scale in which the cut is used). Built directly in COO form
    (vectorised over the terms).
    """
    if normalization not in NORMALIZATIONS:
        raise ValidationError(
            f"normalization must be one of {NORMALIZATIONS}; got {normalization!r}"
        )
    m_vars = G.shape[1]
    n_terms = a_terms.shape[0]
    eye = sp.identity(m_vars, format="csr")
    gf = sp.vstack([sp.csr_matrix(G), eye, -eye], format="coo")
    hf = np.concatenate([h, lo, -hi])
    m_rows = gf.shape[0]
    n_mult = m_rows + 1  # u_t then v_t
    off = m_vars + 1 + n_mult * np.arange(n_terms)  # first column of (u_t, v_t)
    at = sp.coo_matrix(a_terms)
    t_idx = np.arange(n_terms)
    n_eq = n_terms * m_vars
    # equality rows t*M + j:  alpha_j - (Gf'u_t)_j - v_t a_{t,j} = 0
    r_alpha = np.arange(n_eq)
    c_alpha = np.tile(np.arange(m_vars), n_terms)
    r_gf = (t_idx[:, None] * m_vars + gf.col[None, :]).ravel()
    c_gf = (off[:, None] + gf.row[None, :]).ravel()
    v_gf = np.tile(-gf.data, n_terms)
    r_at = at.row * m_vars + at.col
    c_at = off[at.row] + m_rows
    # rows n_eq + t:  hf'u_t + v_t b_t - beta >= 0
    nz = np.flatnonzero(hf)
    r_h = np.repeat(n_eq + t_idx, nz.size)
    c_h = (off[:, None] + nz[None, :]).ravel()
    v_h = np.tile(hf[nz], n_terms)
    r_norm = n_eq + n_terms
    n_cols = m_vars + 1 + n_terms * n_mult
    mult_cols = np.arange(m_vars + 1, n_cols)
    rows = np.concatenate(
        [r_alpha, r_gf, r_at, r_h, n_eq + t_idx, n_eq + t_idx, np.full(mult_cols.size, r_norm)]
    )
    cols = np.concatenate(
        [c_alpha, c_gf, c_at, c_h, off + m_rows, np.full(n_terms, m_vars), mult_cols]
    )
    vals = np.concatenate(
        [
            np.ones(n_eq),
            v_gf,
            -at.data,
            v_h,
            np.asarray(b_terms, dtype=np.float64),
            -np.ones(n_terms),
            np.ones(mult_cols.size),
        ]
    )
    a = sp.csr_matrix((vals, (rows, cols)), shape=(r_norm + 1, n_cols))
    c = np.zeros(n_cols)
    c[:m_vars] = wbar
    c[m_vars] = -1.0
    data = LPData(
        c=c,
        A=a,
        row_lo=np.r_[np.zeros(n_eq), np.zeros(n_terms), 1.0],
        row_hi=np.r_[np.zeros(n_eq), np.full(n_terms, INF), 1.0],
        col_lo=np.r_[np.full(m_vars + 1, -INF), np.zeros(n_terms * n_mult)],
        col_hi=np.full(n_cols, INF),
    )
    if normalization == "alpha":
        data.A = data.A[:-1]
        data.row_lo, data.row_hi = data.row_lo[:-1], data.row_hi[:-1]
        data.col_lo[:m_vars] = -1.0
        data.col_hi[:m_vars] = 1.0
    return data


def term_lps_data(
    alpha: np.ndarray,
    G: sp.csr_matrix,
    h: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    a_terms: sp.csr_matrix,
    b_terms: np.ndarray,
) -> list[LPData]:
    """One LP per term: ``min alpha'w  s.t.  G w >= h,  a_t'w >= b_t,  lo <= w <= hi``."""
    return [
        master_data(alpha, sp.vstack([G, a_terms[t]], format="csr"), np.r_[h, b_terms[t]], lo, hi)
        for t in range(a_terms.shape[0])
    ]


def joint_term_data(
    alpha: np.ndarray,
    G: sp.csr_matrix,
    h: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    a_terms: sp.csr_matrix,
    b_terms: np.ndarray,
) -> LPData:
    """The term LPs of :func:`term_lps_data` as one block-diagonal LP (block ``t`` = term ``t``).

    The blocks share no variable or row, so the joint optimum is the blocks' optima side
    by side and each block's duals certify its own minimum (:func:`block_bounds`).
    """
    n_terms = a_terms.shape[0]
    g = sp.vstack([sp.csr_matrix(G), sp.csr_matrix((1, G.shape[1]))], format="csr")
    base = sp.kron(sp.identity(n_terms, format="csr"), g, format="csr")
    m_vars, k = G.shape[1], g.shape[0]
    at = sp.coo_matrix(a_terms)
    extra = sp.csr_matrix(
        (at.data, (at.row * k + k - 1, at.row * m_vars + at.col)), shape=base.shape
    )
    rlo = np.tile(np.r_[h, 0.0], n_terms)
    rlo[k - 1 :: k] = b_terms
    return LPData(
        c=np.tile(alpha, n_terms),
        A=(base + extra).tocsr(),
        row_lo=rlo,
        row_hi=np.full(n_terms * k, INF),
        col_lo=np.tile(lo, n_terms),
        col_hi=np.tile(hi, n_terms),
    )


def block_bounds(joint: LPData, row_dual: np.ndarray, n_terms: int) -> np.ndarray:
    """Per-block weak-duality lower bounds (see :func:`weak_duality_bound`) of a joint term LP."""
    y = np.maximum(np.asarray(row_dual, dtype=np.float64), 0.0)
    red = joint.c - joint.A.T @ y
    box = np.minimum(red * joint.col_lo, red * joint.col_hi).reshape(n_terms, -1).sum(axis=1)
    return (joint.row_lo * y).reshape(n_terms, -1).sum(axis=1) + box


# ---------------------------------------------------------------------- cvxpy models
class GeneralLP(Formulation):
    """A cvxpy model class of :class:`LPData` (converted to ``A x >= b``; variable ``x``)."""

    name = "LP"

    def __init__(
        self,
        data: LPData,
        name: str | None = None,
        *,
        variables: list[tuple[str, int]] | None = None,
        groups: list[tuple[str, int]] | None = None,
    ) -> None:
        self.data = data
        a, b = data.to_geq()
        super().__init__(a, b, data.c, name, variables=variables, groups=groups)


class NLPMaster(GeneralLP):
    r"""The cutting-plane master ``min c'w s.t. G w >= h, lo <= w <= hi`` (relaxes eq. 25).

    ``G w >= h``: the NLP's single-term (i, u) as ordinary rows and the cuts so far. Its
    optimum is a lower bound on ``c'w*`` as long as every cut is valid.

    Attributes
    ----------
    problem : cvxpy.Problem
        ``min c-bar'w  s.t.  single, cuts, box_lower, box_upper``.
    w : cvxpy.Variable (M,)
        The paper's ``w`` (``variables["w"]``); kept when cuts are added.
    constraints : dict
        ``"single"``: eq. 25 for the (i, u) with one term (an ordinary Bellman row
        ``w(i) >= rho_t + lambda sum_l p_l w(k_l)``); ``"cuts"``: the disjunctive cuts
        ``alpha'w >= beta`` so far (valid for every term of eq. 25's disjunctions; absent
        before the first round); ``"box_lower"``/``"box_upper"``: ``lo <= w <= hi``.
        Each is one sparse vector constraint.
    n_single : int
        The number of single-term rows (the rows of ``data`` before the cuts).
    """

    name = "NLP-master"

    def __init__(self, data: LPData, n_single: int | None = None) -> None:
        n_rows, m = data.A.shape
        self.n_single = n_rows if n_single is None else int(n_single)
        finite = bool(
            np.isfinite(data.row_lo).all()
            and np.isinf(data.row_hi).all()
            and np.isfinite(data.col_lo).all()
            and np.isfinite(data.col_hi).all()
        )
        if not finite:
            raise ValidationError("the NLP master needs >= rows and a finite box")
        super().__init__(data, variables=[("w", m)], groups=self._groups(n_rows, m))

    def _groups(self, n_rows: int, m: int) -> list[tuple[str, int]]:
        return [
            ("single", self.n_single),
            ("cuts", n_rows - self.n_single),
            ("box_lower", m),
            ("box_upper", m),
        ]

    @property
    def w(self) -> Any:
        """The cvxpy variable ``w``."""
        return self.variables["w"]

    @property
    def n_cuts(self) -> int:
        """Cuts in the master so far."""
        return int(self.data.A.shape[0] - self.n_single)

    @classmethod
    def build(
        cls, c: np.ndarray, G: sp.csr_matrix, h: np.ndarray, lo: np.ndarray, hi: np.ndarray
    ) -> NLPMaster:
        """The master of ``min c'w  s.t.  G w >= h,  lo <= w <= hi`` (no cuts yet)."""
        return cls(master_data(c, G, h, lo, hi))

    def add_cuts(self, alpha: np.ndarray, beta: np.ndarray) -> None:
        """Append the cuts ``alpha w >= beta`` (one per row): the same variable ``w``, a new
        ``"cuts"`` group and :attr:`problem` rebuilt around them."""
        alpha = np.atleast_2d(np.asarray(alpha, dtype=np.float64))
        beta = np.atleast_1d(np.asarray(beta, dtype=np.float64))
        self.data = _append_rows(self.data, alpha, beta)
        a, b = self.data.to_geq()
        self.A, self.b = sp.csr_matrix(a), np.asarray(b, dtype=np.float64)
        n_rows, m = self.data.A.shape
        rows = {}
        start = 0
        for k, size in self._groups(n_rows, m):
            if size:
                rows[k] = slice(start, start + size)
            start += size
        self.constraint_rows = rows
        self.constraints = {k: self._group(s) for k, s in rows.items()}
        self.problem = cp.Problem(self.problem.objective, list(self.constraints.values()))


class CutGeneratingLP(GeneralLP):
    """The lift-and-project CGLP of one disjunction (see :func:`cglp_data`)."""

    name = "NLP-CGLP"

    @classmethod
    def build(cls, *args: Any) -> CutGeneratingLP:
        return cls(cglp_data(*args))


class TermLP(GeneralLP):
    """``min alpha'w`` over one term's polyhedron (the exact right-hand side of a cut)."""

    name = "NLP-term"


# ---------------------------------------------------------------------- backends
class _Backend:
    """Solves the loop's LPs; returns primal points and row duals of the ``LPData`` rows."""

    def __init__(self, kind: str, solver: str, options: dict[str, Any]) -> None:
        if kind not in ("highspy", "cvxpy"):
            raise ValidationError(f"backend must be 'highspy' or 'cvxpy'; got {kind!r}")
        self.kind = kind
        self.solver = resolve_solver(solver)
        if kind == "highspy" and self.solver != "HIGHS":
            raise ValidationError(
                f"backend='highspy' solves with HiGHS; for solver={solver!r} use backend='cvxpy'"
            )
        self.options = options
        self.master: PersistentMaster | None = None
        self.model: NLPMaster | None = None
        self.master_data: LPData | None = None
        self.scratch = loop_highs() if kind == "highspy" else None

    def _cvxpy(
        self, data: LPData, cls: type[GeneralLP] = GeneralLP, model: GeneralLP | None = None
    ) -> HighsSolution:
        model = cls(data) if model is None else model
        res = model.solve(self.solver, raise_on_failure=False, **self.options)
        if not res.ok:
            return HighsSolution(res.status, res.x, np.zeros(data.A.shape[0]), np.nan, 0)
        # map the >= duals of to_geq back to data's rows (finite lower sides first)
        y = res.duals
        fl, fh = np.isfinite(data.row_lo), np.isfinite(data.row_hi)
        row_dual = np.zeros(data.A.shape[0])
        k = int(fl.sum())
        row_dual[fl] += y[:k]
        row_dual[fh] -= y[k : k + int(fh.sum())]
        return HighsSolution(Status.OPTIMAL, res.x, row_dual, res.objective, res.iterations or 0)

    def start_master(self, model: NLPMaster) -> None:
        """Solve ``model`` round by round (highspy: a persistent copy of it, kept in step)."""
        self.model = model
        self.master_data = model.data
        if self.kind == "highspy":
            self.master = PersistentMaster(model.data)

    def add_cuts(self, alpha: np.ndarray, beta: np.ndarray) -> None:
        assert self.master_data is not None and self.model is not None
        self.model.add_cuts(alpha, beta)
        if self.master is not None:
            self.master.add_cuts(alpha, beta)
        self.master_data = self.model.data

    def solve_master(self) -> HighsSolution:
        assert self.master_data is not None and self.model is not None
        if self.master is not None:
            return self.master.solve()
        return self._cvxpy(self.master_data, model=self.model)

    def solve(self, data: LPData, cls: type[GeneralLP] = GeneralLP) -> HighsSolution:
        if self.kind == "highspy":
            return highs_solve(data, self.scratch)
        return self._cvxpy(data, cls)

    def term_bounds(self, args: tuple[Any, ...]) -> np.ndarray:
        """Weak-duality lower bounds of each term LP (``nan`` where a solve failed)."""
        n_terms = args[-2].shape[0]
        out = np.full(n_terms, np.nan)
        if self.kind == "highspy":
            joint = joint_term_data(*args)
            sol = highs_solve(joint, self.scratch)
            if sol.status is Status.OPTIMAL:
                out[:] = block_bounds(joint, sol.row_dual, n_terms)
            return out
        for t, p in enumerate(term_lps_data(*args)):
            sol = self._cvxpy(p, TermLP)
            if sol.status is Status.OPTIMAL:
                out[t] = weak_duality_bound(p, sol.row_dual)
        return out


# ---------------------------------------------------------------------- the loop
@dataclass
class CutLoopOutput:
    """What :func:`cutting_planes` hands back to :meth:`NLP.solve`.

    ``master`` is the loop's master LP as a cvxpy model with every round's cuts (the NLP
    stores it as :attr:`NLP.master`); ``stop_reason`` one of :class:`StopReason`'s
    ``GAP_CLOSED``, ``MAX_ROUNDS``, ``TIME_LIMIT``, ``NO_VIOLATED_DISJUNCTION``,
    ``NO_CUT_FOUND``.
    """

    lower: float
    upper: float
    best_point: np.ndarray
    master_point: np.ndarray
    rounds: int
    cuts: int
    converged: bool
    stop_reason: StopReason
    log: list[NLPIteration]
    cut_alpha: np.ndarray
    cut_beta: np.ndarray
    master_objective: float
    cuts_in_last_master: int
    master: NLPMaster


def _check_loop_options(
    max_rounds: int, cuts_per_round: int, cglp_rows: str, normalization: str
) -> None:
    """The cut loop's own options, checked before anything is built."""
    if max_rounds < 1:
        raise ValidationError(f"max_rounds must be >= 1; got {max_rounds}")
    if normalization not in NORMALIZATIONS:
        raise ValidationError(
            f"normalization must be one of {NORMALIZATIONS}; got {normalization!r}"
        )
    if cglp_rows not in ("all", "binding"):
        raise ValidationError(f"cglp_rows must be 'all' or 'binding'; got {cglp_rows!r}")
    if cuts_per_round < 1:
        raise ValidationError(f"cuts_per_round must be >= 1; got {cuts_per_round}")


def _separating_cuts(
    be: _Backend,
    nlp: NLP,
    sol: HighsSolution,
    wbar: np.ndarray,
    cand: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    n_single: int,
    cglp_rows: str,
    normalization: str,
) -> tuple[list[np.ndarray], list[float]]:
    """One round's cuts: a CGLP per violated disjunction in ``cand`` at the master's point
    ``wbar``, each cut ``alpha' w >= beta`` with ``beta`` certified by the term LPs over the
    whole master and kept only when it cuts ``wbar`` off by more than the minimum depth."""
    assert be.master_data is not None
    m = nlp.rows.n_vars
    scale = nlp.scale
    viol_tol = NLP_VIOLATION_RTOL * scale
    depth_tol = NLP_CUT_MIN_DEPTH_RTOL * scale
    starts = nlp.disj_start
    a_all, b_all = nlp.term_matrix
    new_a: list[np.ndarray] = []
    new_b: list[float] = []
    G, h = be.master_data.A, be.master_data.row_lo
    # cglp_rows="binding": the CGLP sees only the single-term rows and the cuts
    # binding at wbar (a relaxation of the master, so its cuts are valid all the
    # same, possibly weaker); the certified right-hand side below always uses the
    # whole master
    slack = G @ wbar - h
    keep = np.flatnonzero(
        (np.arange(G.shape[0]) < n_single)
        | (sol.row_dual > 0)
        | (slack <= viol_tol)
        | (cglp_rows == "all")
    )
    gk, hk = G[keep], h[keep]
    for d in cand:
        sl = slice(starts[d], starts[d + 1])
        at, bt = a_all[sl], b_all[sl]
        cg = be.solve(cglp_data(wbar, gk, hk, lo, hi, at, bt, normalization), CutGeneratingLP)
        if cg.status is not Status.OPTIMAL or not cg.objective < 0:
            continue
        alpha = cg.x[:m].copy()
        s = float(np.abs(alpha).max())
        if not s > 0:
            continue
        alpha /= s
        bounds = be.term_bounds((alpha, G, h, lo, hi, at, bt))
        if np.isnan(bounds).any():
            continue  # a term LP failed: no certified right-hand side, no cut
        beta = float(bounds.min())
        beta -= NLP_CUT_SAFETY_RTOL * max(1.0, abs(beta))
        if beta - float(alpha @ wbar) > depth_tol:
            new_a.append(alpha)
            new_b.append(beta)
    return new_a, new_b


def cutting_planes(
    nlp: NLP,
    *,
    solver: str = "HIGHS",
    backend: str = "highspy",
    gap_rtol: float,
    max_rounds: int = 200,
    cuts_per_round: int = 10,
    time_limit: float | None = None,
    cglp_rows: str = "binding",
    normalization: str = "multipliers",
    on_round: Callable[[NLPIteration], None] | None = None,
    **options: Any,
) -> CutLoopOutput:
    """Run the disjunctive cutting-plane loop on ``nlp`` (see the module docstring).

    ``nlp`` is read only (its public structure: rows, cost, box, terms, strategies); the
    master the loop builds is returned in :attr:`CutLoopOutput.master`.
    """
    _check_loop_options(max_rounds, cuts_per_round, cglp_rows, normalization)
    t0 = time.perf_counter()
    be = _Backend(backend, solver, options)
    rows = nlp.rows
    m = rows.n_vars
    c = nlp.cost
    lo = np.full(m, nlp.box[0])
    hi = np.full(m, nlp.box[1])
    a_all, b_all = nlp.term_matrix
    single = nlp.single_rows
    n_single = single.size
    # the master as a cvxpy model (nlp.master), updated with every round's cuts
    master = NLPMaster(master_data(c, a_all[single], b_all[single], lo, hi), n_single)
    be.start_master(master)
    scale = nlp.scale
    # the gap is measured in the problem's units, sum(c) max|R| / (1 - lambda): an absolute
    # max(1, |upper|) would call a 10 % gap closed when the rewards are of order 1e-6
    gap_unit = gap_rtol * float(c.sum()) * scale
    viol_tol = NLP_VIOLATION_RTOL * scale
    starts, sizes = nlp.disj_start, nlp.disj_size
    multi = np.flatnonzero(sizes >= 2)

    lower, upper = -np.inf, np.inf
    best = np.full(m, nlp.box[1])
    upper = float(c @ best)
    log: list[NLPIteration] = []
    all_alpha: list[np.ndarray] = []
    all_beta: list[float] = []
    converged = False
    stop = StopReason.MAX_ROUNDS
    wbar = best
    master_obj = np.nan
    n_cuts = 0
    cuts_in_master = 0
    for rnd in range(1, max_rounds + 1):
        sol = be.solve_master()
        if sol.status is not Status.OPTIMAL:
            raise SolverError(
                f"NLP cutting planes: master LP status {sol.model_status or sol.status} in "
                f"round {rnd}"
            )
        assert be.master_data is not None
        wbar = np.clip(sol.x, lo, hi)
        master_obj = sol.objective
        cuts_in_master = n_cuts
        lower = max(lower, weak_duality_bound(be.master_data, sol.row_dual))
        # upper side: the minimiser's strategy at wbar, evaluated exactly
        v, ub = nlp.strategy_upper_bound(nlp.best_terms(wbar))
        if ub < upper:
            upper, best = ub, v
        gap = upper - lower
        # separation
        q = rows.q_values(wbar)
        viol = np.minimum.reduceat(q, starts[:-1]) - wbar[nlp.disj_owner]
        cand = multi[viol[multi] > viol_tol]
        cand = cand[np.argsort(-viol[cand], kind="stable")][:cuts_per_round]
        done = gap <= gap_unit
        new_a: list[np.ndarray] = []
        new_b: list[float] = []
        if not done:
            new_a, new_b = _separating_cuts(
                be, nlp, sol, wbar, cand, lo, hi, n_single, cglp_rows, normalization
            )
        entry = NLPIteration(
            iteration=rnd,
            lower=lower,
            upper=upper,
            gap=gap,
            cuts_added=len(new_a),
            seconds=time.perf_counter() - t0,
            max_violation=float(max(viol[multi].max(initial=0.0), 0.0)),
            master_objective=master_obj,
        )
        log.append(entry)
        if on_round is not None:
            on_round(entry)
        if done:
            converged, stop = True, StopReason.GAP_CLOSED
            break
        if not new_a:
            stop = StopReason.NO_VIOLATED_DISJUNCTION if cand.size == 0 else StopReason.NO_CUT_FOUND
            break
        if time_limit is not None and time.perf_counter() - t0 > time_limit:
            stop = StopReason.TIME_LIMIT
            break
        alpha_mat = np.vstack(new_a)
        beta_vec = np.asarray(new_b)
        be.add_cuts(alpha_mat, beta_vec)
        all_alpha.append(alpha_mat)
        all_beta.extend(new_b)
        n_cuts += len(new_a)
    return CutLoopOutput(
        lower=lower,
        upper=upper,
        best_point=best,
        master_point=wbar,
        rounds=len(log),
        cuts=n_cuts,
        converged=converged,
        stop_reason=stop,
        log=log,
        cut_alpha=np.vstack(all_alpha) if all_alpha else np.zeros((0, m)),
        cut_beta=np.asarray(all_beta),
        master_objective=master_obj,
        cuts_in_last_master=cuts_in_master,
        master=master,
    )
