"""``lpbounds solve MODEL``: solve an instance exactly and print value statistics.

``--out DIR`` keeps the solution (:data:`SOLUTION_FILES`, complete or absent, see
:mod:`lpbounds.outputs`):

* ``solution.npz``: ``values`` (V*, as computed), ``policy`` (an action index per state,
  greedy with respect to ``values``), ``lower`` and ``upper``: the certificate, a bracket
  ``lower <= V* <= upper`` computed from ``values`` alone in floating point
  (:func:`lpbounds.certification.certificate.certify` on the MDP's Bellman rows); for a model with
  ``sense = "min"`` or an added sink also ``user_values``, ``user_policy``,
  ``user_lower``, ``user_upper`` in the user's terms;
* ``solution.json``: the statistics, the certificate's numbers (residuals, rounding
  margin, contraction modulus, error bound, width), the action names and how the run was
  made (:func:`lpbounds.outputs.run_metadata`);
* ``manifest.json``: the files with their SHA-256 and the same metadata.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from rich.table import Table

from ..outputs import AtomicDirectory, run_metadata, write_text_atomic
from ..text import fmt_bracket, fmt_counts, fmt_list, fmt_number, fmt_sci, fmt_seconds
from ..tolerances import DP_RTOL
from ._common import (
    add_model_argument,
    check_output_dir,
    check_output_file,
    console,
    positive_float,
    positive_int,
    progress,
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("solve", help="solve an instance exactly (VI / PI / MPI)")
    add_model_argument(p)
    p.add_argument(
        "--method",
        choices=tuple(METHOD_NAMES),
        default="mpi",
        help=f"{fmt_list(METHOD_NAMES.values(), 'or')} (default: mpi)",
    )
    p.add_argument(
        "--tol",
        type=positive_float,
        default=None,
        help=f"residual tolerance ||TV - V||, absolute (default {fmt_number(DP_RTOL)} * max|R|)",
    )
    p.add_argument(
        "--max-iter", type=positive_int, default=100_000, help="iteration limit (default 100,000)"
    )
    p.add_argument("--json", metavar="PATH", help="also write the statistics as JSON")
    p.add_argument(
        "--out",
        metavar="DIR",
        help="keep the solution: solution.npz (V*, policy, certified lower/upper), "
        "solution.json and manifest.json; DIR is replaced as a whole",
    )
    p.set_defaults(func=run)


#: What ``--out`` writes (an existing DIR holding anything else is refused).
SOLUTION_FILES: tuple[str, ...] = ("solution.npz", "solution.json", "manifest.json")


def run(args: argparse.Namespace) -> int:
    from ..dp import solve_exact
    from ..model.instances import load_instance

    inst = load_instance(args.model)
    if args.json:
        check_output_file(args.json, "--json")
    if args.out:
        check_output_dir(args.out, "--out", replaceable=SOLUTION_FILES)
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
        # where the statistics of V* itself lie: the certified bracket of each
        **certified_statistics(result.lower_values, result.upper_values),
    }
    console.print(_table(stats, mdp, result))
    if args.json:
        write_text_atomic(args.json, json.dumps({**stats, "environment": run_metadata()}, indent=2))
    if args.out:
        out = write_solution(args.out, mdp, result, stats)
        console.print(f"wrote {out}: {fmt_list(SOLUTION_FILES, 'and')}")
    return 0


#: The methods by name, as the table says them.
METHOD_NAMES = {
    "mpi": "modified policy iteration (mpi)",
    "vi": "value iteration (vi)",
    "pi": "policy iteration (pi)",
    "ipi": "inexact policy iteration (ipi)",
}


def certified_statistics(lower: Any, upper: Any) -> dict[str, list[float]]:
    """The brackets on ``min V*``, ``mean V*`` and ``max V*`` from a certified bracket
    ``lower <= V* <= upper`` (state by state): ``vstar_min``, ``vstar_mean``,
    ``vstar_max``, each ``[lo, hi]``. The mean's ends are rounded outward (a sum in
    floating point may be off by an ulp either way)."""
    import math

    import numpy as np

    lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    n = lo.size
    mean_lo = math.nextafter(math.fsum(lo.tolist()) / n, -math.inf)
    mean_hi = math.nextafter(math.fsum(hi.tolist()) / n, math.inf)
    return {
        "vstar_min": [float(lo.min()), float(hi.min())],
        "vstar_mean": [mean_lo, mean_hi],
        "vstar_max": [float(lo.max()), float(hi.max())],
    }


def fmt_statistic(lo: float, hi: float) -> str:
    """A number known to lie in ``[lo, hi]``, shown so that what it says is true: the
    4-digit number both ends round to (so every value of the bracket rounds to it), else
    the bracket itself rounded outward (``min [0, 5.9e-10]``, not ``min 2.937e-10`` for a
    V* whose least value is 0)."""
    one = fmt_number(lo)
    return one if one == fmt_number(hi) else fmt_bracket(lo, hi)


def _table(stats: dict[str, Any], mdp: Any, result: Any) -> Table:
    """The statistics as a person reads them (``--json`` keeps the machine's names)."""
    import numpy as np

    t = Table(title=f"exact solve of {stats['instance']}", show_header=False)
    t.add_row(
        "model",
        f"{fmt_number(stats['n_states'])} states, {fmt_number(stats['n_actions'])} actions, "
        f"{fmt_number(stats['n_outcomes'])} outcomes, discount {fmt_number(stats['discount'])}",
    )
    t.add_row("method", METHOD_NAMES.get(stats["method"], stats["method"]))
    t.add_row(
        "iterations", f"{fmt_number(stats['iterations'])} ({fmt_number(stats['sweeps'])} sweeps)"
    )
    t.add_row(
        "Bellman residual",
        f"||TV - V|| = {fmt_sci(stats['residual'])} (tolerance {fmt_sci(stats['tol'])})",
    )
    t.add_row("error bound", f"||V - V*|| <= {fmt_sci(stats['error_bound'])}")
    t.add_row(
        "V* (certified)",
        ", ".join(f"{k} {fmt_statistic(*stats[f'vstar_{k}'])}" for k in ("min", "mean", "max")),
    )
    counts = np.bincount(result.policy, minlength=mdp.n_actions)
    t.add_row(
        "policy (states per action)",
        fmt_counts({mdp.action_names[a]: int(c) for a, c in enumerate(counts)}),
    )
    t.add_row(
        "time",
        f"build {fmt_seconds(stats['build_seconds'])}, solve {fmt_seconds(stats['solve_seconds'])}",
    )
    return t


def write_solution(out: str, mdp: Any, result: Any, stats: dict[str, Any]) -> Path:
    """Write ``--out``: the solution with its certificate (see the module docstring)."""
    import numpy as np

    from ..certification.certificate import certify
    from ..dp import exact_rows

    cert = certify(exact_rows(mdp), result.values)
    arrays = {
        "values": result.values,
        "policy": np.asarray(result.policy, dtype=np.int64),
        "lower": cert.lower,
        "upper": cert.upper,
    }
    if mdp.sense == "min" or mdp.sink:
        lo, hi = mdp.user_bounds(cert.lower, cert.upper)
        arrays.update(
            user_values=mdp.user_values(result.values),
            user_policy=mdp.user_policy(result.policy),
            user_lower=lo,
            user_upper=hi,
        )
    summary = {
        **stats,
        "sense": mdp.sense,
        "sink": mdp.sink,
        "action_names": list(mdp.action_names),
        "certificate": {
            "what": "lower <= V* <= upper entrywise, certified from values alone "
            "(lpbounds.certification.certificate.certify on the Bellman rows, rounding included)",
            "residual_up": cert.residual_up,
            "residual_down": cert.residual_down,
            "margin": cert.margin,
            "modulus": cert.modulus,
            "error_bound": cert.error_bound,
            "width": cert.width,
            "reward_absmax": cert.reward_absmax,
        },
        "arrays": {k: {"shape": list(v.shape), "dtype": str(v.dtype)} for k, v in arrays.items()},
        "environment": run_metadata(),
    }
    target = AtomicDirectory(out, replaceable=SOLUTION_FILES)
    with target as tmp:
        np.savez(tmp / "solution.npz", **arrays)
        (tmp / "solution.json").write_text(json.dumps(summary, indent=2) + "\n")
        return target.commit({"instance": stats["instance"]})
