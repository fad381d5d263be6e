"""Beyond the paper (issue 16): matrix-free exact V* at 4, 5 and 6 stations, time and memory.

1. The paper's instance (2,048,000 states): ``solve_exact`` on the array path and
   ``matrix_free.solve_vstar``, each in a fresh process, alternating; the two V* must be
   equal bit for bit (their SHA-256 is compared) and the times and peak memory are
   recorded side by side.
2. For each size (``--sizes``, default 5 6): the whole study of
   :func:`lpbounds.patrol.beyond.study` (bounds, V*, greedy pass, V_sub, checks) in a
   fresh process, its result saved as JSON in ``--cache`` (where ``lpbounds reproduce
   --beyond`` reads it) and its log in ``--cache``/NAME.log; the time of each stage and
   the peak resident memory are recorded. ``--reuse`` keeps results already in the cache
   (the 6-station run takes long: run it once in the background, then write the section).

Writes the ``beyond`` section of docs/benchmarks.md.

    python benchmarks/bench_beyond.py [--sizes 5 6] [--cache out/beyond] [--reuse]
                                      [--repeat 2] [--no-paper]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from _common import machine, run_isolated, today, write_section

PAPER = """
import time, json, hashlib
import numpy as np
from lpbounds.model.instances import load_instance
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.params import PatrolParams
p = params_from_instance(load_instance("patrol-paper"))
warm = PatrolParams(N=6, stations=(0, 2, 4), D=2, Gamma=11)  # above SMALL_READS: compiles
if "{path}" == "array":
    from lpbounds import solve_exact
    from lpbounds.patrol.model import PatrolModel
    solve_exact(PatrolModel(warm).mdp())  # numba's cache loaded (or compiled), not timed
    t = time.perf_counter()
    r = solve_exact(PatrolModel(p).mdp())
    policy = np.asarray(r.policy, dtype=np.int8)
else:
    from lpbounds.patrol.matrix_free import MatrixFreePatrol, solve_vstar
    solve_vstar(MatrixFreePatrol(warm))  # numba's cache loaded (or compiled), not timed
    t = time.perf_counter()
    r = solve_vstar(MatrixFreePatrol(p))
    policy = r.policy
t = time.perf_counter() - t
print(json.dumps({{"seconds": t, "iterations": r.iterations, "sweeps": r.sweeps,
                  "residual": r.residual, "error_bound": r.error_bound,
                  "values_sha256": hashlib.sha256(r.values.tobytes()).hexdigest(),
                  "policy_sha256": hashlib.sha256(policy.tobytes()).hexdigest()}}))
"""

STUDY = """
import sys, time
from lpbounds.model.instances import load_instance
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.beyond import study, save_result
name, out = sys.argv[1], sys.argv[2]
p = params_from_instance(load_instance(name))
def log(s):
    print(time.strftime("%H:%M:%S"), s, flush=True)
r = study(p, name, log=log, checkpoint=out[: -len(".json")] + "-vstar")
save_result(r, out)
log(f"done: peak rss {r.peak_rss_mb:.0f} MB, seconds {r.seconds}")
"""


TABLE_HEAD = (
    "| m | states | V* it. / sweeps | residual (error bound) | V* s | s / sweep | greedy s "
    "| V_sub s | checks s | total s | peak GB |\n|---|---|---|---|---|---|---|---|---|---|---|"
)


def uptime() -> str:
    try:
        return Path("/proc/loadavg").read_text().split(" ", 3)[:3].__str__()
    except OSError:
        return "?"


def paper_rows(repeat: int) -> tuple[list[str], str]:
    """Array path and matrix-free V* on the paper's instance, alternating, fresh processes."""
    runs: dict[str, list[dict]] = {"array": [], "matrix-free": []}
    for _ in range(repeat):
        for path in runs:
            runs[path].append(run_isolated(PAPER.format(path=path), timeout=3600))
            print(path, runs[path][-1], flush=True)
    same = {r["values_sha256"] for rs in runs.values() for r in rs}
    pol = {r["policy_sha256"] for rs in runs.values() for r in rs}
    rows = []
    for path, rs in runs.items():
        r0 = rs[0]
        rows.append(
            f"| {path} | {statistics.median(r['seconds'] for r in rs):.1f} | "
            f"{r0['iterations']} | {r0['sweeps']} | {r0['residual']:.3e} | "
            f"{max(r['peak_rss_mb'] for r in rs):.0f} |"
        )
    ta = statistics.median(r["seconds"] for r in runs["array"])
    tm = statistics.median(r["seconds"] for r in runs["matrix-free"])
    verdict = (
        "equal bit for bit (one SHA-256 of V* and one of the policy over all runs)"
        if len(same) == 1 and len(pol) == 1
        else f"NOT equal: {len(same)} distinct V*, {len(pol)} distinct policies"
    )
    note = f"V* of the two paths: {verdict}; matrix-free / array time: {tm / ta:.2f}."
    return rows, note


