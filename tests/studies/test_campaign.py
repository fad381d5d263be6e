"""lpbounds.studies.campaign and lpbounds.studies.claims: campaigns, conjectures, resuming.

The verdicts a campaign records are compared with dense, independent computations
(tests/_independent.py); the Dask and resumed runs with a serial, uninterrupted one.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from lpbounds.cli.main import main
from lpbounds.errors import LPBoundsError, OutputError, ValidationError
from lpbounds.model.instances import load_instance
from lpbounds.model.partition import Partition
from lpbounds.status import Verdict
from lpbounds.studies import campaign as cp
from lpbounds.studies import claims as cl
from tests import _independent as ind

GARNETS = ["garnet", "masked-garnet"]


def _dense(mdp):
    P = ind.dense_transitions(mdp.successors, mdp.probabilities)
    R = np.where(mdp.allowed, mdp.rewards, 0.0)
    return P, R, np.asarray(mdp.allowed)


def _refined(partition: Partition) -> Partition:
    """Every block split by the parity of its states' indices (a refinement)."""
    x = np.arange(partition.n_states)
    return Partition(np.unique(2 * partition.labels + x % 2, return_inverse=True)[1].ravel())


# the claims of docs/verify.md ------------------------------------------------------------
def rlp_bound_equals_vstar(trial):
    """False: RLP's upper bound Phi v* equals V* at every state."""
    return trial.equal(trial.rlp_bound(), trial.vstar())


def refinement_lowers_the_bound(trial):
    """True, not stated in the paper: refining the partition never raises RLP's bound."""
    from lpbounds.rows import BellmanRows

    fine = _refined(trial.partition)
    lo, hi = trial.exact(BellmanRows.aggregate(trial.mdp, fine, reduce="max"))
    return trial.at_least(trial.rlp_bound(), (fine.lift(lo), fine.lift(hi)))


FALSE = cl.Conjecture("RLP bound = V*", rlp_bound_equals_vstar, uses_solver=False)
TRUE = cl.Conjecture(
    "refinement lowers RLP's bound", refinement_lowers_the_bound, uses_solver=False
)


def _same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    """Equal records but for the solve timings."""
    drop = list(cp.TIMING_COLUMNS)
    pd.testing.assert_frame_equal(a.drop(columns=drop), b.drop(columns=drop))


# ---------------------------------------------------------------------- instances
def test_an_instance_is_a_function_of_family_and_seed():
    for family in cp.FAMILIES:
        a, b = cp.campaign_instance(family, 12345), cp.campaign_instance(family, 12345)
        assert a.name == f"{family}:12345" and a.params == b.params
        for attr in ("successors", "probabilities", "rewards", "allowed"):
            assert np.array_equal(getattr(a.mdp, attr), getattr(b.mdp, attr))
        assert np.array_equal(a.partition.labels, b.partition.labels)
        assert a.params["n_states"] == a.mdp.n_states == a.partition.n_states
    c = cp.campaign_instance("garnet", 12346)
    assert c.params != cp.campaign_instance("garnet", 12345).params


def test_the_plan_is_seeded_and_its_prefix_is_the_plan_of_fewer():
    plan = cp.instance_plan(50, 7, list(cp.FAMILIES))
    assert plan == cp.instance_plan(50, 7, list(cp.FAMILIES))
    assert cp.instance_plan(20, 7, list(cp.FAMILIES)) == plan[:20]
    assert plan != cp.instance_plan(50, 8, list(cp.FAMILIES))
    assert {f for _, f, _ in plan} == set(cp.FAMILIES)
    assert [k for k, _, _ in plan] == list(range(50))


