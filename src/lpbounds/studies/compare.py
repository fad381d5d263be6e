r"""Solver comparison studies: every (instance, formulation, solver, option set) solved.

A study is the cross product of

* instances: ``models/*.toml`` files (or their names), or seeded random sizes written
  ``garnet:N:M[:SEED]`` (a Garnet MDP with ``N`` states, 3 actions, 4 outcomes,
  discount 0.9, and a random partition into ``M`` sets, both from ``SEED``, default 0);
* formulations by their paper name (``"ELP"``, ``"RLP"``, ``"SLP"``, ``"IB"``, ``"ALP"``,
  ``"UBLP"``, ``"LBLP"``); a name whose class is not importable (not written yet, or an
  instance it does not apply to) is skipped with a note;
* solver configurations: a cvxpy solver name with a named option set, written
  ``SOLVER`` (all option sets of that solver) or ``SOLVER:SET``, e.g. ``HIGHS:ipm``.
  By default every LP-capable solver cvxpy finds installed, read from cvxpy's solver
  classes (:func:`lpbounds.formulations.solvers.lp_capable_solvers`), each with its backend
  named (``SCIPY`` is HiGHS inside scipy) and its option sets
  (:data:`~lpbounds.formulations.solvers.OPTION_SETS`: HiGHS ``simplex``, ``ipm``, ``ipm-nox``,
  ``pdlp``; Clarabel ``default`` and ``tight``; others ``default``). Missing solvers are
  skipped with a note.

Each solve is done on a freshly built formulation (so cvxpy's compile time is measured
every time) with ``raise_on_failure=False``, and gives one row of a
:class:`pandas.DataFrame` (see :data:`COLUMNS`): status (:class:`lpbounds.status.Status`),
objective, the **certified error** of the returned point (``certified_error``: a bound
on ``max |values - exact optimum|`` from the contraction certificate of
:mod:`lpbounds.certification.certificate`, computed from the point alone, the same for every solver:
the fair accuracy measure), the maximum deviation from the formulation's exact,
solver-free counterpart (``fixed_point``; for ELP the exact DP's ``V*``), the primal
residual, compile and solve times, and iterations. A row is ``accurate`` when its
status keeps a point and its certified error is within the requested ``accuracy``
relative to ``max|R| / (1 - lambda)`` (default
:data:`~lpbounds.tolerances.LP_CERT_RTOL`). The reference is computed by exact DP to the
residual tolerance ``DP_RTOL * max|R| / (1 - lambda)``; its error bound is reported in
``reference_error_bound``. With ``time_limit`` each solve gets that many seconds in its
solver's own keyword; a solve that used it up without an OPTIMAL point is ``time_limit``,
with its point and certified error kept. An "infeasible" answer (the LPs are feasible by
construction) gets a note with the exact fixed point's row violation.

What a study writes (per-solver counts, shifted geometric means, performance profiles,
metadata) is in :mod:`lpbounds.studies.report`.

Bad input fails before anything is solved (:class:`~lpbounds.errors.ValidationError`):
an instance file that does not exist, a solver name no one knows (a known solver that
is not installed is skipped with a note naming its install command), an unknown option
set, or a study with no solver left to run.

Solves run in parallel processes (:class:`concurrent.futures.ProcessPoolExecutor`) by
default, or through Dask (a local scheduler, ``scheduler="threads"``, or an existing
cluster, ``scheduler="tcp://host:8786"``; requires the optional ``study`` extra, ``pip
install lpbounds[study]``). Times measured while other
solves run on the same cores are noisy: use ``jobs=1`` for timings you want to quote.
"""

from __future__ import annotations

import importlib.util
import logging
import math
import multiprocessing
import os
import re
import time
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from .._defaults import DEFAULT_FORMULATIONS, DEFAULT_INSTANCES
from ..certification.checks import lp_bracket
from ..errors import LPBoundsError, SolverNotInstalledError, ValidationError
from ..formulations.solvers import (
    backend,
    highs_algorithms,
    known_option_sets,
    lp_capable_solvers,
    option_sets,
    with_time_limit,
)
from ..status import POINT_STATUSES, Status
from ..text import fmt_list, fmt_seconds
from ..tolerances import LP_CERT_RTOL, LP_COMPARE_RTOL, SCHEDULER_CONNECT_SECONDS, dp_scale
from .report import (
    DEFAULT_SHIFTS,
    plot_study,
    save_study,
    solver_summary,
    study_metadata,
    summarize,
)

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from ..formulations.base import Formulation

__all__ = [
    "COLUMNS",
    "DEFAULT_FORMULATIONS",
    "DEFAULT_INSTANCES",
    "FORMULATIONS",
    "SolverConfig",
    "StudyResult",
    "Task",
    "available_formulations",
    "check_scheduler",
    "connect_scheduler",
    "dask_map",
    "highs_algorithms",
    "missing_solvers",
    "plot_study",
    "run_study",
    "save_study",
    "solver_configs",
    "solver_summary",
    "study_metadata",
    "summarize",
]

# DEFAULT_INSTANCES (the default study: the teaching instance and two seeded random sizes)
# and DEFAULT_FORMULATIONS come from ._defaults, which the CLI's --help reads cheaply.

#: Columns of a study's DataFrame, in order.
COLUMNS: tuple[str, ...] = (
    "instance",
    "n_states",
    "n_partitions",
    "formulation",
    "n_rows",
    "n_vars",
    "solver",
    "option_set",
    "config",
    "backend",
    "repeat",
    "status",
    "objective",
    "certified_error",
    "rel_error",
    "accuracy",
    "time_limit",
    "accurate",
    "max_deviation",
    "deviation_tol",
    "reference_error_bound",
    "primal_residual",
    "residual_tol",
    "dual_residual",
    "gap",
    "compile_seconds",
    "solve_seconds",
    "wall_seconds",
    "iterations",
    "note",
)


