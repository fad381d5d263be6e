"""lpbounds.studies.verify and ``lpbounds verify``.

Three-valued verdicts from certified intervals.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json

import numpy as np
import pytest
import scipy.optimize as so

import lpbounds as lb
import lpbounds.studies.verify as verify
from lpbounds.certification.checks import compare_at_least, compare_equal
from lpbounds.cli.main import main
from lpbounds.errors import SolverNotInstalledError, ValidationError
from lpbounds.formulations import RLP, SLP
from lpbounds.rows import BellmanRows
from lpbounds.status import Verdict
from tests import _independent as ind

KEYS = {
    "check",
    "claim",
    "instance",
    "solver",
    "verdict",
    "width",
    "deviation",
    "accuracy",
    "index",
    "lp_interval",
    "exact_interval",
    "detail",
    "solves",
    "solve_seconds",
    "compile_seconds",
    "lp_status",
    "solver_status",
}
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


def _by_claim(recs, check, claim, solver):
    out = [r for r in recs if (r["check"], r["claim"], r["solver"]) == (check, claim, solver)]
    assert len(out) == 1, (check, claim, solver, [(r["check"], r["claim"]) for r in recs])
    return out[0]


def _vstar(mdp) -> ind.Reference:
    """V* by dense policy iteration in numpy (tests/_independent: no lpbounds code)."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    return ind.policy_iteration(P, mdp.rewards, mdp.allowed, mdp.discount)


class ShiftedRLP(RLP):
    """A wrong RLP: every reward 0.05 too large (its optimum is v* + 0.05/(1-lambda))."""

    def __init__(self, mdp, partition, cost=None):
        r = BellmanRows.aggregate(mdp, partition, reduce="max")
        rows = BellmanRows.from_arrays(
            r.owner, r.action, r.reward + 0.05, r.targets, r.probs, r.discount, r.n_vars
        )
        super().__init__(mdp, partition, cost, rows=rows)


# ---------------------------------------------------------------------- the comparisons
def test_equality_verdicts_by_hand():
    assert compare_equal([1.0], [1.1], [1.05], [1.2], 0.5).verdict is Verdict.HOLDS
    inc = compare_equal([1.0], [1.1], [1.05], [1.2], 0.1)
    assert inc.verdict is Verdict.INCONCLUSIVE and inc.width == pytest.approx(0.2)
    bad = compare_equal([0.0, 1.0], [0.1, 1.1], [0.0, 1.2], [0.1, 1.3], 10.0)
    assert bad.verdict is Verdict.VIOLATED, "disjoint at entry 1, whatever the accuracy"
    assert bad.index == 1 and bad.a_interval == (1.0, 1.1) and bad.b_interval == (1.2, 1.3)
    assert compare_equal([np.nan], [1.0], [0.0], [1.0], 1e9).verdict is Verdict.INCONCLUSIVE


def test_inequality_verdicts_by_hand():
    # a >= b proven (a_lo >= b_hi) holds whatever the widths
    assert compare_at_least([2.0], [9.0], [0.0], [1.0], 1e-9).verdict is Verdict.HOLDS
    assert compare_at_least([0.5], [2.0], [0.0], [1.0], 0.6).verdict is Verdict.HOLDS
    assert compare_at_least([0.5], [2.0], [0.0], [1.0], 0.1).verdict is Verdict.INCONCLUSIVE
    bad = compare_at_least([0.0, 0.0], [1.0, 0.4], [0.0, 0.5], [1.0, 0.6], 1.0)
    assert bad.verdict is Verdict.VIOLATED and bad.index == 1


