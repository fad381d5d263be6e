"""lpbounds.verify and ``lpbounds verify``: records, their honesty, and the exit status."""

from __future__ import annotations

import json

import numpy as np
import pytest

import lpbounds as lb
import lpbounds.verify as verify
from lpbounds.cli.main import main
from lpbounds.errors import SolverNotInstalledError, ValidationError
from lpbounds.formulations import RLP

KEYS = {"check", "instance", "solver", "max_deviation", "tolerance", "pass", "detail"}
CHECKS = {"Lemma 1", "Theorem 1", "Lemma 2", "Theorem 2"}

TINY_TOML = """
[model]
kind = "garnet"
n_states = 14
n_actions = 2
branching = 2
discount = 0.85
seed = 3

[partition]
kind = "random"
n_partitions = 4
seed = 5
"""


@pytest.fixture
def tiny_model(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY_TOML)
    return str(path)


@pytest.fixture(scope="module")
def tiny_instance():
    mdp = lb.garnet(16, 2, 3, 0.9, seed=9, allowed_fraction=0.8)
    return verify.VerifyInstance("tiny", mdp, lb.random_partition(16, 4, seed=2))


def test_records_of_one_instance(tiny_instance):
    recs = verify.verify_instance(tiny_instance, ["HIGHS", "CLARABEL"], n_costs=2)
    assert all(set(r) == KEYS for r in recs)
    assert {r["check"] for r in recs} == CHECKS
    assert {r["solver"] for r in recs} == {"exact", "HIGHS", "CLARABEL", "all"}
    for r in recs:
        assert r["pass"], r
        assert r["tolerance"] > 0 and np.isfinite(r["max_deviation"])
        assert r["pass"] == (r["max_deviation"] <= r["tolerance"])
    json.dumps(recs)  # plain types only


def test_a_wrong_optimum_is_caught(tiny_instance, monkeypatch):
    """An RLP whose solver answer is off by 1e-3 must fail Theorem 1 (and nothing else may
    hide it)."""

    class Shifted(RLP):
        def solve(self, *args, **kwargs):
            res = super().solve(*args, **kwargs)
            res.values = res.values + 1e-3
            return res

    monkeypatch.setattr(verify, "RLP", Shifted)
    recs = verify.verify_instance(tiny_instance, ["HIGHS"], n_costs=1)
    failed = {(r["check"], r["detail"].split(":")[0]) for r in recs if not r["pass"]}
    assert ("Theorem 1", "RLP optimum = v* for 1 costs (0 with zeros)") in failed
    bad = [r for r in recs if r["check"] == "Theorem 1" and r["solver"] == "HIGHS"]
    assert any(abs(r["max_deviation"] - 1e-3) < 1e-6 for r in bad)


def test_remark_2_records():
    recs = verify.verify_remark2(["HIGHS", "SCIPY"])
    assert [r["solver"] for r in recs] == ["HIGHS", "SCIPY"]
    for r in recs:
        assert r["check"] == "Remark 2" and r["pass"]
        assert r["max_deviation"] > r["tolerance"], "the cost dependence must be shown"


def test_random_instances_are_seeded_and_valid():
    a = verify.random_instances(3, seed=4)
    b = verify.random_instances(3, seed=4)
    assert [i.name for i in a] == ["random-4-0", "random-4-1", "random-4-2"]
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x.mdp.successors, y.mdp.successors)
        assert np.array_equal(x.partition.labels, y.partition.labels)
    with pytest.raises(ValidationError):
        verify.random_instances(-1)


def test_default_solvers_and_bad_inputs(tiny_instance):
    assert verify.default_solvers()[:3] == ["HIGHS", "CLARABEL", "SCIPY"]
    with pytest.raises(SolverNotInstalledError, match="unknown solver"):
        verify.verify_instance(tiny_instance, ["NOPE"])
    with pytest.raises(ValidationError, match="n_costs"):
        verify.verify_instance(tiny_instance, ["HIGHS"], n_costs=0)


def test_model_instances_skip_large_models():
    insts, skipped = verify.model_instances(max_states=1000)
    assert "garnet-paper-scale" in skipped
    assert all(i.mdp.n_states <= 1000 for i in insts)


# ---------------------------------------------------------------------- the command
def test_cli_passes_and_writes_json(tiny_model, tmp_path, capsys):
    out = tmp_path / "records.json"
    rc = main(["verify", tiny_model, "--random", "0", "--solvers", "HIGHS", "--json", str(out)])
    text = capsys.readouterr().out
    assert rc == 0, text
    recs = json.loads(out.read_text())
    assert recs and all(set(r) == KEYS and r["pass"] for r in recs)
    assert {r["instance"] for r in recs if r["check"] != "Remark 2"} == {"tiny"}
    assert "Remark 2" in {r["check"] for r in recs}
    assert "checks pass" in text and "Theorem 1" in text


def test_cli_exits_nonzero_on_a_failed_check(tiny_model, monkeypatch, capsys):
    class Broken(RLP):
        def solve(self, *args, **kwargs):
            res = super().solve(*args, **kwargs)
            res.values = res.values - 1e-2  # below v*: violates Theorem 1's domination
            return res

    monkeypatch.setattr(verify, "RLP", Broken)
    rc = main(["verify", tiny_model, "--random", "0", "--solvers", "HIGHS"])
    assert rc == 1
    assert "NO" in capsys.readouterr().out


def test_cli_unknown_solver(tiny_model, capsys):
    rc = main(["verify", tiny_model, "--random", "0", "--solvers", "NOPE"])
    assert rc == 1
    assert "unknown solver" in capsys.readouterr().err


def test_summarize_keeps_the_worst_record():
    recs = [
        {
            "check": "Theorem 1",
            "solver": "HIGHS",
            "max_deviation": 1e-9,
            "tolerance": 1e-6,
            "pass": True,
        },
        {
            "check": "Theorem 1",
            "solver": "HIGHS",
            "max_deviation": 2e-6,
            "tolerance": 1e-6,
            "pass": False,
        },
        {
            "check": "Remark 2",
            "solver": "HIGHS",
            "max_deviation": 0.5,
            "tolerance": 1e-6,
            "pass": True,
        },
        {
            "check": "Remark 2",
            "solver": "HIGHS",
            "max_deviation": 0.1,
            "tolerance": 1e-6,
            "pass": True,
        },
    ]
    rows = verify.summarize(recs)
    assert [(r["check"], r["records"], r["passed"]) for r in rows] == [
        ("Theorem 1", 2, 1),
        ("Remark 2", 2, 2),
    ]
    assert rows[0]["max_deviation"] == 2e-6, "the worst ratio, not the first record"
    assert rows[1]["max_deviation"] == 0.1, "Remark 2: the smallest shown difference"
