"""The result of an LP formulation: :class:`LPResult`, one type for every formulation."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..certification.certificate import Certificate
from ..results import Result
from ..status import Status
from ..tolerances import LP_CERT_RTOL

if TYPE_CHECKING:  # annotations only
    from ..exact.lp import ExactLP

__all__ = ["LPResult"]


@dataclass(repr=False)
class LPResult(Result):
    """The result of solving a formulation (one type for every formulation).

    A :class:`lpbounds.results.Result`: :attr:`ok`, a one-line ``repr``, ``summary()``,
    an HTML table in Jupyter and ``to_pandas()`` come from there.

    Attributes
    ----------
    formulation : str
        "ELP", "RLP", "SLP", "IB", "LLP", "ALP", "UBLP", "LBLP", ...
    status : Status
        Decided from the certificate (see the module docstring), not the solver's claim.
    objective : float
        ``c'x`` at the returned point (computed by lpbounds).
    x : ndarray
        The full primal vector of the LP.
    values : ndarray
        The value variables: per state for ELP, per partition for RLP/SLP/UBLP/LBLP,
        ``v_1`` for IB (all blocks in ``extra["blocks"]``), the weights ``r`` for ALP.
    state_values : ndarray or None
        ``Phi v`` per state, where the formulation has a state space.
    lower_values, upper_values : ndarray or None
        The certified bracket, valid in floating point. For a Bellman-row LP: on the LP's
        exact optimum, entry by entry like ``values`` (RLP/UBLP: ``partition.lift(
        upper_values) >= V*``; ELP: ``lower_values <= V* <= upper_values``; LBLP:
        ``lower_values(i) <= min_{x in S_i} V*(x)``). For ALP (no solver-free optimum): per
        state, on ``V*`` itself (``upper_values = Phi r + max(0, max(T Phi r - Phi r)) /
        (1 - lambda)``, rounded up). For LLP: on RLP's ``v*``. ``None`` when the formulation
        has no certificate (the cutting-plane loop's internal LPs).
    error_bound : float
        ``max |values - exact optimum|`` bound from the certificate (``inf`` without one).
    objective_bracket : tuple of float or None
        Certified ``[lo, hi]`` containing the LP's exact optimal objective (Bellman-row LPs).
    certificate : Certificate or None
        The full certificate (residuals, rounding margin, contraction modulus).
    duals : ndarray
        ``y >= 0``, one per row of ``A x >= b`` (the groups' duals stacked in row order).
    group_duals : dict of str to ndarray
        The same duals per named constraint group (``group_duals["bellman"]``, ...; the
        groups of :attr:`Formulation.constraints`).
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
        The absolute threshold the status was decided with: ``accuracy * max|R|`` on the
        certificate's Bellman residual (``accuracy * max|b|`` on ``primal_residual`` for
        an LP without a certificate).
    accuracy : float
        The requested relative accuracy.
    dual_residual : float
        ``||A'y - c||_inf``.
    gap : float
        The duality gap ``|c'x - b'y|`` at the returned primal and dual points (not a
        bracket width: that is ``upper_values - lower_values``, and on an
        :class:`~lpbounds.formulations.nlp.results.NLPResult` its ``width``).
    extra : dict
        Formulation-specific data (e.g. IB's blocks); ``extra["message"]`` on failure;
        ``extra["solver_claim"]`` ("infeasible" or "unbounded") where the solver claimed
        what the formulation's structure excludes; ``extra["lp_scaling"]`` (``{"b": kb,
        "c": kc}``) where the solver saw ``b 2**-kb`` and ``c 2**-kc``;
        ``extra["partition_note"]`` where the partition mixes the model's sink with live
        states (valid, loose bounds: :func:`lpbounds.model.checks.sink_block_note`), shown
        by :meth:`summary`.
    modified : bool
        True for a solve with ``extra_constraints``: then ``lower_values``/``upper_values``
        and ``certificate`` are about the ORIGINAL problem's optimum (still valid, see
        :meth:`Formulation.solve`), ``error_bound`` is ``inf`` and ``objective_bracket`` is
        ``(certified lower bound, inf)``.
    extra_residuals : tuple of float
        Per extra constraint, its largest violation at the returned point (cvxpy's
        ``violation()``, computed from the point).
    extra_duals : tuple of ndarray
        Per extra constraint, its dual (cvxpy's sign: ``>= 0`` for ``<=``/``>=``, free for
        ``==``).
    kkt_gap : float
        Modified solves only: the duality gap of the modified LP from all the duals,
        ``|c'x - D| + ||r||_1 max|x|`` (``D`` the Lagrangian dual value, ``r`` the
        stationarity residual; see :meth:`Formulation.solve`); ``nan`` otherwise.
    exact : ExactLP or None
        ``solve(..., arithmetic="rational")`` only: the LP's exact optimum with the exact
        primal and dual that prove it, the solver's exact error and whether its certified
        bracket held (:class:`lpbounds.exact.lp.ExactLP`).
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
    lower_values: np.ndarray | None = None
    upper_values: np.ndarray | None = None
    error_bound: float = float("inf")
    objective_bracket: tuple[float, float] | None = None
    certificate: Certificate | None = None
    accuracy: float = LP_CERT_RTOL
    extra: dict[str, Any] = field(default_factory=dict)
    group_duals: dict[str, np.ndarray] = field(default_factory=dict)
    modified: bool = False
    extra_residuals: tuple[float, ...] = ()
    extra_duals: tuple[np.ndarray, ...] = ()
    kkt_gap: float = float("nan")
    exact: ExactLP | None = None

    @property
    def relative_error(self) -> float:
        """The certified error relative to ``max|R| / (1 - lambda)`` (``inf`` without one,
        and for a modified solve, whose optimum has no certificate)."""
        if self.certificate is None or not np.isfinite(self.error_bound):
            return float("inf")
        return self.certificate.relative_error()

    # ------------------------------------------------------------------ Result hooks
    def label(self) -> str:
        """The formulation ("RLP", "ELP", ...)."""
        return self.formulation

    def summary_items(self) -> list[tuple[str, str]]:
        """The solver and its times, the residuals, the objective bracket, the message."""
        items = [
            (
                "solver",
                f"{self.solver}: compile {self.compile_seconds:.3f} s, "
                f"solve {self.solve_seconds:.3f} s",
            ),
            (
                "residuals",
                f"primal {self.primal_residual:.3e} (tol {self.residual_tol:.3e}), "
                f"dual {self.dual_residual:.3e}, duality gap {self.gap:.3e}",
            ),
        ]
        if self.objective_bracket is not None:
            lo, hi = self.objective_bracket
            items.append(("objective bracket", f"[{lo:.10g}, {hi:.10g}]"))
        items.append(
            ("relative error", f"{self.relative_error:.3e} (requested {self.accuracy:.1e})")
        )
        if self.modified:
            items.append(("modified", f"{len(self.extra_residuals)} extra constraints"))
        if "message" in self.extra:
            items.append(("message", str(self.extra["message"])))
        if "partition_note" in self.extra:
            items.append(("partition", str(self.extra["partition_note"])))
        return items