def test_objective_bracket_is_tight_for_a_non_unique_optimum():
    """A cost with zeros: Clarabel returns a point inside the optimal face, far from V* where
    c = 0 (wide per-entry bracket); the duality bound still pins c'V* (policy iteration in
    tests/_independent)."""
    from lpbounds.certification.checks import lp_bracket, lp_objective_bracket
    from lpbounds.formulations import ELP

    mdp = lb.garnet(31, 2, 3, 0.685, seed=4)
    cost = np.random.default_rng(1).uniform(0, 1, 31)
    cost[::3] = 0.0
    form = ELP(mdp, cost)
    res = form.solve("CLARABEL", raise_on_failure=False)
    br = lp_bracket(form, res)
    lo, hi = lp_objective_bracket(form, res, br)
    vstar = _vstar(mdp)
    ref = float(cost @ vstar.values)
    slack = vstar.error * float(cost.sum())
    assert lo <= ref + slack and ref - slack <= hi
    assert hi - lo < 1e-6 * max(1.0, abs(ref)), (lo, hi)
    c_lo, c_hi = float(cost @ br.lower), float(cost @ br.upper)
    assert c_lo <= ref + slack and ref - slack <= c_hi  # the plain bracket is valid, wider:
    assert hi - lo < (c_hi - c_lo) / 5, "weak duality must tighten c'[lower, upper]"


# ---------------------------------------------------------------------- one instance
@pytest.fixture(scope="module")
def normal_records(tiny_instance):
    return verify.verify_instance(tiny_instance, ["HIGHS", "CLARABEL"], n_costs=2)


def test_normal_run_all_holds(normal_records):
    recs = normal_records
    assert all(set(r) == KEYS for r in recs)
    assert {r["check"] for r in recs} == CHECKS
    assert {r["solver"] for r in recs} == {"exact", "HIGHS", "CLARABEL", "all"}
    for r in recs:
        assert r["verdict"] == "holds", r
        assert 0 <= r["width"] <= r["accuracy"], r
    json.dumps(recs)  # plain types only


def test_records_count_their_solves_and_name_the_solvers_status(normal_records):
    """n_costs = 2 LPs per objective claim, IB for L = 1..5, LLP with 2 costs d, one SLP;
    none for exact DP. Every point HiGHS and Clarabel returned here is optimal, in
    lpbounds' status and in the solver's own word."""
    expected = {
        "optimal value = c'(exact)": 2,
        "optimum = exact (c > 0)": 2,
        "feasible points >= v*": 2,
        "SLP(mu-bar) = v*": 1,
        "IB blocks = v*": 5,
        "IB feasible point >= v*": 5,
        "LLP v >= v*": 2,
    }
    seen = set()
    for r in normal_records:
        if r["solver"] in ("exact", "all") or r["claim"] == "reduced MDP value = v*":
            assert r["solves"] == 0 and r["lp_status"] == r["solver_status"] == ""
            continue
        seen.add(r["claim"])
        assert r["solves"] == expected[r["claim"]], r
        assert r["lp_status"] == "optimal" and r["solver_status"] == "optimal", r
        assert r["solve_seconds"] > 0 and r["compile_seconds"] >= 0
    assert seen == set(expected)


def test_intervals_contain_an_independent_v_star(tiny_instance, normal_records):
    """The exact side is V*/v* by value iteration from lpbounds; V* and RLP's v* by dense
    policy iteration in tests/_independent (no lpbounds code) must fall inside the reported
    exact intervals, which must be no wider than the check's accuracy."""
    mdp, part = tiny_instance.mdp, tiny_instance.partition
    vstar = _vstar(mdp)
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    vrlp = ind.rlp_optimum(P, mdp.rewards, mdp.allowed, mdp.discount, part.labels)
    for check, ref in (("Lemma 1", vstar), ("Theorem 1", vrlp)):
        for solver in ("HIGHS", "CLARABEL"):
            r = _by_claim(normal_records, check, "optimum = exact (c > 0)", solver)
            lo, hi = r["exact_interval"]
            x = ref.values[r["index"]]
            assert lo <= x + ref.error and x - ref.error <= hi, (check, solver, lo, x, hi)
            assert hi - lo <= r["accuracy"], (check, solver, hi - lo)


