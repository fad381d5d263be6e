"""Certificates anyone can check: the claims decided exactly, their files, the checker.

The checker (src/lpbounds/exact/check.py) must accept every certificate lpbounds writes
when run with the standard library alone (``python -I -S``: no site-packages at all), and
fail, naming the entry, when one number of a file is changed.
"""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.exact import check
from lpbounds.exact.files import write_certificate
from lpbounds.formulations import ELP, RLP, find_cost_dependent_alp
from lpbounds.status import Verdict
from lpbounds.studies.exact_claims import (
    ExactInstance,
    comparison,
    decide_remark2,
    exact_verdict,
    write_certificates,
)

from . import _reference as ref

CHECKER = Path(check.__file__)


@pytest.fixture(scope="module")
def instance() -> ExactInstance:
    mdp = lb.garnet(8, 3, 3, 0.95, seed=21, allowed_fraction=0.8)
    part = lb.random_partition(8, 3, seed=2)
    rng = np.random.default_rng(5)
    costs = [rng.uniform(0.1, 1.0, 8), rng.uniform(0.0, 1.0, 8) * (rng.random(8) > 0.4)]
    d_list = [rng.uniform(0.0, 1.0, (8, 3)), np.zeros((8, 3))]
    return ExactInstance("garnet-8", mdp, part, costs=costs, d_list=d_list, ib_blocks=(1, 2, 3))


@pytest.fixture(scope="module")
def verdicts(instance):
    ex = find_cost_dependent_alp(0)
    return [*instance.decide(), decide_remark2(ex.mdp, ex.basis, ex.cost1, ex.cost2)]


@pytest.fixture(scope="module")
def files(verdicts, tmp_path_factory) -> list[Path]:
    return write_certificates(verdicts, tmp_path_factory.mktemp("certificates"))


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=300)


def test_every_claim_holds_exactly_with_its_difference(instance, verdicts):
    assert [v.check for v in verdicts] == [
        "Lemma 1",
        "Theorem 1",
        "Lemma 2",
        "Theorem 2",
        "Remark 2",
    ]
    assert all(v.verdict is Verdict.HOLDS for v in verdicts)
    lemma1, theorem1, lemma2, theorem2, remark2 = verdicts
    # Phi v* >= V*: the exact margin, against the references of the tests
    vstar = ref.vstar(instance.mdp)
    m = instance.partition.n_partitions
    v_rlp = ref.lp_optimum(ref.rlp(instance.mdp, instance.partition.labels, m),
                           [Fraction(float(c)) for c in instance.cbar(0)])[1]  # fmt: skip
    margin = min(v_rlp[int(i)] - t for i, t in zip(instance.partition.labels, vstar, strict=True))
    assert lemma1.differences["Phi v* >= V*"] == margin >= 0
    assert theorem1.difference == lemma2.difference == theorem2.difference == 0
    ex = find_cost_dependent_alp(0)
    assert remark2.difference > 0 and abs(float(remark2.difference) - ex.excess) < 1e-6


def test_checker_accepts_every_certificate_in_isolated_python(files):
    """``python -I -S check.py``: no site-packages, no environment, no lpbounds: the
    checker proves each claim from the file alone."""
    out = _run("-I", "-S", str(CHECKER), *map(str, files))
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.count(": OK: ") == len(files)


def test_module_entry_point_loads_the_standard_library_only(files):
    code = (
        "import runpy, sys\n"
        f"sys.argv = ['check', {str(files[0])!r}]\n"
        "try:\n    runpy.run_module('lpbounds.exact.check', run_name='__main__')\n"
        "except SystemExit as e:\n    status = e.code\n"
        "heavy = sorted(m for m in ('numpy', 'flint', 'cvxpy', 'scipy') if m in sys.modules)\n"
        "print('STATUS', status, 'HEAVY', heavy)\n"
    )
    out = _run("-c", code)
    assert "STATUS 0 HEAVY []" in out.stdout, out.stdout + out.stderr


def _tampered(path: Path, tmp: Path, change) -> subprocess.CompletedProcess:
    cert = json.loads(path.read_text())
    change(cert)
    bad = tmp / ("tampered-" + path.name)
    bad.write_text(json.dumps(cert))
    return _run("-I", "-S", str(CHECKER), str(bad))


def _bump(vec: dict, i: int) -> None:
    vec["num"][i] = str(int(vec["num"][i], 0) + 1)


def _first_nonzero(vec: dict) -> int:
    return next(i for i, t in enumerate(vec["num"]) if t != "0")


