"""The patrol's kernels in C against their numba versions, side by side in one run.

The matrix-free sweeps, the greedy Monte Carlo and the simulator of the patrol
(``lpbounds._kernels.patrolsweeps``, ``patrolmc``) were numba's until issue 39. This script
measures the tree it lives in against a checkout of an older commit (``--old``, default the
fork point of the port), every measurement in a fresh process, the two trees alternating:

* the paper's instance, ``matrix_free.solve_vstar`` (V* by MPI): in the process after an
  untimed solve of a small instance (numba's cache loaded: a warm cache), and the whole
  process from start (imports, numba's cache, the solve);
* the greedy Monte Carlo on the paper's instance (``greedy_value_mc``, its 16 default
  starts x ``--paths`` paths x the default horizon) and Table 1 of ``pi_s`` (5 seeds x
  60,000 steps), after an untimed run on a small instance;
* the first ``lpbounds reproduce models/patrol-small.toml --seeds 1 --steps 2000`` in a fresh
  process with an empty numba cache (``NUMBA_CACHE_DIR`` a new folder: what a fresh
  environment has), then the second with that cache.

The older tree's processes import numba, so this environment needs it (``pip install
numba``; lpbounds no longer installs it); this tree's never do.

Each pair of runs must give the same V* and policy and the same Monte Carlo estimates (the
script compares SHA-256 prefixes and stops otherwise). Writes the ``patrol-c`` section of
docs/benchmarks.md.

    python benchmarks/bench_patrol_c.py [--old 1571e7d] [--repeat 3] [--cold-repeat 2]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import machine, today, write_section

ROOT = Path(__file__).resolve().parents[1]
SMALL_MODEL = ROOT / "models" / "patrol-small.toml"

VSTAR = """
import hashlib, json, os, time
t0 = time.perf_counter()
from lpbounds.model.instances import load_instance
from lpbounds.patrol import PatrolParams
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.matrix_free import MatrixFreePatrol, solve_vstar
if {warm}:  # the kernels loaded (numba: from its cache) on a small instance, not timed
    solve_vstar(MatrixFreePatrol(PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4)))
p = params_from_instance(load_instance("patrol-paper"))
t = time.perf_counter()
r = solve_vstar(MatrixFreePatrol(p))
solve = time.perf_counter() - t
h = hashlib.sha256(r.values.tobytes() + r.policy.tobytes()).hexdigest()[:16]
print(json.dumps({{"solve": solve, "process": time.perf_counter() - t0, "sweeps": r.sweeps,
                  "iterations": r.iterations, "hash": h, "load": os.getloadavg()[0]}}))
"""

MC = """
import hashlib, json, os, time
import numpy as np
from lpbounds.model.instances import load_instance
from lpbounds.patrol import PatrolParams
from lpbounds.patrol import greedy_mc as g
from lpbounds.patrol.instance import params_from_instance
small = PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4)  # kernels loaded, not timed
b0 = g.partition_bounds(small)
g.greedy_value_mc(small, b0.lower, b0.upper, starts=3, paths=10, horizon=5)
g.greedy_table1(small, b0.lower, steps=100, seeds=[1])
p = params_from_instance(load_instance("patrol-paper"))
b = g.partition_bounds(p)
t = time.perf_counter()
est = g.greedy_value_mc(p, b.lower, b.upper, paths={paths})
mc = time.perf_counter() - t
t = time.perf_counter()
tab = g.greedy_table1(p, b.lower)
table1 = time.perf_counter() - t
h = hashlib.sha256(est.mean.tobytes() + est.std.tobytes()).hexdigest()[:16]
h1 = hashlib.sha256(json.dumps({{k: v for k, v in tab.summary().items() if k != "seconds"}},
                                sort_keys=True).encode()).hexdigest()[:16]
print(json.dumps({{"mc": mc, "steps": est.n_starts * est.paths * est.horizon, "table1": table1,
                  "hash": h + " " + h1, "load": os.getloadavg()[0]}}))
