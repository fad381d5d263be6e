"""``lpbounds verify [MODEL]``: check the paper's LP results per solver against exact values."""

from __future__ import annotations

import argparse

from rich.console import Console
from rich.table import Table

from ..formulations import resolve_solver
from ..tolerances import LP_COMPARE_RTOL
from ..verify import (
    default_solvers,
    model_instances,
    random_instances,
    summarize,
    verify_instance,
    verify_remark2,
    write_json,
)
from ._common import console, progress


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "verify",
        help="check Lemma 1, Theorems 1-2, Lemma 2 and Remark 2 across LP solvers",
        description=(
            "Solve ELP, RLP, SLP(mu-bar), IB (L=1..5), LLP and ALP with each solver and "
            "compare with the exact fixed points (value iteration). Exits 1 if a check fails."
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
        help=f"LP solvers (default: {', '.join(default_solvers())})",
    )
    p.add_argument("--random", type=int, default=5, metavar="N", help="random instances (5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random instances and costs")
    p.add_argument("--costs", type=int, default=3, metavar="K", help="random costs per LP (3)")
    p.add_argument(
        "--rtol",
        type=float,
        default=LP_COMPARE_RTOL,
        help=f"relative tolerance of the LP comparisons ({LP_COMPARE_RTOL:g})",
    )
    p.add_argument("--max-states", type=int, default=10_000, help="size cap of default models")
    p.add_argument("--json", metavar="PATH", help="also write the records as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
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
    n_fail = sum(not r["pass"] for r in records)
    table = Table(title=f"lpbounds verify: {len(records) - n_fail}/{len(records)} checks pass")
    for col, just in (
        ("check", "left"),
        ("instance", "left"),
        ("solver", "left"),
        ("max deviation", "right"),
        ("tolerance", "right"),
        ("pass", "center"),
        ("detail", "left"),
    ):
        table.add_column(col, justify=just, no_wrap=col != "detail")  # type: ignore[arg-type]
    for r in records:
        table.add_row(
            r["check"],
            r["instance"],
            r["solver"],
            f"{r['max_deviation']:.2e}",
            f"{r['tolerance']:.2e}",
            "[green]yes[/green]" if r["pass"] else "[bold red]NO[/bold red]",
            r["detail"],
        )
    # a file or pipe gets full-width lines instead of 80 columns of wrapped details
    out = console if console.is_terminal else Console(width=220)
    out.print(table)
    summary = Table(title="summary: the worst record of each check and solver")
    for col in ("check", "solver", "passed", "worst deviation", "its tolerance"):
        summary.add_column(col, justify="left" if col in ("check", "solver") else "right")
    for row in summarize(records):
        ok = row["passed"] == row["records"]
        summary.add_row(
            row["check"],
            row["solver"],
            f"{'[green]' if ok else '[bold red]'}{row['passed']}/{row['records']}[/]",
            f"{row['max_deviation']:.2e}",
            f"{row['tolerance']:.2e}",
        )
    out.print(summary)
    if skipped:
        out.print(
            f"skipped (more than {args.max_states} states or size unknown; name one to "
            f"verify it): {', '.join(skipped)}"
        )
    if args.json:
        write_json(records, args.json)
    return 1 if n_fail else 0
