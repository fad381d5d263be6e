"""The results of the disjunctive NLP: :class:`NLPResult` and its iteration log."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...certification.certificate import Certificate
from ...results import Result
from ...status import Status
from .stop import StopReason

__all__ = ["NLPIteration", "NLPResult"]


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


@dataclass(repr=False)
class NLPResult(Result):
    """The outcome of :meth:`NLP.solve`.

    A :class:`lpbounds.results.Result`: :attr:`ok`, a one-line ``repr``, :meth:`summary`,
    an HTML table in Jupyter and ``to_pandas()`` come from there.

    Every bound in it is certified from the returned point ``values`` alone
    (:func:`lpbounds.certification.certificate.certify` on the NLP's min-rows with the max-min
    operator
    ``G``), whatever the method or solver claimed.

    Attributes
    ----------
    formulation : str
        "NLP".
    method : str
    values : ndarray (M,)
        The method's point: ``w*`` up to ``error_bound`` (for the cutting planes, the best
        feasible point found, the incumbent of the upper bound; for the MILP the value of
        its strategy).
    state_values : ndarray (n,)
        ``Phi values``.
    lower_values, upper_values : ndarray (M,)
        The certificate's bracket: ``lower_values <= w* <= upper_values`` in floating
        point, hence ``lower_values(i) <= min_{x in S_i} V*(x)``. Taken from the
        certificate only (never from a solver's objective or a cutting-plane master).
    lower_bound, upper_bound : float
        ``Certificate.objective_bracket(cost)``: a certified bracket on ``c'w*``.
    gap : float
        The bracket width ``upper_bound - lower_bound`` on ``c'w*``, the number
        :attr:`width` names (the field keeps its name for the constructor and old code;
        it is not a duality gap, which :attr:`LPResult.gap
        <lpbounds.formulations.results.LPResult.gap>` is).
    status : lpbounds.status.Status
        ``OPTIMAL`` when the certified bracket closed to the requested gap: the computed
        residual ``||G values - values||_inf <= gap_rtol / 2 * max|R|``, so that
        ``max(upper_values - lower_values) <= gap_rtol * scale`` up to the certificate's
        rounding margin (``Certificate.is_accurate``); ``TIME_LIMIT`` /
        ``ITERATION_LIMIT`` / ``LIMIT`` when a limit stopped the method first (the point
        and its bracket are kept); ``INACCURATE`` when the method stopped on its own with
        a wider bracket (for example cutting planes that found no cut).
    stop_reason : StopReason
        Why the method stopped (:class:`~lpbounds.formulations.nlp.stop.StopReason`, a str
        enum: prints and serialises as its value); the status, not the stop reason, says
        whether the bracket is certified. For the MILP, its solver status and limit are in
        ``extra["milp_status"]`` and ``extra["milp_limit"]``.
    objective : float
        ``c'values``.
    residual : float
        ``||G values - values||_inf`` as computed.
    error_bound : float
        The certificate's ``||values - w*||_inf`` bound (contraction argument plus rounding
        margin).
    certificate : lpbounds.certification.certificate.Certificate
    iterations : int
        Rounds (cutting planes), strategies evaluated (strategy iteration), value
        iterations (fixed point), 1 (MILP).
    cuts : int
        Cutting planes only: cuts added (lift-and-project), or the monotone cuts in the
        last master (monotone; ``extra["resolved"]`` counts the resolved disjunctions).
    seconds : float
    log : list of NLPIteration
        The method's own bracket per iteration (the cutting planes' master bound is not
        rounding-certified; the final entry of the other methods is the certified one).
    cost : ndarray (M,)
        The partition cost ``c-bar``.
    solver : str
    gap_rtol : float
        The relative accuracy the method was asked for.
    scale : float
        ``max|R| / (1 - lambda)`` over the NLP's terms: the unit of ``gap_rtol``.
    extra : dict
        Method-specific data (``method_bracket``: the method's own bracket on ``c'w*``;
        the cuts, the MILP's raw point and status, ...).
    """

    formulation: str
    method: str
    values: np.ndarray
    state_values: np.ndarray
    lower_values: np.ndarray
    upper_values: np.ndarray
    lower_bound: float
    upper_bound: float
    gap: float
    status: Status
    stop_reason: StopReason
    objective: float
    residual: float
    error_bound: float
    certificate: Certificate
    iterations: int
    cuts: int
    seconds: float
    log: list[NLPIteration]
    cost: np.ndarray
    solver: str
    gap_rtol: float
    scale: float
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def converged(self) -> bool:
        """Alias of :attr:`ok` (``status is Status.OPTIMAL``), kept for existing code."""
        return self.ok

    @property
    def width(self) -> float:
        """The width ``upper_bound - lower_bound`` of the certified bracket on ``c'w*``
        (the number stored in the field :attr:`gap`)."""
        return self.gap

    @property
    def relative_gap(self) -> float:
        """``width / (sum(cost) * scale)``: the bracket on ``c'w*`` in the problem's units."""
        unit = float(self.cost.sum()) * self.scale
        return self.gap / unit if unit > 0 else (0.0 if self.gap <= 0 else float("inf"))

    # ------------------------------------------------------------------ Result hooks
    def label(self) -> str:
        """The method ("cutting-planes", "strategy-iteration", ...)."""
        return self.method

    def summary_items(self) -> list[tuple[str, str]]:
        """The bracket on ``c'w*``, why the method stopped (never called a convergence:
        the status above says whether the bracket is certified), its counts and time."""
        return [
            (
                "c'w*",
                f"in [{self.lower_bound:.10g}, {self.upper_bound:.10g}], width "
                f"{self.width:.3e} (relative {self.relative_gap:.3e}, asked {self.gap_rtol:.1e})",
            ),
            (
                "method stopped",
                f"{self.stop_reason} after {self.iterations} iterations, {self.cuts} cuts, "
                f"{self.seconds:.3f} s ({self.solver})",
            ),
        ]
