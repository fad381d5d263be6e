r"""The exact LP (paper eq. 8).

.. math:: ELP := \min c^T V \quad \text{s.t.} \quad V \ge R_u + \lambda P_u V \;\; \forall u.

By Lemma 1 its optimum is ``V*`` for every cost ``c >= 0`` (unique for ``c > 0``).
"""

from __future__ import annotations

from typing import Any

import cvxpy as cp
import numpy as np

from ..dp import exact_rows
from ..model.checks import check_formulation_inputs
from ..model.mdp import FiniteMDP
from .rows_lp import RowsLP

__all__ = ["ELP"]


class ELP(RowsLP):
    """The exact LP of ``mdp`` (eq. 8): one row per allowed (state, action).

    Parameters
    ----------
    mdp : FiniteMDP
    cost : array_like (n_states,), optional
        ``c >= 0`` (default all ones).

    Attributes
    ----------
    problem : cvxpy.Problem
        ``min c'V  s.t.  bellman``.
    V : cvxpy.Variable (n_states,)
        The paper's ``V`` (``variables["V"]``).
    constraints : dict
        ``"bellman"``: eq. 8, ``V(x) >= R_u(x) + lambda sum_l p_l V(f(x, u, Y_l))`` for
        every allowed (x, u), one sparse vector constraint (row ``r`` of the pair in
        ``rows.pair_row``); its duals are ``result.group_duals["bellman"]``.

    Notes
    -----
    ``values`` and ``state_values`` of the result are ``V`` per state; ``mu`` holds the
    duals per (state, action) (the discounted state-action frequencies when ``c`` is
    an initial distribution).

    **At the paper's size** (``models/patrol-paper.toml``: 2,048,000 variables, 4.65M rows)
    HiGHS' interior point method does not finish within 10 minutes. The route that does,
    in under a minute and about 5 GB on two cores (docs/benchmarks.md, "ELP of the paper's
    instance")::

        ELP(mdp).solve(backend="highspy", warm_start="policy")

    exact DP (:func:`lpbounds.solve_exact`) gives the optimal policy, and HiGHS' simplex
    method starts from its basis (:meth:`~lpbounds.formulations.RowsLP.policy_basis`) and
    confirms it in 0 iterations. What the result proves: ``lower_values <= V* <=
    upper_values`` from the certificate of the returned point (as for every solve); the
    duals are the policy's occupation measure, dual feasible up to ``dual_residual`` and
    with the ``gap`` lpbounds recomputes; the status comes from the certificate, not from
    HiGHS.
    """

    name = "ELP"
    variable_name = "V"

    def __init__(self, mdp: FiniteMDP, cost: Any = None) -> None:
        check_formulation_inputs(mdp, cost=cost)
        self.mdp = mdp
        super().__init__(exact_rows(mdp), cost)

    def exact_size(self) -> tuple[int, str]:
        """The MDP's states (:meth:`Formulation.exact_size`)."""
        return self.mdp.n_states, "ELP's states"

    def exact_lp(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """``(model, lp)``: eq. 8 built by the checker from the MDP's stored doubles."""
        from ..exact.files import mdp_data

        return mdp_data(self.mdp), {"formulation": "ELP", "cost": self.exact_cost()}

    @property
    def V(self) -> cp.Variable:
        """The cvxpy variable ``V`` (one entry per state)."""
        return self.variables["V"]

    def _interpret(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
        values, _, mu, extra = super()._interpret(x, y)
        return values, values, mu, extra
