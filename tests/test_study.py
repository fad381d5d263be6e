"""lpbounds.study and ``lpbounds compare``: results equal independent solves, skips noted."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize as so

import lpbounds as lb
from lpbounds.cli.main import main
from lpbounds.errors import ValidationError
from lpbounds.formulations.base import INSTALL_HINTS, installed_lp_solvers
from lpbounds.study import (
    FORMULATIONS,
    FormulationSpec,
    available_formulations,
    load_case,
    run_study,
    solver_configs,
)

SPEC = "garnet:60:8:3"


def _loop_lp(mdp: lb.FiniteMDP, labels: np.ndarray | None) -> tuple[float, np.ndarray]:
    """ELP (labels None) or RLP built row by row with Python loops, solved by scipy.

    Deliberately simple and independent of lpbounds' rows: one inequality
    ``v(i) - lambda sum_l p_l v(label(f(x,u,l))) >= R_u(x)`` per (x, u).
    """
    n = mdp.n_states
    lab = np.arange(n) if labels is None else labels
    m = int(lab.max()) + 1
    probs = mdp.probabilities_full()
    a_ub, b_ub = [], []
    for x in range(n):
        for u in range(mdp.n_actions):
            if not mdp.allowed[x, u]:
                continue
            row = np.zeros(m)
            row[lab[x]] += 1.0
            for k in range(mdp.n_outcomes):
                row[lab[mdp.successors[x, u, k]]] -= mdp.discount * probs[x, u, k]
            a_ub.append(-row)  # linprog wants A_ub x <= b_ub
            b_ub.append(-mdp.rewards[x, u])
    cost = np.bincount(lab, minlength=m).astype(float)  # c = 1 per state
    res = so.linprog(cost, A_ub=np.array(a_ub), b_ub=np.array(b_ub), bounds=(None, None))
    assert res.status == 0, res.message
    return float(res.fun), res.x


@pytest.fixture(scope="module")
def study() -> lb.study.StudyResult:
    return run_study([SPEC], ["ELP", "RLP"], ["HIGHS:simplex", "HIGHS:ipm", "CLARABEL"], jobs=1)


def test_study_matches_independent_lp(study):
    case = load_case(SPEC)
    frame = study.frame
    assert len(frame) == 2 * 3, frame
    assert set(frame["status"]) == {"optimal"}, frame[["config", "status", "note"]]
    for form, labels in (("ELP", None), ("RLP", case.partition.labels)):
        ref, _ = _loop_lp(case.mdp, labels)
        got = frame.loc[frame["formulation"] == form, "objective"].to_numpy()
        tol = 1e-6 * max(1.0, abs(ref))
        assert np.all(np.abs(got - ref) <= tol), (
            f"{form}: study objectives {got} vs loop-built scipy LP {ref} (tol {tol:.1e})"
        )
    # the deviation column is measured against exact DP: the loop LP's x must agree
    _, v_elp = _loop_lp(case.mdp, None)
    vstar = lb.solve_exact(case.mdp).values
    assert np.abs(v_elp - vstar).max() <= 1e-6 * max(1.0, np.abs(vstar).max()), (
        "independent ELP vs exact DP, tol 1e-6 relative"
    )
    assert frame["accurate"].all(), frame[["formulation", "config", "certified_error"]]
    assert (frame["max_deviation"] <= frame["deviation_tol"]).all()
    assert (frame["n_states"] == 60).all() and (frame["n_partitions"] == 8).all()
    # the certified error is an honest bound: the distance to the exact DP fixed point
    # never exceeds it (plus the DP's own error bound)
    assert np.isfinite(frame["certified_error"]).all()
    slack = frame["certified_error"] + frame["reference_error_bound"]
    assert (frame["max_deviation"] <= slack * (1 + 1e-9)).all(), frame[
        ["formulation", "config", "max_deviation", "certified_error"]
    ]


def test_parallel_processes_equal_serial(study):
    par = run_study([SPEC], ["ELP", "RLP"], ["HIGHS:simplex", "HIGHS:ipm", "CLARABEL"], jobs=2)
    key = ["formulation", "config"]
    a = study.frame.set_index(key)["objective"].sort_index()
    b = par.frame.set_index(key)["objective"].sort_index()
    assert a.index.equals(b.index)
    assert np.allclose(a.to_numpy(), b.to_numpy(), rtol=1e-9, atol=0), "serial vs parallel"


def test_missing_solver_skipped_with_note():
    have = set(installed_lp_solvers())
    missing = next((s for s in INSTALL_HINTS if s not in have), None)
    if missing is None:  # pragma: no cover - every known solver installed
        pytest.skip("every solver lpbounds knows is installed here")
    configs, notes = solver_configs(["HIGHS:simplex", missing])
    assert [c.label for c in configs] == ["HIGHS:simplex"]
    assert any(missing in n and INSTALL_HINTS[missing] in n for n in notes), notes
    res = run_study(["garnet:20:4"], ["RLP"], ["HIGHS:simplex", missing], jobs=1)
    assert list(res.frame["config"]) == ["HIGHS:simplex"]
    assert any(missing in n for n in res.notes), res.notes
    with pytest.raises(ValidationError, match="no solver to run"):
        run_study(["garnet:20:4"], ["RLP"], [missing], jobs=1)


@pytest.mark.parametrize("bad", ["NO_SUCH_SOLVER", "HIGHS:nope"])
def test_unknown_solver_or_option_set_is_an_error(bad):
    with pytest.raises(ValidationError, match=bad.split(":")[-1]):
        solver_configs(["HIGHS:simplex", bad])


def test_missing_model_is_an_error_before_any_solve(tmp_path):
    with pytest.raises(ValidationError, match="no_such_model"):
        run_study(["garnet:20:4", str(tmp_path / "no_such_model.toml")], ["RLP"], ["HIGHS"])


def test_statuses_use_the_shared_vocabulary():
    from types import SimpleNamespace

    from lpbounds.status import Status
    from lpbounds.study import _status

    assert _status(SimpleNamespace(status=Status.OPTIMAL)) == "optimal"
    assert _status(SimpleNamespace(status=Status.ITERATION_LIMIT)) == "iteration_limit"
    for old in ("optimal_inaccurate", "residual_too_large"):
        assert _status(SimpleNamespace(status=old)) == "inaccurate"


def test_an_inaccurate_solve_is_not_accurate_and_keeps_a_valid_bound():
    """Asking SCS for more than it reaches: status inaccurate, accurate False, and the
    certified error still bounds the distance to the exact fixed point."""
    res = run_study(["garnet:40:5:1"], ["RLP"], ["SCS"], accuracy=1e-14, jobs=1)
    frame = res.frame
    assert len(frame) == 1
    row = frame.iloc[0]
    assert row["status"] == "inaccurate" and not row["accurate"], row
    assert row["max_deviation"] <= row["certified_error"] + row["reference_error_bound"]
    assert row["certified_error"] > 1e-14 * 1.0  # wider than asked for: why it is inaccurate


def test_default_solvers_note_what_is_missing():
    configs, notes = solver_configs(None)
    labels = {c.label for c in configs}
    assert "CLARABEL" in labels and "HIGHS:simplex" in labels and "HIGHS:ipm" in labels
    missing = [s for s in INSTALL_HINTS if s not in installed_lp_solvers()]
    if "GLPK" in missing:
        assert any("GLPK" in n for n in notes), notes


def test_unavailable_formulation_noted(monkeypatch):
    spec = FormulationSpec("NOPE", "lpbounds._no_such_module", None, None, "")  # type: ignore[arg-type]
    monkeypatch.setitem(FORMULATIONS, "NOPE", spec)
    names, notes = available_formulations(["RLP", "NOPE"])
    assert names == ["RLP"]
    assert any("NOPE" in n and "not available" in n for n in notes), notes
    with pytest.raises(ValidationError, match="unknown formulation"):
        available_formulations(["XLP"])


def test_formulation_not_applicable_is_noted():
    # UBLP is for patrol instances: on a random MDP it is skipped with a note, not run
    names, _ = available_formulations(["UBLP"])
    if not names:
        pytest.skip("lpbounds.patrol.bounds not on this branch yet")
    res = run_study(["garnet:20:4"], ["RLP", "UBLP"], ["HIGHS:simplex"], jobs=1)
    assert set(res.frame["formulation"]) == {"RLP"}
    assert any("UBLP" in n and "patrol" in n for n in res.notes), res.notes


@pytest.mark.parametrize("bad", ["garnet:10", "garnet:5:9", "garnet:a:b"])
def test_bad_instance_spec(bad):
    with pytest.raises(ValidationError, match="garnet"):
        run_study([bad], ["RLP"], ["HIGHS:simplex"], jobs=1)


def test_repeat_must_be_positive():
    with pytest.raises(ValidationError, match="repeat"):
        run_study(["garnet:20:4"], ["RLP"], ["HIGHS"], repeat=0)


def test_cli_writes_csv_and_plot(tmp_path):
    import pandas as pd

    out = tmp_path / "cmp"
    argv = ["compare", "garnet:40:5:1", "garnet:80:9:2", "--formulations", "RLP"]
    argv += ["--solvers", "HIGHS:ipm", "CLARABEL", "--repeat", "2", "--jobs", "1"]
    assert main([*argv, "--out", str(out)]) == 0
    frame = pd.read_csv(out / "study.csv")
    assert len(frame) == 2 * 2 * 2, "2 instances x 2 solvers x 2 repeats"
    assert sorted(frame["repeat"].unique()) == [0, 1]
    assert set(frame["status"]) == {"optimal"}
    assert frame["accurate"].all() and (frame["certified_error"] > 0).all()
    summary = pd.read_csv(out / "summary.csv")
    assert len(summary) == 4 and (summary["repeats"] == 2).all()
    png = (out / "study.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["garnet:1"], "garnet:N:M"),
        (["no_such_model"], "no_such_model"),
        (["garnet:20:4", "--solvers", "NOPE"], "NOPE"),
    ],
)
def test_cli_bad_input_exits_2_with_one_line(capsys, tmp_path, argv, needle):
    out = tmp_path / "cmp"
    assert main(["compare", *argv, "--jobs", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and len(err.splitlines()) == 1, err
    assert not out.exists(), "nothing written for bad input"


def test_cli_never_prints_ok_for_a_non_optimal_row(capsys, tmp_path):
    argv = ["compare", "garnet:40:5:1", "--formulations", "RLP", "--solvers", "SCS"]
    assert main([*argv, "--accuracy", "1e-14", "--jobs", "1", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    row = next((line for line in text.splitlines() if "SCS" in line), None)
    assert row is not None, text
    assert "inaccurate" in row and "yes" not in row and "no" in row, row


def test_dask_scheduler_matches_local():
    distributed = pytest.importorskip("distributed", reason="the optional 'study' extra")
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        res = run_study(
            ["garnet:30:4:5"], ["RLP"], ["HIGHS:simplex"], scheduler=cluster.scheduler_address
        )
    local = run_study(["garnet:30:4:5"], ["RLP"], ["HIGHS:simplex"], jobs=1)
    assert res.frame["objective"].iloc[0] == pytest.approx(
        local.frame["objective"].iloc[0], rel=1e-12
    )