def test_the_families_cover_discounts_scales_and_partitions():
    rng = np.random.default_rng(0)
    lams = np.array([cp.draw_discount(rng) for _ in range(4000)])
    assert lams.min() == 0.0 and 0.9995 < lams.max() <= 0.9999
    assert (lams > 0.999).sum() > 100 and ((lams > 0.1) & (lams < 0.5)).sum() > 100
    insts = [cp.campaign_instance(f, s) for _, f, s in cp.instance_plan(120, 1, GARNETS)]
    scales = [i.params["reward_scale"] for i in insts]
    assert min(scales) < 1e-4 and max(scales) > 1e4
    kinds = {i.params["partition_kind"] for i in insts}
    assert kinds == set(cp.PARTITION_KINDS)
    for inst in insts:
        kind, part = inst.params["partition_kind"], inst.partition
        rmax = np.abs(np.where(inst.mdp.allowed, inst.mdp.rewards, 0.0)).max()
        assert rmax <= inst.params["reward_scale"]
        if kind == "singletons":
            assert part.n_partitions == inst.mdp.n_states
        if kind == "one-block":
            assert part.n_partitions == 1
        if kind == "value-ordered":  # the blocks are runs of V*, checked by dense PI
            v = ind.policy_iteration(*_dense(inst.mdp), inst.mdp.discount).values
            order = np.argsort(v, kind="stable")
            tol = 1e-9 * (np.abs(v).max() + 1)
            for i in range(part.n_partitions - 1):
                assert v[part.labels == i].max() <= v[part.labels == i + 1].min() + tol
            assert order.size == inst.mdp.n_states
        if inst.family == "masked-garnet":
            assert not inst.mdp.allowed.all() or inst.mdp.n_actions == 1


def test_unknown_family_and_bad_seed_name_the_argument():
    with pytest.raises(ValidationError, match="family: unknown family 'garnett'"):
        cp.campaign_instance("garnett", 1)
    with pytest.raises(ValidationError, match="seed must be an integer >= 0"):
        cp.campaign_instance("garnet", -1)
    with pytest.raises(ValidationError, match="families: unknown family 'nope'"):
        cp.run_campaign(1, families=["nope"])
    with pytest.raises(ValidationError, match="batch_size"):
        cp.run_campaign(1, batch_size=0)
    with pytest.raises(ValidationError, match="claims: unknown claim 'Theorem 9'"):
        cp.run_campaign(1, claims=["Theorem 9"])
    with pytest.raises(ValidationError, match="exact_method: unknown method 'lu'"):
        cp.run_campaign(1, exact_method="lu")


# ---------------------------------------------------------------------- conjectures
def test_the_false_conjecture_is_shrunk_to_at_most_3_states(tmp_path):
    res = cp.run_campaign(
        6, 0, families=GARNETS, claims=[FALSE], solvers=[], out=tmp_path / "c", batch_size=3
    )
    violated = res.frame[res.frame["verdict"] == "violated"]
    assert len(violated) >= 1 and len(res.counterexamples) == len(violated)
    for cex in res.counterexamples:
        assert cex.shrunk["states"] <= 3 and cex.shrunk["states"] < cex.original["states"] + 1
        # independently: on the shrunk instance Phi v* and V* differ by more than the accuracy
        P, R, allowed = _dense(cex.mdp)
        lam = cex.mdp.discount
        vstar = ind.policy_iteration(P, R, allowed, lam)
        vbar = ind.rlp_optimum(P, R, allowed, lam, cex.partition.labels)
        gap = np.abs(cex.partition.lift(vbar.values) - vstar.values).max()
        assert gap > vstar.error + vbar.error
        # the model file reads back bit for bit, and lpbounds verify accepts it
        inst = load_instance(str(cex.path))
        for attr in ("successors", "probabilities", "rewards", "allowed"):
            assert np.array_equal(getattr(inst.mdp(), attr), getattr(cex.mdp, attr))
        assert np.array_equal(inst.partition().labels, cex.partition.labels)
    listed = pd.read_csv(tmp_path / "c" / "counterexamples.csv")
    assert len(listed) == len(res.counterexamples) and (listed["states"] <= 3).all()
    assert main([
        "verify", str(res.counterexamples[0].path), "--random", "0", "--solvers", "HIGHS",
        "--claims", "theorem1", "-q",
    ]) == 0  # fmt: skip


def test_a_true_conjecture_has_no_counterexample_in_200_instances():
    res = cp.run_campaign(200, 5, families=GARNETS, claims=[TRUE], solvers=[], batch_size=50)
    assert len(res.frame) == 200
    assert res.verdicts() == {"holds": 200, "violated": 0, "inconclusive": 0, "error": 0}
    assert res.due == 200 and res.missing == {}
    assert res.counterexamples == [] and res.exit_status(strict=True) == 0


