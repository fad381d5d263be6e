"""A campaign's folder is evidence: verified on resume, bound to the code that made it,
never silently partial (issue 36).

Each row of the issue's table is a test here: a batch file cut, edited, garbled, deleted
or forged; an unreadable ``campaign.json`` or manifest; a bad ``--scheduler``; an edited
conjecture; a verdict edited to *violated*; a predicate that calls ``sys.exit`` or returns
``None``. Then SIGKILL at random points of a campaign, each followed by a resume: the
records end as those of an uninterrupted run.

The campaigns are small and solver-free (conjectures over exact fixed points), so that
each run takes about a second; the records compared are every column but the timings.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lpbounds.cli.main import main
from lpbounds.errors import OutputError, ValidationError
from lpbounds.studies import campaign as cp
from lpbounds.studies import claims as cl

CLAIMS = '''\
from lpbounds.studies.claims import Conjecture


def equal(trial):
    """False on most instances: RLP's bound equals V* at every state."""
    return trial.equal(trial.rlp_bound(), trial.vstar())


def dominates(trial):
    """True (Theorem 1's consequence): RLP's bound is above V*."""
    return trial.at_least(trial.rlp_bound(), trial.vstar())


def nothing(trial):
    return None


def leave(trial):
    import sys

    sys.exit(0)


def slowly(trial):
    """TRUE, taking its time (a sleep: the batches of a kill test last long enough to be
    cut between and inside, at no CPU cost)."""
    import time

    time.sleep(0.15)
    return dominates(trial)


