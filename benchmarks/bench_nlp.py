"""How the NLP's methods converge on small random MDPs (the table in docs/nlp.md).

For each instance (garnet MDP, random partition, cost all ones) every method of
:meth:`lpbounds.NLP.solve` is run and its iterations, cuts, seconds and final bracket
gap are tabulated, with ``c'w*`` from strategy iteration checked against the other exact
methods. The cutting planes' bracket is also checked against ``c'w*`` at every round (a
round whose lower bound exceeds ``c'w*`` would mean an invalid cut).

Usage::

    python benchmarks/bench_nlp.py            # the 12 instances of docs/nlp.md
    python benchmarks/bench_nlp.py --quick    # 4 instances
    python benchmarks/bench_nlp.py --write    # also replace the nlp section of docs/benchmarks.md
    python benchmarks/bench_nlp.py --variants # cutting-plane variants on 4 instances
    python benchmarks/bench_nlp.py --scale    # 5,000 states, 300 partitions
    python benchmarks/bench_nlp.py --monotone --big --write   # cutting planes at scale
"""

from __future__ import annotations

import argparse
import os

import numpy as np
from _common import machine, today, write_section

from lpbounds.formulations.nlp.problem import NLP
from lpbounds.model.generators import garnet, random_partition

#: (states, actions, outcomes, partitions, seed)
INSTANCES: list[tuple[int, int, int, int, int]] = [
    (8, 2, 2, 3, 0),
    (10, 2, 2, 3, 1),
    (12, 2, 3, 4, 2),
    (15, 2, 2, 4, 0),
    (15, 2, 2, 4, 2),
    (15, 3, 2, 4, 3),
    (20, 2, 2, 4, 4),
    (20, 3, 3, 5, 5),
    (25, 2, 2, 5, 6),
    (25, 3, 2, 6, 7),
    (30, 2, 3, 6, 8),
    (30, 3, 3, 6, 9),
]
QUICK = INSTANCES[:4]
METHODS = ("fixed-point", "strategy-iteration", "milp", "cutting-planes", "lift-and-project")


def run(instances: list[tuple[int, int, int, int, int]], max_rounds: int) -> list[dict]:
    rows = []
    for n, a, l_out, m, seed in instances:
        mdp = garnet(n, a, l_out, 0.9, seed=seed)
        part = random_partition(n, m, seed=seed)
        nlp = NLP(mdp, part)
        exact = nlp.solve("strategy-iteration")
        opt = float(nlp.cost @ exact.values)
        for method in METHODS:
            kw = {"max_iter": max_rounds} if method == "cutting-planes" else {}
            if method == "lift-and-project":
                r = nlp.solve("cutting-planes", cuts="lift-and-project", max_iter=max_rounds)
            else:
                r = nlp.solve(method, **kw)
            ok_bracket = all(
                e.lower <= opt + 1e-9 * max(1.0, abs(opt)) for e in r.log if np.isfinite(e.lower)
            ) and all(
                e.upper >= opt - 1e-9 * max(1.0, abs(opt)) for e in r.log if np.isfinite(e.upper)
            )
            rows.append(
                {
                    "instance": f"n={n} A={a} L={l_out} M={m} s={seed}",
                    "disj": f"{nlp.n_disjunctions}/{int((nlp.disj_size >= 2).sum())}",
                    "terms": nlp.rows.n_rows,
                    "opt": opt,
                    "method": method if method != "cutting-planes" else "cutting-planes (monotone)",
                    "iterations": r.iterations,
                    "cuts": r.cuts,
                    "seconds": r.seconds,
                    "gap": r.gap,
                    "rel_gap": r.relative_gap,
                    "converged": r.converged,
                    "stop": r.stop_reason,
                    "values_err": float(np.abs(r.values - exact.values).max()),
                    "bracket_ok": ok_bracket,
                    "first_exact_upper": _first_exact_upper(r, opt),
                }
            )
            print(
                f"{rows[-1]['instance']:28s} {method:19s} it={r.iterations:4d} "
                f"cuts={r.cuts:5d} t={r.seconds:7.3f}s gap={r.gap:.2e} "
                f"{'ok' if r.converged else 'NOT converged'} ({r.stop_reason})"
                f"{'' if ok_bracket else '  BRACKET VIOLATED'}",
                flush=True,
            )
    return rows


