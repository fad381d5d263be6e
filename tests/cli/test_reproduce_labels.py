"""The reproduce summary's Monte Carlo rows say which number is the paper's and which
delay convention each of the run's is (issue 40: "worst 14 (15)" held the paper's value
there and another convention in the README, unlabelled)."""

from __future__ import annotations

import json

from lpbounds.cli.main import main


def _cell(text: str, label: str) -> str:
    """The second cell of the summary table's row ``label``, over the lines a narrow
    terminal wraps it on (their first cell blank), joined by the spaces it wrapped at."""
    lines = text.splitlines()
    at = next(k for k, ln in enumerate(lines) if f"\u2502 {label} " in ln)
    parts = [lines[at].split("\u2502")[2]]
    for ln in lines[at + 1 :]:
        cols = ln.split("\u2502")
        if len(cols) < 3 or cols[1].strip():
            break
        parts.append(cols[2])
    return " ".join(p.strip() for p in parts)


def test_monte_carlo_rows_label_the_paper_and_both_delay_conventions(tmp_path, capsys):
    out = tmp_path / "r"
    argv = ["reproduce", "models/patrol-small.toml", "--out", str(out), "--seeds", "1"]
    assert main([*argv, "--steps", "2000", "--no-figures"]) == 0
    text = capsys.readouterr().out
    s = json.loads((out / "summary.json").read_text())
    for key, label in (("pi_star", "pi*"), ("pi_s", "pi_s")):
        m, p = s["monte_carlo"][key], s["paper_table1"][key]
        assert _cell(text, f"Monte Carlo {label}") == (
            f"loiters {m['mean_loiters']:.2f} (paper {p['mean_loiters']}); delay counted to "
            f"the first loiter / to its end: mean {m['mean_delay']:.2f} / "
            f"{m['mean_delay_plus_one']:.2f} (paper {p['mean_delay']}), worst "
            f"{m['worst_delay']} / {m['worst_delay_plus_one']} (paper {p['worst_delay']})"
        )
        # the two conventions differ by the loiter itself: one step
        assert m["worst_delay_plus_one"] == m["worst_delay"] + 1