@pytest.mark.parametrize(
    ("claim", "change", "named"),
    [
        ("Theorem_1", lambda c: _bump(c["lps"][0]["x"], 0), "lps[0] 'RLP c1'"),
        ("Theorem_1", lambda c: _bump(c["lps"][1]["y"], _first_nonzero(c["lps"][1]["y"])),
         "lps[1] 'RLP c2'"),
        ("Lemma_1", lambda c: _bump(c["fixed_points"][0]["x"], 3), "fixed_points[0] 'V*'"),
        ("Lemma_1", lambda c: c["claim"]["comparisons"][-1].update(difference="0/1"),
         "comparison 2"),
        ("Lemma_2", lambda c: c["model"]["rewards"][0].__setitem__(0, (0.5).hex()), "model"),
        ("Remark_2", lambda c: c["lps"][2].update(objective="1/1"), "lps[2] 'ALP c1+c2'"),
        ("Theorem_2", lambda c: c["claim"].update(verdict="violated"), "claim"),
    ],
)  # fmt: skip
def test_a_changed_number_fails_naming_the_entry(files, tmp_path, claim, change, named):
    path = next(p for p in files if p.name.endswith(f"--{claim}.json"))
    out = _tampered(path, tmp_path, change)
    assert out.returncode == 1, out.stdout
    assert "FAILED" in out.stdout and named in out.stdout, out.stdout


def test_planted_false_claim_is_violated_with_its_exact_size(instance, tmp_path):
    """The reverse of Lemma 1's domination, V* >= Phi v*, is false where the partition
    loses information: the verdict is VIOLATED with difference -max(Phi v* - V*), computed
    here independently, and the checker accepts the certificate of the counterexample."""
    vstar = ref.vstar(instance.mdp)
    m = instance.partition.n_partitions
    v_rlp = ref.lp_optimum(ref.rlp(instance.mdp, instance.partition.labels, m),
                           [Fraction(float(c)) for c in instance.cbar(0)])[1]  # fmt: skip
    want = min(t - v_rlp[int(i)] for i, t in zip(instance.partition.labels, vstar, strict=True))
    assert want < 0
    fps = [instance.fixed_point("ELP").entry("V*"), instance.fixed_point("RLP").entry("v*")]
    comps = [comparison("V* >= Phi v*", {"of": "V*"}, {"of": "v*", "lift": True}, ">=")]
    v = exact_verdict("conjecture", "V* >= Phi v*", "garnet-8", instance.model, [], fps, comps, 0.0)
    assert v.verdict is Verdict.VIOLATED and v.difference == want
    path = write_certificate(tmp_path / "counterexample.json", v.certificate)
    out = _run("-I", "-S", str(CHECKER), str(path))
    assert out.returncode == 0 and "conjecture violated" in out.stdout, out.stdout
    bad = copy.deepcopy(v.certificate)
    bad["claim"]["verdict"] = "holds"
    with pytest.raises(check.CheckError, match="claim"):
        check.check_certificate(bad)


def test_judging_a_float_solve(instance):
    """Per solver: whether the float answer's certified bracket held, its exact error."""
    form = RLP(instance.mdp, instance.partition, instance.costs[0])
    res = form.solve("CLARABEL")
    j = instance.judge(form, res)
    assert j.inside_bracket is True
    want = max(abs(Fraction(float(a)) - b) for a, b in
               zip(res.values, instance.fixed_point("RLP").values, strict=True))  # fmt: skip
    assert j.error == want > 0
    rec = j.record()
    assert rec["solver"] == "CLARABEL" and Fraction(rec["exact_error"]) == want
    # the same LP through the instance's cache: no second exact solve, the same numbers
    assert instance.judge(form, res).error == want
    elp = ELP(instance.mdp, instance.costs[1])
    assert instance.judge(elp, elp.solve("HIGHS")).inside_bracket


def test_checker_usage_and_unreadable_files(tmp_path):
    out = _run("-I", "-S", str(CHECKER))
    assert out.returncode == 2 and "usage" in out.stderr
    (tmp_path / "x.json").write_text("{not json")
    out = _run("-I", "-S", str(CHECKER), str(tmp_path / "x.json"), str(tmp_path / "missing.json"))
    assert out.returncode == 1 and out.stdout.count("FAILED") == 2


def test_checker_docstring_states_its_length_and_trust():
    text = CHECKER.read_text()
    lines = len(text.splitlines())
    doc = check.__doc__ or ""
    assert "Trusts" in doc or "trusts" in doc
    stated = int(doc.split("this file, about ")[1].split(" lines")[0])
    assert abs(stated - lines) <= 10, f"the docstring says {stated} lines, the file has {lines}"
    assert lines <= 450
