"""Start-up benchmark: ``lpbounds --help``, ``import lpbounds`` and a first solve in a fresh
environment (an empty numba cache), each in fresh processes.

Targets: ``lpbounds --help`` and every ``lpbounds SUBCOMMAND --help`` within
0.3 s; ``import lpbounds`` within 0.1 s of ``import numpy, scipy.sparse``; the first solve
of a small model with an empty numba cache within 3 s. Writes the ``startup`` section of
docs/benchmarks.md.

    python benchmarks/bench_startup.py [--repeat 7] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import machine, today, write_section

COMMANDS = ("solve", "verify", "bounds", "reproduce", "compare")
HELP_TARGET = 0.3
IMPORT_MARGIN = 0.1
FIRST_SOLVE_TARGET = 3.0

#: The tutorial's first two blocks (docs/tutorial.md): a 4-state MDP and its exact solve.
TUTORIAL = """
import numpy as np
import lpbounds as lb
P = np.zeros((2, 4, 4))
P[0] = 0.8 * np.eye(4) + 0.2 * np.roll(np.eye(4), 1, axis=1)
P[1] = np.roll(np.eye(4), 1, axis=1)
R = np.array([[0.0, 0.0], [1.0, 0.0], [3.0, 0.0], [0.5, 0.0]])
mdp = lb.FiniteMDP.from_matrices(P, R, discount=0.9)
dp = lb.solve_exact(mdp)
assert dp.error_bound <= 1e-8
"""

#: A small model's exact solve and its RLP (garnet-small's shape), as a new user runs them.
GARNET_RLP = """
import lpbounds as lb
from lpbounds.formulations import RLP
mdp = lb.garnet(300, 3, 4, 0.9, seed=7)
dp = lb.solve_exact(mdp)
res = RLP(mdp, lb.random_partition(300, 30, seed=11)).solve("HIGHS", verbose=False)
assert res.values is not None and dp.error_bound <= 1e-7
"""


def lpbounds_command() -> list[str]:
    """The installed console script if it sits next to this interpreter, else the module."""
    script = Path(sys.executable).with_name("lpbounds")
    if script.exists():
        return [str(script)]
    return [
        sys.executable,
        "-c",
        "import sys; from lpbounds.cli.main import main; sys.exit(main())",
    ]


def wall(argv: list[str], env: dict[str, str] | None = None) -> float:
    """Wall-clock seconds of one fresh process (its output discarded; it must succeed)."""
    t = time.perf_counter()
    proc = subprocess.run(argv, env=env, capture_output=True, text=True)
    dt = time.perf_counter() - t
    if proc.returncode != 0:
        raise RuntimeError(f"{argv} failed:\n{proc.stderr[-2000:]}")
    return dt


def median_wall(argv: list[str], repeat: int, env: dict[str, str] | None = None) -> float:
    wall(argv, env)  # one unmeasured run: the OS file cache, .pyc files
    return statistics.median(wall(argv, env) for _ in range(repeat))


def cold(code: str, repeat: int) -> tuple[float, float]:
    """Median and max wall seconds of ``code`` in fresh processes, each with its own empty
    numba cache (``NUMBA_CACHE_DIR``): a fresh environment."""
    times = []
    for _ in range(repeat):
        cache = tempfile.mkdtemp(prefix="numba-cold-")
        try:
            env = {**os.environ, "NUMBA_CACHE_DIR": cache}
            times.append(wall([sys.executable, "-c", code], env))
        finally:
            shutil.rmtree(cache, ignore_errors=True)
    return statistics.median(times), max(times)


def load_average() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover - not on this platform
        return "n/a"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--cold-repeat", type=int, default=3)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    load_before = load_average()
    py = sys.executable
    rows: list[tuple[str, float, str]] = []

    def add(name: str, seconds: float, target: str) -> None:
        rows.append((name, seconds, target))
        print(f"{name:<48} {seconds:7.3f} s  {target}", flush=True)

    base = median_wall([py, "-c", "pass"], args.repeat)
    add("python -c pass", base, "")
    np_sp = median_wall([py, "-c", "import numpy, scipy.sparse"], args.repeat)
    add('python -c "import numpy, scipy.sparse"', np_sp, "")
    imp = median_wall([py, "-c", "import lpbounds"], args.repeat)
    ok = imp <= np_sp + IMPORT_MARGIN
    add('python -c "import lpbounds"', imp, f"<= {np_sp + IMPORT_MARGIN:.3f}: {_met(ok)}")
    cmd = lpbounds_command()
    for sub in ("", *COMMANDS):
        argv = [*cmd, *([sub] if sub else []), "--help"]
        t = median_wall(argv, args.repeat)
        add(
            f"lpbounds {sub + ' ' if sub else ''}--help",
            t,
            f"<= {HELP_TARGET}: {_met(t <= HELP_TARGET)}",
        )
    cold_rows = [("tutorial blocks 1-2 (4 states, solve_exact)", TUTORIAL)]
    cold_rows.append(("garnet(300, 3, 4): solve_exact + RLP (HiGHS)", GARNET_RLP))
    for name, code in cold_rows:
        med, worst = cold(code, args.cold_repeat)
        add(f"cold: {name}", med, f"<= {FIRST_SOLVE_TARGET}: {_met(worst <= FIRST_SOLVE_TARGET)}")
    load_after = load_average()
    print(f"machine: {machine()}\ndate: {today()}\nload average: {load_before} -> {load_after}")
    if not args.no_write:
        write_section("startup", _section(rows, args, load_before, load_after))


def _met(ok: bool) -> str:
    return "met" if ok else "**missed**"


def _section(
    rows: list[tuple[str, float, str]], args: argparse.Namespace, before: str, after: str
) -> str:
    table = "\n".join(
        f"| {name if name.startswith('cold') else f'`{name}`'} | {sec:.3f} | {target} |"
        for name, sec, target in rows
    )
    return f"""## Start-up: `--help`, `import lpbounds` and a first solve

Machine: {machine()}. Date: {today()}. Load average (1, 5, 15 min) before and after:
{before} -> {after}. Every figure is the wall time of fresh processes: the median of
{args.repeat} (after one unmeasured run) for the first rows; for the *cold* rows, the median
of {args.cold_repeat} runs, each with its own empty numba cache (`NUMBA_CACHE_DIR`), i.e. a
first run in a fresh environment (the target is checked on the slowest of them).

| what | seconds | target |
|---|---|---|
{table}

`import lpbounds` loads its public names on first use (PEP 562), so it costs less than
numpy; the subcommands import numpy, cvxpy, matplotlib and the models inside their `run`.
Every Bellman-row kernel (exact DP's sweeps, the RLP's aggregation here, the NLP's game
operator, the post-decision form) is C, built at install, at every model size, so a first
solve compiles nothing (a first solve with the kernels forced to numba's took 21.8 s while
they were; `benchmarks/bench_kernels.py` times a cold first RLP of a larger model on both).
"""


if __name__ == "__main__":
    main()
