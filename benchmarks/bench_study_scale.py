"""A solver study of the paper's own LPs at the paper's size.

UBLP and LBLP (Theorems 4 and 3), the RLP of the patrol partition (M = 8,900) and the ELP
(2,048,000 states, about 4.65M rows) of ``models/patrol-paper.toml``, each solved by HiGHS
IPM, HiGHS PDLP, Clarabel and SCS through :func:`lpbounds.studies.compare.run_task` (the same code
as ``lpbounds compare``) under a time limit per solve (default 120 s, passed in each
solver's own keyword). Each solve runs alone in a fresh process, one after the other, so
its time and peak memory are its own; a process that outlives ``--hard-timeout`` (Clarabel
and OSQP do not count their setup and factorisation against their own limit) or grows past
``--max-gb`` is killed and recorded as ``time_limit`` / ``solver_error`` without a point.
ELP runs last.

Writes the table, the per-solver summary and the two performance profiles (PNG under
``docs/img/``) to the ``study-scale`` section of ``docs/benchmarks.md``, and the raw table
to ``benchmarks/results/study_scale.csv``.

Usage::

    python benchmarks/bench_study_scale.py [--time-limit 120] [--formulations UBLP LBLP RLP ELP]
        [--solvers HIGHS:ipm HIGHS:pdlp CLARABEL SCS] [--model models/patrol-paper.toml]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

from _common import machine, today, write_section

ROOT = Path(__file__).resolve().parents[1]
IMG = ROOT / "docs" / "img"
RESULTS = ROOT / "benchmarks" / "results"

CHILD = r"""
import json, resource, sys, time
from lpbounds.studies.compare import Task, run_task, solver_configs
spec, form, cfg_name, limit = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
cfg = next(c for c in solver_configs([cfg_name])[0] if c.label == cfg_name.replace(":default", ""))
t0 = time.perf_counter()
rec = run_task(Task(spec, form, cfg, 1, 1e-6, limit))[0]
rec["process_seconds"] = time.perf_counter() - t0
rec["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print("__RECORD__" + json.dumps(rec, default=float))
"""


def _rss_mb(pid: int) -> float:
    """Resident set size of ``pid`` and its children (MB); 0 when it is gone."""
    total = 0.0
    try:
        out = subprocess.run(
            ["ps", "-o", "rss=", "--ppid", str(pid), "-p", str(pid)],
            capture_output=True,
            text=True,
            check=False,
        ).stdout
        total = sum(float(x) for x in out.split()) / 1024
    except (OSError, ValueError):
        pass
    return total


def solve_isolated(
    spec: str, form: str, cfg: str, limit: float, hard: float, max_gb: float
) -> dict:
    """One solve in a fresh process, killed past ``hard`` seconds or ``max_gb`` GB."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, spec, form, cfg, str(limit)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    peak, killed = 0.0, ""
    while proc.poll() is None:
        time.sleep(1.0)
        peak = max(peak, _rss_mb(proc.pid))
        if time.perf_counter() - t0 > hard:
            killed = f"killed after {hard:.0f} s (setup and solve outlived the limit)"
        elif peak > max_gb * 1024:
            killed = f"killed at {peak / 1024:.1f} GB resident (above --max-gb {max_gb:g})"
        if killed:
            proc.kill()
            break
    stdout, stderr = proc.communicate()
    wall = time.perf_counter() - t0
    line = next((ln for ln in stdout.splitlines() if ln.startswith("__RECORD__")), None)
    if line is not None:
        rec = json.loads(line[len("__RECORD__") :])
        rec["peak_rss_mb"] = max(float(rec.get("peak_rss_mb") or 0.0), peak)
        return rec
    status = "time_limit" if killed.startswith("killed after") else "solver_error"
    note = killed or f"process failed: {stderr.strip().splitlines()[-1:] or ['?']}"
    return {
        "instance": Path(spec).stem,
        "formulation": form,
        "config": cfg,
        "solver": cfg.split(":")[0],
        "status": status,
        "certified_error": math.inf,
        "rel_error": math.inf,
        "accurate": False,
        "solve_seconds": wall,
        "wall_seconds": wall,
        "process_seconds": wall,
        "peak_rss_mb": peak,
        "note": note,
    }


def _fmt(x: object, spec: str) -> str:
    try:
        v = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return "-"
    return "-" if not math.isfinite(v) else format(v, spec)


def _table(frame) -> str:
    head = (
        "| LP | rows | solver | status | cert. error (rel.) | max dev | compile s | solve s "
        "| process s | peak GB | iter |\n|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|\n"
    )
    lines = []
    for r in frame.itertuples(index=False):
        lines.append(
            f"| {r.formulation} | {_fmt(r.n_rows, ',.0f')} | {r.config} | {r.status} | "
            f"{_fmt(r.certified_error, '.1e')} ({_fmt(r.rel_error, '.0e')}) | "
            f"{_fmt(r.max_deviation, '.1e')} | {_fmt(r.compile_seconds, '.1f')} | "
            f"{_fmt(r.solve_seconds, '.1f')} | {_fmt(r.process_seconds, '.0f')} | "
            f"{_fmt(float(r.peak_rss_mb) / 1024, '.1f')} | {_fmt(r.iterations, '.0f')} |"
        )
    return head + "\n".join(lines)


def _summary(frame, limit: float) -> str:
    from lpbounds.studies.report import solver_summary

    s = solver_summary(frame, (10.0, 1.0), time_limit=limit)
    head = (
        "| solver | backend | solved | optimal | inaccurate | time limit | failed "
        "| SGM time (10 s) | SGM time (1 s) |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n"
    )
    rows = [
        f"| {r.config} | {r.backend} | {r.solved}/{r.problems} | {r.optimal} | {r.inaccurate} "
        f"| {r.time_limit} | {r.failed + r.other_limit} | {r.sgm_10s:.2f} | {r.sgm_1s:.2f} |"
        for r in s.itertuples(index=False)
    ]
    return head + "\n".join(rows)


def _notes(frame) -> str:
    """One line per solve that did not end optimal, with what it said (killed, crashed)."""
    lines = []
    for r in frame.itertuples(index=False):
        note = str(r.note) if isinstance(r.note, str) else ""
        if r.status != "optimal" and note:
            lines.append(f"* {r.formulation} {r.config}: {r.status}: {note[:200]}")
    return "\n".join(lines)


def _run(args: argparse.Namespace, hard: float) -> tuple[list[dict], dict]:
    """Every (formulation, solver) in its own process, ELP last; results saved as they come."""
    import pandas as pd

    forms = [f for f in args.formulations if f != "ELP"]
    forms += [f for f in args.formulations if f == "ELP"]  # ELP last: the largest
    meta = {"date": today(), "machine": machine(), "load_start": os.getloadavg()[0]}
    records: list[dict] = []
    t0 = time.perf_counter()
    RESULTS.mkdir(parents=True, exist_ok=True)
    for form in forms:
        for cfg in args.solvers:
            rec = solve_isolated(args.model, form, cfg, args.time_limit, hard, args.max_gb)
            records.append(rec)
            print(
                f"{form:5s} {cfg:12s} {rec['status']:12s} cert.err {rec.get('certified_error')} "
                f"solve {rec.get('solve_seconds')} peak {rec.get('peak_rss_mb', 0):.0f} MB "
                f"{(rec.get('note') or '')[:120]}",
                flush=True,
            )
            pd.DataFrame.from_records(records).to_csv(RESULTS / "study_scale.csv", index=False)
    meta.update(load_end=os.getloadavg()[0], seconds=time.perf_counter() - t0)
    meta.update(model=Path(args.model).name, time_limit=args.time_limit, hard=hard)
    meta["max_gb"] = args.max_gb
    (RESULTS / "study_scale.json").write_text(json.dumps(meta, indent=2) + "\n")
    return records, meta


def _write(frame, meta: dict) -> str:
    """The profiles under docs/img/ and the ``study-scale`` section of docs/benchmarks.md."""
    from lpbounds.studies.profiles import plot_performance_profile
    from lpbounds.studies.report import profile_tables

    time_table, acc_table = profile_tables(frame)
    IMG.mkdir(parents=True, exist_ok=True)
    labels = {c: f"{c}: {b}" for c, b in zip(frame["config"], frame["backend"], strict=True)}
    for table, name, what in (
        (time_table, "time", "solve time"),
        (acc_table, "accuracy", "certified error"),
    ):
        plot_performance_profile(
            table,
            IMG / f"study-scale-{name}.png",
            title=f"Paper-size LPs: {what}",
            measure=what,
            labels=labels,
        )
    body = (
        "## Solver study at the paper's size (`benchmarks/bench_study_scale.py`)\n\n"
        f"{meta['date']}; {meta['machine']}. Load average {meta['load_start']:.1f} at the "
        f"start, {meta['load_end']:.1f} at the end (2 cores shared with other work: times are "
        f"noisy). Model `{meta['model']}`; time limit {meta['time_limit']:g} s per solve in "
        f"each solver's own keyword; a process is killed after {meta['hard']:.0f} s or "
        f"{meta['max_gb']:g} GB. Each solve alone in a fresh process, through cvxpy "
        f"(`lpbounds.studies.compare.run_task`, as `lpbounds compare`); {len(frame)} solves in "
        f"{meta['seconds']:.0f} s. Raw table: `benchmarks/results/study_scale.csv`.\n\n"
        "Cert. error: lpbounds' certified bound on max |values - exact optimum| of the "
        "returned point (relative: / (max|R|/(1-lambda))); max dev: against the exact fixed "
        "point; a point returned at the time limit keeps its certified error. Solved = "
        "certified within 1e-6 relative. Process s: the whole process (building the MDP, the "
        "exact reference by DP, the LP, cvxpy's compilation, the solve, the certificate).\n\n"
        + _table(frame)
        + "\n\n"
        + _notes(frame)
        + "\n\n"
        + _summary(frame, meta["time_limit"])
        + "\n\nShifted geometric means (SGM) of solve time, unsolved charged the time limit.\n\n"
        "![time profile](img/study-scale-time.png)\n"
        "![accuracy profile](img/study-scale-accuracy.png)\n"
    )
    write_section("study-scale", body)
    return body


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=str(ROOT / "models" / "patrol-paper.toml"))
    ap.add_argument("--formulations", nargs="+", default=["UBLP", "LBLP", "RLP", "ELP"])
    ap.add_argument("--solvers", nargs="+", default=["HIGHS:ipm", "HIGHS:pdlp", "CLARABEL", "SCS"])
    ap.add_argument("--time-limit", type=float, default=120.0)
    ap.add_argument(
        "--hard-timeout",
        type=float,
        default=None,
        help="seconds before a solve's process is killed (default 2 x limit + 300)",
    )
    ap.add_argument("--max-gb", type=float, default=7.0)
    ap.add_argument("--no-write", action="store_true", help="print, do not touch docs/")
    ap.add_argument(
        "--from-results",
        action="store_true",
        help="rewrite the section and profiles from benchmarks/results/study_scale.csv and "
        ".json (the last run) without solving",
    )
    args = ap.parse_args()
    import pandas as pd

    hard = args.hard_timeout or 2 * args.time_limit + 300
    if args.from_results:
        frame = pd.read_csv(RESULTS / "study_scale.csv")
        meta = json.loads((RESULTS / "study_scale.json").read_text())
    else:
        records, meta = _run(args, hard)
        frame = pd.DataFrame.from_records(records)
    for col in ("backend", "n_rows", "max_deviation", "compile_seconds", "iterations", "note"):
        if col not in frame:
            frame[col] = None
    frame["backend"] = frame["backend"].fillna(frame["solver"])
    if args.no_write:
        print(_table(frame) + "\n\n" + _notes(frame) + "\n\n" + _summary(frame, args.time_limit))
        return
    print(_write(frame, meta))


if __name__ == "__main__":
    main()
