"""``lpbounds export MODEL --formulation NAME --out DIR``: a Bellman-row LP with its exact
optimum, for solvers outside lpbounds (see :mod:`lpbounds.studies.export`)."""

from __future__ import annotations

import argparse
from typing import Any

from rich.table import Table
from rich.text import Text

from ..errors import ValidationError
from ..text import fmt_seconds
from ._common import add_model_argument, check_output_dir, print_table, progress

EXAMPLES = """\
examples (sizes: rows x columns; times on 2 cores):
  lpbounds export garnet:100:10:1 --formulation RLP --out lib/rlp-tiny   # 300 x 10
  lpbounds export garnet-small --formulation ELP --format lp --out lib/elp-small   # 900 x 300
  lpbounds export patrol-small --formulation UBLP --out lib/ublp-small   # 394 x 176
  lpbounds export patrol-paper --formulation UBLP --out lib/ublp-paper   # 20,456 x 8,900
  lpbounds export patrol-m8 --formulation UBLP --out lib/ublp-m8   # 489,232 x 207,928, 20 s
  lpbounds export garnet-paper-scale --formulation RLP --out lib/rlp-paper   # 6.1M x 10,000
  lpbounds export patrol-paper --formulation ELP --out lib/elp-paper   # 4.65M x 2,048,000
  lpbounds score lib/rlp-tiny solution.sol   # score a solver's answer (see lpbounds score -h)

Writes DIR/lp.mps (or lp.lp; columns c0.., rows r0.., written by HiGHS), optimum.npy
(the exact optimum: numpy float64, one entry per column), rows.npz (the Bellman rows, the
cost, what each column stands for), lp.json (sizes, optimal objective and its certified
bracket, certificate, naming, provenance) and manifest.json. docs/export.md lists the
sizes and times.
"""


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``export`` command to ``sub`` (what ``ArgumentParser.add_subparsers`` returns)."""
    p = sub.add_parser(
        "export",
        help="write a Bellman-row LP (MPS/LP) with its exact optimum, for any LP solver",
        description=(
            "Write the LP min c'x s.t. A x >= b of a formulation (through HiGHS' writer),\n"
            "its exact optimum (the solver-free fixed point, certified) and a JSON sidecar\n"
            "with sizes, certificate, naming and provenance. Score a solver's answer with\n"
            "lpbounds score DIR SOLUTION."
        ),
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_model_argument(p)
    p.add_argument(
        "--formulation",
        required=True,
        metavar="NAME",
        help="ELP, RLP, SLP (uniform mu), IB (L = 2), UBLP or LBLP (patrol models)",
    )
    p.add_argument(
        "--partition",
        metavar="SPEC",
        default=None,
        help="replace the model's partition: random:M[:SEED] (a sink kept in a set of its "
        "own) or a .npy file of labels (RLP, SLP, IB)",
    )
    p.add_argument("--format", dest="fmt", default="mps", metavar="mps|lp", help="default mps")
    p.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="output folder, replaced as a whole when the export completes (new, empty or "
        "an earlier export)",
    )
    p.set_defaults(func=run)


def _command(args: argparse.Namespace) -> str:
    """The command line that reproduces this export (recorded in the provenance)."""
    from ..studies.export import command_line

    argv = ["lpbounds", "export", args.model, "--formulation", args.formulation]
    if args.partition is not None:
        argv += ["--partition", args.partition]
    return command_line([*argv, "--format", args.fmt, "--out", args.out])


#: The option of each argument of :func:`lpbounds.studies.export.export_lp` that the
#: command line takes from the user
_FLAGS = {"formulation": "--formulation", "partition": "--partition", "fmt": "--format"}


def run(args: argparse.Namespace) -> int:
    from ..studies.export import EXPORT_FILES, ExportArgumentError, export_lp

    check_output_dir(args.out, "--out", replaceable=EXPORT_FILES)
    with progress() as prog:
        task = prog.add_task(f"export of {args.model}", total=None, status="")

        def step(text: str) -> None:
            prog.update(task, description=text)

        try:
            result = export_lp(
                args.model,
                args.formulation,
                args.out,
                partition=args.partition,
                fmt=args.fmt,
                command=_command(args),
                step=step,
            )
        except ExportArgumentError as exc:
            raise ValidationError(exc.message(_FLAGS[exc.argument])) from exc
    print_table(_table(result))
    return 0


def _table(result: Any) -> Table:
    s = result.sidecar
    sizes = s["sizes"]
    prov = s["provenance"]
    t = Table(
        title=Text(f"{s['formulation']} of {prov['instance']} -> {result.out}"), show_header=False
    )
    t.add_row(
        "LP",
        f"{sizes['rows']:,} rows x {sizes['columns']:,} columns, "
        f"{sizes['nonzeros']:,} nonzeros ({s['model_file']})",
    )
    opt = s["optimum"]
    if opt.get("exact"):
        cert = opt["certificate"]
        lo, hi = opt["objective_bracket"]
        t.add_row(
            "optimal objective", f"{opt['objective']:.15g}  (certified in [{lo:.15g}, {hi:.15g}])"
        )
        t.add_row(
            "optimum",
            f"{opt['solution_file']}: within {cert['error_bound']:.2e} of the "
            f"exact optimum entrywise (certificate width {cert['width']:.2e})",
        )
    else:
        t.add_row("optimum", f"none: {opt['reason']}")
    t.add_row(
        "time",
        ", ".join(f"{k.replace('_', ' ')} {fmt_seconds(v)}" for k, v in result.seconds.items()),
    )
    return t
