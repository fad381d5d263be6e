"""README's "What it finds" table against the runs it describes (issue 40, item 1).

The table is written by ``benchmarks/readme_table.py`` from a reproduction's
``summary.json``, the one kept as ``benchmarks/results/reproduce_summary.json``. Here: the
README holds exactly what the script writes from it; the comparison that reads the
README's numbers back catches planted changes of known size, and lets pass what the run's
tolerances allow; and (``-m slow``) a fresh ``lpbounds reproduce`` of the paper's instance
agrees with every number within that run's own tolerances.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

from lpbounds.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
STORED = ROOT / "benchmarks" / "results" / "reproduce_summary.json"


def _script():
    spec = importlib.util.spec_from_file_location(
        "readme_table", ROOT / "benchmarks" / "readme_table.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


RT = _script()
SUMMARY = json.loads(STORED.read_text())


def test_the_readme_table_is_what_the_script_writes_from_the_stored_run():
    assert RT.readme_section(README.read_text()) == RT.table(SUMMARY)
    assert RT.main(["--check"]) == 0


def test_the_stored_run_is_the_full_reproduction_of_the_paper():
    """Not a quick run: the paper's instance, 5 seeds x 60,000 steps, the default check."""
    assert SUMMARY["instance"] == "patrol-paper"
    assert (SUMMARY["n_states"], SUMMARY["n_partitions"]) == (2_048_000, 8_900)
    assert SUMMARY["monte_carlo"]["seeds"] == [1, 2, 3, 4, 5]
    assert SUMMARY["monte_carlo"]["n_steps_per_seed"] == 60_000
    assert SUMMARY["theorems"]["method"] == "residual"


def test_every_number_of_the_readme_is_read_back():
    text = README.read_text()
    assert RT.disagreements(text, SUMMARY) == []
    shown = RT.readme_rows(text)
    for row in RT.rows(SUMMARY):
        printed = row.pattern().match(shown[row.check]).groups()
        assert list(printed) == [f.text() for f in row.figures], row.check


@pytest.mark.parametrize(
    ("old", "new", "where"),
    [
        ("residual 1.07e-13", "residual 1.4e-11", "V* (MPI): README 1.4e-11"),  # the old README
        ("max difference 2.78e-15", "max difference 2.50e-14", "Theorem 4"),  # 2.2e-14 > 2.05e-14
        ("margins 2.047e-4", "margins 2.048e-4", "sandwich"),  # one digit: 1e-7 >> 1.1e-12
        ("24 of 7,603,200", "25 of 7,603,200", "Claim 2"),
        ("worst 14 (15 to its end); π_s", "worst 14 (16 to its end); π_s", "Table 1"),
        ("its delays are closest to those counted to the end", "its delays are closest to "
         "those counted to the first", "Table 1"),
        ("| Lemma 3 |", "| Lemma 3' |", "Lemma 3"),
    ],
)  # fmt: skip
def test_a_planted_change_is_a_disagreement(old, new, where):
    text = README.read_text()
    assert old in text
    found = RT.disagreements(text.replace(old, new, 1), SUMMARY)
    assert found and all(where in f or "not a row" in f for f in found), found


def test_what_the_run_tolerances_allow_is_no_disagreement():
    """Another run's residual anywhere below the stopping tolerance, and its differences
    below theirs, agree with the README; the printed digits' rounding too."""
    text = README.read_text()
    other = json.loads(STORED.read_text())
    v, th = other["vstar"], other["theorems"]
    v["residual"] = 0.9 * v["tol"]
    v["error_bound"] *= 0.9 * v["tol"] / SUMMARY["vstar"]["residual"]
    th["theorem4_max_abs_diff"] = 0.9 * th["tolerance_theorem4"]
    other["sandwich"]["certified_lower_margin"] += 4e-8  # 2.04695e-4 + 4e-8 prints 2.047e-4
    assert RT.disagreements(text, other) == []


@pytest.mark.slow
def test_a_fresh_reproduction_agrees_with_the_readme(tmp_path):
    """``lpbounds reproduce`` of the paper's instance (about 20 s and 1.2 GB), and every
    number of the README's table within that run's tolerances."""
    out = tmp_path / "reproduce"
    assert main(["reproduce", "--out", str(out), "--no-figures", "-q"]) == 0
    fresh = json.loads((out / "summary.json").read_text())
    assert RT.disagreements(README.read_text(), fresh) == []
