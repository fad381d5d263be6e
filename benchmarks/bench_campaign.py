"""Throughput of a verification campaign: serially, on Dask's threads, on a 2-worker cluster.

One campaign (:func:`lpbounds.studies.campaign.run_campaign`) of ``--n`` random instances
(default 1,000, seed 0, every family) x the built-in claims x HiGHS and Clarabel, run once
per mode into its own folder (``--out``/MODE): ``serial`` (this process), ``threads``
(Dask's threads scheduler) and ``cluster`` (a ``dask.distributed.LocalCluster`` of 2
single-threaded worker processes, its address passed as ``--scheduler`` would be). Each
mode's folder is removed first, so every run computes every batch.

Reports per mode the wall-clock seconds, instances and records per second, and the
verdict counts; checks that the three modes gave the same records (all columns but the
solve timings) and that no record is *violated*. Writes
``benchmarks/results/campaign.json`` and the ``campaign`` section of
``docs/benchmarks.md``.

Usage::

    python benchmarks/bench_campaign.py [--n 1000] [--seed 0] [--modes cluster threads serial]
        [--out out/bench-campaign] [--batch-size 10]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from pathlib import Path

from _common import machine, today, write_section

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
SOLVERS = ["HIGHS", "CLARABEL"]


def _progress(mode: str, t0: float):
    def report(done: int, total: int, note: str) -> None:
        print(f"[{mode} {time.perf_counter() - t0:7.1f} s] {done}/{total} {note}", flush=True)

    return report


def run_mode(mode: str, args: argparse.Namespace) -> dict:
    """One campaign in ``mode``; its numbers."""
    from lpbounds.studies.campaign import run_campaign

    out = Path(args.out) / mode
    shutil.rmtree(out, ignore_errors=True)
    cluster = None
    started = 0.0
    scheduler: str | None = None
    if mode == "threads":
        scheduler = "threads"
    elif mode == "cluster":
        from dask.distributed import LocalCluster

        t = time.perf_counter()
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True)
        started = time.perf_counter() - t
        scheduler = cluster.scheduler_address
    try:
        t0 = time.perf_counter()
        result = run_campaign(
            args.n,
            args.seed,
            solvers=SOLVERS,
            out=out,
            batch_size=args.batch_size,
            scheduler=scheduler,
            progress=_progress(mode, t0),
        )
        seconds = time.perf_counter() - t0
    finally:
        if cluster is not None:
            cluster.close()
    load = os.getloadavg()
    return {
        "mode": mode,
        "scheduler": scheduler or "serial",
        "seconds": seconds,
        "cluster_start_seconds": started,
        "instances": args.n,
        "records": len(result.frame),
        "instances_per_second": args.n / seconds,
        "records_per_second": len(result.frame) / seconds,
        "verdicts": result.verdicts(),
        "counterexamples": len(result.counterexamples),
        "load_after": list(load),
        "out": str(out),
    }


def same_records(folders: list[Path]) -> bool:
    """True when the campaigns in ``folders`` have the same records but for the timings."""
    import pandas as pd

    from lpbounds.studies.campaign import TIMING_COLUMNS, read_records

    frames = [read_records(f).drop(columns=list(TIMING_COLUMNS)) for f in folders]
    for other in frames[1:]:
        try:
            pd.testing.assert_frame_equal(frames[0], other)
        except AssertionError:
            return False
    return True


def _section(rows: list[dict], identical: bool | None, args: argparse.Namespace, date: str) -> str:
    lines = [
        "## Verification campaigns: throughput",
        "",
        f"`python benchmarks/bench_campaign.py --n {args.n} --seed {args.seed}`; {date}; "
        f"{machine()}.",
        "",
        f"One campaign of {args.n:,} random instances (every family: garnets, masked garnets, "
        "the shelf, small patrol instances; discounts 0 to 0.9999, reward scales 1e-6 to 1e6, "
        "five partition kinds) x the built-in claims (Lemma 1, Theorems 1-2, Lemma 2, "
        f"Remark 2) x HiGHS and Clarabel, batches of {args.batch_size}, written to disk per "
        "batch. The machine is shared (load average after each run in the table).",
        "",
        "| mode | seconds | instances/s | records/s | holds | inconclusive | violated | load |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        v = r["verdicts"]
        lines.append(
            f"| {r['mode']} | {r['seconds']:.0f} | {r['instances_per_second']:.2f} | "
            f"{r['records_per_second']:.1f} | {v['holds']:,} | {v['inconclusive']:,} | "
            f"{v['violated']:,} | {r['load_after'][0]:.1f} |"
        )
    lines.append("")
    cluster = [r for r in rows if r["mode"] == "cluster"]
    if cluster:
        lines.append(
            f"The cluster is a `LocalCluster(n_workers=2, threads_per_worker=1)` (started in "
            f"{cluster[0]['cluster_start_seconds']:.1f} s, not counted), addressed as "
            "`--scheduler tcp://...` would be."
        )
    serial = [r for r in rows if r["mode"] == "serial"]
    if serial and len(rows) > 1:
        base = serial[0]["seconds"]
        ups = ", ".join(
            f"{r['mode']} {base / r['seconds']:.2f}x" for r in rows if r is not serial[0]
        )
        lines.append(
            f"Speed-up over serial: {ups}. Threads share the GIL with cvxpy's compilation of "
            "each LP (Python), so they interleave more than they overlap; a cluster's workers "
            "gain only from cores no other job uses (the load average counts the runnable jobs)."
        )
    if identical is not None:
        lines.append(
            "The modes gave the same records (every column but the solve timings): "
            f"{'yes' if identical else 'NO'}."
        )
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--n", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--batch-size", type=int, default=10)
    parser.add_argument("--modes", nargs="+", default=["cluster", "threads", "serial"])
    parser.add_argument("--out", default=str(ROOT / "out" / "bench-campaign"))
    parser.add_argument("--no-docs", action="store_true", help="do not write docs/benchmarks.md")
    parser.add_argument(
        "--from-results",
        action="store_true",
        help="only rewrite the docs section from benchmarks/results/campaign.json",
    )
    args = parser.parse_args()
    if args.from_results:
        saved = json.loads((RESULTS / "campaign.json").read_text())
        args.n, args.seed, args.batch_size = saved["n"], saved["seed"], saved["batch_size"]
        write_section(
            "campaign", _section(saved["modes"], saved["same_records"], args, saved["date"])
        )
        return 0
    rows = []
    for mode in args.modes:
        rows.append(run_mode(mode, args))
        print(json.dumps(rows[-1]), flush=True)
    identical = same_records([Path(r["out"]) for r in rows]) if len(rows) > 1 else None
    result = {
        "date": today(),
        "machine": machine(),
        "n": args.n,
        "seed": args.seed,
        "batch_size": args.batch_size,
        "solvers": SOLVERS,
        "modes": rows,
        "same_records": identical,
    }
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "campaign.json").write_text(json.dumps(result, indent=2) + "\n")
    if not args.no_docs:
        write_section("campaign", _section(rows, identical, args, result["date"]))
    violated = sum(r["verdicts"]["violated"] for r in rows)
    print(f"violated records: {violated}; same records across modes: {identical}")
    return 1 if violated or identical is False else 0


if __name__ == "__main__":
    sys.exit(main())
