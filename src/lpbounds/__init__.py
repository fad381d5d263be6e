"""lpbounds: bounding discounted MDPs with linear programs.

Implements Park, Kalyanam, Darbha, Chandler and Pachter, *Bounding Procedures for
Stochastic Dynamic Programs with Application to the Perimeter Patrol Problem*: the exact
LP, the state-aggregation restricted LP (an upper bound independent of the cost), its
surrogate, lifted and iterated-Bellman variants, the disjunctive lower-bound program,
and the perimeter patrol application.

Data flows one way: model (:class:`FiniteMDP`, :class:`Partition`) -> Bellman rows
(:class:`BellmanRows`) -> cvxpy problem -> result -> checks and reports.

``import lpbounds`` is cheap: the public names below are imported on first use
(PEP 562), so neither numpy-heavy modules nor cvxpy, matplotlib or pandas load until a
function needs them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ._defaults import VERSION
from ._lazy import attach
from .errors import (
    ConvergenceError,
    LPBoundsError,
    SolverError,
    SolverNotInstalledError,
    ValidationError,
)
from .status import Status, Verdict

if TYPE_CHECKING:  # what type checkers and IDEs see; at run time see __getattr__
    from .certification.certificate import Certificate, certify
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
    from .model.generators import garnet, random_partition
    from .model.instances import Instance, load_instance
    from .model.mdp import FiniteMDP
    from .model.partition import Partition
    from .results import Result
    from .rows import BellmanRows

__version__ = VERSION

#: public name -> the submodule that defines it (imported on first access)
_LAZY: dict[str, str] = {
    "Certificate": "certification.certificate",
    "certify": "certification.certificate",
    "DPResult": "dp",
    "PolicyEvaluation": "dp",
    "PorteusBounds": "dp",
    "bellman_residual": "dp",
    "evaluate_policy": "dp",
    "greedy_policy": "dp",
    "porteus_bounds": "dp",
    "solve_exact": "dp",
    "solve_game": "dp",
    "garnet": "model.generators",
    "random_partition": "model.generators",
    "Instance": "model.instances",
    "load_instance": "model.instances",
    "FiniteMDP": "model.mdp",
    "Partition": "model.partition",
    "BellmanRows": "rows",
    "Result": "results",
}

#: submodules reachable as attributes (``lpbounds.dp``) without importing them first: the
#: layer packages and the shared vocabulary, and under their earlier flat names the modules
#: that moved into a layer package (``lpbounds.mdp`` is :mod:`lpbounds.model.mdp`)
_SUBMODULES: dict[str, str] = {
    **{
        name: name
        for name in (
            "certification",
            "cli",
            "dp",
            "errors",
            "formulations",
            "model",
            "outputs",
            "patrol",
            "plot",
            "results",
            "rows",
            "status",
            "stochastic",
            "studies",
            "tolerances",
            "validation",
        )
    },
    "certificate": "certification.certificate",
    "checks": "certification.checks",
    "generators": "model.generators",
    "instances": "model.instances",
    "mdp": "model.mdp",
    "partition": "model.partition",
    "study": "studies.compare",
    "verify": "studies.verify",
    "campaign": "studies.campaign",
}

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
    "Result",
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


__getattr__, __dir__ = attach(__name__, _LAZY, _SUBMODULES)
