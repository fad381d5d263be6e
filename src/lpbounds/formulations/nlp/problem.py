r"""The disjunctive lower-bound program NLP (paper Section 3.3, eq. 23-25).

.. math::

    \begin{array}{l}
    NLP := \min \bar c^T w \quad\text{s.t.} \\
    \qquad w(i) \ge \min_{x \in S_i} \Big\{ R_u(x) + \lambda \sum_{l=0}^m p_l\,
    w(\bar f(x, u, Y_l)) \Big\} \quad \forall u,\ i = 1..M.   \qquad (25)
    \end{array}

Its optimum ``w*`` satisfies ``w*(i) <= min_{x in S_i} V*(x)`` (the paper: ``w-bar(i) =
min_{S_i} V*`` is feasible, eq. 24). The minimum over ``x in S_i`` only ranges over the
distinct successor tuples of ``T(i, u)`` (the *terms*; for equal tuples the smallest
reward is kept): ``BellmanRows.aggregate(mdp, partition, reduce="min")``.

**The optimum does not depend on the cost.** By Fact 2 of :mod:`lpbounds.rows.system`, the
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
    ``cuts="monotone"`` (default): a certified lower point ``l <= w*`` is lifted round by
    round by the least element of a master made of the single-term rows, monotone cuts
    ``w(i) >= min_k f_k(l) + amin'(w - l)`` and the disjunctions *resolved* on the box
    ``[l, h]`` (``h >= w*``: the certified value of the minimiser's strategy at ``l``);
    the master is a Bellman row system, solved by modified policy iteration (or, with
    ``backend="highspy"``/``"cvxpy"``, as an LP). Closes the bracket in a few dozen
    rounds whatever ``M``; see :mod:`lpbounds.formulations.nlp.monotone` for the proofs.
    ``cuts="lift-and-project"``: Balas' disjunctive cuts on a master LP relaxation; every
    master optimum is a lower bound (weak duality: the log's lower side), strategies
    read off the master points give the upper bound and the returned point (the
    incumbent). See :mod:`lpbounds.formulations.nlp.cuts` for the CGLP, its
    normalisation and how each cut is made valid (closes only small instances).
``"strategy-iteration"``
    Fix one term per disjunction (the minimiser's strategy ``sigma``), solve that row
    system exactly (its least element ``v_sigma``, Fact 1), switch each disjunction to
    its smallest term at ``v_sigma``, repeat. ``v_sigma`` is feasible, so every iterate
    is an upper bound; they decrease (``T_{sigma'} v_sigma <= v_sigma`` makes ``v_sigma``
    feasible for ``sigma'``) and the method is finite (a strategy never repeats).
``"milp"``
    Big-M: a binary ``z_t`` per term of each multi-term disjunction, ``sum_t z_t = 1``,
    ``a_t'w >= b_t - M_t (1 - z_t)`` with ``M_t = max(0, b_t - min_{lo <= w <= hi}
    a_t'w)`` (the term's largest possible violation on a certified box ``lo <= w* <=
    hi``, :attr:`NLP.milp`). The model is :attr:`NLP.problem` (class :class:`NLPMILP`).
    Solved with cvxpy + HiGHS; the chosen strategy is then evaluated exactly. Under ``time_limit``
    the solver gets the time left; without an incumbent the initial strategy's value
    is returned (``TIME_LIMIT``, with its certified bracket).
``"fixed-point"``
    :func:`lpbounds.dp.solve_game`: value iteration on ``w = Gw``.

**Action sets.** A disjunction ``(i, u)`` is kept only when ``u`` is allowed at every
state of ``S_i``: a state that forbids ``u`` contributes the term ``R_u(x) = -inf`` to
the min over ``S_i``, so the disjunction says nothing (the proof is "Action sets" in
:mod:`lpbounds.rows.aggregation`). The rule lives in ``aggregate(reduce="min")``, so all four
methods see the same rows; a partition whose states share no allowed action would have the
bound ``-inf`` and is refused with a :class:`~lpbounds.errors.ValidationError` naming it.

**Certified results.** Whatever the method, the result's bounds come from the returned
point ``w`` alone: :func:`lpbounds.certification.certificate.certify` with the max-min operator
``G``
(a ``lambda``-contraction, Fact 2) gives ``lower_values <= w* <= upper_values`` in
floating point (contraction argument plus a derived rounding margin), hence
``lower_values(i) <= min_{S_i} V*``; ``lower_bound``/``upper_bound`` on ``c'w*`` are
``Certificate.objective_bracket(c)``. The cutting planes' master value and the MILP
solver's dual bound are reported in ``extra["method_bracket"]`` and the log only: they
are valid in exact arithmetic but not rounding-certified, so the reported
``lower_values`` never use them. The status is ``OPTIMAL`` when the certified bracket is
within ``gap_rtol`` of the problem's scale ``max|R| / (1 - lambda)``, a limit status
(``TIME_LIMIT``, ``ITERATION_LIMIT``, ``LIMIT``) when a limit stopped the method first,
``INACCURATE`` otherwise; ``converged`` is ``status is OPTIMAL``.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ...certification.certificate import Certificate, certify
from ...dp import solve_exact, solve_game, threads_for
from ...errors import ConvergenceError, SolverError, ValidationError
from ...model.checks import sink_block_note
from ...model.mdp import FiniteMDP
from ...model.partition import Partition
from ...rows import BellmanRows
from ...status import Status
from ...tolerances import NLP_EXACT_RTOL, NLP_GAP_RTOL, NLP_MILP_GAP_RTOL, NLP_SWITCH_RTOL, dp_scale
from ...validation import check_choice
from ..base import aggregated_cost, resolve_solver
from ..highs import silence_highs_banner
from .results import NLPIteration, NLPResult
from .stop import StopReason

if TYPE_CHECKING:
    from ...exact.lp import ExactLP
    from .cuts import NLPMaster

__all__ = [
    "METHOD_KEYWORDS",
    "NLP",
    "NLPMILP",
    "NLPIteration",
    "NLPResult",
    "StopReason",
    "progress_status",
]

Method = Literal["cutting-planes", "strategy-iteration", "milp", "fixed-point"]
METHODS: tuple[str, ...] = ("cutting-planes", "strategy-iteration", "milp", "fixed-point")
#: The cut families of ``solve("cutting-planes", cuts=...)``.
CUT_FAMILIES: tuple[str, ...] = ("monotone", "lift-and-project")

_TINY = float(np.finfo(np.float64).tiny)


#: The keywords of each method (besides ``gap_rtol``, ``progress`` and
#: ``raise_on_failure``, which every method takes) and their defaults.
METHOD_KEYWORDS: dict[str, dict[str, Any]] = {
    "cutting-planes": {
        "cuts": "monotone",
        "resolve": True,
        "solver": "HIGHS",
        "max_iter": 200,
        "cuts_per_round": 10,
        "backend": None,
        "time_limit": None,
        "cglp_rows": "binding",
        "normalization": "multipliers",
        "solver_options": None,
    },
    "strategy-iteration": {"max_iter": 10_000, "time_limit": None},
    "milp": {"solver": "HIGHS", "time_limit": None, "solver_options": None},
    "fixed-point": {"max_iter": 100_000},
}


def _method_options(method: str, given: dict[str, Any]) -> dict[str, Any]:
    """``given`` checked against ``method``'s keywords, with the defaults filled in."""
    allowed = METHOD_KEYWORDS[method]
    for key in given:
        if key not in allowed:
            owners = [m for m in METHODS if key in METHOD_KEYWORDS[m]]
            where = f"; it belongs to {', '.join(map(repr, owners))}" if owners else ""
            raise ValidationError(
                f"NLP.solve: method {method!r} does not accept the keyword {key!r}{where}. "
                f"{method!r} accepts: {', '.join(sorted(allowed))}, gap_rtol, progress, "
                "raise_on_failure"
            )
    opts = {**allowed, **given}
    mi = opts.get("max_iter")
    if mi is not None and not (isinstance(mi, int | np.integer) and mi >= 1):
        raise ValidationError(f"max_iter must be an integer >= 1; got {mi!r}")
    tl = opts.get("time_limit")
    if tl is not None and not (isinstance(tl, int | float) and np.isfinite(tl) and tl > 0):
        raise ValidationError(f"time_limit must be a finite number of seconds > 0; got {tl!r}")
    so = opts.get("solver_options")
    if so is not None and not isinstance(so, dict):
        raise ValidationError(f"solver_options must be a dict; got {type(so).__name__}")
    return opts


