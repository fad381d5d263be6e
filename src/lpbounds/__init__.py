"""lpbounds: bounding discounted MDPs with linear programs.

Implements Park, Kalyanam, Darbha, Chandler and Pachter, *Bounding Procedures for
Stochastic Dynamic Programs with Application to the Perimeter Patrol Problem*: the exact
LP, the state-aggregation restricted LP (an upper bound independent of the cost), its
surrogate, lifted and iterated-Bellman variants, the disjunctive lower-bound program,
and the perimeter patrol application.

Data flows one way: model (:class:`FiniteMDP`, :class:`Partition`) -> Bellman rows
(:class:`BellmanRows`) -> cvxpy problem -> result -> checks and reports.
"""

from __future__ import annotations

from .certificate import Certificate, certify
from .dp import (
    DPResult,
    PolicyEvaluation,
    PorteusBounds,
    bellman_residual,
    evaluate_policy,
    greedy_policy,
    porteus_bounds,
    solve_exact,
    solve_game,
)
from .errors import (
    ConvergenceError,
    LPBoundsError,
    SolverError,
    SolverNotInstalledError,
    ValidationError,
)
from .generators import garnet, random_partition
from .instances import Instance, load_instance
from .mdp import FiniteMDP
from .partition import Partition
from .rows import BellmanRows
from .status import Status, Verdict

__version__ = "0.1.0"

__all__ = [
    "BellmanRows",
    "Certificate",
    "ConvergenceError",
    "DPResult",
    "FiniteMDP",
    "Instance",
    "LPBoundsError",
    "Partition",
    "PolicyEvaluation",
    "PorteusBounds",
    "SolverError",
    "SolverNotInstalledError",
    "Status",
    "ValidationError",
    "Verdict",
    "__version__",
    "bellman_residual",
    "certify",
    "evaluate_policy",
    "garnet",
    "greedy_policy",
    "load_instance",
    "porteus_bounds",
    "random_partition",
    "solve_exact",
    "solve_game",
]