# ---------------------------------------------------------------------- solvers
@dataclass(frozen=True)
class SolverConfig:
    """A cvxpy solver with a named option set.

    Attributes
    ----------
    solver : str
        cvxpy's name ("HIGHS", "CLARABEL", ...).
    option_set : str
        "default", or e.g. "simplex" / "ipm" / "ipm-nox" / "pdlp" for HiGHS.
    options : dict
        Keyword arguments for :meth:`Formulation.solve`.
    """

    solver: str
    option_set: str = "default"
    options: Mapping[str, Any] = field(default_factory=dict)

    @property
    def label(self) -> str:
        """``SOLVER`` or ``SOLVER:SET``."""
        return self.solver if self.option_set == "default" else f"{self.solver}:{self.option_set}"

    @property
    def backend(self) -> str:
        """The code that runs (``SCIPY``: HiGHS inside scipy; see :data:`BACKENDS`)."""
        return backend(self.solver)


def missing_solvers(installed: Sequence[str]) -> list[str]:
    """The known LP solvers that are not among ``installed`` (licensed ones left out): what
    a default study (every installed solver) does not run."""
    from ..formulations.base import INSTALL_HINTS

    return [
        s
        for s in INSTALL_HINTS
        if s not in installed and "licence" not in INSTALL_HINTS[s] and s != "GLPK_MI"
    ]


def _expand(spec: str, solver: str, opt: str, notes: list[str]) -> dict[str, dict[str, Any]]:
    """The option sets ``spec`` names (all when ``opt`` is empty); skips noted, typos raised."""
    sets = option_sets(solver)
    known = known_option_sets(solver)
    unsupported = sorted(set(known) - set(sets))
    if unsupported and not opt:
        notes.append(
            f"{solver}: this installation does not accept {fmt_list(unsupported)}; skipped"
        )
    if not opt:
        return sets
    if opt not in sets:
        if opt not in known:
            raise ValidationError(
                f"solver {spec!r}: unknown option set {opt!r}; {solver} has "
                f"{fmt_list(known, 'and')}"
            )
        notes.append(f"{spec}: skipped: this {solver} does not accept {opt!r}")
        return {}
    return {opt: sets[opt]}


def solver_configs(names: Iterable[str] | None = None) -> tuple[list[SolverConfig], list[str]]:
    """Expand solver names into configurations, with notes for what is skipped.

    Parameters
    ----------
    names : iterable of str, optional
        ``"HIGHS"`` (every HiGHS option set), ``"HIGHS:ipm"`` (one set), ``"CLARABEL"``,
        ... (case-insensitive). Default: every LP-capable solver cvxpy finds installed
        (:func:`lpbounds.formulations.solvers.lp_capable_solvers`: read from cvxpy's solver
        classes), every option set of each.

    Returns
    -------
    configs : list of SolverConfig
    notes : list of str
        One line per solver or option set skipped, and why (a named solver that is not
        installed, a HiGHS algorithm this highspy does not accept), and one per solver
        whose backend is another's (``SCIPY`` runs HiGHS). With ``names=None`` (every
        installed solver) the known solvers that are not installed are not skipped but
        absent: :func:`missing_solvers` lists them.

    Raises
    ------
    ValidationError
        For a solver name that no one knows or an unknown option set (typos).
    """
    from ..formulations.base import INSTALL_HINTS, resolve_solver

    notes: list[str] = []
    if names is None:
        names = list(lp_capable_solvers())
    configs: list[SolverConfig] = []
    for spec in names:
        name, _, opt = str(spec).partition(":")
        try:
            solver = resolve_solver(name)
        except SolverNotInstalledError as exc:
            if name.upper() not in INSTALL_HINTS:  # a name no one knows: a typo, not a skip
                raise ValidationError(f"solver {spec!r}: {exc}") from exc
            notes.append(f"{spec}: skipped: {exc}")
            continue
        if solver not in lp_capable_solvers():
            raise ValidationError(
                f"solver {spec!r}: cvxpy's {solver} does not take an LP (neither a conic solver "
                f"with zero and nonnegative cones nor a QP solver); LP solvers here: "
                f"{', '.join(lp_capable_solvers())}"
            )
        for set_name, options in _expand(str(spec), solver, opt, notes).items():
            cfg = SolverConfig(solver, set_name, options)
            if cfg not in configs:
                configs.append(cfg)
    if any(c.solver == "SCIPY" for c in configs):
        notes.append(
            "SCIPY is HiGHS inside scipy.optimize.linprog (the same code as HIGHS, reached "
            "through scipy's interface): not an independent solver"
        )
    return configs, notes


# ---------------------------------------------------------------------- instances
class Case:
    """A study instance: its MDP and partition, built on first use (patrol instances
    far too large to enumerate are used through their parameters alone)."""

    def __init__(self, spec: str, name: str, instance: Any, mdp: Any = None, partition: Any = None):
        self.spec = spec
        self.name = name
        self.instance = instance
        self._mdp = mdp
        self._partition = partition

    @property
    def kind(self) -> str:
        return "garnet" if self.instance is None else self.instance.kind

    @property
    def mdp(self) -> Any:
        if self._mdp is None:
            self._mdp = self.instance.mdp()
        return self._mdp

    @property
    def partition(self) -> Any:
        if self._partition is None and self.instance is not None and self.instance.has_partition:
            self._partition = self.instance.partition()
        return self._partition

    def sizes(self) -> tuple[int, int | None]:
        """``(n_states, n_partitions)`` without enumerating a patrol model."""
        if self.kind == "patrol":
            p = self.params()
            return int(p.n_states), int(p.n_partitions)
        part = self.partition
        return self.mdp.n_states, (None if part is None else part.n_partitions)

    def params(self) -> Any:
        """The patrol parameters of a ``kind = "patrol"`` instance."""
        from ..patrol.params import PatrolParams

        table = {k: v for k, v in self.instance.config["model"].items() if k != "kind"}
        return PatrolParams.from_table(table)


