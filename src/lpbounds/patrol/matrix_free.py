r"""Matrix-free exact DP for the patrol model: sweeps that compute the dynamics on the fly.

The array path (:meth:`PatrolModel.mdp` and :class:`lpbounds.rows.PostDecisionRows`)
stores ``(m + 1)`` successors per state and action; at 6 stations (534,773,760 states)
those arrays alone would take about 32 GB. The sweeps here store nothing per state but
the value vectors: the successors, rewards and (for the bounds) partitions are computed
inside compiled kernels (:mod:`lpbounds.patrol.sweeps`) that walk the states in index
order. The encoding is mixed radix, so the ``Gamma + 1`` consecutive states of a *row*
differ in one delay and their successors are arithmetic sequences of indices; a row's
successors are set up from the previous row's delays (a counter, carried), no state
index is decoded but a work chunk's first, and the two travel states at one node with
the same delays (headings +1 and -1) share their successors, so one row of sums serves
both.

Speed: ``benchmarks/bench_beyond.py --in-order`` measures a sweep against the array
path's on the paper's instance and records it in ``docs/benchmarks.md`` ("Matrix-free
sweeps in state order").

Same numbers as the array path
------------------------------
Every Q-value is computed with the array path's arithmetic, in its order:
``W = sum_l p_l v(g_l)`` accumulated from ``0.0`` over ``l = 0..m``, then
``q = R_u(x) + lambda W`` with ``R_u(x)`` the float :meth:`PatrolModel.rewards` stores;
the maximum keeps the first maximising action; a sweep returns the extremes of
``T v - v``. :class:`MatrixFreePatrol` implements the sweep protocol
(:class:`lpbounds.rows.SweepOperator`), so :func:`solve_vstar` and
:func:`evaluate_policy` run the very loops of :func:`lpbounds.solve_exact` and
:func:`lpbounds.evaluate_policy`'s iterative method (:func:`lpbounds.dp.mpi_loop`,
:func:`lpbounds.dp.evaluation_loop`: the same ``eval_sweeps`` rule, the Porteus shift
carried as a scalar offset, the thread choice), with the default tolerance
``dp_default_tol``, and both return the array path's vectors bit for bit
(``tests/patrol/test_matrix_free.py`` checks it; ``benchmarks/bench_beyond.py`` on the
paper's instance). Only the memory differs: the loops keep two value vectors (4.3 GB each
at 6 stations) and form ``u + c`` in place, and the policy is int8.

Certificate
-----------
``V*`` is certified as every exact-DP result is: the residual ``||T V - V||_inf`` is
measured by a full max sweep on the returned vector and turned into
:func:`lpbounds.tolerances.error_bound` (``(residual + rounding slack) / (1 - lambda)``);
the status is :attr:`Status.OPTIMAL` when the residual reached the tolerance.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Literal

import numpy as np

from .._kernels.threads import get_threads
from ..dp import DPResult, PolicyEvaluation, check_eval_sweeps, evaluation_loop, mpi_loop
from ..errors import ConvergenceError, ValidationError
from ..rows import PolicySweeps
from ..stochastic import RowSums, row_sums
from ..tolerances import GREEDY_TIE_RTOL, dp_default_tol, error_bound
from ..validation import check_int
from . import sweeps as sw
from .model import PatrolModel
from .params import PatrolParams

__all__ = [
    "MatrixFreePatrol",
    "check_finite",
    "evaluate_policy",
    "solve_vstar",
]


# ---------------------------------------------------------------------- the model
class MatrixFreePatrol:
    """The patrol MDP of one :class:`PatrolParams` as compiled sweeps (nothing stored per state).

    Parameters
    ----------
    params : PatrolParams, optional
        Default: the paper's example.

    Attributes
    ----------
    geometry : tuple of ndarray
        The arrays every kernel of :mod:`lpbounds.patrol.sweeps` takes first
        (:func:`lpbounds.patrol.sweeps.geometry`: sizes, plane table, station positions,
        index weights, alert distribution, loiter increments, penalties).

    Notes
    -----
    The state encoding, the dynamics and the partitions are those of
    :class:`~lpbounds.patrol.model.PatrolModel`; the sweeps (C,
    :mod:`lpbounds._kernels.patrolsweeps`) run in parallel over chunks of consecutive rows,
    one range of chunks per thread (:mod:`lpbounds._kernels.threads`).
    """

    def __init__(self, params: PatrolParams | None = None) -> None:
        pm = PatrolModel(params)
        p = pm.params
        self.params = p
        self.model = pm
        self.n_vars = int(p.n_states)
        self.discount = float(p.discount)
        self.geometry: sw.Geometry = sw.geometry(p)
        self._reward_absmax: float | None = None

    def __repr__(self) -> str:
        return f"MatrixFreePatrol(n_states={self.n_vars:,}, m={self.params.m})"

    #: The sweeps are compiled (for :func:`lpbounds.dp.threads_for`, which runs sweeps of
    #: fewer than ``SERIAL_SWEEP_READS`` reads on one thread, as the array path does).
    compiled: bool = True

    @property
    def n_rows(self) -> int:
        """State-action pairs at most (three actions per state): the size of a sweep."""
        return 3 * self.n_vars

    @property
    def n_outcomes(self) -> int:
        """Outcomes per pair, ``m + 1``."""
        return self.params.m + 1

    @property
    def sweep_reads(self) -> int:
        """Values a sweep reads at most, ``n_rows * n_outcomes`` (the thread rule of
        :func:`lpbounds.dp.threads_for`, as for the array path's rows)."""
        return self.n_rows * self.n_outcomes

    @staticmethod
    def nchunks() -> int:
        """Work chunks per sweep: eight per thread, for load balance. The per-chunk
        statistics of :meth:`greedy_gap` and :meth:`vsub_stats` (sums) depend on it, the
        sweeps' numbers do not."""
        return 8 * get_threads()

    def _walk(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The kernels' first arguments: the plane geometry (sizes, planes, stations, weights)."""
        return self.geometry[:4]

    def _dynamics(
        self,
    ) -> tuple[
        np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float
    ]:
        """The sweeps' first arguments: the geometry, then probabilities, rewards, discount."""
        return (*self.geometry, self.discount)

    @property
    def reward_absmax(self) -> float:
        """``max |R_u(x)|`` over the allowed pairs (one pass over the states, cached)."""
        if self._reward_absmax is None:
            geo, planes, sp, weights, _, inc, pent = self.geometry
            self._reward_absmax = float(
                sw.reward_absmax_pass(geo, planes, sp, weights, inc, pent, self.nchunks())
            )
        return self._reward_absmax

    def row_sums(self) -> RowSums:
        """Certified bounds on the exact sum of the alert distribution ``p_l``."""
        return row_sums(self.geometry[4])

    def modulus(self) -> float:
        """The contraction modulus ``lambda sum_l p_l`` (rounded up) of the error bounds."""
        return self.row_sums().modulus(self.discount)

    def default_tol(self) -> float:
        """:func:`lpbounds.solve_exact`'s default (:func:`lpbounds.tolerances.dp_default_tol`)."""
        return dp_default_tol(self.reward_absmax, self.discount, self.n_outcomes)

    # ------------------------------------------------------------------ sweep protocol
    # intended parallel: the SweepOperator signatures (rows/sweep.py), repeated by each operator
    def new_vector(self) -> np.ndarray:
        """An uninitialised float64 vector over the states."""
        return np.empty(self.n_vars)

    def new_arg(self) -> np.ndarray:
        """A zeroed array for the chosen action of every state (int8)."""
        return np.zeros(self.n_vars, dtype=np.int8)

    def new_work(self) -> None:
        """No scratch array: the sweeps keep a row's buffers per thread."""
        return None

    def evaluator(self, work: np.ndarray | None = None) -> PolicySweeps:
        """Evaluation sweeps of one policy at a time (in place: nothing to pack)."""
        return PolicySweeps(self)

    def sweep_max(
        self,
        v: np.ndarray,
        out: np.ndarray,
        arg: np.ndarray,
        *,
        work: np.ndarray | None = None,
        nchunks: int | None = None,
    ) -> tuple[float, float]:
        """``out = T v``, the first maximising action in ``arg`` (int8); returns the min and
        max of ``out - v`` (``work`` is unused; ``nchunks`` default :meth:`nchunks`)."""
        nc = self.nchunks() if nchunks is None else nchunks
        lo, hi = sw.max_sweep(*self._dynamics(), v, out, arg, nc)
        return float(lo), float(hi)

    def sweep_policy(
        self,
        sel: np.ndarray,
        v: np.ndarray,
        out: np.ndarray,
        *,
        work: np.ndarray | None = None,
        nchunks: int | None = None,
    ) -> tuple[float, float]:
        """``out = T_pi v`` for the actions ``sel`` (int8); returns min and max of ``out - v``."""
        nc = self.nchunks() if nchunks is None else nchunks
        lo, hi = sw.policy_sweep(*self._dynamics(), sel, v, out, nc)
        return float(lo), float(hi)

    # ------------------------------------------------------------------ passes
    def labels(self) -> np.ndarray:
        """The partition of every state, int32 (computed, as the model's :meth:`partition`)."""
        out = np.empty(self.n_vars, dtype=np.int32)
        sw.labels_pass(*self._walk(), out, self.nchunks())
        return out

    def check_policy(self, policy: Any) -> np.ndarray:
        """``policy`` as an int8 array of allowed actions, or a ValidationError naming the
        first state where it is not one."""
        pol = np.asarray(policy)
        if pol.shape != (self.n_vars,) or pol.dtype.kind not in "iu":
            raise ValidationError(
                f"a policy must be {self.n_vars} integers; got {pol.shape} {pol.dtype}"
            )
        if pol.size and (pol.min() < 0 or pol.max() > 2):
            x = int(np.flatnonzero((pol < 0) | (pol > 2))[0])
            raise ValidationError(f"policy[{x}] = {int(pol[x])} is not an action index 0..2")
        act = np.ascontiguousarray(pol, dtype=np.int8)
        x = int(sw.check_policy_pass(*self._walk(), act, self.nchunks()))
        if x >= 0:
            raise ValidationError(f"policy[{x}] = {int(act[x])} is not allowed in state {x}")
        return act

    def greedy_gap(
        self,
        vstar: np.ndarray,
        pistar: np.ndarray,
        w_low: np.ndarray,
        v_up: np.ndarray,
        loss_tol: float,
        tie_rtol: float = GREEDY_TIE_RTOL,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """One pass: ``pi_s`` greedy w.r.t. the lifted ``w_low`` and the gap statistics.

        Parameters
        ----------
        vstar : ndarray
            ``V*`` over the states.
        pistar : ndarray of int
            ``V*``'s policy (counts where ``pi_s`` differs from it).
        w_low, v_up : ndarray
            Lower and upper bounds per partition.
        loss_tol : float
            A one-step loss ``max_u Q*(x, u) - Q*(x, pi_s(x))`` above it counts as
            certainly suboptimal.
        tie_rtol : float
            Ties as in :func:`lpbounds.greedy_policy` (lowest action among them).

        Returns
        -------
        pi_s : ndarray of int8
        stats : dict
            ``upper_*`` (``v_up - V*``), ``lower_*`` (``V* - w_low``), ``gap_*``
            (``v_up - w_low``): max, mean, min with its state; ``optimal``, ``differs``,
            ``suboptimal`` (state counts) and ``max_one_step_loss``.
        """
        labels = self.labels()
        nch = self.nchunks()
        f = np.empty((nch, 9))
        st = np.empty((nch, 5), dtype=np.int64)
        pi_s = np.empty(self.n_vars, dtype=np.int8)
        sw.greedy_pass(
            *self._dynamics(),
            vstar,
            labels,
            np.ascontiguousarray(w_low, dtype=np.float64),
            np.ascontiguousarray(v_up, dtype=np.float64),
            np.ascontiguousarray(pistar, np.int8),
            float(tie_rtol),
            float(loss_tol),
            pi_s,
            f,
            st,
            nch,
        )
        del labels
        return pi_s, _reduce_greedy(f, st, self.n_vars)

    def vsub_stats(self, vstar: np.ndarray, vsub: np.ndarray, w_low: np.ndarray) -> dict[str, Any]:
        """Max, mean and min of ``vstar - vsub`` and the smallest ``vsub - w_low`` (the lifted
        lower bound), each with its state, in one pass."""
        nch = self.nchunks()
        f = np.empty((nch, 4))
        st = np.empty((nch, 3), dtype=np.int64)
        sw.vsub_pass(
            *self._walk(),
            vstar,
            vsub,
            np.ascontiguousarray(w_low, dtype=np.float64),
            f,
            st,
            nch,
        )
        c_max = int(np.argmax(f[:, sw.S_MAX]))
        c_min = int(np.argmin(f[:, sw.S_MIN]))
        c_low = int(np.argmin(f[:, sw.S_LOW_MIN]))
        return {
            "max": float(f[c_max, sw.S_MAX]),
            "argmax": int(st[c_max, sw.J_ARGMAX]),
            "mean": float(f[:, sw.S_SUM].sum() / self.n_vars),
            "min": float(f[c_min, sw.S_MIN]),
            "argmin": int(st[c_min, sw.J_ARGMIN]),
            "low_min": float(f[c_low, sw.S_LOW_MIN]),
            "low_argmin": int(st[c_low, sw.J_LOW_ARGMIN]),
        }


def _reduce_greedy(f: np.ndarray, st: np.ndarray, n: int) -> dict[str, Any]:
    """Merge the greedy pass's per-chunk statistics (:meth:`MatrixFreePatrol.greedy_gap`)."""
    up_c = int(np.argmin(f[:, sw.F_UP_MIN]))
    low_c = int(np.argmin(f[:, sw.F_LOW_MIN]))
    up_mean = float(f[:, sw.F_UP_SUM].sum() / n)
    low_mean = float(f[:, sw.F_LOW_SUM].sum() / n)
    gap_mean = float(f[:, sw.F_GAP_SUM].sum() / n)
    return {
        "upper_max": float(f[:, sw.F_UP_MAX].max()),
        "upper_mean": up_mean,
        "upper_min": float(f[up_c, sw.F_UP_MIN]),
        "upper_argmin": int(st[up_c, sw.I_UP_ARGMIN]),
        "lower_max": float(f[:, sw.F_LOW_MAX].max()),
        "lower_mean": low_mean,
        "lower_min": float(f[low_c, sw.F_LOW_MIN]),
        "lower_argmin": int(st[low_c, sw.I_LOW_ARGMIN]),
        "gap_max": float(f[:, sw.F_GAP_MAX].max()),
        "gap_mean": gap_mean,
        "upper_share": up_mean / gap_mean if gap_mean > 0 else float("nan"),
        "lower_share": low_mean / gap_mean if gap_mean > 0 else float("nan"),
        "optimal": int(st[:, sw.I_OPTIMAL].sum()),
        "differs": int(st[:, sw.I_DIFFERS].sum()),
        "suboptimal": int(st[:, sw.I_SUBOPT].sum()),
        "max_one_step_loss": float(f[:, sw.F_LOSS_MAX].max()),
    }


# ---------------------------------------------------------------------- solvers
Callback = Callable[[int, float], None]


def _absmax(v: np.ndarray) -> float:
    """``max |v|`` without a temporary of the vector's size."""
    return max(abs(float(v.max(initial=0.0))), abs(float(v.min(initial=0.0))))


def check_finite(what: str, v: np.ndarray, res: float) -> float:
    """``max |v|``, or a ConvergenceError naming ``what`` when it or ``res`` is not finite.

    No temporary of the vector's size (a 6-station vector is 4.3 GB).
    """
    vmax = _absmax(v)
    if not (np.isfinite(vmax) and np.isfinite(res)):
        raise ConvergenceError(
            f"{what} produced non-finite values (max|V| = {vmax}, residual {res})"
        )
    return vmax


def solve_vstar(
    mf: MatrixFreePatrol,
    *,
    eval_sweeps: int | Literal["auto"] = "auto",
    max_iter: int = 100_000,
    tol: float | None = None,
    callback: Callback | None = None,
    raise_on_failure: bool = True,
) -> DPResult:
    """``V*`` by modified policy iteration from 0: :func:`lpbounds.solve_exact`'s loop
    (:func:`lpbounds.dp.mpi_loop`: same numbers, bit for bit), in two value vectors.

    Parameters
    ----------
    mf : MatrixFreePatrol
    eval_sweeps : int or "auto"
        Evaluation sweeps per improvement step, as in :func:`lpbounds.solve_exact`
        (default ``"auto"``: none while the policy changes).
    max_iter : int
        Limit on improvement steps.
    tol : float, optional
        Stop when ``||T V - V||_inf <= tol``; default :meth:`MatrixFreePatrol.default_tol`.
    callback : callable(iteration, residual), optional
        Called after each improvement step.
    raise_on_failure : bool
        Raise ConvergenceError at ``max_iter`` (else return ``Status.ITERATION_LIMIT``).

    Returns
    -------
    DPResult
        ``policy`` is int8 (the first maximising action), and ``policy_rows`` is the same
        array: the operator's choices are its actions (it stores no rows).
    """
    t0 = time.perf_counter()
    eval_sweeps = check_eval_sweeps(eval_sweeps)
    max_iter = check_int("max_iter", max_iter, lo=1)
    tol_ = mf.default_tol() if tol is None else float(tol)
    if not tol_ > 0:
        raise ValidationError(f"tol must be a positive number; got {tol!r}")
    run = mpi_loop(mf, np.zeros(mf.n_vars), tol_, max_iter, eval_sweeps, True, callback)
    return run.finish("mpi", run.arg, run.arg, tol_, mf.modulus(), t0, raise_on_failure)


def evaluate_policy(
    mf: MatrixFreePatrol,
    policy: Any,
    *,
    tol: float | None = None,
    max_sweeps: int = 1_000_000,
    callback: Callback | None = None,
) -> PolicyEvaluation:
    """``V_pi`` by extrapolated evaluation sweeps: :func:`lpbounds.evaluate_policy`'s
    iterative method (:func:`lpbounds.dp.evaluation_loop`: same numbers, bit for bit), in
    two value vectors.

    The residual is measured by one more sweep on the returned vector; the error bound is
    :func:`lpbounds.tolerances.error_bound` of it. ``callback(sweep, residual)``, if given,
    is called after every sweep (progress of a long evaluation).

    Raises
    ------
    ValidationError
        ``policy`` is not one allowed action per state (names the first bad state).
    ConvergenceError
        The residual did not reach ``tol`` in ``max_sweeps`` sweeps.
    """
    t0 = time.perf_counter()
    act = mf.check_policy(policy)
    tol_ = mf.default_tol() if tol is None else float(tol)
    run = evaluation_loop(mf, act, tol_, max_sweeps, callback)
    res = run.residual
    vmax = check_finite("matrix-free policy evaluation", run.values, res)
    if res > tol_:
        raise ConvergenceError(f"policy evaluation stopped with residual {res:.3e} > {tol_:.3e}")
    return PolicyEvaluation(
        values=run.values,
        residual=res,
        error_bound=error_bound(res, vmax, mf.modulus()),
        method="iterative (matrix-free)",
        sweeps=run.sweeps,
        seconds=time.perf_counter() - t0,
    )
