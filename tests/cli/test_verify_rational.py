"""``lpbounds verify --arithmetic rational``: a small campaign decided exactly, its folder
(the arithmetic recorded, resuming in the other one refused, a tampered certificate caught
by the manifest), the size limit refused up front, and the summary's width of exact records.

Every certificate is checked by the checker run as a separate, standard-library-only
Python (``python -I -S src/lpbounds/exact/check.py``), not by lpbounds' own call of it.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import re
import shutil
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import pandas as pd
import pytest

from lpbounds.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
CHECKER = ROOT / "src" / "lpbounds" / "exact" / "check.py"
CAMPAIGN = ["verify", "--arithmetic", "rational", "--random", "3", "--seed", "7"]


def run_checker(*paths: Path) -> subprocess.CompletedProcess[str]:
    """The checker as a plain script in an isolated Python without site-packages."""
    return subprocess.run(
        [sys.executable, "-I", "-S", str(CHECKER), *map(str, paths)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd="/",
    )


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, int]:
    """``verify --arithmetic rational --random 3 --seed 7 --out DIR --certificates``: the
    folder, what it printed and its exit status."""
    out = tmp_path_factory.mktemp("rational") / "c"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main([*CAMPAIGN, "--out", str(out), "--certificates"])
    return out, buf.getvalue(), code


def _records(out: Path) -> pd.DataFrame:
    return pd.read_csv(out / "records.csv", keep_default_na=False)


def test_a_rational_campaign_decides_every_record_and_agrees_with_float(campaign):
    out, _, code = campaign
    assert code == 0
    frame = _records(out)
    assert len(frame) > 0
    # decided exactly: holds or violated only, and (the paper's results) all hold
    assert set(frame["verdict"]) == {"holds"}
    # every record whose float verdict was decided agrees with its exact verdict
    decided = frame[frame["float_verdict"].isin(["holds", "violated"])]
    assert len(decided) > 0.9 * len(frame)
    assert (decided["float_verdict"] == decided["verdict"]).all()
    # every judged solve's certified bracket held its exact optimum
    judged = frame[frame["inside_bracket"] != ""]
    assert len(judged) > 0 and set(judged["inside_bracket"].astype(str)) == {"True"}
    # each exact difference is an exact rational, its float its nearest double
    for text, near in zip(frame["exact_difference"], frame["exact_difference_float"], strict=True):
        p, _, q = str(text).partition("/")
        assert float(Fraction(int(p), int(q or 1))) == float(near)
    params = json.loads((out / "campaign.json").read_text())["arguments"]
    assert params["arithmetic"] == "rational" and params["certificates"] is True


def test_every_certificate_of_the_campaign_is_accepted_by_the_standalone_checker(campaign):
    out, _, _ = campaign
    frame = _records(out)
    named = {str(t) for t in frame["certificate"] if str(t)}
    files = sorted((out / "certificates").iterdir())
    assert {p.name for p in files} == named
    # 3 instances x 4 instance claims + Remark 2
    assert len(files) == 3 * 4 + 1
    done = run_checker(*files)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.strip().splitlines()
    assert len(lines) == len(files) and all(": OK: " in line for line in lines)
    # the manifest lists every certificate with its SHA-256
    manifest = json.loads((out / "manifest.json").read_text())
    listed = {}
    for entry in manifest["batches"].values():
        listed.update(entry.get("certificates", {}))
    assert listed == {p.name: sha256(p) for p in files}


def test_resuming_in_the_other_arithmetic_is_refused(campaign, tmp_path, capsys):
    out = tmp_path / "c"
    shutil.copytree(campaign[0], out)
    before = {p: sha256(p) for p in out.rglob("*") if p.is_file()}
    code = main(["verify", "--random", "3", "--seed", "7", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert "arithmetic = 'rational', now 'float'" in err and len(err.strip().splitlines()) == 1
    assert {p: sha256(p) for p in out.rglob("*") if p.is_file()} == before  # nothing changed


def test_a_tampered_certificate_is_caught_on_resume_and_made_again(campaign, tmp_path, capsys):
    out = tmp_path / "c"
    shutil.copytree(campaign[0], out)
    target = sorted((out / "certificates").glob("*Theorem_1.json"))[0]
    original = target.read_bytes()
    cert = json.loads(original)
    x = cert["lps"][0]["x"]
    x["num"][0] = str(int(x["num"][0]) + 1)  # one number changed
    target.write_text(json.dumps(cert))
    assert run_checker(target).returncode == 1  # the checker alone catches it too
    code = main([*CAMPAIGN, "--out", str(out), "--certificates"])
    err = capsys.readouterr().err
    assert code == 0
    assert f"certificates/{target.name} moved to rejected/{target.name}" in err
    assert "does not match the manifest (its SHA-256 differs)" in err and "recomputed" in err
    assert (out / "rejected" / target.name).read_text() == json.dumps(cert)
    # written again, the same bytes as the first run's
    assert target.read_bytes() == original
    assert run_checker(target).returncode == 0


GARNET = """[model]
kind = "garnet"
n_states = 9
n_actions = 2
branching = 3
discount = 0.9
seed = 4

[partition]
kind = "random"
n_partitions = 3
seed = 1
"""


def test_exact_size_limit_refuses_up_front_in_one_line(tmp_path, capsys):
    model = tmp_path / "g9.toml"
    model.write_text(GARNET)
    args = ["verify", str(model), "--random", "0", "--arithmetic", "rational"]
    args += ["--solvers", "HIGHS"]
    written = tmp_path / "records.json"
    code = main([*args, "--exact-size-limit", "2", "--json", str(written)])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and not written.exists()  # nothing printed or written
    lines = err.strip().splitlines()
    assert len(lines) == 1
    m = re.search(
        r"solves (\d+) variables together, above the limit of 2 .*--exact-size-limit (\d+) "
        r"lifts it",
        lines[0],
    )
    assert m is not None, lines[0]
    size = int(m.group(1))
    assert m.group(2) == str(size) and 2 < size <= 9
    # the limit it names lifts it, and one less is refused again, naming the same size
    assert main([*args, "--exact-size-limit", str(size), "--json", str(written), "-q"]) == 0
    assert written.exists()
    capsys.readouterr()
    assert main([*args, "--exact-size-limit", str(size - 1)]) == 2
    assert f"solves {size} variables together" in capsys.readouterr().err


def test_exact_records_show_width_zero_in_the_summary(campaign):
    out, text, _ = campaign
    summary = pd.read_csv(out / "summary.csv")
    exact = summary[summary["solver"] == "exact"]
    assert len(exact) == 3 and (exact["width"] == 0).all()  # Lemma 1, Theorem 1, Theorem 2
    frame = _records(out)
    assert (frame.loc[frame["solver"] == "exact", "width"].astype(float) == 0).all()
    # a solver's records keep its certified bracket's width (what it is judged on)
    assert (frame.loc[frame["solver"] == "HIGHS", "width"].astype(float) > 0).any()
    lines = text.splitlines()
    rows = [ln.split() for ln in lines if re.match(r"^(Lemma|Theorem) \d\s+exact\s", ln)]
    assert len(rows) == 3
    for cells in rows:
        assert cells[7] == "0", cells  # check (2 words), solver, 3 counts, worst, width