def test_a_wrong_lp_is_violated(tiny_instance, monkeypatch):
    monkeypatch.setattr(verify, "RLP", ShiftedRLP)
    recs = verify.verify_instance(tiny_instance, ["HIGHS"], n_costs=1)
    r = _by_claim(recs, "Theorem 1", "optimum = exact (c > 0)", "HIGHS")
    assert r["verdict"] == "violated", r
    lo, hi = r["lp_interval"]
    elo, ehi = r["exact_interval"]
    assert lo > ehi, "the counterexample's intervals are disjoint"
    shift = 0.05 / (1 - tiny_instance.mdp.discount)  # the wrong LP's optimum is v* + shift
    assert lo <= ehi + shift and elo + shift <= hi, "the wrong LP's optimum is inside"
    assert _by_claim(recs, "Theorem 1", "optimal value = c'(exact)", "HIGHS")["verdict"] == (
        "violated"
    )
    # claims that do not involve RLP are untouched
    assert _by_claim(recs, "Lemma 1", "optimum = exact (c > 0)", "HIGHS")["verdict"] == "holds"


def test_a_perturbed_slp_dual_is_violated(tiny_instance, monkeypatch):
    """An SLP that does not use the duals it is given (mu-bar plus a uniform weight):
    its optimum is provably below Lemma 2's prediction from the true mu-bar."""

    class WrongSLP(SLP):
        def __init__(self, mdp, partition, mu, cost=None):
            super().__init__(mdp, partition, np.where(mdp.allowed, mu + 1.0, 0.0), cost)

    monkeypatch.setattr(verify, "SLP", WrongSLP)
    recs = verify.verify_instance(tiny_instance, ["HIGHS"], n_costs=1)
    r = _by_claim(recs, "Lemma 2", "SLP(mu-bar) = v*", "HIGHS")
    assert r["verdict"] == "violated", r
    # the independent value of the perturbed SLP (its fixed point by policy iteration)
    mdp, part = tiny_instance.mdp, tiny_instance.partition
    cost = verify._references(tiny_instance, 1, 0, 1e-6).costs[0]  # the check's first cost
    mu = RLP(mdp, part, cost).solve("HIGHS").mu
    # its reduced MDP built and solved in tests/_independent (numpy only)
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    p_red, r_red, used = ind.surrogate_mdp(P, mdp.rewards, mdp.allowed, part.labels,
                                           np.where(mdp.allowed, mu + 1.0, 0.0))  # fmt: skip
    w = ind.policy_iteration(p_red, r_red, used, mdp.discount)
    lo, hi = r["lp_interval"]
    assert lo <= w.values[r["index"]] + w.error and w.values[r["index"]] - w.error <= hi
    assert hi < r["exact_interval"][0]


def test_an_injected_wrong_bracket_is_violated(tiny_instance):
    """A result whose certified fields are wrong (shifted by 0.1) is caught by the check."""
    mdp, part = tiny_instance.mdp, tiny_instance.partition
    refs = verify._references(tiny_instance, 1, 0, 1e-6)
    cbar = np.bincount(part.labels, weights=refs.costs[0], minlength=part.n_partitions)
    form = RLP(mdp, part, refs.costs[0])
    res = form.solve("HIGHS")
    fake = dataclasses.replace(
        res,
        certificate=None,
        lower_values=res.lower_values + 0.1,
        upper_values=res.upper_values + 0.1,
    )
    _, entry, _ = verify._optimum_claims(form, fake, cbar, refs.v_lo, refs.v_hi, refs.accuracy)
    assert entry is not None and entry.verdict is Verdict.VIOLATED
    _, entry, _ = verify._optimum_claims(form, res, cbar, refs.v_lo, refs.v_hi, refs.accuracy)
    assert entry.verdict is Verdict.HOLDS


def test_an_inaccurate_point_is_inconclusive(tiny_instance):
    """A point with a large residual has a wide (valid) bracket: inconclusive, not violated."""
    mdp, part = tiny_instance.mdp, tiny_instance.partition
    refs = verify._references(tiny_instance, 1, 0, 1e-6)
    cbar = np.bincount(part.labels, weights=refs.costs[0], minlength=part.n_partitions)
    form = RLP(mdp, part, refs.costs[0])
    res = form.solve("HIGHS")
    noise = np.random.default_rng(0).uniform(-1e-3, 1e-3, res.x.shape)
    fake = dataclasses.replace(
        res, x=res.x + noise, certificate=None, lower_values=None, upper_values=None
    )
    obj, entry, _ = verify._optimum_claims(form, fake, cbar, refs.v_lo, refs.v_hi, refs.accuracy)
    assert entry.verdict is Verdict.INCONCLUSIVE and entry.width > refs.accuracy
    assert obj.verdict is not Verdict.VIOLATED


