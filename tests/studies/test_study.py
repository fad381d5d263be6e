"""lpbounds.studies.compare and ``lpbounds compare``.

Results equal independent solves; skips are noted.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize as so

import lpbounds as lb
from lpbounds.cli.main import main
from lpbounds.errors import ValidationError
from lpbounds.formulations.base import INSTALL_HINTS, installed_lp_solvers
from lpbounds.studies.compare import (
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
    return run_study(
        [SPEC], ["ELP", "RLP"], ["HIGHS:simplex", "HIGHS:ipm", "CLARABEL:default"], jobs=1
    )


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
    par = run_study(
        [SPEC], ["ELP", "RLP"], ["HIGHS:simplex", "HIGHS:ipm", "CLARABEL:default"], jobs=2
    )
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
    from lpbounds.studies.compare import _status

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


def test_default_solvers_name_what_is_missing_without_a_skip_note():
    """A default study runs every installed solver: the known ones that are not installed
    are listed (missing_solvers, notes.txt), not reported as skips of the user's choice."""
    from lpbounds.studies.compare import missing_solvers
    from lpbounds.studies.report import missing_solvers_note

    configs, notes = solver_configs(None)
    labels = {c.label for c in configs}
    assert "CLARABEL" in labels and "HIGHS:simplex" in labels and "HIGHS:ipm" in labels
    assert not any("not installed" in n for n in notes), notes
    installed = installed_lp_solvers()
    missing = missing_solvers(installed)
    assert not set(missing) & set(installed)
    if "GLPK" not in installed:
        assert "GLPK" in missing
    for name in missing:
        assert f"{name} ({INSTALL_HINTS[name]})" in missing_solvers_note(missing)
    # a solver the user names and does not have is still a skip, with its install line
    if missing:
        _, named = solver_configs(["HIGHS:simplex", missing[0]])
        assert any(missing[0] in n for n in named), named


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
    names, notes = available_formulations(["UBLP"])
    assert names == ["UBLP"], notes  # lpbounds.patrol.bounds must import: never a skip
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
    import json
    from importlib.metadata import version

    import pandas as pd

    out = tmp_path / "cmp"
    argv = ["compare", "garnet:40:5:1", "garnet:80:9:2", "--formulations", "RLP"]
    argv += ["--solvers", "HIGHS:ipm", "CLARABEL:default", "--repeat", "2", "--jobs", "1"]
    argv += ["--shift", "10", "0.5", "--time-limit", "60"]
    assert main([*argv, "--out", str(out)]) == 0
    frame = pd.read_csv(out / "study.csv")
    assert len(frame) == 2 * 2 * 2, "2 instances x 2 solvers x 2 repeats"
    assert sorted(frame["repeat"].unique()) == [0, 1]
    assert set(frame["status"]) == {"optimal"}
    assert frame["accurate"].all() and (frame["certified_error"] > 0).all()
    assert (frame["time_limit"] == 60).all()
    summary = pd.read_csv(out / "summary.csv")
    assert len(summary) == 4 and (summary["repeats"] == 2).all()
    solvers = pd.read_csv(out / "solvers.csv").set_index("config")
    assert sorted(solvers.index) == ["CLARABEL", "HIGHS:ipm"]
    assert (solvers["solved"] == 2).all() and (solvers["problems"] == 2).all()
    assert (solvers[["inaccurate", "time_limit", "other_limit", "failed"]] == 0).all().all()
    # every problem solved: the mean is over the median solve times of the two problems
    for cfg, grp in frame.groupby("config"):
        t = grp.groupby("instance")["solve_seconds"].median().to_numpy()
        expected = np.sqrt((t[0] + 0.5) * (t[1] + 0.5)) - 0.5  # two values, shift 0.5
        assert solvers.loc[cfg, "sgm_0.5s"] == pytest.approx(expected, rel=1e-9)
    assert "sgm_10s" in solvers.columns
    for name in ("study.png", "profile_time.png", "profile_accuracy.png"):
        png = (out / name).read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000, name
    meta = json.loads((out / "metadata.json").read_text())
    assert (
        meta["command_line"][:2] == ["lpbounds", "compare"]
        and "--time-limit" in meta["command_line"]
    )
    assert meta["dependencies"]["cvxpy"] == version("cvxpy")
    assert meta["study_solvers"]["CLARABEL"]["packages"] == {"clarabel": version("clarabel")}
    assert meta["study_solvers"]["HIGHS"]["packages"] == {"highspy": version("highspy")}
    assert meta["study_solvers"]["CLARABEL"]["requires"]["numpy"] == version("numpy")
    assert meta["machine"]["cpus"] >= 1 and meta["machine"]["cpu"]
    assert meta["study"]["time_limit"] == 60 and meta["study"]["accuracy"] == 1e-6


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


