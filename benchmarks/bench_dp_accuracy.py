"""The cost and the gain of ``solve_exact``'s default accuracy.

The default residual tolerance is ``DP_RTOL * max|R|`` with ``DP_RTOL = 1e-11`` (never below
the rounding floor of ``tolerances.dp_default_tol``); before it was measured it was ``1e-10 *
max|R| / (1 - lambda)``. For each shipped model this script solves with both, alternating in
one fresh process per model (``--repeat`` times each), and reports improvement sweeps,
median seconds and the certified error bound; for FrozenLake (when gymnasium is installed)
it reports each default's distance to an independent dense policy iteration. Writes the
``dp-accuracy`` section of docs/benchmarks.md.

    python benchmarks/bench_dp_accuracy.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import os

from _common import machine, run_isolated, today, write_section

MODELS = ("garnet-small", "garnet-paper-scale", "patrol-small", "patrol-paper")

SOLVE = """
import time, json, statistics, numpy as np, lpbounds as lb
mdp = lb.load_instance("{name}").mdp()
rmax = float(np.abs(mdp.rewards[mdp.allowed]).max())
old_tol = 1e-10 * rmax / (1 - mdp.discount)
lb.solve_exact(mdp)  # load the compiled kernels
out = {{"n": mdp.n_states, "discount": mdp.discount}}
runs = {{"old": [], "new": []}}
for _ in range({repeat}):
    for key, kw in (("old", {{"tol": old_tol}}), ("new", {{}})):
        t = time.perf_counter()
        r = lb.solve_exact(mdp, **kw)
        runs[key].append((time.perf_counter() - t, r.iterations, r.error_bound, r.tol))
for key, rs in runs.items():
    out[key] = {{"seconds": statistics.median(x[0] for x in rs), "sweeps": rs[0][1],
                 "error_bound": rs[0][2], "tol": rs[0][3],
                 "value_scale": rmax / (1 - mdp.discount)}}
print(json.dumps(out))
"""

FROZEN = """
import json, numpy as np, gymnasium, lpbounds as lb
from scipy.sparse.linalg import spsolve
import scipy.sparse as sp
out = []
for name, kw in (("FrozenLake 4x4", {{}}), ("FrozenLake 8x8", {{"map_name": "8x8"}})):
    env = gymnasium.make("FrozenLake-v1", **kw).unwrapped
    for lam in (0.99, 0.999):
        mdp = lb.FiniteMDP.from_gymnasium(env, lam)
        # independent: policy iteration on dense arrays built here from mdp's arrays
        n, m = mdp.n_states, mdp.n_actions
        P = np.zeros((n, m, n))
        probs = np.broadcast_to(mdp.probabilities, mdp.successors.shape)
        for s in range(n):
            for a in range(m):
                if mdp.allowed[s, a]:
                    np.add.at(P[s, a], mdp.successors[s, a], probs[s, a])
        R = np.where(mdp.allowed, mdp.rewards, -np.inf)
        pol = np.argmax(R, axis=1)
        for _ in range(200):
            Pp = P[np.arange(n), pol]; Rp = R[np.arange(n), pol]
            v = np.linalg.solve(np.eye(n) - lam * Pp, Rp)
            q = np.where(mdp.allowed, mdp.rewards + lam * P @ v, -np.inf)
            new = np.argmax(q, axis=1)
            keep = q[np.arange(n), pol] >= q[np.arange(n), new] - 1e-14
            new[keep] = pol[keep]
            if np.array_equal(new, pol):
                break
            pol = new
        rmax = float(np.abs(mdp.rewards[mdp.allowed]).max())
        old = lb.solve_exact(mdp, tol=1e-10 * rmax / (1 - lam))
        new = lb.solve_exact(mdp)
        out.append({{"model": name, "discount": lam,
                     "old_err": float(np.abs(old.values - v).max()), "old_bound": old.error_bound,
                     "new_err": float(np.abs(new.values - v).max()), "new_bound": new.error_bound,
                     "old_sweeps": old.iterations, "new_sweeps": new.iterations}})
print(json.dumps({{"rows": out}}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    load = os.getloadavg()
    rows = [(name, run_isolated(SOLVE.format(name=name, repeat=args.repeat))) for name in MODELS]
    try:
        frozen = run_isolated(FROZEN.format())["rows"]
    except RuntimeError as exc:  # gymnasium missing
        frozen, why = [], str(exc).splitlines()[-1]
    else:
        why = ""
    load_after = os.getloadavg()
    lines = [
        "## Default accuracy of `solve_exact`",
        "",
        f"Machine: {machine()}. Date: {today()}. Load average {load[0]:.1f} before, "
        f"{load_after[0]:.1f} after (shared machine: compare the columns of one row, not rows "
        f"of different runs). `python benchmarks/bench_dp_accuracy.py --repeat {args.repeat}`: "
        "both tolerances alternated in one fresh process per model, medians.",
        "",
        "The default residual tolerance is now `DP_RTOL * max|R|`, `DP_RTOL = 1e-11` (never "
        "below a rounding floor); before it was `1e-10 * max|R| / (1 - lambda)`. The sweep "
        "counts are the robust measure of the cost (one or two more improvement sweeps, each "
        "with its evaluation sweeps); on a loaded machine the seconds are noise.",
        "",
        "| model | states | discount | sweeps before -> now | seconds before -> now (ratio) "
        "| error bound / value scale before -> now |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, r in rows:
        o, n = r["old"], r["new"]
        lines.append(
            f"| {name} | {r['n']:,} | {r['discount']:g} | {o['sweeps']} -> {n['sweeps']} | "
            f"{o['seconds']:.3f} -> {n['seconds']:.3f} ({n['seconds'] / o['seconds']:.2f}x) | "
            f"{o['error_bound'] / o['value_scale']:.1e} -> "
            f"{n['error_bound'] / n['value_scale']:.1e} |"
        )
    lines += [
        "",
        "FrozenLake (rewards 0/1, values of order 1), distance of the default V* to an "
        "independent dense policy iteration:",
        "",
    ]
    if frozen:
        lines += [
            "| model | discount | error before (bound) | error now (bound) "
            "| sweeps before -> now |",
            "|---|---:|---:|---:|---:|",
        ]
        for f in frozen:
            lines.append(
                f"| {f['model']} | {f['discount']:g} | {f['old_err']:.1e} "
                f"({f['old_bound']:.1e}) | {f['new_err']:.1e} ({f['new_bound']:.1e}) | "
                f"{f['old_sweeps']} -> {f['new_sweeps']} |"
            )
    else:
        lines.append(f"(not measured: {why})")
    write_section("dp-accuracy", "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