def test_a_loose_first_order_solver_is_never_violated(tiny_instance, monkeypatch):
    """SCS with eps 1e-3: some claims inconclusive, none violated."""
    real = verify.try_solve

    def loose(form, solver):
        try:
            return form.solve(solver, raise_on_failure=False, eps_abs=1e-3, eps_rel=1e-3), ""
        except lb.errors.LPBoundsError:
            return real(form, solver)

    monkeypatch.setattr(verify, "try_solve", loose)
    recs = verify.verify_instance(tiny_instance, ["SCS"], n_costs=2)
    verdicts = {r["verdict"] for r in recs if r["solver"] == "SCS"}
    assert "violated" not in verdicts
    assert "inconclusive" in verdicts, [(r["claim"], r["width"]) for r in recs]


# ---------------------------------------------------------------------- Remark 2
def test_remark_2_is_a_certified_difference():
    recs = verify.verify_remark2(["HIGHS", "SCIPY"])
    assert [r["solver"] for r in recs] == ["HIGHS", "SCIPY"]
    for r in recs:
        assert r["check"] == "Remark 2" and r["verdict"] == "holds", r
        assert r["deviation"] > 0, "lo OPT(c1+c2) - hi OPT(c1) - hi OPT(c2) must be positive"


def test_alp_value_bracket_contains_an_independent_optimum():
    ex = lb.formulations.find_cost_dependent_alp(0)
    res = lb.formulations.alp.ALP(ex.mdp, ex.basis, ex.cost1).solve("CLARABEL")
    lo, hi = verify.alp_value_bracket(ex.mdp, ex.basis, ex.cost1, res)
    # the same ALP built with loops and solved by scipy's HiGHS interface
    mdp, phi = ex.mdp, np.asarray(ex.basis)
    probs = mdp.probabilities_full()
    a_ub, b_ub = [], []
    for x in range(mdp.n_states):
        for u in range(mdp.n_actions):
            if mdp.allowed[x, u]:
                row = phi[x].copy()
                for k in range(mdp.n_outcomes):
                    row -= mdp.discount * probs[x, u, k] * phi[mdp.successors[x, u, k]]
                a_ub.append(-row)
                b_ub.append(-mdp.rewards[x, u])
    ref = so.linprog(phi.T @ ex.cost1, A_ub=a_ub, b_ub=b_ub, bounds=(None, None))
    assert ref.status == 0
    assert float(lo) - 1e-9 <= ref.fun <= float(hi) + 1e-9
    assert float(hi - lo) < 1e-5


# ---------------------------------------------------------------------- helpers
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
    with pytest.raises(ValidationError, match="rtol"):
        verify.verify_instance(tiny_instance, ["HIGHS"], rtol=0.0)


def test_model_instances_skip_large_models():
    insts, skipped = verify.model_instances(max_states=1000)
    assert "garnet-paper-scale" in skipped
    assert all(i.mdp.n_states <= 1000 for i in insts)


def test_summarize_counts_and_keeps_the_worst():
    def rec(verdict, width):
        return {"check": "Theorem 1", "solver": "HIGHS", "verdict": verdict, "width": width,
                "accuracy": 1e-6}  # fmt: skip

    rows = verify.summarize([rec("holds", 1e-9), rec("inconclusive", 1e-5), rec("holds", 5e-7)])
    assert len(rows) == 1
    row = rows[0]
    assert (row["records"], row["holds"], row["inconclusive"], row["violated"]) == (3, 2, 1, 0)
    assert row["verdict"] == "inconclusive" and row["width"] == 1e-5
    assert verify.exit_status([rec("inconclusive", 1.0)]) == 0
    assert verify.exit_status([rec("inconclusive", 1.0)], strict=True) == 1
    assert verify.exit_status([rec("violated", 0.0)]) == 1