# ---------------------------------------------------------------------- solver studies
def test_lp_solvers_read_from_cvxpy_classes(monkeypatch):
    """LP-capable = a conic class with Zero and NonNeg cones, or a QP class: an NLP solver
    (IPOPT) and DIFFCP (SCS differentiated) are left out whatever cvxpy reports."""
    import cvxpy as cp

    from lpbounds.formulations import solvers as solver_catalog

    fake = ["SCS", "IPOPT", "DIFFCP", "OSQP", "HIGHS", "SDPA"]
    monkeypatch.setattr(cp, "installed_solvers", lambda: fake)
    solver_catalog.lp_capable_solvers.cache_clear()
    try:
        got = solver_catalog.lp_capable_solvers()
    finally:
        monkeypatch.undo()
        solver_catalog.lp_capable_solvers.cache_clear()
    # SDPA: Zero, NonNeg and PSD cones (an LP fits); OSQP: a QP solver; HIGHS first
    assert got[0] == "HIGHS" and sorted(got) == ["HIGHS", "OSQP", "SCS", "SDPA"], got


def test_every_installed_lp_solver_is_in_the_default_study():
    import cvxpy as cp

    configs, notes = solver_configs(None)
    solvers = {c.solver for c in configs}
    for name in ("HIGHS", "CLARABEL", "SCS", "OSQP", "SCIPY"):
        if name in cp.installed_solvers():
            assert name in solvers, (name, solvers)
    labels = {c.label for c in configs}
    assert {"CLARABEL", "CLARABEL:tight"} <= labels
    scipy_cfg = next(c for c in configs if c.solver == "SCIPY")
    assert "HiGHS" in scipy_cfg.backend
    assert any("SCIPY is HiGHS" in n for n in notes), notes


@pytest.mark.parametrize(
    ("module", "solver"),
    [("daqp", "DAQP"), ("proxsuite", "PROXQP"), ("pyscipopt", "SCIP"), ("ortools", "PDLP")],
)
def test_optional_solvers_are_found_when_installed(module, solver):
    import cvxpy as cp

    from lpbounds.formulations.solvers import lp_capable_solvers

    pytest.importorskip(module, reason=f"{module} is not installed here (optional)")
    if solver not in cp.installed_solvers():
        pytest.skip(f"cvxpy does not load {solver} with this {module}")
    assert solver in lp_capable_solvers()
    res = run_study(["garnet:20:4:1"], ["RLP"], [solver], jobs=1)
    row = res.frame.iloc[0]
    assert row["status"] in ("optimal", "inaccurate", "infeasible"), row
    if row["status"] == "infeasible":  # PROXQP did: the row says why that is wrong
        assert "feasible by construction" in row["note"], row["note"]


def test_with_time_limit_merges_each_solvers_keyword():
    from lpbounds.formulations.solvers import with_time_limit

    opts, ok = with_time_limit("HIGHS", {"highs_options": {"solver": "ipm"}}, 5.0)
    assert ok and opts == {"highs_options": {"solver": "ipm", "time_limit": 5.0}}
    assert with_time_limit("SCS", {}, 2.0) == ({"time_limit_secs": 2.0}, True)
    assert with_time_limit("CLARABEL", {"tol_feas": 1e-9}, 2.0)[0] == {
        "tol_feas": 1e-9,
        "time_limit": 2.0,
    }
    assert with_time_limit("DAQP", {}, 2.0) == ({}, False)
    assert with_time_limit("SCS", {"a": 1}, None) == ({"a": 1}, True)


def test_limit_status_rules():
    from lpbounds.studies.compare import _limit_status

    assert _limit_status("limit", 1.99, 2.0) == "time_limit"  # USER_LIMIT at the limit
    assert _limit_status("inaccurate", 2.3, 2.0) == "time_limit"  # SCS stops "inaccurate"
    assert _limit_status("limit", 0.5, 2.0) == "limit"  # an iteration limit, not time
    assert _limit_status("optimal", 3.0, 2.0) == "optimal"  # certified: stays optimal
    assert _limit_status("infeasible", 3.0, 2.0) == "infeasible"
    assert _limit_status("limit", 3.0, None) == "limit"


@pytest.mark.parametrize("config", ["HIGHS:ipm", "SCS"])
def test_time_limit_keeps_the_point_and_its_certified_error(config):
    """Stopped after 2 ms on an ELP they need far longer for (HiGHS names its time limit;
    SCS calls its stop "solved inaccurate", named by the solve time): status time_limit, the
    point kept, and its certified error still bounds the distance to V*. (HiGHS' PDLP is
    not used: it checks its clock rarely and ran 0.6 s under a 2 ms limit.)"""
    res = run_study(["garnet:1500:20:1"], ["ELP"], [config], time_limit=0.002, jobs=1)
    row = res.frame.iloc[0]
    assert row["status"] == "time_limit", row[["status", "solve_seconds", "note"]]
    assert np.isfinite(row["certified_error"]) and np.isfinite(row["max_deviation"])
    assert row["max_deviation"] <= row["certified_error"] + row["reference_error_bound"]
    assert "time limit 0.002 s reached" in row["note"]
    summ = res.solver_summary((1.0,)).iloc[0]
    assert summ["time_limit"] == 1 and summ["solved"] == 0
    assert summ["sgm_1s"] == pytest.approx(0.002, rel=1e-12)  # one unsolved: the limit


