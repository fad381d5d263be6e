"""pi_s beyond exact DP: Monte Carlo value and Table 1 at 4, 6 and 8 stations.

For each model, in a fresh process: the partition bounds (LBLP ``w*``, UBLP ``v*``, fixed
points with certified errors), the Monte Carlo value of ``pi_s`` (greedy for ``w*``,
acted out on the fly) from :func:`lpbounds.patrol.greedy_mc.default_starts` (the ``m``
empty stations and 12 seeded random states; 4,000 paths each with the control variate,
horizon with truncation error <= 1e-6, Student's t 95 %), and Table 1 (5 seeds x 60,000
steps, as at 4 stations), with wall and CPU times and the process's peak RSS. On the
paper's instance the exact ``V_pis`` (``evaluate_policy`` on its MDP) checks the
intervals. Then, at 8 stations, the estimator with and without the control variate side
by side (alternating, same paths): CPU time and variance.

Writes the ``greedy-mc`` section of docs/benchmarks.md and benchmarks/results/greedy_mc.json.

    python benchmarks/bench_greedy_mc.py [--paths 4000] [--models ...] [--reps 3]

The paper's 4-station instance runs too: its Table 1 row must match the MDP-array run of
``lpbounds reproduce`` (pi_s: 4.70 loiters, mean delay 4.69, worst 14).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

from _common import machine, run_isolated, today, write_section

HERE = Path(__file__).resolve().parent
M6_PAPER = HERE.parent / "src" / "lpbounds" / "models" / "patrol-m6-paper.toml"
M6 = str(M6_PAPER) if M6_PAPER.exists() else "patrol-m6"
RESULTS = HERE / "results" / "greedy_mc.json"

RUN = """
import json, time
import numpy as np
from lpbounds.model.instances import load_instance
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol import greedy_mc as g
from lpbounds.patrol import PatrolParams
small = PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4)  # compile on a small model first
t = time.perf_counter()
b0 = g.partition_bounds(small)
g.greedy_value_mc(small, b0.lower, b0.upper, starts=3, paths=10, horizon=5)
g.greedy_table1(small, b0.lower, steps=100, seeds=[1])
compile_s = time.perf_counter() - t
params = params_from_instance(load_instance({model!r}))
b = g.partition_bounds(params)
cpu = time.process_time()
est = g.greedy_value_mc(params, b.lower, b.upper, paths={paths}, upper_error=b.upper_error)
mc_cpu = time.process_time() - cpu
exact = None
if params.n_states <= 3_000_000:  # the paper's instance: the exact V_pis to check against
    from lpbounds import evaluate_policy, greedy_policy
    from lpbounds.patrol import PatrolModel
    pm = PatrolModel(params)
    mdp = pm.mdp()
    pol = greedy_policy(mdp, b.lower[pm.partition().labels])
    v = evaluate_policy(mdp, pol, method="iterative").values[est.starts]
    exact = {{"values": v.tolist(),
             "covered": int(((est.ci_low <= v) & (v <= est.ci_high)).sum()),
             "max_abs_error": float(np.abs(est.mean - v).max())}}
    del mdp, pm
t = time.perf_counter()
tab = g.greedy_table1(params, b.lower)
tab_s = time.perf_counter() - t
s = tab.statistics
name = {model!r}.rsplit("/", 1)[-1].removesuffix(".toml")
print(json.dumps({{
    "model": name, "n_states": params.n_states, "n_partitions": params.n_partitions,
    "m": params.m, "compile_s": compile_s, "bounds_s": b.seconds,
    "lower_error": b.lower_error, "upper_error": b.upper_error,
    "mc": est.summary(), "mc_md": est.markdown(), "mc_cpu_s": mc_cpu, "exact": exact,
    "table1_s": tab_s, "table1": tab.summary(), "table1_md": g.table1_markdown({{name: tab}}),
}}))
"""

CONTROL = """
import json, time
import numpy as np
from lpbounds.model.instances import load_instance
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol import greedy_mc as g
params = params_from_instance(load_instance("patrol-m8"))
b = g.partition_bounds(params)
g.greedy_value_mc(params, b.lower, b.upper, starts=8, paths=10, horizon=5)  # compile
out = {{"on": [], "off": []}}
std = {{}}
for rep in range({reps}):
    for key in ("on", "off"):
        c = time.process_time()
        est = g.greedy_value_mc(params, b.lower, b.upper, starts=8, paths={paths},
                                control_variate=key == "on")
        out[key].append(time.process_time() - c)
        std[key] = est.std.tolist()
