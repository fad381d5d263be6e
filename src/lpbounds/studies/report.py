"""What a solver study writes: result tables, per-solver summaries, profiles and metadata.

Everything here works on a study's table (one row per solve,
:data:`lpbounds.studies.compare.COLUMNS`):

* :func:`summarize` -- per (instance, formulation, solver configuration): medians over
  repetitions, the worst certified error;
* :func:`solver_summary` -- per solver configuration, as LP benchmarks report it: status
  counts (solved, optimal, inaccurate, time limit, other limits, failed) and shifted
  geometric means of the solve time (:data:`DEFAULT_SHIFTS`: Mittelmann's 10 s, and 0.01 s
  for studies of sub-second solves), an unsolved problem charged the time limit (or, with
  none, the longest solve of the study);
* :func:`profile_tables` / :func:`plot_profiles` -- Dolan-Moré performance profiles
  (:mod:`lpbounds.studies.profiles`) of time and, separately, of accuracy (the certified error
  relative to ``max|R| / (1 - lambda)``), failures counting as unsolved;
* :func:`study_metadata` -- versions of lpbounds, cvxpy, every solver package of the study
  and what it depends on, the machine, the date and the command line;
* :func:`save_study` -- all of it into a folder.

A problem is one (instance, formulation); it is *solved* by a configuration when every
repetition returned a point certified within the requested accuracy (``accurate``),
whatever the solver's status.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._defaults import DEFAULT_SHIFTS
from ..status import POINT_STATUSES, Status
from .profiles import new_figure, plot_performance_profile, shifted_geometric_mean

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from .compare import StudyResult

__all__ = [
    "DEFAULT_SHIFTS",
    "ERROR_FLOOR",
    "TIME_FLOOR",
    "missing_solvers_note",
    "plot_profiles",
    "plot_study",
    "profile_tables",
    "save_study",
    "sgm_column",
    "solver_summary",
    "study_metadata",
    "summarize",
]

#: Times below this (s) are read as this in the time profile (timer resolution).
TIME_FLOOR = 1e-4
#: Relative certified errors below this are read as this in the accuracy profile.
ERROR_FLOOR = 1e-16

_POINT = frozenset(s.value for s in POINT_STATUSES)
_OTHER_LIMITS = frozenset({Status.ITERATION_LIMIT.value, Status.LIMIT.value})
_FAILED = frozenset({Status.INFEASIBLE.value, Status.UNBOUNDED.value, Status.SOLVER_ERROR.value})
_KEYS = ["instance", "formulation", "config"]


def missing_solvers_note(missing: Sequence[str]) -> str:
    """One line naming the ``missing`` solvers with their install commands (notes.txt)."""
    from ..formulations.base import INSTALL_HINTS

    return "not installed, skipped: " + ", ".join(f"{s} ({INSTALL_HINTS[s]})" for s in missing)


def sgm_column(shift: float) -> str:
    """Name of the shifted-geometric-mean column for ``shift`` seconds (``sgm_10s``)."""
    return f"sgm_{shift:g}s"


def summarize(frame: pd.DataFrame) -> pd.DataFrame:
    """Median times over repetitions per (instance, formulation, configuration).

    ``status`` joins the distinct statuses; ``accurate`` is true only when every
    repetition was (a point, certified within the requested accuracy);
    ``certified_error``, ``rel_error`` and ``max_deviation`` are the largest over
    repetitions; ``note`` is the first repetition's."""
    agg = frame.groupby(_KEYS, sort=False).agg(
        backend=("backend", "first"),
        n_vars=("n_vars", "first"),
        status=("status", lambda s: ",".join(sorted(set(s)))),
        objective=("objective", "median"),
        certified_error=("certified_error", "max"),
        rel_error=("rel_error", "max"),
        accurate=("accurate", "all"),
        max_deviation=("max_deviation", "max"),
        primal_residual=("primal_residual", "max"),
        compile_seconds=("compile_seconds", "median"),
        solve_seconds=("solve_seconds", "median"),
        iterations=("iterations", "median"),
        repeats=("repeat", "count"),
        note=("note", "first"),
    )
    return agg.reset_index()


def _per_problem(frame: pd.DataFrame) -> pd.DataFrame:
    """Per (instance, formulation, configuration): solved, median time, worst error."""
    f = frame.assign(
        has_point=frame["status"].isin(_POINT)
        & np.isfinite(frame["rel_error"].astype(float).fillna(np.inf)),
        accurate=frame["accurate"].fillna(False).astype(bool),
    )
    per = f.groupby(_KEYS, sort=False).agg(
        solved=("accurate", "all"),
        all_points=("has_point", "all"),
        seconds=("solve_seconds", "median"),
        rel_error=("rel_error", "max"),
    )
    return per.reset_index()


