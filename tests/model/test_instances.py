"""Instance files: loading, lazy building and clear errors for bad files."""

from __future__ import annotations

import os
import re

import pytest

import lpbounds as lb
from lpbounds.errors import ValidationError


def test_load_garnet_small_by_name_and_path():
    by_name = lb.load_instance("garnet-small")
    by_path = lb.load_instance(by_name.path)
    assert by_name.name == "garnet-small"
    mdp = by_name.mdp()
    assert (mdp.n_states, mdp.n_actions, mdp.n_outcomes) == (300, 3, 4)
    assert by_name.partition().n_partitions == 30
    # seeded: the same file gives the same model
    assert (by_path.mdp().successors == mdp.successors).all()


def test_unknown_key_is_named(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text(
        '[model]\nkind = "garnet"\nn_states = 5\nn_actions = 2\nbranching = 2\nseeds = 3\n'
    )
    with pytest.raises(ValidationError, match=r"unknown key\(s\) \['seeds'\] in \[model\]"):
        lb.load_instance(f).mdp()


def test_missing_key_and_unknown_kind(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text('[model]\nkind = "garnet"\nn_states = 5\n')
    with pytest.raises(ValidationError, match="missing key"):
        lb.load_instance(f).mdp()
    g = tmp_path / "k.toml"
    g.write_text('[model]\nkind = "chess"\n')
    with pytest.raises(ValidationError, match="unknown model kind 'chess'"):
        lb.load_instance(g)


def test_missing_file_and_bad_toml(tmp_path):
    with pytest.raises(ValidationError, match="no instance file"):
        lb.load_instance(tmp_path / "nope.toml")
    f = tmp_path / "x.toml"
    f.write_text("[model\n")
    with pytest.raises(ValidationError, match="not valid TOML"):
        lb.load_instance(f)


def test_instance_without_partition(tmp_path):
    inst = lb.load_instance(
        {"model": {"kind": "garnet", "n_states": 4, "n_actions": 1, "branching": 1}}
    )
    with pytest.raises(ValidationError, match="no \\[partition\\] table"):
        inst.partition()


@pytest.mark.parametrize("kind", ["FIFO", "directory", "character device"])
def test_a_model_that_is_not_a_regular_file_is_named(tmp_path, kind):
    """Checked with stat before any open (opening a FIFO would block)."""
    if kind == "FIFO":
        if not hasattr(os, "mkfifo"):
            pytest.skip("no FIFOs on this platform")
        path = tmp_path / "model.toml"
        os.mkfifo(path)
    elif kind == "directory":
        path = tmp_path / "models.toml"
        path.mkdir()
    else:
        path = tmp_path.joinpath("/dev/null")
        if not path.exists():
            pytest.skip("no /dev/null")
    with pytest.raises(
        ValidationError, match=re.escape(f"not a regular file: '{path}' (a {kind})")
    ):
        lb.load_instance(path)


# ---------------------------------------------------------------------- names of the shelf
SHELF = [
    "forest",
    "gridworld",
    "queue",
    "inventory",
    "savings",
    "frozenlake",
    "taxi",
    "cliffwalking",
]


@pytest.mark.parametrize("name", SHELF)
def test_shelf_names_resolve_like_garnet_small(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no ./models here: the packaged files
    from lpbounds.model.instances import packaged_models_dir, resolve_instance_path

    expected = packaged_models_dir() / f"{name}.toml"
    for spelling in (name, f"{name}.toml", f"models/{name}.toml"):
        assert resolve_instance_path(spelling) == expected
    inst = lb.load_instance(name)
    assert inst.name == name and inst.has_partition  # loaded lazily: nothing built yet
    assert inst.config["about"]["source"]


def test_unknown_name_lists_the_packaged_models():
    with pytest.raises(ValidationError) as exc:
        lb.load_instance("forrest")
    msg = str(exc.value)
    assert "no instance file 'forrest'" in msg
    assert "forest, frozenlake, garnet-paper-scale, garnet-small, gridworld" in msg


def test_shelf_builders_are_in_lpbounds_instances():
    for name in ["forest", "gridworld", "admission_queue", "inventory", "savings"]:
        assert callable(getattr(lb.instances, name))
    assert lb.instances.forest().n_states == 3


def test_explicit_model_and_labels_partition():
    """``kind = "explicit"``: the two-state model of conftest, V* by its closed form."""
    from tests.conftest import two_state_closed_form

    table = {
        "model": {
            "kind": "explicit",
            "successors": [[[0], [1]], [[1], [1]]],
            "probabilities": [1.0],
            "rewards": [[1.0, 0.0], [2.0, 0.0]],
            "allowed": [[True, True], [True, False]],
            "discount": 0.8,
        },
        "partition": {"kind": "labels", "labels": [0, 0]},
    }
    inst = lb.load_instance(table)
    res = lb.solve_exact(inst.mdp(), "pi")
    assert res.values == pytest.approx(two_state_closed_form(0.8), abs=1e-12)
    assert inst.partition().n_partitions == 1
    bad = {**table, "partition": {"kind": "labels", "labels": [0, 1, 2]}}
    with pytest.raises(ValidationError, match=r"labels has 3 entries; the model has 2 states"):
        lb.load_instance(bad).partition()
    bad = {"model": {**table["model"], "rewards": [[1.0, 0.0]]}}
    with pytest.raises(ValidationError, match=r"^\[model\] .*rewards"):
        lb.load_instance(bad).mdp()
