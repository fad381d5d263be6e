r"""The restricted LP under state aggregation (paper eq. 9, compact form eq. 10).

.. math::

    \begin{array}{l}
    RLP := \min \sum_{i=1}^M \sum_{x \in S_i} c(x)\, v(i) \quad \text{s.t.} \\
    \qquad v(i) \ge R_u(x) + \lambda \sum_{l=0}^m p_l\, v(\bar f(x, u, Y_l))
    \;\; \forall x \in S_i,\ i = 1..M,\ \forall u.
    \end{array}

``Phi v*`` is an upper bound on ``V*`` (every solution of the Bellman inequalities
dominates ``V*``: the paper's lemma on iterated Bellman inequalities), and by Theorem 1 the
optimum ``v*`` is the same for every cost ``c >= 0``: it is the least feasible point,
the fixed point of the max over the aggregated rows (Fact 1 in :mod:`lpbounds.rows.system`),
and every feasible ``v`` dominates it.
"""

from __future__ import annotations

from typing import Any

import cvxpy as cp
import numpy as np

from ..model.checks import check_formulation_inputs, sink_block_note
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from ..rows import BellmanRows
from .base import aggregated_cost
from .rows_lp import RowsLP

__all__ = ["RLP"]


class RLP(RowsLP):
    """The restricted LP of ``mdp`` under ``partition`` (eq. 9).

    Parameters
    ----------
    mdp : FiniteMDP
    partition : Partition
    cost : array_like (n_states,), optional
        The paper's state weights ``c(x) >= 0`` (default all ones); the objective is
        ``c-bar' v`` with ``c-bar(i) = sum_{x in S_i} c(x)``.
    partition_cost : array_like (M,), optional
        ``c-bar`` directly (instead of ``cost``).

    Attributes
    ----------
    problem : cvxpy.Problem
        ``min c-bar'v  s.t.  bellman``.
    v : cvxpy.Variable (M,)
        The paper's ``v``, one entry per partition (``variables["v"]``).
    constraints : dict
        ``"bellman"``: eq. 9, ``v(i) >= R_u(x) + lambda sum_l p_l v(f-bar(x, u, Y_l))``,
        one sparse vector constraint over the merged rows; its duals are
        ``result.group_duals["bellman"]`` (spread over pairs: ``result.mu``).
        Add constraints of your own with
        ``solve(extra_constraints=[rlp.v[i] <= rlp.v[j]])``
        (:meth:`~lpbounds.formulations.base.Formulation.solve`: what stays certified).

    Notes
    -----
    Identical aggregated rows are merged (and rows implied by a row with the same
    successor distribution and a larger reward dropped): the LP has one row per
    distinct (partition, action, successor distribution). The result's ``mu`` spreads
    each row's dual equally over the (state, action) pairs it came from that attain its
    reward: an optimal dual ``mu-bar`` of the unmerged RLP, as used by SLP (Lemma 2).
    """

    name = "RLP"

    def __init__(
        self,
        mdp: FiniteMDP,
        partition: Partition,
        cost: Any = None,
        *,
        partition_cost: Any = None,
        rows: BellmanRows | None = None,
    ) -> None:
        check_formulation_inputs(mdp, partition, cost=cost, partition_cost=partition_cost)
        cbar = aggregated_cost(mdp, partition, cost, partition_cost)
        self.mdp = mdp
        self.partition = partition
        self.partition_note = sink_block_note(mdp, partition)
        if rows is None:
            rows = BellmanRows.aggregate(mdp, partition, reduce="max")
        super().__init__(rows, cbar)

    def exact_size(self) -> tuple[int, str]:
        """The partitions (:meth:`Formulation.exact_size`)."""
        return self.partition.n_partitions, "RLP's partitions"

    def exact_lp(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """``(model, lp)``: eq. 9 built by the checker from the MDP and the partition, one
        row per allowed pair with its probabilities summed by target partition exactly
        (the float rows merge them in floating point)."""
        from ..exact.files import mdp_data

        model = mdp_data(self.mdp, self.partition)
        return model, {"formulation": "RLP", "cost": self.exact_cost()}

    @property
    def v(self) -> cp.Variable:
        """The cvxpy variable ``v`` (one entry per partition)."""
        return self.variables["v"]

    def _interpret(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
        values, _, mu, extra = super()._interpret(x, y)
        extra = {**extra, "mdp": self.mdp, "partition": self.partition}
        return values, self.partition.lift(values), mu, extra
