"""Exact verdicts (issue 38, items 3 and 4) against computations written here in
``fractions``: a planted false conjecture's counterexample (shrunk, certified, its
certificate checked by the standalone checker and failing when one number changes), a
planted violation of a built-in claim's exact comparison of known size, and a solver's
exact error and bracket against an LP optimum found by enumerating bases.

The references (tests/exact/_reference.py) use no lpbounds code: ``V*`` by enumerating
policies, LP optima by enumerating bases of the LP written out from the model's arrays.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from fractions import Fraction
from pathlib import Path

import numpy as np

import lpbounds as lb
from lpbounds.exact.rationals import RationalVector
from lpbounds.formulations import RLP
from lpbounds.model.instances import load_instance
from lpbounds.studies import campaign as cp
from lpbounds.studies import claims as cl
from lpbounds.studies.exact_claims import ExactInstance, ExactJudge, comparison, exact_verdict
from lpbounds.studies.verify import (
    VerifyInstance,
    exact_instance,
    exit_status,
    summarize,
    verify_instance,
)
from tests.exact import _reference as ref

ROOT = Path(__file__).resolve().parents[2]
CHECKER = ROOT / "src" / "lpbounds" / "exact" / "check.py"


def run_checker(*paths: Path) -> subprocess.CompletedProcess[str]:
    """The checker as a plain script in a Python without site-packages."""
    return subprocess.run(
        [sys.executable, "-I", "-S", str(CHECKER), *map(str, paths)],
        capture_output=True, text=True, timeout=600, cwd="/",
    )  # fmt: skip


def rlp_optimum(mdp, part, cost) -> tuple[Fraction, list[Fraction]]:
    """RLP's optimum for the state cost ``cost`` (summed per partition in floating point,
    as RLP states it), by enumerating the bases of eq. 9 written out in fractions."""
    m = part.n_partitions
    cbar = np.bincount(part.labels, weights=np.asarray(cost, float), minlength=m)
    return ref.lp_optimum(ref.rlp(mdp, part.labels, m), [Fraction(float(t)) for t in cbar])


# ---------------------------------------------------------------------- a false conjecture
def rlp_bound_equals_vstar(trial):
    """False: RLP's upper bound Phi v* equals V* at every state."""
    return trial.equal(trial.rlp_bound(), trial.vstar())


FALSE = cl.Conjecture("RLP bound = V*", rlp_bound_equals_vstar, uses_solver=False)


def test_a_false_conjecture_gets_a_shrunk_exact_counterexample_with_a_certificate(tmp_path):
    out = tmp_path / "c"
    res = cp.run_campaign(
        4, 3, families=["garnet"], claims=[FALSE], solvers=[], arithmetic="rational",
        certificates=True, out=out, shrink_seconds=60,
    )  # fmt: skip
    frame = res.frame.set_index("instance")
    kinds = frame["partition_kind"]
    # Phi v* = V* exactly where the partition is the states themselves, and only there
    assert (frame["verdict"] == np.where(kinds == "singletons", "holds", "violated")).all()
    assert 1 <= (kinds == "singletons").sum() < len(frame)
    (one,) = frame.index[kinds == "singletons"]
    drawn = cp.campaign_instance("garnet", int(one.split(":")[1]))
    assert drawn.mdp.n_actions == 1  # one policy: V* and v* by one exact solve each
    vstar = ref.vstar(drawn.mdp)
    _, vbar = rlp_optimum(drawn.mdp, drawn.partition, np.ones(drawn.mdp.n_states))
    assert [vbar[drawn.partition.labels[s]] for s in range(len(vstar))] == vstar
    assert Fraction(frame.loc[one, "exact_difference"]) == 0
    assert len(res.counterexamples) == (frame["verdict"] == "violated").sum()
    for cex in res.counterexamples:
        assert cex.certificate is not None and cex.certificate.exists()
        original, shrunk = cex.original["states"], cex.shrunk["states"]
        assert shrunk < original and shrunk <= 3 and cex.steps >= 1
        # the shrunk instance, loaded back from its model file, decided here in fractions
        inst = load_instance(str(cex.path))
        mdp, part = inst.mdp(), inst.partition()
        vstar = ref.vstar(mdp)
        _, vbar = rlp_optimum(mdp, part, np.ones(mdp.n_states))  # positive cost: v*
        gap = max(abs(vbar[part.labels[s]] - vstar[s]) for s in range(mdp.n_states))
        assert gap > 0  # a counterexample in exact arithmetic
        cert = json.loads(cex.certificate.read_text())
        assert cert["claim"]["verdict"] == "violated"
        (comp,) = cert["claim"]["comparisons"]
        assert Fraction(comp["difference"]) == gap and comp["verdict"] == "violated"
        # the checker alone accepts it ...
        done = run_checker(cex.certificate)
        assert done.returncode == 0, done.stdout + done.stderr
        assert "OK: RLP bound = V* violated" in done.stdout
        # ... and fails it, naming the entry, when one number of V* changes
        fp = next(e for e in cert["fixed_points"] if e["id"] == "V*")
        fp["x"]["num"][-1] = str(int(fp["x"]["num"][-1]) + 1)
        bad = tmp_path / "tampered.json"
        bad.write_text(json.dumps(cert))
        done = run_checker(bad)
        assert done.returncode == 1
        assert "FAILED" in done.stdout and "'V*'" in done.stdout, done.stdout


