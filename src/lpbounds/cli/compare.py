"""``lpbounds compare [MODELS...]``: a solver comparison study.

See :mod:`lpbounds.studies.compare`.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from typing import Any

from rich import box
from rich.table import Table
from rich.text import Text

from .._defaults import DEFAULT_FORMULATIONS, DEFAULT_INSTANCES, DEFAULT_SHIFTS
from ..errors import ValidationError
from ..outputs import MANIFEST, AtomicDirectory
from ..text import fmt_list, fmt_number, fmt_sci, fmt_seconds
from ..tolerances import LP_CERT_RTOL
from ._common import check_output_dir, console, positive_float, print_table, progress

log = logging.getLogger("lpbounds")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compare",
        help="solve every (instance, formulation, solver) and tabulate accuracy and time",
        description=(
            "Solve every (instance, formulation, solver option set) and write to --out: "
            "study.csv (one row per solve; study.parquet with pyarrow), summary.csv (per "
            "problem), solvers.csv (per solver: status counts, shifted geometric means of "
            "time), profile_time.png and profile_accuracy.png (Dolan-More performance "
            "profiles, failures unsolved), study.png, notes.txt and metadata.json (versions, "
            "machine, command line). Instances are models/ files or names, or "
            "garnet:N:M[:SEED] (a seeded random MDP with N states and a random partition into "
            "M sets). Solvers: every LP-capable solver cvxpy finds installed."
        ),
    )
    p.add_argument(
        "models",
        metavar="MODEL",
        nargs="*",
        help=f"instances (default: {', '.join(DEFAULT_INSTANCES)}); lpbounds models lists the "
        "named ones",
    )
    p.add_argument(
        "--instances",
        nargs="+",
        metavar="MODEL",
        default=None,
        help="the instances, as an option: names, files or garnet:N:M[:SEED], separated "
        "by spaces or commas (forest,gridworld,queue); the same as the MODEL arguments, "
        "give one or the other",
    )
    p.add_argument(
        "--formulations",
        nargs="+",
        metavar="NAME",
        default=list(DEFAULT_FORMULATIONS),
        help="paper names: ELP RLP SLP IB ALP UBLP LBLP "
        f"(default: {', '.join(DEFAULT_FORMULATIONS)})",
    )
    p.add_argument(
        "--solvers",
        nargs="+",
        metavar="SOLVER[:SET]",
        default=None,
        help="e.g. HIGHS (all option sets) HIGHS:ipm CLARABEL SCIPY "
        "(default: every installed LP solver)",
    )
    p.add_argument(
        "--repeat", type=int, default=1, metavar="K", help="solves per combination (default 1)"
    )
    p.add_argument(
        "--accuracy",
        type=float,
        default=LP_CERT_RTOL,
        metavar="RTOL",
        help="requested accuracy relative to max|R|/(1-lambda): ok = certified error within "
        f"it (default {fmt_number(LP_CERT_RTOL)})",
    )
    p.add_argument(
        "--time-limit",
        type=positive_float,
        default=None,
        metavar="SECONDS",
        help="per solve, in each solver's own option; a solve that uses it up has status "
        "time_limit and keeps its point and certified error (default: none)",
    )
    p.add_argument(
        "--shift",
        type=nonnegative_float,
        nargs="+",
        default=list(DEFAULT_SHIFTS),
        metavar="SECONDS",
        help="shifts of the shifted geometric means of time (default: "
        f"{fmt_list(DEFAULT_SHIFTS, 'and')}: Mittelmann's 10 s, and 0.01 s "
        "for sub-second solves)",
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
        help="run through Dask: an existing cluster (tcp://127.0.0.1:8786) or a local "
        "scheduler (synchronous, threads, processes); pip install 'lpbounds[study]'",
    )
    p.set_defaults(func=run)


def nonnegative_float(text: str) -> float:
    """An argparse type: a finite number >= 0 (a shift may be 0: the plain geometric mean)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0; got {text}")
    return value


