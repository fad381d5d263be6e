r"""Exact dynamic programming: value, policy and modified policy iteration, policy
evaluation, greedy policies and the Porteus bounds (paper Sections 2 and 3.3).

Every function takes either a :class:`~lpbounds.model.mdp.FiniteMDP` or a
:class:`~lpbounds.rows.BellmanRows` system (an MDP whose actions at ``i`` are the rows
of ``i``), so the same code computes ``V*`` and the exact, solver-free counterparts of
the LPs (RLP's least feasible point is the fixed point of its rows, Fact 1 in
:mod:`lpbounds.rows`).

Stopping rule and error bound
-----------------------------
The solvers stop when the Bellman residual of the vector they return,
``||T V - V||_inf``, is at most ``tol`` (default ``DP_RTOL * max|R|``, at least a rounding
floor: :func:`lpbounds.tolerances.dp_default_tol`), and report that residual, measured
on the returned vector. It implies

* ``||V - V*||_inf <= residual / (1 - kappa)`` (reported as ``error_bound``), and
* ``||T V - V*||_inf <= kappa / (1 - kappa) * residual`` for one more application of T,

where ``kappa = lambda max_r sum_l p_{r,l}`` (rounded up, :func:`modulus`) is the
contraction modulus of the rows *as stored*: ``lambda`` itself when every row sums to
one, larger for accepted rows summing to ``1 + 1e-9`` (``docs/tolerances.md``, "Row sums").

Value iteration and MPI use the Porteus/MacQueen extrapolation: after a sweep
``V' = T V`` with ``r = V' - V``, the constant ``lambda / (1 - lambda) * (min r + max r) / 2``
is added to ``V'``. A constant shift does not change greedy policies and
``T(V + c) = T V + lambda c``, so the shift only removes the slowest (constant) error
mode; the residual of the shifted vector is at most ``lambda * span(r) / 2``.

Evaluation sweeps of MPI
------------------------
MPI converges for any number ``m_n >= 0`` of evaluation sweeps after improvement ``n``
(Puterman, *Markov Decision Processes*, Thm. 6.5.5), and the stopping test is always an
improvement sweep, so ``m_n`` changes the speed, never the certificate. With
``eval_sweeps=<int>`` every ``m_n`` is that number (textbook MPI). The default
``eval_sweeps="auto"`` does not spend evaluation sweeps on a policy that is about to be
replaced: ``m_n = AUTO_EVAL_SWEEPS`` once at most :data:`AUTO_SETTLED` of the states
changed their action in improvement ``n`` (the first improvement counts as a change of
every state), else ``m_n = 0``, a value-iteration step, which does everything an
evaluation sweep does and improves the policy too. The rule reads only the policies, so
the iterates and the sweep count do not depend on timing, and a model gives the same
numbers on its plain rows and its post-decision form.

Measured (2 cores, quiet machine, best of 3, the same answers within the certificates):
the garnet 2,048,000 x 3 x 5 at discount 0.9 took 11 improvement and 25 evaluation
sweeps against fixed MPI's 9 and 40 (1.7 against 2.4 s); the patrol MDP, where an
evaluation sweep costs nearly an improvement sweep (both are dominated by the
expectations at every post-decision state), 27 and 35 against 16 and 75 (0.67 against
1.00 s; value iteration: 58 sweeps, 0.70 s).

Inexact policy iteration
------------------------
``method="ipi"`` alternates an improvement sweep (greedy policy ``pi``, Bellman residual
``res``) with a GMRES solve of ``(I - lambda P_pi) d = T u - u`` (:mod:`lpbounds.dp.krylov`,
self-loop preconditioned, products from the policy sweep with zero rewards) stopped at
``max(IPI_FORCING * res, tol / 2)`` in the max norm. The stopping rule and certificate
are those above: the residual of the returned vector is measured by a full sweep, so the
evaluation's accuracy only affects speed. It is opt-in: measured against MPI with five
evaluation sweeps per improvement (sweep equivalents; improvement sweeps plus GMRES
products, 2 cores; ``eval_sweeps="auto"`` needs fewer still on the large models) it lost on
every large model and won only on small slow-mixing ones:

* the ported peer test models (tests/interop): pymdptoolbox's forest with 1,000 states
  and discount 0.99, MPI 157 sweeps (44 ms), IPI 57 (26 ms); MDPSolver's test 1
  (discount 0.98): 31 against 11 sweeps, 0.56 against 0.44 ms;

* garnet 100,000 x 3 x 5, discount 0.9: MPI 55 sweeps, IPI 123 (a random MDP mixes
  fast; with the Porteus shift an evaluation sweep already contracts by ~0.45);
* the paper's patrol MDP: MPI 91 sweeps, IPI 165 (and 5x the time: each GMRES step
  also orthogonalises 2 M-entry vectors);
* a slow-mixing chain (3,000 states, discount 0.99): MPI 1,537, IPI 1,115 sweeps,
  about the same time; at 30,000 states and discount 0.999, MPI 13,057 sweeps (11 s),
  IPI 16,042 (32 s): PI's outer steps move the policy along the chain one stretch at a
  time, so GMRES's faster evaluations are spent on policies about to change.

So :func:`solve_exact` does not pick it by itself (a rule that pays only below a
millisecond is not worth a second default path); the measurements are rerun by
``benchmarks/bench_peers.py --dp``.

Fast path
---------
Value iteration, MPI, iterative policy evaluation and :func:`bellman_residual` on a
:class:`~lpbounds.model.mdp.FiniteMDP` first look for its post-decision form
(:class:`~lpbounds.rows.PostDecisionRows`, verified on every pair, cached on the MDP):
where it exists (the patrol model) a sweep reads far less memory and the exact rows are
never built. Its arithmetic is that of the rows, so the results are the same numbers;
``tests/test_fast_paths.py`` checks that. Pass the rows (``exact_rows(mdp)``) to force
the plain path.

Every sweep runs C kernels built at install (:mod:`lpbounds._kernels.dispatch`), at every
size: a first solve in a fresh environment compiles nothing. Their numpy twins, with the
same arithmetic and the same numbers, are the tests' reference.

One loop
--------
VI, MPI and the game's VI are one loop, :func:`mpi_loop`, and iterative policy
evaluation is :func:`evaluation_loop`; both run on any
:class:`~lpbounds.rows.SweepOperator` (the rows, their post-decision form, the
matrix-free patrol operator of :mod:`lpbounds.patrol.matrix_free`), so every path gives
the same numbers for the same operator. They keep two value vectors: the starting vector,
which they overwrite, and one from :meth:`~lpbounds.rows.SweepOperator.new_vector`; the
result ``u + c`` is formed in place (534 M states at 6 patrol stations: 4.3 GB a vector).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .._kernels import dispatch as _backend
from ..errors import ConvergenceError, ValidationError
from ..model.mdp import FiniteMDP
from ..results import Result, outward_bracket
from ..rows import BellmanRows, PostDecisionRows, SweepOperator
from ..status import Status
from ..stochastic import RowSums, bellman_margin
from ..tolerances import (
    DP_OFFSET_CARRY_SHARE,
    GREEDY_TIE_RTOL,
    dp_default_tol,
    error_bound,
    offset_folds,
)
from ..validation import (
    MAX_VALUE_SCALE,
    check_array,
    check_bool,
    check_choice,
    check_int,
    check_real,
    check_vector,
    is_int,
)

if TYPE_CHECKING:  # annotations only: python-flint loads when exact arithmetic is asked for
    from ..exact.fixed_point import ExactFixedPoint
    from ..exact.rationals import RationalVector

__all__ = [
    "DPResult",
    "EvalPlan",
    "LoopResult",
    "PolicyEvaluation",
    "PolicyLoop",
    "PorteusBounds",
    "PorteusShift",
    "ThreadChoice",
    "bellman_residual",
    "check_eval_sweeps",
    "evaluate_policy",
    "evaluation_loop",
    "exact_rows",
    "greedy_policy",
    "modulus",
    "mpi_loop",
    "porteus_bounds",
    "post_decision_rows",
    "solve_exact",
    "solve_game",
    "threads_for",
]

Model = FiniteMDP | BellmanRows
Method = Literal["mpi", "vi", "pi", "ipi"]
Callback = Callable[[int, float], None]

#: ``eval_sweeps="auto"``: evaluation sweeps after an improvement once the policy settled.
AUTO_EVAL_SWEEPS: int = 5
#: ``eval_sweeps="auto"``: the policy has settled when at most this fraction of the states
#: changed their action in the last improvement (1 % and 0.1 % gave sweep times within
#: 6 % of each other on the garnets and the patrol of docs/benchmarks.md, "Peers").
AUTO_SETTLED: float = 0.01


def exact_rows(model: Model) -> BellmanRows:
    """The Bellman rows of ``model`` (cached on a FiniteMDP; the rows themselves otherwise)."""
    if isinstance(model, BellmanRows):
        return model
    if not isinstance(model, FiniteMDP):
        raise ValidationError(f"expected a FiniteMDP or BellmanRows; got {type(model).__name__}")
    cached = model.__dict__.get("_exact_rows")
    if cached is None:
        cached = BellmanRows.from_mdp(model)
        model.__dict__["_exact_rows"] = cached
    return cached


def post_decision_rows(model: Model) -> PostDecisionRows | None:
    """The verified post-decision form of an MDP (cached on it), or ``None``.

    ``None`` for row systems and for MDPs without the form (see
    :class:`~lpbounds.rows.PostDecisionRows`).
    """
    if not isinstance(model, FiniteMDP):
        return None
    cached = model.__dict__.get("_post_decision")
    if cached is None:
        cached = PostDecisionRows.detect(model) or False
        model.__dict__["_post_decision"] = cached
    return cached if isinstance(cached, PostDecisionRows) else None


def _default_tol(rows: BellmanRows | PostDecisionRows, tol: float | None) -> float:
    """``tol`` checked, or :func:`lpbounds.tolerances.dp_default_tol` of the rows."""
    if tol is not None:
        return check_real("tol", tol, lo=0.0, lo_open=True)
    if isinstance(rows, PostDecisionRows):
        # disallowed rewards are stored as 0, so this is max|R| over the allowed pairs,
        # the same number as on the exact rows; the outcomes per pair are those per row
        rmax, n_out = rows.reward_absmax, int(rows.outcomes.shape[1])
    else:
        rmax, n_out = float(np.abs(rows.reward).max(initial=0.0)), rows.n_outcomes
    tol_ = dp_default_tol(rmax, rows.discount, n_out, row_delta=rows.row_sums().delta)
    if not np.isfinite(tol_):  # refused by FiniteMDP / from_arrays (MAX_VALUE_SCALE)
        raise ValidationError(f"the value scale max|R| / (1 - discount) of {rmax} overflows")
    return tol_


def _initial(initial: Any, n: int) -> np.ndarray:
    """The starting vector: zeros, or ``initial`` checked and copied (once): an array of
    its own, which the loops overwrite.

    Its entries must be finite and within ``MAX_VALUE_SCALE`` (the largest accepted
    ``|V*|``): a starting point beyond every possible value only risks overflow.
    """
    if initial is None:
        return np.zeros(n)
    v = check_vector("initial", initial, n)
    big = np.abs(v) > MAX_VALUE_SCALE
    if big.any():
        i = int(np.flatnonzero(big)[0])
        raise ValidationError(
            f"initial[{i}] = {v[i]:.3g} exceeds {MAX_VALUE_SCALE:g} in magnitude "
            "(no value function is that large: lpbounds.validation.MAX_VALUE_SCALE)"
        )
    # a fresh array owns its data; ``initial`` itself or a view of the caller's buffer is copied
    return v if v is not initial and v.flags.owndata else v.copy()


def _check_callback(callback: Any) -> None:
    if callback is not None and not callable(callback):
        raise ValidationError(f"callback must be callable or None; got {callback!r}")


def _policy_out(model: Model, rows: BellmanRows, policy_rows: np.ndarray) -> np.ndarray:
    """Actions per state for an MDP, row indices for a row system."""
    if isinstance(model, FiniteMDP):
        return rows.action[policy_rows].astype(np.int64)
    return policy_rows


def _check_policy(policy: Any, n: int, mdp: FiniteMDP | None = None) -> np.ndarray:
    """A policy as an integer array of length ``n``; for an MDP, an allowed action per state.

    Ranges are checked in the given dtype, before any narrowing cast.
    """
    pol = check_array("policy", policy, integer=True)
    if pol.shape != (n,) or pol.dtype.kind not in "iu":
        raise ValidationError(f"a policy must be {n} integers; got {pol.shape} {pol.dtype}")
    if mdp is not None:
        bad = (pol < 0) | (pol >= mdp.n_actions)
        if bad.any():
            x = int(np.flatnonzero(bad)[0])
            raise ValidationError(f"policy[{x}] = {int(pol[x])} is not an action index")
        ok = mdp.allowed[np.arange(n), pol]
        if not ok.all():
            x = int(np.flatnonzero(~ok)[0])
            raise ValidationError(f"policy[{x}] = {int(pol[x])} is not allowed in state {x}")
    return pol


def _policy_rows(model: Model, rows: BellmanRows, policy: Any) -> np.ndarray:
    if isinstance(model, FiniteMDP):
        pol = _check_policy(policy, rows.n_vars, model)
        assert rows.pair_row is not None
        return rows.pair_row[np.arange(rows.n_vars), pol]
    pol = _check_policy(policy, rows.n_vars)
    bad = (pol < rows.indptr[:-1]) | (pol >= rows.indptr[1:])
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValidationError(f"policy[{i}] = {int(pol[i])} is not a row of owner {i}")
    return pol.astype(np.int64)


# ---------------------------------------------------------------------- results
@dataclass(repr=False)
class DPResult(Result):
    """Outcome of :func:`solve_exact`.

    A :class:`lpbounds.results.Result`: :attr:`ok`, a one-line ``repr``, ``summary()``,
    an HTML table in Jupyter and ``to_pandas()`` (with the ``policy`` column) come from
    there.

    Attributes
    ----------
    values : ndarray
        ``V``, within ``error_bound`` of ``V*`` in the max norm.
    policy : ndarray of int
        A policy greedy w.r.t. ``values`` (first maximising action; the exact maximiser
        of the returned ``values``): actions per state for an MDP, rows per owner for
        a row system.
    policy_rows : ndarray of int
        The row chosen at each owner (for the matrix-free patrol operator, which stores no
        rows, the same int8 array as ``policy``: :func:`lpbounds.patrol.matrix_free.solve_vstar`).
    residual : float
        ``||T values - values||_inf``, measured on the returned vector.
    error_bound : float
        ``(residual + slack) / (1 - discount)``, a bound on ``||values - V*||_inf``; the
        slack of a few ulps of ``max|V|`` covers the rounding of the residual itself
        (:func:`lpbounds.tolerances.error_bound`).
    tol : float
        The stopping tolerance on ``residual``.
    iterations : int
        Improvement steps (Bellman sweeps with a max) performed.
    sweeps : int
        All sweeps over the rows, improvement and evaluation.
    seconds : float
    method : str
    status : lpbounds.status.Status
        ``OPTIMAL`` when ``residual <= tol`` (so ``error_bound`` holds at the requested
        accuracy), ``ITERATION_LIMIT`` when the iteration stopped at ``max_iter``
        (only returned with ``raise_on_failure=False``; ``values`` and ``error_bound``
        are still valid, only wider).
    history : list of float
        The residual at each improvement step.
    rational_values : RationalVector or None
        ``arithmetic="rational"`` only: the exact fixed point of the stored model, a
        sequence of :class:`~fractions.Fraction` (one per state; made on first access,
        numerators over one common denominator until then: see
        :class:`lpbounds.exact.rationals.RationalVector`). ``values`` are then their
        nearest doubles and ``error_bound`` their exact distance from it, rounded up.
    arithmetic : str
        ``"float"`` or ``"rational"``.
    lower_values, upper_values : ndarray
        The certified bracket ``lower_values <= V* <= upper_values`` (properties, see
        :attr:`lower_values`).
    ok : bool
        ``status is Status.OPTIMAL`` (:attr:`lpbounds.results.Result.ok`).
    converged : bool
        Alias of ``ok``, kept for existing code.
    """

    values: np.ndarray
    policy: np.ndarray
    policy_rows: np.ndarray
    residual: float
    error_bound: float
    tol: float
    iterations: int
    sweeps: int
    seconds: float
    method: str
    status: Status
    history: list[float] = field(default_factory=list)
    rational_values: RationalVector | None = None
    arithmetic: str = "float"

    @property
    def converged(self) -> bool:
        """Alias of :attr:`ok`: the residual reached ``tol`` (``status is Status.OPTIMAL``)."""
        return self.ok

    @property
    def lower_values(self) -> np.ndarray:
        """``values - error_bound`` rounded toward ``-inf``: ``lower_values <= V*``.

        Why it contains ``V*``: ``error_bound`` is a certified bound on ``||values -
        V*||_inf`` (module docstring, "Stopping rule and error bound"), so ``values(x) -
        error_bound <= V*(x)`` in exact arithmetic; the computed difference is the float
        nearest the exact one, and one ``np.nextafter`` toward ``-inf`` moves it to or
        below the exact difference, which covers the rounding of that one operation
        (:func:`lpbounds.results.outward_bracket`). Computed on each access (a new
        array the size of ``values``).
        """
        return outward_bracket(self.values, self.error_bound)[0]

    @property
    def upper_values(self) -> np.ndarray:
        """``values + error_bound`` rounded toward ``+inf``: ``V* <= upper_values`` (the
        mirror image of :attr:`lower_values`)."""
        return outward_bracket(self.values, self.error_bound)[1]

    # ------------------------------------------------------------------ Result hooks
    def label(self) -> str:
        """The method ("mpi", "vi", "pi", "ipi", "game-vi", ...)."""
        return self.method

    def summary_items(self) -> list[tuple[str, str]]:
        """The residual against its tolerance, the sweeps and the time."""
        return [
            ("residual", f"||T V - V||_inf = {self.residual:.3e} (tol {self.tol:.3e})"),
            ("sweeps", f"{self.sweeps} in all, {self.seconds:.3f} s"),
        ]

    def table_columns(self) -> dict[str, np.ndarray]:
        """The greedy ``policy`` per state (per owner for a row system)."""
        return {"policy": self.policy}


@dataclass
class PolicyEvaluation:
    """Outcome of :func:`evaluate_policy`: ``V_pi`` with its residual and error bound.

    Attributes
    ----------
    values : ndarray
        ``V_pi`` up to ``error_bound``.
    residual : float
        ``||T_pi values - values||_inf``, measured on the returned vector.
    error_bound : float
        A bound on ``||values - V_pi||_inf`` (:func:`lpbounds.tolerances.error_bound`).
    method : str
    sweeps : int
    seconds : float
    lower_values, upper_values : ndarray
        The certified bracket ``lower_values <= V_pi <= upper_values`` (properties:
        ``values -+ error_bound`` rounded outward, as :attr:`DPResult.lower_values`).
    """

    values: np.ndarray
    residual: float
    error_bound: float
    method: str
    sweeps: int
    seconds: float

    @property
    def lower_values(self) -> np.ndarray:
        """``values - error_bound`` rounded toward ``-inf``: ``lower_values <= V_pi``
        (why: :attr:`DPResult.lower_values`, with ``V_pi`` for ``V*``)."""
        return outward_bracket(self.values, self.error_bound)[0]

    @property
    def upper_values(self) -> np.ndarray:
        """``values + error_bound`` rounded toward ``+inf``: ``V_pi <= upper_values``."""
        return outward_bracket(self.values, self.error_bound)[1]


@dataclass
class PorteusBounds:
    r"""The Porteus (1975) bounds from a candidate value vector ``V`` (paper Sec. 3.3).

    With ``alpha = T V - V`` and ``pi`` greedy w.r.t. ``V``:
    ``lower_paper = V + min(alpha) / (1 - lambda) <= lower = T V + lambda/(1-lambda) min(alpha)
    <= V_pi <= V* <= upper = T V + lambda/(1-lambda) max(alpha)``.

    For rows whose exact sums lie in ``[lo, hi]`` (:class:`lpbounds.stochastic.RowSums`;
    ``lo = hi = 1`` is the textbook case) each ``lambda`` above is ``lambda s``, with
    the ``s`` in ``{lo, hi}`` that makes the bound weakest: ``T^{k+1} V - T^k V >= a``
    implies ``T^{k+2} V - T^{k+1} V >= lambda s a`` for ``s = lo`` when ``a >= 0`` and
    ``s = hi`` when ``a < 0`` (and the mirror image above), so the tail of the series
    sums to ``a lambda s / (1 - lambda s)``.

    In floating point: ``alpha``'s extremes are widened by the rounding allowance of a
    computed ``T V - V`` (:func:`lpbounds.stochastic.bellman_margin`), every factor is
    rounded away from the bound and the bounds are rounded outward by one ulp, so they
    hold for the exact ``V_pi`` and ``V*`` of the stored rows (tested against exact
    rational arithmetic in ``tests/test_row_sums.py``).
    """

    lower: np.ndarray
    lower_paper: np.ndarray
    upper: np.ndarray
    policy: np.ndarray
    alpha_min: float
    alpha_max: float


def _absmax(v: np.ndarray) -> float:
    """``max |v|`` (0 for an empty ``v``) without a temporary of the vector's size: the
    same number as ``np.abs(v).max(initial=0.0)``, NaN included."""
    return max(abs(float(v.max(initial=0.0))), abs(float(v.min(initial=0.0))))


@dataclass
class LoopResult:
    """Where a solver loop (:func:`mpi_loop`, policy iteration, IPI) stopped.

    Attributes
    ----------
    values : ndarray
        The returned vector (the loop's starting vector, overwritten, or its other one).
    arg : ndarray
        The choices of the last improvement sweep, greedy w.r.t. ``values`` (rows for
        :class:`~lpbounds.rows.BellmanRows`, actions for the post-decision form and the
        matrix-free operator).
    residual : float
        ``||T values - values||_inf`` (a bound on it for rows not stochastic to rounding,
        :class:`PorteusShift`).
    iterations : int
        Improvement steps.
    sweeps : int
        All sweeps, improvement and evaluation.
    converged : bool
        ``residual <= tol``.
    history : list of float
        The residual at each improvement step.
    """

    values: np.ndarray
    arg: np.ndarray
    residual: float
    iterations: int
    sweeps: int
    converged: bool
    history: list[float] = field(default_factory=list)

    def finish(
        self,
        method: str,
        policy: np.ndarray,
        policy_rows: np.ndarray,
        tol: float,
        kappa: float,
        t0: float,
        raise_on_failure: bool,
    ) -> DPResult:
        """The :class:`DPResult` of the finished loop, or ConvergenceError if it stopped short.

        The returned vector and its residual are checked once here (never per sweep): a
        non-finite value (float64 overflow, e.g. from a huge but finite ``initial``) can
        make the sweep's residual extremes meaningless, so it raises instead of being
        reported with a residual. ``kappa`` is the contraction modulus (:func:`modulus`),
        ``t0`` the solve's start (``time.perf_counter()``).
        """
        res, its = self.residual, self.iterations
        vmax = _absmax(self.values)  # no temporary: the matrix-free path has two vectors
        if not (np.isfinite(vmax) and np.isfinite(res)):
            raise ConvergenceError(
                f"{method} produced non-finite values (float64 overflow; max|V| = {vmax}, "
                f"residual {res}): start from a smaller initial vector or rescale the rewards"
            )
        if not self.converged and raise_on_failure:
            raise ConvergenceError(
                f"{method} stopped after {its} iterations with residual {res:.3e} > tol "
                f"{tol:.3e}; raise max_iter or tol"
            )
        return DPResult(
            values=self.values,
            policy=policy,
            policy_rows=policy_rows,
            residual=res,
            error_bound=error_bound(res, vmax, kappa),
            tol=tol,
            iterations=its,
            sweeps=self.sweeps,
            seconds=time.perf_counter() - t0,
            method=method,
            status=Status.OPTIMAL if self.converged else Status.ITERATION_LIMIT,
            history=self.history,
        )


@dataclass
class PolicyLoop:
    """Where :func:`evaluation_loop` stopped.

    Attributes
    ----------
    values : ndarray
        ``V`` (the loop's first vector or its other one; ``u + c`` formed in place).
    residual : float
        ``||T_pi V - V||_inf`` measured by one more sweep on ``values`` (with
        ``measure=False``: the residual of the same iterate from the extremes of the
        loop's last sweep and the offset, :meth:`PorteusShift.step`).
    sweeps : int
        Evaluation sweeps, not counting the measuring one.
    """

    values: np.ndarray
    residual: float
    sweeps: int


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
        residual: see "Inexact policy iteration" in the module docstring; it is never
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
        ``"auto"`` (default): :data:`AUTO_EVAL_SWEEPS` once the policy has settled, none
        while it changes (see "Evaluation sweeps of MPI" in the module docstring; the
        answer's certificate is the same either way).
    extrapolate : bool
        Use the Porteus/MacQueen constant shift (see the module docstring).
    initial : array_like, optional
        Starting vector (default 0).
    evaluation : {"auto", "direct", "iterative"}
        Policy iteration's evaluation: sparse LU, sweeps, or LU up to 200,000 states
        (LU fills in on a random transition graph: see :func:`evaluate_policy`).
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
    _check_callback(callback)
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
    tol_ = _default_tol(rows, tol)
    v = _initial(initial, rows.n_vars)
    if method == "pi":
        run = _policy_iteration(model, rows, v, tol_, max_iter, evaluation, callback)
    elif method == "ipi":
        run = _inexact_pi(rows, v, tol_, max_iter, callback)
    else:
        m = eval_sweeps if method == "mpi" else 0
        run = mpi_loop(rows, v, tol_, max_iter, m, extrapolate, callback)
    return run.finish(
        method, _policy_out(model, rows, run.arg), run.arg, tol_, modulus(rows), t0,
        raise_on_failure,
    )  # fmt: skip


def _exact_model(model: Model) -> tuple[dict[str, Any], dict[str, Any], str]:
    """The certificate model data, the rows' spec and their name (for the size error)."""
    from ..exact.files import mdp_data, rows_data

    if isinstance(model, FiniteMDP):
        return mdp_data(model), {"rows": "ELP"}, "the MDP's states"
    if isinstance(model, BellmanRows):
        return rows_data(model), {"rows": "ROWS"}, "the row system's variables"
    raise ValidationError(f"expected a FiniteMDP or BellmanRows; got {type(model).__name__}")


def _exact_result(
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
        policy=fp.policy if fp.game else _policy_out(model, rows, fp.policy),
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


def _exact_callback(callback: Callback | None) -> Callable[[Any], None] | None:
    """The exact engine's progress events as ``callback(iteration, residual)`` calls (one
    per exact improvement check)."""
    if callback is None:
        return None

    def relay(event: Any) -> None:
        if event.stage == "improve":
            callback(event.iteration, event.residual)

    return relay


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

    _check_callback(callback)
    data, spec, what = _exact_model(model)
    fl = solve_exact(model, method, **float_options)
    rows = ExactRows.build(data, spec)
    fp = least_fixed_point(rows, fl.policy_rows, callback=_exact_callback(callback),
                           size_limit=size_limit, what=what)  # fmt: skip
    return _exact_result(model, fp, fl, t0, f"{fl.method}+exact-pi")


def check_eval_sweeps(eval_sweeps: Any) -> int | Literal["auto"]:
    """``eval_sweeps`` checked: ``"auto"`` or a non-negative integer.

    Raises
    ------
    ValidationError
        For anything else (a bool, a negative or non-integer number, another string).
    """
    if isinstance(eval_sweeps, str) and eval_sweeps == "auto":
        return "auto"
    if not is_int(eval_sweeps):
        raise ValidationError(
            f"eval_sweeps must be a non-negative integer or 'auto'; got {eval_sweeps!r}"
        )
    return check_int("eval_sweeps", eval_sweeps, lo=0)


class EvalPlan:
    """MPI's evaluation sweeps after each improvement: a fixed number, or the ``"auto"``
    rule of the module docstring ("Evaluation sweeps of MPI").

    Parameters
    ----------
    eval_sweeps : int or "auto"
        As checked by :func:`check_eval_sweeps`.
    """

    def __init__(self, eval_sweeps: int | str) -> None:
        self.fixed = None if eval_sweeps == "auto" else int(eval_sweeps)
        self.prev: np.ndarray | None = None  # the choices of the previous improvement

    @property
    def ever(self) -> bool:
        """False when no evaluation sweep will ever run (value iteration)."""
        return self.fixed != 0

    def count(self, arg: np.ndarray) -> int:
        """Evaluation sweeps after the improvement that chose ``arg`` (rows or actions:
        one to one on the states' allowed actions, so both count the same changes)."""
        if self.fixed is not None:
            return self.fixed
        if self.prev is None:
            self.prev = arg.copy()
            return 0
        changed = 0
        step = 1 << 22  # in blocks: no temporary of the states' size (534 M at 6 stations)
        for b in range(0, arg.size, step):
            changed += int(np.count_nonzero(arg[b : b + step] != self.prev[b : b + step]))
        self.prev[:] = arg
        return AUTO_EVAL_SWEEPS if changed <= AUTO_SETTLED * arg.size else 0


#: The pre-protocol private name (tests/test_dp.py imports it): remove once it uses EvalPlan.


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
    tol_ = _default_tol(ps, tol)
    v = _initial(initial, ps.n_vars)
    m = eval_sweeps if method == "mpi" else 0
    if method == "ipi":
        run = _inexact_pi(ps, v, tol_, max_iter, callback)
    else:
        run = mpi_loop(ps, v, tol_, max_iter, m, extrapolate, callback)
    act = run.arg
    return run.finish(
        method, act.astype(np.int64), ps.rows_of(act), tol_, modulus(ps), t0, raise_on_failure
    )


#: Below this many value reads per sweep the sweeps run on one thread: a parallel region
#: costs a wake-up of the other threads (tens of microseconds on an idle machine,
#: milliseconds on a busy one), more than a small sweep itself. Measured on the patrol
#: model (16,320 states) on a loaded 2-core machine: 0.03 s on one thread, 1-4 s on two.
SERIAL_SWEEP_READS: int = 1_000_000


@contextmanager
def threads_for(ops: SweepOperator) -> Iterator[None]:
    """Run the enclosed sweeps of ``ops`` on one thread when they are small.

    Below :data:`SERIAL_SWEEP_READS` values read per sweep (``ops.sweep_reads``) the
    compiled kernels' thread count (:func:`lpbounds._kernels.dispatch.set_threads`) is set
    to 1 for the block and restored after. Only compiled sweeps have threads.
    """
    if not ops.compiled:
        yield
        return
    before = _backend.get_threads()
    serial = before > 1 and ops.sweep_reads < SERIAL_SWEEP_READS
    if serial:
        _backend.set_threads(1)
    try:
        yield
    finally:
        if serial:
            _backend.set_threads(before)


#: The pre-protocol private name (lpbounds.formulations.nlp.problem imports it): remove once it
#: uses threads_for.


def _serial_if_small(func: Callable[..., Any]) -> Callable[..., Any]:
    """Run ``func(ops, ...)`` with the thread count :func:`threads_for` picks for ``ops``."""

    @functools.wraps(func)
    def wrapper(ops: Any, *args: Any, **kwargs: Any) -> Any:
        with threads_for(ops):
            return func(ops, *args, **kwargs)

    return wrapper


class ThreadChoice:
    """One thread or all of the compiled kernels' for the sweeps of one large solve, chosen
    by timing (the count of :func:`lpbounds._kernels.dispatch.set_threads`).

    Two threads halve a sweep on an idle 2-core machine, but when other jobs hold the
    cores, a parallel region waits for a descheduled thread and one thread is faster
    (measured: a random MDP of 2,048,000 x 3 x 5 took 10.6 s on one thread and 13.7-14.7 s
    on two with one core busy). Sweeps of one kind (improvement, evaluation) are timed
    against each other: sweep 0 of a kind pays first-touch page faults and is not timed;
    the first kind to get that far runs sweep 1 on one thread and sweeps 2 and 3 on all
    (:attr:`MANY_SAMPLES`), and keeps all threads if their mean is below :attr:`PREFER`
    times the one thread's. That choice holds for every kind (they stall alike when a core
    is taken; a one-thread sample of the garnet's improvement sweep costs 80 ms, of its
    evaluation sweep 30). Every :attr:`RECHECK` sweeps of a kind, the other count is timed
    again and taken for that kind if faster by :attr:`MARGIN` than the median of the
    chosen count's last three (the load changes). Sweeps below :data:`SERIAL_SWEEP_READS`
    always run on one thread (:func:`threads_for`). The thread count changes no number:
    every state's value is computed by the same arithmetic on whichever thread, and the
    residual extremes are exact minima and maxima.
    """

    MANY_SAMPLES: int = 2
    RECHECK: int = 32
    MARGIN: float = 0.9
    #: All threads are kept only when their mean sweep is this much faster than one
    #: thread's: on a loaded machine their times scatter (a descheduled thread stalls the
    #: region), and two lucky samples made the choice lose to one thread (patrol MPI, load
    #: 7: one thread 3.8-4.9 s, all 6.7-9.4 s, a plain lower-mean choice 5.4-5.6 s).
    PREFER: float = 0.85

    def __init__(self, ops: SweepOperator) -> None:
        self.many = 1
        if ops.compiled and ops.sweep_reads >= SERIAL_SWEEP_READS:
            self.many = _backend.get_threads()
        self.current = self.many
        self.count: dict[str, int] = {}  # sweeps of each kind so far
        self.times: dict[tuple[str, int], list[float]] = {}
        self.chosen: dict[str, int] = {}
        self.first: int | None = None  # the first choice made, adopted by every kind

    @property
    def n_calibrate(self) -> int:
        """Sweeps of the first kind before the first choice (sweep 0 untimed, one sample
        on one thread, :attr:`MANY_SAMPLES` on all)."""
        return 2 + self.MANY_SAMPLES

    def start(self, kind: str) -> int:
        """Set the kernels' thread count for the next sweep of ``kind``; returns it."""
        if self.many == 1:
            return 1
        i = self.count.get(kind, 0)
        if kind not in self.chosen and self.first is not None:
            self.chosen[kind] = self.first
        if kind not in self.chosen:
            want = 1 if i == 1 else self.many
        elif i > 0 and i % self.RECHECK == 0:
            want = 1 if self.chosen[kind] != 1 else self.many
        else:
            want = self.chosen[kind]
        self._set(want)
        return want

    def stop(self, kind: str, threads: int, seconds: float) -> None:
        """Record the time of the sweep of ``kind`` just run on ``threads``."""
        if self.many == 1:
            return
        i = self.count.get(kind, 0)
        self.count[kind] = i + 1
        if i == 0:
            return
        mine = self.times.setdefault((kind, threads), [])
        mine.append(seconds)
        chosen = self.chosen.get(kind)
        if chosen is None:
            if i == self.n_calibrate - 1:
                fast = self._mean(kind, self.many) < self.PREFER * self._mean(kind, 1)
                self.chosen[kind] = self.first = self.many if fast else 1
            return
        if threads != chosen:
            # against the median of the chosen count's last three sweeps: one slow sweep
            # flipped a 256,000-state garnet to one thread (2.1 ms sweeps, one of 5.1 ms)
            recent = float(np.median(self.times.get((kind, chosen), [np.inf])[-3:]))
            if seconds < self.MARGIN * recent:
                self.chosen[kind] = threads

    def timed(self, kind: str, sweep: Callable[..., tuple[float, float]], *args: Any) -> Any:
        """``sweep(*args)`` on the thread count :meth:`start` sets for ``kind``, timed into
        :meth:`stop`; returns what the sweep returns."""
        k = self.start(kind)
        t = time.perf_counter()
        out = sweep(*args)
        self.stop(kind, k, time.perf_counter() - t)
        return out

    def _mean(self, kind: str, threads: int) -> float:
        return float(np.mean(self.times.get((kind, threads)) or [np.inf]))

    def _set(self, k: int) -> None:
        if k != self.current:
            _backend.set_threads(k)
            self.current = k

    def restore(self) -> None:
        """Back to the kernels' thread count at the start."""
        self._set(self.many)


#: The pre-protocol private name (tests/test_fast_paths.py and benchmarks/bench_dp.py use
#: it): remove once they use ThreadChoice.


class PorteusShift:
    """The Porteus offset algebra of an iterate ``v = u + c``, shared by every sweep loop.

    Given the extremes ``lo, hi`` of ``T u - u`` (``T`` a max, game or fixed-policy
    operator of rows whose exact sums lie in ``[1 - delta, 1 + delta]``),
    :meth:`step` returns the residual of ``v`` and the offset after the sweep.
    ``T(v) = T u + lambda c`` holds for stochastic rows; in general each row gains
    ``lambda s_r c``, so the residual extremes of ``v`` are those of ``T u - u`` less
    ``(1 - lambda) c``, within ``lambda |c| delta``, which :meth:`step` adds to the
    residual it returns: the residual is a bound on the true one, whatever the rows.

    Two modes (:data:`~lpbounds.tolerances.DP_OFFSET_ROWSUM_ATOL` decides):

    * rows stochastic to rounding (``delta`` at most that, every model whose rows were
      normalised): the offset is carried as a scalar (``u + c`` formed once, at the
      end) and the shift is ``lambda / (1 - lambda)`` times the residual's midpoint;
    * rows that are not (accepted sums ``1 +- 1e-9``): :meth:`settle` adds the offset to
      the iterate after every sweep, so ``c`` is 0 at each sweep and the residual is
      exactly the computed one, and the shift uses the mean effective discount
      ``kappa_m = lambda (lo + hi) / 2`` of the rows: ``kappa_m / (1 - kappa_m)``. The
      constant error mode then contracts by ``lambda (s_r - (lo + hi)/2) / (1 - kappa_m)
      < 1`` whenever ``lambda hi < 1``, which the model's validation guarantees.
    """

    def __init__(self, discount: float, sums: RowSums, tol: float = np.inf) -> None:
        self.lam = float(discount)
        self.delta = sums.delta
        self.fold = offset_folds(self.delta)
        # the most a carried offset may add to the residual (DP_OFFSET_CARRY_SHARE)
        self.carry_limit = DP_OFFSET_CARRY_SHARE * float(tol)
        if self.fold:
            km = self.lam * 0.5 * (sums.lo + sums.hi)
            self.gain = km / (1.0 - km)
        else:
            self.gain = self.lam / (1.0 - self.lam)

    def step(self, c: float, lo: float, hi: float, extrapolate: bool) -> tuple[float, float]:
        """``(residual of u + c, offset after the sweep)`` from the extremes of ``T u - u``."""
        lam = self.lam
        lo -= (1.0 - lam) * c
        hi -= (1.0 - lam) * c
        c_next = lam * c + (self.gain * 0.5 * (lo + hi) if extrapolate else 0.0)
        res = max(-lo, hi)
        if c != 0.0 and self.delta > 0.0:
            res += lam * abs(c) * self.delta
        return res, c_next

    def settle(self, u: np.ndarray, c: float) -> float:
        """The offset to carry into the next sweep: ``c``, or 0 after ``u += c`` (folding).

        The offset is folded when the rows are not stochastic to rounding, and also when
        carrying it would add more than ``DP_OFFSET_CARRY_SHARE`` of the tolerance to the
        next residual (``lambda |c| delta``), so that residual can still reach it.
        """
        if c != 0.0 and (self.fold or self.lam * abs(c) * self.delta > self.carry_limit):
            u += c
            return 0.0
        return c


def modulus(ops: SweepOperator) -> float:
    """``lambda max_r sum_l p_{r,l}`` rounded up: the contraction modulus the error bounds use."""
    return ops.row_sums().modulus(ops.discount)


def _improvement(
    ops: SweepOperator, game: bool, work: np.ndarray | None
) -> Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[float, float]]:
    """The improvement sweep ``(u, out, arg) -> (lo, hi)``: ``T``, or the game's ``G``."""
    if game:  # the game operator exists on row systems only
        if not isinstance(ops, BellmanRows):
            raise ValidationError(f"the game operator needs BellmanRows; got {type(ops).__name__}")
        return ops.sweep_maxmin
    return functools.partial(ops.sweep_max, work=work)


@_serial_if_small
def mpi_loop(
    ops: SweepOperator,
    v: np.ndarray,
    tol: float,
    max_iter: int,
    eval_sweeps: int | Literal["auto"] = "auto",
    extrapolate: bool = True,
    callback: Callback | None = None,
    *,
    game: bool = False,
) -> LoopResult:
    """VI / MPI (and the game's VI) with the Porteus shift carried as a scalar offset.

    The iterate is ``v = u + c`` with ``u`` an array and ``c`` a scalar: since
    ``T(u + c) = T u + lambda c`` (and likewise for a fixed policy and for the game
    operator), a sweep computes ``T u`` and the extremes of ``T u - u`` in one pass, the
    residual extremes of ``v`` are those less ``(1 - lambda) c``, and the shift only
    updates ``c``. ``u + c`` is formed once, at the end, in place (:class:`PorteusShift`:
    rows that are not stochastic to rounding fold the offset into ``u`` after every sweep).
    The sweeps run on the thread count :class:`ThreadChoice` picks (no number changes).

    Parameters
    ----------
    ops : SweepOperator
    v : ndarray
        The starting vector, **overwritten** (the loop's first value vector; its second
        comes from ``ops.new_vector()``): pass a copy to keep it.
    tol : float
        Stop at the first improvement sweep whose residual is ``<= tol``.
    max_iter : int
        Limit on improvement steps (``max_iter + 1`` improvement sweeps at most).
    eval_sweeps : int or "auto"
        Evaluation sweeps after each improvement (:class:`EvalPlan`); 0 is value iteration.
    extrapolate : bool
        The Porteus/MacQueen shift.
    callback : callable(iteration, residual), optional
        Called after each improvement sweep.
    game : bool
        Improve with the game operator ``G`` (``ops`` must be :class:`BellmanRows`).

    Returns
    -------
    LoopResult
        ``values`` is ``v`` or the other vector, ``arg`` from ``ops.new_arg()``.
    """
    shift = PorteusShift(ops.discount, ops.row_sums(), tol)
    plan = EvalPlan(check_eval_sweeps(eval_sweeps))
    work = ops.new_work()  # reused by every sweep of this solve
    improve = _improvement(ops, game, work)
    evaluator = ops.evaluator(work) if plan.ever else None
    u, buf, arg = v, ops.new_vector(), ops.new_arg()
    run = LoopResult(u, arg, np.inf, max_iter, 0, False)
    c = 0.0
    threads = ThreadChoice(ops)
    try:
        for it in range(max_iter + 1):
            lo, hi = threads.timed("max", improve, u, buf, arg)
            run.sweeps += 1
            run.residual, c_next = shift.step(c, lo, hi, extrapolate)
            run.history.append(run.residual)
            if callback is not None:
                callback(it, run.residual)
            if run.residual <= tol:
                run.iterations, run.converged = it, True
                break
            if it == max_iter:
                break
            u, buf = buf, u
            c = shift.settle(u, c_next)
            m = plan.count(arg)
            if m == 0:
                continue
            assert evaluator is not None  # plan.ever
            evaluator.set_policy(arg)
            for _ in range(m):
                lo, hi = threads.timed("policy", evaluator.sweep, u, buf)
                run.sweeps += 1
                _, c_next = shift.step(c, lo, hi, extrapolate)
                u, buf = buf, u
                c = shift.settle(u, c_next)
    finally:
        threads.restore()
    del buf, evaluator
    u += c  # u + c, in place: the same numbers as a new vector, one vector less
    run.values = u
    return run


#: Inexact policy iteration: each evaluation stops when the max norm of its residual is at
#: most this fraction of the Bellman residual that started it (the forcing term), or at
#: half the requested tolerance once that is larger.
IPI_FORCING: float = 0.1
#: Krylov vectors per GMRES cycle (memory: that many vectors of the states' size).
IPI_RESTART: int = 20
#: Products (sweep equivalents) one evaluation may spend before the next improvement.
IPI_MAX_PRODUCTS: int = 200


@_serial_if_small
def _inexact_pi(
    ops: BellmanRows | PostDecisionRows,
    v: np.ndarray,
    tol: float,
    max_iter: int,
    callback: Callback | None,
) -> LoopResult:
    """Inexact policy iteration: improvement sweeps, GMRES evaluations of the greedy policy.

    At ``u`` the improvement sweep gives ``T u``, the greedy policy ``pi`` and the
    Bellman residual ``res = ||T u - u||``; the evaluation solves
    ``(I - lambda P_pi) d = T u - u`` (whose exact solution makes ``u + d = V_pi``) by
    GMRES until ``||T_pi(u + d) - (u + d)||_inf <= max(IPI_FORCING * res, tol / 2)``,
    right-preconditioned by ``1 / (1 - lambda P_pi(x, x))`` (self-loops). The product
    ``lambda P_pi z`` is the policy sweep with zero rewards. The returned residual is
    measured by a full improvement sweep on the returned vector, as for MPI. ``v`` is
    overwritten (the iterate).
    """
    from .krylov import gmres

    lam = ops.discount
    arg = ops.new_arg()
    work = ops.new_work()
    zero = ops.zero_rewards()
    u = v
    tu = ops.new_vector()
    prod = ops.new_vector()

    def apply(z: np.ndarray) -> np.ndarray:  # (I - lambda P_pi) z
        ops.sweep_policy(arg, z, prod, work=work, reward=zero)
        np.subtract(z, prod, out=prod)
        return prod

    run = LoopResult(u, arg, np.inf, max_iter, 0, False)
    for it in range(max_iter + 1):
        lo, hi = ops.sweep_max(u, tu, arg, work=work)
        run.sweeps += 1
        run.residual = res = max(-lo, hi)
        run.history.append(res)
        if callback is not None:
            callback(it, res)
        if res <= tol:
            run.iterations, run.converged = it, True
            break
        if it == max_iter:
            break
        dinv = 1.0 / (1.0 - lam * ops.self_loops(arg))
        target = max(IPI_FORCING * res, 0.5 * tol)
        d, k = gmres(apply, tu - u, target, IPI_RESTART, IPI_MAX_PRODUCTS, dinv)
        run.sweeps += k
        u += d
    return run


def _greedy_rows(
    rows: BellmanRows, v: np.ndarray, tie_rtol: float, prefer: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Greedy rows w.r.t. ``v`` (ties: ``prefer`` if tied, else the lowest action) and ``T v``."""
    q = rows.q_values(v)
    best = np.maximum.reduceat(q, rows.indptr[:-1])
    thr = best - tie_rtol * np.maximum(1.0, np.abs(best))
    cand = q >= thr[rows.owner]
    idx = np.flatnonzero(cand)
    _, first = np.unique(rows.owner[idx], return_index=True)
    sel = idx[first]
    if prefer is not None:
        keep = cand[prefer]
        sel = np.where(keep, prefer, sel)
    return sel.astype(np.int64), best


def _policy_iteration(
    model: Model,
    rows: BellmanRows,
    v: np.ndarray,
    tol: float,
    max_iter: int,
    evaluation: str,
    callback: Callback | None,
) -> LoopResult:
    """Policy iteration: exact evaluations (:func:`_evaluate_rows`), greedy improvements
    that keep a tied policy; the residual is measured by a max sweep at the end."""
    pol, _ = _greedy_rows(rows, v, GREEDY_TIE_RTOL)
    sweeps = 0
    hist: list[float] = []
    for it in range(1, max_iter + 1):
        ev = _evaluate_rows(rows, pol, evaluation, tol * (1 - rows.discount) * 0.1)
        v = ev.values
        sweeps += ev.sweeps
        new, tv = _greedy_rows(rows, v, GREEDY_TIE_RTOL, prefer=pol)
        sweeps += 1
        res = float(np.abs(tv - v).max())
        hist.append(res)
        if callback is not None:
            callback(it, res)
        if np.array_equal(new, pol):
            tv, arg = rows.apply_max(v)
            res = float(np.abs(tv - v).max())
            return LoopResult(v, arg, res, it, sweeps, res <= tol, hist)
        pol = new
    tv, arg = rows.apply_max(v)
    return LoopResult(v, arg, float(np.abs(tv - v).max()), max_iter, sweeps, False, hist)


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
    r"""Fixed point of ``(Gw)(i) = max_u min_{r in (i, u)} q_r(w)`` (Fact 2, :mod:`lpbounds.rows`).

    The least element of the disjunctive NLP's feasible set (eq. 25) when ``rows`` are
    the NLP's terms (``BellmanRows.aggregate(mdp, partition, reduce="min")``): the value
    of the zero-sum game in which the controller picks the action and an adversary the
    state of the partition. Value iteration with the Porteus shift (valid for ``G``:
    monotone, and ``G(w + c) = Gw + lambda c``); stops when ``||Gw - w||_inf <= tol``.

    With ``arithmetic="rational"`` the float value iteration runs first and starts exact
    strategy iteration (:func:`lpbounds.exact.game_fixed_point`) on the rows as stored
    (each double taken exactly); the result is as :func:`solve_exact`'s with
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
    tol_ = _default_tol(rows, tol)
    max_iter = check_int("max_iter", max_iter, lo=1)
    raise_on_failure = check_bool("raise_on_failure", raise_on_failure)
    _check_callback(callback)
    v = _initial(initial, rows.n_vars)
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

    _check_callback(callback)
    fl = solve_game(rows, **float_options)
    er = ExactRows.build(rows_data(rows), {"rows": "ROWS"})
    fp = game_fixed_point(
        er,
        fl.values,
        callback=_exact_callback(callback),
        size_limit=size_limit,
        what="the game's variables",
    )
    return _exact_result(rows, fp, fl, t0, "game-vi+exact-strategy-iteration")


# ---------------------------------------------------------------------- evaluation
def _evaluate_rows(
    rows: BellmanRows, sel: np.ndarray, method: str, tol: float, max_sweeps: int = 1_000_000
) -> PolicyEvaluation:
    t0 = time.perf_counter()
    lam = rows.discount
    r_pi = rows.reward[sel]
    if method == "auto":
        method = "direct" if rows.n_vars <= 200_000 else "iterative"
    if method == "direct":
        import scipy.sparse as sp  # 0.1 s to import: only where it is used
        import scipy.sparse.linalg as spla

        p = rows.transition_matrix(sel)
        a = sp.identity(rows.n_vars, format="csc") - lam * p.tocsc()
        v = np.asarray(spla.spsolve(a, r_pi), dtype=np.float64)
        sweeps = 0
    elif method == "iterative":
        run = evaluation_loop(rows, sel, tol, max_sweeps, measure=False)
        v, sweeps = run.values, run.sweeps
    else:
        raise ValidationError(f"unknown evaluation {method!r}; use 'direct' or 'iterative'")
    res = float(np.abs(rows.evaluate_rows(sel, v) - v).max())
    if method == "iterative" and res > tol:
        raise ConvergenceError(f"policy evaluation stopped with residual {res:.3e} > {tol:.3e}")
    return PolicyEvaluation(
        values=v,
        residual=res,
        error_bound=error_bound(res, float(np.abs(v).max(initial=0.0)), modulus(rows)),
        method=method,
        sweeps=sweeps,
        seconds=time.perf_counter() - t0,
    )


@_serial_if_small
def evaluation_loop(
    ops: SweepOperator,
    sel: np.ndarray,
    tol: float,
    max_sweeps: int,
    callback: Callback | None = None,
    *,
    measure: bool = True,
) -> PolicyLoop:
    """Extrapolated evaluation sweeps of a fixed policy from 0 until the residual is <= ``tol``.

    The Porteus shift is carried as a scalar offset as in :func:`mpi_loop`: the iterate
    is ``u + c``; ``T_pi(u + c) - (u + c) = (T_pi u - u) - (1 - lambda) c``
    (:class:`PorteusShift` for rows that are not stochastic). Two value vectors (zeros and
    ``ops.new_vector()``); ``u + c`` is formed in place and, with ``measure``, its residual
    measured by one more sweep into the other vector.

    Parameters
    ----------
    ops : SweepOperator
    sel : ndarray
        The policy in the operator's choices (rows of a row system, int8 actions of the
        post-decision form and the matrix-free operator).
    tol : float
    max_sweeps : int
        Stop after this many sweeps whatever the residual (the caller checks it).
    callback : callable(sweep, residual), optional
        Called after every sweep (1, 2, ...).
    measure : bool
        Measure the residual of the returned vector (one more sweep).

    Returns
    -------
    PolicyLoop
    """
    shift = PorteusShift(ops.discount, ops.row_sums(), tol)
    sweep = functools.partial(ops.sweep_policy, sel, work=ops.new_work())
    u = np.zeros(ops.n_vars)
    buf = ops.new_vector()
    c, sweeps = 0.0, 0
    threads = ThreadChoice(ops)
    try:
        while True:
            lo, hi = threads.timed("policy", sweep, u, buf)
            sweeps += 1
            res, c_next = shift.step(c, lo, hi, True)
            if callback is not None:
                callback(sweeps, res)
            if res <= tol or sweeps >= max_sweeps:
                break
            u, buf = buf, u
            c = shift.settle(u, c_next)
        u += c  # u + c, in place
        if measure:  # on the returned vector
            lo, hi = threads.timed("policy", sweep, u, buf)
            res = max(-lo, hi)
    finally:
        threads.restore()
    return PolicyLoop(u, res, sweeps)


def _evaluate_post_decision(
    mdp: FiniteMDP, ps: PostDecisionRows, policy: Any, tol: float
) -> PolicyEvaluation:
    """Iterative policy evaluation on the post-decision form (actions, not rows)."""
    t0 = time.perf_counter()
    pol = _check_policy(policy, ps.n_vars, mdp)
    run = evaluation_loop(ps, pol.astype(np.int8), tol, 1_000_000)
    res = run.residual
    if res > tol:
        raise ConvergenceError(f"policy evaluation stopped with residual {res:.3e} > {tol:.3e}")
    return PolicyEvaluation(
        values=run.values,
        residual=res,
        error_bound=error_bound(res, _absmax(run.values), modulus(ps)),
        method="iterative",
        sweeps=run.sweeps,
        seconds=time.perf_counter() - t0,
    )


def evaluate_policy(
    model: Model,
    policy: Any,
    method: Literal["auto", "direct", "iterative"] = "auto",
    tol: float | None = None,
) -> PolicyEvaluation:
    """``V_pi``, the solution of ``(I - lambda P_pi) V = R_pi`` (paper eq. 31).

    Parameters
    ----------
    model : FiniteMDP or BellmanRows
    policy : array_like of int
        Actions per state (MDP) or rows per owner (row system).
    method : {"auto", "direct", "iterative"}
        Sparse LU (scipy's SuperLU), extrapolated sweeps to ``tol``, or LU up to
        200,000 states and sweeps beyond. LU's cost is its fill-in, which the structure
        decides: near-banded chains (the patrol, pymdptoolbox's forest) factor in
        milliseconds, a random transition graph fills in (a 10,000-state garnet's policy:
        LU 20 s, sweeps 15 ms; 2,000 states: 0.4 s and 4 ms): pass
        ``method="iterative"`` for such a model.
    tol : float, optional
        Residual target of the iterative method (default as in :func:`solve_exact`).

    Returns
    -------
    PolicyEvaluation
        ``residual = ||R_pi + lambda P_pi V - V||_inf`` measured on the result.
    """
    if method not in ("auto", "direct", "iterative"):
        raise ValidationError(f"unknown evaluation {method!r}; use 'direct' or 'iterative'")
    if isinstance(model, FiniteMDP) and (
        method == "iterative" or (method == "auto" and model.n_states > 200_000)
    ):
        ps = post_decision_rows(model)
        if ps is not None:
            return _evaluate_post_decision(model, ps, policy, _default_tol(ps, tol))
    rows = exact_rows(model)
    sel = _policy_rows(model, rows, policy)
    return _evaluate_rows(rows, sel, method, _default_tol(rows, tol))


def greedy_policy(model: Model, values: Any, tie_rtol: float = GREEDY_TIE_RTOL) -> np.ndarray:
    """A policy greedy w.r.t. ``values`` (paper Sec. 3.3 and eq. 30).

    Tie rule: every action whose Q-value is within
    ``tie_rtol * max(1, |max_u Q(x, u)|)`` of the maximum counts as tied, and the
    lowest action index among them is chosen (for a row system: the first row).

    Raises
    ------
    ValidationError
        If ``values`` has the wrong length or a NaN/inf entry (a NaN Q-value is never
        a maximum: the policy would silently miss states), or ``tie_rtol`` is not a
        finite number ``>= 0``.
    """
    rows = exact_rows(model)
    tie_rtol = check_real("tie_rtol", tie_rtol, lo=0.0)
    sel, _ = _greedy_rows(rows, check_vector("values", values, rows.n_vars), tie_rtol)
    return _policy_out(model, rows, sel)


def bellman_residual(model: Model, values: Any) -> float:
    """``||T V - V||_inf`` (``values`` must be finite: a NaN would be skipped by the max)."""
    ps = post_decision_rows(model)
    if ps is not None:
        v = check_vector("values", values, ps.n_vars)
        lo, hi = ps.sweep_max(v, ps.new_vector(), ps.new_arg())
        return max(-lo, hi)
    rows = exact_rows(model)
    v = check_vector("values", values, rows.n_vars)
    tv, _ = rows.apply_max(v)
    return float(np.abs(tv - v).max())


class _PorteusTail:
    """``sum_{k>=1} a (lambda s)^k = a lambda s / (1 - lambda s)`` rounded the safe way.

    ``s`` is the end of the rows' certified sums ``[lo, hi]`` that makes the tail weakest
    (see :class:`PorteusBounds`), each factor rounded away from the bound's side by a few
    ulps, so the result is a lower (upper) bound on the exact tail in floating point.
    """

    def __init__(self, discount: float, sums: RowSums) -> None:
        e = float(np.finfo(np.float64).eps)
        k_small = discount * sums.lo * (1.0 - 2.0 * e)  # kappa rounded down / up
        k_big = min(discount * sums.hi * (1.0 + 2.0 * e), 1.0)
        self.f_small = k_small / (1.0 - k_small) * (1.0 - 4.0 * e)  # lambda s / (1 - lambda s)
        self.f_big = k_big / ((1.0 - k_big) * (1.0 - 2.0 * e)) * (1.0 + 4.0 * e)
        self.g_small = 1.0 / (1.0 - k_small) * (1.0 - 4.0 * e)  # 1 / (1 - lambda s)
        self.g_big = 1.0 / ((1.0 - k_big) * (1.0 - 2.0 * e)) * (1.0 + 4.0 * e)
        self.e = e

    def lower(self, a: float, paper: bool = False) -> float:
        """A value at most the exact tail of ``a`` (``a / (1 - lambda s)`` with ``paper``)."""
        f = (
            (self.g_small if a >= 0 else self.g_big)
            if paper
            else (self.f_small if a >= 0 else self.f_big)
        )
        t = a * f
        return t - abs(t) * 2.0 * self.e

    def upper(self, a: float) -> float:
        """A value at least the exact tail of ``a``."""
        t = a * (self.f_big if a >= 0 else self.f_small)
        return t + abs(t) * 2.0 * self.e


def porteus_bounds(model: Model, values: Any) -> PorteusBounds:
    """The Porteus bounds of :class:`PorteusBounds` for a candidate ``V`` (finite, else
    :class:`~lpbounds.errors.ValidationError`)."""
    rows = exact_rows(model)
    v = check_vector("values", values, rows.n_vars)
    sums = rows.row_sums()
    sel, tv = _greedy_rows(rows, v, GREEDY_TIE_RTOL)
    # the lower bounds use the chosen policy's own Q-values, so a tie within
    # GREEDY_TIE_RTOL cannot make them invalid
    tpi = rows.evaluate_rows(sel, v)
    alpha = tpi - v
    a_lo = float(alpha.min())
    a_hi = float((tv - v).max())
    kappa = sums.modulus(rows.discount)
    m = bellman_margin(
        rows.n_outcomes, float(np.abs(rows.reward).max(initial=0.0)), kappa,
        float(np.abs(v).max(initial=0.0)), float(np.abs(tv).max(initial=0.0)),
    )  # fmt: skip
    tail = _PorteusTail(rows.discount, sums)
    down, up = -np.inf, np.inf
    return PorteusBounds(
        lower=np.nextafter(tpi - m + tail.lower(a_lo - m), down),
        lower_paper=np.nextafter(v + tail.lower(a_lo - m, paper=True), down),
        upper=np.nextafter(tv + m + tail.upper(a_hi + m), up),
        policy=_policy_out(model, rows, sel),
        alpha_min=a_lo,
        alpha_max=a_hi,
    )
