"""``lpbounds models``: the listing of the packaged and named models, its sizes and errors.

The sizes the listing reads from the parameters are checked against the built models
(for the small ones) and against the closed forms of the patrol model (eq. 27-28).
"""

from __future__ import annotations

import json

import pytest

import lpbounds as lb
from lpbounds.cli.main import main
from lpbounds.cli.models import catalogue

SHELF = [
    "cliffwalking",
    "forest",
    "frozenlake",
    "gridworld",
    "inventory",
    "queue",
    "savings",
    "taxi",
]


def _listing(capsys, *args: str) -> list[dict]:
    assert main(["models", "--json", *args]) == 0
    return json.loads(capsys.readouterr().out)


def test_lists_every_packaged_model_with_sizes_and_source(capsys):
    assert main(["models"]) == 0
    out = capsys.readouterr().out
    for name in [*SHELF, "garnet-small", "patrol-paper", "patrol-small"]:
        assert f"\n{name} " in out, name
    for col in ("states", "actions", "outcomes", "pairs", "discount", "sets", "kind", "source"):
        assert col in out
    assert "Sutton and Barto" in out and "mdptoolbox.example.forest" in out
    # the paper's instance, by its closed forms: |S| = 2,048,000 (eq. 27), M = 8,900 (eq. 28)
    line = next(x for x in out.splitlines() if x.startswith("patrol-paper "))
    assert "2,048,000" in line and "8,900" in line


def test_json_sizes_are_the_built_models(capsys):
    rows = {r["name"]: r for r in _listing(capsys)}
    assert set(SHELF) <= set(rows)
    for name in [
        "forest",
        "gridworld",
        "inventory",
        "queue",
        "savings",
        "garnet-small",
        "patrol-small",
    ]:
        inst = lb.load_instance(name)
        mdp, part = inst.mdp(), inst.partition()
        r = rows[name]
        got = (r["n_states"], r["n_actions"], r["n_outcomes"], r["n_pairs"], r["n_partitions"])
        assert got == (
            mdp.n_states,
            mdp.n_actions,
            mdp.n_outcomes,
            mdp.n_pairs,
            part.n_partitions,
        ), name
        assert r["discount"] == mdp.discount and r["source"] and r["error"] == ""
    assert rows["patrol-paper"]["n_states"] == 2_048_000
    assert rows["patrol-paper"]["n_partitions"] == 8_900


def test_named_models_only_in_the_order_given(capsys):
    rows = _listing(capsys, "savings", "forest")
    assert [r["name"] for r in rows] == ["savings", "forest"]
    assert rows[0]["n_states"] == 16 and rows[1]["n_states"] == 3


def test_a_file_can_be_listed(tmp_path, capsys):
    f = tmp_path / "mine.toml"
    f.write_text('[model]\nkind = "forest"\nS = 9\n[partition]\nkind = "blocks"\nsize = 4\n')
    (row,) = _listing(capsys, str(f))
    assert (row["name"], row["n_states"], row["n_partitions"], row["source"]) == ("mine", 9, 3, "")


def test_gymnasium_models_without_gymnasium(monkeypatch, capsys):
    monkeypatch.setitem(__import__("sys").modules, "gymnasium", None)
    assert main(["models", "frozenlake", "forest"]) == 0
    # rich wraps the note at the console's width (narrow under some runners): words only
    out = " ".join(capsys.readouterr().out.split())
    assert (
        "gymnasium*" in out
        and 'not installed here: gymnasium (pip install "lpbounds[interop]")' in out
    )
    (row,) = [r for r in catalogue(["frozenlake"])]
    assert not row.installed and row.n_states is None and row.needs == ["gymnasium"]


def test_gymnasium_models_with_gymnasium(capsys):
    pytest.importorskip("gymnasium")
    rows = {r["name"]: r for r in _listing(capsys, *["frozenlake", "taxi", "cliffwalking"])}
    # Gymnasium's states and the sink; 4x4 map in 2 x 2 tiles and the sink: 5 sets
    assert (rows["frozenlake"]["n_states"], rows["frozenlake"]["n_partitions"]) == (17, 5)
    assert (rows["taxi"]["n_states"], rows["taxi"]["n_actions"]) == (501, 6)
    assert (rows["cliffwalking"]["n_states"], rows["cliffwalking"]["n_actions"]) == (49, 4)
    assert all(r["installed"] for r in rows.values())


def test_a_bad_name_is_exit_2_and_one_line(capsys):
    assert main(["models", "forest", "no-such-model"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "no instance file 'no-such-model'" in err and "forest, frozenlake" in err


def test_an_unreadable_file_in_models_is_listed_with_its_reason(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "broken.toml").write_text('[model]\nkind = "forest"\nS = 0\n')
    (tmp_path / "models" / "forest.toml").write_text('[model]\nkind = "forest"\nS = 5\n')
    rows = {r["name"]: r for r in _listing(capsys)}
    assert "S must lie in [2, inf]" in rows["broken"]["error"]
    assert rows["forest"]["n_states"] == 5  # ./models is found before the packaged files
    assert rows["forest"]["path"] == "models/forest.toml"
    assert "savings" in rows  # and the packaged ones are still listed


def test_help_and_quiet(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["models", "--help"])
    assert exc.value.code == 0
    assert "outcomes" in capsys.readouterr().out
    assert main(["models", "--quiet"]) == 0
    assert capsys.readouterr().out == ""


def test_the_docs_table_is_the_listing():
    """docs/models.md's sizes table says what ``lpbounds models`` says."""
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "docs" / "models.md").read_text()
    rows = [line for line in page.splitlines() if line.startswith("| `")]
    assert len(rows) == len(SHELF)
    listed = {e.name: e for e in catalogue(SHELF)}
    for line in rows:
        cells = [c.strip() for c in line.strip("|").split("|")]
        name = cells[0].strip("`")
        e = listed[name]
        if e.n_states is None:  # a Gymnasium model without Gymnasium
            continue
        sizes = [int(c.replace(",", "")) for c in cells[2:6]] + [int(cells[7])]
        assert sizes == [e.n_states, e.n_actions, e.n_outcomes, e.n_pairs, e.n_partitions], name
        assert float(cells[6]) == e.discount, name
