"""Exact V* of patrol instances against their number of states: Gamma = 5..15, m = 2..5.

Each instance runs in a fresh process: the model build (``PatrolModel(...).mdp()``), the
exact solve (``solve_exact``, MPI, to residual <= 1e-10 max|R|/(1-discount)) and the
process's peak RSS. Stations are spread over the paper's 15-node ring (m = 4 is the
paper's (0, 3, 7, 11)); the other parameters are the paper's. Writes the ``scaling``
section of docs/benchmarks.md and the plot docs/img/scaling.png.

    python benchmarks/bench_scaling.py [--max-states 40000000] [--gammas 5 7 9 11 13 15]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from _common import DOCS, machine, run_isolated, today, write_section

STATIONS = {2: (0, 7), 3: (0, 5, 10), 4: (0, 3, 7, 11), 5: (0, 3, 6, 9, 12)}

POINT = """
import json, os, threading, time
import lpbounds as lb
from lpbounds.patrol import PatrolModel, PatrolParams
lb.solve_exact(PatrolModel(PatrolParams(N=6, stations=(0, 3), Gamma=4)).mdp())  # JIT warm-up
page = os.sysconf("SC_PAGE_SIZE") / 2**20
def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * page
t = time.perf_counter()
model = PatrolModel(PatrolParams(stations={stations}, Gamma={gamma}))
mdp = model.mdp()
tb = time.perf_counter() - t
del model  # its cached state table is not needed by the solve
after_build = rss()
peak = [after_build]
done = threading.Event()
def sample():  # the solve's own peak RSS (the process peak includes the build)
    while not done.wait(0.02):
        peak[0] = max(peak[0], rss())
th = threading.Thread(target=sample, daemon=True)
th.start()
t = time.perf_counter()
r = lb.solve_exact(mdp, "{method}")
ts = time.perf_counter() - t
done.set()
th.join()
print(json.dumps({{"n": mdp.n_states, "build": tb, "solve": ts, "residual": r.residual,
                  "tol": r.tol, "iterations": r.iterations, "sweeps": r.sweeps,
                  "after_build_mb": after_build, "solve_peak_mb": max(peak[0], rss())}}))
"""


def n_states(m: int, gamma: int, n_nodes: int = 15, big_d: int = 5) -> int:
    """Eq. (27)."""
    return 2 * n_nodes * (gamma + 1) ** m + m * big_d * (gamma + 1) ** (m - 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--max-states", type=int, default=40_000_000)
    ap.add_argument("--gammas", type=int, nargs="*", default=list(range(5, 16)))
    ap.add_argument("--ms", type=int, nargs="*", default=[2, 3, 4, 5])
    ap.add_argument("--method", default="mpi")
    ap.add_argument(
        "--replot", action="store_true", help="redraw the PNG and the section from the last run"
    )
    args = ap.parse_args()
    if args.replot:  # redraw the PNG and rewrite the section from the last run's results
        last = json.loads((Path("/tmp") / "lpbounds-scaling.json").read_text())
        plot(last["results"], DOCS.parent / "img" / "scaling.png")
        write_doc(last["results"], last["meta"])
        return
    load0 = os.getloadavg()
    t0 = time.time()
    results, skipped = [], []
    for m in args.ms:
        for g in args.gammas:
            n = n_states(m, g)
            if n > args.max_states:
                skipped.append((m, g, n))
                continue
            code = POINT.format(stations=STATIONS[m], gamma=g, method=args.method)
            try:
                out = run_isolated(code, timeout=1800)
            except Exception as exc:  # record and go on
                out = {"n": n, "error": str(exc)[-300:]}
            out.update(m=m, gamma=g)
            results.append(out)
            print(json.dumps(out), flush=True)
    meta = {
        "load0": load0[0],
        "load1": os.getloadavg()[0],
        "minutes": (time.time() - t0) / 60,
        "date": today(),
        "machine": machine(),
        "method": args.method,
        "max_states": args.max_states,
        "skipped": skipped,
    }
    (Path("/tmp") / "lpbounds-scaling.json").write_text(
        json.dumps({"results": results, "meta": meta}, indent=1)
    )
    plot(results, DOCS.parent / "img" / "scaling.png")
    write_doc(results, meta)


def write_doc(results: list[dict], meta: dict) -> None:
    rows = []
    for r in results:
        if "error" in r:
            rows.append(f"| {r['m']} | {r['gamma']} | {r['n']:,} | failed: {r['error'][-80:]} ||||")
            continue
        ok = "yes" if r["residual"] <= r["tol"] else "NO"
        rows.append(
            f"| {r['m']} | {r['gamma']} | {r['n']:,} | {r['build']:.2f} | {r['solve']:.2f} | "
            f"{r['iterations']} / {r['sweeps']} | {ok} | {r['peak_rss_mb']:.0f} | "
            f"{r['after_build_mb']:.0f} / {r['solve_peak_mb']:.0f} |"
        )
    skip = ", ".join(f"m={m} Gamma={g} ({n:,} states)" for m, g, n in meta["skipped"])
    ok = [r for r in results if "error" not in r]
    big = max(ok, key=lambda r: r["n"]) if ok else None
    note = ""
    if big is not None:
        within = "within" if big["peak_rss_mb"] <= 8192 else "**over**"
        where = (
            "the solve"
            if big["solve_peak_mb"] >= big["peak_rss_mb"] - 64
            else "the model build (the decoded state table and per-action temporaries of "
            "`PatrolModel.mdp()`)"
        )
        note = f"""
