"""Layer 6, formulations: the LPs of the paper, each a cvxpy model class with one result
type; the NLP and its cutting planes; the one HiGHS layer; the solver catalogue.

A table of contents: each name's module is imported on first use (PEP 562,
:mod:`lpbounds._lazy`), so ``import lpbounds.formulations`` (or its solver-independent
``quiet`` module, which the command line uses for every command) loads no cvxpy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import attach

if TYPE_CHECKING:  # what type checkers see; at run time see __getattr__
    from .alp import ALP, CostDependenceExample, find_cost_dependent_alp, soft_aggregation_basis
    from .base import Formulation, LPResult, Status, installed_lp_solvers, resolve_solver
    from .elp import ELP
    from .ib import IB, LLP
    from .nlp.problem import NLP, NLPMILP, NLPIteration, NLPResult
    from .rlp import RLP
    from .rows_lp import RowsLP
    from .slp import SLP

#: public name -> the submodule that defines it (imported on first access)
_LAZY: dict[str, str] = {
    "ALP": "alp",
    "CostDependenceExample": "alp",
    "find_cost_dependent_alp": "alp",
    "soft_aggregation_basis": "alp",
    "Formulation": "base",
    "LPResult": "base",
    "Status": "base",
    "installed_lp_solvers": "base",
    "resolve_solver": "base",
    "ELP": "elp",
    "IB": "ib",
    "LLP": "ib",
    "NLP": "nlp.problem",
    "NLPMILP": "nlp.problem",
    "NLPIteration": "nlp.problem",
    "NLPResult": "nlp.problem",
    "RLP": "rlp",
    "RowsLP": "rows_lp",
    "SLP": "slp",
}

__all__ = [
    "ALP",
    "ELP",
    "IB",
    "LLP",
    "NLP",
    "NLPMILP",
    "RLP",
    "SLP",
    "CostDependenceExample",
    "Formulation",
    "LPResult",
    "NLPIteration",
    "NLPResult",
    "RowsLP",
    "Status",
    "find_cost_dependent_alp",
    "installed_lp_solvers",
    "resolve_solver",
    "soft_aggregation_basis",
]

__getattr__, __dir__ = attach(__name__, _LAZY)