def _first_exact_upper(r, opt: float) -> int | None:
    """The first round whose upper bound equals ``c'w*`` to 1e-9 (cutting planes)."""
    if r.method != "cutting-planes":
        return None
    for e in r.log:
        if e.upper <= opt + 1e-9 * max(1.0, abs(opt)):
            return e.iteration
    return None


def table(rows: list[dict], max_rounds: int) -> str:
    lines = [
        f"Garnet MDPs (discount 0.9), random partitions, cost all ones; cutting planes: "
        f"monotone cuts with box resolution (the default) and lift-and-project with at most "
        f"10 cuts a round, {max_rounds} rounds each, gap target 1e-6 relative. Machine: "
        f"{machine()} (shared; load average {os.getloadavg()[0]:.1f}), {today()}. "
        "`disj` = disjunctions / those with 2+ terms; `gap` = upper - lower bound on c'w* "
        "at the end; `exact UB at` = the round whose upper bound (the strategy read off the "
        "master point) first equals c'w*; `bracket` = lower <= c'w* <= upper at every "
        "round.",
        "",
        "| instance | disj | terms | c'w* | method | iterations | cuts | seconds | gap | "
        "converged | exact UB at | bracket |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['instance']} | {r['disj']} | {r['terms']} | {r['opt']:.6f} | {r['method']} | "
            f"{r['iterations']} | {r['cuts']} | {r['seconds']:.3f} | {r['gap']:.1e} | "
            f"{'yes' if r['converged'] else 'no: ' + r['stop']} | "
            f"{r['first_exact_upper'] if r['first_exact_upper'] is not None else '-'} | "
            f"{'ok' if r['bracket_ok'] else 'VIOLATED'} |"
        )
    lines.append("")
    for label in ("cutting-planes (monotone)", "lift-and-project"):
        cp_rows = [r for r in rows if r["method"] == label]
        n_conv = sum(r["converged"] for r in cp_rows)
        lines.append(
            f"Cutting planes, {label}: {n_conv} of {len(cp_rows)} instances closed the gap; "
            f"rounds {min(r['iterations'] for r in cp_rows)}-"
            f"{max(r['iterations'] for r in cp_rows)}, largest final relative gap "
            f"{max(r['rel_gap'] for r in cp_rows):.1e}."
        )
    return "\n".join(lines)


#: cutting-plane variants compared by ``--variants`` (keyword arguments of NLP.solve)
VARIANTS: dict[str, dict] = {
    "default (10 cuts/round, binding rows, sum(u)+sum(v)=1)": {},
    "1 cut/round": {"cuts_per_round": 1},
    "CGLP on all master rows": {"cglp_rows": "all"},
    "normalisation max abs(alpha) <= 1": {"normalization": "alpha"},
}


def variants(instances: list[tuple[int, int, int, int, int]], max_rounds: int) -> str:
    """Rounds, cuts, seconds and final relative gap of each cutting-plane variant."""
    lines = [
        "| instance | variant | rounds | cuts | seconds | final rel. gap | converged |",
        "|---|---|---|---|---|---|---|",
    ]
    for n, a, l_out, m, seed in instances:
        nlp = NLP(garnet(n, a, l_out, 0.9, seed=seed), random_partition(n, m, seed=seed))
        for name, kw in VARIANTS.items():
            r = nlp.solve("cutting-planes", cuts="lift-and-project", max_iter=max_rounds, **kw)
            lines.append(
                f"| n={n} A={a} L={l_out} M={m} s={seed} | {name} | {r.iterations} | {r.cuts} | "
                f"{r.seconds:.2f} | {r.relative_gap:.1e} | "
                f"{'yes' if r.converged else 'no: ' + r.stop_reason} |"
            )
            print(lines[-1], flush=True)
    return "\n".join(lines)


