"""The LP-capable solvers cvxpy finds at run time, their backends, option sets and time limits.

A solver is LP-capable when cvxpy's own solver class says so: a conic solver whose
``SUPPORTED_CONSTRAINTS`` include the zero and nonnegative cones (every LP is written with
those two), or a QP solver (an LP is a QP with a zero quadratic term). Nothing here is a
hand-kept list of which solvers exist; the tables below only add what a class cannot say:
the code that actually runs (:data:`BACKENDS`: ``SCIPY`` is HiGHS inside
``scipy.optimize.linprog``, ``PDLP`` and ``GLOP`` are OR-Tools', ...), each solver's
named option sets (:data:`OPTION_SETS`) and the keyword its cvxpy interface takes for a
time limit (:data:`TIME_LIMIT_OPTIONS`). A solver missing from those tables still runs,
with its defaults and without a time limit (a note says so).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import lru_cache
from typing import Any

__all__ = [
    "BACKENDS",
    "OPTION_SETS",
    "TIME_LIMIT_OPTIONS",
    "backend",
    "highs_algorithms",
    "known_option_sets",
    "lp_capable_solvers",
    "option_sets",
    "solver_distributions",
    "with_time_limit",
]

#: Solvers cvxpy registers that are not solvers of an LP one would benchmark: DIFFCP
#: differentiates through SCS (its numbers would be SCS's).
_NOT_SOLVERS = frozenset({"DIFFCP"})


@lru_cache(maxsize=1)
def lp_capable_solvers() -> tuple[str, ...]:
    """Installed cvxpy solvers that accept an LP, read from cvxpy's solver classes.

    Conic solvers qualify when their class supports the ``Zero`` and ``NonNeg`` cones;
    every QP solver qualifies. HiGHS and Clarabel come first (the project's defaults),
    then the rest in cvxpy's order.
    """
    import cvxpy as cp
    from cvxpy.reductions.solvers import defines

    installed = set(cp.installed_solvers())
    names: list[str] = []
    for name, cls in defines.SOLVER_MAP_CONIC.items():
        cones = {c.__name__ for c in getattr(cls, "SUPPORTED_CONSTRAINTS", ())}
        if {"Zero", "NonNeg"} <= cones and name in installed and name not in _NOT_SOLVERS:
            names.append(name)
    names += [n for n in defines.SOLVER_MAP_QP if n in installed and n not in names]
    first = [n for n in ("HIGHS", "CLARABEL") if n in names]
    return tuple(first + [n for n in names if n not in first])


#: The code that runs behind each cvxpy solver name (shown in tables and notes).
BACKENDS: dict[str, str] = {
    "HIGHS": "HiGHS (highspy)",
    "SCIPY": "HiGHS inside scipy.optimize.linprog (same code as HIGHS)",
    "CLARABEL": "Clarabel (interior point)",
    "SCS": "SCS (ADMM, conic)",
    "OSQP": "OSQP (ADMM, QP)",
    "ECOS": "ECOS (interior point, conic)",
    "CVXOPT": "CVXOPT (interior point)",
    "GLPK": "GLPK simplex through cvxopt",
    "GLPK_MI": "GLPK MIP through cvxopt",
    "PDLP": "PDLP of OR-Tools (first order)",
    "GLOP": "GLOP simplex of OR-Tools",
    "SCIP": "SCIP (pyscipopt; LP relaxation by its LP solver)",
    "DAQP": "DAQP (dual active set, QP)",
    "PROXQP": "ProxQP of proxsuite (proximal ALM, QP)",
    "PIQP": "PIQP (proximal interior point, QP)",
    "QPALM": "QPALM (proximal ALM, QP)",
    "QOCO": "QOCO (interior point, conic)",
    "CBC": "COIN-OR CBC (cylp)",
    "GUROBI": "Gurobi",
    "MOSEK": "MOSEK",
    "COPT": "COPT",
    "CPLEX": "CPLEX",
    "XPRESS": "FICO Xpress",
    "CUOPT": "NVIDIA cuOpt",
    "MPAX": "MPAX (JAX PDHG)",
}


def backend(solver: str) -> str:
    """What runs behind a cvxpy solver name (``"<name> (through cvxpy)"`` if unknown)."""
    return BACKENDS.get(solver, f"{solver} (through cvxpy)")


#: Python distributions that hold each solver (their versions go into a study's metadata).
_DISTRIBUTIONS: dict[str, tuple[str, ...]] = {
    "HIGHS": ("highspy",),
    "SCIPY": ("scipy",),
    "CLARABEL": ("clarabel",),
    "SCS": ("scs",),
    "OSQP": ("osqp",),
    "ECOS": ("ecos",),
    "CVXOPT": ("cvxopt",),
    "GLPK": ("cvxopt",),
    "GLPK_MI": ("cvxopt",),
    "PDLP": ("ortools",),
    "GLOP": ("ortools",),
    "SCIP": ("pyscipopt",),
    "DAQP": ("daqp",),
    "PROXQP": ("proxsuite",),
    "PIQP": ("piqp",),
    "QPALM": ("qpalm",),
    "QOCO": ("qoco",),
    "CBC": ("cylp",),
    "GUROBI": ("gurobipy",),
    "MOSEK": ("mosek",),
    "COPT": ("coptpy",),
    "CPLEX": ("cplex",),
    "XPRESS": ("xpress",),
    "CUOPT": ("cuopt",),
}


def solver_distributions(solvers: list[str]) -> dict[str, dict[str, Any]]:
    """For each solver: its backend, its distributions' versions and their requirements'.

    Returns
    -------
    dict
        ``{solver: {"backend": str, "packages": {dist: version}, "requires": {dist:
        version}}}``; ``requires`` holds the installed versions of what the solver's
        packages declare they need (numpy, scipy, protobuf, ...).
    """
    import re
    from importlib.metadata import PackageNotFoundError, requires, version

    def ver(name: str) -> str | None:
        try:
            return version(name)
        except PackageNotFoundError:
            return None

    out: dict[str, dict[str, Any]] = {}
    for solver in solvers:
        dists = _DISTRIBUTIONS.get(solver, (solver.lower(),))
        packages = {d: ver(d) for d in dists}
        needs: dict[str, str | None] = {}
        for d in dists:
            try:
                reqs = requires(d) or []
            except PackageNotFoundError:
                continue
            for req in reqs:
                if "extra ==" in req:
                    continue  # optional extras: not what the solver runs on
                m = re.match(r"[A-Za-z0-9_.\-]+", req)
                if m and (v := ver(m.group(0))) is not None:
                    needs[m.group(0)] = v
        out[solver] = {"backend": backend(solver), "packages": packages, "requires": needs}
    return out


# ---------------------------------------------------------------------- option sets
#: HiGHS option sets: name -> the value of HiGHS' ``solver`` option and extra options.
_HIGHS_SETS: dict[str, dict[str, Any]] = {
    "simplex": {"solver": "simplex"},
    "ipm": {"solver": "ipm", "run_crossover": "on"},
    "ipm-nox": {"solver": "ipm", "run_crossover": "off"},
    "pdlp": {"solver": "pdlp"},
}

#: Named option sets per solver (keyword arguments of ``Formulation.solve``); a solver not
#: listed has one set, ``default``. HiGHS' sets are filtered by what the installed highspy
#: accepts (:func:`highs_algorithms`); ``output_flag=False`` keeps PDLP's log off stdout.
#: ``tight`` asks the interior point / ADMM solvers for 1e-10 / 1e-9 tolerances.
OPTION_SETS: dict[str, dict[str, dict[str, Any]]] = {
    "HIGHS": {
        name: {"highs_options": {**opts, "output_flag": False}}
        for name, opts in _HIGHS_SETS.items()
    },
    "CLARABEL": {
        "default": {},
        "tight": {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10},
    },
    "SCS": {"default": {}},
    "OSQP": {"default": {}},
}


@lru_cache(maxsize=1)
def highs_algorithms() -> tuple[str, ...]:
    """The values of HiGHS' ``solver`` option that the installed highspy accepts."""
    try:
        import highspy  # noqa: F401
    except ImportError:  # pragma: no cover - highspy is a dependency
        return ()
    from .highs import accepted_option_values

    return accepted_option_values("solver", ("simplex", "ipm", "pdlp"))


def option_sets(solver: str) -> dict[str, dict[str, Any]]:
    """The named option sets of an installed solver (name -> solve() keyword arguments)."""
    sets = OPTION_SETS.get(solver, {"default": {}})
    if solver == "HIGHS":
        have = set(highs_algorithms())
        return {n: o for n, o in sets.items() if _HIGHS_SETS[n]["solver"] in have}
    return dict(sets)


def known_option_sets(solver: str) -> list[str]:
    """Every option set name of ``solver``, including those this installation lacks."""
    return sorted(OPTION_SETS.get(solver, {"default": {}}))


# ---------------------------------------------------------------------- time limits
def _nested(key: str, name: str) -> Callable[[float], dict[str, Any]]:
    return lambda t: {key: {name: t}}


def _flat(name: str) -> Callable[[float], dict[str, Any]]:
    return lambda t: {name: t}


#: How each solver's cvxpy interface takes a time limit in seconds (solver's own clock:
#: Clarabel and OSQP do not count their setup and factorisation, HiGHS counts its run).
TIME_LIMIT_OPTIONS: dict[str, Callable[[float], dict[str, Any]]] = {
    "HIGHS": _nested("highs_options", "time_limit"),
    "SCIPY": _nested("scipy_options", "time_limit"),
    "CLARABEL": _flat("time_limit"),
    "SCS": _flat("time_limit_secs"),
    "OSQP": _flat("time_limit"),
    "PDLP": _flat("time_limit_sec"),
    "GLOP": _flat("time_limit_sec"),
    "SCIP": _nested("scip_params", "limits/time"),
    "GUROBI": _flat("TimeLimit"),
    "COPT": _flat("TimeLimit"),
    "MOSEK": _nested("mosek_params", "MSK_DPAR_OPTIMIZER_MAX_TIME"),
    "CPLEX": _nested("cplex_params", "timelimit"),
}


def with_time_limit(
    solver: str, options: Mapping[str, Any], seconds: float | None
) -> tuple[dict[str, Any], bool]:
    """``options`` with a time limit of ``seconds`` added in ``solver``'s own keyword.

    Returns
    -------
    options : dict
        A new dict (nested option dicts such as ``highs_options`` are merged, not
        replaced).
    applied : bool
        False when ``solver`` has no known time-limit keyword (it runs without one).
    """
    opts = {k: (dict(v) if isinstance(v, Mapping) else v) for k, v in options.items()}
    if seconds is None:
        return opts, True
    make = TIME_LIMIT_OPTIONS.get(solver)
    if make is None:
        return opts, False
    for key, value in make(float(seconds)).items():
        if isinstance(value, dict):
            opts[key] = {**opts.get(key, {}), **value}
        else:
            opts[key] = value
    return opts, True