def parse_instance(spec: str) -> tuple[str, dict[str, int] | None]:
    """``(name, garnet parameters or None)`` of an instance specification."""
    if spec.startswith("garnet:"):
        parts = spec.split(":")[1:]
        if not 2 <= len(parts) <= 3 or not all(p.isdigit() for p in parts):
            raise ValidationError(
                f"random instance {spec!r} must be written garnet:N:M[:SEED] (integers)"
            )
        n, m = int(parts[0]), int(parts[1])
        seed = int(parts[2]) if len(parts) == 3 else 0
        if not 1 <= m <= n:
            raise ValidationError(f"{spec!r}: need 1 <= M <= N")
        return spec, {"n": n, "m": m, "seed": seed}
    return spec, None


@lru_cache(maxsize=8)
def load_case(spec: str) -> Case:
    """Load (and cache in this process) the instance ``spec``."""
    from ..model.generators import garnet, random_partition
    from ..model.instances import load_instance

    name, g = parse_instance(spec)
    if g is not None:
        mdp = garnet(g["n"], 3, 4, 0.9, seed=g["seed"])
        part = random_partition(g["n"], g["m"], seed=g["seed"] + 1)
        return Case(spec, name, None, mdp, part)
    inst = load_instance(spec)
    return Case(spec, inst.name, inst)


# ---------------------------------------------------------------------- formulations
@dataclass(frozen=True)
class FormulationSpec:
    """How a study builds a formulation and its exact, solver-free counterpart.

    ``build(case)`` returns a fresh :class:`~lpbounds.formulations.base.Formulation`;
    ``reference(case, form)`` returns ``(exact values, their error bound)`` to compare
    with ``LPResult.values`` (or with ``LPResult.x`` when the sizes match that instead).
    """

    name: str
    module: str
    build: Callable[[Case], Formulation]
    reference: Callable[[Case, Any], tuple[np.ndarray, float]]
    description: str


def _dp_reference(rows: Any) -> tuple[np.ndarray, float]:
    """Fixed point of the max over ``rows`` (Fact 1) by exact DP, with its error bound."""
    from ..dp import solve_exact

    res = solve_exact(rows)
    return res.values, float(res.error_bound)


def _rows_reference(case: Case, form: Any) -> tuple[np.ndarray, float]:
    """Fixed point of the max over the formulation's rows (Fact 1), with its error bound."""
    return _dp_reference(form.rows)


def _fixed_point_reference(case: Case, form: Any) -> tuple[np.ndarray, float]:
    """The formulation's own ``fixed_point()`` (error bound: that of an exact DP solve)."""
    fp = form.fixed_point()
    values = getattr(fp, "values", fp)
    bound = float(getattr(fp, "error_bound", float("nan")))
    return np.asarray(values, dtype=np.float64), bound


def _need_mdp(case: Case, what: str) -> None:
    if case.partition is None:
        raise ValidationError(f"{what} needs a partition; {case.name} has none")


def _build_elp(case: Case) -> Any:
    from ..formulations.elp import ELP

    return ELP(case.mdp)


def _build_rlp(case: Case) -> Any:
    from ..formulations.rlp import RLP

    _need_mdp(case, "RLP")
    return RLP(case.mdp, case.partition)


def _build_slp(case: Case) -> Any:
    from ..formulations.slp import SLP

    _need_mdp(case, "SLP")
    return SLP(case.mdp, case.partition, mu="uniform")


def _build_ib(case: Case) -> Any:
    from ..formulations.ib import IB

    _need_mdp(case, "IB")
    return IB(case.mdp, case.partition, 2)


def _build_alp(case: Case) -> Any:
    from ..formulations.alp import ALP

    _need_mdp(case, "ALP")
    return ALP(case.mdp, case.partition.basis)


def _alp_reference(case: Case, form: Any) -> tuple[np.ndarray, float]:
    """With the hard basis Phi, ALP is RLP: its optimum is RLP's least feasible point."""
    from ..rows import BellmanRows

    return _dp_reference(BellmanRows.aggregate(case.mdp, case.partition, reduce="max"))


def _build_patrol(kind: str) -> Callable[[Case], Any]:
    name = "UBLP" if kind == "up" else "LBLP"

    def build(case: Case) -> Any:
        from ..patrol import bounds

        if case.kind != "patrol":
            raise ValidationError(f"{name} applies to patrol instances only")
        cls = bounds.UBLP if kind == "up" else bounds.LBLP
        return cls(case.params())

    return build


#: Formulations a study knows, by the paper's name. A class not importable yet is
#: skipped with a note (see :func:`available_formulations`).
FORMULATIONS: dict[str, FormulationSpec] = {
    "ELP": FormulationSpec(
        "ELP", "lpbounds.formulations.elp", _build_elp, _rows_reference, "exact LP, eq. 8"
    ),
    "RLP": FormulationSpec(
        "RLP", "lpbounds.formulations.rlp", _build_rlp, _rows_reference, "restricted LP, eq. 9"
    ),
    "SLP": FormulationSpec(
        "SLP",
        "lpbounds.formulations.slp",
        _build_slp,
        _fixed_point_reference,
        "surrogate LP, eq. 12, uniform mu (hard aggregation)",
    ),
    "IB": FormulationSpec(
        "IB",
        "lpbounds.formulations.ib",
        _build_ib,
        _fixed_point_reference,
        "iterated-Bellman lifted LP, eq. 20-22, L = 2",
    ),
    "ALP": FormulationSpec(
        "ALP",
        "lpbounds.formulations.alp",
        _build_alp,
        _alp_reference,
        "basis LP with the hard basis Phi (equals RLP)",
    ),
    "UBLP": FormulationSpec(
        "UBLP",
        "lpbounds.patrol.bounds",
        _build_patrol("up"),
        _fixed_point_reference,
        "patrol upper-bound LP, Theorem 4",
    ),
    "LBLP": FormulationSpec(
        "LBLP",
        "lpbounds.patrol.bounds",
        _build_patrol("low"),
        _fixed_point_reference,
        "patrol lower-bound LP, Theorem 3",
    ),
}


