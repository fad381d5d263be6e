"""``lpbounds compare [MODELS...]``: a solver comparison study (see :mod:`lpbounds.study`)."""

from __future__ import annotations

import argparse
import math

from rich.console import Console
from rich.table import Table
from rich.text import Text

from ..errors import ValidationError
from ..study import DEFAULT_FORMULATIONS, DEFAULT_INSTANCES, run_study, save_study
from ..tolerances import LP_CERT_RTOL
from ._common import console, err_console, progress


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
    p.add_argument("--out", default="compare-out", metavar="DIR", help="output folder")
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


def run(args: argparse.Namespace) -> int:
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
    table = Table(title=f"lpbounds compare ({len(result.frame)} solves, {result.seconds:.1f} s)")
    for col in (
        "instance",
        "form.",
        "solver",
        "status",
        "objective",
        "cert. error",
        "ok",
        "max dev.",
        "residual",
        "compile s",
        "solve s",
        "iter.",
    ):
        table.add_column(
            col, justify="left" if col in ("instance", "solver", "status") else "right"
        )
    for row in summary.itertuples(index=False):
        table.add_row(
            Text(str(row.instance)),  # Text: no markup or emoji (":100:" is an emoji code)
            Text(str(row.formulation)),
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
    # a table this wide is unreadable wrapped at 80 columns: widen it when piped
    out = console if console.is_terminal else Console(width=max(console.width, 150))
    out.print(table)
    out.print(
        "cert. error = certified bound on max |LP values - exact optimum| from the returned "
        f"point alone; ok = status optimal and cert. error <= {args.accuracy:g} * "
        "max|R|/(1-lambda); max dev. = max |LP values - exact fixed point| (exact DP)"
    )
    for note in result.notes:
        err_console.print(Text(f"note: {note}"))
    paths = save_study(result, args.out)
    out.print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0
