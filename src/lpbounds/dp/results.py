"""What the solvers of :mod:`lpbounds.dp` return (:class:`DPResult`,
:class:`PolicyEvaluation`) and where their loops stop (:class:`LoopResult`,
:class:`PolicyLoop`), with the certified brackets ``values -+ error_bound``."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError
from ..results import Result, outward_bracket
from ..status import Status
from ..tolerances import error_bound

if TYPE_CHECKING:  # annotations only: python-flint loads when exact arithmetic is asked for
    from ..exact.rationals import RationalVector

__all__ = ["DPResult", "LoopResult", "PolicyEvaluation", "PolicyLoop", "absmax"]


# ---------------------------------------------------------------------- results
@dataclass(repr=False)
class DPResult(Result):
    """Outcome of :func:`~lpbounds.dp.solve_exact`.

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
        V*||_inf`` (:mod:`lpbounds.dp.solve`, "Stopping rule and error bound"), so ``values(x) -
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
    """Outcome of :func:`~lpbounds.dp.evaluate_policy`: ``V_pi`` with its residual and error bound.

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


def absmax(v: np.ndarray) -> float:
    """``max |v|`` (0 for an empty ``v``) without a temporary of the vector's size: the
    same number as ``np.abs(v).max(initial=0.0)``, NaN included."""
    return max(abs(float(v.max(initial=0.0))), abs(float(v.min(initial=0.0))))


@dataclass
class LoopResult:
    """Where a solver loop (:func:`~lpbounds.dp.mpi_loop`, policy iteration, IPI) stopped.

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
        :class:`~lpbounds.dp.PorteusShift`).
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
        reported with a residual. ``kappa`` is the contraction modulus
        (:func:`~lpbounds.dp.modulus`), ``t0`` the solve's start (``time.perf_counter()``).
        """
        res, its = self.residual, self.iterations
        vmax = absmax(self.values)  # no temporary: the matrix-free path has two vectors
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
    """Where :func:`~lpbounds.dp.evaluation_loop` stopped.

    Attributes
    ----------
    values : ndarray
        ``V`` (the loop's first vector or its other one; ``u + c`` formed in place).
    residual : float
        ``||T_pi V - V||_inf`` measured by one more sweep on ``values`` (with
        ``measure=False``: the residual of the same iterate from the extremes of the
        loop's last sweep and the offset, :meth:`~lpbounds.dp.PorteusShift.step`).
    sweeps : int
        Evaluation sweeps, not counting the measuring one.
    """

    values: np.ndarray
    residual: float
    sweeps: int