Largest instance (m = {big["m"]}, Gamma = {big["gamma"]}, {big["n"]:,} states): exact V* in
{big["solve"]:.1f} s ({big["iterations"]} improvements, {big["sweeps"]} sweeps) after a
{big["build"]:.1f} s model build. The solve itself peaks at {big["solve_peak_mb"]:,.0f} MB
(the MDP's arrays {big["after_build_mb"]:,.0f} MB plus the post-decision form, the value
vectors and the policy's row indices); the process peak of {big["peak_rss_mb"]:,.0f} MB,
{within} the 8 GB target, is reached in {where}. (`FiniteMDP(..., copy=False)` takes the
builder's int32 arrays over and checks ranges in a compiled loop: before that, a copy of
the successors and three full-size boolean masks put this build at 8.86 GB.)
"""
    body = (
        f"""## Scaling: exact V* of patrol instances vs number of states

Machine: {meta["machine"]}. Date: {meta["date"]}. Load average at start {meta["load0"]:.2f}, at
end {meta["load1"]:.2f} (2 cores; above ~2 the times are inflated). One fresh process per
instance (single run, not a median). Stations on the 15-node ring: {STATIONS}; other
parameters the paper's. Build = `PatrolModel(params).mdp()`; solve =
`solve_exact(mdp, "{meta["method"]}")` to residual <= 1e-10 max|R|/(1-discount) (post-decision
fast path; detection included); peak = the process's peak RSS (build and solve); the last
column is the RSS once the MDP is built and the highest RSS during the solve (sampled every
20 ms). The whole run took {meta["minutes"]:.1f} min.
{"Skipped (over --max-states " + f"{meta['max_states']:,}): " + skip if skip else ""}

![time vs states](img/scaling.png)
{note}
| m | Gamma | states | build s | solve s | improvements / sweeps | residual ok | peak MB | \
RSS after build / solve peak MB |
|---|---|---|---|---|---|---|---|---|
"""
        + "\n".join(rows)
        + "\n"
    )
    write_section("scaling", body)


def plot(results: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    markers = {2: "o", 3: "s", 4: "^", 5: "D"}
    for m in sorted({r["m"] for r in results}):
        rs = sorted((r for r in results if r["m"] == m and "error" not in r), key=lambda r: r["n"])
        if not rs:
            continue
        n = [r["n"] for r in rs]
        axes[0].loglog(n, [r["solve"] for r in rs], marker=markers.get(m, "o"), label=f"m={m}")
        axes[0].loglog(
            n,
            [r["build"] for r in rs],
            marker=markers.get(m, "o"),
            ls=":",
            color=axes[0].lines[-1].get_color(),
        )
        axes[1].loglog(
            n, [r["peak_rss_mb"] for r in rs], marker=markers.get(m, "o"), label=f"m={m}"
        )
        if "solve_peak_mb" in rs[0]:
            axes[1].loglog(
                n, [r["solve_peak_mb"] for r in rs], ls="--", color=axes[1].lines[-1].get_color()
            )
        for r in rs:
            if r["gamma"] in (5, 15):
                axes[0].annotate(
                    f"G={r['gamma']}",
                    (r["n"], r["solve"]),
                    fontsize=7,
                    textcoords="offset points",
                    xytext=(3, -9),
                )
    allr = [r for r in results if "error" not in r]
    if allr:
        lo, hi = min(r["n"] for r in allr), max(r["n"] for r in allr)
        ref = (
            max(r["solve"] / r["n"] for r in allr if r["n"] >= 1e6)
            if any(r["n"] >= 1e6 for r in allr)
            else allr[-1]["solve"] / allr[-1]["n"]
        )
        axes[0].loglog(
            [lo, hi], [ref * lo, ref * hi], color="gray", lw=0.8, ls="--", label="linear in states"
        )
    axes[0].axhline(1.5, color="red", lw=0.8, label="1.5 s target (paper instance)")
    axes[0].axvline(2_048_000, color="gray", lw=0.6)
    axes[0].set_xlabel("number of states")
    axes[0].set_ylabel("seconds (solid: exact V*; dotted: model build)")
    axes[0].set_title("Patrol MDP: time vs states (Gamma = 5..15)")
    axes[0].legend(fontsize=8)
    axes[1].axhline(8192, color="red", lw=0.8, label="8 GB")
    axes[1].axhline(1024, color="orange", lw=0.8, label="1 GB")
    axes[1].set_xlabel("number of states")
    axes[1].set_ylabel("peak RSS of the process (MB)")
    axes[1].set_title("peak RSS (solid: whole process; dashed: during the solve)")
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