"""


def old_tree(rev: str, where: Path) -> Path:
    """``src`` of commit ``rev`` in ``where``, its row sweeps built (copied when
    ``rowsweeps.c`` is the same as here)."""
    subprocess.run(f"git -C {ROOT} archive {rev} src | tar -x -C {where}", shell=True, check=True)
    src = where / "src"
    kernels = src / "lpbounds" / "_kernels"
    same = subprocess.run(
        ["git", "-C", str(ROOT), "diff", "--quiet", rev, "--", "src/lpbounds/_kernels/rowsweeps.c"]
    ).returncode == 0  # fmt: skip
    built = sorted((ROOT / "src" / "lpbounds" / "_kernels").glob("rowsweeps*.so"))
    if same and built:
        shutil.copy(built[0], kernels)
        return src
    code = (
        "from setuptools import Extension, setup; setup(name='old', package_dir={'': 'src'}, "
        "ext_modules=[Extension('lpbounds._kernels.rowsweeps', "
        "['src/lpbounds/_kernels/rowsweeps.c'], extra_compile_args=['-O3', "
        "'-ffp-contract=off', '-std=c99'])], script_args=['build_ext', '--inplace'])"
    )
    subprocess.run([sys.executable, "-c", code], cwd=where, check=True, capture_output=True)
    return src


def child(code: str, pythonpath: str | None, env: dict | None = None) -> dict:
    """Run ``code`` in a fresh interpreter (``pythonpath`` first on its path); its last
    line of output is JSON; adds the whole process's wall seconds."""
    e = dict(os.environ if env is None else env)
    if pythonpath:
        e["PYTHONPATH"] = pythonpath
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=e)
    wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    out["wall"] = wall
    return out


def reproduce(pythonpath: str | None, cache: str, out: str) -> dict:
    """``lpbounds reproduce`` of the small patrol, one seed of 2,000 steps, whole process."""
    e = dict(os.environ, NUMBA_CACHE_DIR=cache)
    if pythonpath:
        e["PYTHONPATH"] = pythonpath
    cmd = [sys.executable, "-m", "lpbounds.cli.main", "reproduce", str(SMALL_MODEL),
           "--seeds", "1", "--steps", "2000", "--out", out, "--no-figures", "-q"]  # fmt: skip
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=e)
    wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    return {"wall": wall, "load": os.getloadavg()[0]}


PROBE = """
import json, sys
from lpbounds.cli.main import entry
sys.argv = ["lpbounds", "reproduce", {model!r}, "--seeds", "1", "--steps", "2000", "--out",
            {out!r}, "--no-figures", "-q"]
try:
    entry()
except SystemExit:
    pass
print(json.dumps({{"numba": "numba" in sys.modules}}))
"""


def med(runs: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in runs)


def agree(runs: dict[str, list[dict]], what: str) -> str:
    hashes = {r["hash"] for rs in runs.values() for r in rs}
    if len(hashes) != 1:
        raise SystemExit(f"{what}: the two trees disagree: {sorted(hashes)}")
    return hashes.pop()