def available_formulations(
    names: Iterable[str] | None = None,
) -> tuple[list[str], list[str]]:
    """The requested formulation names whose classes import, and notes for the rest."""
    import importlib

    requested = list(FORMULATIONS) if names is None else [str(n).upper() for n in names]
    ok: list[str] = []
    notes: list[str] = []
    for name in requested:
        spec = FORMULATIONS.get(name)
        if spec is None:
            raise ValidationError(
                f"unknown formulation {name!r}; known: {fmt_list(FORMULATIONS, 'and')}"
            )
        try:
            importlib.import_module(spec.module)
        except ImportError as exc:
            notes.append(f"{name}: skipped: {spec.module} is not available ({exc})")
            continue
        if name not in ok:
            ok.append(name)
    return ok, notes


# ---------------------------------------------------------------------- one task
@lru_cache(maxsize=32)
def _reference(spec: str, formulation: str) -> tuple[np.ndarray, float]:
    case = load_case(spec)
    fspec = FORMULATIONS[formulation]
    return fspec.reference(case, fspec.build(case))


def _status(result: Any) -> str:
    """The result's status in :class:`lpbounds.status.Status`'s vocabulary (the retired
    "optimal_inaccurate" and "residual_too_large" are points with a valid bracket:
    "inaccurate")."""
    value = getattr(result.status, "value", str(result.status))
    if value in ("optimal_inaccurate", "residual_too_large"):
        return Status.INACCURATE.value
    return value


def _certified_error(case: Case, formulation: str, form: Any, result: Any) -> tuple[float, float]:
    """``(certified error, scale)`` of the returned point: a bound on ``max |values - exact
    optimum|`` (:func:`lpbounds.certification.checks.lp_bracket`) and ``max|R| / (1 - lambda)`` of
    the
    rows it was certified on. ALP with the hard basis is certified on RLP's rows (its
    optimum ``r`` is RLP's ``v*``)."""
    if formulation == "ALP":
        from ..certification.certificate import certify
        from ..rows import BellmanRows

        rows = BellmanRows.aggregate(case.mdp, case.partition, reduce="max")
        err = float(certify(rows, np.asarray(result.values, dtype=np.float64)).error_bound)
    else:
        rows = form.rows
        err = float(lp_bracket(form, result).error_bound)
    scale = dp_scale(float(np.abs(rows.reward).max(initial=0.0)), rows.discount)
    return err, scale


def _compare(result: Any, exact: np.ndarray) -> float:
    """``max |LP values - exact|`` (against ``x`` when that is what ``exact`` matches)."""
    for vec in (result.values, result.x):
        v = np.asarray(vec, dtype=np.float64).ravel()
        if v.size == exact.size:
            return float(np.abs(v - exact.ravel()).max(initial=0.0))
    return float("nan")


@dataclass(frozen=True)
class Task:
    """One (instance, formulation, solver configuration), solved ``repeat`` times."""

    instance: str
    formulation: str
    config: SolverConfig
    repeat: int = 1
    accuracy: float = LP_CERT_RTOL
    time_limit: float | None = None


#: Share of the time limit from which a stop that is not OPTIMAL counts as the limit's hit
#: (solvers stop a little before or after it).
_AT_LIMIT = 0.98


def _limit_status(status: str, solver_seconds: float, time_limit: float | None) -> str:
    """``time_limit`` when a solve that did not end OPTIMAL used up its time limit.

    cvxpy folds every limit into ``USER_LIMIT`` (``limit``) for most solvers, and SCS
    reports a stop at its time limit as "solved inaccurate"; HiGHS' own ``time_limit``
    already arrives as such. A point returned at the limit keeps its certified error.
    """
    if time_limit is None or status in (Status.OPTIMAL.value, Status.TIME_LIMIT.value):
        return status
    if status in (Status.INFEASIBLE.value, Status.UNBOUNDED.value):
        return status
    return Status.TIME_LIMIT.value if solver_seconds >= _AT_LIMIT * time_limit else status


def _infeasible_comment(form: Any, exact: np.ndarray) -> str:
    """The row violation of the exact solution, to say why "infeasible" is wrong."""
    if exact.size != form.A.shape[1]:
        return (
            "the solver says infeasible, but this LP is feasible by construction (the exact "
            "fixed point of its Bellman rows is a feasible point)"
        )
    viol = float(max(0.0, (form.b - form.A @ exact).max(initial=0.0)))
    return (
        "the solver says infeasible, but this LP is feasible by construction: the exact "
        f"fixed point satisfies every row up to rounding (largest violation {viol:.1e})"
    )