def test_the_true_conjecture_by_hand():
    """The refinement claim's two sides, computed independently, on a few instances."""
    for _, family, seed in cp.instance_plan(8, 2, GARNETS):
        inst = cp.campaign_instance(family, seed)
        P, R, allowed = _dense(inst.mdp)
        lam = inst.mdp.discount
        coarse = ind.rlp_optimum(P, R, allowed, lam, inst.partition.labels)
        fine_part = _refined(inst.partition)
        fine = ind.rlp_optimum(P, R, allowed, lam, fine_part.labels)
        slack = coarse.error + fine.error
        assert np.all(inst.partition.lift(coarse.values) >= fine_part.lift(fine.values) - slack)
        rec = cl.run_claims(inst, [TRUE], [])[0]
        assert rec["verdict"] == Verdict.HOLDS


def test_a_predicate_may_return_a_bool_a_verdict_or_raise():
    inst = cp.campaign_instance("garnet", 3)

    def boom(trial):
        raise RuntimeError("kaput")

    conjs = [
        cl.Conjecture("yes", lambda t: True, uses_solver=False),
        cl.Conjecture("no", lambda t: (False, "said no"), uses_solver=False),
        cl.Conjecture("word", lambda t: "inconclusive", uses_solver=False),
        cl.Conjecture("boom", boom, uses_solver=False),
    ]
    recs = {r["check"]: r for r in cl.run_claims(inst, conjs, [])}
    assert recs["yes"]["verdict"] == Verdict.HOLDS
    assert recs["no"]["verdict"] == Verdict.VIOLATED and recs["no"]["detail"] == "said no"
    assert recs["word"]["verdict"] == Verdict.INCONCLUSIVE
    assert recs["boom"]["verdict"] == "error"  # a crash is an error record, not a verdict
    assert recs["boom"]["error"] == "RuntimeError: kaput"
    bad = cl.Conjecture("bad", lambda t: 3.5, uses_solver=False)
    (rec,) = cl.run_claims(inst, [bad], [])
    assert rec["verdict"] == "error"
    assert rec["error"].startswith("conjecture 'bad' returned 3.5, not a verdict")
    with pytest.raises(ValidationError, match="predicate must be callable"):
        cl.Conjecture("x", 3)  # type: ignore[arg-type]


def test_a_conjecture_with_a_solver_uses_certified_brackets():
    """RLP solved by HiGHS: its certified bracket contains the dense v*, and the claim
    "the LP's bracket contains v*" holds; a bracket shifted by 1 is violated."""
    from lpbounds.formulations import RLP

    inst = cp.campaign_instance("garnet", 11)
    P, R, allowed = _dense(inst.mdp)
    vbar = ind.rlp_optimum(P, R, allowed, inst.mdp.discount, inst.partition.labels)
    seen = {}

    def rlp_is_vbar(trial, shift=0.0):
        solved = trial.solve(RLP(trial.mdp, trial.partition))
        seen["bracket"] = solved.bracket
        b = solved.bracket
        return trial.equal((b.lower + shift, b.upper + shift), trial.rlp_values())

    good = cl.Conjecture("RLP = v*", rlp_is_vbar)
    off = cl.Conjecture("RLP + 1 = v*", lambda t: rlp_is_vbar(t, 1.0))
    recs = cl.run_claims(inst, [good, off], ["HIGHS"])
    assert [r["verdict"] for r in recs] == [Verdict.HOLDS, Verdict.VIOLATED]
    assert recs[0]["solves"] == 1 and recs[0]["solver"] == "HIGHS"
    b = seen["bracket"]
    assert np.all(b.lower <= vbar.values + vbar.error) and np.all(
        vbar.values - vbar.error <= b.upper
    )
    with pytest.raises(ValidationError, match="solver-free"):
        cl.Trial(inst, None).solve(RLP(inst.mdp, inst.partition))


def test_load_claim_from_a_file_and_by_name(tmp_path):
    path = tmp_path / "mine.py"
    path.write_text(
        "from lpbounds.studies.claims import Conjecture\n"
        "def always(trial):\n    return True\n"
        "C = Conjecture('mine', always, uses_solver=False)\n"
    )
    assert cl.load_claim(f"{path}:C").name == "mine"
    assert cl.load_claim(f"{path}:always").name == "always"
    assert cl.load_claim("theorem-2").name == "Theorem 2"
    with pytest.raises(ValidationError, match="defines no 'D'"):
        cl.load_claim(f"{path}:D")
    with pytest.raises(ValidationError, match="no file"):
        cl.load_claim(f"{tmp_path / 'none.py'}:C")
    (tmp_path / "broken.py").write_text("1/0\n")
    with pytest.raises(ValidationError, match="raised ZeroDivisionError"):
        cl.load_claim(f"{tmp_path / 'broken.py'}:C")