def profile_tables(frame: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The measure tables of the time and accuracy profiles (problems x configurations).

    Time: the median solve time (floored at :data:`TIME_FLOOR`) where the problem was
    solved (every repetition certified within the accuracy), ``inf`` otherwise. Accuracy:
    the largest relative certified error over repetitions (floored at
    :data:`ERROR_FLOOR`) where every repetition returned a point (a stop at a time limit
    is compared on the point it reached), ``inf`` where one returned none.
    """
    per = _per_problem(frame)
    per["problem"] = per["instance"].astype(str) + " / " + per["formulation"].astype(str)
    secs = per["seconds"].astype(float).clip(lower=TIME_FLOOR)
    per["time"] = np.where(per["solved"] & np.isfinite(secs), secs, np.inf)
    err = per["rel_error"].astype(float).clip(lower=ERROR_FLOOR)
    per["accuracy"] = np.where(per["all_points"] & np.isfinite(err), err, np.inf)
    order = list(dict.fromkeys(per["config"]))
    time_table = per.pivot(index="problem", columns="config", values="time")[order]
    acc_table = per.pivot(index="problem", columns="config", values="accuracy")[order]
    return time_table.fillna(np.inf), acc_table.fillna(np.inf)


def solver_summary(
    frame: pd.DataFrame,
    shifts: Sequence[float] = DEFAULT_SHIFTS,
    *,
    time_limit: float | None = None,
) -> pd.DataFrame:
    """Per solver configuration: status counts and shifted geometric means of time.

    Parameters
    ----------
    frame : pandas.DataFrame
        A study's table.
    shifts : sequence of float
        Shifts in seconds; one column ``sgm_<shift>s`` each (:func:`sgm_column`).
    time_limit : float, optional
        What an unsolved problem is charged in the means; default the longest solve time
        in ``frame`` (so a failure never looks faster than the slowest solve).

    Returns
    -------
    pandas.DataFrame
        ``config``, ``backend``, ``problems``, ``solved`` (problems certified within the
        accuracy in every repetition), solve counts ``optimal``, ``inaccurate``,
        ``time_limit``, ``other_limit`` (iteration or unnamed limits), ``failed`` (no
        point: infeasible, unbounded, solver error), ``worst_rel_error`` (largest
        relative certified error of a returned point) and the means.
    """
    import pandas as pd

    per = _per_problem(frame)
    longest = float(np.nanmax(frame["solve_seconds"].astype(float), initial=0.0))
    charge = float(time_limit) if time_limit is not None else longest
    rows = []
    for cfg, grp in frame.groupby("config", sort=False):
        prob = per[per["config"] == cfg]
        secs = prob["seconds"].astype(float)
        times = np.where(prob["solved"] & np.isfinite(secs), secs.fillna(0.0), charge)
        status = grp["status"]
        finite = grp["rel_error"].astype(float)
        finite = finite[np.isfinite(finite)]
        row: dict[str, Any] = {
            "config": cfg,
            "backend": grp["backend"].iloc[0],
            "problems": len(prob),
            "solved": int(prob["solved"].sum()),
            "optimal": int((status == Status.OPTIMAL.value).sum()),
            "inaccurate": int((status == Status.INACCURATE.value).sum()),
            "time_limit": int((status == Status.TIME_LIMIT.value).sum()),
            "other_limit": int(status.isin(_OTHER_LIMITS).sum()),
            "failed": int(status.isin(_FAILED).sum()),
            "worst_rel_error": float(finite.max()) if len(finite) else float("nan"),
        }
        for s in shifts:
            row[sgm_column(s)] = shifted_geometric_mean(np.maximum(times, 0.0), s)
        rows.append(row)
    return pd.DataFrame(rows)


def plot_profiles(frame: pd.DataFrame, out: str | Path) -> dict[str, Path]:
    """``profile_time.png`` and ``profile_accuracy.png`` in ``out`` (see :func:`profile_tables`)."""
    out = Path(out)
    time_table, acc_table = profile_tables(frame)
    labels = {
        str(c): f"{c}: {b}"
        for c, b in frame.groupby("config", sort=False)["backend"].first().items()
    }
    n = time_table.shape[0]
    return {
        "profile_time": plot_performance_profile(
            time_table,
            out / "profile_time.png",
            title=f"Performance profile: solve time ({n} problems, solved = certified)",
            measure="solve time",
            labels=labels,
        ),
        "profile_accuracy": plot_performance_profile(
            acc_table,
            out / "profile_accuracy.png",
            title=f"Performance profile: certified error of the returned point ({n} problems)",
            measure="certified error",
            labels=labels,
        ),
    }


def plot_study(frame: pd.DataFrame, path: str | Path) -> Path:
    """Save the summary figure: solve time vs LP size per solver; certified error vs time.

    Left, a point per problem (the median over its repeats) and per solver a line through
    the median at each size, so problems of one size show as points and the line never
    runs vertically through them. Solves that returned no point are drawn at their wall
    time as red crosses (left) and on the top edge (right), not dropped."""
    from matplotlib import colormaps
    from matplotlib.lines import Line2D

    path = Path(path)
    point = frame["status"].isin(_POINT) & np.isfinite(frame["certified_error"].astype(float))
    ok, failed = frame[point], frame[~point]
    fig = new_figure((12, 4.8))
    ax1, ax2 = fig.subplots(1, 2)
    markers = dict(zip(sorted(frame["formulation"].unique()), "osD^v<>ph*", strict=False))
    configs = list(dict.fromkeys(frame["config"]))
    tab10 = colormaps["tab10"]
    colors = {c: tab10(i % 10) for i, c in enumerate(configs)}
    for (cfg, form), grp in ok.groupby(["config", "formulation"]):
        # a point per problem (median of its repeats); the line through the median at
        # each size, one y per x: problems of the same size show as points, not as a
        # vertical stroke of the line through them
        per = grp.groupby(["instance", "n_vars"], as_index=False)["solve_seconds"].median()
        ax1.scatter(per["n_vars"], per["solve_seconds"], marker=markers[form], color=colors[cfg])
        med = per.groupby("n_vars", as_index=False)["solve_seconds"].median()
        ax1.plot(med["n_vars"], med["solve_seconds"], color=colors[cfg], lw=1.2)
        total = grp["compile_seconds"] + grp["solve_seconds"]
        err = np.maximum(grp["certified_error"].astype(float), 1e-16)
        ax2.scatter(total, err, marker=markers[form], color=colors[cfg])
    if len(failed):
        ax1.scatter(failed["n_vars"], failed["wall_seconds"], marker="x", color="red", zorder=3)
        top = max(1.0, float(ok["certified_error"].max()) * 10 if len(ok) else 1.0)
        ax2.scatter(failed["wall_seconds"], np.full(len(failed), top), marker="x", color="red")
    ax1.set(xscale="log", yscale="log", xlabel="LP variables", title="solve time vs size")
    ax1.set_ylabel("solve time (s): each problem, median of repeats;\nline: median per size")
    ax2.set(xscale="log", yscale="log", xlabel="compile + solve time (s)", title="accuracy vs time")
    ax2.set_ylabel("certified error bound (floored at 1e-16)")
    for ax in (ax1, ax2):
        ax.grid(True, which="both", alpha=0.3)
    keys = [Line2D([], [], color=colors[c], marker="o", ls="-", label=c) for c in configs]
    keys += [Line2D([], [], color="k", marker=m, ls="", label=f) for f, m in markers.items()]
    if len(failed):  # a legend entry only for what is drawn
        keys.append(Line2D([], [], color="red", marker="x", ls="", label="no point returned"))
    fig.legend(handles=keys, loc="center right", fontsize=8, frameon=False,
               title="solver (colour) / formulation (marker)", title_fontsize=8)  # fmt: skip
    fig.tight_layout(rect=(0, 0, 0.8, 1))
    fig.savefig(path, dpi=100)
    return path


def study_metadata(
    result: StudyResult, command_line: Sequence[str] | None = None
) -> dict[str, Any]:
    """How a study was made: :func:`lpbounds.outputs.run_metadata` (lpbounds, Python,
    dependencies, machine, date), the command line, the study's parameters, and per
    solver of the study its backend, package versions and their requirements' versions."""
    from ..formulations.solvers import solver_distributions
    from ..outputs import run_metadata

    params = dict(result.params)
    solvers = list(dict.fromkeys(c["solver"] for c in params.get("configs", [])))
    return {
        **run_metadata(),
        "command_line": list(sys.argv if command_line is None else command_line),
        "study": params,
        "study_solvers": solver_distributions(solvers),
        "notes": list(result.notes),
        "not_installed": list(result.not_installed),
        "seconds": result.seconds,
    }


def save_study(
    result: StudyResult,
    out: str | Path,
    *,
    shifts: Sequence[float] = DEFAULT_SHIFTS,
    command_line: Sequence[str] | None = None,
) -> dict[str, Path]:
    """Write a study into ``out``; returns the paths by kind.

    ``study.csv`` (and ``study.parquet`` with pyarrow): one row per solve; ``summary.csv``:
    per problem and configuration; ``solvers.csv``: :func:`solver_summary`;
    ``profile_time.png``, ``profile_accuracy.png``: :func:`plot_profiles`; ``study.png``:
    :func:`plot_study`; ``notes.txt``; ``metadata.json``: :func:`study_metadata`.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {
        "csv": out / "study.csv",
        "summary": out / "summary.csv",
        "solvers": out / "solvers.csv",
        "notes": out / "notes.txt",
        "metadata": out / "metadata.json",
    }
    result.frame.to_csv(paths["csv"], index=False)
    result.summary().to_csv(paths["summary"], index=False)
    result.solver_summary(shifts).to_csv(paths["solvers"], index=False)
    notes = list(result.notes)
    if result.not_installed:
        notes.append(missing_solvers_note(result.not_installed))
    paths["notes"].write_text("".join(f"{n}\n" for n in notes))
    meta = study_metadata(result, command_line)
    paths["metadata"].write_text(json.dumps(meta, indent=2, default=str) + "\n")
    try:
        import pyarrow  # noqa: F401

        paths["parquet"] = out / "study.parquet"
        result.frame.to_parquet(paths["parquet"], index=False)
    except ImportError:
        pass
    paths.update(plot_profiles(result.frame, out))
    paths["plot"] = plot_study(result.frame, out / "study.png")
    return paths
