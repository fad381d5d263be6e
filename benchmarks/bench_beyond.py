"""Beyond the paper: matrix-free exact V* at 4, 5 and 6 stations, time and memory.

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

``--in-order`` instead writes the ``sweeps-in-order`` section: the paper's instance as in
1 (``--repeat`` alternating runs, the array path's build time recorded apart), then
single improvement and evaluation sweeps of both paths at 4 stations and of the
matrix-free path at 5 (1 thread and all, best and median) against the bandwidth floor
(this machine's read and copy bandwidth measured beside), and from those costs per state
an estimate for 6 stations and what 7 and 8 need. It runs no study (a few minutes).

    python benchmarks/bench_beyond.py [--sizes 5 6] [--cache out/beyond] [--reuse]
                                      [--repeat 2] [--no-paper]
    python benchmarks/bench_beyond.py --in-order [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from _common import BANDWIDTH_PROBE, machine, run_isolated, today, write_section

PAPER = """
import time, json, hashlib, os
import numpy as np
from lpbounds.model.instances import load_instance
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.params import PatrolParams
p = params_from_instance(load_instance("patrol-paper"))
warm = PatrolParams(N=6, stations=(0, 2, 4), D=2, Gamma=11)  # loads every kernel once
if "{path}" == "array":
    from lpbounds import solve_exact
    from lpbounds.patrol.model import PatrolModel
    solve_exact(PatrolModel(warm).mdp())  # first calls made, not timed
    t = time.perf_counter()
    model = PatrolModel(p).mdp()
    build = time.perf_counter() - t
    r = solve_exact(model)
    policy = np.asarray(r.policy, dtype=np.int8)
else:
    from lpbounds.patrol.matrix_free import MatrixFreePatrol, solve_vstar
    solve_vstar(MatrixFreePatrol(warm))  # the C sweeps' first run, not timed
    t = time.perf_counter()
    model = MatrixFreePatrol(p)
    build = time.perf_counter() - t
    r = solve_vstar(model)
    policy = r.policy