# ---------------------------------------------------------------------- built-in claims
def test_builtin_records_agree_with_verify_and_are_streamed(tmp_path):
    """A campaign's records of the built-in claims are verify_instance's on the same
    instance (costs seeded by the instance's seed), one file per batch."""
    from lpbounds.studies.verify import verify_instance

    out = tmp_path / "c"
    res = cp.run_campaign(
        4, 1, families=GARNETS, claims=["Theorem 1", "Lemma 2"], solvers=["HIGHS"],
        out=out, batch_size=3,
    )  # fmt: skip
    assert sorted(p.name for p in (out / "batches").iterdir()) == [
        "batch-000000.csv",
        "batch-000001.csv",
    ]
    assert res.verdicts()["violated"] == 0
    first = res.frame[res.frame["campaign_index"] == 0]
    inst = cp.campaign_instance(first["family"].iloc[0], int(first["seed"].iloc[0]))
    direct = verify_instance(
        inst, ["HIGHS"], seed=inst.seed, checks=["Theorem 1", "Lemma 2"], exact_method="pi"
    )
    assert list(first["claim"]) == [r["claim"] for r in direct]
    assert list(first["verdict"]) == [str(r["verdict"].value) for r in direct]
    assert np.array_equal(first["lp_lo"].to_numpy(), [r["lp_interval"][0] for r in direct])
    summary = pd.read_csv(out / "summary.csv")
    assert set(summary["check"]) == {"Theorem 1", "Lemma 2"}
    assert summary["records"].sum() == len(res.frame)
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["campaign"]["n"] == 4 and "HIGHS" in meta["campaign_solvers"]
    assert {"lpbounds", "python", "machine", "dependencies", "command_line"} <= set(meta)
    assert meta["records"] == len(res.frame) and meta["verdicts"] == res.verdicts()


def test_the_folder_must_hold_this_campaign(tmp_path):
    out = tmp_path / "c"
    cp.run_campaign(2, 0, families=["garnet"], claims=[FALSE], solvers=[], out=out, shrink=False)
    with pytest.raises(ValidationError, match=r"other arguments \(seed = 0, now 1\)"):
        cp.run_campaign(2, 1, families=["garnet"], claims=[FALSE], solvers=[], out=out)
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "thesis.tex").write_text("x")
    with pytest.raises(OutputError, match="holds no campaign"):
        cp.run_campaign(2, 0, claims=[FALSE], solvers=[], out=tmp_path / "full")
    assert (tmp_path / "full" / "thesis.tex").read_text() == "x"


def test_parquet_batches(tmp_path):
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        with pytest.raises(LPBoundsError, match="needs pyarrow"):
            cp.run_campaign(2, claims=[FALSE], solvers=[], out=tmp_path / "p", fmt="parquet")
        return
    kw = {"families": ["garnet"], "claims": [FALSE], "solvers": [], "shrink": False}
    a = cp.run_campaign(4, 0, out=tmp_path / "p", fmt="parquet", batch_size=2, **kw)
    b = cp.run_campaign(4, 0, out=tmp_path / "c", fmt="csv", batch_size=2, **kw)
    _same(a.frame, b.frame)
    assert (tmp_path / "p" / "records.parquet").exists()