print(json.dumps({{"cpu": out, "std": std, "steps": 8 * {paths} * est.horizon}}))
"""


def _fmt_table(runs: list[dict]) -> str:
    lines = [
        "| model | m | states | bounds (s) | MC: starts x paths x H | MC wall (s) "
        "| us/step wall | us/step CPU | Table 1: 5 x 60,000 steps (s) | peak RSS (MB) |",
        "|---|---:|---:|---:|---|---:|---:|---:|---:|---:|",
    ]
    for r in runs:
        mc = r["mc"]
        steps = mc["n_starts"] * mc["paths"] * mc["horizon"]
        lines.append(
            f"| {r['model']} | {r['m']} | {r['n_states']:,} | {r['bounds_s']:.1f} "
            f"| {mc['n_starts']} x {mc['paths']:,} x {mc['horizon']} | {mc['seconds']:.1f} "
            f"| {1e6 * mc['seconds'] / steps:.2f} | {1e6 * r['mc_cpu_s'] / steps:.2f} "
            f"| {r['table1_s']:.1f} "
            f"| {r['peak_rss_mb']:.0f} |"
        )
    return "\n".join(lines)


def _fmt_certificate(r: dict) -> str:
    mc = r["mc"]
    head = (
        f"**{r['model']}** ({r['n_states']:,} states): V_pis by Monte Carlo ({mc['paths']:,} "
        f"paths, horizon {mc['horizon']}, truncation <= {mc['truncation']:.1e}, Student's t "
        f"{mc['level']:.0%}) beside the certified bounds (err(v*) = {r['upper_error']:.1e}); "
        "the last column is v* + err(v*) - (mean - half-width - truncation), a bound on "
        f"V* - V_pis at {mc['level']:.0%} per start. Intervals wholly above v*: "
        f"{mc['contradicts_upper']}; wholly below w*: {mc['below_lower']}."
    )
    return head + "\n\n" + r["mc_md"]


def _fmt_exact(runs: list[dict]) -> str:
    """Where the exact V_pis exists (the paper's instance): how the intervals did."""
    out = []
    for r in runs:
        if r.get("exact"):
            e, mc = r["exact"], r["mc"]
            out.append(
                f"Check on {r['model']} (exact V_pis by evaluate_policy on its MDP): the "
                f"{mc['level']:.0%} intervals cover it at {e['covered']} of {mc['n_starts']} "
                f"starts; max |mean - V_pis| = {e['max_abs_error']:.1e}."
            )
    return "\n\n".join(out) or "(no instance small enough for the exact check)"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--paths", type=int, default=4_000)
    ap.add_argument("--models", nargs="*", default=["patrol-paper", M6, "patrol-m8"])
    ap.add_argument("--reps", type=int, default=3, help="repetitions of the side-by-side run")
    ap.add_argument("--cv-paths", type=int, default=2_000)
    args = ap.parse_args()
    load0 = os.getloadavg()
    t0 = time.time()
    runs = [run_isolated(RUN.format(model=m, paths=args.paths), timeout=3600) for m in args.models]
    cv = run_isolated(CONTROL.format(reps=args.reps, paths=args.cv_paths), timeout=3600)
    load1 = os.getloadavg()
    c_on, c_off = statistics.median(cv["cpu"]["on"]), statistics.median(cv["cpu"]["off"])
    ratio = [(a / b) ** 2 for a, b in zip(cv["std"]["off"], cv["std"]["on"], strict=True)]
    meta = {"machine": machine(), "date": today(), "load_before": load0, "load_after": load1}
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps({"meta": meta, "runs": runs, "control": cv}, indent=1) + "\n")
    body = "\n\n".join(
        [
            "## pi_s beyond exact DP: Monte Carlo value and Table 1 "
            "(benchmarks/bench_greedy_mc.py)",
            f"{meta['machine']}; {meta['date']}; load average {load0[0]:.1f} before, "
            f"{load1[0]:.1f} after; total {time.time() - t0:.0f} s. Each model in a fresh "
            "process; compiled kernels (C, one range of paths per thread), their first run "
            "excluded (done on a small model first).",
            _fmt_table(runs),
            f"Control variate at 8 stations, side by side (8 empty-station starts x "
            f"{args.cv_paths:,} paths, {cv['steps']:,} steps each way, alternating, median of "
            f"{args.reps}): CPU {c_on:.2f} s with, {c_off:.2f} s without (ratio "
            f"{c_on / c_off:.2f}); variance ratio (without / with) {min(ratio):.0f}-"
            f"{max(ratio):.0f}, i.e. that many times fewer paths for the same interval.",
            _fmt_exact(runs),
            "Table 1 of pi_s (5 seeds x 60,000 steps; the 4-station conventions: delay to the "
            "first loiter, uncapped; in brackets counted to the end of the first loiter):",
            "\n".join(
                runs[0]["table1_md"].splitlines()[:2]
                + [r["table1_md"].splitlines()[-1] for r in runs]
            ),
            *[_fmt_certificate(r) for r in runs],
        ]
    )
    write_section("greedy-mc", body)
    print(body)


if __name__ == "__main__":
    main()
