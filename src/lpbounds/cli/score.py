"""``lpbounds score DIR SOLUTION``: measure a solver's answer against an export's exact
optimum and certify it (see :func:`lpbounds.studies.export.score_solution`)."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from rich.table import Table
from rich.text import Text

from ..tolerances import LP_CERT_RTOL
from ._common import check_output_file, positive_float, print_table


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "score",
        help="score a solution file against an lpbounds export (objective error, deviation, "
        "infeasibility, certified error)",
        description=(
            "Read SOLUTION (HiGHS' raw or sparse solution file, as highs --solution_file\n"
            "writes it; a .npy vector; or a text vector of one number per column) and\n"
            "measure it against the export DIR: objective error, max deviation from the\n"
            "exact optimum, primal infeasibility max (b - A x)+, and the certified error of\n"
            "the point (from the point alone, on the export's Bellman rows). Exit status 0\n"
            "whatever the score; 2 for a malformed or mismatched solution file."
        ),
        epilog="example:\n  lpbounds export garnet-small --formulation RLP --out lib/rlp\n"
        "  highs lib/rlp/lp.mps --solution_file sol.txt\n  lpbounds score lib/rlp sol.txt",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("export_dir", metavar="DIR", help="a folder written by lpbounds export")
    p.add_argument("solution", metavar="SOLUTION", help="the solution file to score")
    p.add_argument(
        "--accuracy",
        type=positive_float,
        default=LP_CERT_RTOL,
        metavar="RTOL",
        help="status optimal when the certified error is within RTOL * max|R|/(1-lambda) "
        "(default %(default)g)",
    )
    p.add_argument("--json", metavar="PATH", help="also write the score as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..outputs import run_metadata, write_text_atomic
    from ..studies.export import score_solution

    if args.json:
        check_output_file(args.json, "--json")
    score = score_solution(args.export_dir, args.solution, accuracy=args.accuracy)
    print_table(_table(score))
    if args.json:
        body = {**score.to_dict(), "export": str(args.export_dir), "environment": run_metadata()}
        write_text_atomic(args.json, json.dumps(body, indent=2) + "\n")
    return 0


def _num(x: Any, spec: str = ".3e") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return format(x, spec)


def _table(s: Any) -> Table:
    t = Table(title=Text(f"score of {s.solution}"), show_header=False)
    status = f", solver's model status {s.model_status!r}" if s.model_status else ""
    t.add_row("solution", Text(f"{s.format}, {s.columns:,} columns{status}"))
    t.add_row("objective c'x", _num(s.objective, ".15g"))
    if s.optimum_objective is not None:
        lo, hi = s.objective_bracket
        t.add_row(
            "exact optimum", f"{s.optimum_objective:.15g} (certified in [{lo:.15g}, {hi:.15g}])"
        )
        t.add_row("objective error", f"|c'x - c'x*| = {_num(s.objective_error)}")
        t.add_row(
            "max deviation",
            f"max |x - x*| = {_num(s.max_deviation)} at column "
            f"c{s.worst_column} (x* itself within {_num(s.optimum_error_bound)})",
        )
    else:
        t.add_row("exact optimum", "none in this export (see lp.json: optimum.reason)")
    where = f" at row r{s.worst_row}" if s.worst_row is not None else ""
    t.add_row("primal infeasibility", f"max (b - A x)+ = {_num(s.primal_infeasibility)}{where}")
    t.add_row(
        "certified error",
        f"max |x - v*| <= {_num(s.certified_error)} (relative "
        f"{_num(s.relative_error)}; Bellman residual up {_num(s.residual_up)}, down "
        f"{_num(s.residual_down)})",
    )
    within = "within" if s.status.value == "optimal" else "above"
    t.add_row(
        "status", f"{s.status.value}: certified error {within} {s.accuracy:g} * max|R|/(1-lambda)"
    )
    return t
