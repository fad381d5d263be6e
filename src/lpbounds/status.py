"""One status vocabulary for every result lpbounds returns (LP, NLP and DP), and one for
theorem checks.

As linopy's termination conditions do, a status says what lpbounds *knows* about the
returned point, not what a solver claimed:

* :attr:`Status.OPTIMAL` -- a point whose certified error (computed by lpbounds from the
  point alone, :mod:`lpbounds.certification.certificate`) is within the requested accuracy;
* :attr:`Status.INACCURATE` -- a point whose certified bracket is valid but wider than
  requested (the bracket still bounds the exact optimum);
* :attr:`Status.TIME_LIMIT`, :attr:`Status.ITERATION_LIMIT` -- stopped at a limit; the point
  reached and its certificate are kept. :attr:`Status.LIMIT` is the same where the solver
  (through cvxpy's ``USER_LIMIT``) does not say which limit stopped it;
* :attr:`Status.INFEASIBLE`, :attr:`Status.UNBOUNDED`, :attr:`Status.SOLVER_ERROR` -- no point.

A bound is usable under every status that keeps a point (:data:`POINT_STATUSES`): its
certified bracket is valid whatever the status; only its width differs.
"""

from __future__ import annotations

from enum import Enum

__all__ = ["POINT_STATUSES", "Status", "Verdict"]


class Status(str, Enum):
    """Outcome of a solve, as lpbounds judges it from the returned point."""

    OPTIMAL = "optimal"
    INACCURATE = "inaccurate"
    TIME_LIMIT = "time_limit"
    ITERATION_LIMIT = "iteration_limit"
    LIMIT = "limit"
    INFEASIBLE = "infeasible"
    UNBOUNDED = "unbounded"
    SOLVER_ERROR = "solver_error"

    def __str__(self) -> str:
        return self.value

    @property
    def has_point(self) -> bool:
        """True when a point (with its certificate) was returned."""
        return self in POINT_STATUSES


#: Statuses under which a point and its certificate are kept.
POINT_STATUSES = frozenset(
    {Status.OPTIMAL, Status.INACCURATE, Status.TIME_LIMIT, Status.ITERATION_LIMIT, Status.LIMIT}
)


class Verdict(str, Enum):
    """The answer of a theorem check that compares certified intervals.

    * ``HOLDS`` -- the claim is consistent with the certified intervals, and they are
      narrow enough to have shown a violation of the requested size;
    * ``VIOLATED`` -- the intervals prove the claim false (a counterexample);
    * ``INCONCLUSIVE`` -- the intervals are too wide to decide either way.
    """

    HOLDS = "holds"
    VIOLATED = "violated"
    INCONCLUSIVE = "inconclusive"

    def __str__(self) -> str:
        return self.value