# ---------------------------------------------------------------------- Dask and resuming
def test_a_local_cluster_gives_the_same_records_as_serial(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    kw = {  # no patrol family: each worker process would compile its kernels first
        "families": ["garnet", "masked-garnet", "shelf"],
        "claims": ["Theorem 1", "Theorem 2", TRUE],
        "solvers": ["HIGHS"],
        "batch_size": 2,
    }
    serial = cp.run_campaign(6, 4, out=tmp_path / "serial", **kw)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        address = cluster.scheduler_address  # as a user passes it: --scheduler ADDRESS
        remote = cp.run_campaign(6, 4, out=tmp_path / "cluster", scheduler=address, **kw)
    assert remote.scheduler == "cluster" and len(serial.frame) > 6
    _same(serial.frame, remote.frame)
    threads = cp.run_campaign(6, 4, scheduler="threads", **kw)  # in memory, no folder
    _same(serial.frame, threads.frame)


def _cli(*args: str) -> list[str]:
    code = "import sys; sys.argv[0] = 'lpbounds'; from lpbounds.cli.main import entry; entry()"
    return [sys.executable, "-c", code, *args]


#: A conjecture that holds and, while the file named by LPBOUNDS_TEST_GATE exists, waits
#: at every instance after the first two (the first batch): the run it is part of cannot
#: finish before the test interrupts it, however loaded the machine is.
GATE = """
import os, time
from lpbounds.studies.claims import Conjecture


def wait_at_the_gate(trial):
    gate = os.environ.get("LPBOUNDS_TEST_GATE", "")
    if trial.instance.name not in FIRST and gate:
        while os.path.exists(gate):
            time.sleep(0.01)
    return True


FIRST = set()
GATED = Conjecture("holds, waiting at the gate", wait_at_the_gate, uses_solver=False)
"""


def test_an_interrupted_campaign_resumes_to_the_same_records(tmp_path):
    args = [
        "verify", "--random", "12", "--seed", "2", "--families", "garnet", "masked-garnet",
        "--claims", "theorem1", "--solvers", "HIGHS", "--batch-size", "2",
    ]  # fmt: skip
    whole = tmp_path / "whole"
    names = [
        f"{fam}:{seed}" for _, fam, seed in cp.instance_plan(2, 2, ["garnet", "masked-garnet"])
    ]
    gate_file = tmp_path / "gate.py"
    gate_file.write_text(GATE.replace("FIRST = set()", f"FIRST = {set(names)!r}"))
    args.insert(args.index("theorem1") + 1, f"{gate_file}:GATED")
    assert main([*args, "--out", str(whole), "-q"]) == 0
    out = tmp_path / "cut"
    gate = tmp_path / "closed"
    gate.touch()
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "LPBOUNDS_TEST_GATE": str(gate)}
    proc = subprocess.Popen(
        _cli(*args, "--out", str(out)),
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        # SIGINT as in a terminal, even when the suite runs as a background job (which
        # starts its children with SIGINT ignored: the campaign then ran to its end)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if list((out / "batches").glob("batch-*.csv")):
            break
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "run the same command again to resume" in err
    on_disk = len(list((out / "batches").glob("batch-*.csv")))
    assert 1 <= on_disk < 6 and not (out / "records.csv").exists()
    done = subprocess.run(_cli(*args, "--out", str(out), "-q"), capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["batches"]["resumed"] == on_disk and meta["batches"]["run"] == 6 - on_disk
    _same(cp.read_records(whole), cp.read_records(out))
    _same(
        pd.read_csv(whole / "records.csv", keep_default_na=False),
        pd.read_csv(out / "records.csv", keep_default_na=False),
    )


# ---------------------------------------------------------------------- the command line
def test_cli_campaign_options_need_out(capsys):
    assert main(["verify", "--scheduler", "threads", "--random", "0"]) == 2
    assert "--scheduler belongs to a campaign: give --out DIR" in capsys.readouterr().err
    assert main(["verify", "garnet-small", "--out", "x", "--random", "0"]) == 2
    assert "a campaign draws its instances" in capsys.readouterr().err


def test_cli_campaign_with_a_conjecture_file(tmp_path, capsys):
    path = tmp_path / "claims.py"
    path.write_text(
        "from lpbounds.studies.claims import Conjecture\n"
        "def equal(trial):\n    return trial.equal(trial.rlp_bound(), trial.vstar())\n"
        "FALSE = Conjecture('RLP bound = V*', equal, uses_solver=False)\n"
    )
    out = tmp_path / "c"
    code = main([
        "verify", "--random", "3", "--seed", "0", "--families", "garnet", "--claims",
        f"{path}:FALSE", "--out", str(out),
    ])  # fmt: skip
    text = capsys.readouterr().out
    frame = cp.read_records(out)
    violated = int((frame["verdict"] == "violated").sum())
    assert code == (1 if violated else 0)
    assert f"{violated} violated" in text
    if violated:
        assert "counterexamples, shrunk" in text
        assert len(list((out / "counterexamples").glob("*.toml"))) == violated
