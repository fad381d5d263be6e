"""``report.md`` of a reproduction: every table and figure beside the paper's statement.

Built from the typed summary of :func:`lpbounds.patrol.reproduce.reproduce` only (the
objects ``summary.json`` is written from), so the report never shows a number that is
not also in ``summary.json``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..outputs import metadata_lines
from ..text import fmt_bool, fmt_list, fmt_tuple
from .summary import ClaimsSummary, Inequality, SandwichSummary, Summary

__all__ = ["markdown_table", "monte_carlo_table", "write_report"]


def _fmt(x: Any, digits: int = 4) -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return f"{x:,}"
    if isinstance(x, float):
        if math.isnan(x):
            return "nan"
        if x != 0 and (abs(x) < 1e-3 or abs(x) >= 1e6):
            return f"{x:.2e}"
        return f"{x:.{digits}g}"
    return str(x)


def markdown_table(header: list[str], rows: list[list[Any]], align: str | None = None) -> str:
    """A GitHub-flavoured markdown table: the one table writer of the patrol's reports.

    ``align`` has one letter per column, ``"l"`` (default) or ``"r"`` (``---:``); a cell
    that is not a string is formatted as the report's numbers are.
    """
    marks = align or "l" * len(header)
    out = [
        "| " + " | ".join(h.replace("|", "\\|") for h in header) + " |",
        "|" + "|".join("---:" if m == "r" else "---" for m in marks) + "|",
    ]
    out += ["| " + " | ".join(_fmt(c).replace("|", "\\|") for c in r) + " |" for r in rows]
    return "\n".join(out)


def monte_carlo_table(summary: Summary) -> str:
    """Table 1 beside the Monte Carlo (pooled over seeds; per-seed spread in brackets)."""
    mc, paper = summary.monte_carlo, summary.paper_table1
    rows = []
    for key, label in (("pi_star", "π*"), ("pi_s", "π_s")):
        st, p = mc.policy(key), paper[key]
        rows.append(
            [
                label,
                f"{st.mean_loiters:.2f} (paper {p['mean_loiters']})",
                f"{st.mean_delay:.2f} ± {st.std_mean_delay:.2f} (paper {p['mean_delay']})",
                f"{st.worst_delay} (paper {p['worst_delay']})",
                st.n_serviced,
            ]
        )
    return markdown_table(
        [
            "policy",
            "mean number of loiters",
            "mean service delay (± sd over seeds)",
            "worst service delay",
            "serviced alerts",
        ],
        rows,
    )


def _img(files: dict[str, Path], key: str, out: Path, caption: str) -> str:
    p = files.get(key)
    if p is None:
        return f"*({caption}: figures not written)*"
    rel = Path(p).relative_to(out) if Path(p).is_relative_to(out) else Path(p)
    return f"![{caption}]({rel.as_posix()})"


def write_report(summary: Summary, files: dict[str, Path], path: str | Path) -> Path:
    """Write ``report.md`` next to the figures and return its path.

    One function per section, each reading the typed objects that ``summary.json`` is
    written from (:class:`lpbounds.patrol.summary.Summary`).
    """
    path = Path(path)
    out = path.parent
    parts = [
        _header(summary),
        _section_size(summary),
        _section_bounds(summary),
        _section_claims(summary, files, out),
        _section_sandwich(summary, files, out),
        _section_monte_carlo(summary, files, out),
        _section_times(summary),
    ]
    path.write_text("\n".join(line for part in parts for line in part) + "\n")
    return path


def _header(s: Summary) -> list[str]:
    pr = s.params
    return [
        f"# Reproduction of Park et al., Sections 4-6, on `{s.instance}`\n",
        f"Parameters: N = {pr['N']}, stations = {fmt_tuple(pr['stations'])}, D = {pr['D']}, "
        f"Gamma = {pr['Gamma']}, rho = {pr['rho']}, lambda = {pr['discount']}, "
        f"alpha = {pr['alpha']:.6g}, "
        f"allow_empty_loiter = {fmt_bool(pr['allow_empty_loiter'], 'true', 'false')}; "
        f"total {s.seconds_total:.1f} s.\n",
        "Run with:\n",
        *[f"- {line}" for line in metadata_lines(s.machine)],
        "",
        "Figures are numbered as in the paper's source (Figure 1 is the scenario sketch).\n",
    ]


def _section_size(s: Summary) -> list[str]:
    c, v = s.counts, s.vstar
    return [
        "## 1. Problem size and the exact solution\n",
        "*Paper (Sec. 5-6):* |S| = 2,048,000 (eq. 27) and M = 8,900 partitions (eq. 28) "
        "for the example; V* is computed exactly.\n",
        markdown_table(
            ["quantity", "eq. (27)/(28)", "counted", "paper (example)"],
            [
                ["|S|", c.n_states_eq27, c.n_states_counted, c.paper["n_states"]],
                ["M", c.n_partitions_eq28, c.n_partitions_counted, c.paper["n_partitions"]],
            ],
        ),
        "",
        f"V* by {v.method}: {v.iterations} improvement steps ({v.sweeps} sweeps), "
        f"Bellman residual ||TV - V|| = {_fmt(v.residual)}, so ||V - V*|| <= "
        f"{_fmt(v.error_bound)}; {v.seconds:.2f} s. V* ranges over "
        f"[{v.min:.4f}, {v.max:.4f}]. Optimal actions: {v.policy_counts}.\n",
    ]


def _section_bounds(s: Summary) -> list[str]:
    b, t, lem = s.bounds, s.theorems, s.lemma3
    aggregate = t.method == "aggregate"
    how = (
        "aggregated rows of the full MDP solved exactly (RLP: fixed point of the max, NLP: "
        "max-min game value)"
        if aggregate
        else "a certified bound from one sweep of the general operators at UBLP's/LBLP's optima"
    )
    lp_table = markdown_table(
        [
            "LP",
            "solver",
            "status",
            "rows",
            "primal residual",
            "|LP - fixed point|",
            "fixed-point error bound",
            "solve s",
        ],
        [
            [
                k.upper(),
                x.solver,
                x.status,
                x.n_rows,
                x.primal_residual,
                x.lp_minus_fixed_point_max_abs,
                x.fixed_point_error_bound,
                x.solve_seconds,
            ]
            for k, x in b.items()
        ],
    )
    theorem_table = markdown_table(
        [
            "check",
            "max |difference|" if aggregate else "bound on max |difference|",
            "tolerance",
            "operator residual (bound / (1-λ))",
        ],
        [
            [
                "Theorem 4: RLP(full MDP) = UBLP",
                t.theorem4_max_abs_diff,
                t.tolerance_theorem4,
                f"{_fmt(t.rlp_residual)} ({_fmt(t.rlp_distance_bound)})",
            ],
            [
                "Theorem 3: NLP(full MDP) = LBLP",
                t.theorem3_max_abs_diff,
                t.tolerance_theorem3,
                f"{_fmt(t.nlp_residual)} ({_fmt(t.nlp_distance_bound)})",
            ],
        ],
    )
    counted = ""
    if lem.full_mdp_rows_equal_construction is not None:
        counted = (
            f" Counted independently from the full MDP's aggregated rows: "
            f"{'identical' if lem.full_mdp_rows_equal_construction else 'DIFFERENT'} "
            f"({lem.full_mdp_rows_differ_pairs} pairs differ)."
        )
    return [
        "## 2. UBLP and LBLP; Theorems 3 and 4; Lemma 3\n",
        "*Paper:* RLP collapses to UBLP (Theorem 4; type-1 loiter successor taubar = 2) and "
        "the disjunctive NLP to LBLP (Theorem 3; successor taubar = taubar + 1).\n",
        lp_table,
        "",
        theorem_table,
        f"\nMethod: {how}.\n",
        f"Lemma 3: |T(i,u)| from the partition-level construction equals the paper's formula "
        f"on {lem.pairs - lem.pairs_differing:,} of {lem.pairs:,} allowed "
        f"(partition, action) pairs; it differs on {lem.pairs_differing} pairs, all of "
        f"them type-1 loiters at taubar = {fmt_list(lem.differing_taubar_values, 'or')}: "
        "there the cap "
        f"at Gamma merges the next maximum delays Gamma and Gamma + 1, so |T| = Gamma - 1, "
        f"not taubar = Gamma." + counted + "\n",
    ]


def _claims_table(cl: ClaimsSummary) -> str:
    return markdown_table(
        ["pairs x1 = x2 + e_j", "count", "violations (V*(x1) - V*(x2) > tol)", "max excess"],
        [
            ["all", cl.pairs, cl.violations, cl.max_excess],
            [
                "tau_j(x2) = 0 (a new alert at j)",
                cl.pairs - cl.pairs_same_alert_status,
                cl.violations_new_alert,
                None,
            ],
            [
                "... at the UAV's own station, d = 0",
                None,
                cl.violations_new_alert_own_station,
                None,
            ],
            [
                "tau_j(x2) >= 1 (same alert status)",
                cl.pairs_same_alert_status,
                cl.violations_same_alert_status,
                cl.max_excess_same_alert_status,
            ],
            [
                "partitions, same (l,w,d,A), taubar+1 vs taubar",
                cl.partition_pairs,
                cl.partition_violations,
                cl.partition_max_excess,
            ],
        ],
    )


def _claims_explanation(cl: ClaimsSummary) -> list[str]:
    """Why Claim 2 fails where it does (only when it does), with the worst examples."""
    if not cl.violations:
        return []
    lines = [
        "**Why Claim 2 fails here.** The claim's proof (Appendix, Claim 1) applies the "
        "control sequence that is optimal from x1 to x2. Under this model that is not "
        "always possible: loitering at a station with d = 0 is allowed only if the "
        "station has an alert (`allow_empty_loiter = false`, the project's "
        "specification). A state with a new alert at station j (tau_j = 1 instead of 0) "
        "therefore has *more* admissible controls — the UAV may loiter at j and collect "
        "the information reward — so its value can be higher, although its delay "
        "penalty is not lower; and a new alert at another station gives the same extra "
        "option a few steps later. "
        + (
            "Every violation above has tau_j(x2) = 0; among pairs with the same alert "
            "status (where the admissible controls along every trajectory agree) there "
            "are none, so the claim — and the partition-level claim, whose pairs keep A "
            "fixed — holds where its proof applies. "
            if cl.violations_same_alert_status == 0
            else f"**{cl.violations_same_alert_status} violations have the same alert "
            "status: the explanation above does not cover them.** "
        )
        + "With `allow_empty_loiter = true` (the paper's literal text) the admissible "
        "controls never depend on the delays.\n"
    ]
    ex = cl.examples[:5]
    if ex:
        lines.append(
            markdown_table(
                ["x2 (l, w, d, tau)", "station j", "V*(x2)", "V*(x1 = x2 + e_j)", "excess"],
                [
                    [
                        fmt_tuple(
                            [e["x2"]["l"], e["x2"]["w"], e["x2"]["d"], *e["x2"]["tau"].values()]
                        ),
                        e["station"],
                        e["vstar_x2"],
                        e["vstar_x1"],
                        e["excess"],
                    ]
                    for e in ex
                ],
            )
        )
        lines.append("")
    return lines


def _section_claims(s: Summary, files: dict[str, Path], out: Path) -> list[str]:
    cl = s.claims
    return [
        "## 3. Claims 1 and 2 (monotonicity)\n",
        "*Paper (Claim 2):* if x1 >= x2 (same l, w, d; tau(x1) >= tau(x2)) then "
        "V*(x1) <= V*(x2); if S_i >= S_j then min over S_i of V* <= min over S_j of V*. "
        "Figures 3 and 4 support it.\n",
        _claims_table(cl),
        f"\nTolerance: 2 x the error bound of V* = {_fmt(cl.tolerance)}.\n",
        *_claims_explanation(cl),
        f"Figure 4's chain (A = first and last station, d = 0, w = +1, l = first station): "
        f"min V* non-increasing in taubar: **{_fmt(cl.figure4_chain['non_increasing'])}**.\n",
        _img(files, "fig3", out, "Figure 3: V* along ordered states") + "\n",
        "*Paper, Figure 3:* monotonically decreasing value function along partially "
        "ordered states with increasing maximum delay.\n",
        _img(files, "fig4", out, "Figure 4: min V* per partition") + "\n",
        "*Paper, Figure 4:* monotonically decreasing least value per partition "
        "(green line), A = 1001, d = 0, w = 1, l = 0.\n",
    ]


def _section_sandwich(s: Summary, files: dict[str, Path], out: Path) -> list[str]:
    sw, po = s.sandwich, s.policy
    tighter = "tighter" if sw.mean_vstar_minus_vlow < sw.mean_vup_minus_vstar else "looser"
    return [
        "## 4. The sandwich, the greedy policy and V_sub\n",
        "*Paper (Sec. 6):* w*(i) <= V*(x) <= v*(i); pi_s greedy w.r.t. V_low = Phi w*; "
        "V_low <= V_sub <= V* <= V_up; 'the lower bound appears to be tighter than the "
        "upper bound'; V_sub is close to V*.\n",
        markdown_table(
            ["inequality", "margin min(rhs - lhs)", "tolerance", "violations", "worst state"],
            [
                _inequality_row("w*(i) <= V*(x)", sw.lower),
                _inequality_row("V*(x) <= v*(i)", sw.upper),
                _inequality_row("V_low <= V_sub", po.chain["vlow_le_vsub"]),
                _inequality_row("V_sub <= V*", po.chain["vsub_le_vstar"]),
            ],
        ),
        f"\nMean V* - V_low = {_fmt(sw.mean_vstar_minus_vlow)}, mean V_up - V* = "
        f"{_fmt(sw.mean_vup_minus_vstar)} (the lower bound is {tighter} on average); "
        f"largest partition gap v* - w* = {_fmt(sw.partition_gap_max)}. "
        f"With the LP solutions in place of the fixed points the margins are "
        f"{_fmt(sw.lp_lower_margin)} (lower) and {_fmt(sw.lp_upper_margin)} (upper); "
        f"certified from the LPs' returned points (their certified brackets on the exact "
        f"LP optima, widened by V*'s error bound) they are "
        f"{_fmt(sw.certified_lower_margin)} and {_fmt(sw.certified_upper_margin)}"
        f"{_certified_verdict(sw)}.\n",
        f"pi_s differs from pi* on {po.differs_states:,} states "
        f"({100 * po.differs_fraction:.2f} %; this count includes actions tied under "
        "V_low or V*, where the tie rule decides); its action loses more than "
        f"{_fmt(po.suboptimal_tolerance)} in one step on "
        f"{100 * po.suboptimal_fraction:.2f} % of states (largest one-step loss "
        f"{_fmt(po.max_one_step_loss)}). max(V* - V_sub) = "
        f"{_fmt(po.max_vstar_minus_vsub)} (at {_st(po.max_vstar_minus_vsub_state)}), "
        f"mean {_fmt(po.mean_vstar_minus_vsub)}; "
        f"V_sub by {po.vsub_method} evaluation, residual {_fmt(po.vsub_residual)}.\n",
        _img(files, "fig5", out, "Figure 5: bounds vs V*") + "\n",
        "*Paper, Figure 5:* V_up, V_low and V* on the 30 partitions of eq. (32)-(33); "
        "the lower bound appears tighter.\n",
        _img(files, "fig6", out, "Figure 6: V_sub vs V*") + "\n",
        "*Paper, Figure 6:* V_sub against V* on the clockwise states (32): "
        "'the approximation is quite good'.\n",
    ]


def _section_monte_carlo(s: Summary, files: dict[str, Path], out: Path) -> list[str]:
    mc = s.monte_carlo
    ps, pp = mc.pi_star, mc.pi_s
    conv = mc.conventions
    conv_table = markdown_table(
        ["delay convention", "π* mean / worst", "π_s mean / worst", "closeness to Table 1"],
        [
            [
                r["convention"],
                f"{r['values']['pi_star']['mean_delay']:.2f} / "
                f"{r['values']['pi_star']['worst_delay']}",
                f"{r['values']['pi_s']['mean_delay']:.2f} / {r['values']['pi_s']['worst_delay']}",
                r["relative_error_sum"],
            ]
            for r in conv["table"]
        ],
    )
    return [
        "## 5. Monte Carlo (Table 1, Figure 7)\n",
        f"Seeds {fmt_list(mc.seeds, 'and')}, {mc.n_steps_per_seed:,} steps each, the same alert "
        f"sequence for both policies; statistics pooled over all serviced alerts.\n",
        monte_carlo_table(s) + "\n",
        "**Conventions.** An alert arriving with the disturbance of step t shows as "
        "tau_j(t+1) = 1. Its *service delay* is the time from its arrival to the step on "
        "which the UAV starts loitering at that station (the model's tau_j then, but not "
        "capped at Gamma). *Loiters* are the consecutive loiters from that step (the dwell "
        "reached when the UAV leaves). An alert arriving at a station that already has a "
        "pending alert is merged by the model and is not a separate serviced alert (merged: "
        f"{ps.n_merged} for pi*, {pp.n_merged} for pi_s); one "
        "arriving at the station where the UAV is loitering is cleared by that loiter "
        f"(absorbed: {ps.n_absorbed} / {pp.n_absorbed}). Alerts "
        "still pending at the end are not counted.\n",
        conv_table,
        f"\nClosest to the paper's numbers (sum of relative errors of mean and worst delay): "
        f"**{conv['closest']}**. Mean delay over all arrivals (merged alerts with their own "
        f"delay, absorbed ones 0): pi* {ps.mean_delay_all_arrivals:.2f}, "
        f"pi_s {pp.mean_delay_all_arrivals:.2f}. Fraction of services with the "
        f"full dwell D: pi* {ps.fraction_full_dwell:.2f}, pi_s "
        f"{pp.fraction_full_dwell:.2f} (paper: 'almost 90 %'); delay <= 10: pi* "
        f"{ps.fraction_delay_le_10:.2f}, pi_s "
        f"{pp.fraction_delay_le_10:.2f} (paper: 'roughly 90 %').\n",
        _img(files, "fig7", out, "Figure 7: delay and loiter histograms") + "\n",
        "*Paper, Figure 7:* histograms of service delay and dwell for pi* and pi_s; "
        "'hardly any difference'.\n",
        _img(files, "fig2", out, "Figure 2: information gain vs dwell") + "\n",
        "*Paper, Figure 2:* value of information gained vs dwell time (Appendix A's "
        "operator model, natural log).\n",
    ]


def _section_times(s: Summary) -> list[str]:
    return [
        "## Times and memory\n",
        markdown_table(
            ["step", "wall seconds", "CPU seconds (all threads)", "peak RSS after (MB)"],
            [
                [
                    k,
                    round(x, 3),
                    round(s.cpu_seconds.get(k, float("nan")), 3),
                    round(s.peak_rss_mb.get(k, float("nan"))),
                ]
                for k, x in s.seconds.items()
            ],
        ),
        "",
    ]


def _certified_verdict(sw: SandwichSummary) -> str:
    margins = (sw.certified_lower_margin, sw.certified_upper_margin)
    if None in margins:
        return " (an LP result without a certificate: not proved from the LPs)"
    if min(m for m in margins if m is not None) > 0:
        return " (both positive: the sandwich is proved for the exact optima)"
    return " (not both positive: the sandwich is not proved from the LPs' points)"


def _inequality_row(label: str, check: Inequality) -> list[Any]:
    """One row of the sandwich table: margin, tolerance, violations, worst state."""
    return [label, check.margin, check.tolerance, check.violations, _st(check.worst_state)]


def _st(d: dict[str, Any]) -> str:
    return f"l={d['l']} w={d['w']} d={d['d']} tau={fmt_tuple(d['tau'].values())}"
