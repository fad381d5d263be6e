"""LP formulations of the paper, each a cvxpy model class with one result type."""

from .alp import ALP, CostDependenceExample, find_cost_dependent_alp, soft_aggregation_basis
from .base import Formulation, LPResult, Status, installed_lp_solvers, resolve_solver
from .elp import ELP
from .ib import IB, LLP
from .nlp.problem import NLP, NLPMILP, NLPIteration, NLPResult
from .rlp import RLP
from .rows_lp import RowsLP
from .slp import SLP

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
