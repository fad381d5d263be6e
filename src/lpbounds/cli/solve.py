"""``lpbounds solve MODEL``: solve an instance exactly and print value statistics."""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np
from rich.table import Table

from ..dp import solve_exact
from ..instances import load_instance
from ..outputs import write_text_atomic
from ._common import (
    add_model_argument,
    check_output_file,
    console,
    positive_float,
    positive_int,
    progress,
)


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("solve", help="solve an instance exactly (VI / PI / MPI)")
    add_model_argument(p)
    p.add_argument("--method", choices=("mpi", "vi", "pi"), default="mpi")
    p.add_argument("--tol", type=positive_float, default=None, help="residual tolerance (absolute)")
    p.add_argument("--max-iter", type=positive_int, default=100_000)
    p.add_argument("--json", metavar="PATH", help="also write the statistics as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    inst = load_instance(args.model)
    if args.json:
        check_output_file(args.json, "--json")
    t0 = time.perf_counter()
    with progress() as prog:
        task = prog.add_task(f"building {inst.name}", total=None, status="")
        mdp = inst.mdp()
        build = time.perf_counter() - t0
        prog.update(task, description=f"solving {inst.name} ({args.method})")

        def cb(it: int, res: float) -> None:
            prog.update(task, completed=it, status=f"iteration {it}  residual {res:.2e}")

        result = solve_exact(mdp, args.method, tol=args.tol, max_iter=args.max_iter, callback=cb)
    v = result.values
    stats = {
        "instance": inst.name,
        "n_states": mdp.n_states,
        "n_actions": mdp.n_actions,
        "n_outcomes": mdp.n_outcomes,
        "discount": mdp.discount,
        "method": result.method,
        "iterations": result.iterations,
        "sweeps": result.sweeps,
        "residual": result.residual,
        "tol": result.tol,
        "error_bound": result.error_bound,
        "build_seconds": build,
        "solve_seconds": result.seconds,
        "value_min": float(v.min()),
        "value_mean": float(v.mean()),
        "value_max": float(v.max()),
    }
    table = Table(title=f"exact solve of {inst.name}", show_header=False)
    for k, val in stats.items():
        if isinstance(val, float):
            text = f"{val:.6g}" if math.isfinite(val) else str(val)
        else:
            text = str(val)
        table.add_row(k, text)
    action_counts = np.bincount(result.policy, minlength=mdp.n_actions)
    table.add_row(
        "policy (states per action)",
        ", ".join(f"{mdp.action_names[a]}: {c}" for a, c in enumerate(action_counts)),
    )
    console.print(table)
    if args.json:
        write_text_atomic(args.json, json.dumps(stats, indent=2))
    return 0
