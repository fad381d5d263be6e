"""The reproduce summary's Monte Carlo rows say which number is the paper's and which
delay convention each of the run's is (issue 40: "worst 14 (15)" held the paper's value
there and another convention in the README, unlabelled)."""

from __future__ import annotations

import json
import re

from lpbounds.cli.main import main


def test_monte_carlo_rows_label_the_paper_and_both_delay_conventions(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "300")  # one line per row
    out = tmp_path / "r"
    argv = ["reproduce", "models/patrol-small.toml", "--out", str(out), "--seeds", "1"]
    assert main([*argv, "--steps", "2000", "--no-figures"]) == 0
    text = capsys.readouterr().out
    s = json.loads((out / "summary.json").read_text())
    for key, label in (("pi_star", "pi*"), ("pi_s", "pi_s")):
        m, p = s["monte_carlo"][key], s["paper_table1"][key]
        row = re.search(rf"Monte Carlo {re.escape(label)}\s*│ (.*?)\s*│", text)
        assert row, text
        assert row.group(1) == (
            f"loiters {m['mean_loiters']:.2f} (paper {p['mean_loiters']}); delay counted to "
            f"the first loiter / to its end: mean {m['mean_delay']:.2f} / "
            f"{m['mean_delay_plus_one']:.2f} (paper {p['mean_delay']}), worst "
            f"{m['worst_delay']} / {m['worst_delay_plus_one']} (paper {p['worst_delay']})"
        )
        # the two conventions differ by the loiter itself: one step
        assert m["worst_delay_plus_one"] == m["worst_delay"] + 1
