"""Exact (rational) arithmetic on the stored model: fixed points, LP optima, certificates.

Every double of a model is an exact dyadic rational, so the stored model has one exact
``V*``, one exact RLP optimum, one exact game value. This package computes them with
python-flint and proves them in Python integers (docs/exact.md):

* :mod:`~lpbounds.exact.rationals` -- :class:`RationalVector` (integer numerators over one
  denominator, a sequence of Fractions), conversions, the one dense rational solver;
* :mod:`~lpbounds.exact.system` -- :class:`ExactRows`, a row system in exact arithmetic,
  and the exact solve of one policy's rows (component by component); the size limit;
* :mod:`~lpbounds.exact.fixed_point` -- :func:`least_fixed_point` (exact policy
  iteration: ``V*``, the Bellman-row LPs' optima) and :func:`game_fixed_point` (exact
  strategy iteration: the disjunctive NLP);
* :mod:`~lpbounds.exact.lp` -- :class:`ExactLP`: exact optima with primal and dual
  (``form.solve(..., arithmetic="rational")``), the exact simplex method;
* :mod:`~lpbounds.exact.files` -- the certificate format and its writer;
* :mod:`~lpbounds.exact.check` -- the checker, standard library only
  (``python -m lpbounds.exact.check FILE...``).

The entry points of the rest of the package: ``solve_exact(model, arithmetic="rational")``,
``solve_game(rows, arithmetic="rational")``, ``form.solve(solver, arithmetic="rational")``
and ``NLP.solve(..., arithmetic="rational")``. Names are imported on first use, so that
``python -m lpbounds.exact.check`` loads the standard library alone.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .files import certificate, mdp_data, rows_data, write_certificate
    from .fixed_point import ExactFixedPoint, game_fixed_point, least_fixed_point
    from .lp import ExactLP
    from .rationals import RationalVector
    from .system import ExactProgress, ExactRows

_LAZY: dict[str, str] = {
    "ExactFixedPoint": "fixed_point",
    "ExactLP": "lp",
    "ExactProgress": "system",
    "ExactRows": "system",
    "RationalVector": "rationals",
    "certificate": "files",
    "game_fixed_point": "fixed_point",
    "least_fixed_point": "fixed_point",
    "mdp_data": "files",
    "rows_data": "files",
    "write_certificate": "files",
}

__all__ = [
    "ExactFixedPoint",
    "ExactLP",
    "ExactProgress",
    "ExactRows",
    "RationalVector",
    "certificate",
    "game_fixed_point",
    "least_fixed_point",
    "mdp_data",
    "rows_data",
    "write_certificate",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