def _fmt(x: object, spec: str) -> str:
    """A table cell: ``-`` for none or a non-finite number; an ``.Ne`` spec as
    :func:`~lpbounds.text.fmt_sci` writes it (``5.7e-11``, ``0``; not ``0.0e+00``)."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    if spec.endswith("e"):
        return fmt_sci(x, int(spec[1:-1]) + 1)
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


#: Statuses whose row note is printed under the table (why it failed, what the limit kept).
_NOTED = ("infeasible", "unbounded", "solver_error", "time_limit")


def _instance_table(instance: str, rows: Any) -> tuple[Table, list[str]]:
    """The summary rows of one instance, as a table at most 100 columns wide, and the
    footnotes of its failed and time-limited rows (``[k] LP solver: note``)."""
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
    notes: list[str] = []
    for row in rows.itertuples(index=False):
        status = str(row.status)
        if any(s in status.split(",") for s in _NOTED) and str(row.note or "") not in ("", "nan"):
            notes.append(f"[{len(notes) + 1}] {row.formulation} {row.config}: {row.note}")
            status += f" [{len(notes)}]"
        table.add_row(
            Text(str(row.formulation)),  # Text: no markup or emoji (":100:" is an emoji code)
            Text(str(row.config)),
            Text(status),
            _fmt(row.objective, ".8g"),
            _fmt(row.certified_error, ".1e"),
            "yes" if row.accurate and row.status == "optimal" else "[red]no[/red]",
            _fmt(row.max_deviation, ".1e"),
            _fmt(row.primal_residual, ".1e"),
            _fmt(row.compile_seconds, ".3f"),
            _fmt(row.solve_seconds, ".3f"),
            _fmt(row.iterations, ".0f"),
        )
    return table, notes


def _solver_table(summary: Any, shifts: list[float]) -> Table:
    """Per solver configuration: status counts and shifted geometric means (100 columns)."""
    from ..studies.report import sgm_column

    table = Table(
        title=Text("per solver (solved = certified within the accuracy)", "bold"),
        title_justify="left",
        box=box.SIMPLE_HEAD,
        padding=(0, 1, 0, 0),
        show_edge=False,
    )
    table.add_column("solver", no_wrap=False, overflow="fold")
    table.add_column("backend", no_wrap=False, overflow="fold", max_width=26)
    for col in ("solved", "opt", "inacc", "t.lim", "lim", "fail"):
        table.add_column(col, justify="right", no_wrap=True)
    for shift in shifts:
        table.add_column(f"sgm {shift:g}s", justify="right", no_wrap=True)
    for r in summary.to_dict("records"):
        table.add_row(
            Text(str(r["config"])),
            Text(str(r["backend"])),
            f"{r['solved']}/{r['problems']}",
            str(r["optimal"]),
            str(r["inaccurate"]),
            str(r["time_limit"]),
            str(r["other_limit"]),
            str(r["failed"]),
            *(_fmt(r[sgm_column(s)], ".4f") for s in shifts),
        )
    return table


#: What ``--out`` holds (an existing folder with anything else is refused, not replaced).
COMPARE_FILES: tuple[str, ...] = (
    "study.csv",
    "study.parquet",
    "summary.csv",
    "solvers.csv",
    "notes.txt",
    "study.png",
    "profile_time.png",
    "profile_accuracy.png",
    "metadata.json",
    MANIFEST,
)


def instance_list(given: list[str] | None) -> list[str]:
    """The instances of ``--instances`` or the MODEL arguments: each item split at commas
    (``forest,gridworld queue`` is three); an empty item (``forest,,queue``) is refused."""
    out: list[str] = []
    for item in given or []:
        parts = [p.strip() for p in item.split(",")]
        if not all(parts):
            raise ValidationError(
                f"an empty instance name in {item!r} (instances are separated by commas)"
            )
        out += parts
    return out


def run(args: argparse.Namespace) -> int:
    from ..studies.compare import check_scheduler, run_study, save_study

    if args.models and args.instances:
        raise ValidationError(
            "instances given twice: as MODEL arguments and with --instances; give one or the other"
        )
    instances = instance_list(args.instances or args.models) or None
    scheduler = check_scheduler(args.scheduler)  # before --out is touched
    check_output_dir(args.out, "--out", replaceable=COMPARE_FILES)
    with progress() as prog:
        task = prog.add_task("comparing solvers", total=None, status="")

        def cb(done: int, total: int) -> None:
            prog.update(task, total=total, completed=done, status=f"{done}/{total}")

        result = run_study(
            instances,
            args.formulations,
            args.solvers,
            repeat=args.repeat,
            accuracy=args.accuracy,
            time_limit=args.time_limit,
            jobs=args.jobs,
            scheduler=scheduler,
            progress=cb,
        )
    if result.frame.empty:
        raise ValidationError("nothing was solved: " + ("; ".join(result.notes) or "no task"))
    summary = result.summary()
    console.print(
        Text(
            f"lpbounds compare: {len(result.frame):,} solves in {fmt_seconds(result.seconds)}",
            "bold",
        )
    )
    for instance, rows in summary.groupby("instance", sort=False):
        table, footnotes = _instance_table(str(instance), rows)
        print_table(table)
        for line in footnotes:
            console.print(Text(line))
    console.print(
        "cert.err = certified bound on max |LP values - exact optimum| from the returned "
        f"point alone; ok = status optimal and cert.err <= {fmt_number(args.accuracy)} * "
        "max|R|/(1-lambda); max dev = max |LP values - exact fixed point| (exact DP); "
        "resid = primal residual; comp s = cvxpy's compile time"
    )
    shifts = list(dict.fromkeys(args.shift))
    print_table(_solver_table(result.solver_summary(shifts), shifts))
    charged = (
        f"the time limit ({fmt_seconds(args.time_limit)})"
        if args.time_limit
        else "the longest solve"
    )
    console.print(
        "counts are solves: opt(imal), inacc(urate), t.lim (time limit), lim (other limits), "
        f"fail (no point); sgm = shifted geometric mean of solve time in s, an unsolved "
        f"problem charged {charged}; profiles in profile_time.png and profile_accuracy.png"
    )
    for note in result.notes:
        log.warning("%s", note)
    if result.not_installed:  # optional: said with --verbose only (their list is in notes.txt)
        log.info(
            "not installed here, so not compared (optional LP solvers; install commands in "
            "notes.txt): %s",
            fmt_list(result.not_installed, "and"),
        )
    target = AtomicDirectory(args.out, replaceable=COMPARE_FILES)
    with target as tmp:
        paths = save_study(
            result,
            tmp,
            shifts=shifts,
            command_line=["lpbounds", *getattr(args, "argv", sys.argv[1:])],
        )
        out = target.commit({"instances": sorted(set(summary["instance"].astype(str)))})
    names = [p.name for p in paths.values()] + [MANIFEST]
    console.print(f"wrote {out}: {fmt_list(names, 'and')}")
    return 0
