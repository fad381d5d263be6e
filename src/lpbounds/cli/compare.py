"""``lpbounds compare [MODELS...]``: a solver comparison study (see :mod:`lpbounds.study`)."""

from __future__ import annotations

import argparse
import logging
import math
from typing import Any

from rich import box
from rich.table import Table
from rich.text import Text

from .._defaults import DEFAULT_FORMULATIONS, DEFAULT_INSTANCES
from ..errors import ValidationError
from ..outputs import MANIFEST, AtomicDirectory
from ..tolerances import LP_CERT_RTOL
from ._common import check_output_dir, console, print_table, progress

log = logging.getLogger("lpbounds")


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "compare",
        help="solve every (instance, formulation, solver) and tabulate accuracy and time",
        description=(
            "Solve every (instance, formulation, solver option set) and write study.csv "
            "(and study.parquet with pyarrow), summary.csv, notes.txt and study.png to --out. "
            "Instances are models/ files or names, or garnet:N:M[:SEED] (a seeded random "
            "MDP with N states and a random partition into M sets)."
        ),
    )
    p.add_argument(
        "models",
        metavar="MODEL",
        nargs="*",
        help=f"instances (default: {' '.join(DEFAULT_INSTANCES)})",
    )
    p.add_argument(
        "--formulations",
        nargs="+",
        metavar="NAME",
        default=list(DEFAULT_FORMULATIONS),
        help="paper names: ELP RLP SLP IB ALP UBLP LBLP (default: %(default)s)",
    )
    p.add_argument(
        "--solvers",
        nargs="+",
        metavar="SOLVER[:SET]",
        default=None,
        help="e.g. HIGHS (all option sets) HIGHS:ipm CLARABEL SCIPY "
        "(default: every installed LP solver)",
    )
    p.add_argument("--repeat", type=int, default=1, metavar="K", help="solves per combination")
    p.add_argument(
        "--accuracy",
        type=float,
        default=LP_CERT_RTOL,
        metavar="RTOL",
        help="requested accuracy relative to max|R|/(1-lambda): ok = certified error within "
        "it (default %(default)g)",
    )
    p.add_argument(
        "--out",
        default="compare-out",
        metavar="DIR",
        help="output folder, replaced as a whole when the study completes, with "
        "manifest.json (versions, commit, machine, date)",
    )
    p.add_argument(
        "--jobs", type=int, default=None, metavar="N", help="local processes (default: all cores)"
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on an existing Dask cluster, e.g. tcp://127.0.0.1:8786 (pip install "
        "'lpbounds[study]')",
    )
    p.set_defaults(func=run)


def _fmt(x: object, spec: str) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return format(x, spec)


#: (heading, justification); numbers and statuses never wrap, the solver column folds: the
#: table fits 100 columns (a 100-column terminal or a pipe) with the longest names.
_COLUMNS: tuple[tuple[str, str], ...] = (
    ("LP", "left"),
    ("solver", "left"),
    ("status", "left"),
    ("objective", "right"),
    ("cert.err", "right"),
    ("ok", "left"),
    ("max dev", "right"),
    ("resid", "right"),
    ("comp s", "right"),
    ("solve s", "right"),
    ("iter", "right"),
)


def _instance_table(instance: str, rows: Any) -> Table:
    """The summary rows of one instance, as a table at most 100 columns wide."""
    table = Table(
        title=Text(instance, "bold"),
        title_justify="left",
        box=box.SIMPLE_HEAD,
        padding=(0, 1, 0, 0),
        show_edge=False,
    )
    for col, just in _COLUMNS:
        # only the solver configuration folds: a status is read whole ("inaccurate")
        text = col == "solver"
        table.add_column(col, justify=just, no_wrap=not text, overflow="fold")  # type: ignore[arg-type]
    for row in rows.itertuples(index=False):
        table.add_row(
            Text(str(row.formulation)),  # Text: no markup or emoji (":100:" is an emoji code)
            Text(str(row.config)),
            Text(str(row.status)),
            _fmt(row.objective, ".8g"),
            _fmt(row.certified_error, ".1e"),
            "yes" if row.accurate and row.status == "optimal" else "[red]no[/red]",
            _fmt(row.max_deviation, ".1e"),
            _fmt(row.primal_residual, ".1e"),
            _fmt(row.compile_seconds, ".3f"),
            _fmt(row.solve_seconds, ".3f"),
            _fmt(row.iterations, ".0f"),
        )
    return table


#: What ``--out`` holds (an existing folder with anything else is refused, not replaced).
COMPARE_FILES: tuple[str, ...] = (
    "study.csv",
    "study.parquet",
    "summary.csv",
    "notes.txt",
    "study.png",
    MANIFEST,
)


def run(args: argparse.Namespace) -> int:
    from ..study import run_study, save_study

    check_output_dir(args.out, "--out", replaceable=COMPARE_FILES)
    with progress() as prog:
        task = prog.add_task("comparing solvers", total=None, status="")

        def cb(done: int, total: int) -> None:
            prog.update(task, total=total, completed=done, status=f"{done}/{total}")

        result = run_study(
            args.models or None,
            args.formulations,
            args.solvers,
            repeat=args.repeat,
            accuracy=args.accuracy,
            jobs=args.jobs,
            scheduler=args.scheduler,
            progress=cb,
        )
    if result.frame.empty:
        raise ValidationError("nothing was solved: " + ("; ".join(result.notes) or "no task"))
    summary = result.summary()
    console.print(
        Text(f"lpbounds compare: {len(result.frame)} solves in {result.seconds:.1f} s", "bold")
    )
    for instance, rows in summary.groupby("instance", sort=False):
        print_table(_instance_table(str(instance), rows))
    console.print(
        "cert.err = certified bound on max |LP values - exact optimum| from the returned "
        f"point alone; ok = status optimal and cert.err <= {args.accuracy:g} * "
        "max|R|/(1-lambda); max dev = max |LP values - exact fixed point| (exact DP); "
        "resid = primal residual; comp s = cvxpy's compile time"
    )
    for note in result.notes:
        log.warning("note: %s", note)
    target = AtomicDirectory(args.out, replaceable=COMPARE_FILES)
    with target as tmp:
        paths = save_study(result, tmp)
        out = target.commit({"instances": sorted(set(summary["instance"].astype(str)))})
    console.print(f"wrote {out}: " + ", ".join(p.name for p in paths.values()) + ", manifest.json")
    return 0
