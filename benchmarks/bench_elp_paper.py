"""The ELP of the paper's instance solved: its section of docs/benchmarks.md.

``models/patrol-paper.toml``: 2,048,000 states, one row per allowed (state, action), about
4.65M rows. HiGHS' interior point method did not finish it in 600 s (18 iterations, 3.9 GB,
still 0.043 from V*). The documented route: ``ELP(mdp).solve(backend="highspy",
warm_start="policy")`` -- exact DP gives the optimal policy, HiGHS' simplex method starts
from that policy's basis and only has to confirm it. Measured in this process: the time of
each step, the peak resident set size, the iterations, the certified error of the returned
point (:func:`lpbounds.certification`), lpbounds' dual residual and gap from the returned duals.

Usage: ``python benchmarks/bench_elp_paper.py [--model patrol-paper] [--min-free-gb 10]``.
Needs about 5 GB; it refuses to start with less than ``--min-free-gb`` available.
"""

from __future__ import annotations

import argparse
import os
import resource
import time
from pathlib import Path

from _common import machine, today, write_section

from lpbounds import load_instance
from lpbounds.formulations import ELP


def _available_gb() -> float:
    for line in Path("/proc/meminfo").read_text().splitlines():
        if line.startswith("MemAvailable:"):
            return int(line.split()[1]) / 2**20
    return float("nan")


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run(model: str) -> dict[str, float | str | int]:
    """Build and solve the ELP of ``model`` by the policy route; every figure measured."""
    out: dict[str, float | str | int] = {}
    t0 = time.perf_counter()
    mdp = load_instance(model).mdp()
    out["mdp_s"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    form = ELP(mdp)
    out["elp_s"] = time.perf_counter() - t1
    out["rows"], out["cols"], out["nnz"] = *form.A.shape, form.A.nnz
    out["rss_built_mb"] = _peak_mb()
    t2 = time.perf_counter()
    res = form.solve(backend="highspy", warm_start="policy")
    out["solve_s"] = time.perf_counter() - t2
    out["total_s"] = time.perf_counter() - t0
    out["dp_s"] = float(res.extra["warm_start_seconds"])
    out["pass_s"] = res.compile_seconds
    out["highs_s"] = res.solve_seconds
    out["judge_s"] = out["solve_s"] - out["dp_s"] - out["pass_s"] - out["highs_s"]
    out["iterations"] = int(res.iterations or 0)
    out["status"] = str(res.status)
    out["error_bound"] = res.error_bound
    out["relative_error"] = res.relative_error
    out["dual_residual"] = res.dual_residual
    out["gap"] = res.gap
    out["objective"] = res.objective
    lo, hi = res.objective_bracket or (float("nan"), float("nan"))
    out["bracket_width"] = hi - lo
    out["peak_mb"] = _peak_mb()
    return out


def report(r: dict, load_before: tuple, load_after: tuple, model: str) -> str:
    return "\n".join(
        [
            "## ELP of the paper's instance (benchmarks/bench_elp_paper.py)",
            "",
            f"Run {today()} on {machine()}. Load average (1, 5, 15 min) before "
            f"({', '.join(f'{x:.1f}' for x in load_before)}), after "
            f"({', '.join(f'{x:.1f}' for x in load_after)}) on 2 cores. One run, one process.",
            "",
            f"`models/{model}.toml`: {r['cols']:,} states, {r['rows']:,} rows, {r['nnz']:,} "
            "nonzeros. `ELP(mdp).solve(backend='highspy', warm_start='policy')`: "
            f"**{r['status']} in {r['total_s']:.1f} s** end to end (model and LP built, "
            f"solved, certified), peak RSS **{r['peak_mb'] / 1024:.2f} GB**, certified error "
            f"**{r['error_bound']:.1e}** (relative {r['relative_error']:.1e}).",
            "",
            "| step | seconds |",
            "|---|---:|",
            f"| MDP build (`load_instance(...).mdp()`) | {r['mdp_s']:.1f} |",
            f"| ELP rows and (A, b, c) | {r['elp_s']:.1f} |",
            f"| exact DP for the policy and its basis (`policy_basis`) | {r['dp_s']:.1f} |",
            f"| LP passed to HiGHS (array interface), basis set | {r['pass_s']:.1f} |",
            f"| HiGHS simplex from the basis ({r['iterations']} iterations) | {r['highs_s']:.1f} |",
            f"| certificate, residuals, duals mapped to (state, action) | {r['judge_s']:.1f} |",
            "",
            f"Dual residual `||A'y - c||_inf` = {r['dual_residual']:.1e}, gap `|c'x - b'y|` = "
            f"{r['gap']:.1e} (objective {r['objective']:.10g}), certified objective bracket "
            f"width {r['bracket_width']:.1e}; RSS with the model and the LP built "
            f"{r['rss_built_mb'] / 1024:.2f} GB.",
            "",
            "What this proves. The point: `lower_values <= V* <= upper_values` entry by entry "
            "from `lpbounds.certification` (Bellman residual / (1 - lambda), rounding included), "
            "whatever HiGHS claimed; the certified error above is that bracket's width. The "
            "duals: HiGHS' row duals at the final basis are the optimal policy's discounted "
            "occupation measure, `y >= 0`; lpbounds recomputes `A'y - c` and `c'x - b'y` from "
            "them, so `b'y` is a lower bound on the optimum up to the dual residual (used in "
            "`objective_bracket`). HiGHS' own optimality test (primal and dual feasibility "
            "at the basis, its tolerances) is its claim, not lpbounds': the status is decided "
            "by the certificate. Without the warm start, HiGHS' IPM had not finished after "
            "600 s.",
            "",
        ]
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="patrol-paper")
    ap.add_argument("--min-free-gb", type=float, default=10.0)
    args = ap.parse_args()
    free = _available_gb()
    if free < args.min_free_gb:
        raise SystemExit(
            f"only {free:.1f} GB available (< {args.min_free_gb} GB): not starting; retry later"
        )
    load_before = os.getloadavg()
    r = run(args.model)
    body = report(r, load_before, os.getloadavg(), args.model)
    write_section("elp-paper", body)
    print(body)


if __name__ == "__main__":
    main()
