"""Benchmark of ``lpbounds reproduce`` on the paper's instance (targets: <= 20 s, <= 1.5 GB).

Runs the whole reproduction (``lpbounds.patrol.reproduce.reproduce``) in a fresh process,
``--repeat`` times, and writes the ``reproduce`` section of docs/benchmarks.md: the total
time, where it goes (seconds per step, median over the repetitions), the peak resident
memory after each step, and the load average of the machine (it is shared, so a loaded
machine shows up there, not as a hidden slowdown).

    python benchmarks/bench_reproduce.py [--repeat 1] [--general residual|aggregate]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile

from _common import machine, run_isolated, today, write_section

CODE = """
import json, time
from lpbounds.patrol.reproduce import reproduce
t = time.perf_counter()
rep = reproduce({model!r}, {out!r}, general={general!r}, seeds={seeds!r}, n_steps={steps})
wall = time.perf_counter() - t
s = rep.summary
print(json.dumps({{
    "wall": wall, "seconds": s["seconds"], "peak_after": s["peak_rss_mb"],
    "cpu": s["cpu_seconds"],
    "lp": {{k: [v["compile_seconds"], v["solve_seconds"], v["fixed_point_seconds"]]
           for k, v in s["bounds"].items()}},
    "n_states": s["n_states"], "n_partitions": s["n_partitions"],
    "vstar_iterations": s["vstar"]["iterations"],
}}))
"""

TARGET_SECONDS = 20.0
TARGET_MB = 1536.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--model", default="models/patrol-paper.toml")
    ap.add_argument("--general", choices=("residual", "aggregate"), default="residual")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--steps", type=int, default=60_000)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    load_before = os.getloadavg()
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeat):
            runs.append(
                run_isolated(
                    CODE.format(
                        model=args.model,
                        out=tmp,
                        general=args.general,
                        seeds=tuple(args.seeds),
                        steps=args.steps,
                    )
                )
            )
    load_after = os.getloadavg()
    wall = statistics.median(r["wall"] for r in runs)
    peak = max(r["peak_rss_mb"] for r in runs)
    steps = list(runs[0]["seconds"])
    med = {k: statistics.median(r["seconds"][k] for r in runs) for k in steps}
    peak_after = {k: max(r["peak_after"][k] for r in runs) for k in steps}
    cpu = {k: statistics.median(r["cpu"][k] for r in runs) for k in steps}
    total = sum(med.values())
    r0 = runs[0]
    lines = [
        "## Reproduction of the paper (`lpbounds reproduce`)",
        "",
        f"Machine: {machine()}. Date: {today()}. Load average (1, 5, 15 min) before "
        f"{tuple(round(x, 1) for x in load_before)}, after "
        f"{tuple(round(x, 1) for x in load_after)} on {os.cpu_count()} cores (shared "
        "machine: a load above the core count slows every step).",
        "",
        f"Instance `{args.model}`: |S| = {r0['n_states']:,}, M = {r0['n_partitions']:,}; "
        f"Theorems 3-4 check `--general {args.general}`; Monte Carlo {len(args.seeds)} seeds "
        f"x {args.steps:,} steps; {args.repeat} run(s) in fresh processes (the kernels are C, "
        "built at install: nothing compiles), medians.",
        "",
        f"- total: **{wall:.1f} s** (target <= {TARGET_SECONDS:.0f} s: "
        f"{'met' if wall <= TARGET_SECONDS else 'NOT met'}); peak resident memory "
        f"**{peak:.0f} MB** (target <= {TARGET_MB:.0f} MB: "
        f"{'met' if peak <= TARGET_MB else 'NOT met'}).",
        "",
        f"- CPU time (user + system, all threads): **{sum(cpu.values()):.1f} s**; on an "
        "otherwise idle machine the wall time is at most about this.",
        "",
        "| step | wall seconds | share | CPU seconds | peak RSS after the step (MB) |",
        "|---|---|---|---|---|",
    ]
    for k in steps:
        lines.append(
            f"| {k} | {med[k]:.2f} | {100 * med[k] / total:.0f} % | {cpu[k]:.2f} "
            f"| {peak_after[k]:.0f} |"
        )
    lp = r0["lp"]
    lines += [
        "",
        "Inside `bounds` (first run): "
        + "; ".join(
            f"{k.upper()} cvxpy compile {v[0]:.2f} s, HiGHS solve {v[1]:.2f} s, "
            f"fixed point {v[2]:.2f} s"
            for k, v in lp.items()
        )
        + ".",
    ]
    lines += [
        "",
        "Steps: `build` the MDP and partition (model); `vstar` exact V* (MPI, "
        f"{r0['vstar_iterations']} improvements); `bounds` UBLP and LBLP with cvxpy + HiGHS "
        "(IPM with crossover) and their fixed points; `general` the full MDP's RLP/NLP check; "
        "`claims` Claims 1-2 on all ordered pairs; `sandwich` the bounds, pi_s and V_sub "
        "(iterative evaluation); `monte_carlo`; `figures`; `write` the files.",
    ]
    body = "\n".join(lines)
    print(body)
    if not args.no_write:
        write_section("reproduce", body)


if __name__ == "__main__":
    main()
