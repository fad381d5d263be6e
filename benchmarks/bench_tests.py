"""The README's test command, timed: ``python -m pytest -n 2`` as a whole process, with its
test count and the machine's load. Target: under 10 minutes on a quiet 2-core machine.
Writes the ``test-suite`` section of docs/benchmarks.md.

    python benchmarks/bench_tests.py [--no-write] [-- extra pytest arguments]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

from _common import machine, today, write_section

ROOT = Path(__file__).resolve().parents[1]
TARGET_MINUTES = 10.0
COMMAND = [sys.executable, "-m", "pytest", "-n", "2"]


def load_average() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def counts(summary: str) -> dict[str, int]:
    """``{"passed": 1718, "skipped": 3, ...}`` from pytest's closing line."""
    return {word: int(n) for n, word in re.findall(r"(\d+) (\w+)", summary)}


def slow_tests() -> int:
    """Tests marked ``slow`` (left out by the default options; ``-m slow`` runs them)."""
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-m", "slow"],
        cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    return sum("::" in line for line in proc.stdout.splitlines())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument("pytest_args", nargs="*", help="more pytest arguments (after --)")
    args = ap.parse_args()
    n_slow = slow_tests()
    before = load_average()
    t = time.perf_counter()
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(
        [*COMMAND, "-q", *args.pytest_args], cwd=ROOT, capture_output=True, text=True
    )
    minutes = (time.perf_counter() - t) / 60
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)  # pytest, its workers, their children
    cpu = (cpu1.ru_utime - cpu0.ru_utime + cpu1.ru_stime - cpu0.ru_stime) / 60
    after = load_average()
    lines = [ln for ln in proc.stdout.splitlines() if ln.strip()]
    summary = lines[-1].strip("= ") if lines else ""
    seed = next((ln for ln in proc.stdout.splitlines() if "randomly-seed" in ln), "")
    print(proc.stdout[-3000:])
    print(f"{minutes:.2f} min; CPU {cpu:.2f} min; load {before} -> {after}; exit {proc.returncode}")
    if proc.returncode != 0:
        sys.exit(f"the suite failed (exit {proc.returncode}); nothing written")
    n = counts(summary)
    ok = minutes < TARGET_MINUTES
    body = f"""## Test suite: the README's test command

Machine: {machine()}. Date: {today()}. Load average (1, 5, 15 min) before and after:
{before} -> {after} (`nproc` = {os.cpu_count()}; a load above it means other jobs shared
the cores, and the time scales with it).

`python -m pytest -n 2` (`benchmarks/bench_tests.py`), a whole process: **{minutes:.1f} min**
(target under {TARGET_MINUTES:.0f} min on a quiet machine: {"met" if ok else "**missed**"}
here), {cpu:.1f} CPU minutes (user and system time of pytest, its two workers and every
process they started: on a quiet 2-core machine the wall time is about half of it, or more
where one worker waits for the other at the end); {n.get("passed", 0):,} tests passed,
{n.get("skipped", 0)} skipped; {n_slow} more are marked `slow` (full-size runs, left out by
the default options: `-m slow` runs them). pytest's summary: `{summary}`. {seed.strip()}
"""
    if not args.no_write:
        write_section("test-suite", body)


if __name__ == "__main__":
    main()
