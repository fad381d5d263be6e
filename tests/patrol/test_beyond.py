"""The study beyond the paper's size on small instances: every number of a size's row
recomputed independently from the array path (the MDP's arrays, numpy written here), the
certified verdicts on hand-made intervals, the result files, and `reproduce --beyond`."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lpbounds import evaluate_policy, solve_exact
from lpbounds.patrol import beyond
from lpbounds.patrol.beyond import (
    Check,
    SizeResult,
    certified_check,
    load_result,
    report_section,
    save_result,
    study,
    tighter_side,
    write_beyond,
)
from lpbounds.patrol.greedy_mc import partition_bounds
from lpbounds.patrol.model import PatrolModel
from lpbounds.patrol.params import PatrolParams
from lpbounds.patrol.reproduce import reproduce
from lpbounds.tolerances import GREEDY_TIE_RTOL

PARAMS = PatrolParams(N=6, stations=(0, 2, 4), D=2, Gamma=5)


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    ck = tmp_path_factory.mktemp("ck")
    lines: list[str] = []
    res = study(PARAMS, "three-stations", log=lines.append, checkpoint=ck)
    return res, lines, ck


@pytest.fixture(scope="module")
def reference():
    """The row from the array path: V* by solve_exact, Q-values from the successor arrays
    (written here), pi_s by the tie rule, V_sub by solve-free iterative evaluation."""
    pm = PatrolModel(PARAMS)
    mdp = pm.mdp()
    labels = pm.partition().labels
    ref = solve_exact(mdp)
    v = ref.values
    pb = partition_bounds(PARAMS)
    succ, p = mdp.successors.astype(np.int64), np.asarray(mdp.probabilities)

    def q_of(vec):
        acc = np.zeros(succ.shape[:2])
        for ll in range(p.size):
            acc = acc + p[ll] * vec[succ[:, :, ll]]
        return np.where(mdp.allowed, mdp.rewards + mdp.discount * acc, -np.inf)

    qw = q_of(pb.lower[labels])
    best_w = qw.max(axis=1)
    tied = qw >= (best_w - GREEDY_TIE_RTOL * np.maximum(1.0, np.abs(best_w)))[:, None]
    pi_s = tied.argmax(axis=1)
    qv = q_of(v)
    best_v = qv.max(axis=1)
    q_pis = qv[np.arange(v.size), pi_s]
    optimal = q_pis >= best_v - GREEDY_TIE_RTOL * np.maximum(1.0, np.abs(best_v))
    vsub = evaluate_policy(mdp, pi_s, method="direct").values
    up, low = pb.upper[labels] - v, v - pb.lower[labels]
    return {
        "upper_max": up.max(),
        "upper_mean": up.mean(),
        "lower_max": low.max(),
        "lower_mean": low.mean(),
        "gap_max": (pb.upper - pb.lower)[labels].max(),
        "gap_mean": (pb.upper - pb.lower)[labels].mean(),
        "optimal_fraction": optimal.mean(),
        "differs_fraction": (pi_s != ref.policy).mean(),
        "max_vstar_minus_vsub": (v - vsub).max(),
        "vstar_residual": ref.residual,
        "upper_margin": up.min(),
        "lower_margin": low.min(),
    }


def test_the_row_equals_the_array_path(result, reference):
    res, _, _ = result
    g, pol = res.gaps, res.policy
    for key in ("upper_max", "lower_max", "gap_max"):
        assert g[key] == reference[key], key
    for key in ("upper_mean", "lower_mean", "gap_mean"):
        assert g[key] == pytest.approx(reference[key], rel=1e-12, abs=1e-15), key
    assert g["upper_share"] + g["lower_share"] == pytest.approx(1.0, rel=1e-12)
    assert pol["optimal_fraction"] == reference["optimal_fraction"]
    assert pol["differs_fraction"] == reference["differs_fraction"]
    # V_sub by LU above, by sweeps in the study: equal within their certified errors
    err = pol["vsub_error_bound"] + res.vstar["error_bound"] + 1e-12
    assert abs(pol["max_vstar_minus_vsub"] - reference["max_vstar_minus_vsub"]) <= err
    assert res.vstar["residual"] == reference["vstar_residual"]
    assert res.n_states == PARAMS.n_states and res.n_partitions == PARAMS.n_partitions


def test_the_checks_hold_with_the_margins_of_the_array_path(result, reference):
    res, _, _ = result
    assert res.all_hold, res.checks
    up = res.checks["vstar_le_upper"]
    assert up.min_difference == reference["upper_margin"]
    assert up.margin == pytest.approx(reference["upper_margin"] - up.errors, abs=1e-15)
    assert res.checks["lower_le_vstar"].min_difference == reference["lower_margin"]


def test_certified_verdicts_on_hand_made_intervals():
    # a = 1.0 +- 0.1 >= b = 0.5 +- 0.1: proven
    assert certified_check("a >= b", 0.5, 7, 1.0, 0.1, 0.5, 0.1).verdict == "holds"
    # a = 0.5 +- 0.1 < b = 1.0 +- 0.1: proven violated, at the given state
    c = certified_check("a >= b", -0.5, 7, 0.5, 0.1, 1.0, 0.1)
    assert (c.verdict, c.state) == ("violated", 7)
    assert c.margin == pytest.approx(-0.7)
    # a = 0.95 +- 0.1, b = 1.0 +- 0.1: the intervals overlap, nothing proven
    assert certified_check("a >= b", -0.05, 0, 0.95, 0.1, 1.0, 0.1).verdict == "inconclusive"
    # a = 1.05 +- 0.1, b = 1.0 +- 0.1: a >= b not proven, but a >= b - 0.4 is
    ok = certified_check("a >= b", 0.05, 0, 1.05, 0.1, 1.0, 0.1, accuracy=0.4)
    assert (ok.verdict, ok.accuracy) == ("holds", 0.4)
    assert certified_check("a >= b", 0.05, 0, 1.05, 0.1, 1.0, 0.1).verdict == "inconclusive"


def test_saved_results_round_trip_and_other_parameters_are_ignored(result, tmp_path):
    res, _, _ = result
    path = save_result(res, tmp_path / "r.json")
    back = load_result(path, PARAMS)
    assert back is not None and back.gaps == res.gaps and back.checks == res.checks
    assert isinstance(back.checks["vsub_le_vstar"], Check)
    assert load_result(path, PARAMS.replace(Gamma=4)) is None
    assert load_result(tmp_path / "missing.json", PARAMS) is None


def test_a_checkpoint_is_resumed(result):
    res, lines, ck = result
    assert (ck / "vstar.npy").is_file() and not any("loaded" in ln for ln in lines)
    again: list[str] = []
    res2 = study(PARAMS, "three-stations", log=again.append, checkpoint=ck)
    assert any("V* loaded" in ln for ln in again)
    assert res2.gaps == res.gaps and res2.vstar["status"] == res.vstar["status"] == "optimal"
    # the loaded vector is certified again, not trusted: its residual is within the tolerance
    assert res2.vstar["residual"] <= res2.vstar["tol"]


def test_a_tampered_checkpoint_is_not_trusted(result, tmp_path):
    _, _, ck = result
    import shutil

    bad = tmp_path / "bad"
    shutil.copytree(ck, bad)
    v = np.load(bad / "vstar.npy")
    v[7] += 1e-3  # an edit the saved summary does not know about
    np.save(bad / "vstar.npy", v)
    res = study(PARAMS, "three-stations", log=[].append, checkpoint=bad)
    assert res.vstar["status"] == "inaccurate"
    # at state 7, T v - v moves by at least (1 - lambda) 1e-3 (lambda = 0.9)
    assert res.vstar["residual"] >= 0.99 * (1 - PARAMS.discount) * 1e-3


def _fake(m: int, upper_mean: float, lower_mean: float, upper_max: float = 1.0) -> SizeResult:
    gap = upper_mean + lower_mean
    gaps = {
        "upper_max": upper_max,
        "upper_mean": upper_mean,
        "lower_max": 0.5,
        "lower_mean": lower_mean,
        "gap_max": 2.0,
        "gap_mean": gap,
        "upper_share": upper_mean / gap,
        "lower_share": lower_mean / gap,
    }
    check = Check("V*(x) <= v*(i)", "holds", 1e-4, 1e-4, 0, 1e-9)
    return SizeResult(
        instance=f"m{m}",
        m=m,
        stations=list(range(m)),
        n_states=10**m,
        n_partitions=10 * m,
        source="test",
        vstar={"residual": 1e-11, "error_bound": 1e-10},
        bounds={},
        gaps=gaps,
        policy={"optimal_fraction": 0.99, "max_vstar_minus_vsub": 1e-3},
        checks={"vstar_le_upper": check},
    )


def test_the_sentence_on_the_tighter_side():
    rows = [_fake(4, 0.3, 0.1), _fake(5, 0.4, 0.1)]
    s = tighter_side(rows)
    assert s.startswith("The lower bound w* is the tighter one at every size")
    assert "0.25 at m = 4" in s and "0.20 at m = 5" in s
    assert tighter_side([_fake(4, 0.1, 0.3)]).startswith("The upper bound v*")
    mixed = tighter_side([_fake(4, 0.1, 0.3), _fake(5, 0.4, 0.1)])
    assert "at m = 5 only" in mixed and "at m = 4, 5 (of 4, 5)" in mixed


def test_section_figure_and_json(result, tmp_path):
    res, _, _ = result
    rows = [_fake(2, 0.3, 0.1), res]
    lines, files = write_beyond(tmp_path, rows, [], figures=True)
    text = "\n".join(lines)
    assert "## Beyond the paper" in text and "What the gap shares say" in text
    assert "fig8_beyond_gap_shares.png" in text
    assert files["fig8"].read_bytes().startswith(b"\x89PNG")
    data = json.loads(files["beyond"].read_text())
    assert [r["m"] for r in data["sizes"]] == [2, 3]
    assert report_section(rows, [], None, tmp_path)[0].startswith("## Beyond the paper")


def test_reproduce_beyond_writes_the_section(result, tmp_path, monkeypatch):
    """The plumbing of ``reproduce(beyond=True)`` with the sizes and the Monte Carlo
    replaced by small ones (the real ones take minutes to hours)."""
    res, _, _ = result
    real_mc = beyond.monte_carlo
    monkeypatch.setattr(beyond, "run_sizes", lambda *a, **k: [res])
    monkeypatch.setattr(beyond, "monte_carlo", lambda *a, **k: real_mc(("patrol-small",)))
    rep = reproduce(
        "models/patrol-small.toml",
        tmp_path / "out",
        seeds=[1],
        n_steps=500,
        figures=False,
        beyond=True,
        beyond_cache=tmp_path / "cache",
    )
    text = (tmp_path / "out" / "report.md").read_text()
    assert "## Beyond the paper" in text and "pi_s where no exact value exists" in text
    assert "Inconsistent Monte Carlo" not in text  # every interval below v* + err
    data = json.loads((tmp_path / "out" / "beyond.json").read_text())
    assert [r["m"] for r in data["sizes"]] == [2, 3]
    assert data["sizes"][0]["source"].startswith("array path")
    assert all(c["verdict"] == "holds" for c in data["sizes"][0]["checks"].values())
    assert rep.out == tmp_path / "out"


def test_reproduce_beyond_refuses_other_sizes_before_computing(tmp_path):
    from lpbounds.errors import ValidationError

    with pytest.raises(ValidationError, match=r"beyond_sizes must be 5, 6 or both; got \[4\]"):
        reproduce("models/patrol-small.toml", tmp_path / "out", beyond=True, beyond_sizes=[4])
    assert not (tmp_path / "out").exists()


def test_the_array_path_row_must_find_the_runs_policy():
    """``study_from_arrays`` recomputes pi_s and refuses a run whose pi_s differs."""
    from lpbounds.dp import PolicyEvaluation
    from lpbounds.errors import ConsistencyError
    from lpbounds.patrol.beyond import study_from_arrays

    params = PatrolParams(N=4, stations=(0, 2), D=2, Gamma=3)
    pm = PatrolModel(params)
    mdp = pm.mdp()
    ref = solve_exact(mdp)
    pb = partition_bounds(params)
    from lpbounds import greedy_policy

    pi_s = greedy_policy(mdp, pb.lower[pm.partition().labels]).astype(np.int8)
    ev = evaluate_policy(mdp, pi_s, method="iterative")
    summary = {"error_bound": ref.error_bound, "residual": ref.residual}
    kw = dict(vstar=ref.values, vstar_summary=summary, pistar=ref.policy, bounds=pb, vsub=ev)
    row = study_from_arrays(params, "tiny", pi_s=pi_s, **kw)
    assert row.source.startswith("array path") and row.all_hold
    assert row.policy["vsub_sweeps"] == ev.sweeps
    wrong = pi_s.copy()
    wrong[0] = 1 - wrong[0] if wrong[0] < 2 else 0
    with pytest.raises(ConsistencyError, match="differs from the run's on 1 states"):
        study_from_arrays(params, "tiny", pi_s=wrong, **kw)
    assert isinstance(ev, PolicyEvaluation)


def test_a_monte_carlo_interval_above_the_upper_bound_is_reported():
    """V_pis <= V* <= v*: an interval wholly above v* + err proves the estimate wrong."""
    t1 = {
        "mean_loiters": 4.7,
        "mean_delay": 4.7,
        "mean_delay_plus_one": 5.7,
        "worst_delay": 14,
        "worst_delay_plus_one": 15,
    }
    entry = {
        "m": 6,
        "n_states": 10,
        "starts": 3,
        "paths": 100,
        "horizon": 5,
        "max_half_width": 1e-3,
        "gap_bound_max": -0.1,
        "gap_bound_mean": -0.2,
        "above_upper": 2,
        "table1": t1,
        "level": 0.95,
        "table1_seeds": [1],
        "table1_steps": 10,
    }
    text = "\n".join(beyond._mc_lines([entry]))
    assert "**Inconsistent Monte Carlo at m = 6:** 2 of 3 intervals" in text
    entry["above_upper"] = 0
    assert "Inconsistent" not in "\n".join(beyond._mc_lines([entry]))
