"""The reproduction pipeline on the small patrol instance: files, keys, and every headline
number of ``summary.json`` recomputed independently (dense numpy operators written here,
plain loops over states), plus the command line."""

from __future__ import annotations

import hashlib
import json
import math
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from lpbounds.cli.main import main
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.model import PatrolModel
from lpbounds.patrol.reproduce import PAPER_TABLE1, reproduce
from lpbounds.patrol.simulation import alert_sequence, pooled_statistics, simulate

SMALL = "models/patrol-small.toml"
SEEDS = (3, 4)
STEPS = 4000
#: values computed here by dense value iteration agree with the pipeline's to this
#: (both are within ~1e-10 of the exact fixed points)
VALUE_ATOL = 1e-8
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce") / "out"
    rep = reproduce(SMALL, out, seeds=SEEDS, n_steps=STEPS, general="aggregate")
    return rep


@pytest.fixture(scope="module")
def model():
    return PatrolModel(params_from_instance(SMALL))


@pytest.fixture(scope="module")
def dense(model):
    """Dense arrays of the small MDP: successors, probabilities, rewards, allowed."""
    mdp = model.mdp()
    r = np.where(mdp.allowed, mdp.rewards, -np.inf)
    return mdp.successors.astype(np.int64), np.asarray(mdp.probabilities), r, mdp.discount


def _q(dense, v):
    succ, p, r, lam = dense
    return r + lam * (v[succ] * p).sum(axis=2)


def _vi(op, n, lam, tol=1e-13):
    v = np.zeros(n)
    for _ in range(5000):
        nv = op(v)
        if np.abs(nv - v).max() < tol * (1 - lam):
            return nv
        v = nv
    raise AssertionError("value iteration did not converge")


def test_files_and_keys(run):
    out = run.out
    s = json.loads((out / "summary.json").read_text())
    for key in (
        "n_states",
        "n_partitions",
        "theorem3_max_abs_diff",
        "theorem4_max_abs_diff",
        "claim2_violations",
        "paper_table1",
        "seconds_total",
    ):
        assert key in s, key
    assert {"iterations", "residual", "seconds"} <= set(s["vstar"])
    assert {"lower_margin", "upper_margin"} <= set(s["sandwich"])
    assert {"differs_fraction", "max_vstar_minus_vsub"} <= set(s["policy"])
    for pol in ("pi_star", "pi_s"):
        assert {"mean_loiters", "mean_delay", "worst_delay"} <= set(s["monte_carlo"][pol])
    assert s["paper_table1"] == PAPER_TABLE1
    z = np.load(out / "values.npz")
    n, m_parts = s["n_states"], s["n_partitions"]
    assert z["vstar"].shape == (n,) and z["pi_star"].shape == (n,)
    assert z["state_components"].shape == (n, 3 + 2)
    assert z["lower"].shape == (m_parts,) and z["upper"].shape == (m_parts,)
    assert z["partition_components"].shape == (m_parts, 4 + 2)
    for k in ("fig2", "fig3", "fig4", "fig5", "fig6", "fig7"):
        p = run.files[k]
        data = Path(p).read_bytes()
        assert data[:8] == PNG_MAGIC and len(data) > 10_000, f"{p} is not a non-empty PNG"
    report = (out / "report.md").read_text()
    for k in ("fig2", "fig3", "fig4", "fig5", "fig6", "fig7"):
        assert Path(run.files[k]).name in report, f"report.md does not show {k}"
    assert "Table 1" in report or "paper 4.7" in report


def test_counts_against_eq_27_28(run):
    s = run.summary
    n_nodes, m, d, g = 6, 2, 2, 4  # models/patrol-small.toml
    assert s["n_states"] == 2 * n_nodes * (g + 1) ** m + d * m * (g + 1) ** (m - 1)
    assert s["n_partitions"] == (
        2 * n_nodes + 2 * n_nodes * (2**m - 1) * g + m * d + m * d * (2 ** (m - 1) - 1) * g
    )


def test_vstar_and_pi_star_by_dense_value_iteration(run, dense):
    z = run.arrays
    lam = dense[3]
    v = _vi(lambda v: _q(dense, v).max(axis=1), z["vstar"].size, lam)
    assert np.abs(v - z["vstar"]).max() < VALUE_ATOL
    q = _q(dense, v)
    chosen = q[np.arange(v.size), z["pi_star"].astype(int)]
    assert (chosen >= q.max(axis=1) - VALUE_ATOL).all(), "pi* is not greedy w.r.t. V*"
    assert run.summary["vstar"]["residual"] <= run.summary["vstar"]["tol"]


