r"""The LP of a Bellman row system: ``min c'v  s.t.  v(owner_r) >= q_r(v)`` for every row.

ELP, RLP, UBLP and LBLP are all of this form; they differ only in their rows. By
Fact 1 of :mod:`lpbounds.rows` the optimum for any cost ``c >= 0`` is the least
feasible point, the fixed point of the max over the rows, which :meth:`RowsLP.fixed_point`
computes without a solver, and :func:`lpbounds.certificate.certify` turns any returned point
into a certified bracket on that optimum (the result's ``lower_values``/``upper_values``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..certificate import Certificate, certify
from ..dp import solve_exact
from ..rows import BellmanRows
from .base import Formulation, check_cost

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

    def _certify(self, x: np.ndarray) -> Certificate:
        """The bracket on the exact optimum (the least feasible point) from ``x`` alone."""
        return certify(self.rows, x)

    def fixed_point(self, tol: float | None = None) -> np.ndarray:
        """The exact optimum, solver-free: the fixed point of ``max`` over the rows (Fact 1)."""
        return solve_exact(self.rows, tol=tol).values