def _solve_once(task: Task, case: Case, exact: np.ndarray, rec: dict[str, Any]) -> None:
    """Build, solve and judge one repetition into ``rec`` (errors recorded, not raised)."""
    cfg = task.config
    options, _ = with_time_limit(cfg.solver, cfg.options, task.time_limit)
    t0 = time.perf_counter()
    try:
        form = FORMULATIONS[task.formulation].build(case)
        rec["n_rows"], rec["n_vars"] = (int(s) for s in form.A.shape)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = form.solve(cfg.solver, accuracy=task.accuracy, raise_on_failure=False, **options)
    except Exception as exc:  # a third-party solver's crash is a row, not an abort
        what = str(exc) if isinstance(exc, LPBoundsError) else f"{type(exc).__name__}: {exc}"
        rec.update(status=Status.SOLVER_ERROR.value, accurate=False, note=what)
        rec["certified_error"] = rec["rel_error"] = math.inf
        rec["wall_seconds"] = time.perf_counter() - t0
        return
    rec["wall_seconds"] = time.perf_counter() - t0
    status = _limit_status(_status(res), float(res.solve_seconds or 0.0), task.time_limit)
    has_point = bool(np.isfinite(np.asarray(res.x, dtype=np.float64)).all())
    has_point = has_point and status in {s.value for s in POINT_STATUSES}
    dev = _compare(res, exact) if has_point else float("nan")
    cert_err, scale = (
        _certified_error(case, task.formulation, form, res) if has_point else (math.inf, 1.0)
    )
    notes = [str(res.extra["message"])] if "message" in res.extra else []
    notes += sorted({f"{w.category.__name__}: {w.message}" for w in caught})
    if status == Status.INFEASIBLE.value:
        notes.append(_infeasible_comment(form, exact))
    if status == Status.TIME_LIMIT.value:
        notes.append(
            f"time limit {task.time_limit:g} s reached"
            + ("" if has_point else "; no point returned")
        )
    rec.update(
        status=status,
        objective=res.objective,
        certified_error=cert_err,
        rel_error=cert_err / scale,
        accurate=bool(has_point and cert_err <= task.accuracy * scale),
        max_deviation=dev,
        primal_residual=res.primal_residual,
        residual_tol=res.residual_tol,
        dual_residual=res.dual_residual,
        gap=res.gap,
        compile_seconds=res.compile_seconds,
        solve_seconds=res.solve_seconds,
        iterations=res.iterations,
        note="; ".join(notes),
    )


def run_task(task: Task) -> list[dict[str, Any]]:
    """Solve one (instance, formulation, solver configuration) ``task.repeat`` times.

    Returns one record per repetition (keys :data:`COLUMNS`). Errors of the model or the
    solver are recorded in ``status``/``note``, never raised, so one failure does not
    stop a study.
    """
    cfg = task.config
    base: dict[str, Any] = dict.fromkeys(COLUMNS)
    _, limited = with_time_limit(cfg.solver, cfg.options, task.time_limit)
    base.update(
        instance=task.instance,
        formulation=task.formulation,
        solver=cfg.solver,
        option_set=cfg.option_set,
        config=cfg.label,
        backend=cfg.backend,
        accuracy=task.accuracy,
        time_limit=task.time_limit if limited else None,
        note="",
    )
    try:
        case = load_case(task.instance)
        base["instance"] = case.name
        base["n_states"], base["n_partitions"] = case.sizes()
        exact, ref_bound = _reference(task.instance, task.formulation)
    except (LPBoundsError, ImportError) as exc:
        return [{**base, "repeat": 0, "status": "skipped", "note": str(exc)}]
    base["reference_error_bound"] = ref_bound
    base["deviation_tol"] = LP_COMPARE_RTOL * max(1.0, float(np.abs(exact).max(initial=0.0)))
    records = []
    for k in range(task.repeat):
        rec = {**base, "repeat": k}
        _solve_once(task, case, exact, rec)
        records.append(rec)
    return records


# ---------------------------------------------------------------------- the study
@dataclass(repr=False)
class StudyResult:
    """A study's table (one row per solve), the notes on what was skipped, and how it was
    run (``params``: instances, formulations, configurations, accuracy, time limit)."""

    frame: pd.DataFrame
    notes: list[str]
    seconds: float
    params: dict[str, Any] = field(default_factory=dict)
    #: a default study (every installed solver): the known LP solvers that are not
    #: installed here, which it could not run (:func:`missing_solvers`; written to notes.txt
    #: with their install commands)
    not_installed: list[str] = field(default_factory=list)

    def __repr__(self) -> str:
        """One line, no table: solves, instances, formulations, configurations, seconds."""
        f = self.frame
        counts = [
            f"{len(f):,} solves",
            f"{len(self.params.get('instances', [])):,} instances",
            f"formulations {fmt_list(self.params.get('formulations', []))}",
            f"{len(self.params.get('configs', [])):,} solver configurations",
        ]
        return f"StudyResult({', '.join(counts)}, {fmt_seconds(self.seconds)})"

    def to_pandas(self) -> pd.DataFrame:
        """The study as a table, one row per solve (a copy: changing it changes nothing
        here).

        Returns
        -------
        pandas.DataFrame
            Indexed by ``solve`` (0, 1, ...), with the columns :data:`COLUMNS`:

            ``instance``, ``n_states``, ``n_partitions``
                The instance's name (a models/ name or ``garnet:N:M[:SEED]``) and its size
                (``n_partitions`` None without a partition).
            ``formulation``, ``n_rows``, ``n_vars``
                The paper's name and the LP's size ``A`` (rows x variables).
            ``solver``, ``option_set``, ``config``, ``backend``, ``repeat``
                cvxpy's solver name, the named option set, ``SOLVER`` or ``SOLVER:SET``,
                the code that runs (``SCIPY`` runs HiGHS), the repetition (0, 1, ...).
            ``status``
                The :class:`~lpbounds.status.Status` value (``optimal``, ``inaccurate``,
                ``time_limit``, ``infeasible``, ``solver_error``, ...), decided from the
                returned point's certificate.
            ``objective``
                ``c'x`` of the returned point.
            ``certified_error``, ``rel_error``
                A bound on ``max |values - exact optimum|`` certified from the point alone
                (``inf`` without a point), and the same relative to ``max|R| / (1 -
                lambda)``.
            ``accuracy``, ``time_limit``, ``accurate``
                The requested relative accuracy, the seconds given to the solver (None
                without a limit, or for a solver that has no time-limit option), and
                whether the point is certified within ``accuracy`` (the solve counts as
                solved).
            ``max_deviation``, ``deviation_tol``, ``reference_error_bound``
                ``max |values - exact|`` against the formulation's exact, solver-free
                counterpart (NaN without a point), the tolerance it is read against, and
                the exact reference's own error bound.
            ``primal_residual``, ``residual_tol``, ``dual_residual``, ``gap``
                The LP result's ``max (b - A x)^+``, the absolute threshold of its status,
                ``||A'y - c||_inf`` and the duality gap ``|c'x - b'y|``.
            ``compile_seconds``, ``solve_seconds``, ``wall_seconds``
                cvxpy's compilation, the solver's own time, and building plus solving.
            ``iterations``, ``note``
                The solver's iterations; the solver's message, warnings, and why an
                "infeasible" or a time limit happened (``""`` when nothing is to say).
        """
        out = self.frame.copy()
        out.index = out.index.rename("solve")
        return out

    def summary(self) -> pd.DataFrame:
        """Median over repetitions per (instance, formulation, solver configuration)."""
        return summarize(self.frame)

    def solver_summary(self, shifts: Sequence[float] = DEFAULT_SHIFTS) -> pd.DataFrame:
        """Per solver configuration: counts and shifted geometric means of time
        (:func:`lpbounds.studies.report.solver_summary`)."""
        return solver_summary(self.frame, shifts, time_limit=self.params.get("time_limit"))