def test_bounds_are_the_full_mdp_rlp_and_nlp(run, dense):
    """UBLP = RLP and LBLP = NLP (Theorems 4, 3): dense fixed points of the aggregated
    operators of the full MDP, max over the states of a partition (RLP) and
    max_u min over the states (NLP)."""
    z = run.arrays
    lab = z["partition_of_state"].astype(np.int64)
    m_parts = z["lower"].size
    lam = dense[3]
    allowed = np.isfinite(dense[2])

    def rlp(v):
        q = _q(dense, v[lab]).max(axis=1)
        out = np.full(m_parts, -np.inf)
        np.maximum.at(out, lab, q)
        return out

    def nlp(w):
        q = np.where(allowed, _q(dense, w[lab]), np.inf)
        mins = np.full((m_parts, 3), np.inf)
        for a in range(3):
            np.minimum.at(mins[:, a], lab, q[:, a])
        return np.where(np.isinf(mins), -np.inf, mins).max(axis=1)

    v_rlp = _vi(rlp, m_parts, lam)
    w_nlp = _vi(nlp, m_parts, lam)
    assert np.abs(v_rlp - z["upper"]).max() < VALUE_ATOL
    assert np.abs(w_nlp - z["lower"]).max() < VALUE_ATOL
    s = run.summary
    assert s["theorem4_max_abs_diff"] <= s["theorems"]["tolerance_theorem4"]
    assert s["theorem3_max_abs_diff"] <= s["theorems"]["tolerance_theorem3"]
    for b in s["bounds"].values():
        assert b["lp_minus_fixed_point_max_abs"] < 1e-7, b


def test_sandwich_and_policy_numbers(run, dense):
    z, s = run.arrays, run.summary
    lab = z["partition_of_state"].astype(np.int64)
    vstar, vlow, vup = z["vstar"], z["lower"][lab], z["upper"][lab]
    assert s["sandwich"]["lower_margin"] == pytest.approx((vstar - vlow).min(), abs=1e-12)
    assert s["sandwich"]["upper_margin"] == pytest.approx((vup - vstar).min(), abs=1e-12)
    tol = 1e-8
    assert (vlow <= vstar + tol).all() and (vstar <= vup + tol).all()
    # pi_s greedy w.r.t. V_low; V_sub by a dense linear solve
    q = _q(dense, vlow)
    pi_s = z["pi_s"].astype(int)
    assert (q[np.arange(pi_s.size), pi_s] >= q.max(axis=1) - 1e-9).all()
    succ, p, r, lam = dense
    n = pi_s.size
    P = np.zeros((n, n))
    np.add.at(P, (np.repeat(np.arange(n), p.size), succ[np.arange(n), pi_s].ravel()), np.tile(p, n))
    vsub = np.linalg.solve(np.eye(n) - lam * P, r[np.arange(n), pi_s])
    assert np.abs(vsub - z["vsub"]).max() < VALUE_ATOL
    assert s["policy"]["max_vstar_minus_vsub"] == pytest.approx((vstar - vsub).max(), abs=1e-8)
    assert s["policy"]["differs_fraction"] == pytest.approx(np.mean(pi_s != z["pi_star"]), abs=0)
    assert (vlow <= vsub + tol).all() and (vsub <= vstar + tol).all()


def test_certified_sandwich_margins_are_promises(run, dense):
    """The certified margins (from the LP results' brackets and V*'s error bound) never
    exceed the true margins, computed here from a dense value iteration of V* and the
    partition fixed points (checked against dense operators above); and they are
    below the uncertified margins by at least V*'s error bound."""
    z, s = run.arrays, run.summary
    lab = z["partition_of_state"].astype(np.int64)
    v = _vi(lambda v: _q(dense, v).max(axis=1), z["vstar"].size, dense[3])
    true_lower = float((v - z["lower"][lab]).min())
    true_upper = float((z["upper"][lab] - v).min())
    sw = s["sandwich"]
    err_v = s["vstar"]["error_bound"]
    assert sw["certified_lower_margin"] <= true_lower + VALUE_ATOL
    assert sw["certified_upper_margin"] <= true_upper + VALUE_ATOL
    assert sw["certified_lower_margin"] <= sw["lower_margin"] - err_v
    assert sw["certified_upper_margin"] <= sw["upper_margin"] - err_v
    # and they are not vacuous on this instance: the sandwich is proved
    assert sw["certified_lower_margin"] > 0 and sw["certified_upper_margin"] > 0
    assert "the sandwich is proved" in (run.out / "report.md").read_text()


