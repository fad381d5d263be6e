"""Start-up benchmark: ``lpbounds --help``, ``import lpbounds``, whole commands and a first
solve, each in fresh processes; with ``--fresh-venv``, the first ``lpbounds reproduce`` in
a new virtual environment against the second.

Targets: ``lpbounds --help`` and every ``lpbounds SUBCOMMAND --help`` within 0.3 s;
``import lpbounds`` within 0.1 s of ``import numpy, scipy.sparse``; the whole processes of
``lpbounds solve forest``, ``lpbounds models`` and ``lpbounds solve
models/garnet-small.toml`` within 1.5x of ``python -c "import numpy, scipy.sparse"``
(medians of runs alternated with it, so a loaded machine slows both alike); the first
solve of a small model within 3 s; the first ``lpbounds reproduce`` in a fresh virtual
environment within 1.15x of the second (the kernels are C, built at install: the first
run differs by the disk cache only). Writes the ``startup`` section of docs/benchmarks.md.

    python benchmarks/bench_startup.py [--repeat 7] [--fresh-venv] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import machine, today, write_section

from lpbounds.cli.main import COMMANDS

ROOT = Path(__file__).resolve().parents[1]
HELP_TARGET = 0.3
IMPORT_MARGIN = 0.1
COMMAND_RATIO = 1.5
FIRST_SOLVE_TARGET = 3.0
FIRST_REPRODUCE_RATIO = 1.15

#: The whole commands timed against ``import numpy, scipy.sparse`` (exact DP and listings:
#: none needs the LP stack, figures or tables).
WHOLE_COMMANDS: tuple[tuple[str, ...], ...] = (
    ("solve", "forest"),
    ("models",),
    ("solve", "models/garnet-small.toml"),
)

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


def alternated(runs: dict[str, list[str]], repeat: int) -> dict[str, float]:
    """Median wall seconds of each command, the commands run in turn ``repeat`` times (after
    one unmeasured round: the OS file cache, .pyc files), so that the machine's load falls
    on all of them alike."""
    for argv in runs.values():
        wall(argv)
    times: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(repeat):
        for name, argv in runs.items():
            times[name].append(wall(argv))
    return {name: statistics.median(ts) for name, ts in times.items()}


def fresh_venv_reproduce(rounds: int) -> list[tuple[float, float, str]]:
    """(first, second) wall seconds of ``lpbounds reproduce`` (the paper's instance, the
    README's first command, without figures) in ``rounds`` new virtual environments, each
    with lpbounds installed from a wheel built here, and what ``pip show numba`` said."""
    out = []
    with tempfile.TemporaryDirectory(prefix="lpbounds-fresh-") as tmp:
        dist = Path(tmp, "dist")
        subprocess.run(
            [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist), str(ROOT)],
            check=True,
        )
        (wheel,) = dist.glob("lpbounds-*.whl")
        for r in range(rounds):
            venv = Path(tmp, f"venv{r}")
            subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
            py = str(venv / "bin" / "python")
            subprocess.run([py, "-m", "pip", "install", "-q", str(wheel)], check=True)
            show = subprocess.run(
                [py, "-m", "pip", "show", "numba"], capture_output=True, text=True
            )
            numba = "not installed" if show.returncode else "installed"
            argv = [str(venv / "bin" / "lpbounds"), "reproduce", "--no-figures", "-q"]
            first = wall([*argv, "--out", str(Path(tmp, f"out{r}a"))])
            second = wall([*argv, "--out", str(Path(tmp, f"out{r}b"))])
            print(f"fresh venv {r}: first {first:.2f} s, second {second:.2f} s, numba {numba}")
            out.append((first, second, numba))
    return out


def load_average() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover - not on this platform
        return "n/a"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--first-repeat", type=int, default=3, help="runs of each first solve")
    ap.add_argument(
        "--fresh-venv", type=int, default=0, metavar="N",
        help="also time the first and second reproduce in N new virtual environments",
    )  # fmt: skip
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    os.chdir(ROOT)  # models/garnet-small.toml
    load_before = load_average()
    py = sys.executable
    rows: list[tuple[str, float, str]] = []

    def add(name: str, seconds: float, target: str) -> None:
        rows.append((name, seconds, target))
        print(f"{name:<48} {seconds:7.3f} s  {target}", flush=True)

    base = median_wall([py, "-c", "pass"], args.repeat)
    add("python -c pass", base, "")
    imp = median_wall([py, "-c", "import lpbounds"], args.repeat)
    cmd = lpbounds_command()
    numpy_scipy = 'python -c "import numpy, scipy.sparse"'
    runs = {numpy_scipy: [py, "-c", "import numpy, scipy.sparse"]}
    runs.update({f"lpbounds {' '.join(c)}": [*cmd, *c] for c in WHOLE_COMMANDS})
    whole = alternated(runs, args.repeat)
    np_sp = whole.pop(numpy_scipy)
    add(numpy_scipy, np_sp, "")
    ok = imp <= np_sp + IMPORT_MARGIN
    add('python -c "import lpbounds"', imp, f"<= {np_sp + IMPORT_MARGIN:.3f}: {_met(ok)}")
    for name, t in whole.items():
        ratio = t / np_sp
        add(name, t, f"{ratio:.2f}x; <= {COMMAND_RATIO}x: {_met(ratio <= COMMAND_RATIO)}")
    for sub in ("", *COMMANDS):
        argv = [*cmd, *([sub] if sub else []), "--help"]
        t = median_wall(argv, args.repeat)
        add(
            f"lpbounds {sub + ' ' if sub else ''}--help",
            t,
            f"<= {HELP_TARGET}: {_met(t <= HELP_TARGET)}",
        )
    first_rows = [("tutorial blocks 1-2 (4 states, solve_exact)", TUTORIAL)]
    first_rows.append(("garnet(300, 3, 4): solve_exact + RLP (HiGHS)", GARNET_RLP))
    for name, code in first_rows:
        ts = [wall([py, "-c", code]) for _ in range(args.first_repeat)]
        ok = max(ts) <= FIRST_SOLVE_TARGET
        add(f"first solve: {name}", statistics.median(ts), f"<= {FIRST_SOLVE_TARGET}: {_met(ok)}")
    fresh = fresh_venv_reproduce(args.fresh_venv) if args.fresh_venv else []
    for i, (first, second, numba) in enumerate(fresh):
        ratio = first / second
        ok = ratio <= FIRST_REPRODUCE_RATIO
        add(f"fresh venv {i + 1}: first reproduce", first, f"numba {numba}")
        add(
            f"fresh venv {i + 1}: second reproduce",
            second,
            f"first / second {ratio:.2f}; <= {FIRST_REPRODUCE_RATIO}: {_met(ok)}",
        )
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
        f"| {name if name.startswith(('first', 'fresh')) else f'`{name}`'} | {sec:.3f} | {target} |"
        for name, sec, target in rows
    )
    return f"""## Start-up: `--help`, `import lpbounds`, whole commands and a first solve

Machine: {machine()}. Date: {today()}. Load average (1, 5, 15 min) before and after:
{before} -> {after}. Every figure is the wall time of fresh processes
(`benchmarks/bench_startup.py`): the median of {args.repeat} (after one unmeasured run);
the whole commands and `import numpy, scipy.sparse` ran in turn, {args.repeat} rounds, so
the machine's load fell on all alike, and their ratio to it is the target; the first
solves are the median of {args.first_repeat} runs (the target checked on the slowest).
With `--fresh-venv N`, the README's first command, `lpbounds reproduce` (the paper's
instance, here without figures), ran twice in each of N new virtual environments with
lpbounds installed from its wheel: a first run against the second.

| what | seconds | target |
|---|---|---|
{table}

`import lpbounds` loads its public names on first use (PEP 562), as the packages do (the
formulations, the NLP, the patrol: `lpbounds._lazy`), so a command imports what its work
needs: exact DP and the model listing load no cvxpy, scipy.stats, HiGHS, Clarabel,
matplotlib, pandas, Gymnasium or Dask (`tests/cli/test_startup.py` fails if they do). Every
kernel is C, built at install: nothing is compiled at run time, so a first solve costs
what any solve does, and numba is no dependency (`pip show numba` in the fresh
environments above).
"""


if __name__ == "__main__":
    main()
