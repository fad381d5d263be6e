"""What power-of-two scaling of an LP's data does to the solvers; writes the ``lp-scale``
section of docs/benchmarks.md.

The ELP of small seeded garnets (30 states, 2 actions, 3 outcomes, rewards uniform on
[-1, 1] times a reward scale) is solved by Clarabel and SCS (where installed) at reward
scales 1e-6..1e10 and discounts 0.9..0.9999, and by HiGHS at the tiny and huge scales,
each twice: with scaling off (``form._scaling = False``: the LP as built, the solver's
claims still judged against the structure) and on (the default). Per cell: the statuses
over the instances and the largest certified relative error (``result.relative_error``,
the certificate's bound on ``max|V - V*|`` relative to ``max|R| / (1 - lambda)``, ``inf``
without a point). Takes about a minute.

    python benchmarks/bench_lp_scale.py [--seeds 3] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from collections import Counter

import cvxpy as cp
import numpy as np
from _common import machine, today, write_section

import lpbounds as lb
from lpbounds.formulations import ELP
from lpbounds.tolerances import LP_DATA_BAND, LP_VALUE_SCALE_MAX

DISCOUNTS = (0.9, 0.99, 0.9999)
#: (solver, reward scales) measured; a solver not installed is skipped.
PLAN: tuple[tuple[str, tuple[float, ...]], ...] = (
    ("CLARABEL", (1e-6, 1e-3, 1.0, 1e3, 1e6, 1e10)),
    ("SCS", (1e-6, 1e-3, 1.0, 1e3, 1e6, 1e10)),
    ("HIGHS", (1e-300, 1e-6, 1.0, 1e10, 1e21)),
)
SHORT = {
    "optimal": "opt",
    "inaccurate": "inacc",
    "infeasible": "INFEAS",
    "unbounded": "UNBD",
    "solver_error": "err",
    "limit": "limit",
    "iteration_limit": "iter",
    "time_limit": "time",
}


def instances(discount: float, seeds: int) -> list[lb.FiniteMDP]:
    return [lb.garnet(30, 2, 3, discount, seed=s, reward_range=(-1.0, 1.0)) for s in range(seeds)]


def scaled(mdp: lb.FiniteMDP, factor: float) -> lb.FiniteMDP:
    return lb.FiniteMDP(
        mdp.successors, mdp.probabilities, mdp.rewards * factor, mdp.discount, mdp.allowed
    )


def cell(mdps: list[lb.FiniteMDP], solver: str, scaling: bool) -> dict:
    """Statuses, worst certified relative error and the claims of one (solver, scale)."""
    statuses: Counter[str] = Counter()
    claims: Counter[str] = Counter()
    worst, exps = 0.0, set()
    for mdp in mdps:
        form = ELP(mdp)
        form._scaling = scaling
        res = form.solve(solver, raise_on_failure=False)
        statuses[SHORT.get(res.status.value, res.status.value)] += 1
        if "solver_claim" in res.extra:
            claims[res.extra["solver_claim"]] += 1
        worst = max(worst, res.relative_error if res.status.has_point else np.inf)
        exps.add(res.extra.get("lp_scaling", {}).get("b", 0))
    return {"statuses": statuses, "claims": claims, "worst": worst, "exps": sorted(exps)}


def fmt_statuses(c: dict) -> str:
    out = ", ".join(f"{k} {v}" for k, v in sorted(c["statuses"].items()))
    if c["claims"]:
        out += " (claimed " + ", ".join(f"{k} {v}" for k, v in sorted(c["claims"].items())) + ")"
    return out


def fmt_err(x: float) -> str:
    return "inf" if not np.isfinite(x) else f"{x:.1e}"


def measure(seeds: int) -> tuple[list[str], float]:
    installed = set(cp.installed_solvers())
    rows, t0 = [], time.perf_counter()
    for solver, scales in PLAN:
        if solver not in installed:
            rows.append(f"| {solver} | - | - | not installed | | | | |")
            continue
        for lam in DISCOUNTS:
            base = instances(lam, seeds)
            for s in scales:
                mdps = [scaled(m, s) for m in base]
                off, on = cell(mdps, solver, False), cell(mdps, solver, True)
                kb = ", ".join(str(k) for k in on["exps"])
                rows.append(
                    f"| {solver} | {lam} | {s:g} | {fmt_statuses(off)} | {fmt_err(off['worst'])} "
                    f"| {fmt_statuses(on)} | {fmt_err(on['worst'])} | {kb} |"
                )
                print(rows[-1], flush=True)
    return rows, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3, help="garnets per cell (default 3)")
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    load0 = " ".join(f"{x:.2f}" for x in os.getloadavg())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rows, seconds = measure(args.seeds)
    load1 = " ".join(f"{x:.2f}" for x in os.getloadavg())
    lo, hi = LP_DATA_BAND
    body = (
        "## LP data scale: what power-of-two scaling does to the solvers "
        "(benchmarks/bench_lp_scale.py)\n\n"
        f"{machine()}; {today()}; load average (1, 5, 15 min) before {load0}, after "
        f"{load1}; {seconds:.0f} s in all. cvxpy {cp.__version__}.\n\n"
        f"ELP of {args.seeds} seeded garnets per cell (30 states, 2 actions, 3 outcomes, "
        "rewards uniform on [-1, 1] times the scale), solved with each solver's defaults, "
        "first with scaling off (`form._scaling = False`: the LP as built), then as "
        "`solve()` does by default: `b` and `c` multiplied by powers of two so that their "
        f"largest entries lie in [1, 2), unless max|b| is within [2**-10, 2**20] = "
        f"[{lo:.3g}, {hi:.3g}] and max|b| / (1 - lambda) <= 2**26 = {LP_VALUE_SCALE_MAX:.3g} "
        "(the same for c; here c = 1 is never scaled). Statuses count instances; a "
        "solver's 'infeasible'/'unbounded' on these LPs, feasible and bounded by "
        "construction, is reported as a solver error with the claim noted ('claimed "
        "...'). 'worst' is the largest certified relative error, the certificate's bound on "
        "max|V - V*| / (max|R| / (1 - lambda)) (inf: no point). k_b: the exponent of the "
        "scaling (the solver saw b 2**-k_b; 0 = untouched).\n\n"
        "| solver | discount | reward scale | statuses, scaling off | worst | "
        "statuses, scaled | worst | k_b |\n"
        "|---|---|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n"
    )
    print(body)
    if not args.no_write:
        write_section("lp-scale", body)


if __name__ == "__main__":
    main()
