"""``lpbounds reproduce [MODEL]``: the paper's patrol results in one command.

Writes ``summary.json``, ``values.npz``, ``report.md``, Figures 2-7 and ``manifest.json``
into ``--out`` (see :mod:`lpbounds.patrol.reproduce`) and prints the headline numbers.
The model, the arguments and ``--out`` are checked before any computation; ``--out``
appears complete or not at all (a previous output stays until the new one is complete).
"""

from __future__ import annotations

import argparse

from rich.table import Table

from .._defaults import DEFAULT_MODEL, DEFAULT_OUT, DEFAULT_SEEDS
from ._common import add_model_argument, console, nonnegative_int, positive_int, progress


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``reproduce`` command to ``sub`` (what ``ArgumentParser.add_subparsers`` returns)."""
    p = sub.add_parser(
        "reproduce",
        help="reproduce the paper's patrol results (Sections 4-6): report, figures, data",
    )
    add_model_argument(p, default=DEFAULT_MODEL)
    p.add_argument(
        "--out",
        default=DEFAULT_OUT,
        help=f"output folder, replaced as a whole when the run completes (default: {DEFAULT_OUT})",
    )
    p.add_argument(
        "--seeds",
        type=nonnegative_int,
        nargs="+",
        default=list(DEFAULT_SEEDS),
        metavar="SEED",
        help="Monte Carlo seeds, one alert sequence each (default: 1 2 3 4 5)",
    )
    p.add_argument(
        "--steps",
        type=positive_int,
        default=60_000,
        help="Monte Carlo steps per seed (default: 60,000)",
    )
    p.add_argument(
        "--solver", default="HIGHS", help="LP solver for UBLP/LBLP: HIGHS (default) or CLARABEL"
    )
    p.add_argument(
        "--general",
        choices=("aggregate", "residual"),
        default="residual",
        help="Theorems 3-4 check against the full MDP's RLP/NLP: a certified bound from one "
        "sweep of their operators at UBLP's/LBLP's optima (residual, default), or build "
        "their aggregated rows and solve them (aggregate: measured, ~1 GB more and slower)",
    )
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.add_argument(
        "--beyond",
        action="store_true",
        help="also go beyond the paper's size: exact V* at 5 and 6 stations (matrix-free; at 6 "
        "stations ~14 GB and ~10 min on 2 cores, see --beyond-sizes), pi_s by Monte Carlo at 6 "
        "and 8 stations, and a 'Beyond the paper' report section with beyond.json and a figure",
    )
    p.add_argument(
        "--beyond-cache",
        default="out/beyond",
        metavar="DIR",
        help="where --beyond keeps the 5- and 6-station results between runs, reused for "
        "the same parameters (default: out/beyond)",
    )
    p.add_argument(
        "--beyond-sizes",
        type=int,
        nargs="+",
        choices=(5, 6),
        default=[5, 6],
        metavar="M",
        help="the numbers of stations --beyond solves exactly: 5, 6 or both (default: 5 and 6)",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..patrol.reproduce import reproduce

    with progress(transient=False) as prog:
        rep = reproduce(
            args.model,
            args.out,
            seeds=args.seeds,
            n_steps=args.steps,
            solver=args.solver,
            general=args.general,
            figures=not args.no_figures,
            progress=prog,
            beyond=args.beyond,
            beyond_cache=args.beyond_cache,
            beyond_sizes=args.beyond_sizes,
        )
    s = rep.result
    t = Table(title=f"reproduction of {s.instance}", show_header=False)
    t.add_row("|S|, M", f"{s.n_states:,}, {s.n_partitions:,}")
    v = s.vstar
    t.add_row("V*", f"{v.iterations} iterations, residual {v.residual:.1e}")
    t.add_row("Theorem 4 |RLP - UBLP|", f"{s.theorem4_max_abs_diff:.2e}")
    t.add_row("Theorem 3 |NLP - LBLP|", f"{s.theorem3_max_abs_diff:.2e}")
    c = s.claims
    t.add_row(
        "Claim 2 violations",
        f"{c.violations:,} of {c.pairs:,} pairs "
        f"({c.violations_same_alert_status} with the same alert status); "
        f"partitions {c.partition_violations} of {c.partition_pairs:,}",
    )
    sw = s.sandwich
    cert = (sw.certified_lower_margin, sw.certified_upper_margin)
    t.add_row(
        "sandwich margins",
        f"lower {sw.lower_margin:.3e}, upper {sw.upper_margin:.3e}; "
        + (
            f"certified (LP brackets and V*'s error bound) {cert[0]:.3e}, {cert[1]:.3e}"
            if cert[0] is not None and cert[1] is not None
            else "not certified (an LP returned no point)"
        ),
    )
    po = s.policy
    t.add_row(
        "pi_s",
        f"differs on {100 * po.differs_fraction:.2f} % of states, "
        f"max V* - V_sub = {po.max_vstar_minus_vsub:.2e}",
    )
    for key, label in (("pi_star", "pi*"), ("pi_s", "pi_s")):
        m = s.monte_carlo.policy(key)
        p = s.paper_table1[key]
        t.add_row(
            f"Monte Carlo {label}",
            f"loiters {m.mean_loiters:.2f} (paper {p['mean_loiters']}); delay counted to "
            f"the first loiter / to its end: mean {m.mean_delay:.2f} / "
            f"{m.mean_delay_plus_one:.2f} (paper {p['mean_delay']}), worst {m.worst_delay} / "
            f"{m.worst_delay_plus_one} (paper {p['worst_delay']})",
        )
    t.add_row("total", f"{s.seconds_total:.1f} s")
    t.add_row("written", str(rep.out))
    console.print(t)
    return 0
