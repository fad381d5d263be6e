"""`lpbounds solve MODEL --out DIR` keeps V*, the policy and a certificate that an
independent recomputation confirms; every output records how it was made."""

from __future__ import annotations

import json
import os
import subprocess
import time
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.cli.main import main

SMALL = "models/patrol-small.toml"
ROOT = Path(__file__).resolve().parents[2]


def _dense_policy_system(mdp, policy):
    """(I - lambda P_pi, r_pi) built from the model's arrays with numpy alone."""
    n = mdp.n_states
    succ = np.asarray(mdp.successors)
    probs = np.broadcast_to(np.asarray(mdp.probabilities_full()), succ.shape)
    rows = np.arange(n)
    p = np.zeros((n, n))
    np.add.at(
        p, (np.repeat(rows, succ.shape[2]), succ[rows, policy].ravel()), probs[rows, policy].ravel()
    )
    r = np.asarray(mdp.rewards)[rows, policy]
    return np.eye(n) - mdp.discount * p, r


def _q_values(mdp, v):
    succ = np.asarray(mdp.successors)
    probs = np.broadcast_to(np.asarray(mdp.probabilities_full()), succ.shape)
    q = np.asarray(mdp.rewards) + mdp.discount * (probs * v[succ]).sum(axis=2)
    return np.where(np.asarray(mdp.allowed), q, -np.inf)


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    out = tmp_path_factory.mktemp("solve") / "d"
    assert main(["solve", SMALL, "--out", str(out), "--quiet"]) == 0
    return out


def test_solve_out_writes_loadable_values_policy_and_certificate(solved):
    assert sorted(p.name for p in solved.iterdir()) == [
        "manifest.json",
        "solution.json",
        "solution.npz",
    ]
    with np.load(solved / "solution.npz") as z:
        arrays = {k: z[k] for k in z.files}
    assert set(arrays) == {"values", "policy", "lower", "upper"}
    mdp = lb.load_instance(SMALL).mdp()
    for name in ("values", "lower", "upper", "policy"):
        assert arrays[name].shape == (mdp.n_states,)
    summary = json.loads((solved / "solution.json").read_text())
    assert summary["n_states"] == mdp.n_states
    assert summary["action_names"] == list(mdp.action_names)


def test_the_certificate_holds_against_an_independent_solve(solved):
    """V_pi of the saved policy by a dense linear solve; the policy is optimal (no action
    improves on V_pi), so V_pi = V*, and the saved bracket must contain it."""
    mdp = lb.load_instance(SMALL).mdp()
    with np.load(solved / "solution.npz") as z:
        values, policy, lower, upper = [z[k] for k in ("values", "policy", "lower", "upper")]
    assert np.all(np.asarray(mdp.allowed)[np.arange(mdp.n_states), policy])
    a, r = _dense_policy_system(mdp, policy)
    v_pi = np.linalg.solve(a, r)
    scale = np.abs(v_pi).max()
    # optimality of the policy: one Bellman step improves nowhere (beyond rounding)
    q = _q_values(mdp, v_pi)
    assert np.all(q.max(axis=1) - v_pi <= 1e-12 * scale)
    # the certificate: lower <= V* <= upper, and it is tight
    slack = 1e-13 * scale  # the dense solve's own error
    assert np.all(lower <= v_pi + slack) and np.all(v_pi - slack <= upper)
    assert np.all(lower <= values) and np.all(values <= upper)
    cert = json.loads((solved / "solution.json").read_text())["certificate"]
    assert np.max(upper - lower) == pytest.approx(cert["width"])
    assert cert["width"] < 1e-8 * scale
    assert np.abs(values - v_pi).max() <= cert["error_bound"] + slack
    # the recorded residual is the residual of the saved values, recomputed here
    residual = np.abs(_q_values(mdp, values).max(axis=1) - values).max()
    assert max(cert["residual_up"], cert["residual_down"]) == pytest.approx(residual, rel=1e-6)


def test_the_policy_is_the_greedy_one(solved):
    mdp = lb.load_instance(SMALL).mdp()
    with np.load(solved / "solution.npz") as z:
        values, policy = z["values"], z["policy"]
    q = _q_values(mdp, values)
    best = q.max(axis=1)
    chosen = q[np.arange(mdp.n_states), policy]
    assert np.all(chosen >= best - 1e-12 * np.abs(best).max())


def _check_environment(meta: dict) -> None:
    assert meta["lpbounds"] == lb.__version__
    for name in ("numpy", "scipy", "cvxpy", "highspy", "clarabel"):
        assert meta["dependencies"][name] == version(name)
    assert meta["solvers"]["highspy"] == version("highspy")
    assert meta["machine"]["cpus"] == os.cpu_count()
    stamp = time.mktime(time.strptime(meta["date"], "%Y-%m-%dT%H:%M:%SZ")) - time.timezone
    assert abs(time.time() - stamp) < 3600
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=False
    )
    if head.returncode == 0:
        assert meta["git"]["commit"] == head.stdout.strip()
        assert isinstance(meta["git"]["modified"], bool)


def test_solve_out_records_versions_commit_machine_and_date(solved):
    _check_environment(json.loads((solved / "solution.json").read_text())["environment"])
    manifest = json.loads((solved / "manifest.json").read_text())
    _check_environment(manifest["environment"])
    assert {f["name"] for f in manifest["files"]} == {"solution.npz", "solution.json"}


def test_solve_json_records_the_environment(tmp_path):
    path = tmp_path / "s.json"
    assert main(["solve", "garnet-small", "--json", str(path), "--quiet"]) == 0
    _check_environment(json.loads(path.read_text())["environment"])


def test_solve_out_refuses_a_folder_with_other_files_before_solving(tmp_path, capsys):
    out = tmp_path / "d"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(["solve", SMALL, "--out", str(out)]) == 2
    assert "notes.txt" in capsys.readouterr().err
    assert (out / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]


def test_reproduce_report_records_versions_commit_and_machine(tmp_path):
    out = tmp_path / "r"
    args = ["reproduce", SMALL, "--out", str(out), "--seeds", "1", "--steps", "200"]
    assert main([*args, "--no-figures", "--quiet"]) == 0
    report = (out / "report.md").read_text()
    assert f"numpy {version('numpy')}" in report and f"highspy {version('highspy')}" in report
    assert f"{os.cpu_count()} CPUs" in report
    manifest = json.loads((out / "manifest.json").read_text())
    _check_environment(manifest["environment"])
    git = manifest["environment"]["git"]
    if git:
        assert git["commit"][:12] in report
