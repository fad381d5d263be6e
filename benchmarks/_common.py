"""Shared by the benchmark scripts: machine description, timing in a fresh process, and
writing one marked section of docs/benchmarks.md."""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import re
import subprocess
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md"
HEADER = """# Benchmarks

Each section below is written by one script in `benchmarks/` (run it to refresh the
section; the others are left as they are). Times are medians over repetitions unless a
section says otherwise; peak memory is the peak resident set size of a fresh process
that does only the measured work. Timings are never asserted in tests.
"""


#: Source text for a benchmark's child process (after ``import time, numpy as np``): this
#: machine's read and copy bandwidth in plain numpy, no compiler. ``read_sum(a, k)`` sums
#: ``a`` and ``copy(a, b, k)`` copies it into ``b``, each as ``k`` equal slices on ``k``
#: threads (``np.add.reduce`` and ``np.copyto`` release the GIL in their loops, so the
#: slices stream at once; on 512 MB arrays the caches play no part). ``best(f, reps)``: the
#: minimum and median seconds of ``reps`` calls. Beside the numba loops it replaced
#: (2026-12-03, Xeon, 2 cores, load 6.5, 512 MB, best of 7, two rounds), in GB/s: read
#: 10.1-11.0 (numba 11.0-11.2) on one thread, 10.0-14.9 (10.3-10.7) on two; copy 15.5-17.0
#: (15.4-16.9) on one, 15.0-16.5 (14.1-15.1) on two: the same floor within the noise.
BANDWIDTH_PROBE = r"""
from concurrent.futures import ThreadPoolExecutor

_pools = {}

def _slices(n, k):
    return [slice(i * n // k, (i + 1) * n // k) for i in range(k)]

def _on_threads(k, tasks):
    if k == 1:
        return [t() for t in tasks]
    pool = _pools.setdefault(k, ThreadPoolExecutor(max_workers=k))
    return [f.result() for f in [pool.submit(t) for t in tasks]]

def read_sum(a, k=1):
    parts = _on_threads(k, [lambda s=s: np.add.reduce(a[s]) for s in _slices(a.shape[0], k)])
    return float(sum(parts))

def copy(a, b, k=1):
    _on_threads(k, [lambda s=s: np.copyto(b[s], a[s]) for s in _slices(a.shape[0], k)])

def best(f, reps):
    ts = []
    for _ in range(reps):
        t = time.perf_counter(); f(); ts.append(time.perf_counter() - t)
    return min(ts), float(np.median(ts))
"""


def machine() -> str:
    """One line describing this machine, Python and the key libraries."""
    cpu = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(Path("/proc/meminfo").read_text().split()[1])
        mem = f", {kb / 2**20:.0f} GiB RAM"
    except (OSError, ValueError, IndexError):
        pass
    import numpy

    return (
        f"{cpu}, {os.cpu_count()} cores{mem}; {platform.system()} {platform.release()}; "
        f"Python {platform.python_version()}, numpy {numpy.__version__}"
    )


def today() -> str:
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def run_isolated(code: str, timeout: float = 1800) -> dict:
    """Run ``code`` in a fresh interpreter; it must print one JSON object as its last line.

    Adds ``peak_rss_mb`` (the child's peak resident set size).
    """
    wrapper = (
        code
        + "\nimport resource as _r, json as _j\n"
        + "print('__PEAK__', _r.getrusage(_r.RUSAGE_SELF).ru_maxrss / 1024)\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", wrapper], capture_output=True, text=True, timeout=timeout
    )
    if proc.returncode != 0:
        raise RuntimeError(f"benchmark child failed:\n{proc.stderr[-3000:]}")
    lines = [ln for ln in proc.stdout.splitlines() if ln.strip()]
    peak = float(lines[-1].split()[1])
    out = json.loads(lines[-2])
    out["peak_rss_mb"] = peak
    return out


def write_section(name: str, body: str, page: Path = DOCS) -> None:
    """Replace (or append) the section between ``<!-- name:start -->`` and ``<!-- name:end -->``
    of ``page`` (docs/benchmarks.md unless another page of docs/ holds the section)."""
    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    text = page.read_text() if page.exists() else HEADER
    block = f"{start}\n{body.rstrip()}\n{end}"
    pattern = re.compile(re.escape(start) + r".*?" + re.escape(end), re.S)
    text = (
        pattern.sub(lambda _: block, text)
        if pattern.search(text)
        else text.rstrip() + "\n\n" + block + "\n"
    )
    page.parent.mkdir(parents=True, exist_ok=True)
    page.write_text(text)
