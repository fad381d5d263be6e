"""Export benchmark: ``lpbounds export`` from tiny LPs to the paper's ELP and beyond, and
``lpbounds score`` of each export's own optimum, each in a fresh process (time per step,
peak memory, file sizes, the certified error of the exported optimum). Writes the
``export`` section of docs/benchmarks.md.

    python benchmarks/bench_export.py [--quick] [--keep DIR] [--no-write]

``--quick`` runs only the exports that take seconds. The full run needs about 3.5 GB of
memory at its peak (the RLP of garnet-paper-scale) and 2.8 GB of disk while it runs.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
from pathlib import Path

from _common import machine, run_isolated, today, write_section

#: (model, formulation, quick): tiny to the paper's instance and beyond.
SIZES: tuple[tuple[str, str, bool], ...] = (
    ("garnet:100:10:1", "RLP", True),
    ("garnet-small", "ELP", True),
    ("garnet-small", "IB", True),
    ("patrol-small", "UBLP", True),
    ("patrol-paper", "UBLP", True),
    ("patrol-paper", "LBLP", True),
    ("patrol-m8", "UBLP", False),
    ("patrol-paper", "ELP", False),
    ("garnet-paper-scale", "RLP", False),
)

EXPORT = """
import json, time
from lpbounds.studies.export import export_lp
t0 = time.perf_counter()
res = export_lp({model!r}, {formulation!r}, {out!r})
s = res.sidecar
print(json.dumps({{"seconds": res.seconds, "wall": time.perf_counter() - t0,
                  "sizes": s["sizes"], "error": s["optimum"]["certificate"]["error_bound"],
                  "relative": s["optimum"]["certificate"]["relative_error"]}}))
"""

SCORE = """
import json, time
from lpbounds.studies.export import score_solution
t0 = time.perf_counter()
sc = score_solution({out!r}, {solution!r})
print(json.dumps({{"wall": time.perf_counter() - t0, "certified": sc.certified_error,
                  "deviation": sc.max_deviation}}))
"""


def _load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def measure(model: str, formulation: str, root: Path) -> dict:
    out = root / f"{model.replace(':', '_')}-{formulation.lower()}"
    exp = run_isolated(EXPORT.format(model=model, formulation=formulation, out=str(out)))
    exp["mps_mb"] = (out / "lp.mps").stat().st_size / 2**20
    sc = run_isolated(SCORE.format(out=str(out), solution=str(out / "optimum.npy")))
    assert sc["deviation"] == 0.0 and sc["certified"] == exp["error"], (sc, exp)
    return {"model": model, "formulation": formulation, "export": exp, "score": sc}


def table(rows: list[dict]) -> str:
    head = (
        "| export | rows | columns | nonzeros | lp.mps | build | optimum | write MPS | total "
        "| peak | certified error (relative) | score | score peak |\n"
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    )
    lines = []
    for r in rows:
        e, s, z = r["export"], r["export"]["seconds"], r["score"]
        sz = e["sizes"]
        lines.append(
            f"| `{r['model']}` {r['formulation']} | {sz['rows']:,} | {sz['columns']:,} | "
            f"{sz['nonzeros']:,} | {e['mps_mb']:,.1f} MB | {s['build']:.1f} s | "
            f"{s['optimum']:.1f} s | {s['write_model']:.1f} s | {e['wall']:.1f} s | "
            f"{e['peak_rss_mb'] / 1024:.2f} GB | {e['error']:.1e} ({e['relative']:.0e}) | "
            f"{z['wall']:.1f} s | {z['peak_rss_mb'] / 1024:.2f} GB |"
        )
    return head + "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="only the exports that take seconds")
    ap.add_argument("--keep", metavar="DIR", help="keep the exports in DIR")
    ap.add_argument("--no-write", action="store_true", help="print, do not write the docs")
    args = ap.parse_args()
    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench-export-"))
    root.mkdir(parents=True, exist_ok=True)
    load_before = _load()
    rows = []
    try:
        for model, formulation, quick in SIZES:
            if args.quick and not quick:
                continue
            rows.append(measure(model, formulation, root))
            print(json.dumps(rows[-1]), flush=True)
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)
    body = (
        "## LP library export (`lpbounds export`, benchmarks/bench_export.py)\n\n"
        f"{machine()}; {today()}; load average before {load_before}, after {_load()} "
        "(1, 5, 15 min). One run per export, each in a fresh process (times include "
        "start-up and imports); `score` scores the export's own optimum.npy (deviation 0, "
        "certified error equal to the sidecar's, checked).\n\n"
        + table(rows)
        + "\n\nbuild: the formulation (rows and sparse A; includes the first import of cvxpy, "
        "about 2.5 s); optimum: the exact DP to "
        "EXPORT_DP_RTOL and its certificate; write MPS: HiGHS' writer; certified error: "
        "absolute bound on max |optimum.npy - exact optimum| (relative to max|R|/(1-lambda)).\n"
    )
    print(body)
    if not args.no_write:
        write_section("export", body)


if __name__ == "__main__":
    main()