def _yes(flag: bool) -> str:
    return "imported" if flag else "not imported"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", default="1571e7d", help="the commit whose kernels are numba's")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each timing per tree")
    ap.add_argument("--cold-repeat", type=int, default=2, help="cold reproduce runs per tree")
    ap.add_argument("--paths", type=int, default=1000, help="Monte Carlo paths per start")
    ap.add_argument("--no-write", action="store_true", help="print, do not write the section")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()
    tmp = Path(tempfile.mkdtemp(prefix="bench-patrol-c-"))
    try:
        trees = {"numba": str(old_tree(args.old, tmp)), "C": None}
        for path in trees.values():  # numba's cache filled, .pyc written: not measured
            child(VSTAR.format(warm=True), path)
            child(MC.format(paths=10), path)
        vs: dict[str, list[dict]] = {k: [] for k in trees}
        vs_cold: dict[str, list[dict]] = {k: [] for k in trees}
        mc: dict[str, list[dict]] = {k: [] for k in trees}
        for _ in range(args.repeat):
            for name, path in trees.items():
                vs[name].append(child(VSTAR.format(warm=True), path))
                vs_cold[name].append(child(VSTAR.format(warm=False), path))
                mc[name].append(child(MC.format(paths=args.paths), path))
        cold: dict[str, list[dict]] = {k: [] for k in trees}
        warm: dict[str, list[dict]] = {k: [] for k in trees}
        for i in range(args.cold_repeat):
            for name, path in trees.items():
                cache = str(tmp / f"numba-cache-{name}-{i}")
                out = str(tmp / f"out-{name}-{i}")
                cold[name].append(reproduce(path, cache, out))
                warm[name].append(reproduce(path, cache, out))
        numba_in = {
            name: child(PROBE.format(model=str(SMALL_MODEL), out=str(tmp / "probe")), path)["numba"]
            for name, path in trees.items()
        }
        h_vs = agree({k: vs[k] + vs_cold[k] for k in trees}, "V*")
        h_mc = agree(mc, "Monte Carlo")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    load1 = os.getloadavg()
    steps = mc["C"][0]["steps"]
    rows = [
        ("V* of patrol-paper, solve after a warm-up (s)", vs, "solve"),
        ("V* of patrol-paper, whole process (s)", vs_cold, "wall"),
        (f"greedy Monte Carlo, 16 starts, {steps:,} steps (s)", mc, "mc"),
        ("Table 1 of pi_s, 5 x 60,000 steps (s)", mc, "table1"),
        ("first `reproduce` of patrol-small, empty numba cache (s)", cold, "wall"),
        ("second `reproduce`, numba's cache filled (s)", warm, "wall"),
    ]
    lines = [
        "| measurement | numba | C | C / numba |",
        "|---|---:|---:|---:|",
    ]
    for label, runs, key in rows:
        a, b = med(runs["numba"], key), med(runs["C"], key)
        lines.append(f"| {label} | {a:.3f} | {b:.3f} | {b / a:.2f} |")
    loads = [r["load"] for d in (vs, vs_cold, mc, cold, warm) for rs in d.values() for r in rs]
    first_second = {k: med(cold[k], "wall") / med(warm[k], "wall") for k in trees}
    r0 = vs["C"][0]
    body = f"""## The patrol's kernels: C against numba (benchmarks/bench_patrol_c.py)

{machine()}; {today()}; load average (1, 5, 15 min) {load0[0]:.2f}, {load0[1]:.2f}, \
{load0[2]:.2f} at the start, {load1[0]:.2f}, {load1[1]:.2f}, {load1[2]:.2f} at the end; 1-min \
load at the runs' ends {min(loads):.2f} to {max(loads):.2f} (`nproc` = {os.cpu_count()}; \
other jobs shared the machine).

The matrix-free sweeps and passes, the greedy policy on the fly and the simulator of the
patrol are C since issue 39 (`lpbounds._kernels.patrolsweeps`, `patrolmc`), built at
install; before, numba compiled them ("numba": commit `{args.old}`, the same
arithmetic). Every run in a fresh process on 2 threads, the two trees alternating; medians
of {args.repeat} runs ({args.cold_repeat} for `reproduce`). The V* runs: {r0["iterations"]}
MPI steps, {r0["sweeps"]} sweeps, V* and policy SHA-256 `{h_vs}` in every run of both
trees; the Monte Carlo means and deviations and Table 1: `{h_mc}` in every run of both.
"Warm-up": the kernels first run on a small instance in the same process (numba's
cache loaded, not timed); "whole process": from interpreter start, numba's cache filled.
`reproduce`: `lpbounds reproduce models/patrol-small.toml --seeds 1 --steps 2000
--no-figures -q`, the first run with an empty `NUMBA_CACHE_DIR` (a fresh environment),
the second with the cache it left; first / second: numba {first_second["numba"]:.2f},
C {first_second["C"]:.2f}. numba in the `reproduce` process: {_yes(numba_in["numba"])} before,
{_yes(numba_in["C"])} in the C tree (the small model's other sweeps are numpy's).

{chr(10).join(lines)}
"""
    if args.no_write:
        print(body)
    else:
        write_section("patrol-c", body)
        print(body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