FALSE = Conjecture("RLP bound = V*", equal, uses_solver=False)
SLOW = Conjecture("RLP bound >= V* (slowly)", slowly, uses_solver=False)
TRUE = Conjecture("RLP bound >= V*", dominates, uses_solver=False)
NONE = Conjecture("returns None", nothing, uses_solver=False)
EXIT = Conjecture("calls sys.exit", leave, uses_solver=False)
'''

FAMILIES = ["--families", "garnet", "masked-garnet"]


@pytest.fixture
def claims_file(tmp_path):
    path = tmp_path / "claims.py"
    path.write_text(CLAIMS)
    return path


def _args(claims_file: Path, *names: str, n: int = 6, batch: int = 2) -> list[str]:
    specs = [f"{claims_file}:{name}" for name in names]
    return [
        "verify", "--random", str(n), "--seed", "3", *FAMILIES, "--batch-size", str(batch),
        "--solvers", "HIGHS", "--claims", *specs, "--shrink-seconds", "5",
    ]  # fmt: skip


def _same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    """Equal records but for the solve timings."""
    drop = list(cp.TIMING_COLUMNS)
    pd.testing.assert_frame_equal(a.drop(columns=drop), b.drop(columns=drop), check_exact=True)


def _snapshot(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (relative name -> SHA-256): "nothing changed" is equal
    snapshots before and after."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


@pytest.fixture
def whole(tmp_path, claims_file):
    """An uninterrupted campaign of TRUE (3 batches of 2 instances)."""
    out = tmp_path / "whole"
    assert main([*_args(claims_file, "TRUE"), "--out", str(out), "-q"]) == 0
    return out


# ---------------------------------------------------------------------- the manifest
def test_the_manifest_lists_each_batch_with_its_hash(whole):
    manifest = json.loads((whole / cp.MANIFEST_FILE).read_text())
    assert manifest["campaign_folder"] == cp.FOLDER_VERSION
    entries = manifest["batches"]
    assert sorted(entries) == ["batch-000000", "batch-000001", "batch-000002"]
    frame = cp.read_records(whole)
    for k, (stem, e) in enumerate(sorted(entries.items())):
        path = whole / "batches" / e["file"]
        assert e["file"] == f"{stem}.csv" and e["instances"] == [2 * k, 2 * k + 1]
        assert e["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
        assert e["records"] == len(pd.read_csv(path)) == 2  # 2 instances x 1 claim x exact
        assert e["lpbounds"] == json.loads((whole / cp.CAMPAIGN_FILE).read_text())["lpbounds"]
    assert len(frame) == 6 and set(frame["verdict"]) == {"holds"}
    meta = json.loads((whole / cp.CAMPAIGN_FILE).read_text())
    assert meta["arguments"]["n"] == 6 and meta["arguments"]["claims"] == ["RLP bound >= V*"]
    fp = meta["claims"]["RLP bound >= V*"]
    assert fp["kind"] == "conjecture" and fp["source"].endswith("claims.py")
    assert fp["sha256"] == hashlib.sha256(Path(fp["source"]).read_bytes()).hexdigest()


# ---------------------------------------------------------------------- a batch damaged
def _cut_to_header(path: Path) -> None:
    path.write_text(path.read_text().splitlines()[0] + "\n")


def _drop_a_line(path: Path) -> None:
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:-1]))


def _garbage(path: Path) -> None:
    path.write_bytes(bytes(range(256)) * 7)


DAMAGE = {
    "cut to its header": (_cut_to_header, "does not match the manifest (its SHA-256 differs)"),
    "a record deleted": (_drop_a_line, "does not match the manifest (its SHA-256 differs)"),
    "binary garbage": (_garbage, "does not match the manifest (its SHA-256 differs)"),
    "deleted": (Path.unlink, "is listed in the manifest but missing"),
}


@pytest.mark.parametrize("damage", list(DAMAGE))
def test_a_damaged_batch_is_named_moved_aside_and_recomputed(
    damage, whole, tmp_path, claims_file, capsys
):
    """The table's first rows: a batch cut to its header (it said "40 instances, 114
    records" where 120 were due), a record deleted, garbage (a traceback), the file
    deleted. The same command again names the batch in one line, moves the damaged file
    into rejected/ (never deletes it) and ends with the uninterrupted run's records."""
    out = tmp_path / "c"
    args = [*_args(claims_file, "TRUE"), "--out", str(out)]
    assert main([*args, "-q"]) == 0
    batch = out / "batches" / "batch-000001.csv"
    hurt, said = DAMAGE[damage]
    hurt(batch)
    damaged = batch.read_bytes() if batch.exists() else None
    capsys.readouterr()
    assert main(args) == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "batch-000001.csv" in ln]
    assert len(lines) == 1 and said in lines[0] and "it is recomputed" in lines[0], err
    if damaged is not None:
        assert "moved to rejected/batch-000001.csv" in lines[0]
        assert (out / "rejected" / "batch-000001.csv").read_bytes() == damaged
    _same(cp.read_records(whole), cp.read_records(out))
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["batches"] == {"run": 1, "resumed": 2} and meta["missing"] == {}
    assert len(meta["notes"]) == 1 and meta["records"] == meta["due"] == 6


def test_a_forged_batch_consistent_with_a_forged_manifest_lacks_records_due(
    whole, tmp_path, claims_file, capsys
):
    """A record deleted *and* the manifest's hash and count rewritten to match: the file
    passes its hash, but its records no longer cover every (instance, claim, solver) due,
    so it is still named, moved aside and recomputed."""
    out = tmp_path / "c"
    args = [*_args(claims_file, "TRUE"), "--out", str(out)]
    assert main([*args, "-q"]) == 0
    batch = out / "batches" / "batch-000002.csv"
    _drop_a_line(batch)
    manifest = json.loads((out / cp.MANIFEST_FILE).read_text())
    manifest["batches"]["batch-000002"].update(
        sha256=hashlib.sha256(batch.read_bytes()).hexdigest(), records=1
    )
    (out / cp.MANIFEST_FILE).write_text(json.dumps(manifest))
    capsys.readouterr()
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "batch-000002.csv lacks the records of 1 (instance, claim, solver) due" in err
    _same(cp.read_records(whole), cp.read_records(out))


def test_a_truncated_parquet_batch_is_recomputed(tmp_path, capsys):
    pytest.importorskip("pyarrow")
    conj = cl.Conjecture("RLP bound >= V*", _dominates, uses_solver=False)
    kw = {"families": ["garnet"], "claims": [conj], "solvers": [], "batch_size": 2}
    whole = cp.run_campaign(4, 1, out=tmp_path / "w", fmt="parquet", **kw)
    out = tmp_path / "c"
    cp.run_campaign(4, 1, out=out, fmt="parquet", **kw)
    batch = out / "batches" / "batch-000000.parquet"
    batch.write_bytes(batch.read_bytes()[:100])  # an ArrowInvalid traceback before
    notes: list[str] = []
    res = cp.run_campaign(4, 1, out=out, fmt="parquet", notify=notes.append, **kw)
    assert len(notes) == 1 and notes[0].startswith("batch-000000.parquet does not match")
    assert res.batches_run == 1 and res.exit_status() == 0
    _same(whole.frame, res.frame)


def test_stray_files_are_moved_aside(whole, tmp_path, claims_file, capsys):
    """A file in batches/ that is no batch of this campaign (another format, a temporary
    file of a killed write) is moved into rejected/, and said; never read as records."""
    out = tmp_path / "c"
    args = [*_args(claims_file, "TRUE"), "--out", str(out)]
    assert main([*args, "-q"]) == 0
    (out / "batches" / "batch-000007.csv").write_text("check,claim\nx,y\n")
    (out / "batches" / ".batch-000001.csv.abc123.tmp").write_text("half a file")
    capsys.readouterr()
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "batches/batch-000007.csv is not a batch of this campaign: moved to rejected/" in err
    assert "is an unfinished write of an interrupted run: moved to rejected/" in err
    assert sorted(p.name for p in (out / "rejected").iterdir()) == [
        ".batch-000001.csv.abc123.tmp",
        "batch-000007.csv",
    ]
    _same(cp.read_records(whole), cp.read_records(out))


# ---------------------------------------------------------------------- unreadable folders
@pytest.mark.parametrize(
    ("name", "content", "said"),
    [
        (cp.CAMPAIGN_FILE, None, r"campaign\.json' cannot be read \(not valid JSON"),
        (cp.CAMPAIGN_FILE, "[1, 2, 3]\n", r"campaign\.json' cannot be read \(a JSON list"),
        (cp.CAMPAIGN_FILE, '{"campaign_folder": 2}', r"campaign\.json' cannot be read \(not a"),
        (cp.MANIFEST_FILE, None, r"manifest\.json' cannot be read \(not valid JSON"),
        (cp.MANIFEST_FILE, b"\xff\xfe\x00garbage", r"manifest\.json' cannot be read \(not valid"),
        (cp.MANIFEST_FILE, "", r"manifest\.json' cannot be read \(not valid JSON"),
    ],
)
def test_an_unreadable_campaign_file_or_manifest_is_refused_and_nothing_changes(
    name, content, said, tmp_path, claims_file, capsys
):
    """campaign.json truncated or a JSON list (a traceback before), the manifest truncated
    or garbled: one line naming the file, exit 2, every file as it was."""
    out = tmp_path / "c"
    args = [*_args(claims_file, "TRUE"), "--out", str(out)]
    assert main([*args, "-q"]) == 0
    path = out / name
    if content is None:  # truncated in the middle
        path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])
    elif isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    before = _snapshot(out)
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("lpbounds verify: error: out: ")
    assert re.search(said, err), err
    assert _snapshot(out) == before


def test_a_missing_manifest_is_refused(whole, claims_file):
    before = {k: v for k, v in _snapshot(whole).items() if k != cp.MANIFEST_FILE}
    (whole / cp.MANIFEST_FILE).unlink()
    conj = cl.load_claim(f"{claims_file}:TRUE")
    with pytest.raises(OutputError, match=r"manifest\.json' cannot be read \(no such file\)"):
        cp.run_campaign(
            6, 3, families=["garnet", "masked-garnet"], claims=[conj], solvers=["HIGHS"],
            batch_size=2, out=whole,
        )  # fmt: skip
    assert _snapshot(whole) == before


def test_a_folder_from_before_the_manifest_is_refused_saying_how_to_proceed(tmp_path):
    """A folder written by lpbounds before the manifest (campaign.json holds the bare
    arguments, no manifest): its batches cannot be checked, so it is refused, never
    trusted; the message says to run the campaign into a new folder."""
    out = tmp_path / "old"
    (out / "batches").mkdir(parents=True)
    old = {
        "n": 6, "seed": 3, "families": ["garnet"], "claims": ["RLP bound >= V*"],
        "solvers": [], "n_costs": 3, "rtol": 1e-6, "exact_method": "pi", "batch_size": 2,
        "format": "csv",
    }  # fmt: skip
    (out / "campaign.json").write_text(json.dumps(old))
    (out / "batches" / "batch-000000.csv").write_text("check\nx\n")
    before = _snapshot(out)
    conj = cl.Conjecture("RLP bound >= V*", _dominates, uses_solver=False)
    with pytest.raises(OutputError, match="written before campaigns kept a manifest") as err:
        cp.run_campaign(6, 3, families=["garnet"], claims=[conj], solvers=[], out=out)
    assert "run the campaign into a new folder" in str(err.value)
    assert _snapshot(out) == before


def test_an_interrupted_initialisation_is_taken_up(tmp_path):
    """Killed after batches/ and the empty manifest but before campaign.json: the folder is
    still taken as new (it holds nothing else), not refused for ever."""
    out = tmp_path / "c"
    (out / "batches").mkdir(parents=True)
    (out / cp.MANIFEST_FILE).write_text('{"campaign_folder": 2, "batches": {}}')
    conj = cl.Conjecture("RLP bound >= V*", _dominates, uses_solver=False)
    res = cp.run_campaign(2, 0, families=["garnet"], claims=[conj], solvers=[], out=out)
    assert len(res.frame) == 2 and (out / cp.CAMPAIGN_FILE).exists()


# ---------------------------------------------------------------------- --scheduler
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.parametrize(
    ("scheduler", "said"),
    [
        ("foo", "is neither one of Dask's local schedulers"),
        ("tcp://", "is neither one of Dask's local schedulers"),
        ("http://127.0.0.1:8786", "unknown scheme 'http'"),
        ("localhost:70000", "port 70000 is not in 1..65535"),
        ("UNREACHABLE", "no Dask scheduler answers at 127.0.0.1:"),
    ],
)
@pytest.mark.parametrize("command", ["verify", "compare"])
def test_a_bad_scheduler_is_refused_before_out_is_touched(
    command, scheduler, said, tmp_path, claims_file, capsys
):
    """``--scheduler foo`` was a traceback ("missing port number") after campaign.json
    was written. Now: one line, exit 2, and neither --out nor its parent touched (no
    folder, no lock file); an unreachable address likewise."""
    if scheduler == "UNREACHABLE":
        scheduler = f"tcp://127.0.0.1:{_free_port()}"
    out = tmp_path / "new"
    if command == "verify":
        args = [*_args(claims_file, "TRUE"), "--out", str(out), "--scheduler", scheduler]
    else:
        args = ["compare", "garnet:10:2:1", "--formulations", "RLP", "--solvers", "HIGHS"]
        args += ["--out", str(out), "--scheduler", scheduler]
    before = sorted(p.name for p in tmp_path.iterdir())
    t0 = time.monotonic()
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and said in err, err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == before
    assert time.monotonic() - t0 < 60  # refused at once, not after a connection timeout


def test_a_bad_scheduler_leaves_an_existing_campaign_as_it_was(whole, claims_file, capsys):
    before = _snapshot(whole)
    args = [*_args(claims_file, "TRUE"), "--out", str(whole), "--scheduler", "foo"]
    assert main(args) == 2
    assert "is neither one of Dask's local schedulers" in capsys.readouterr().err
    assert _snapshot(whole) == before


# ---------------------------------------------------------------------- a changed predicate
def test_an_edited_conjecture_is_refused_then_rerun_with_rerun_changed(
    tmp_path, claims_file, capsys
):
    """The conjecture file edited (same claim name) and the campaign resumed: its old
    verdicts were reported as the new predicate's. Now refused naming the claim, nothing
    changed; with --rerun-changed, the records of that claim are recomputed (the other
    claim's kept) and equal those of a fresh campaign with the edited file."""
    out = tmp_path / "c"
    args = [*_args(claims_file, "TRUE", "FALSE"), "--out", str(out)]
    first = main([*args, "-q"])
    assert first == 1  # FALSE is violated on some instances
    kept = cp.read_records(out)
    before = _snapshot(out)
    # TRUE's predicate now compares the other way round (Phi v* <= V*): false where they differ
    claims_file.write_text(CLAIMS.replace(
        "return trial.at_least(trial.rlp_bound(), trial.vstar())",
        "return trial.at_least(trial.vstar(), trial.rlp_bound())",
    ))  # fmt: skip
    capsys.readouterr()
    assert main([*args, "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "the claim 'RLP bound = V*' changed" in err or "the claim 'RLP bound >= V*'" in err
    assert "SHA-256 of" in err and "--rerun-changed" in err
    assert _snapshot(out) == before
    code = main([*args, "--rerun-changed"])
    err = capsys.readouterr().err
    assert "changed (SHA-256 of" in err and "its records are recomputed" in err
    fresh = tmp_path / "fresh"
    assert main([*_args(claims_file, "TRUE", "FALSE"), "--out", str(fresh), "-q"]) == code
    _same(cp.read_records(fresh), cp.read_records(out))
    after = cp.read_records(out)
    assert not after["verdict"].equals(kept["verdict"])  # the records did change
    # a resume without the flag now goes through: the folder records the new fingerprints
    assert main([*args, "-q"]) == code


def test_rerun_changed_recomputes_only_the_changed_claims(tmp_path):
    """Two conjectures in two files, one file edited: with rerun_changed, only that
    claim's records are recomputed in every batch (merged with the other's, in the order
    of a fresh run), and the records equal those of a fresh campaign."""
    a, b = tmp_path / "a.py", tmp_path / "b.py"
    a.write_text(CLAIMS)
    b.write_text(CLAIMS)
    kw = {"families": ["garnet", "masked-garnet"], "solvers": [], "batch_size": 2}
    kw["shrink"] = False

    def claims():
        return [cl.load_claim(f"{a}:TRUE"), cl.load_claim(f"{b}:FALSE")]

    out = tmp_path / "c"
    first = cp.run_campaign(6, 1, out=out, claims=claims(), **kw)
    a.write_text(CLAIMS.replace(
        "return trial.at_least(trial.rlp_bound(), trial.vstar())",
        "return trial.at_least(trial.vstar(), trial.rlp_bound())",
    ))  # fmt: skip
    with pytest.raises(ValidationError, match=r"the claim 'RLP bound >= V\*' changed"):
        cp.run_campaign(6, 1, out=out, claims=claims(), **kw)
    notes: list[str] = []
    again = cp.run_campaign(6, 1, out=out, claims=claims(), rerun_changed=True,
                            notify=notes.append, **kw)  # fmt: skip
    assert len(notes) == 2 and notes[0].startswith("'RLP bound >= V*' changed (SHA-256 of")
    assert notes[1] == (
        "3 batch files held records of changed claims: moved to rejected/, their records recomputed"
    )
    assert sorted(p.name for p in (out / "rejected").iterdir()) == [
        f"batch-00000{k}.csv" for k in range(3)
    ]  # the old predicate's records, kept
    fresh = cp.run_campaign(6, 1, out=tmp_path / "fresh", claims=claims(), **kw)
    _same(fresh.frame, again.frame)
    _same(cp.read_records(tmp_path / "fresh"), cp.read_records(out))
    other = again.frame["check"] == "RLP bound = V*"
    _same(first.frame[other].reset_index(drop=True), again.frame[other].reset_index(drop=True))
    assert not first.frame[~other]["verdict"].equals(again.frame[~other]["verdict"])
    assert again.batches_run == 3  # each batch redone (for one claim), none kept whole


def test_a_changed_lpbounds_version_is_refused(whole, claims_file, capsys):
    meta = json.loads((whole / cp.CAMPAIGN_FILE).read_text())
    meta["lpbounds"] = "0.0.1"
    (whole / cp.CAMPAIGN_FILE).write_text(json.dumps(meta))
    before = _snapshot(whole)
    assert main([*_args(claims_file, "TRUE"), "--out", str(whole), "-q"]) == 2
    err = capsys.readouterr().err
    assert "lpbounds itself changed since the campaign's records were made (0.0.1 then" in err
    assert _snapshot(whole) == before


# ---------------------------------------------------------------------- counterexamples
def test_a_verdict_edited_to_violated_is_recomputed_and_never_shrunk(
    whole, tmp_path, claims_file, capsys
):
    """A record's verdict edited on disk to "violated": a counterexample file was written
    for a claim that holds everywhere. The edit breaks the batch's hash: it is named,
    moved aside and recomputed, and no counterexample is written."""
    out = tmp_path / "c"
    args = [*_args(claims_file, "TRUE"), "--out", str(out)]
    assert main([*args, "-q"]) == 0
    batch = out / "batches" / "batch-000000.csv"
    batch.write_text(batch.read_text().replace(",holds,", ",violated,", 1))
    capsys.readouterr()
    assert main(args) == 0
    assert "batch-000000.csv does not match the manifest" in capsys.readouterr().err
    assert not (out / "counterexamples").exists()
    _same(cp.read_records(whole), cp.read_records(out))


def test_a_forged_violated_verdict_is_re_tested_and_not_shrunk(whole, tmp_path, claims_file):
    """The verdict edited *and* the manifest's hash forged to match: the batch passes its
    check, so the record says "violated"; the shrinker re-tests its start, which shows
    nothing, and writes nothing (one note says so)."""
    batch = whole / "batches" / "batch-000000.csv"
    batch.write_text(batch.read_text().replace(",holds,", ",violated,", 1))
    manifest = json.loads((whole / cp.MANIFEST_FILE).read_text())
    manifest["batches"]["batch-000000"]["sha256"] = hashlib.sha256(batch.read_bytes()).hexdigest()
    (whole / cp.MANIFEST_FILE).write_text(json.dumps(manifest))
    notes: list[str] = []
    conj = cl.load_claim(f"{claims_file}:TRUE")
    res = cp.run_campaign(
        6, 3, families=["garnet", "masked-garnet"], claims=[conj], solvers=["HIGHS"],
        batch_size=2, out=whole, notify=notes.append,
    )  # fmt: skip
    assert res.verdicts()["violated"] == 1 and res.counterexamples == []
    assert len(notes) == 1 and "not so when checked again on its instance" in notes[0]
    assert not (whole / "counterexamples").exists() or not list(
        (whole / "counterexamples").glob("*.toml")
    )


def test_counterexample_files_are_loaded_back_and_re_checked(tmp_path, claims_file):
    """Every counterexample reported is a file that loads back and still shows its verdict;
    on resume a counterexample file that does not (edited) is moved aside and shrunk again."""
    conj = cl.load_claim(f"{claims_file}:FALSE")
    kw = {"families": ["garnet"], "claims": [conj], "solvers": [], "batch_size": 2}
    out = tmp_path / "c"
    res = cp.run_campaign(4, 0, out=out, shrink_seconds=5, **kw)
    assert res.counterexamples, "FALSE is violated on some of these instances"
    target = _target_of(res.counterexamples[0], conj)
    for cex in res.counterexamples:
        assert cex.path is not None and cex.path.exists()
        assert cp._confirmed(cex, _target_of(cex, conj))
    # an edited model file: its rewards made zero (then Phi v* = V* = 0: not violated)
    path = res.counterexamples[0].path
    text = path.read_text()
    lines = [ln if not ln.startswith("rewards") else _zeroed(ln) for ln in text.splitlines()]
    path.write_text("\n".join(lines) + "\n")
    notes: list[str] = []
    again = cp.run_campaign(4, 0, out=out, shrink_seconds=5, notify=notes.append, **kw)
    assert any("on disk does not show it: moved to counterexamples/rejected/" in n for n in notes)
    assert (out / "counterexamples" / "rejected" / path.name).read_text() != text
    assert len(again.counterexamples) == len(res.counterexamples)
    assert all(cp._confirmed(c, target if c.path == path else _target_of(c, conj))
               for c in again.counterexamples)  # fmt: skip
    assert path.read_text() == text  # shrunk again: the same file as the first run's


def _zeroed(line: str) -> str:
    import re

    return re.sub(r"-?\d+(\.\d+)?(e-?\d+)?", "0.0", line.split("=", 1)[1]).join(
        [line.split("=", 1)[0] + "= ", ""]
    )


def _target_of(cex, conj):
    return cp._Target(conj, cex.claim, cex.solver, cex.verdict, (), 3, 1e-6, 0, "pi")


# ---------------------------------------------------------------------- predicates sandboxed
def test_sys_exit_in_a_predicate_is_an_error_record(tmp_path, claims_file, capsys):
    """A conjecture that calls sys.exit(0): exit 0, nothing written, no records. Now every
    trial is an *error* record, the campaign finishes, and the exit status is 1."""
    out = tmp_path / "c"
    code = main([*_args(claims_file, "EXIT", "TRUE"), "--out", str(out)])
    text = capsys.readouterr()
    assert code == 1
    frame = cp.read_records(out)
    mine = frame[frame["check"] == "calls sys.exit"]
    assert len(mine) == 6 and set(mine["verdict"]) == {"error"}
    assert set(mine["error"]) == {"SystemExit: the predicate called sys.exit(0)"}
    assert set(frame[frame["check"] == "RLP bound >= V*"]["verdict"]) == {"holds"}
    assert "6 errors" in text.out and "6 records are errors" in text.err


@pytest.mark.parametrize("with_out", [False, True])
def test_none_from_a_predicate_is_an_error_record_with_and_without_out(
    with_out, tmp_path, claims_file, capsys
):
    """A conjecture that returns None: exit 2 without --out, exit 0 and "3 inconclusive"
    with it. Now the same outcome both ways: error records, counted apart, exit 1."""
    args = [
        "verify", "--random", "3", "--seed", "3", "--solvers", "HIGHS", "--claims",
        f"{claims_file}:NONE",
    ]  # fmt: skip
    # 3 instances each way: 3 random garnets (no packaged model: --max-states 1), or a
    # campaign of 3 drawn instances
    args += ["--out", str(tmp_path / "c"), *FAMILIES] if with_out else ["--max-states", "1"]
    assert main(args) == 1
    text = capsys.readouterr()
    assert "3 records are errors" in text.err
    assert "0 hold, 0 inconclusive, 0 violated, 3 errors" in text.out
    if with_out:
        frame = cp.read_records(tmp_path / "c")
        assert list(frame["verdict"]) == ["error"] * 3
        assert frame["error"].str.startswith("conjecture 'returns None' returned None").all()


def test_keyboard_interrupt_in_a_predicate_still_stops_the_run(tmp_path):
    """Ctrl-C is not sandboxed: a predicate interrupted stops the campaign (the CLI exits
    130 and keeps the finished batches, as before)."""
    calls = []

    def interrupted(trial):
        calls.append(1)
        if len(calls) > 2:
            raise KeyboardInterrupt
        return True

    conj = cl.Conjecture("stops", interrupted, uses_solver=False)
    out = tmp_path / "c"
    with pytest.raises(KeyboardInterrupt):
        cp.run_campaign(6, 0, families=["garnet"], claims=[conj], solvers=[], out=out,
                        batch_size=2)  # fmt: skip
    assert [p.name for p in (out / "batches").iterdir()] == ["batch-000000.csv"]


# ---------------------------------------------------------------------- the end counts
def test_records_missing_at_the_end_fail_naming_the_batch(tmp_path, monkeypatch, capsys):
    """The final summary counts the records on disk against those due; a batch that lacks
    some (here: a run_batch that loses a record) fails the campaign, exit 1, naming it."""
    real = cp.run_batch

    def lossy(batch):
        records = real(batch)
        return records[:-1] if batch.number == 1 else records

    monkeypatch.setattr(cp, "run_batch", lossy)
    conj = cl.Conjecture("RLP bound >= V*", _dominates, uses_solver=False)
    kw = {"families": ["garnet"], "claims": [conj], "solvers": [], "batch_size": 2}
    res = cp.run_campaign(6, 0, out=tmp_path / "c", **kw)
    assert res.missing == {"batch-000001": 1} and res.due == 6 and len(res.frame) == 5
    assert res.exit_status() == 1
    meta = json.loads((tmp_path / "c" / "metadata.json").read_text())
    assert meta["missing"] == {"batch-000001": 1} and meta["due"] == 6
    # the command line names it; run again (records now complete), the batch is recomputed
    path = tmp_path / "claims.py"
    path.write_text(CLAIMS)
    out = tmp_path / "cli"
    args = ["verify", "--random", "6", "--seed", "0", "--families", "garnet", "--batch-size",
            "2", "--solvers", "HIGHS", "--claims", f"{path}:TRUE", "--out", str(out)]  # fmt: skip
    assert main(args) == 1
    text = capsys.readouterr()
    assert "5 records on disk, 1 of 6 due missing" in text.out
    assert "records due are missing from 1 batch: batch-000001 (1)" in text.err
    monkeypatch.setattr(cp, "run_batch", real)
    assert main(args) == 0
    assert "batch-000001.csv lacks the records of 1" in capsys.readouterr().err


def test_every_builtin_claim_and_solver_has_its_records(tmp_path):
    """Due: every instance x claim x solver (and "exact" for the solver-free checks, Remark
    2 once per solver); the built-in claims' records cover them."""
    res = cp.run_campaign(
        1, 7, families=["garnet"], solvers=["HIGHS", "CLARABEL"], n_costs=1, out=tmp_path / "c"
    )
    # Lemma 1, Theorem 1, Theorem 2: 2 solvers + exact; Lemma 2: 2 solvers; Remark 2: 2
    assert res.missing == {} and res.due == (3 + 3 + 2 + 3) + 2


def test_lemma2_has_its_records_when_rlp_returns_no_point(monkeypatch):
    """Lemma 2 takes the duals of the first RLP solve; when it returns no point, its two
    records are still there (*inconclusive*, saying why), so no record due is missing."""
    from lpbounds.formulations import RLP
    from lpbounds.studies import verify as vf

    real = vf.try_solve
    monkeypatch.setattr(
        vf, "try_solve", lambda f, s: (None, "forced") if isinstance(f, RLP) else real(f, s)
    )
    inst = cp.campaign_instance("garnet", 5)
    recs = vf.verify_instance(inst, ["HIGHS"], n_costs=1, checks=["Lemma 2"])
    assert [(r["claim"], str(r["verdict"])) for r in recs] == [
        ("SLP(mu-bar) = v*", "inconclusive"),
        ("reduced MDP value = v*", "inconclusive"),
    ]
    assert "no RLP point" in recs[0]["detail"]


# ---------------------------------------------------------------------- SIGKILL, resumed
def _cli(*args: str) -> list[str]:
    code = "import sys; sys.argv[0] = 'lpbounds'; from lpbounds.cli.main import entry; entry()"
    return [sys.executable, "-c", code, *args]


def _killed_and_resumed(tmp_path: Path, claims_file: Path, kills: int, seed: int) -> None:
    """SIGKILL at ``kills`` random points of one campaign, each followed by the same
    command; the last resume runs to its end. A point is a random stage among those left
    (start-up, the batches, the shrinking) and a random moment in it. The records, the
    summary and the counterexamples then equal those of an uninterrupted run."""
    args = _args(claims_file, "SLOW", "FALSE", n=10, batch=2)
    whole = tmp_path / "whole"
    t0 = time.monotonic()
    done = subprocess.run(_cli(*args, "--out", str(whole), "-q"), capture_output=True, text=True)
    assert done.returncode == 1, done.stderr  # FALSE is violated: counterexamples shrunk
    span = time.monotonic() - t0
    cexs = _cex_files(whole)
    out = tmp_path / "cut"
    rng = np.random.default_rng(seed)
    stages = []
    while len(stages) < kills:
        # -1: start-up; 0: after a batch of this run, inside the next; 1: as a
        # counterexample of this run is written (the shrinking, then the final files)
        batches0, cexs0 = _batches_done(out), _cex_files(out)
        possible = [-1, *([0] if batches0 < 5 else []), *([1] if cexs0 < cexs else [])]
        stage = 0 if 0 in possible and rng.random() < 0.5 else int(rng.choice(possible))
        proc = subprocess.Popen(_cli(*args, "--out", str(out), "-q"), stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + float(rng.uniform(0.05, 0.6)) * span
        while proc.poll() is None:
            if (stage < 0 and time.monotonic() > deadline) or (
                stage == 0 and _batches_done(out) > batches0
            ):
                time.sleep(float(rng.uniform(0.0, 0.4)))
                break
            if stage == 1 and _cex_files(out) > cexs0:
                break
            time.sleep(0.005)
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
            stages.append(stage)
        proc.wait()
    last = subprocess.run(_cli(*args, "--out", str(out), "-q"), capture_output=True, text=True)
    assert last.returncode == 1, last.stderr
    _same(cp.read_records(whole), cp.read_records(out))
    _same(_read(whole / "records.csv"), _read(out / "records.csv"))
    pd.testing.assert_frame_equal(_read(whole / "summary.csv"), _read(out / "summary.csv"))
    a, b = _read(whole / "counterexamples.csv"), _read(out / "counterexamples.csv")
    pd.testing.assert_frame_equal(a.drop(columns=["path"]), b.drop(columns=["path"]))
    for name in a["path"]:
        here = out / "counterexamples" / Path(name).name
        assert here.read_text() == Path(name).read_text()  # the same model file
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["missing"] == {} and meta["records"] == meta["due"] == 20
    print(f"killed at stages {stages} (-1: start-up, 0: batches, 1: shrinking)")


def _cex_files(out: Path) -> int:
    return len(list((out / "counterexamples").glob("*.toml")))


def _batches_done(out: Path) -> int:
    try:
        return len(json.loads((out / cp.MANIFEST_FILE).read_text())["batches"])
    except (OSError, ValueError, KeyError):
        return 0


def _read(path: Path) -> pd.DataFrame:
    return cp._read_frame(path) if path.name == "records.csv" else pd.read_csv(path)


def test_sigkill_at_3_random_points_then_resume_gives_the_uninterrupted_records(
    tmp_path, claims_file
):
    _killed_and_resumed(tmp_path, claims_file, kills=3, seed=36)


@pytest.mark.slow
def test_sigkill_at_10_random_points_then_resume_gives_the_uninterrupted_records(
    tmp_path, claims_file
):
    _killed_and_resumed(tmp_path, claims_file, kills=10, seed=3636)


def _dominates(trial):
    return trial.at_least(trial.rlp_bound(), trial.vstar())


def test_a_conjectures_fingerprint_is_its_files_hash(claims_file):
    conj = cl.load_claim(f"{claims_file}:TRUE")
    fp = cl.claim_fingerprint(conj)
    assert fp["sha256"] == hashlib.sha256(claims_file.read_bytes()).hexdigest()
    assert fp["source"] == str(claims_file) and fp["uses_solver"] is False
    assert cl.claim_fingerprint(cl.resolve_claims(["lemma1"])[0]) == {"kind": "built in"}
    with pytest.raises(ValidationError):
        cl.load_claim(f"{claims_file}:NOPE")