class NLP:
    r"""The disjunctive lower-bound program (eq. 25) of ``mdp`` under ``partition``.

    ``min c-bar'w  s.t.  w(i) >= min_{x in S_i} [R_u(x) + lambda sum_l p_l w(f-bar(x, u,
    Y_l))]`` for every (i, u); its optimum ``w*`` bounds ``V*`` from below on each
    partition: ``w*(i) <= min_{x in S_i} V*(x)``. ``w*`` is the same for every cost
    ``c > 0`` (module docstring, Fact 2 of :mod:`lpbounds.rows.system`).

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
        ``(min rho / (1 - lambda s), max rho / (1 - lambda s))``, each the extreme over the
        rows' certified sums ``s`` (1 when stochastic), widened by a few ulps: contains ``w*``.
    problem : cvxpy.Problem
        Eq. 25 as a cvxpy mixed-integer problem (the big-M MILP of :attr:`milp`, an
        :class:`NLPMILP` with variables ``w`` and ``z`` and constraint groups ``single``,
        ``disjunction``, ``select``, ``box_lower``, ``box_upper``);
        ``problem.solve(solver="HIGHS")`` gives ``c'w*``.
    master : NLPMaster
        The cutting-plane master LP as a cvxpy model (variable ``w``; groups ``single``,
        ``cuts``, ``box_lower``, ``box_upper``), updated round by round by
        ``solve("cutting-planes")``.
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
        self.partition_note = sink_block_note(mdp, partition)
        # HiGHS' banner to the log before anything can solve this NLP's models (its MILP
        # and masters are cvxpy problems a user may solve directly); once per process
        silence_highs_banner()
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
        # w* solves w = rho + lambda s w' row by row with s in the rows' certified sums
        # [s_lo, s_hi] (1 for stochastic rows): the extreme of rho / (1 - lambda s) over
        # both ends bounds it; widened by a few ulps so that rounding cannot exclude w*
        sums = r.row_sums()
        ends = [1 - lam * sums.lo, 1 - lam * sums.hi]
        rmin, rmax = float(r.reward.min()), float(r.reward.max())
        lo, hi = min(rmin / d for d in ends), max(rmax / d for d in ends)
        pad = 8 * np.finfo(np.float64).eps
        self.box = (lo - pad * abs(lo) - _TINY, hi + pad * abs(hi) + _TINY)
        self.scale = dp_scale(float(np.abs(r.reward).max(initial=0.0)), lam)
        self._term_matrix: tuple[sp.csr_matrix, np.ndarray] | None = None
        self._milp_model: NLPMILP | None = None
        self._master: NLPMaster | None = None
        # the last monotone master (LPData, n_single, n_resolved), built into cvxpy on demand
        self._master_pending: tuple[Any, int, int] | None = None

    # ------------------------------------------------------------------ cvxpy models
    @property
    def milp(self) -> NLPMILP:
        """The big-M MILP of eq. 25 (:class:`NLPMILP`) in a certified box, built once.

        ``lower``: :func:`~lpbounds.certification.certificate.certify` (max-min) at the constant
        point
        ``box[0]``, a floating-point lower bound on ``w*``; ``upper``: the certificate's
        upper side at the value of the minimiser's strategy chosen at ``box[1]`` (a
        feasible point, so ``>= w*``). The MILP's optimum is therefore ``c'w*``.
        """
        if self._milp_model is None:
            n = self.rows.n_vars
            lower = self.certify(np.full(n, self.box[0])).lower
            v0, _ = self.strategy_value(self.best_terms(np.full(n, self.box[1])))
            self._milp_model = NLPMILP(self, upper=self.certify(v0).upper, lower=lower)
        return self._milp_model

    @property
    def problem(self) -> cp.Problem:
        """Eq. 25 as a cvxpy mixed-integer problem: ``self.milp.problem``.

        ``NLP(...).problem.solve(solver="HIGHS")`` (any MIP-capable cvxpy solver) gives
        ``c'w*``; its variables are ``self.milp.w`` and ``self.milp.z``.
        """
        return self.milp.problem

    @property
    def master(self) -> NLPMaster:
        """The cutting-plane master LP as a cvxpy model (:class:`.nlp_cuts.NLPMaster`).

        Before a cutting-plane solve: the first master (the single-term rows and the box
        ``box``). ``solve("cutting-planes", cuts="lift-and-project")`` starts a fresh one
        and adds each round's cuts to it (group ``"cuts"``), so afterwards it is the last
        master of that run; its optimum is a lower bound on ``c'w*``. After
        ``cuts="monotone"`` it is the last round's master
        (:class:`.nlp_monotone.MonotoneMaster`: groups ``single``, ``resolved``, ``cuts``,
        ``box_lower`` = that round's ``l``, ``box_upper``), built on first access; its
        optimum is ``c'`` of that round's row-system least element.
        """
        if self._master is None and self._master_pending is not None:
            from .monotone import MonotoneMaster

            self._master = MonotoneMaster(*self._master_pending)
        if self._master is None:
            from .cuts import NLPMaster, master_data

            a, b = self.term_matrix
            single = self.single_rows
            m = self.rows.n_vars
            lo, hi = np.full(m, self.box[0]), np.full(m, self.box[1])
            data = master_data(self.cost, a[single], b[single], lo, hi)
            self._master = NLPMaster(data, single.size)
        return self._master

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
        ww = self.rows.as_vector(w)
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
        res = solve_exact(sub, method="pi", tol=NLP_EXACT_RTOL * self.scale, evaluation="direct")
        v = res.values
        return v, float(np.abs(sub.apply_max(v)[0] - v).max())

    def strategy_upper_bound(self, sel: np.ndarray) -> tuple[np.ndarray, float]:
        """``(v_sigma, c'v_sigma + sum(c) residual / (1 - kappa))``: a certified upper bound.

        ``v + residual / (1 - kappa)`` satisfies the strategy's rows, hence the NLP's
        (``kappa = lambda max_r s_r``, the rows' contraction modulus: ``q_r(v + t) =
        q_r(v) + lambda s_r t``).
        """
        v, res = self.strategy_value(sel)
        kappa = self.rows.row_sums().modulus(self.rows.discount)
        return v, float(self.cost @ v + self.cost.sum() * res / (1 - kappa))

    # ------------------------------------------------------------------ solve
    def solve(
        self,
        method: Method = "cutting-planes",
        *,
        gap_rtol: float = NLP_GAP_RTOL,
        progress: bool = False,
        raise_on_failure: bool = False,
        arithmetic: str = "float",
        size_limit: int | None = None,
        **options: Any,
    ) -> NLPResult:
        """Solve the NLP with ``method``.

        Each method accepts only its own keywords (:data:`METHOD_KEYWORDS`); any other
        keyword is a :class:`~lpbounds.errors.ValidationError` naming it and the method.

        Parameters
        ----------
        method : {"cutting-planes", "strategy-iteration", "milp", "fixed-point"}
        gap_rtol : float
            Every method: the result is ``OPTIMAL`` when its certified bracket satisfies
            ``max(upper_values - lower_values) <= gap_rtol * scale`` (up to the rounding
            margin) with ``scale = max|R| / (1 - lambda)``: relative to the problem's
            scale, so that rewards of 1e-6 are not "closed" by an absolute gap. The
            cutting planes also stop when their own bracket on ``c'w*`` closes to
            ``gap_rtol * sum(c) * scale``.
        progress : bool
            Show a rich progress bar (on stderr) with the bracket.
        raise_on_failure : bool
            Raise :class:`~lpbounds.errors.ConvergenceError` unless the status is
            ``OPTIMAL`` (default: return the result with its status).
        arithmetic : {"float", "rational"}
            ``"rational"``: after the method, also ``w*`` exactly, by exact strategy
            iteration on the game started at the method's point
            (:func:`lpbounds.exact.lp.game_optimum`; verified as a fixed point of ``G`` in
            rationals); ``result.exact`` holds it with the method's exact error and whether
            its certified bracket held. The float result is unchanged.
        size_limit : int, optional
            ``arithmetic="rational"``: the most partitions solved together (default
            :data:`~lpbounds.tolerances.EXACT_MAX_VARIABLES`), checked before any exact work.
        **options
            The method's own keywords, listed under Other Parameters.

        Other Parameters
        ----------------
        solver : str
            ``"cutting-planes"``, ``"milp"``: the LP/MILP solver through cvxpy ("HIGHS"
            default). The cutting planes with ``backend="highspy"`` require HIGHS.
        max_iter : int
            ``"cutting-planes"``: rounds (default 200); ``"strategy-iteration"``:
            strategies (default 10,000); ``"fixed-point"``: value iterations (default
            100,000). Reaching it gives ``ITERATION_LIMIT`` unless the bracket closed.
        time_limit : float
            ``"cutting-planes"``, ``"strategy-iteration"``, ``"milp"``: stop after about
            this many seconds (``TIME_LIMIT``, with the best point and its certified
            bracket). The MILP passes the time left to the solver (HIGHS or SCIPY; other
            MILP solvers are refused) and, if the solver returns no incumbent, keeps the
            value of the initial strategy.
        cuts : {"monotone", "lift-and-project"}
            ``"cutting-planes"``: the cut family (default ``"monotone"``; see the module
            docstring). ``cuts_per_round``, ``cglp_rows`` and ``normalization`` apply to
            ``"lift-and-project"`` only.
        resolve : bool
            ``"cutting-planes"`` with ``cuts="monotone"``: resolve disjunctions on the box
            ``[l, h]`` (default ``True``; ``False`` leaves monotone cuts alone, which
            converge at the rate ``lambda`` only).
        cuts_per_round : int
            ``"cutting-planes"``: at most this many cuts a round (the most violated
            disjunctions first).
        backend : {None, "rows", "highspy", "cvxpy"}
            ``"cutting-planes"``. Monotone cuts: the master's row system by policy
            iteration (``"rows"``, the default for ``None``), or its LP cold with highspy
            or through cvxpy with ``solver``. Lift-and-project: a persistent HiGHS master
            (``"highspy"``, the default for ``None``), or every LP cold through cvxpy.
        cglp_rows : {"binding", "all"}
            ``"cutting-planes"``: the master rows the cut-generating LP is built on: the
            single-term rows and the cuts binding at the master's point (default), or all
            of them (docs/nlp.md has the measurements).
        normalization : {"multipliers", "alpha"}
            ``"cutting-planes"``: the CGLP's normalisation, ``sum(u) + sum(v) = 1``
            (default) or ``max|alpha| <= 1`` (see
            :func:`~lpbounds.formulations.nlp.cuts.cglp_data`).
        solver_options : dict
            ``"cutting-planes"`` (cvxpy backend), ``"milp"``: passed to the solver.

        Returns
        -------
        NLPResult
        """
        if method not in METHODS:
            raise ValidationError(f"unknown NLP method {method!r}; choose one of {METHODS}")
        if not (isinstance(gap_rtol, int | float) and np.isfinite(gap_rtol) and gap_rtol >= 0):
            raise ValidationError(f"gap_rtol must be a finite number >= 0; got {gap_rtol!r}")
        opts = _method_options(method, options)
        check_choice("arithmetic", arithmetic, ("float", "rational"))
        t0 = time.perf_counter()
        with _progress_bar(progress, method, opts.get("max_iter")) as tick, threads_for(self.rows):
            if method == "cutting-planes":
                out = self._cutting_planes(opts, gap_rtol, tick)
            elif method == "strategy-iteration":
                out = self._strategy_iteration(opts["max_iter"], opts["time_limit"], tick)
            elif method == "milp":
                out = self._milp(opts["solver"], opts["time_limit"], opts["solver_options"], tick)
            else:
                out = self._fixed_point(opts["max_iter"], tick)
        result = self._result(method, out, gap_rtol, time.perf_counter() - t0)
        if raise_on_failure and not result.converged:
            raise ConvergenceError(result.summary())
        if arithmetic == "rational":
            result.exact = self.exact_optimum(result, size_limit=size_limit)
        return result

    def exact_optimum(
        self,
        result: NLPResult | None = None,
        *,
        size_limit: int | None = None,
        callback: Any = None,
    ) -> ExactLP:
        """``w*`` exactly (:func:`lpbounds.exact.lp.game_optimum`), judged against
        ``result`` when given (its exact error, whether its bracket held)."""
        from ...exact.files import mdp_data
        from ...exact.lp import game_optimum

        approx = None if result is None else result.values
        exact = game_optimum(mdp_data(self.mdp, self.partition), list(self.cost), approx=approx,
                             callback=callback, size_limit=size_limit)  # fmt: skip
        if result is not None:
            exact.judge(result.values, result.lower_values, result.upper_values, result.objective)
        return exact

    # ------------------------------------------------------------------ helpers
    def certify(self, w: Any) -> Certificate:
        """The certified bracket on ``w*`` from any point ``w`` (max-min operator ``G``)."""
        return certify(self.rows, w, operator="maxmin")

    def _result(self, method: str, out: _Outcome, gap_rtol: float, seconds: float) -> NLPResult:
        values = np.asarray(out.values, dtype=np.float64)
        cert = self.certify(values)
        lo, hi = cert.objective_bracket(self.cost)
        # width = 2 (residual + margin) / (1 - kappa): a residual within gap_rtol / 2 of
        # max|R| closes the bracket to gap_rtol max|R| / (1 - kappa) plus the rounding margin
        if cert.is_accurate(gap_rtol / 2):
            status = Status.OPTIMAL
        else:
            status = out.limit if out.limit is not None else Status.INACCURATE
        if out.log and not out.keep_log_bracket:
            out.log[-1].lower, out.log[-1].upper, out.log[-1].gap = lo, hi, hi - lo
        return NLPResult(
            formulation="NLP",
            method=method,
            values=values,
            state_values=self.partition.lift(values),
            lower_values=cert.lower,
            upper_values=cert.upper,
            lower_bound=lo,
            upper_bound=hi,
            gap=hi - lo,
            status=status,
            stop_reason=out.stop_reason,
            objective=float(self.cost @ values),
            residual=cert.residual,
            error_bound=cert.error_bound,
            certificate=cert,
            iterations=out.iterations,
            cuts=out.cuts,
            seconds=seconds,
            log=out.log,
            cost=self.cost,
            solver=out.solver,
            gap_rtol=gap_rtol,
            scale=self.scale,
            extra=out.extra
            if self.partition_note is None
            else {**out.extra, "partition_note": self.partition_note},
        )

    def _limit(self, t0: float, time_limit: float | None) -> bool:
        return time_limit is not None and time.perf_counter() - t0 >= time_limit

    # ------------------------------------------------------------------ methods
    def _fixed_point(self, max_iter: int, tick: Callable[..., None]) -> _Outcome:
        t0 = time.perf_counter()
        log: list[NLPIteration] = []
        s = float(self.cost.sum())
        kappa = self.rows.row_sums().modulus(self.rows.discount)

        def cb(it: int, res: float) -> None:
            # the residual alone bounds the bracket's width: 2 sum(c) res / (1 - kappa)
            e = NLPIteration(
                it, np.nan, np.nan, 2 * s * res / (1 - kappa), 0, time.perf_counter() - t0
            )
            log.append(e)
            tick(e)

        dp = solve_game(
            self.rows,
            tol=NLP_EXACT_RTOL * self.scale,
            max_iter=max_iter,
            callback=cb,
            raise_on_failure=False,
        )
        return _Outcome(
            dp.values,
            stop_reason=StopReason.RESIDUAL_TOL if dp.converged else StopReason.MAX_ITER,
            limit=None if dp.converged else Status.ITERATION_LIMIT,
            iterations=dp.iterations,
            log=log,
            solver="none (value iteration)",
            extra={"tol": dp.tol, "sweeps": dp.sweeps},
        )

    def _strategy_iteration(
        self, max_iter: int, time_limit: float | None, tick: Callable[..., None]
    ) -> _Outcome:
        t0 = time.perf_counter()
        log: list[NLPIteration] = []
        sel = self.best_terms(np.full(self.rows.n_vars, self.box[1]))
        upper = np.inf
        v = np.full(self.rows.n_vars, self.box[1])
        limit: Status | None = Status.ITERATION_LIMIT
        stop, it = StopReason.MAX_ITER, 0
        for it in range(1, max_iter + 1):
            v, ub = self.strategy_upper_bound(sel)
            upper = min(upper, ub)
            new = self.best_terms(v, current=sel)
            e = NLPIteration(it, np.nan, upper, np.nan, 0, time.perf_counter() - t0)
            log.append(e)
            tick(e)
            if np.array_equal(new, sel):
                stop, limit = StopReason.STRATEGY_STABLE, None
                break
            if self._limit(t0, time_limit):
                stop, limit = StopReason.TIME_LIMIT, Status.TIME_LIMIT
                break
            sel = new
        return _Outcome(
            v,
            stop_reason=stop,
            limit=limit,
            iterations=it,
            log=log,
            solver="none (exact evaluation)",
            extra={"strategy": sel},
        )

    def _milp(
        self,
        solver: str,
        time_limit: float | None,
        solver_options: dict[str, Any] | None,
        tick: Callable[..., None],
    ) -> _Outcome:
        t0 = time.perf_counter()
        name = resolve_solver(solver)
        opts = dict(solver_options or {})
        # a feasible point bounds w* from above (Fact 2): it shrinks the box and the big-Ms;
        # the certificate's upper side is >= w* in floating point
        sel0 = self.best_terms(np.full(self.rows.n_vars, self.box[1]))
        model = self.milp
        if name == "HIGHS":
            opts.setdefault("mip_rel_gap", NLP_MILP_GAP_RTOL)
            opts.setdefault("mip_abs_gap", NLP_MILP_GAP_RTOL * self.scale)
        if time_limit is not None:
            _set_time_limit(name, opts, max(time_limit - (time.perf_counter() - t0), 1e-3))
        try:
            with warnings.catch_warnings():
                # cvxpy warns on a limit or an inaccurate solve; the point is certified below
                warnings.filterwarnings("ignore", "Solution may be inaccurate", UserWarning)
                model.problem.solve(solver=name, **opts)
        except cp.SolverError as exc:
            raise SolverError(f"NLP milp with {name}: {exc}") from exc
        status = model.problem.status
        if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE, cp.USER_LIMIT):
            raise SolverError(f"NLP milp with {name}: status {status}")
        sel = sel0 if model.w.value is None else self._milp_strategy(model)
        v, ub = self.strategy_upper_bound(sel)
        # cvxpy reports a time limit as USER_LIMIT (HIGHS) or OPTIMAL_INACCURATE (SCIPY): a
        # non-optimal stop after 90 % of the time limit is taken as the limit
        limit = None
        if status != cp.OPTIMAL and self._limit(
            t0, None if time_limit is None else 0.9 * time_limit
        ):
            limit = Status.TIME_LIMIT
        elif status == cp.USER_LIMIT:
            limit = Status.LIMIT
        stats = getattr(model.problem.solver_stats, "extra_stats", None)
        dual_bound = _mip_dual_bound(stats)
        e = NLPIteration(1, dual_bound, ub, ub - dual_bound, 0, time.perf_counter() - t0)
        tick(e)
        if limit is Status.TIME_LIMIT:
            stop = StopReason.TIME_LIMIT
        elif limit is not None:
            stop = StopReason.SOLVER_LIMIT
        else:
            stop = StopReason.MILP_OPTIMAL if status == cp.OPTIMAL else StopReason.MILP_INACCURATE
        return _Outcome(
            v,
            stop_reason=stop,
            limit=limit,
            iterations=1,
            log=[e],
            solver=name,
            extra={
                "w_milp": None if model.w.value is None else np.asarray(model.w.value, float),
                "milp_status": str(status),
                "milp_limit": limit,
                "milp_objective": float(model.problem.value)
                if model.w.value is not None
                else np.nan,
                "mip_dual_bound": dual_bound,
                "strategy": sel,
                "big_m": model.big_m,
                "method_bracket": (dual_bound, ub),
            },
        )

    def _milp_strategy(self, model: NLPMILP) -> np.ndarray:
        """Per multi-term disjunction the term with the largest ``z`` (others: their term)."""
        sel = self.disj_start[:-1].copy()
        if model.z is None:
            return sel
        z = np.asarray(model.z.value, dtype=np.float64)
        zz = np.full(self.rows.n_rows, -np.inf)
        zz[model.multi_rows] = z
        best = np.maximum.reduceat(zz, self.disj_start[:-1])
        idx = np.flatnonzero(zz >= best[self.disj_of_row])
        _, first = np.unique(self.disj_of_row[idx], return_index=True)
        return idx[first]

    def _cutting_planes(
        self, opts: dict[str, Any], gap_rtol: float, tick: Callable[..., None]
    ) -> _Outcome:
        from .cuts import cutting_planes

        if opts["cuts"] not in CUT_FAMILIES:
            raise ValidationError(f"cuts must be one of {CUT_FAMILIES}; got {opts['cuts']!r}")
        if not isinstance(opts["resolve"], bool):
            raise ValidationError(f"resolve must be True or False; got {opts['resolve']!r}")
        if opts["cuts"] == "monotone":
            return self._monotone(opts, gap_rtol, tick)
        backend = "highspy" if opts["backend"] is None else opts["backend"]
        out = cutting_planes(
            self,
            solver=opts["solver"],
            backend=backend,
            gap_rtol=gap_rtol,
            max_rounds=opts["max_iter"],
            cuts_per_round=opts["cuts_per_round"],
            time_limit=opts["time_limit"],
            cglp_rows=opts["cglp_rows"],
            normalization=opts["normalization"],
            on_round=tick,
            **(opts["solver_options"] or {}),
        )
        # the loop's master, with every round's cuts: what self.master returns from now on
        self._master, self._master_pending = out.master, None
        solver = (
            "HIGHS (highspy, persistent)" if backend == "highspy" else f"{opts['solver']} (cvxpy)"
        )
        return self._cut_outcome(
            out,
            solver,
            {
                "cut_alpha": out.cut_alpha,
                "cut_beta": out.cut_beta,
                "master_point": out.master_point,
                "master_objective": out.master_objective,
                "cuts_in_last_master": out.cuts_in_last_master,
                "box": self.box,
            },
        )

    @staticmethod
    def _cut_outcome(out: Any, solver: str, extra: dict[str, Any]) -> _Outcome:
        """The outcome of either cut loop: its point, stop, limit, rounds, log and bracket."""
        limits = {
            StopReason.MAX_ROUNDS: Status.ITERATION_LIMIT,
            StopReason.TIME_LIMIT: Status.TIME_LIMIT,
        }
        return _Outcome(
            out.best_point,
            stop_reason=out.stop_reason,
            limit=limits.get(out.stop_reason),
            iterations=out.rounds,
            cuts=out.cuts,
            log=out.log,
            keep_log_bracket=True,
            solver=solver,
            extra={"method_bracket": (out.lower, out.upper), **extra},
        )

    def _monotone(
        self, opts: dict[str, Any], gap_rtol: float, tick: Callable[..., None]
    ) -> _Outcome:
        from .monotone import monotone_cuts

        backend = "rows" if opts["backend"] is None else opts["backend"]
        out = monotone_cuts(
            self,
            gap_rtol=gap_rtol,
            max_rounds=opts["max_iter"],
            time_limit=opts["time_limit"],
            resolve=opts["resolve"],
            backend=backend,
            solver=opts["solver"],
            on_round=tick,
            **(opts["solver_options"] or {}),
        )
        self._master, self._master_pending = None, out.master
        solver = {
            "rows": "none (row-system master, modified policy iteration)",
            "highspy": "HIGHS (highspy)",
        }.get(backend, f"{opts['solver']} (cvxpy)")
        return self._cut_outcome(
            out,
            solver,
            {
                "cut_family": "monotone",
                "loop_lower_values": out.lower_values,
                "loop_upper_values": out.upper_values,
                "resolved": out.resolved,
                "box": self.box,
            },
        )


@dataclass
class _Outcome:
    """What a method hands to :meth:`NLP._result`: its point and why it stopped."""

    values: np.ndarray
    stop_reason: StopReason
    limit: Status | None  # the limit that stopped the method, None if it stopped on its own
    iterations: int
    log: list[NLPIteration]
    solver: str
    cuts: int = 0
    keep_log_bracket: bool = False  # the cutting planes' log holds the master's bracket
    extra: dict[str, Any] = field(default_factory=dict)


def _set_time_limit(solver: str, opts: dict[str, Any], seconds: float) -> None:
    """Put a time limit into a MILP solver's cvxpy options (HIGHS and SCIPY only)."""
    if solver == "HIGHS":
        opts["time_limit"] = float(seconds)
    elif solver == "SCIPY":
        sc = dict(opts.get("scipy_options", {}))
        sc["time_limit"] = float(seconds)
        opts["scipy_options"] = sc
    else:
        raise ValidationError(
            f"NLP.solve('milp', time_limit=...) supports the solvers HIGHS and SCIPY; got "
            f"{solver!r} (set its own limit through solver_options)"
        )


def _mip_dual_bound(stats: Any) -> float:
    """The solver's MIP dual bound when cvxpy passes it on (not certified), else ``-inf``."""
    for key in ("mip_dual_bound",):
        val = stats.get(key) if isinstance(stats, dict) else getattr(stats, key, None)
        if val is not None and np.isfinite(float(val)):
            return float(val)
    return -np.inf


class NLPMILP:
    r"""The disjunctive program of eq. 25 as a cvxpy mixed-integer LP (big-M; a model class).

    .. math::

        \begin{array}{l}
        \min \bar c^T w \quad\text{s.t.} \\
        \qquad a_t^T w \ge b_t - M_t (1 - z_t)\ \ (t \text{ a term of a multi-term } (i, u)), \\
        \qquad \sum_{t \in (i, u)} z_t = 1,\quad z_t \in \{0, 1\},\quad
        a_t^T w \ge b_t\ \ (\text{single-term } (i, u)), \\
        \qquad lo \le w \le hi,
        \end{array}

    with term ``t`` of disjunction ``(i, u)`` the row ``w(i) >= rho_t + lambda sum_l
    p_{t,l} w(k_{t,l})`` (``a_t = e_i - lambda P_t``, ``b_t = rho_t``: one distinct successor
    tuple of ``T(i, u)``). ``z_t = 1`` selects the term that must hold, which is eq. 25's
    ``w(i) >= min_t q_t(w)``. ``M_t = max(0, b_t - min_{lo <= w <= hi} a_t'w)``: with
    ``z_t = 0`` the row is implied by the box, so inside the box the MILP's feasible set is
    exactly the NLP's.

    The box must contain ``w*`` (then the MILP's optimum is ``c'w*``: ``w*`` is the least
    element of the NLP's feasible set, Fact 2). :meth:`NLP.milp` passes a certified one:
    ``lower`` from :func:`~lpbounds.certification.certificate.certify` (max-min operator) at the
    constant
    point ``min rho / (1 - lambda)`` and ``upper`` from the certificate of the value of one
    strategy (a feasible point, so ``>= w*``; 3-6x faster than ``hi = max rho / (1 -
    lambda)`` on a 30-state, 6-partition garnet because the ``M_t`` shrink). Without them
    the box is :attr:`NLP.box`.

    Parameters
    ----------
    nlp : NLP
    upper, lower : ndarray (M,), optional
        Bounds on ``w*``, used as given (they must contain ``w*``; a certificate's sides
        do, in floating point); default :attr:`NLP.box`.

    Attributes
    ----------
    problem : cvxpy.Problem
        The MILP; ``problem.solve(solver="HIGHS")`` (or any installed MIP-capable cvxpy
        solver: SCIP, GLPK_MI, ...) gives ``c'w*`` to the solver's MIP gap (HiGHS' default
        relative gap is 1e-4; pass ``mip_rel_gap=1e-10`` for more).
    w : cvxpy.Variable (M,)
        The paper's ``w``.
    z : cvxpy.Variable or None
        One boolean per term of the multi-term disjunctions (rows :attr:`multi_rows` of
        ``nlp.rows``); ``None`` when every disjunction has one term (then an LP).
    constraints : dict of str to cvxpy.Constraint
        ``"single"``: eq. 25 for the single-term (i, u) (ordinary rows); ``"disjunction"``:
        the big-M rows of the multi-term (i, u); ``"select"``: ``sum_t z_t = 1`` per
        multi-term (i, u); ``"box_lower"``, ``"box_upper"``: ``lo <= w <= hi``. Each is one
        sparse vector constraint; groups with no rows are absent.
    big_m : ndarray
        ``M_t`` per multi-term row.
    lo, hi : ndarray (M,)
        The box.
    """

    def __init__(
        self, nlp: NLP, upper: np.ndarray | None = None, lower: np.ndarray | None = None
    ) -> None:
        a, b = nlp.term_matrix
        m = nlp.rows.n_vars
        lo = np.full(m, nlp.box[0]) if lower is None else np.asarray(lower, dtype=np.float64)
        hi = np.full(m, nlp.box[1]) if upper is None else np.asarray(upper, dtype=np.float64)
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
        cons: dict[str, cp.Constraint] = {}
        if single.size:
            cons["single"] = a[single] @ self.w >= b[single]
        self.z: cp.Variable | None = None
        if self.multi_rows.size:
            self.z = cp.Variable(self.multi_rows.size, boolean=True, name="z")
            cons["disjunction"] = am @ self.w - sp.diags(self.big_m) @ self.z >= bm - self.big_m
            d_of = nlp.disj_of_row[self.multi_rows]
            _, d_idx = np.unique(d_of, return_inverse=True)
            s = sp.csr_matrix(
                (np.ones(d_idx.size), (d_idx, np.arange(d_idx.size))),
                shape=(int(d_idx.max()) + 1, d_idx.size),
            )
            cons["select"] = s @ self.z == 1
        cons["box_lower"] = self.w >= lo
        cons["box_upper"] = self.w <= hi
        self.constraints = cons
        self.variables = {"w": self.w} if self.z is None else {"w": self.w, "z": self.z}
        self.problem = cp.Problem(cp.Minimize(nlp.cost @ self.w), list(cons.values()))

    def __repr__(self) -> str:
        nz = 0 if self.z is None else self.z.size
        return (
            f"NLPMILP(w={self.w.size}, binaries={nz}, constraint groups: "
            f"{', '.join(self.constraints)})"
        )


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
            prog.update(task, completed=e.iteration, status=progress_status(e))

        yield tick


def progress_status(e: NLPIteration) -> str:
    """The progress bar's text for one iteration: the bracket, the gap and the cuts added;
    an end or gap the method does not have yet (nan) reads "-" (no "[nan, 3.2]")."""

    def num(x: float, spec: str) -> str:
        return "-" if x != x else format(x, spec)  # x != x: nan

    text = f"it {e.iteration}  [{num(e.lower, '.6g')}, {num(e.upper, '.6g')}]"
    text += f"  gap {num(e.gap, '.2e')}"
    return text + (f"  cuts +{e.cuts_added}" if e.cuts_added else "")
