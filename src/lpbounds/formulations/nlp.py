r"""The disjunctive lower-bound program NLP (paper Section 3.3, eq. 23-25).

.. math:: NLP := \min \bar c^T w \quad\text{s.t.}\quad
          w(i) \ge \min_{x \in S_i} \Big\{ R_u(x) + \lambda \sum_{l=0}^m p_l\,
          w(\bar f(x, u, Y_l)) \Big\} \quad \forall u,\ i = 1..M.   \qquad (25)

Its optimum ``w*`` satisfies ``w*(i) <= min_{x in S_i} V*(x)`` (the paper: ``w-bar(i) =
min_{S_i} V*`` is feasible, eq. 24). The minimum over ``x in S_i`` only ranges over the
distinct successor tuples of ``T(i, u)`` (the *terms*; for equal tuples the smallest
reward is kept): ``BellmanRows.aggregate(mdp, partition, reduce="min")``.

**The optimum does not depend on the cost.** By Fact 2 of :mod:`lpbounds.rows`, the
feasible set ``G = {w : w(i) >= min_{t in (i,u)} q_t(w)}`` has a least element ``w*``,
the fixed point of ``(Gw)(i) = max_u min_t q_t(w)`` (a zero-sum game: the controller
picks ``u``, an adversary the term): if ``w`` is feasible then ``w >= Gw >= G^2 w >= ...
-> w*``. Hence ``c'w >= c'w*`` for every feasible ``w`` and every ``c >= 0``, with
equality only at ``w = w*`` when ``c > 0``. So one solve gives ``w*`` and with it the
bound for every partition at once; the paper's one program per partition (``c-bar = e_i``)
is not needed. (For ``c >= 0`` with zeros the optimal *value* is still ``c'w*`` but the
minimiser need not be ``w*``; the methods below still return ``w*`` except the MILP and
the cutting planes, whose ``values`` are then only optimal in ``c'w``.)

Four methods (``NLP.solve(method=...)``), each returning :class:`NLPResult` with a
bracket ``lower_bound <= c'w* <= upper_bound`` and an iteration log:

``"cutting-planes"``
    Balas' disjunctive (lift-and-project) cuts on a master LP relaxation; every master
    optimum is a certified lower bound, strategies read off the master points give the
    upper bound. See :mod:`lpbounds.formulations.nlp_cuts` for the CGLP, its
    normalisation and how each cut is made valid.
``"strategy-iteration"``
    Fix one term per disjunction (the minimiser's strategy ``sigma``), solve that row
    system exactly (its least element ``v_sigma``, Fact 1), switch each disjunction to
    its smallest term at ``v_sigma``, repeat. ``v_sigma`` is feasible, so every iterate
    is an upper bound; they decrease (``T_{sigma'} v_sigma <= v_sigma`` makes ``v_sigma``
    feasible for ``sigma'``) and the method is finite (a strategy never repeats).
``"milp"``
    Big-M: a binary ``z_t`` per term of each multi-term disjunction, ``sum_t z_t = 1``,
    ``a_t'w >= b_t - M_t (1 - z_t)`` with ``M_t = max(0, b_t - min_{lo <= w <= hi}
    a_t'w)`` (the term's largest possible violation on the box ``lo = min rho / (1 -
    lambda) <= w <= hi = max rho / (1 - lambda)``, which contains ``w*``). Solved with
    cvxpy + HiGHS; the chosen strategy is then evaluated exactly.
``"fixed-point"``
    :func:`lpbounds.dp.solve_game`: value iteration on ``w = Gw``.

Every result also carries ``residual = ||G w - w||_inf`` of its ``values`` and
``error_bound = residual / (1 - lambda)``: ``w - error_bound <= w* <= w + error_bound``
componentwise (``x = w - delta`` satisfies ``x <= Gx``, hence ``x <= w*``), so
``lower_values`` is a certified lower bound on ``min_{S_i} V*``, whatever the method.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Literal

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..dp import _threads_for, solve_exact, solve_game
from ..errors import ConvergenceError, SolverError, ValidationError
from ..mdp import FiniteMDP
from ..partition import Partition
from ..rows import BellmanRows
from ..tolerances import NLP_GAP_RTOL, NLP_MILP_GAP_RTOL, NLP_SWITCH_RTOL, dp_scale
from .base import aggregated_cost, resolve_solver

__all__ = ["NLP", "NLPIteration", "NLPResult"]

Method = Literal["cutting-planes", "strategy-iteration", "milp", "fixed-point"]
METHODS: tuple[str, ...] = ("cutting-planes", "strategy-iteration", "milp", "fixed-point")

#: Exact solves (fixed points of strategies and of G) stop at this relative residual.
_EXACT_RTOL = 1e-13


@dataclass
class NLPIteration:
    """One entry of the iteration log (``nan`` where a method has no such number)."""

    iteration: int
    lower: float
    upper: float
    gap: float
    cuts_added: int
    seconds: float
    max_violation: float = float("nan")
    master_objective: float = float("nan")


@dataclass
class NLPResult:
    """The outcome of :meth:`NLP.solve`.

    Attributes
    ----------
    formulation : str
        "NLP".
    method : str
    values : ndarray (M,)
        The method's point: ``w*`` up to ``error_bound`` (for the cutting planes, the best
        feasible point found, the incumbent of the upper bound).
    state_values : ndarray (n,)
        ``Phi values``.
    lower_values : ndarray (M,)
        ``values - error_bound``: certified ``<= w*(i) <= min_{x in S_i} V*(x)``.
    lower_bound, upper_bound : float
        The method's bracket on ``c'w*`` (``-inf``/``inf`` if it has no such side).
    gap : float
        ``upper_bound - lower_bound``.
    converged : bool
        Whether the method reached its stopping rule (for the cutting planes: the gap
        closed to ``gap_rtol``); ``False`` means stalled or stopped at a limit, see
        ``stop_reason``.
    stop_reason : str
    objective : float
        ``c'values``.
    residual : float
        ``||G values - values||_inf``.
    error_bound : float
        ``residual / (1 - discount)``: ``|values - w*| <= error_bound`` componentwise.
    iterations : int
        Rounds (cutting planes), strategies evaluated (strategy iteration), value
        iterations (fixed point), 1 (MILP).
    cuts : int
        Cuts added (cutting planes only).
    seconds : float
    log : list of NLPIteration
    cost : ndarray (M,)
        The partition cost ``c-bar``.
    solver : str
    gap_rtol : float
        The relative gap the method was asked for (cutting planes).
    extra : dict
        Method-specific data (the cuts, the MILP's raw point and status, ...).
    """

    formulation: str
    method: str
    values: np.ndarray
    state_values: np.ndarray
    lower_values: np.ndarray
    lower_bound: float
    upper_bound: float
    gap: float
    converged: bool
    stop_reason: str
    objective: float
    residual: float
    error_bound: float
    iterations: int
    cuts: int
    seconds: float
    log: list[NLPIteration]
    cost: np.ndarray
    solver: str
    gap_rtol: float
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def relative_gap(self) -> float:
        """``gap / max(1, |upper_bound|)``."""
        return self.gap / max(1.0, abs(self.upper_bound))

    def summary(self) -> str:
        """One line: method, bracket, gap, rounds, cuts, time, convergence."""
        return (
            f"NLP[{self.method}] c'w* in [{self.lower_bound:.10g}, {self.upper_bound:.10g}] "
            f"gap {self.gap:.3e} after {self.iterations} iterations, {self.cuts} cuts, "
            f"{self.seconds:.3f} s; {'converged' if self.converged else 'NOT converged'} "
            f"({self.stop_reason})"
        )


class NLP:
    r"""The disjunctive lower-bound program (eq. 25) of ``mdp`` under ``partition``.

    ``min c-bar'w  s.t.  w(i) >= min_{x in S_i} [R_u(x) + lambda sum_l p_l w(f-bar(x, u,
    Y_l))]`` for every (i, u); its optimum ``w*`` bounds ``V*`` from below on each
    partition: ``w*(i) <= min_{x in S_i} V*(x)``. ``w*`` is the same for every cost
    ``c > 0`` (module docstring, Fact 2 of :mod:`lpbounds.rows`).

    Parameters
    ----------
    mdp : FiniteMDP
    partition : Partition
    cost : array_like (n_states,), optional
        State weights ``c(x) >= 0`` (default all ones); ``c-bar(i) = sum_{S_i} c(x)``.
    partition_cost : array_like (M,), optional
        ``c-bar`` directly (instead of ``cost``).

    Attributes
    ----------
    rows : BellmanRows
        The terms, sorted by (owner, action): ``aggregate(mdp, partition, "min")``.
    disj_start : ndarray (D + 1,)
        Disjunction ``d`` = the (owner, action) pair whose terms are rows
        ``disj_start[d]:disj_start[d+1]``.
    disj_owner, disj_action, disj_size : ndarray (D,)
    cost : ndarray (M,)
    box : (float, float)
        ``(min rho / (1 - lambda), max rho / (1 - lambda))``: contains ``w*``.
    """

    name = "NLP"

    def __init__(
        self,
        mdp: FiniteMDP,
        partition: Partition,
        cost: Any = None,
        *,
        partition_cost: Any = None,
    ) -> None:
        if not isinstance(mdp, FiniteMDP):
            raise ValidationError(f"mdp must be a FiniteMDP; got {type(mdp).__name__}")
        if not isinstance(partition, Partition):
            raise ValidationError(f"partition must be a Partition; got {type(partition).__name__}")
        cbar = aggregated_cost(mdp, partition, cost, partition_cost)
        self.mdp = mdp
        self.partition = partition
        self.cost = cbar
        self.rows = BellmanRows.aggregate(mdp, partition, reduce="min")
        r = self.rows
        new = np.r_[True, (r.owner[1:] != r.owner[:-1]) | (r.action[1:] != r.action[:-1])]
        first = np.flatnonzero(new)
        self.disj_start = np.r_[first, r.n_rows].astype(np.int64)
        self.disj_owner = r.owner[first].astype(np.int64)
        self.disj_action = r.action[first].astype(np.int64)
        self.disj_size = np.diff(self.disj_start)
        self.disj_of_row = np.repeat(np.arange(first.size), self.disj_size)
        lam = r.discount
        self.box = (float(r.reward.min()) / (1 - lam), float(r.reward.max()) / (1 - lam))
        self.scale = dp_scale(float(np.abs(r.reward).max(initial=0.0)), lam)
        self._term_matrix: tuple[sp.csr_matrix, np.ndarray] | None = None

    # ------------------------------------------------------------------ structure
    @property
    def n_disjunctions(self) -> int:
        """Number of (partition, action) pairs ``D``."""
        return int(self.disj_size.size)

    @property
    def single_rows(self) -> np.ndarray:
        """Rows of the disjunctions with one term (ordinary LP rows)."""
        return self.disj_start[:-1][self.disj_size == 1]

    @property
    def term_matrix(self) -> tuple[sp.csr_matrix, np.ndarray]:
        """``(A, b)``: term ``t`` is ``a_t'w >= b_t`` (``A = E - lambda P``, ``b = rho``)."""
        if self._term_matrix is None:
            self._term_matrix = self.rows.constraint_matrix()
        return self._term_matrix

    def __repr__(self) -> str:
        return (
            f"NLP(partitions={self.rows.n_vars}, disjunctions={self.n_disjunctions}, "
            f"terms={self.rows.n_rows}, multi-term={int((self.disj_size >= 2).sum())})"
        )

    # ------------------------------------------------------------------ operators
    def game_operator(self, w: Any) -> np.ndarray:
        """``(Gw)(i) = max_u min_t q_t(w)``."""
        return self.rows.apply_maxmin(w)[0]

    def residual(self, w: Any) -> float:
        """``||G w - w||_inf``."""
        ww = self.rows._vec(w)
        return float(np.abs(self.game_operator(ww) - ww).max())

    def best_terms(self, w: np.ndarray, current: np.ndarray | None = None) -> np.ndarray:
        """The minimiser's strategy at ``w``: per disjunction the row of its smallest term.

        With ``current``, a disjunction keeps its current term unless another is smaller
        by more than ``NLP_SWITCH_RTOL * scale``.
        """
        q = self.rows.q_values(w)
        starts = self.disj_start[:-1]
        qmin = np.minimum.reduceat(q, starts)
        is_min = q <= qmin[self.disj_of_row]
        idx = np.flatnonzero(is_min)
        _, first = np.unique(self.disj_of_row[idx], return_index=True)
        sel = idx[first]
        if current is not None:
            keep = q[current] <= qmin + NLP_SWITCH_RTOL * self.scale
            sel = np.where(keep, current, sel)
        return sel.astype(np.int64)

    def strategy_rows(self, sel: np.ndarray) -> BellmanRows:
        """The row system of strategy ``sel`` (one row per disjunction)."""
        r = self.rows
        return BellmanRows.from_arrays(
            r.owner[sel],
            r.action[sel],
            r.reward[sel],
            r.targets[sel],
            np.asarray(r.probs)[sel],
            r.discount,
            r.n_vars,
        )

    def strategy_value(self, sel: np.ndarray) -> tuple[np.ndarray, float]:
        """``v_sigma`` (the least element of the strategy's rows) and ``||T_sigma v - v||_inf``."""
        sub = self.strategy_rows(sel)
        res = solve_exact(sub, method="pi", tol=_EXACT_RTOL * self.scale, evaluation="direct")
        v = res.values
        return v, float(np.abs(sub.apply_max(v)[0] - v).max())

    def strategy_upper_bound(self, sel: np.ndarray) -> tuple[np.ndarray, float]:
        """``(v_sigma, c'v_sigma + sum(c) residual / (1 - lambda))``: a certified upper bound.

        ``v + residual / (1 - lambda)`` satisfies the strategy's rows, hence the NLP's.
        """
        v, res = self.strategy_value(sel)
        lam = self.rows.discount
        return v, float(self.cost @ v + self.cost.sum() * res / (1 - lam))

    # ------------------------------------------------------------------ solve
    def solve(
        self,
        method: Method = "cutting-planes",
        *,
        solver: str = "HIGHS",
        gap_rtol: float = NLP_GAP_RTOL,
        max_iter: int | None = None,
        cuts_per_round: int = 10,
        backend: str = "highspy",
        time_limit: float | None = None,
        cglp_rows: str = "binding",
        normalization: str = "multipliers",
        progress: bool = False,
        raise_on_failure: bool = False,
        **solver_options: Any,
    ) -> NLPResult:
        """Solve the NLP with ``method``.

        Parameters
        ----------
        method : {"cutting-planes", "strategy-iteration", "milp", "fixed-point"}
        solver : str
            LP/MILP solver through cvxpy ("HIGHS" default). The cutting planes with
            ``backend="highspy"`` require HIGHS; strategy iteration and the fixed point
            use no solver.
        gap_rtol : float
            Cutting planes: stop when ``upper - lower <= gap_rtol * max(1, |upper|)``.
        max_iter : int, optional
            Rounds (cutting planes, default 200), strategies (strategy iteration, default
            10,000) or value iterations (fixed point, default 100,000).
        cuts_per_round : int
            Cutting planes: at most this many cuts a round (the most violated
            disjunctions first).
        backend : {"highspy", "cvxpy"}
            Cutting planes: a persistent HiGHS master (fast), or every LP cold through
            cvxpy with ``solver``.
        time_limit : float, optional
            Cutting planes: stop after this many seconds.
        cglp_rows : {"binding", "all"}
            Cutting planes: the master rows the cut-generating LP is built on: the
            single-term rows and the cuts binding at the master's point (default), or all
            of them. Measured (docs/nlp.md): the same rounds and cuts on 3 of 4 instances,
            and up to 4x less time, since the CGLP no longer grows with every cut.
        normalization : {"multipliers", "alpha"}
            Cutting planes: the CGLP's normalisation, ``sum(u) + sum(v) = 1`` (default)
            or ``max|alpha| <= 1`` (see :func:`~lpbounds.formulations.nlp_cuts.cglp_data`).
        progress : bool
            Show a rich progress bar (on stderr) with the bracket.
        raise_on_failure : bool
            Raise :class:`~lpbounds.errors.ConvergenceError` when the method does not
            converge (default: return with ``converged=False``).
        **solver_options
            Passed to the solver (cvxpy backends and the MILP).

        Returns
        -------
        NLPResult
        """
        if method not in METHODS:
            raise ValidationError(f"unknown NLP method {method!r}; choose one of {METHODS}")
        if not (gap_rtol >= 0 and np.isfinite(gap_rtol)):
            raise ValidationError(f"gap_rtol must be a finite number >= 0; got {gap_rtol}")
        if max_iter is not None and max_iter < 1:
            raise ValidationError(f"max_iter must be >= 1; got {max_iter}")
        t0 = time.perf_counter()
        with _progress_bar(progress, method, max_iter) as tick, _threads_for(self.rows):
            if method == "cutting-planes":
                out = self._cutting_planes(
                    solver,
                    gap_rtol,
                    max_iter or 200,
                    cuts_per_round,
                    backend,
                    time_limit,
                    cglp_rows,
                    normalization,
                    tick,
                    solver_options,
                )
            elif method == "strategy-iteration":
                out = self._strategy_iteration(max_iter or 10_000, tick)
            elif method == "milp":
                out = self._milp(solver, tick, solver_options)
            else:
                out = self._fixed_point(max_iter or 100_000, tick)
        out.seconds = time.perf_counter() - t0
        out.gap_rtol = gap_rtol
        if raise_on_failure and not out.converged:
            raise ConvergenceError(out.summary())
        return out

    # ------------------------------------------------------------------ helpers
    def _result(self, method: str, values: np.ndarray, **kw: Any) -> NLPResult:
        values = np.asarray(values, dtype=np.float64)
        res = self.residual(values)
        err = res / (1 - self.rows.discount)
        lower = kw.pop("lower_bound", -np.inf)
        upper = kw.pop("upper_bound", np.inf)
        return NLPResult(
            formulation="NLP",
            method=method,
            values=values,
            state_values=self.partition.lift(values),
            lower_values=values - err,
            lower_bound=float(lower),
            upper_bound=float(upper),
            gap=float(upper - lower),
            objective=float(self.cost @ values),
            residual=res,
            error_bound=err,
            cost=self.cost,
            seconds=0.0,
            gap_rtol=np.nan,
            **kw,
        )

    def _residual_bracket(self, w: np.ndarray) -> tuple[float, float, np.ndarray]:
        """Porteus bounds of ``c'w*`` from one application of ``G`` at ``w``.

        With ``r = Gw - w``: ``Gw + lambda min r / (1 - lambda) <= w* <= Gw + lambda max r
        / (1 - lambda)`` componentwise (``G`` is monotone and ``G(w + k) = Gw + lambda k``).
        """
        gw = self.game_operator(w)
        r = gw - w
        k = self.rows.discount / (1 - self.rows.discount)
        base = float(self.cost @ gw)
        s = float(self.cost.sum())
        return base + s * k * float(r.min()), base + s * k * float(r.max()), gw

    # ------------------------------------------------------------------ methods
    def _fixed_point(self, max_iter: int, tick: Callable[..., None]) -> NLPResult:
        t0 = time.perf_counter()
        log: list[NLPIteration] = []
        s = float(self.cost.sum())
        lam = self.rows.discount

        def cb(it: int, res: float) -> None:
            # the residual alone bounds the bracket's width: 2 sum(c) res / (1 - lambda)
            e = NLPIteration(
                it, np.nan, np.nan, 2 * s * res / (1 - lam), 0, time.perf_counter() - t0
            )
            log.append(e)
            tick(e)

        dp = solve_game(
            self.rows,
            tol=_EXACT_RTOL * self.scale,
            max_iter=max_iter,
            callback=cb,
            raise_on_failure=False,
        )
        lo, hi, _ = self._residual_bracket(dp.values)
        if log:
            log[-1].lower, log[-1].upper, log[-1].gap = lo, hi, hi - lo
        return self._result(
            "fixed-point",
            dp.values,
            lower_bound=lo,
            upper_bound=hi,
            converged=dp.converged,
            stop_reason="residual <= tol" if dp.converged else "max_iter",
            iterations=dp.iterations,
            cuts=0,
            log=log,
            solver="none (value iteration)",
            extra={"tol": dp.tol, "sweeps": dp.sweeps},
        )

    def _strategy_iteration(self, max_iter: int, tick: Callable[..., None]) -> NLPResult:
        t0 = time.perf_counter()
        log: list[NLPIteration] = []
        sel = self.best_terms(np.full(self.rows.n_vars, self.box[1]))
        upper = np.inf
        converged = False
        v = np.full(self.rows.n_vars, self.box[1])
        it = 0
        for it in range(1, max_iter + 1):
            v, ub = self.strategy_upper_bound(sel)
            upper = min(upper, ub)
            new = self.best_terms(v, current=sel)
            e = NLPIteration(it, np.nan, upper, np.nan, 0, time.perf_counter() - t0)
            log.append(e)
            tick(e)
            if np.array_equal(new, sel):
                converged = True
                break
            sel = new
        lo, hi, _ = self._residual_bracket(v)
        upper = min(upper, hi)
        log[-1].lower, log[-1].upper, log[-1].gap = lo, upper, upper - lo
        return self._result(
            "strategy-iteration",
            v,
            lower_bound=lo,
            upper_bound=upper,
            converged=converged,
            stop_reason="strategy stable" if converged else "max_iter",
            iterations=it,
            cuts=0,
            log=log,
            solver="none (exact evaluation)",
            extra={"strategy": sel},
        )

    def _milp(self, solver: str, tick: Callable[..., None], options: dict[str, Any]) -> NLPResult:
        t0 = time.perf_counter()
        name = resolve_solver(solver)
        # a feasible point bounds w* from above (Fact 2): it shrinks the box and the big-Ms
        v0, _ = self.strategy_value(self.best_terms(np.full(self.rows.n_vars, self.box[1])))
        r0 = float((self.game_operator(v0) - v0).max())
        upper = v0 + max(r0, 0.0) / (1 - self.rows.discount)  # >= w*: (G - I) at it <= 0
        model = NLPMILP(self, upper=upper)
        opts = dict(options)
        if name == "HIGHS":
            opts.setdefault("mip_rel_gap", NLP_MILP_GAP_RTOL)
            opts.setdefault("mip_abs_gap", NLP_MILP_GAP_RTOL * self.scale)
        try:
            model.problem.solve(solver=name, **opts)
        except cp.SolverError as exc:
            raise SolverError(f"NLP milp with {name}: {exc}") from exc
        if model.problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            raise SolverError(f"NLP milp with {name}: status {model.problem.status}")
        w_raw = np.asarray(model.w.value, dtype=np.float64)
        z = np.asarray(model.z.value, dtype=np.float64) if model.z is not None else np.zeros(0)
        # the MILP's strategy: per multi-term disjunction the term with the largest z
        sel = self.disj_start[:-1].copy()
        multi = np.flatnonzero(self.disj_size >= 2)
        if multi.size:
            zz = np.full(self.rows.n_rows, -np.inf)
            zz[model.multi_rows] = z
            best = np.maximum.reduceat(zz, self.disj_start[:-1])
            is_best = zz >= best[self.disj_of_row]
            idx = np.flatnonzero(is_best)
            _, first = np.unique(self.disj_of_row[idx], return_index=True)
            sel = idx[first]
        v, ub = self.strategy_upper_bound(sel)
        # the bracket: the solver's MIP dual bound is not passed on by cvxpy for HiGHS (and
        # is only as good as its tolerances), so both sides come from the polished point:
        # its strategy's value (upper) and the Porteus bounds of G at it (module docstring)
        stats = model.problem.solver_stats
        extra = getattr(stats, "extra_stats", None)
        dual_bound = np.nan
        if isinstance(extra, dict) and "mip_dual_bound" in extra:  # e.g. SCIPY
            dual_bound = float(extra["mip_dual_bound"])
        lower, hi, _ = self._residual_bracket(v)
        upper = min(ub, hi)
        e = NLPIteration(1, lower, upper, upper - lower, 0, time.perf_counter() - t0)
        tick(e)
        return self._result(
            "milp",
            v,
            lower_bound=lower,
            upper_bound=upper,
            converged=model.problem.status == cp.OPTIMAL,
            stop_reason=str(model.problem.status),
            iterations=1,
            cuts=0,
            log=[e],
            solver=name,
            extra={
                "w_milp": w_raw,
                "milp_objective": float(model.problem.value),
                "mip_dual_bound": dual_bound,
                "strategy": sel,
                "big_m": model.big_m,
            },
        )

    def _cutting_planes(
        self,
        solver: str,
        gap_rtol: float,
        max_rounds: int,
        cuts_per_round: int,
        backend: str,
        time_limit: float | None,
        cglp_rows: str,
        normalization: str,
        tick: Callable[..., None],
        options: dict[str, Any],
    ) -> NLPResult:
        from .nlp_cuts import cutting_planes

        out = cutting_planes(
            self,
            solver=solver,
            backend=backend,
            gap_rtol=gap_rtol,
            max_rounds=max_rounds,
            cuts_per_round=cuts_per_round,
            time_limit=time_limit,
            cglp_rows=cglp_rows,
            normalization=normalization,
            on_round=tick,
            **options,
        )
        return self._result(
            "cutting-planes",
            out.best_point,
            lower_bound=out.lower,
            upper_bound=out.upper,
            converged=out.converged,
            stop_reason=out.stop_reason,
            iterations=out.rounds,
            cuts=out.cuts,
            log=out.log,
            solver="HIGHS (highspy, persistent)" if backend == "highspy" else f"{solver} (cvxpy)",
            extra={
                "cut_alpha": out.cut_alpha,
                "cut_beta": out.cut_beta,
                "master_point": out.master_point,
                "master_objective": out.master_objective,
                "cuts_in_last_master": out.cuts_in_last_master,
                "box": self.box,
            },
        )


