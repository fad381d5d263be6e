"""Why an NLP method stopped: :class:`StopReason`, the values of ``NLPResult.stop_reason``.

A ``str``-valued enum: a member *is* its string (``StopReason.GAP_CLOSED == "gap closed"``,
``json.dumps`` writes the string, ``str()`` and f-strings print it), so the reason stays
readable in summaries and files. Where a stop carries data (the MILP solver's status, the
limit that stopped it), the data is in ``NLPResult.extra`` and the reason is a fixed member.
"""

from __future__ import annotations

from enum import Enum

__all__ = ["StopReason"]


class StopReason(str, Enum):
    """The reason an NLP method (or one of its loops) stopped."""

    #: The cutting planes (either family): their own bracket on ``c'w*`` closed to
    #: ``gap_rtol * sum(c) * scale``.
    GAP_CLOSED = "gap closed"
    #: The cutting planes: ``max_iter`` rounds were run.
    MAX_ROUNDS = "max_rounds"
    #: Strategy iteration or the fixed point: ``max_iter`` iterations were run.
    MAX_ITER = "max_iter"
    #: A time limit stopped the method (the cutting planes, strategy iteration, or the MILP
    #: solver when it stopped after 90 % of ``time_limit``).
    TIME_LIMIT = "time_limit"
    #: The fixed point: value iteration reached its residual tolerance.
    RESIDUAL_TOL = "residual <= tol"
    #: Strategy iteration: the minimiser's strategy did not change.
    STRATEGY_STABLE = "strategy stable"
    #: Lift-and-project cuts: no multi-term disjunction is violated at the master's point.
    NO_VIOLATED_DISJUNCTION = "no violated disjunction"
    #: Lift-and-project cuts: disjunctions are violated but no valid cut separates them.
    NO_CUT_FOUND = "no cut found (stalled)"
    #: Monotone cuts: the master's least element did not rise and nothing was resolved.
    MASTER_STALLED = "stalled (the master's least element did not rise)"
    #: The MILP: the solver reported an optimal solution (cvxpy's ``optimal``).
    MILP_OPTIMAL = "optimal"
    #: The MILP: the solver reported an inaccurate optimum (cvxpy's ``optimal_inaccurate``)
    #: before the time limit.
    MILP_INACCURATE = "optimal_inaccurate"
    #: The MILP: the solver stopped at a limit other than the time limit (cvxpy's
    #: ``user_limit``); ``extra["milp_status"]`` holds the solver's status.
    SOLVER_LIMIT = "solver limit"

    def __str__(self) -> str:
        return self.value

    def explain(self) -> str:
        """What the reason means, in a few words (after the reason itself in a summary:
        ``"max_rounds: the round limit was reached"``)."""
        return _EXPLAIN[self]

    @property
    def is_limit(self) -> bool:
        """True for a limit (rounds, iterations, time, the MILP solver's): the method did
        not stop on its own, whatever the certified bracket says."""
        return self in (
            StopReason.MAX_ROUNDS,
            StopReason.MAX_ITER,
            StopReason.TIME_LIMIT,
            StopReason.SOLVER_LIMIT,
        )

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)


_EXPLAIN: dict[StopReason, str] = {
    StopReason.GAP_CLOSED: "the method's own bracket on c'w* reached the asked gap",
    StopReason.MAX_ROUNDS: "the round limit was reached",
    StopReason.MAX_ITER: "the iteration limit was reached",
    StopReason.TIME_LIMIT: "the time limit was reached",
    StopReason.RESIDUAL_TOL: "value iteration reached its residual tolerance",
    StopReason.STRATEGY_STABLE: "the minimiser's strategy did not change, so its value is exact",
    StopReason.NO_VIOLATED_DISJUNCTION: "every disjunction holds at the master's point",
    StopReason.NO_CUT_FOUND: "disjunctions are violated but no valid cut separates them",
    StopReason.MASTER_STALLED: "no disjunction was resolved either",
    StopReason.MILP_OPTIMAL: "the MILP solver's status",
    StopReason.MILP_INACCURATE: "the MILP solver's status: an inaccurate optimum",
    StopReason.SOLVER_LIMIT: "a limit of the MILP solver other than time (extra['milp_status'])",
}