def test_bad_time_limit_is_an_error():
    with pytest.raises(ValidationError, match="time_limit"):
        run_study(["garnet:20:4"], ["RLP"], ["HIGHS:ipm"], time_limit=-1.0)


def test_infeasible_answer_gets_a_comment(monkeypatch):
    """A solver answering "infeasible" (as PROXQP did) on a feasible LP: the row keeps the
    status, counts as failed, and says the exact fixed point is feasible."""
    from lpbounds.formulations.rlp import RLP
    from lpbounds.status import Status

    original = RLP.solve

    def infeasible(self, *args, **kwargs):
        res = original(self, *args, **kwargs)
        res.status = Status.INFEASIBLE
        res.x = np.full_like(res.x, np.nan)
        return res

    monkeypatch.setattr(RLP, "solve", infeasible)
    res = run_study(["garnet:30:4:2"], ["RLP"], ["HIGHS:simplex"], jobs=1)
    row = res.frame.iloc[0]
    assert row["status"] == "infeasible" and not row["accurate"]
    assert "feasible by construction" in row["note"], row["note"]
    violation = float(row["note"].rsplit("largest violation ", 1)[1].rstrip(")"))
    assert violation <= 1e-9
    assert res.solver_summary().iloc[0]["failed"] == 1


def test_a_crashing_solver_is_a_row_not_an_abort(monkeypatch):
    from lpbounds.formulations.rlp import RLP

    def crash(self, *args, **kwargs):
        raise ModuleNotFoundError("No module named 'google'")

    monkeypatch.setattr(RLP, "solve", crash)
    res = run_study(["garnet:20:4:2"], ["RLP"], ["HIGHS:simplex"], jobs=1)
    row = res.frame.iloc[0]
    assert row["status"] == "solver_error" and "ModuleNotFoundError" in row["note"]


@pytest.mark.parametrize("scheduler", ["synchronous", "threads"])
def test_dask_local_scheduler_matches_local(scheduler):
    pytest.importorskip("dask", reason="the optional 'study' extra")
    specs = (["garnet:30:4:5", "garnet:25:5:6"], ["RLP"], ["HIGHS:simplex", "CLARABEL:default"])
    res = run_study(*specs, scheduler=scheduler)
    local = run_study(*specs, jobs=1)
    key = ["instance", "config"]
    a = res.frame.set_index(key)["objective"].sort_index()
    b = local.frame.set_index(key)["objective"].sort_index()
    assert a.index.equals(b.index) and len(a) == 4
    assert np.allclose(a.to_numpy(), b.to_numpy(), rtol=1e-9, atol=0)
    assert res.params["scheduler"] == scheduler


@pytest.mark.parametrize(
    ("flag", "value"), [("--time-limit", "0"), ("--time-limit", "nan"), ("--shift", "-1")]
)
def test_cli_rejects_bad_limits_and_shifts(capsys, tmp_path, flag, value):
    out = tmp_path / "cmp"
    with pytest.raises(SystemExit) as exc:
        main(["compare", "garnet:20:4", flag, value, "--out", str(out)])
    assert exc.value.code == 2
    assert f"argument {flag}" in capsys.readouterr().err
    assert not out.exists()


def test_study_png_shows_every_problem_and_no_vertical_line(tmp_path, monkeypatch):
    """Problems of the same size (two garnets with 100 states: their ELPs have 100
    variables, their RLPs 10) are each a point; the line of a solver has one y per x, so it
    never runs vertically through them; every legend entry shows."""
    from lpbounds.studies import report
    from lpbounds.studies.profiles import new_figure
    from tests._figures import assert_legend_visible

    made = []
    monkeypatch.setattr(
        report, "new_figure", lambda size: made.append(new_figure(size)) or made[-1]
    )
    result = run_study(
        ["garnet:100:10:1", "garnet:100:10:2", "garnet:300:10:3"],
        ["ELP", "RLP"],
        ["HIGHS:simplex", "CLARABEL:default"],
        repeat=2,
        jobs=1,
    )
    report.plot_study(result.frame, tmp_path / "study.png")
    ax1 = made[0].axes[0]
    for line in ax1.get_lines():
        x = np.asarray(line.get_xdata(), dtype=float)
        assert (np.diff(x) > 0).all(), f"a vertical segment in {line.get_label()}: x = {x}"
    points = np.concatenate([c.get_offsets() for c in ax1.collections])
    # every (instance, solver, formulation) with a point is drawn: 3 x 2 x 2
    assert len(points) == 12
    frame = result.frame
    per = frame.groupby(["instance", "config", "formulation"])["solve_seconds"].median()
    assert sorted(points[:, 1].tolist()) == sorted(per.tolist())
    assert_legend_visible(made[0], allow_shared=("ELP", "RLP"))