class NLPMILP:
    r"""The big-M MILP of the NLP (a cvxpy model class).

    ``min c'w`` s.t. the single-term rows ``a_r'w >= b_r``; for each term ``t`` of a
    multi-term disjunction ``a_t'w >= b_t - M_t (1 - z_t)``, ``z_t`` binary and
    ``sum_{t in d} z_t = 1``; ``lo <= w <= hi``. ``M_t = max(0, b_t - min_{lo <= w <= hi}
    a_t'w)``: with ``z_t = 0`` the row is implied by the box, so the MILP's feasible set
    is exactly the NLP's inside the box, which contains ``w*``.

    ``lo = min rho / (1 - lambda)`` and, by default, ``hi = max rho / (1 - lambda)`` (the
    box of :attr:`NLP.box`). ``upper`` may replace ``hi`` by any NLP-feasible point: a
    feasible ``v`` satisfies ``v >= w*`` (Fact 2), so the box still contains ``w*`` and the
    MILP's optimum is unchanged, while the smaller ``M_t`` tighten its relaxation
    (:meth:`NLP.solve` passes the value of one strategy: 3-6x faster on a 30-state,
    6-partition garnet).
    """

    def __init__(self, nlp: NLP, upper: np.ndarray | None = None) -> None:
        a, b = nlp.term_matrix
        m = nlp.rows.n_vars
        lo = np.full(m, nlp.box[0])
        hi = np.full(m, nlp.box[1]) if upper is None else np.minimum(upper, nlp.box[1])
        single = nlp.single_rows
        multi_mask = np.repeat(nlp.disj_size >= 2, nlp.disj_size)
        self.multi_rows = np.flatnonzero(multi_mask)
        am = a[self.multi_rows]
        bm = b[self.multi_rows]
        pos = am.maximum(0)
        neg = am.minimum(0)
        box_min = pos @ lo + neg @ hi
        self.big_m = np.maximum(0.0, bm - box_min)
        self.lo, self.hi = lo, hi
        self.w = cp.Variable(m, name="w")
        cons = [self.w >= lo, self.w <= hi]
        if single.size:
            cons.append(a[single] @ self.w >= b[single])
        self.z: cp.Variable | None = None
        if self.multi_rows.size:
            self.z = cp.Variable(self.multi_rows.size, boolean=True, name="z")
            cons.append(am @ self.w - sp.diags(self.big_m) @ self.z >= bm - self.big_m)
            d_of = nlp.disj_of_row[self.multi_rows]
            _, d_idx = np.unique(d_of, return_inverse=True)
            s = sp.csr_matrix(
                (np.ones(d_idx.size), (d_idx, np.arange(d_idx.size))),
                shape=(int(d_idx.max()) + 1, d_idx.size),
            )
            cons.append(s @ self.z == 1)
        self.problem = cp.Problem(cp.Minimize(nlp.cost @ self.w), cons)


@contextmanager
def _progress_bar(enabled: bool, method: str, total: int | None) -> Iterator[Callable[..., None]]:
    """A rich progress bar showing the bracket; a no-op when disabled."""
    if not enabled:
        yield lambda e: None
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(
        TextColumn(f"NLP {method}"),
        BarColumn(),
        TextColumn("{task.fields[status]}"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
        transient=True,
    ) as prog:
        task = prog.add_task(method, total=total, status="")

        def tick(e: NLPIteration) -> None:
            prog.update(
                task,
                completed=e.iteration,
                status=f"it {e.iteration}  [{e.lower:.6g}, {e.upper:.6g}]  gap {e.gap:.2e}"
                + (f"  cuts +{e.cuts_added}" if e.cuts_added else ""),
            )

        yield tick
