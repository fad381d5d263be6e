"""The README's "What it finds" table, written from a reproduction's ``summary.json``.

Every number of the table is read from the ``summary.json`` that ``lpbounds reproduce``
writes (the paper's instance, ``models/patrol-paper.toml``), never typed by hand::

    lpbounds reproduce --out out/reproduce
    cp out/reproduce/summary.json benchmarks/results/reproduce_summary.json
    python benchmarks/readme_table.py            # rewrites README.md between the markers
    python benchmarks/readme_table.py --check    # exit 1 when README.md differs

The run the README shows is kept as ``benchmarks/results/reproduce_summary.json``.
``tests/project/test_readme_numbers.py`` checks that README.md is what this script writes
from it, and (``-m slow``) that a fresh ``lpbounds reproduce`` agrees with every number of
the table within that run's own tolerances (:attr:`Figure.tol`).

Each row is a template with one ``{}`` per number and the numbers as :class:`Figure`: its
value, its format and how far another run's value may lie from it. The tolerances are
the run's own: a residual may be anywhere below the stopping tolerance ``vstar.tol``, a
difference of Theorems 3-4 anywhere below its tolerance, a margin within the sandwich's
tolerance; a count and the Monte Carlo statistics (the seeds fix the draws) are exact.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
SUMMARY = ROOT / "benchmarks" / "results" / "reproduce_summary.json"
START, END = "<!-- what-it-finds:start -->", "<!-- what-it-finds:end -->"


@dataclass(frozen=True)
class Figure:
    """A number of the table: ``value`` printed with ``spec``; another run's value agrees
    when it lies within ``tol`` of it (and half a unit of the last printed digit)."""

    value: float
    spec: str
    tol: float = 0.0

    def text(self) -> str:
        """The value as printed: ``format(value, spec)``, an exponent without its leading
        zeros (``2.047e-4``, as lpbounds' reports write it)."""
        return re.sub(r"e([+-])0*(\d)", r"e\1\2", format(self.value, self.spec)).replace("e+", "e")


@dataclass(frozen=True)
class Row:
    """One row: the check (its first cell) and the result, ``template`` with one ``{}``
    per figure."""

    check: str
    template: str
    figures: tuple[Figure, ...]

    def text(self) -> str:
        return self.template.format(*(f.text() for f in self.figures))

    def pattern(self) -> re.Pattern[str]:
        """The result cell with each number captured (to read another table's numbers)."""
        parts = [re.escape(p) for p in self.template.split("{}")]
        return re.compile("^" + r"([-+0-9.,e]+?)".join(parts) + "$")


def _vstar_rows(s: dict[str, Any]) -> list[Row]:
    v, lam = s["vstar"], float(s["params"]["discount"])
    # the error bound a residual at the stopping tolerance would give (the same ratio)
    eb_tol = v["error_bound"] / v["residual"] * v["tol"] if v["residual"] > 0 else v["tol"]
    th = s["theorems"]
    return [
        Row(
            f"V* ({v['method'].upper()})",
            "residual {}, so max\\|V - V*\\| <= {} (the run stops below residual {}, "
            f"discount {lam:g})",
            (
                Figure(v["residual"], ".2e", v["tol"]),
                Figure(v["error_bound"], ".2e", eb_tol),
                Figure(v["tol"], ".1e", v["tol"]),
            ),
        ),
        Row(
            "Theorem 4: RLP of the full MDP = UBLP",
            "max difference {} (tolerance {})",
            (
                Figure(th["theorem4_max_abs_diff"], ".2e", th["tolerance_theorem4"]),
                Figure(th["tolerance_theorem4"], ".2e", th["tolerance_theorem4"]),
            ),
        ),
        Row(
            "Theorem 3: disjunctive NLP of the full MDP = LBLP",
            "max difference {} (tolerance {})",
            (
                Figure(th["theorem3_max_abs_diff"], ".2e", th["tolerance_theorem3"]),
                Figure(th["tolerance_theorem3"], ".2e", th["tolerance_theorem3"]),
            ),
        ),
    ]


def _sandwich_rows(s: dict[str, Any]) -> list[Row]:
    sw, v = s["sandwich"], s["vstar"]
    lp_error = max(lp["certified_error_bound"] for lp in s["bounds"].values())
    eb_tol = v["error_bound"] / v["residual"] * v["tol"] if v["residual"] > 0 else v["tol"]
    chain = s["policy"]["chain"]
    proved = (
        "proved"
        if min(sw["certified_lower_margin"], sw["certified_upper_margin"]) > 0
        else "NOT proved"
    )
    return [
        Row(
            "sandwich w*(i) <= V*(x) <= v*(i)",
            f"{proved}: certified margins {{}} (lower) and {{}} (upper), i.e. the LPs' "
            "certified brackets (HiGHS, errors <= {}) widened by V*'s error bound {} still "
            "leave that room",
            (
                Figure(sw["certified_lower_margin"], ".3e", sw["lower"]["tolerance"]),
                Figure(sw["certified_upper_margin"], ".3e", sw["upper"]["tolerance"]),
                Figure(lp_error, ".0e", lp_error),
                Figure(v["error_bound"], ".1e", eb_tol),
            ),
        ),
        Row(
            "V_low <= V_sub <= V* <= V_up",
            "{} violations",
            (Figure(sum(link["violations"] for link in chain.values()), "d"),),
        ),
    ]


def _claim_rows(s: dict[str, Any]) -> list[Row]:
    l3, c2 = s["lemma3"], s["claims"]
    gamma = s["params"]["Gamma"]
    at_gamma = l3["differing_all_type1_loiter"] and l3["differing_taubar_values"] == [gamma]
    lemma3 = (
        "holds except on {} type-1 loiter pairs at taubar = Gamma, where the cap gives "
        "Gamma - 1 tuples"
        if at_gamma
        else "differs on {} pairs, not all type-1 loiter pairs at taubar = Gamma (see report.md)"
    )
    new_alert = c2["violations_same_alert_status"] == 0
    claim2 = "{} of {} pairs fail" + (
        ", all where a new alert adds the loiter action (the default model forbids "
        "loitering at an empty station; none on the test suite's small models with "
        "`allow_empty_loiter = true`)"
        if new_alert
        else ", {} of them with the same alert status (see report.md)"
    )
    claim2_figures = [Figure(c2["violations"], ",d"), Figure(c2["pairs"], ",d")]
    if not new_alert:
        claim2_figures.append(Figure(c2["violations_same_alert_status"], ",d"))
    return [
        Row("Lemma 3", lemma3, (Figure(l3["pairs_differing"], "d"),)),
        Row("Claim 2 (monotonicity)", claim2, tuple(claim2_figures)),
    ]


#: ``monte_carlo.conventions.closest`` of summary.json in the row's words
CONVENTIONS = {"delay to end of first loiter": "those counted to the end of the first loiter"}


def _table1_row(s: dict[str, Any]) -> Row:
    mc, paper = s["monte_carlo"], s["paper_table1"]
    figures = [Figure(len(mc["seeds"]), "d"), Figure(mc["n_steps_per_seed"], ",d")]
    parts = []
    for key, label in (("pi_star", "π*"), ("pi_s", "π_s")):
        st = mc[key]
        parts.append(
            f"{label}: {{}} loiters, mean delay {{}} counted to the first loiter ({{}} counted "
            "to its end), worst {} ({} to its end)"
        )
        figures += [
            Figure(st["mean_loiters"], ".2f"),
            Figure(st["mean_delay"], ".2f"),
            Figure(st["mean_delay_plus_one"], ".2f"),
            Figure(st["worst_delay"], "d"),
            Figure(st["worst_delay_plus_one"], "d"),
        ]
    closest = mc["conventions"]["closest"]
    closest = CONVENTIONS.get(closest, f"those of the convention '{closest}'")
    paper_text = " and ".join(
        f"{p['mean_loiters']} / {p['mean_delay']} / {p['worst_delay']}"
        for p in (paper["pi_star"], paper["pi_s"])
    )
    return Row(
        "Table 1 (Monte Carlo)",
        "{} seeds x {} steps; "
        + "; ".join(parts)
        + f". Paper (loiters / mean delay / worst delay): {paper_text}; its delays are closest "
        f"to {closest}",
        tuple(figures),
    )


def rows(summary: dict[str, Any]) -> list[Row]:
    """The table's rows from a ``summary.json`` (as :func:`json.load` reads it)."""
    return [*_vstar_rows(summary), *_sandwich_rows(summary), *_claim_rows(summary),
            _table1_row(summary)]  # fmt: skip


def table(summary: dict[str, Any]) -> str:
    """The markdown table, with the line that says where it comes from."""
    lines = [
        f"Generated by `benchmarks/readme_table.py` from the `summary.json` of `lpbounds "
        f"reproduce` ({summary['instance']}, {summary['date']}; kept as "
        "`benchmarks/results/reproduce_summary.json`):",
        "",
        "| check | result |",
        "|---|---|",
    ]
    lines += [f"| {r.check} | {r.text()} |" for r in rows(summary)]
    return "\n".join(lines)


def readme_section(text: str) -> str:
    """What README.md holds between the markers (without them and the blank lines)."""
    if START not in text or END not in text:
        raise SystemExit(f"README.md has no {START} ... {END} section")
    return text.split(START, 1)[1].split(END, 1)[0].strip("\n")


def readme_rows(text: str) -> dict[str, str]:
    """check -> result cell of the README's table (the cells' ``\\|`` kept as written)."""
    out = {}
    for line in readme_section(text).splitlines():
        if line.startswith("| ") and not line.startswith("| check |"):
            check, _, result = line[2:-2].partition(" | ")
            out[check] = result
    return out


def half_unit(printed: str) -> float:
    """Half a unit of the last digit of a printed number (``1.07e-13``: 5e-16; ``7,603,200``
    and ``14``: 0.5, which an integer never reaches)."""
    mantissa, _, exponent = printed.replace(",", "").partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 0.5 * 10.0 ** (int(exponent or 0) - decimals)


def disagreements(readme_text: str, summary: dict[str, Any]) -> list[str]:
    """Where README's table and the rows of ``summary`` disagree beyond the run's own
    tolerances: a row missing or worded otherwise (a verdict, a convention, the paper's
    numbers), or a number farther from the run's than its :attr:`Figure.tol` plus half a
    unit of its last printed digit. Empty when they agree."""
    shown = readme_rows(readme_text)
    expected = rows(summary)
    out = [
        f"{c}: in README, not a row of the run"
        for c in shown
        if c not in {r.check for r in expected}
    ]
    for row in expected:
        cell = shown.get(row.check)
        match = None if cell is None else row.pattern().match(cell)
        if match is None:
            out.append(f"{row.check}: README {cell!r}, the run {row.text()!r}")
            continue
        for printed, fig in zip(match.groups(), row.figures, strict=True):
            if abs(float(printed.replace(",", "")) - fig.value) > fig.tol + half_unit(printed):
                out.append(
                    f"{row.check}: README {printed}, the run {fig.text()} ({fig.value!r}, "
                    f"tolerance {fig.tol:.2g})"
                )
    return out


def write(readme: Path, summary: dict[str, Any]) -> bool:
    """Rewrite the section of ``readme``; True when it changed."""
    text = readme.read_text()
    head, rest = text.split(START, 1)
    _, tail = rest.split(END, 1)
    new = f"{head}{START}\n{table(summary)}\n{END}{tail}"
    if new != text:
        readme.write_text(new)
    return new != text


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("summary", nargs="?", default=str(SUMMARY), help="a reproduce summary.json")
    ap.add_argument("--readme", default=str(README))
    ap.add_argument("--check", action="store_true", help="exit 1 when README.md differs")
    args = ap.parse_args(argv)
    summary = json.loads(Path(args.summary).read_text())
    readme = Path(args.readme)
    if args.check:
        same = readme_section(readme.read_text()) == table(summary)
        print("README.md is up to date" if same else "README.md differs: rerun without --check")
        return 0 if same else 1
    print("README.md rewritten" if write(readme, summary) else "README.md unchanged")
    return 0


if __name__ == "__main__":
    sys.exit(main())
