"""The results of the disjunctive NLP: :class:`NLPResult` and its iteration log."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...certification.certificate import Certificate
from ...results import Result
from ...status import Status
from ...text import fmt_bracket, fmt_number, fmt_sci, fmt_seconds
from .stop import StopReason

if TYPE_CHECKING:  # annotations only
    import pandas as pd

    from ...exact.lp import ExactLP

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
    exact : ExactLP or None
        ``solve(..., arithmetic="rational")`` only: ``w*`` exactly (the game's value by
        exact strategy iteration), the method's exact error and whether its certified
        bracket held (:class:`lpbounds.exact.lp.ExactLP`, without duals: the NLP is not
        an LP).
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
    exact: ExactLP | None = None

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
        """The bracket on ``c'w*`` (rounded outward as printed), why the method stopped
        (in words, with the status: a limit is never called a convergence) and its counts,
        in the units of :meth:`log_table` (rounds, strategies, sweeps) and agreeing with
        it (the cuts are the sum of its ``cuts_added`` column)."""
        items = [
            ("c'w*", self._bracket_text()),
            ("method stopped", f"{self.stop_reason}: {self._stop_text()}"),
            ("work", f"{self._unit(self.iterations)} in {fmt_seconds(self.seconds)}; "
             f"solver: {self.solver}"),
        ]  # fmt: skip
        if self.method == "cutting-planes":
            items.append(("cuts", self._cuts_text()))
        if "partition_note" in self.extra:
            items.append(("partition", str(self.extra["partition_note"])))
        return items

    def log_table(self) -> pd.DataFrame:
        """The iteration log as a table, one row per entry of :attr:`log`.

        Returns
        -------
        pandas.DataFrame
            Indexed by ``iteration`` (1, 2, ...: rounds of the cutting planes, strategies
            of strategy iteration, the one MILP solve; 0, 1, ...: sweeps of the fixed
            point, row 0 its starting point), the last index equal to :attr:`iterations`
            as the summary counts them, with
            columns ``lower``, ``upper`` and ``gap`` (the method's own bracket on ``c'w*``
            then: the cutting planes' lower side is the master's bound, not
            rounding-certified; NaN where a method has no such side), ``cuts_added`` (the
            lift-and-project cuts added in the round, or the monotone cuts of the round's
            master, which replace the previous round's), ``seconds`` (since the start),
            ``max_violation`` and ``master_objective`` (cutting planes; NaN otherwise).
        """
        import pandas as pd  # only where it is used

        cols = [
            "lower", "upper", "gap", "cuts_added", "seconds", "max_violation",
            "master_objective",
        ]  # fmt: skip
        rows = [[getattr(e, c) for c in cols] for e in self.log]
        index = pd.Index([e.iteration for e in self.log], name="iteration")
        return pd.DataFrame(rows, columns=cols, index=index)

    # ------------------------------------------------------------------ summary text
    def _bracket_text(self) -> str:
        rel, asked = self.relative_gap, self.gap_rtol
        if rel <= asked:
            how = f"asked {fmt_number(asked)}"
        elif self.ok:  # the residual met the accuracy; the rest is the rounding allowance
            how = f"the asked {fmt_number(asked)} plus the certificate's rounding allowance"
        else:
            how = f"wider than the asked {fmt_number(asked)}"
        shown = fmt_bracket(self.lower_bound, self.upper_bound)  # or "0 ± m" around 0
        return (
            f"{'in ' if shown.startswith('[') else ''}{shown} (certified, rounded "
            f"outward), width {fmt_sci(self.width, 3)} (relative {fmt_sci(rel, 3)}, {how})"
        )

    def _unit(self, n: int) -> str:
        """``n`` in the unit of :attr:`iterations` for this method."""
        one, many = _UNITS.get(self.method, ("iteration", "iterations"))
        return f"{n:,} {one if n == 1 else many}"

    def _stop_text(self) -> str:
        """Why the method stopped, in words, and what that means with this status."""
        reason = self.stop_reason
        what = reason.explain()
        if reason in (StopReason.MAX_ROUNDS, StopReason.MAX_ITER):
            what += f" (max_iter = {self.iterations:,})"
        if reason.is_limit:
            if self.ok:
                return f"{what}; the certified bracket is within the asked accuracy all the same"
            return f"{what} before the certified bracket closed to the asked accuracy"
        return what if self.ok else f"{what}; the certified bracket is wider than asked"

    def _cuts_text(self) -> str:
        """The cuts, counted as the log table's ``cuts_added`` column sums them (and, for
        lift-and-project, those of them in the final master: :attr:`cuts`)."""
        logged = int(sum(e.cuts_added for e in self.log))
        if self.extra.get("cut_family") == "monotone":
            resolved = self.extra.get("resolved")
            tail = "" if resolved is None else f"; {resolved:,} disjunctions resolved"
            return (
                f"{logged:,} monotone cuts over the rounds (each round's master has one per "
                f"unresolved disjunction; {self.cuts:,} in the last){tail}"
            )
        text = f"{self.cuts:,} lift-and-project cuts added to the master"
        if logged != self.cuts:  # the last round's cuts, found when a limit stopped it
            text += (
                f"; the last round found {logged - self.cuts:,} more, not added: "
                f"{self.stop_reason.explain()}"
            )
        return text


#: The unit of ``iterations`` per method (one, many).
_UNITS: dict[str, tuple[str, str]] = {
    "cutting-planes": ("round", "rounds"),
    "strategy-iteration": ("strategy evaluated", "strategies evaluated"),
    "fixed-point": ("value-iteration sweep", "value-iteration sweeps"),
    "milp": ("MILP solve", "MILP solves"),
}