# ---------------------------------------------------------------------- a planted violation
#: The planted shifts: far below a double's resolution at these values (so the float
#: verdicts hold), and not dyadic (so no double could carry them).
SHIFT_EQ = Fraction(1, 3**40)
SHIFT_GE = Fraction(5, 7**30)


class Planted(ExactInstance):
    """An exact instance whose Lemma 1 verdict compares ``V*`` with ``V*`` shifted by
    :data:`SHIFT_EQ` at one state (ELP's equality) and a vector with itself shifted by
    :data:`SHIFT_GE` (``Phi v* >= V*``): two planted violations of known size."""

    def decide(self, checks=None):
        out = super().decide(checks)
        return [self.planted() if v.check == "Lemma 1" else v for v in out]

    def planted(self):
        fp = self.fixed_point("ELP")
        w = list(fp.values)
        up = [t + SHIFT_EQ * (i == 1) for i, t in enumerate(w)]
        more = [t + SHIFT_GE * (i == 0) for i, t in enumerate(w)]

        def vec(xs):
            return {"vector": RationalVector.from_fractions(xs).to_json()}

        comps = [
            comparison("ELP c1 optimum = V*", {"of": "V*"}, vec(up), "=="),
            comparison("Phi v* >= V*", vec(w), vec(more), ">="),
        ]
        t0 = time.perf_counter()
        return exact_verdict(
            "Lemma 1", "planted", self.name, self.model, [], [fp.entry("V*")], comps, t0
        )


def test_a_planted_violation_is_violated_by_exactly_its_size():
    mdp = lb.garnet(7, 2, 3, 0.9, seed=2)
    inst = VerifyInstance("planted", mdp, lb.random_partition(7, 3, seed=1))
    base = exact_instance(inst, 2, 0)
    planted = Planted(
        inst.name, mdp, inst.partition, costs=base.costs, d_list=base.d_list,
        ib_blocks=base.ib_blocks,
    )  # fmt: skip
    records = verify_instance(
        inst, ["HIGHS"], n_costs=2, seed=0, checks=["Lemma 1"], arithmetic="rational",
        exact=planted,
    )  # fmt: skip
    by_claim = {r["claim"]: r for r in records}
    for claim in ("optimal value = c'(exact)", "optimum = exact (c > 0)"):
        r = by_claim[claim]
        assert r["solver"] == "HIGHS" and str(r["verdict"]) == "violated"
        assert Fraction(r["exact_difference"]) == SHIFT_EQ
        assert r["float_verdict"] == "holds"  # no double sees the shift
    r = by_claim["Phi v* >= V*"]
    assert r["solver"] == "exact" and str(r["verdict"]) == "violated"
    assert Fraction(r["exact_difference"]) == -SHIFT_GE and r["float_verdict"] == "holds"
    assert exit_status(records) == 1
    rows = {row["solver"]: row for row in summarize(records)}
    assert rows["HIGHS"]["violated"] == rows["HIGHS"]["disagree"] == 2
    assert rows["exact"]["violated"] == rows["exact"]["disagree"] == 1
    # unplanted, the same instance holds: the violation is the plant's alone
    fair = verify_instance(
        inst, ["HIGHS"], n_costs=2, seed=0, checks=["Lemma 1"], arithmetic="rational"
    )
    assert {str(r["verdict"]) for r in fair} == {"holds"} and exit_status(fair) == 0


