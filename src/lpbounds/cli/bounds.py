"""``lpbounds bounds MODEL``: LBLP and UBLP of a patrol instance, without enumerating states.

Computes, from the ``M`` partitions alone (:mod:`lpbounds.patrol.bounds`):

* UBLP (Theorem 4) and LBLP (Theorem 3): each as a solver-free fixed point (its exact LP
  optimum, Fact 1 in :mod:`lpbounds.rows.system`) and as an LP with cvxpy (``--solver``),
  cross-checked against the fixed point. The LP is solved by default up to
  ``--lp-max-partitions`` partitions (50,000: the paper's M = 8,900 takes seconds, the
  8-station M = 207,928 takes HiGHS many minutes); ``--lp`` forces it, ``--no-lp`` skips it;
* the policy-free gap ``v*(i) - w*(i)`` per partition: for every state ``x`` of ``S_i``,
  ``w*(i) <= V*(x) <= v*(i)``, so the gap bounds how far either bound is from ``V*``;
* Lemma 3's ``|T(i, u)|`` against the construction (where the Gamma cap changes it).
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from typing import Any

from rich.table import Table

from ..errors import SolverError, ValidationError
from ..outputs import run_metadata, write_text_atomic
from ..text import fmt_bool, fmt_list, fmt_sci, fmt_seconds
from ._common import (
    add_model_argument,
    check_output_file,
    console,
    nonnegative_int,
    progress,
)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``bounds`` command to ``sub`` (what ``ArgumentParser.add_subparsers`` returns)."""
    p = sub.add_parser(
        "bounds",
        help="UBLP/LBLP bounds of a patrol instance from its partitions (no state enumeration)",
    )
    add_model_argument(p, default="patrol-paper")
    p.add_argument("--solver", default="HIGHS", help="LP solver (HIGHS, CLARABEL, ...)")
    p.add_argument("--no-lp", action="store_true", help="fixed points only (no LP solve)")
    p.add_argument("--lp", action="store_true", help="solve the LPs whatever the size")
    p.add_argument(
        "--lp-max-partitions",
        type=nonnegative_int,
        default=50_000,
        help="above this M the LPs are skipped unless --lp (default 50,000)",
    )
    p.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    p.set_defaults(func=run)


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run(args: argparse.Namespace) -> int:
    from ..model.instances import load_instance
    from ..patrol.bounds import analyse_bounds
    from ..patrol.instance import params_from_instance

    if args.lp and args.no_lp:
        raise ValidationError("--lp and --no-lp contradict each other")
    inst = load_instance(args.model)
    params = params_from_instance(inst)
    if args.json:
        check_output_file(args.json, "--json")
    out: dict[str, Any] = {
        "instance": inst.name,
        "n_states": params.n_states,
        "n_partitions": params.n_partitions,
        "allow_empty_loiter": params.allow_empty_loiter,
    }
    t_all = time.perf_counter()
    solve_lp = not args.no_lp and (args.lp or params.n_partitions <= args.lp_max_partitions)
    out["lp_solved"] = solve_lp
    if not solve_lp:
        out["lp_note"] = (
            f"LP not solved (M = {params.n_partitions:,} > --lp-max-partitions "
            f"{args.lp_max_partitions:,}, or --no-lp): the fixed points are the LPs' exact optima"
        )
    with progress() as prog:
        steps = 4 + (2 if solve_lp else 0)
        task = prog.add_task(f"bounds of {inst.name}", total=steps, status="")
        analysis = analyse_bounds(
            params,
            solver=args.solver,
            solve_lp=solve_lp,
            step=lambda text: prog.update(task, description=text),
            advance=lambda: prog.advance(task),
        )
    out.update(analysis.formulations)
    out["lemma3"] = analysis.lemma3
    out["gap"] = analysis.gap
    out["seconds"] = {**analysis.seconds, "total": time.perf_counter() - t_all}
    out["peak_rss_mb"] = _peak_mb()
    _print(out, params)
    if args.json:
        write_text_atomic(args.json, json.dumps({**out, "environment": run_metadata()}, indent=2))
    bad = analysis.lp_disagreements
    if analysis.negative_count:
        console.print("[red]the lower bound exceeds the upper bound somewhere[/red]")
        return 1
    if bad:
        raise SolverError(f"LP optimum differs from the fixed point for {fmt_list(bad, 'and')}")
    return 0


def _step(key: str) -> str:
    """A step's key in words: ``ublp_fixed_point`` -> ``UBLP fixed point``."""
    if key.startswith("lemma"):
        return f"Lemma {key[5:]}"
    words = key.split("_")
    return " ".join(w.upper() if w in ("ublp", "lblp", "lp") else w for w in words)


def _print(out: dict[str, Any], params: Any) -> None:

    t = Table(title=f"LBLP / UBLP bounds of {out['instance']}", show_header=False)
    t.add_row("|S| (eq. 27)", f"{out['n_states']:,}")
    t.add_row("M (eq. 28)", f"{out['n_partitions']:,}")
    t.add_row("allow_empty_loiter", fmt_bool(out["allow_empty_loiter"], "true", "false"))
    for name in ("UBLP", "LBLP"):
        e = out[name]
        fp = e["fixed_point"]
        t.add_row(
            f"{name} fixed point",
            f"{e['n_rows']:,} rows, {fp['iterations']:,} iterations, residual "
            f"{fmt_sci(fp['residual'])}, {fmt_seconds(fp['seconds'])}",
        )
        if "lp" in e:
            lp = e["lp"]
            t.add_row(
                f"{name} LP ({lp['solver']})",
                f"{lp['status']}, {fmt_seconds(lp['seconds'])}, max |LP - fixed point| "
                f"{fmt_sci(lp['max_abs_diff_fixed_point'])} (tolerance {fmt_sci(lp['tolerance'])})",
            )
    g = out["gap"]
    t.add_row(
        "gap v* - w* per partition",
        f"min {fmt_sci(g['min'], 4)}, mean {fmt_sci(g['mean'], 4)}, median "
        f"{fmt_sci(g['median'], 4)}, max {fmt_sci(g['max'], 4)}",
    )
    lem = out["lemma3"]
    where = (
        f" (all at taubar = {fmt_list(lem['differing_taubar_values'], 'or')}, the Gamma cap)"
        if lem["pairs_differing"]
        else ""
    )
    t.add_row(
        "Lemma 3 |T(i,u)|",
        f"{lem['pairs_differing']:,} of {lem['pairs']:,} pairs differ from the paper's "
        f"formula{where}",
    )
    t.add_row("time", ", ".join(f"{_step(k)} {fmt_seconds(v)}" for k, v in out["seconds"].items()))
    t.add_row("peak memory", f"{out['peak_rss_mb']:.0f} MB")
    if "lp_note" in out:
        t.add_row("LP", out["lp_note"])
    console.print(t)
    w = Table(title=f"largest gaps v* - w* (of {out['n_partitions']:,} partitions)")
    for col in ("partition", "l", "w", "d", "A", "taubar", "lower w*", "upper v*", "gap"):
        w.add_column(col, justify="right")
    for row in g["worst"]:
        k = row["key"]
        a = "".join(str(k[f"A{j + 1}"]) for j in range(params.m))
        w.add_row(
            str(row["partition"]),
            str(k["l"]),
            f"{k['w']:+d}",
            str(k["d"]),
            a,
            str(k["taubar"]),
            f"{row['lower']:.6f}",
            f"{row['upper']:.6f}",
            fmt_sci(row["gap"], 4),
        )
    console.print(w)
