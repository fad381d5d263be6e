r"""Layer 3, rows: systems of Bellman rows ``v(i) >= rho_r + lambda sum_l p_{r,l} v(k_{r,l})``,
the one structure every formulation in lpbounds is made of (the exact LP's rows, the
restricted LP's aggregated rows, the NLP's disjunctions), and the sweep protocol on which
the exact-DP loops of :mod:`lpbounds.dp` run.

A table of contents; the modules:

* :mod:`~lpbounds.rows.system` -- :class:`BellmanRows`, the row system, with Facts 1 and 2
  (the least feasible point is the fixed point of the rows' max, or of the game's max-min,
  for every cost ``c >= 0``) and :class:`PackedSweeps`, its evaluation sweeps;
* :mod:`~lpbounds.rows.aggregation` -- the aggregation of rows by a partition
  (:meth:`BellmanRows.aggregate`) and why ``reduce="min"`` drops some actions;
* :mod:`~lpbounds.rows.post_decision` -- :class:`PostDecisionRows`, the exact rows in
  post-decision form (the fast path of structured models);
* :mod:`~lpbounds.rows.sweep` -- the sweep protocol :class:`SweepOperator` and
  :class:`PolicySweeps`.
"""

from __future__ import annotations

from .post_decision import PostDecisionRows
from .sweep import PolicySweeps, SweepOperator
from .system import BellmanRows, PackedSweeps

__all__ = ["BellmanRows", "PackedSweeps", "PolicySweeps", "PostDecisionRows", "SweepOperator"]