# ---------------------------------------------------------------------- a solver's exact error
def _tiny():
    mdp = lb.garnet(4, 2, 2, 0.95, seed=6)
    return mdp, lb.random_partition(4, 2, seed=3)


def test_a_solvers_exact_error_and_bracket_against_an_independent_optimum():
    mdp, part = _tiny()
    cost = np.array([1.0, 0.25, 3.0, 0.5])
    opt, x = rlp_optimum(mdp, part, cost)
    judge = ExactJudge()
    for solver in ("HIGHS", "CLARABEL"):
        form = RLP(mdp, part, cost)
        res = form.solve(solver)
        j = judge(form, res)
        assert j.exact.objective == opt
        assert j.objective_error == abs(Fraction(float(res.objective)) - opt)
        assert j.error == max(
            abs(Fraction(float(v)) - t) for v, t in zip(res.values, x, strict=True)
        )
        inside = all(
            Fraction(float(lo)) <= t <= Fraction(float(hi))
            for lo, hi, t in zip(res.lower_values, res.upper_values, x, strict=True)
        )
        assert j.inside_bracket is inside is True


def test_a_records_exact_error_is_the_largest_of_its_solves():
    mdp, part = _tiny()
    inst = VerifyInstance("tiny", mdp, part)
    costs = exact_instance(inst, 3, 5).costs
    records = verify_instance(
        inst, ["HIGHS", "CLARABEL"], n_costs=3, seed=5, checks=["Theorem 1"],
        arithmetic="rational",
    )  # fmt: skip
    for solver in ("HIGHS", "CLARABEL"):
        objective, point = [], []
        for c in costs:
            opt, x = rlp_optimum(mdp, part, c)
            res = RLP(mdp, part, c).solve(solver, raise_on_failure=False)
            objective.append(abs(Fraction(float(res.objective)) - opt))
            if np.all(np.bincount(part.labels, weights=c) > 0):  # a unique optimal point
                point.append(
                    max(abs(Fraction(float(v)) - t) for v, t in zip(res.values, x, strict=True))
                )
        (r,) = [
            r for r in records if r["solver"] == solver and r["claim"] == "optimum = exact (c > 0)"
        ]
        assert Fraction(r["exact_error"]) == max(objective)
        assert r["exact_error_float"] == float(max(objective))
        assert Fraction(r["exact_value_error"]) == max(point)
        assert r["inside_bracket"] is True


def test_a_planted_bracket_that_misses_is_counted_and_fails_the_run():
    """A float solve whose certified bracket misses the exact optimum by a known amount:
    the judge says so, the record says so, the summary counts it and the exit status is 1
    (the check can fail, not only pass)."""
    import copy

    from lpbounds.studies.verify import judged_fields

    mdp, part = _tiny()
    cost = np.array([1.0, 0.25, 3.0, 0.5])
    _, x = rlp_optimum(mdp, part, cost)
    form = RLP(mdp, part, cost)
    res = form.solve("HIGHS")
    judge = ExactJudge()
    honest = judge(form, res)
    assert honest.inside_bracket is True
    planted = copy.copy(res)
    k = len(x) - 1
    shift = 2.0**-10  # the bracket of the last entry moved wholly below its exact value
    upper = np.array(res.upper_values, dtype=np.float64)
    lower = np.array(res.lower_values, dtype=np.float64)
    upper[k] = float(x[k]) - shift
    lower[k] = upper[k] - 1e-9
    planted.upper_values, planted.lower_values = upper, lower
    missed = judge(form, planted)
    assert Fraction(float(upper[k])) < x[k]  # missed in exact arithmetic
    assert missed.inside_bracket is False
    fields = judged_fields([honest, missed])
    assert fields["inside_bracket"] is False
    assert judged_fields([honest])["inside_bracket"] is True
    record = {"check": "Theorem 1", "solver": "HIGHS", "verdict": "holds", "width": 0.0,
              "accuracy": 1.0, "float_verdict": "holds", **fields}  # fmt: skip
    assert exit_status([record]) == 1
    assert exit_status([{**record, "inside_bracket": True}]) == 0
    assert exit_status([{**record, "inside_bracket": "False"}]) == 1  # read back from CSV
    (row,) = summarize([record])
    assert row["missed"] == 1 and row["disagree"] == 0