# ---------------------------------------------------------------------- the command
def test_cli_holds_and_writes_json(tiny_model, tmp_path, capsys):
    out = tmp_path / "records.json"
    argv = ["verify", tiny_model, "--random", "0", "--solvers", "HIGHS", "CLARABEL"]
    rc = main([*argv, "--json", str(out), "--strict"])
    text = capsys.readouterr().out
    assert rc == 0, text
    recs = json.loads(out.read_text())
    assert recs and all(set(r) == KEYS and r["verdict"] == "holds" for r in recs)
    assert {r["instance"] for r in recs if r["check"] != "Remark 2"} == {"tiny"}
    assert "Remark 2" in {r["check"] for r in recs}
    assert "0 violated" in text and "holds" in text


def test_cli_exits_1_on_a_violated_claim(tiny_model, monkeypatch, capsys):
    monkeypatch.setattr(verify, "RLP", ShiftedRLP)
    rc = main(["verify", tiny_model, "--random", "0", "--solvers", "HIGHS"])
    assert rc == 1
    assert "violated" in capsys.readouterr().out


def test_cli_strict_fails_on_inconclusive(tiny_model, monkeypatch, capsys):
    real = verify.try_solve

    def noisy(form, solver):  # every RLP point 1e-3 off: valid but wide brackets
        res, msg = real(form, solver)
        if res is not None and res.formulation == "RLP":
            res = dataclasses.replace(
                res, x=res.x + 1e-3, certificate=None, lower_values=None, upper_values=None
            )
        return res, msg

    monkeypatch.setattr(verify, "try_solve", noisy)
    argv = ["verify", tiny_model, "--random", "0", "--solvers", "HIGHS"]
    assert main(argv) == 0
    assert "inconclusive" in capsys.readouterr().out
    assert main([*argv, "--strict"]) == 1


def test_cli_unknown_solver(tiny_model, capsys):
    rc = main(["verify", tiny_model, "--random", "0", "--solvers", "NOPE"])
    assert rc == 2
    err = capsys.readouterr().err
    assert "unknown solver" in err and len(err.strip().splitlines()) == 1


def test_shelf_model_sizes_are_known_without_building():
    """The default run verifies the shelf models: their sizes, read from the parameters,
    are the built models' (a Gymnasium model's is the built model's, unknown without
    Gymnasium: None)."""
    from lpbounds.model.instances import load_instance, models_dir

    gym = importlib.util.find_spec("gymnasium") is not None
    seen = set()
    for path in sorted(models_dir().glob("*.toml")):
        inst = load_instance(str(path))
        if inst.kind in ("forest", "gridworld", "admission_queue", "inventory", "savings"):
            assert verify.estimated_states(inst) == inst.mdp().n_states, path.name
            seen.add(inst.kind)
        elif inst.kind == "gymnasium":
            expected = load_instance(str(path)).mdp().n_states if gym else None
            assert verify.estimated_states(inst) == expected, path.name
    assert seen == {"forest", "gridworld", "admission_queue", "inventory", "savings"}
    insts, skipped = verify.model_instances(max_states=10_000)
    names = {i.name for i in insts}
    assert {"forest", "gridworld", "queue", "inventory", "savings"} <= names
    assert "patrol-paper" in skipped and "forest" not in skipped


def test_the_default_run_verifies_the_gymnasium_models():
    """With Gymnasium installed the default run (no model named) verifies FrozenLake (17
    states with the sink), CliffWalking (49) and Taxi (501), which it used to skip as of
    unknown size; a --max-states below a model's size still skips it, by its size."""
    pytest.importorskip("gymnasium")
    insts, skipped = verify.model_instances(max_states=10_000)
    sizes = {i.name: i.mdp.n_states for i in insts}
    assert {"frozenlake": 17, "cliffwalking": 49, "taxi": 501}.items() <= sizes.items()
    assert not {"frozenlake", "cliffwalking", "taxi"} & set(skipped)
    insts, skipped = verify.model_instances(max_states=100)
    assert "frozenlake" in {i.name for i in insts} and "cliffwalking" in {i.name for i in insts}
    assert "taxi" in skipped and "taxi" not in {i.name for i in insts}