def run_study(
    instances: Sequence[str] | None = None,
    formulations: Sequence[str] | None = None,
    solvers: Sequence[str] | None = None,
    *,
    repeat: int = 1,
    accuracy: float = LP_CERT_RTOL,
    time_limit: float | None = None,
    jobs: int | None = None,
    scheduler: str | Any | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> StudyResult:
    """Solve every (instance, formulation, solver configuration) ``repeat`` times.

    Parameters
    ----------
    instances : sequence of str, optional
        Instance files or names (``models/``), or ``garnet:N:M[:SEED]``
        (default :data:`DEFAULT_INSTANCES`).
    formulations : sequence of str, optional
        Paper names (default :data:`DEFAULT_FORMULATIONS`).
    solvers : sequence of str, optional
        ``SOLVER`` or ``SOLVER:SET`` (default: every installed LP solver, every set).
    repeat : int
        Solves per combination (each on a freshly built formulation).
    accuracy : float
        Requested accuracy relative to ``max|R| / (1 - lambda)``: passed to each solve
        (its status) and the threshold of the ``accurate`` column on ``certified_error``.
    time_limit : float, optional
        Seconds per solve, passed in each solver's own keyword
        (:data:`lpbounds.formulations.solvers.TIME_LIMIT_OPTIONS`; a solver without one runs
        unlimited, with a note). A solve that used it up without an OPTIMAL point has
        status ``time_limit`` and keeps its point and certified error.
    jobs : int, optional
        Local worker processes (default ``os.cpu_count()``); ``1`` runs in this process.
    scheduler : str or dask.distributed.Client, optional
        ``"synchronous"``, ``"threads"`` or ``"processes"`` (dask's local schedulers,
        without a cluster), the address of a running Dask scheduler
        (``"tcp://127.0.0.1:8786"``), or a client; the tasks then run through Dask
        instead of local processes.
    progress : callable(done, total), optional
        Called after each finished task.

    Returns
    -------
    StudyResult

    Raises
    ------
    ValidationError
        Before any solve: a missing instance file, an unknown solver or option set, no
        solver or formulation left to run, a bad ``repeat``, ``accuracy`` or
        ``time_limit``, a ``scheduler`` that is none of the accepted ones or an address
        where no scheduler answers (:func:`check_scheduler`).
    """
    import pandas as pd

    t0 = time.perf_counter()
    scheduler = check_scheduler(scheduler)
    tasks, notes = _prepare_tasks(instances, formulations, solvers, repeat, accuracy, time_limit)
    records = _execute(tasks, jobs, scheduler, progress)
    frame = pd.DataFrame.from_records(records, columns=list(COLUMNS))
    skipped = frame[frame["status"] == "skipped"]
    for (inst, form), grp in skipped.groupby(["instance", "formulation"]):
        notes.append(f"{form} on {inst}: skipped: {grp['note'].iloc[0]}")
    frame = frame[frame["status"] != "skipped"].reset_index(drop=True)
    configs: list[SolverConfig] = []
    for t in tasks:  # SolverConfig holds a dict: not hashable, compared instead
        if t.config not in configs:
            configs.append(t.config)
    params = {
        "instances": list(dict.fromkeys(t.instance for t in tasks)),
        "formulations": list(dict.fromkeys(t.formulation for t in tasks)),
        "configs": [
            {"label": c.label, "solver": c.solver, "backend": c.backend, "options": c.options}
            for c in configs
        ],
        "repeat": repeat,
        "accuracy": float(accuracy),
        "time_limit": time_limit,
        "jobs": jobs,
        "scheduler": scheduler if isinstance(scheduler, (str, type(None))) else "client",
    }
    missing = missing_solvers(lp_capable_solvers()) if solvers is None else []
    return StudyResult(frame, notes, time.perf_counter() - t0, params, missing)


def _prepare_tasks(
    instances: Sequence[str] | None,
    formulations: Sequence[str] | None,
    solvers: Sequence[str] | None,
    repeat: int,
    accuracy: float,
    time_limit: float | None = None,
) -> tuple[list[Task], list[str]]:
    """The tasks of a study and its notes; every input error raised here, before a solve."""
    from ..model.instances import load_instance
    from ..validation import check_real

    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValidationError(f"repeat must be an integer >= 1; got {repeat!r}")
    if not (isinstance(accuracy, (int, float)) and math.isfinite(accuracy) and accuracy > 0):
        raise ValidationError(f"accuracy must be a positive finite number; got {accuracy!r}")
    if time_limit is not None:
        time_limit = check_real("time_limit", time_limit, lo=0.0, lo_open=True)
    instances = list(instances) if instances else list(DEFAULT_INSTANCES)
    for spec in instances:
        if parse_instance(spec)[1] is None:
            load_instance(spec)  # a missing or invalid file fails now, not as a skip
    names, notes = available_formulations(formulations or DEFAULT_FORMULATIONS)
    configs, solver_notes = solver_configs(solvers)
    notes += solver_notes
    if not names:
        raise ValidationError("no formulation to run: " + "; ".join(notes))
    if not configs:
        raise ValidationError("no solver to run: " + ("; ".join(solver_notes) or "none given"))
    if time_limit is not None:
        unlimited = sorted({c.solver for c in configs if not with_time_limit(c.solver, {}, 1.0)[1]})
        if unlimited:
            notes.append(
                f"no time-limit option known for {fmt_list(unlimited, 'and')}: they run without one"
            )
    tasks = [
        Task(s, f, c, repeat, float(accuracy), time_limit)
        for s in instances
        for f in names
        for c in configs
    ]
    return tasks, notes


#: A log record of a worker process, re-emitted by the parent: (logger name, level, text).
LogLine = tuple[str, int, str]


class _Collect(logging.Handler):
    """Keeps the records of the ``lpbounds`` log (WARNING and above) instead of printing."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.lines: list[LogLine] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append((record.name, record.levelno, record.getMessage()))


def run_task_in_worker(task: Task) -> tuple[list[dict[str, Any]], list[LogLine]]:
    """:func:`run_task` in a worker process, returning its ``lpbounds`` log records (WARNING
    and above) instead of printing them: a worker writing to the terminal itself would
    write into the parent's progress display, and every worker would repeat a notice (once
    per worker). The parent logs each distinct record once."""
    logger = logging.getLogger("lpbounds")
    handler = _Collect()
    saved = logger.propagate
    logger.addHandler(handler)
    logger.propagate = False
    try:
        return run_task(task), handler.lines
    finally:
        logger.removeHandler(handler)
        logger.propagate = saved


def _relog(lines: Iterable[LogLine], seen: set[LogLine]) -> None:
    """Log the workers' records in this process, each distinct one once."""
    for line in lines:
        if line not in seen:
            seen.add(line)
            name, level, text = line
            logging.getLogger(name).log(level, "%s", text)