def test_section_6_statements_on_the_small_instance(run, dense):
    """What Section 6 says of its instance, on this one (Table 1's numbers themselves are for
    D = 5 and are checked at the paper's size in test_paper_figures.py): the lower bound is
    the tighter one on average (Figure 5), and pi_s performs as well as pi* on the same
    alert sequences (Table 1: the two rows agree to the printed digit, 0.05). V* here is
    the dense value iteration of this file, not the pipeline's."""
    z, s = run.arrays, run.summary
    lab = z["partition_of_state"].astype(np.int64)
    v = _vi(lambda v: _q(dense, v).max(axis=1), z["vstar"].size, dense[3])
    below, above = v - z["lower"][lab], z["upper"][lab] - v
    assert below.min() >= -VALUE_ATOL and above.min() >= -VALUE_ATOL
    assert below.mean() < above.mean(), (below.mean(), above.mean())
    assert s["sandwich"]["mean_vstar_minus_vlow"] == pytest.approx(below.mean(), abs=VALUE_ATOL)
    assert s["sandwich"]["mean_vup_minus_vstar"] == pytest.approx(above.mean(), abs=VALUE_ATOL)
    mc = s["monte_carlo"]
    for key in ("mean_loiters", "mean_delay_plus_one"):
        assert abs(mc["pi_star"][key] - mc["pi_s"][key]) <= 0.05, key
    assert abs(mc["pi_star"]["worst_delay_plus_one"] - mc["pi_s"]["worst_delay_plus_one"]) <= 3


def test_claim_counts_by_loops(run, model):
    """Claim 2 on every pair x1 = x2 + e_j, counted with a plain loop over states."""
    z, s = run.arrays, run.summary
    comps = [tuple(int(c) for c in row) for row in z["state_components"]]
    index = {c: i for i, c in enumerate(comps)}
    p = model.params
    tol = s["claims"]["tolerance"]
    pairs = viol = 0
    for x2, c in enumerate(comps):
        for j in range(p.m):
            tau = list(c[3:])
            if tau[j] >= p.Gamma:
                continue
            tau[j] += 1
            x1 = index.get((*c[:3], *tau))
            if x1 is None:  # the own station of a loiter state
                continue
            pairs += 1
            viol += z["vstar"][x1] - z["vstar"][x2] > tol
    assert s["claims"]["pairs"] == pairs
    assert s["claim2_violations"] == viol
    assert s["claims"]["violations_same_alert_status"] == 0


def test_lemma3_differences_are_the_capped_type1_partitions(run, model):
    pc = model.partition_components()
    st = list(model.params.stations)
    m = model.params.m
    n = 0
    for row in pc:
        l, _, d, *a, tb = (int(v) for v in row)
        if l in st and d == 0 and a[st.index(l)] == 1 and sum(a) >= 2 and tb == model.params.Gamma:
            n += 1
    assert run.summary["lemma3"]["pairs_differing"] == n
    assert run.summary["lemma3"]["full_mdp_rows_equal_construction"]
    assert m == 2


def test_report_words_lists_and_states_without_python_reprs(run):
    """report.md is prose: "taubar = 4", states and stations as tuples, seeds as a list of
    words, never a Python list ("taubar in [4]", "stations = [0, 3]") or bool."""
    text = (run.out / "report.md").read_text()
    found = re.search(r".{0,40}(?:\[\d+(?:, \d+)*\]|\b(?:True|False|None)\b).{0,20}", text)
    assert not found, found.group()
    taubar = run.summary["lemma3"]["differing_taubar_values"]
    if run.summary["lemma3"]["pairs_differing"]:
        said = " or ".join(str(t) for t in taubar)
        assert f"type-1 loiters at taubar = {said}:" in text


def test_monte_carlo_summary_is_reproducible(run, model):
    z, s = run.arrays, run.summary
    p0 = math.exp(-model.params.alpha)
    res = [
        simulate(model, z["pi_star"].astype(np.int64), alert_sequence(STEPS, p0, 2, sd))
        for sd in SEEDS
    ]
    pooled = pooled_statistics(res)
    for k in ("mean_loiters", "mean_delay", "worst_delay", "n_serviced"):
        assert s["monte_carlo"]["pi_star"][k] == pooled[k], k
    assert s["monte_carlo"]["pi_star"]["mismatches"] == 0


