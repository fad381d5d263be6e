r"""The LP of a Bellman row system: ``min c'v  s.t.  v(owner_r) >= q_r(v)`` for every row.

ELP, RLP, UBLP and LBLP are all of this form; they differ only in their rows. By
Fact 1 of :mod:`lpbounds.rows.system` the optimum for any cost ``c >= 0`` is the least
feasible point, the fixed point of the max over the rows, which :meth:`RowsLP.fixed_point`
computes without a solver, and :func:`lpbounds.certification.certificate.certify` turns any
returned point
into a certified bracket on that optimum (the result's ``lower_values``/``upper_values``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..certification.certificate import Certificate, certify
from ..dp import solve_exact
from ..rows import BellmanRows
from .base import Formulation, check_cost
from .highs import tight_basis

if TYPE_CHECKING:  # annotations only
    from ..exact.lp import ExactLP

__all__ = ["RowsLP"]


class RowsLP(Formulation):
    r"""``min c'v`` subject to the rows ``v(i) >= reward_r + lambda sum_l p_{r,l} v(k_{r,l})``.

    As a cvxpy model (:attr:`problem`): one variable named :attr:`variable_name` (``v``
    unless a subclass names it after its paper symbol) and one constraint group named
    :attr:`group_name` (``bellman``) holding every row as one sparse vector constraint.

    Parameters
    ----------
    rows : BellmanRows
    cost : array_like, shape (rows.n_vars,), optional
        Non-negative cost (default all ones).
    name : str
    """

    name = "RowsLP"
    #: The name of the cvxpy variable (the paper's symbol).
    variable_name = "v"
    #: The name of the constraint group (after the equation it implements).
    group_name = "bellman"
    feasible_by_construction = True
    feasibility_reason = (
        "its Bellman rows contract (kappa = lambda max_r sum_l p_rl < 1), so the constant "
        "v = max(R)^+ / (1 - kappa) satisfies every row"
    )
    bounded_by_construction = True
    boundedness_reason = (
        "every variable owns a Bellman row and the rows contract (kappa < 1), so every "
        "feasible v dominates the least feasible point v* (Fact 1), and the cost is >= 0: "
        "c'v >= c'v*"
    )

    def __init__(self, rows: BellmanRows, cost: Any = None, name: str | None = None) -> None:
        self.rows = rows
        c = check_cost(cost, rows.n_vars)
        a, b = rows.constraint_matrix()
        super().__init__(
            a, b, c, name, variables=self._variable_blocks(), groups=self._group_blocks()
        )

    def _variable_blocks(self) -> list[tuple[str, int]]:
        """The named blocks of the columns (one variable ``v`` here)."""
        return [(self.variable_name, self.rows.n_vars)]

    def _group_blocks(self) -> list[tuple[str, int]]:
        """The named blocks of the rows (one group ``bellman`` here)."""
        return [(self.group_name, self.rows.n_rows)]

    def _interpret(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
        mu = self.rows.pair_values(y) if self.rows.pair_row is not None else None
        return x, None, mu, {}

    @property
    def row_rounding(self) -> float:
        """``2 (L + 3) eps``: the rows' ``A = E - lambda P`` is formed in floating point (the
        owner's ``1 - lambda p`` cancels where a row reads its own variable: an error of
        ``eps``, not of ``eps |1 - lambda p|``), and aggregated rows sum up to ``L``
        probabilities per target, so ``sum_j |A_rj - A~_rj| <= (L + 2) eps (1 + lambda s_r)``
        against the exact rows; the rewards are stored exactly."""
        return 2.0 * (self.rows.n_outcomes + 3) * float(np.finfo(np.float64).eps)

    def _certify(self, x: np.ndarray) -> Certificate:
        """The bracket on the exact optimum (the least feasible point) from ``x`` alone."""
        return certify(self.rows, x)

    def _discount(self) -> float:
        return float(self.rows.discount)

    def _value_bound(self) -> float:
        """``max|R| / (1 - lambda)``: ``|v*|`` is at most that (Fact 1)."""
        return float(np.abs(self.rows.reward).max(initial=0.0)) / (1.0 - self._discount())

    def policy_basis(self) -> Any:
        """HiGHS' basis of the optimal policy, from exact DP (``solve(warm_start="policy")``).

        :func:`~lpbounds.solve_exact` on :attr:`rows` gives the fixed point and, per
        variable, a maximising row (``policy_rows``). In the basis every column is basic,
        those rows are at their lower bound (tight) and every other row's slack is basic:
        the basis matrix is ``I - lambda P_pi`` over the tight rows, its primal solution
        the policy's value and its dual solution ``y = (I - lambda P_pi)^{-T} c >= 0`` on
        the tight rows (0 elsewhere), the policy's discounted occupation measure. For an
        optimal policy both are feasible, so HiGHS' simplex method stops after factorising
        the basis and checking it (0 iterations; a few when DP's policy is optimal only to
        its tolerance). What the result then proves: the point's bracket
        ``lower_values <= v* <= upper_values`` from :func:`lpbounds.certification`, as for any
        solve; and, from the returned duals, ``dual_residual = ||A'y - c||_inf`` and
        ``gap = |c'x - b'y|`` computed by lpbounds (``y >= 0`` is dual feasible up to
        ``dual_residual``, so ``b'y`` is a lower bound on the optimum up to it:
        ``objective_bracket`` uses it).

        The route needs an LU factorisation of ``I - lambda P_pi`` without much fill-in.
        The patrol problem's transitions make it cheap (the paper's ELP: 2,048,000
        variables, factorised and checked in about 15 s); on a random garnet with 100,000
        states HiGHS had not set the basis after 5 minutes (random sparse ``P``: the LU
        fills in). Use an interior point method there.
        """
        dp = solve_exact(self.rows)
        return tight_basis(self.A.shape[0], self.A.shape[1], dp.policy_rows)

    def fixed_point(self, tol: float | None = None) -> np.ndarray:
        """The exact optimum, solver-free: the fixed point of ``max`` over the rows (Fact 1)."""
        return solve_exact(self.rows, tol=tol).values

    # ------------------------------------------------------------------ exact arithmetic
    def exact_size(self) -> tuple[int, str]:
        """The variables of the exact fixed point (:meth:`Formulation.exact_size`)."""
        return self.rows.n_vars, f"{self.name}'s variables"

    def exact_lp(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """``(model, lp)``: this LP as the certificate describes it (the rows as stored,
        each double exact: ``{"formulation": "ROWS"}``; ELP, RLP, SLP rebuild theirs from
        the MDP in exact arithmetic)."""
        from ..exact.files import rows_data

        return rows_data(self.rows), {"formulation": "ROWS", "cost": self.exact_cost()}

    def exact_cost(self) -> list[str]:
        """The LP's cost as stored (each double exact, as hex)."""
        return [float(t).hex() for t in self.c]

    def _exact_route(self, approx: Any, size_limit: int | None, callback: Any) -> ExactLP:
        """The rows' exact least fixed point and its policy's occupation measure."""
        from ..exact.lp import bellman_lp

        model, spec = self.exact_lp()
        _, what = self.exact_size()
        return bellman_lp(model, spec, approx=approx, callback=callback, size_limit=size_limit,
                          what=what)  # fmt: skip