def run_size(name: str, cache: Path) -> dict:
    """The study of one size in a fresh process (log in cache/NAME.log); its JSON result."""
    out = cache / f"{name}.json"
    log = cache / f"{name}.log"
    with open(log, "w") as fh:
        proc = subprocess.run(
            [sys.executable, "-c", STUDY, name, str(out)], stdout=fh, stderr=subprocess.STDOUT
        )
    if proc.returncode != 0:
        raise RuntimeError(f"the study of {name} failed: see {log}")
    return json.loads(out.read_text())


def size_row(r: dict) -> str:
    v, s = r["vstar"], r["seconds"]
    tag = f"beyond_m{r['m']}"
    stage = [s.get(f"{tag}_{k}", float("nan")) for k in ("vstar", "greedy", "vsub", "checks")]
    per_sweep = v["seconds"] / max(1, v["sweeps"])
    return (
        f"| {r['m']} | {r['n_states']:,} | {v['iterations']} / {v['sweeps']} | "
        f"{v['residual']:.2e} ({v['error_bound']:.1e}) | {stage[0]:.0f} | {per_sweep:.2f} | "
        f"{stage[1]:.0f} | {stage[2]:.0f} ({r['policy']['vsub_sweeps']}) | {stage[3]:.0f} | "
        f"{sum(s.values()):.0f} | {r['peak_rss_mb'] / 1024:.1f} |"
    )


def progress_note(name: str, cache: Path, done: list[dict]) -> str:
    """A size still running (or stopped) before its V*: the improvement steps in its log,
    their seconds, and the total extrapolated with the step counts of the largest finished
    size (the same MPI: 1 max + 5 evaluation sweeps a step)."""
    import re

    log = cache / f"{name}.log"
    if not log.is_file():
        return f"{name}: no result and no log."
    steps = [
        (int(m.group(1)), float(m.group(2)), float(m.group(3)))
        for m in re.finditer(r"V\* iteration (\d+): residual (\S+) \((\d+) s\)", log.read_text())
    ]
    if len(steps) < 2:
        return f"{name}: V* not past its first improvement step yet (log: {log})."
    per_step = (steps[-1][2] - steps[0][2]) / (steps[-1][0] - steps[0][0])
    text = (
        f"{name}: V* not finished when this was written: {steps[-1][0] + 1} improvement "
        f"steps (residual {steps[-1][1]:.2e}) in {steps[-1][2]:.0f} s; {per_step:.0f} s per "
        f"step (1 max + 5 evaluation sweeps: {per_step / 6:.0f} s per sweep)"
    )
    if done:
        ref = max(done, key=lambda r: r["n_states"])
        its = ref["vstar"]["iterations"] + 1
        ev = ref["policy"]["vsub_sweeps"] + 1
        total = per_step * its + per_step / 6 * ev
        text += (
            f"; at this speed, with the {its} steps and {ev} evaluation sweeps of "
            f"{ref['instance']}, V* and V_sub would take about {total / 3600:.1f} h"
        )
    return text + "."


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sizes", type=int, nargs="*", default=[5, 6])
    ap.add_argument("--cache", default="out/beyond")
    ap.add_argument("--reuse", action="store_true", help="keep results already in --cache")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--no-paper", action="store_true", help="skip the paper-instance comparison")
    ap.add_argument(
        "--progress-only",
        action="store_true",
        help="run no size: the finished ones from --cache, the others' progress from their logs",
    )
    args = ap.parse_args()
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    load = [uptime()]
    paper, note = ([], "not run") if args.no_paper else paper_rows(args.repeat)
    load.append(uptime())
    from lpbounds.patrol.beyond import BEYOND_MODELS

    results, notes = [], []
    for m in args.sizes:
        name = BEYOND_MODELS[m]
        path = cache / f"{name}.json"
        if args.progress_only:
            if path.is_file():
                results.append(json.loads(path.read_text()))
            else:
                notes.append(progress_note(name, cache, results))
            continue
        r = json.loads(path.read_text()) if args.reuse and path.is_file() else run_size(name, cache)
        results.append(r)
        load.append(uptime())
        print(size_row(r), flush=True)
    body = f"""## Beyond the paper: matrix-free exact V* (issue 16)

Machine: {machine()}; {today()}; load average (1, 5, 15 min) during the runs: {"; ".join(load)}
(`nproc` = {os.cpu_count()}; other jobs shared the machine).

The paper's instance, `solve_exact` (array path: successor arrays and the post-decision
form) against `lpbounds.patrol.matrix_free.solve_vstar` (nothing stored per state), each
in a fresh process after an untimed solve of a small instance (numba's cache loaded),
{args.repeat} alternating runs (median seconds, including building the MDP for the array path):

| path | seconds | iterations | sweeps | residual | peak MB |
|---|---|---|---|---|---|
{chr(10).join(paper)}

{note}

The study at each size (`lpbounds.patrol.beyond.study`, one fresh process each): V* by
matrix-free MPI (iterations / sweeps, residual and certified error bound), seconds per
sweep (all sweeps, improvement and evaluation), the greedy pass (pi_s and the gaps), V_sub
(its evaluation sweeps in brackets), the checks, the total and the peak resident memory:

{TABLE_HEAD}
{chr(10).join(size_row(r) for r in results)}

{chr(10).join(notes)}
"""
    write_section("beyond", body)
    print(body)


if __name__ == "__main__":
    main()
