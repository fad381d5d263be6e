"""``lpbounds score DIR SOLUTION``: measure a solver's answer against an export's exact
optimum and certify it (see :func:`lpbounds.studies.export.score_solution`)."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from rich.table import Table
from rich.text import Text

from ..text import fmt_number, fmt_sci, fmt_within
from ..tolerances import LP_CERT_RTOL
from ._common import check_output_file, positive_float, print_table

#: The example of ``--help``: solved with highspy, which lpbounds installs (HiGHS' Python
#: package; no ``highs`` program comes with it), then scored.
EPILOG = (
    "example (HiGHS through highspy, installed with lpbounds; any LP solver's vector works):\n"
    "  lpbounds export garnet-small --formulation RLP --out lib/rlp\n"
    "  python -c \"import highspy; h = highspy.Highs(); h.readModel('lib/rlp/lp.mps'); "
    "h.run(); h.writeSolution('sol.txt', 0)\"\n"
    "  lpbounds score lib/rlp sol.txt\n"
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "score",
        help="score a solution file against an lpbounds export (objective error, deviation, "
        "infeasibility, certified error)",
        description=(
            "Read SOLUTION (a HiGHS solution file in its raw or sparse style, as highspy's\n"
            "Highs.writeSolution writes it; a .npy vector; or a text vector of one number per\n"
            "column) and measure it against the export DIR: objective error, max deviation\n"
            "from the exact optimum, primal infeasibility max (b - A x)+, and the certified\n"
            "error of the point (from the point alone, on the export's Bellman rows). Exit\n"
            "status 0 whatever the score; 2 for a malformed or mismatched solution file."
        ),
        epilog=EPILOG,
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
        f"(default {fmt_number(LP_CERT_RTOL)})",
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


def _num(x: Any, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return fmt_sci(x, digits)


def _table(s: Any) -> Table:
    t = Table(title=Text(f"score of {s.solution}"), show_header=False)
    status = f", the solver's model status: {s.model_status}" if s.model_status else ""
    t.add_row("solution", Text(f"{s.format}, {s.columns:,} columns{status}"))
    t.add_row("objective c'x", "-" if s.objective is None else f"{s.objective:.15g}")
    if s.optimum_objective is not None:
        lo, hi = s.objective_bracket
        t.add_row(
            "exact optimum",
            f"{s.optimum_objective:.15g} (certified {fmt_within(lo, hi)})",
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
        "status",
        f"{s.status.value}: certified error {within} {fmt_number(s.accuracy)} * max|R|/(1-lambda)",
    )
    return t
