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

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)