def dask_map(
    fn: Callable[[Any], Any], items: Sequence[Any], scheduler: str | Any
) -> Iterator[tuple[int, Any]]:
    """``fn`` over ``items`` through Dask: ``(index, fn(items[index]))`` as each finishes.

    Parameters
    ----------
    fn : callable
        Picklable (a module-level function) for a cluster or the ``processes`` scheduler.
    items : sequence
    scheduler : str or dask.distributed.Client
        One of :data:`DASK_LOCAL` (Dask's local schedulers: the calls are computed
        together and yielded in order), the address of a running Dask scheduler, or a
        client (the calls are submitted at once and yielded as they complete; a client
        given is left open, one made from an address is closed).

    Raises
    ------
    SolverNotInstalledError
        Without dask (a local scheduler) or dask.distributed (a cluster).
    """
    if scheduler in DASK_LOCAL:
        try:
            import dask
        except ImportError as exc:
            raise SolverNotInstalledError(
                f"scheduler {scheduler!r} needs dask: pip install 'lpbounds[study]'"
            ) from exc
        calls = [dask.delayed(fn, pure=False)(t) for t in items]
        yield from enumerate(dask.compute(*calls, scheduler=str(scheduler)))
        return
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:
        raise SolverNotInstalledError(
            "--scheduler needs dask.distributed: pip install 'lpbounds[study]'"
        ) from exc
    own = not isinstance(scheduler, Client)
    client = Client(scheduler) if own else cast(Client, scheduler)
    try:
        futures = client.map(fn, list(items), pure=False)
        where = {fut.key: k for k, fut in enumerate(futures)}
        for fut in as_completed(futures):
            yield where[fut.key], fut.result()
    finally:
        if own:
            client.close()


def _run_dask(
    tasks: list[Task], scheduler: str | Any
) -> Iterable[tuple[list[dict[str, Any]], list[LogLine]]]:
    return (batch for _, batch in dask_map(run_task_in_worker, tasks, scheduler))


#: Dask's local schedulers, usable without a cluster (``scheduler="threads"``).
DASK_LOCAL = ("synchronous", "threads", "processes")

#: The address schemes of a Dask scheduler given as text: over TCP (checked by opening a
#: connection), UCX (parsed only), and ``inproc://`` (a cluster in this process).
DASK_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx", "inproc")

_ADDRESS = re.compile(
    r"(?:(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+)"
    r":(?P<port>[0-9]{1,5})"
)


