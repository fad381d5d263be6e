"""Foundation benchmark: a random MDP of the paper's shape (2,048,000 x 3 x 5).

Times construction and the exact solve to residual <= 1e-10 * max|R| / (1 - discount)
for each method, each in a fresh process (so peak memory is that step's own), and
writes the `foundation` section of docs/benchmarks.md.

    python benchmarks/bench_dp.py [--repeat 3] [--n 2048000]
"""

from __future__ import annotations

import argparse
import statistics

from _common import machine, run_isolated, today, write_section

BUILD = """
import time, json, lpbounds as lb
t = time.perf_counter()
mdp = lb.garnet({n}, 3, 5, 0.9, seed=2048, shared_probabilities=True)
t = time.perf_counter() - t
arrays_mb = (mdp.successors.nbytes + mdp.rewards.nbytes + mdp.allowed.nbytes) / 2**20
print(json.dumps({{"seconds": t, "arrays_mb": arrays_mb}}))
"""

SOLVE = """
import time, json, lpbounds as lb
lb.solve_exact(lb.garnet(50, 3, 5, 0.9, shared_probabilities=True), "{method}")  # compile
mdp = lb.garnet({n}, 3, 5, 0.9, seed=2048, shared_probabilities=True)
t = time.perf_counter()
r = lb.solve_exact(mdp, "{method}")
t = time.perf_counter() - t
print(json.dumps({{"seconds": t, "iterations": r.iterations, "sweeps": r.sweeps,
                  "residual": r.residual, "tol": r.tol}}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--n", type=int, default=2_048_000)
    args = ap.parse_args()
    n = args.n
    builds = [run_isolated(BUILD.format(n=n)) for _ in range(args.repeat)]
    rows = []
    best = (float("inf"), "")
    base_rss = statistics.median(b["peak_rss_mb"] for b in builds)
    for method in ("mpi", "vi", "pi"):
        runs = [run_isolated(SOLVE.format(n=n, method=method)) for _ in range(args.repeat)]
        med = statistics.median(r["seconds"] for r in runs)
        best = min(best, (med, method))
        r0 = runs[0]
        peak = max(r["peak_rss_mb"] for r in runs)
        rows.append(
            f"| {method} | {med:.2f} | {r0['iterations']} | {r0['sweeps']} | "
            f"{r0['residual']:.2e} (tol {r0['tol']:.2e}) | {peak:.0f} | {peak - base_rss:.0f} |"
        )
        print(rows[-1], flush=True)
    body = (
        f"""## Foundation: exact DP on a random MDP of the paper's shape

Machine: {machine()}. Date: {today()}. Repetitions: {args.repeat} (median time).
Model: `garnet({n}, 3 actions, 5 outcomes, discount 0.9, seed 2048, shared probabilities)`;
its arrays take {builds[0]["arrays_mb"]:.0f} MB; construction takes
{statistics.median(b["seconds"] for b in builds):.2f} s (peak RSS of that process
{base_rss:.0f} MB). Solve to residual <= 1e-10 max|R|/(1-discount) (targets: <= 2 s,
<= 1 GB above the model's own arrays).

| method | seconds | improvement steps | sweeps | residual | peak RSS (MB) | above build (MB) |
|---|---|---|---|---|---|---|
"""
        + "\n".join(rows)
        + f"""

Target <= 2 s: {"met" if best[0] <= 2 else "**missed**"} (fastest: {best[1]}, {best[0]:.2f} s).
A random MDP has no locality: each sweep is ~30 M random reads of a 16 MB vector, so the
solve is bound by memory latency (about 6-7 ns per read with both cores), not by
arithmetic; the sweep counts are what the algorithms control.
"""
    )
    write_section("foundation", body)


if __name__ == "__main__":
    main()
