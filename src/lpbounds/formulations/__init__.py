"""LP formulations of the paper, each a cvxpy model class with one result type."""

from .base import Formulation, LPResult, Status, installed_lp_solvers, resolve_solver
from .elp import ELP
from .rlp import RLP
from .rows_lp import RowsLP

__all__ = [
    "ELP",
    "RLP",
    "Formulation",
    "LPResult",
    "RowsLP",
    "Status",
    "installed_lp_solvers",
    "resolve_solver",
]