t = time.perf_counter() - t
print(json.dumps({{"seconds": t, "build_seconds": build, "load": os.getloadavg()[0],
                  "iterations": r.iterations, "sweeps": r.sweeps,
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


SWEEPS = r"""
import json, os, time, numpy as np
from lpbounds._kernels import threads
from lpbounds.model.instances import load_instance
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.matrix_free import MatrixFreePatrol

__PROBE__

many = threads.get_threads()
a = np.random.default_rng(0).random(64 * 2**20)  # 512 MB, far above the caches
b = np.empty_like(a)
read_sum(a, many); copy(a, b, many)
bw = {"read": a.nbytes / best(lambda: read_sum(a, many), 7)[0] / 1e9,
      "copy": 2 * a.nbytes / best(lambda: copy(a, b, many), 7)[0] / 1e9}
del a, b
out = {"bw": bw, "many": many, "load": [os.getloadavg()[0]], "sizes": {}}
for name in __NAMES__:
    p = params_from_instance(load_instance(name))
    ops = {"matrix-free": MatrixFreePatrol(p)}
    if p.n_states <= 4_000_000:  # the array path's arrays fit easily: measure it beside
        from lpbounds.dp import post_decision_rows
        from lpbounds.patrol.model import PatrolModel
        ops["array"] = post_decision_rows(PatrolModel(p).mdp())
    n = p.n_states
    v, u = np.zeros(n), np.empty(n)
    res = {"n": n}
    for path, op in ops.items():
        arg, work = op.new_arg(), op.new_work()
        v[:] = 0.0
        for _ in range(4):  # a few VI steps from 0: values with the solve's structure
            op.sweep_max(v, u, arg, work=work)
            v, u = u, v
        act = arg.copy()
        r = {}
        for k in sorted({1, many}):
            threads.set_threads(k)  # every kernel (C): the array path's and the matrix-free
            op.sweep_max(v, u, arg, work=work)
            r[f"max/{k}"] = best(lambda: op.sweep_max(v, u, arg, work=work), 15)
            r[f"policy/{k}"] = best(lambda: op.sweep_policy(act, v, u, work=work), 15)
        threads.set_threads(many)
        res[path] = r
    out["sizes"][name] = res
    out["load"].append(os.getloadavg()[0])
print(json.dumps(out))
""".replace("__PROBE__", BANDWIDTH_PROBE)


def in_order(repeat: int) -> None:
    """The ``sweeps-in-order`` section: the in-order matrix-free sweeps against the array
    path on the paper's instance (whole solves, alternating), their cost per state at 4
    and 5 stations against the bandwidth floor, and what 6, 7 and 8 stations need."""
    load0 = os.getloadavg()
    paper, note, runs = paper_rows(repeat)
    load1 = os.getloadavg()
    names = ["patrol-paper", "patrol-m5-paper"]
    r = run_isolated(SWEEPS.replace("__NAMES__", repr(names)), timeout=3600)
    bw = max(r["bw"].values())
    many = r["many"]
    rows = []
    for name, res in r["sizes"].items():
        n = res["n"]
        for path in ("array", "matrix-free"):
            if path not in res:
                continue
            # compulsory bytes per state: v read and out written (8 + 8), the choice (1);
            # the array path's own arrays besides (from the dp-floor section: outcomes,
            # W twice, first, reward codes), measured there as 139.0 MB / 2,048,000 states
            bps = 17.0 if path == "matrix-free" else 139.0e6 / 2_048_000
            for kind in ("max", "policy"):
                t1 = res[path][f"{kind}/1"][0]
                tm, med = res[path][f"{kind}/{many}"]
                floor_ms = bps * n / bw / 1e6
                rows.append(
                    f"| {name} | {path} | {'improvement' if kind == 'max' else 'evaluation'} | "
                    f"{n:,} | {bps:.0f} | {floor_ms:.1f} | {t1 * 1e3:.1f} | {tm * 1e3:.1f} | "
                    f"{med * 1e3:.1f} | {t1 / n * 1e9:.1f} | {tm / n * 1e9:.1f} | "
                    f"{tm * 1e3 / floor_ms:.1f}x |"
                )
    body = _in_order_body(repeat, paper, note, runs, rows, r, (load0, load1))
    write_section("sweeps-in-order", body)
    print(body)


def _in_order_body(repeat, paper, note, runs, rows, r, loads) -> str:
    """The text of the ``sweeps-in-order`` section (see :func:`in_order`)."""
    est, big = _beyond_sizes(Path("out/beyond"))
    ratios = ""
    if runs:
        import statistics

        ta = statistics.median(x["seconds"] for x in runs["array"])
        tb = statistics.median(x["build_seconds"] for x in runs["array"])
        tm = statistics.median(x["seconds"] for x in runs["matrix-free"])
        run_loads = ", ".join(f"{x['load']:.2f}" for rs in runs.values() for x in rs)
        ratios = (
            f"Ratios (medians of {repeat} alternating runs): matrix-free / array path "
            f"**{tm / ta:.2f}** as timed (the array path's time includes building its MDP, "
            f"{tb:.1f} s); matrix-free / the array path's solve alone {tm / (ta - tb):.2f}. "
            f"Load average (1 min) at each run's end: {run_loads}."
        )
    start, after = (", ".join(f"{x:.2f}" for x in ld) for ld in loads)
    during = ", ".join(f"{x:.2f}" for x in r["load"])
    k = r["many"]
    head = (
        f"| instance | path | sweep | states | B / state | floor ms | 1 thread ms | {k} threads "
        f"best ms | median ms | ns / state, 1 thread | ns / state, {k} threads | / floor |"
    )
    return f"""## Matrix-free sweeps in state order

Machine: {machine()}; {today()}; load average (1, 5, 15 min) at the start
{start}, after the solves {after}, 1-min load during the sweep timings {during} (`nproc` =
{os.cpu_count()}; other jobs shared the machine).

The matrix-free sweeps (`lpbounds.patrol.sweeps`) walk the states in index order: a row
of `Gamma + 1` states differing in one delay is set up from the previous row's delays (a
mixed-radix counter, carried), its successors are arithmetic sequences of indices, and the
two travel states at a node with the same delays (headings +1, -1) share their sums.

Whole V* solves of the paper's instance (`lpbounds.solve_exact` on the MDP's arrays
against `matrix_free.solve_vstar`, fresh processes, {repeat} alternating runs, median
seconds, the array path including building its MDP):

| path | seconds | iterations | sweeps | residual | peak MB |
|---|---|---|---|---|---|
{chr(10).join(paper)}

{note}

{ratios}

Single sweeps (best of 15 and median, after 4 value-iteration steps from 0; on 1 thread and
on {r["many"]}). Bandwidth (numpy, 512 MB, a slice a thread): read {r["bw"]["read"]:.1f} GB/s,
copy {r["bw"]["copy"]:.1f} GB/s. The floor is the compulsory bytes per state (matrix-free:
`v` read and `out` written once, 8 + 8 bytes, and the int8 choice; the array path: 68
bytes, its own arrays besides, as in the dp-floor section) over the best bandwidth:

{head}
|---|---|---|---|---|---|---|---|---|---|---|---|
{chr(10).join(rows)}

{est}

{big}
"""


BIG_HEAD = (
    "| m | states | GiB | minutes per sweep (2 cores) | hours for V* + V_sub (2 cores, "
    "given the RAM) | nodes | GB per node and sweep exchanged | hours on those nodes |\n"
    "|---|---|---|---|---|---|---|---|"
)
#: The 6-station study's result, written by ``bench_beyond.py --sizes 6`` (its cache).
M6 = "patrol-m6-paper.json"
#: RAM of one cluster node in the sizing of 7 and 8 stations (GiB), and its cores.
NODE_GIB, NODE_CORES = 256, 32


def _beyond_sizes(cache: Path) -> tuple[str, str]:
    """The 6-station study as measured (from ``cache``), and what 7 and 8 stations need,
    from its cost per state and sweep counts: memory, time on these 2 cores, and the
    cluster that holds them (on paper: not run)."""
    path = cache / M6
    if not path.is_file():
        return f"(No 6-station study in {cache}: run `bench_beyond.py --sizes 6` first.)", ""
    r = json.loads(path.read_text())
    n6, vs, pol = r["n_states"], r["vstar"], r["policy"]
    t_v, t_s = r["seconds"]["beyond_m6_vstar"], r["seconds"]["beyond_m6_vsub"]
    sweeps = vs["sweeps"] + pol["vsub_sweeps"]
    core_ns = 2 * (t_v + t_s) / sweeps / n6 * 1e9  # core-nanoseconds per state and sweep
    bps = r["peak_rss_mb"] * 2**20 / n6
    est = (
        f"**Measured at 6 stations** ({n6:,} states; the beyond section's study, these "
        f"kernels): V* {vs['iterations']} MPI steps, {vs['sweeps']} sweeps, {t_v:.0f} s "
        f"({t_v / 60:.1f} min; target 20); V_sub {pol['vsub_sweeps']} sweeps, {t_s:.0f} s "
        f"({t_s / 60:.1f} min; target 15); peak {r['peak_rss_mb'] / 1024:.1f} GiB "
        f"({bps:.0f} B per state). Over both solves: {(t_v + t_s) / sweeps:.2f} s per sweep, "
        f"{core_ns:.1f} core-ns per state and sweep (2 cores), against the 5-station single "
        f"sweeps above: a plane of v is 134 MB there, far beyond the caches, and the value "
        f"vectors stream from memory."
    )
    rows, need = [], {}
    for m in (7, 8):
        n = 2 * 15 * 16**m + 5 * m * 16 ** (m - 1)
        gib = bps * n / 2**30
        core_h = core_ns * n * sweeps / 1e9 / 3600
        nodes = max(1, -(-gib // (0.8 * NODE_GIB)))  # 80 % of a node's RAM for the study
        # per sweep each node sends and receives the planes next to its own: with the
        # planes split among the nodes, 2 of the 2 N = 30 travel planes' share of v
        halo_gb = 2 * 8 * n / 30 / 1e9 if nodes > 1 else 0.0
        wall = core_h / (nodes * NODE_CORES) + sweeps * halo_gb / 10.0 / 3600  # 10 GB/s links
        need[m] = (gib, nodes)
        rows.append(
            f"| {m} | {n:,} | {gib:,.0f} | {core_ns * n / 2e9 / 60:,.1f} | "
            f"{core_h / 2:,.0f} | {nodes:.0f} | {halo_gb:,.0f} | {wall:,.1f} |"
        )
    (gib7, nodes7), (_, nodes8) = need[7], need[8]
    big = f"""What 7 and 8 stations need (on paper, not run: the paper's N = 15, D = 5, Gamma = 15;
memory at the 6-station study's {bps:.0f} B per state; time at its {core_ns:.1f} core-ns per
state and sweep and its {sweeps} sweeps for V* and V_sub; a node of {NODE_GIB} GiB and
{NODE_CORES} cores, 80 % of its RAM for the study, 10 GB/s links):

{BIG_HEAD}
{chr(10).join(rows)}

At 7 stations memory decides, not time: the study needs {gib7:,.0f} GiB, one machine with
512 GB (or the table's {nodes7:.0f} nodes), and then runs in a few hours even on two cores:
a day's run on one large machine. At 8 stations no machine holds it: a cluster of the
table's {nodes8:.0f} nodes makes it an hour's run (a day's run on a few cores per node),
each node holding a run of consecutive planes (node, heading) of v and the policy. A sweep's
successors lie in the planes of the two neighbouring nodes and the node's own loiter plane,
so each node swaps its edge planes with its two neighbours once per sweep (a ring: the
perimeter is a cycle) and runs these kernels on its own planes. The engine for that is MPI
(mpi4py, one rank per node, `Sendrecv` of the halo planes, `Allreduce` of the residual's min
and max); Dask's `map_overlap` on v viewed as a (planes x 16^m) array chunked by planes,
with a periodic halo, expresses the same exchange but builds a task graph per sweep and
moves the halos through its scheduler's comms, so MPI is the one to carry it."""
    return est, big


TABLE_HEAD = (
    "| m | states | V* it. / sweeps | residual (error bound) | V* s | s / sweep | greedy s "
    "| V_sub s | checks s | total s | peak GB |\n|---|---|---|---|---|---|---|---|---|---|---|"
)


def uptime() -> str:
    try:
        return Path("/proc/loadavg").read_text().split(" ", 3)[:3].__str__()
    except OSError:
        return "?"


def paper_rows(repeat: int) -> tuple[list[str], str, dict[str, list[dict]]]:
    """Array path and matrix-free V* on the paper's instance, alternating, fresh processes:
    the table rows, the verdict on their equality and the runs."""
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
    return rows, note, runs


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
    ap.add_argument(
        "--in-order",
        action="store_true",
        help="only the sweeps-in-order section: paper-instance solves (--repeat) and sweeps",
    )
    args = ap.parse_args()
    if args.in_order:
        in_order(args.repeat)
        return
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    load = [uptime()]
    paper, note, _ = ([], "not run", {}) if args.no_paper else paper_rows(args.repeat)
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
    body = f"""## Beyond the paper: matrix-free exact V*

Machine: {machine()}; {today()}; load average (1, 5, 15 min) during the runs: {"; ".join(load)}
(`nproc` = {os.cpu_count()}; other jobs shared the machine).

The paper's instance, `solve_exact` (array path: successor arrays and the post-decision
form) against `lpbounds.patrol.matrix_free.solve_vstar` (nothing stored per state), each
in a fresh process after an untimed solve of a small instance (the first calls made),
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