def test_residual_mode_bounds_the_measured_difference(run, tmp_path):
    rep = reproduce(SMALL, tmp_path, seeds=(1,), n_steps=200, general="residual", figures=False)
    t, ta = rep.summary["theorems"], run.summary["theorems"]
    # measured |RLP - UBLP| <= (RLP solve's own error) + (certified distance of UBLP's
    # optimum from the true RLP optimum), and likewise for the NLP
    assert ta["theorem4_max_abs_diff"] <= t["theorem4_max_abs_diff"] + ta["rlp_error_bound"]
    assert ta["theorem3_max_abs_diff"] <= t["theorem3_max_abs_diff"] + ta["nlp_error_bound"]
    assert t["theorem4_max_abs_diff"] < 1e-8 and t["theorem3_max_abs_diff"] < 1e-8


def test_cli(tmp_path, capsys):
    out = tmp_path / "o"
    code = main(
        ["reproduce", SMALL, "--out", str(out), "--seeds", "1", "--steps", "300", "--no-figures"]
    )
    assert code == 0
    assert (out / "summary.json").exists() and (out / "report.md").exists()
    assert "reproduction of patrol-small" in capsys.readouterr().out
    before = (out / "summary.json").read_bytes()
    # input errors: exit status 2, one line, and the previous output untouched
    assert main(["reproduce", SMALL, "--out", str(out), "--solver", "NOSUCH"]) == 2
    assert "NOSUCH" in capsys.readouterr().err
    assert main(["reproduce", "models/garnet-small.toml", "--out", str(out)]) == 2
    assert "patrol" in capsys.readouterr().err
    assert (out / "summary.json").read_bytes() == before


def test_manifest_lists_every_file_with_size_and_hash(run):
    """manifest.json names every other file of the folder, with its size and SHA-256
    recomputed here, and the package version."""
    import lpbounds

    man = json.loads((run.out / "manifest.json").read_text())
    assert man["version"] == lpbounds.__version__ and man["instance"] == "patrol-small"
    on_disk = {p.name for p in run.out.iterdir()} - {"manifest.json"}
    assert {f["name"] for f in man["files"]} == on_disk
    for f in man["files"]:
        data = (run.out / f["name"]).read_bytes()
        assert f["bytes"] == len(data)
        assert f["sha256"] == hashlib.sha256(data).hexdigest()
    # nothing but the output folder is left beside it (no temporary folder, no lock)
    assert [p.name for p in run.out.parent.iterdir()] == [run.out.name]


def test_summary_json_is_the_typed_result(run):
    """summary.json holds exactly the typed objects the report reads."""
    from lpbounds.patrol.summary import jsonable

    on_disk = json.loads((run.out / "summary.json").read_text())
    assert on_disk == json.loads(json.dumps(jsonable(run.result)))
    assert run.result.sandwich.lower.margin == on_disk["sandwich"]["lower"]["margin"]
    assert run.result.monte_carlo.pi_s.mean_delay == on_disk["monte_carlo"]["pi_s"]["mean_delay"]


def test_reproduce_after_a_default_highs_solve_in_the_same_process(tmp_path):
    """HiGHS keeps one thread scheduler per process: an option that asks for another
    thread count fails every solve after the first. Solve an LP with HiGHS at its
    defaults first (as a notebook or another test would), then reproduce, in one fresh
    process; the LP's optimum is checked against its closed form (x = 1, y = 2: 5)."""
    code = textwrap.dedent(
        f"""
        import cvxpy as cp
        x, y = cp.Variable(), cp.Variable()
        prob = cp.Problem(cp.Maximize(x + 2 * y), [x + y <= 3, y <= 2, x >= 0, y >= 0])
        prob.solve(solver="HIGHS")
        assert abs(prob.value - 5.0) < 1e-9, prob.value
        from lpbounds.patrol.reproduce import reproduce
        rep = reproduce({SMALL!r}, {str(tmp_path / "o")!r}, seeds=(1,), n_steps=200,
                        figures=False)
        print([str(b.status) for b in rep.result.bounds.values()])
        """
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip().splitlines()[-1] == "['optimal', 'optimal']"
