"""lpbounds: bounding discounted MDPs with linear programs.

Implements Park, Kalyanam, Darbha, Chandler and Pachter, *Bounding Procedures for
Stochastic Dynamic Programs with Application to the Perimeter Patrol Problem*: the exact
LP, the state-aggregation restricted LP (an upper bound independent of the cost), its
surrogate, lifted and iterated-Bellman variants, the disjunctive lower-bound program,
and the perimeter patrol application.

Data flows one way: model (:class:`FiniteMDP`, :class:`Partition`) -> Bellman rows
(:class:`BellmanRows`) -> cvxpy problem -> result -> checks and reports.

``import lpbounds`` is cheap: the public names below are imported on first use
(PEP 562), so neither numpy-heavy modules nor cvxpy, matplotlib, pandas or numba load
until a function needs them.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .errors import (
    ConvergenceError,
    LPBoundsError,
    SolverError,
    SolverNotInstalledError,
    ValidationError,
)
from .status import Status, Verdict

if TYPE_CHECKING:  # what type checkers and IDEs see; at run time see __getattr__
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
    from .generators import garnet, random_partition
    from .instances import Instance, load_instance
    from .mdp import FiniteMDP
    from .partition import Partition
    from .rows import BellmanRows

__version__ = "0.1.0"

#: public name -> the submodule that defines it (imported on first access)
_LAZY: dict[str, str] = {
    "Certificate": "certificate",
    "certify": "certificate",
    "DPResult": "dp",
    "PolicyEvaluation": "dp",
    "PorteusBounds": "dp",
    "bellman_residual": "dp",
    "evaluate_policy": "dp",
    "greedy_policy": "dp",
    "porteus_bounds": "dp",
    "solve_exact": "dp",
    "solve_game": "dp",
    "garnet": "generators",
    "random_partition": "generators",
    "Instance": "instances",
    "load_instance": "instances",
    "FiniteMDP": "mdp",
    "Partition": "partition",
    "BellmanRows": "rows",
}

#: submodules reachable as attributes (``lpbounds.dp``) without importing them first
_SUBMODULES = frozenset(
    {
        "certificate",
        "checks",
        "cli",
        "dp",
        "errors",
        "formulations",
        "generators",
        "instances",
        "mdp",
        "outputs",
        "partition",
        "patrol",
        "rows",
        "status",
        "study",
        "tolerances",
        "validation",
        "verify",
    }
)

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


def __getattr__(name: str) -> Any:
    """Import a public name's module on first access and cache the name here."""
    module = _LAZY.get(name)
    if module is not None:
        value = getattr(importlib.import_module(f".{module}", __name__), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY) | _SUBMODULES)