def _address(scheduler: str) -> tuple[str, int]:
    """``(host, port)`` of a scheduler's address, ``host:port`` or ``scheme://host:port``."""
    m = _ADDRESS.fullmatch(scheduler.strip())
    if m is None:
        raise ValidationError(
            f"scheduler {scheduler!r} is neither one of Dask's local schedulers "
            f"({', '.join(DASK_LOCAL)}) nor a Dask scheduler's address with its port "
            "(host:port or tcp://host:port)"
        )
    scheme, port = m["scheme"], int(m["port"])
    if scheme is not None and scheme.lower() not in DASK_SCHEMES:
        raise ValidationError(
            f"scheduler {scheduler!r}: unknown scheme {scheme!r} (known: "
            f"{', '.join(DASK_SCHEMES)}); for another transport pass a dask.distributed "
            "Client"
        )
    if not 0 < port < 65536:
        raise ValidationError(f"scheduler {scheduler!r}: port {port} is not in 1..65535")
    return m["host"].strip("[]"), port


def check_scheduler(scheduler: str | Any | None) -> str | Any | None:
    """``scheduler`` checked before any work or output: None, one of :data:`DASK_LOCAL`
    (dask installed), a ``dask.distributed`` client, or the address of a Dask scheduler
    that answers (``host:port`` or ``scheme://host:port``, schemes :data:`DASK_SCHEMES`;
    a TCP connection is opened and closed, waiting at most
    :data:`~lpbounds.tolerances.SCHEDULER_CONNECT_SECONDS`).

    Returns
    -------
    str or Client or None
        ``scheduler`` itself (an address stripped of surrounding blanks).

    Raises
    ------
    ValidationError
        Anything else (naming it and what is accepted), or an address where nothing
        answers.
    SolverNotInstalledError
        dask (a local scheduler) or dask.distributed (an address) is not installed.
    """
    if scheduler is None:
        return None
    if not isinstance(scheduler, str):
        if all(callable(getattr(scheduler, m, None)) for m in ("submit", "map")):
            return scheduler
        raise ValidationError(
            f"scheduler must be a name, an address or a dask.distributed Client; got "
            f"{type(scheduler).__name__}"
        )
    if scheduler in DASK_LOCAL:
        if importlib.util.find_spec("dask") is None:
            raise SolverNotInstalledError(
                f"scheduler {scheduler!r} needs dask: pip install 'lpbounds[study]'"
            )
        return scheduler
    if importlib.util.find_spec("distributed") is None:
        raise SolverNotInstalledError(
            f"scheduler {scheduler!r} needs dask.distributed: pip install 'lpbounds[study]'"
        )
    if scheduler.strip().startswith("inproc://"):  # a cluster of this process
        return scheduler.strip()
    host, port = _address(scheduler)
    if scheduler.strip().lower().startswith("ucx://"):  # not TCP: parsed, not probed
        return scheduler.strip()
    import socket

    try:
        with socket.create_connection((host, port), timeout=SCHEDULER_CONNECT_SECONDS):
            pass
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        raise ValidationError(
            f"scheduler {scheduler!r}: no Dask scheduler answers at {host}:{port} ({why}); "
            f"start one there (dask scheduler --port {port}) or give one of "
            f"{', '.join(DASK_LOCAL)}"
        ) from None
    return scheduler.strip()


def connect_scheduler(address: str) -> Any:
    """A ``dask.distributed`` client of the scheduler at ``address`` (checked by
    :func:`check_scheduler`), connected within
    :data:`~lpbounds.tolerances.SCHEDULER_CONNECT_SECONDS`; the caller closes it.

    Raises
    ------
    ValidationError
        The address answers but no Dask scheduler does (another service, a timeout).
    """
    from dask.distributed import Client

    try:
        return Client(address, timeout=SCHEDULER_CONNECT_SECONDS)
    except (OSError, TimeoutError) as exc:
        raise ValidationError(
            f"scheduler {address!r}: the address answers, but no Dask scheduler does "
            f"({type(exc).__name__}: {' '.join(str(exc).split())[:200]})"
        ) from None


def _execute(
    tasks: list[Task],
    jobs: int | None,
    scheduler: str | Any | None,
    progress: Callable[[int, int], None] | None,
) -> list[dict[str, Any]]:
    """Run the tasks through Dask, in this process, or in spawned local processes; the
    log records of other processes are logged here, each distinct one once."""
    records: list[dict[str, Any]] = []
    seen: set[LogLine] = set()
    with ExitStack() as stack:  # the process pool, when there is one, lives as long as this
        batches: Iterable[tuple[list[dict[str, Any]], list[LogLine]]]
        if scheduler in DASK_LOCAL:
            batches = _run_dask_local(tasks, str(scheduler))
        elif scheduler is not None:
            batches = _run_dask(tasks, scheduler)
        elif (jobs or os.cpu_count() or 1) <= 1 or len(tasks) <= 1:
            batches = ((run_task(t), []) for t in tasks)  # this process: logged as it happens
        else:
            n = min(int(jobs or os.cpu_count() or 1), len(tasks))
            # spawn, not fork: forking a process that has run OpenMP code (HiGHS)
            # aborts the child ("fork() called from a process already using GNU OpenMP")
            ctx = multiprocessing.get_context("spawn")
            pool = stack.enter_context(ProcessPoolExecutor(max_workers=n, mp_context=ctx))
            batches = pool.map(run_task_in_worker, tasks)
        for done, (batch, lines) in enumerate(batches, 1):
            _relog(lines, seen)
            records += batch
            if progress:
                progress(done, len(tasks))
    return records


def _run_dask_local(
    tasks: list[Task], scheduler: str
) -> list[tuple[list[dict[str, Any]], list[LogLine]]]:
    """The tasks as dask.delayed calls, computed by one of Dask's local schedulers (the
    ``processes`` one collects each worker's log; the others run here and log here)."""
    if scheduler == "processes":
        return [batch for _, batch in dask_map(run_task_in_worker, tasks, scheduler)]
    return [(batch, []) for _, batch in dask_map(run_task, tasks, scheduler)]
