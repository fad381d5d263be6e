"""`lpbounds bounds`: the LP is skipped above --lp-max-partitions, forced by --lp, and says so."""

from __future__ import annotations

import json

from lpbounds.cli.main import main


def test_lp_skipped_above_the_size_limit_and_reported(tmp_path):
    out = tmp_path / "b.json"
    assert main(["bounds", "patrol-small", "--lp-max-partitions", "10", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["lp_solved"] is False
    assert "fixed points are the LPs' exact optima" in res["lp_note"]


def test_lp_forced_and_contradiction(tmp_path, capsys):
    out = tmp_path / "b.json"
    args = ["bounds", "patrol-small", "--lp", "--lp-max-partitions", "10", "--json", str(out)]
    assert main(args) == 0
    assert json.loads(out.read_text())["lp_solved"] is True
    assert main(["bounds", "patrol-small", "--lp", "--no-lp"]) == 2  # a usage error
    assert "contradict" in capsys.readouterr().err
