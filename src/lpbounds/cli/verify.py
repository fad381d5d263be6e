"""``lpbounds verify [MODEL]``: theorem verdicts (holds / violated / inconclusive) per solver.

Exit status 1 only when a claim is *violated* (the certified intervals prove it false);
``--strict`` also fails on *inconclusive*. See :mod:`lpbounds.studies.verify`."""

from __future__ import annotations

import argparse

from rich import box
from rich.markup import escape
from rich.table import Table

from ..tolerances import LP_COMPARE_RTOL
from ._common import console, print_table, progress


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "verify",
        help="check Lemma 1, Theorems 1-2, Lemma 2 and Remark 2 across LP solvers",
        description=(
            "Solve ELP, RLP, SLP(mu-bar), IB (L=1..5), LLP and ALP with each solver and "
            "compare certified intervals with the exact fixed points (value iteration): each "
            "claim holds, is violated (the intervals prove it false) or is inconclusive (not "
            "accurate enough to decide). Exits 1 only on a violated claim (--strict: also on "
            "an inconclusive one)."
        ),
    )
    p.add_argument(
        "model",
        metavar="MODEL",
        nargs="?",
        default=None,
        help="instance file or name in models/ (default: every model with a partition "
        "and at most --max-states states)",
    )
    p.add_argument(
        "--solvers",
        nargs="+",
        metavar="SOLVER",
        default=None,
        help="LP solvers by cvxpy name, e.g. HIGHS CLARABEL SCIPY (default: those of the three "
        "installed here; a missing solver is refused with its install command, an unknown name "
        "with the list of installed ones)",
    )
    p.add_argument("--random", type=int, default=5, metavar="N", help="random instances (5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random instances and costs")
    p.add_argument("--costs", type=int, default=3, metavar="K", help="random costs per LP (3)")
    p.add_argument(
        "--rtol",
        type=float,
        default=LP_COMPARE_RTOL,
        help="requested accuracy relative to max|R|/(1-lambda): a claim holds when the "
        f"certified intervals allow no larger difference ({LP_COMPARE_RTOL:g})",
    )
    p.add_argument("--strict", action="store_true", help="also exit 1 when a claim is inconclusive")
    p.add_argument("--max-states", type=int, default=10_000, help="size cap of default models")
    p.add_argument("--json", metavar="PATH", help="also write the records as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..formulations import resolve_solver
    from ..studies.verify import (
        default_solvers,
        exit_status,
        model_instances,
        random_instances,
        verify_instance,
        verify_remark2,
        write_json,
    )

    solvers = [resolve_solver(s) for s in (args.solvers or default_solvers())]
    insts, skipped = model_instances(
        None if args.model is None else [args.model], max_states=args.max_states
    )
    insts += random_instances(args.random, args.seed)
    records = []
    with progress() as prog:
        task = prog.add_task("verifying", total=len(insts) + 1, status="")
        for inst in insts:
            prog.update(task, description=f"verifying {inst.name}")
            records += verify_instance(
                inst,
                solvers,
                n_costs=args.costs,
                seed=args.seed,
                rtol=args.rtol,
                progress=lambda msg: prog.update(task, status=msg),
            )
            prog.advance(task)
        prog.update(task, description="Remark 2 (soft aggregation)")
        records += verify_remark2(solvers, seed=args.seed, rtol=args.rtol)
        prog.advance(task)
    for table in _records_tables(records):
        print_table(table)
    print_table(_summary_table(records))
    if skipped:
        console.print(
            f"skipped (more than {args.max_states} states or size unknown; name one to "
            f"verify it): {', '.join(skipped)}"
        )
    if args.json:
        write_json(records, args.json)
    return exit_status(records, strict=args.strict)


_STYLE = {"holds": "green", "inconclusive": "yellow", "violated": "bold red"}


def _verdict(v: str) -> str:
    return f"[{_STYLE[v]}]{v}[/]"


def _records_tables(records: list[dict]) -> list[Table]:
    """The records, one table per instance, each at most 100 columns wide (the claim and
    how it was checked fold; the numbers never do)."""
    counts = {v: sum(r["verdict"] == v for r in records) for v in _STYLE}
    tables: list[Table] = []
    by_instance: dict[str, list[dict]] = {}
    for r in records:
        by_instance.setdefault(r["instance"], []).append(r)
    for i, (instance, rows) in enumerate(by_instance.items()):
        title = f"{instance}"
        if i == 0:
            title = (
                f"lpbounds verify: {counts['holds']} hold, {counts['inconclusive']} "
                f"inconclusive, {counts['violated']} violated\n\n{instance}"
            )
        table = Table(
            title=title,
            title_justify="left",
            box=box.SIMPLE_HEAD,
            show_edge=False,
            padding=(0, 1, 0, 0),
        )
        for col, just in (
            ("check", "left"),
            ("solver", "left"),
            ("verdict", "left"),
            ("width", "right"),
            ("dev.", "right"),
            ("acc.", "right"),
            ("claim: how it was checked", "left"),
        ):
            table.add_column(
                col,
                justify=just,  # type: ignore[arg-type]
                no_wrap=not col.startswith("claim"),
                overflow="fold",
            )
        for r in rows:
            table.add_row(*_record_cells(r))
        tables.append(table)
    return tables


def _record_cells(r: dict) -> tuple[str, ...]:
    detail = r["detail"]
    if r["verdict"] == "violated":
        lo, hi = r["lp_interval"], r["exact_interval"]
        detail = (
            f"entry {r['index']}: [{lo[0]:.10g}, {lo[1]:.10g}] vs exact "
            f"[{hi[0]:.10g}, {hi[1]:.10g}]; {detail}"
        )
    return (
        r["check"],
        r["solver"],
        _verdict(r["verdict"]),
        f"{r['width']:.1e}",
        f"{r['deviation']:.1e}",
        f"{r['accuracy']:.1e}",
        f"{escape(r['claim'])}: [dim]{escape(detail)}[/dim]",
    )


def _summary_table(records: list[dict]) -> Table:
    from ..studies.verify import summarize

    summary = Table(
        title="summary: verdicts of each check and solver (worst record)",
        title_justify="left",
        box=box.SIMPLE_HEAD,
        show_edge=False,
        padding=(0, 1, 0, 0),
    )
    for col in ("check", "solver", "holds", "inconclusive", "violated", "worst", "width", "acc."):
        summary.add_column(col, justify="left" if col in ("check", "solver", "worst") else "right")
    for row in summarize(records):
        summary.add_row(
            row["check"],
            row["solver"],
            str(row["holds"]),
            str(row["inconclusive"]),
            str(row["violated"]),
            _verdict(row["verdict"]),
            f"{row['width']:.2e}",
            f"{row['accuracy']:.2e}",
        )
    return summary
