"""Exact (rational) arithmetic against model size: its section of docs/benchmarks.md.

For random garnets (3 actions, 5 successors, discount 0.9) of growing size and the
packaged patrol-small (320 states, 176 partitions), each in a fresh process (so the peak
resident set is the measured step's own):

* ``solve_exact(mdp)`` (float) beside ``solve_exact(mdp, arithmetic="rational")`` (exact
  ``V*``: the float solve, exact policy iteration, the checker's verification);
* ``RLP(mdp, partition).solve("HIGHS")`` beside the same with ``arithmetic="rational"``
  (exact optimum, occupation-measure dual, verification), for a random partition of
  ``n / 4`` partitions (patrol-small: its own 176).

Reported: seconds, peak RSS, exact iterations, the bits of ``V*``'s common denominator,
and the float answer's exact error. ``EXACT_MAX_VARIABLES`` (lpbounds.tolerances) is
chosen from this table.

    python benchmarks/bench_exact.py [--sizes 10 25 50 100 200 400 600 800] [--no-docs]
"""

from __future__ import annotations

import argparse
import json

from _common import machine, run_isolated, today, write_section

VSTAR = """
import time, json, lpbounds as lb
from lpbounds.model.instances import load_instance
mdp = {model}
lb.solve_exact(lb.garnet(10, 2, 2, seed=0), arithmetic="rational")  # imports, first calls
t = time.perf_counter(); f = lb.solve_exact(mdp); tf = time.perf_counter() - t
t = time.perf_counter()
r = lb.solve_exact(mdp, arithmetic="rational", size_limit=10**6)
te = time.perf_counter() - t
err = r.rational_values.max_abs_error(f.values)
print(json.dumps({{"n": mdp.n_states, "float_s": tf, "exact_s": te, "iterations": r.iterations,
                  "bits": r.rational_values.denominator.bit_length(), "error": float(err)}}))
"""

RLP = """
import time, json, lpbounds as lb
from lpbounds.formulations import RLP
from lpbounds.model.instances import load_instance
mdp = {model}
part = {partition}
lb.solve_exact(lb.garnet(10, 2, 2, seed=0), arithmetic="rational")
RLP(lb.garnet(10, 2, 2, seed=0), lb.random_partition(10, 3)).solve("HIGHS")
form = RLP(mdp, part)
t = time.perf_counter(); f = form.solve("HIGHS"); tf = time.perf_counter() - t
t = time.perf_counter(); e = form.exact_optimum(f, size_limit=10**6); te = time.perf_counter() - t
print(json.dumps({{"m": part.n_partitions, "float_s": tf, "exact_s": te,
                  "bits": e.values.denominator.bit_length(), "error": float(e.error),
                  "inside": e.inside_bracket}}))
"""


def garnet(n: int) -> tuple[str, str]:
    return (
        f"lb.garnet({n}, 3, 5, 0.9, seed={n})",
        f"lb.random_partition({n}, {max(1, n // 4)}, seed=1)",
    )


PATROL = ("load_instance('patrol-small').mdp()", "load_instance('patrol-small').partition()")


def measure(sizes: list[int]) -> list[dict]:
    rows = []
    for label, (model, partition) in [*((f"garnet {n}", garnet(n)) for n in sizes),
                                      ("patrol-small", PATROL)]:  # fmt: skip
        v = run_isolated(VSTAR.format(model=model))
        r = run_isolated(RLP.format(model=model, partition=partition))
        rows.append({"label": label, "vstar": v, "rlp": r})
        print(json.dumps(rows[-1]), flush=True)
    return rows


def table(rows: list[dict]) -> str:
    head = (
        "| model | states | float V* | exact V* | peak | iterations | bits of V*'s "
        "denominator | float's exact error | partitions | HiGHS RLP | exact RLP | peak | "
        "RLP's exact error | bracket held |\n|" + "---|" * 14
    )
    lines = [head]
    for row in rows:
        v, r = row["vstar"], row["rlp"]
        lines.append(
            f"| {row['label']} | {v['n']} | {v['float_s']:.3f} s | {v['exact_s']:.2f} s | "
            f"{v['peak_rss_mb']:.0f} MB | {v['iterations']} | {v['bits']:,} | "
            f"{v['error']:.1e} | {r['m']} | {r['float_s']:.3f} s | {r['exact_s']:.2f} s | "
            f"{r['peak_rss_mb']:.0f} MB | {r['error']:.1e} | {r['inside']} |"
        )
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[10, 25, 50, 100, 200, 400, 600, 800])
    p.add_argument("--no-docs", action="store_true", help="do not write docs/benchmarks.md")
    args = p.parse_args()
    rows = measure(args.sizes)
    body = (
        "## Exact arithmetic: time and memory against size\n\n"
        f"`benchmarks/bench_exact.py`, {today()}; {machine()}.\n\n"
        "Garnets with 3 actions, 5 successors, discount 0.9; RLP on a random partition of "
        "n / 4 partitions; patrol-small with its own 176. Each cell is one run in a fresh "
        "process (peak: its resident set). *Exact V\\**: `solve_exact(mdp, "
        'arithmetic="rational")`, the float solve included; *exact RLP*: '
        "`RLP.exact_optimum` (fixed point, occupation-measure dual, the checker's "
        "verification) from HiGHS's point. *Iterations*: exact policy evaluations (1: the "
        "float policy was optimal). The exact error is the float answer's distance from "
        "the exact one.\n\n" + table(rows) + "\n"
    )
    print(body)
    if not args.no_docs:
        write_section("exact", body)


if __name__ == "__main__":
    main()