def scale_run(seconds: float = 20.0) -> str:
    """A larger instance (5,000 states, 300 partitions): cutting planes under a time limit."""
    mdp = garnet(5000, 3, 3, 0.95, seed=1)
    nlp = NLP(mdp, random_partition(5000, 300, seed=1))
    out = [repr(nlp)]
    for method in ("fixed-point", "strategy-iteration"):
        out.append(nlp.solve(method).summary())
    r = nlp.solve("cutting-planes", cuts="lift-and-project", time_limit=seconds)
    out.append(r.summary())
    out += [
        f"  round {e.iteration}: lower {e.lower:.6g}, upper {e.upper:.6g}, {e.seconds:.1f} s"
        for e in (r.log[0], r.log[len(r.log) // 2], r.log[-1])
    ]
    return "\n".join(out)


#: cutting-plane runs of ``--monotone``: (label, keywords, largest M it is run at)
SCALE_RUNS: list[tuple[str, dict, int]] = [
    ("monotone + resolution", {}, 10**9),
    ("monotone cuts only", {"resolve": False, "max_iter": 1000}, 2_000),
    ("lift-and-project", {"cuts": "lift-and-project", "time_limit": 60.0}, 50),
]


def _scale_row(label: str, nlp: NLP, r, opt: tuple[float, float], m: int) -> dict:
    lo, hi = r.extra.get("method_bracket", (r.lower_bound, r.upper_bound))
    unit = float(nlp.cost.sum()) * nlp.scale
    ok = all(
        e.lower <= opt[1] + 1e-9 * unit and e.upper >= opt[0] - 1e-9 * unit
        for e in r.log
        if np.isfinite(e.lower) and np.isfinite(e.upper)
    )
    return {
        "M": m,
        "method": label,
        "iterations": r.iterations,
        "seconds": r.seconds,
        "gap_scale": (hi - lo) / unit,
        "gap_opt": (hi - lo) / max(abs(opt[0]), 1e-300),
        "cert_gap": r.relative_gap,
        "status": str(r.status),
        "resolved": r.extra.get("resolved", "-"),
        "bracket_ok": ok,
    }


def scale_runs(ms: list[int], patrol: bool) -> tuple[list[dict], list[str]]:
    """Garnets (n = 10 M, 3 actions, 3 outcomes, discount 0.9) and the paper's patrol."""
    rows, notes = [], []
    cases = [(m, None) for m in ms] + ([("patrol", None)] if patrol else [])
    for m, _ in cases:
        if m == "patrol":
            import time

            from lpbounds.patrol.instance import model_for, params_from_instance

            t0 = time.perf_counter()
            pm = model_for(params_from_instance("models/patrol-paper.toml"))
            mdp, part = pm.mdp(), pm.partition()
            t1 = time.perf_counter()
            nlp = NLP(mdp, part)
            notes.append(
                f"patrol-paper: |S| = {mdp.n_states:,}, M = {part.n_partitions:,}, "
                f"{nlp!r}; MDP build {t1 - t0:.1f} s, NLP rows {time.perf_counter() - t1:.1f} s "
                "(not in the times below)."
            )
        else:
            n = 10 * m
            nlp = NLP(garnet(n, 3, 3, 0.9, seed=0), random_partition(n, m, seed=0))
            notes.append(f"garnet M = {m:,}: n = {n:,}, {nlp!r}.")
        ref_method = "strategy-iteration" if m == "patrol" or m <= 2_000 else "fixed-point"
        ref = nlp.solve(ref_method)
        opt = (ref.lower_bound, ref.upper_bound)
        rows.append(_scale_row(ref_method, nlp, ref, opt, m))
        print(rows[-1], flush=True)
        if ref_method != "fixed-point":
            rows.append(_scale_row("fixed-point", nlp, nlp.solve("fixed-point"), opt, m))
            print(rows[-1], flush=True)
        for label, kw, m_max in SCALE_RUNS:
            if m != "patrol" and m > m_max:
                continue
            if m == "patrol" and label != "monotone + resolution":
                continue
            r = nlp.solve("cutting-planes", gap_rtol=1e-9, **kw)
            rows.append(_scale_row(label, nlp, r, opt, m))
            print(rows[-1], flush=True)
    return rows, notes


def scale_table(rows: list[dict], notes: list[str]) -> str:
    lines = [
        "### Cutting planes at scale (`python benchmarks/bench_nlp.py --monotone`)",
        "",
        f"Machine: {machine()} (shared; load average {os.getloadavg()[0]:.1f} at the end), "
        f"{today()}. Garnets with n = 10 M states, 3 actions, 3 outcomes, discount 0.9, "
        "random partition (seed 0), cost all ones; the paper's patrol instance "
        "(`models/patrol-paper.toml`, full-MDP NLP). Gap target `gap_rtol = 1e-9`. "
        "`gap/scale` = the method's own bracket on c'w* over sum(c) max|R| / (1 - lambda) "
        "(the unit of `gap_rtol`); `gap/c'w*` = the same over |c'w*|; `cert. gap` = the "
        "certified bracket of the returned point, relative like `gap/scale`; `resolved` = "
        "disjunctions resolved on the box; `bracket` = lower <= c'w* <= upper in every "
        "round (c'w* from strategy iteration, or the fixed point at M = 10,000).",
        "",
        "| M | method | iterations | seconds | gap/scale | gap/c'w* | cert. gap | status | "
        "resolved | bracket |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['M']} | {r['method']} | {r['iterations']} | {r['seconds']:.2f} | "
            f"{r['gap_scale']:.1e} | {r['gap_opt']:.1e} | {r['cert_gap']:.1e} | {r['status']} | "
            f"{r['resolved']} | {'ok' if r['bracket_ok'] else 'VIOLATED'} |"
        )
    lines += [""] + [f"- {n}" for n in notes]
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="4 instances only")
    ap.add_argument("--max-rounds", type=int, default=200)
    ap.add_argument("--write", action="store_true", help="update docs/benchmarks.md")
    ap.add_argument(
        "--variants", action="store_true", help="compare cutting-plane variants (4 instances)"
    )
    ap.add_argument(
        "--scale", action="store_true", help="5,000 states, 300 partitions, 20 s of cuts"
    )
    ap.add_argument(
        "--monotone",
        action="store_true",
        help="cutting planes at scale: garnets M = 5..2,000 (--big: 10,000) and the patrol",
    )
    ap.add_argument("--big", action="store_true", help="with --monotone: also M = 10,000")
    args = ap.parse_args()
    if args.monotone:
        ms = [5, 50, 300, 2_000] + ([10_000] if args.big else [])
        rows, notes = scale_runs(ms, patrol=True)
        text = scale_table(rows, notes)
        print(text)
        if args.write:
            write_section("nlp-scale", text)
        return 0 if all(r["bracket_ok"] for r in rows) else 1
    if args.scale:
        print(scale_run())
        return 0
    if args.variants:
        print(variants([INSTANCES[i] for i in (2, 3, 7, 10)], args.max_rounds))
        return 0
    rows = run(QUICK if args.quick else INSTANCES, args.max_rounds)
    text = table(rows, args.max_rounds)
    print()
    print(text)
    if args.write:
        write_section("nlp", f"## NLP (disjunctive lower bound): convergence\n\n{text}")
    return 0 if all(r["bracket_ok"] for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
