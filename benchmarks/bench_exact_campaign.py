"""Exact verdicts on a campaign: ``lpbounds verify --arithmetic rational`` of ``--n``
random instances, and every certificate it wrote checked by the standalone checker.

Runs the command line as a user does (a child process, under ``nice``), measuring its wall
time and peak resident set, the machine's load average before and after; then runs
``python -I -S src/lpbounds/exact/check.py`` (standard library only) on every certificate
of the folder; then reads the records back and counts: records, the exact verdicts, the
float verdicts the exact ones overturned or decided, certified brackets that missed, the
largest instance (states x actions) and the slowest claim (its exact seconds).

Writes ``benchmarks/results/exact_campaign.json`` and the ``exact-campaign`` section of
``docs/benchmarks.md``. The numbers of that section other than times are asserted against
the folder by this script before it writes them (it stops on any disagreement).

Usage::

    python benchmarks/bench_exact_campaign.py [--n 200] [--seed 7] [--out out/exact-campaign]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

from _common import machine, today, write_section

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
CHECKER = ROOT / "src" / "lpbounds" / "exact" / "check.py"


def run_campaign(n: int, seed: int, out: Path) -> dict:
    """The command line, timed; its exit status, wall seconds, peak RSS and loads."""
    shutil.rmtree(out, ignore_errors=True)
    command = [
        "lpbounds", "verify", "--arithmetic", "rational", "--random", str(n), "--seed",
        str(seed), "--out", str(out), "--certificates", "-q",
    ]  # fmt: skip
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    proc = subprocess.run(["nice", "-n", "10", *command], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    if proc.returncode not in (0, 1):
        raise RuntimeError(f"the campaign failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    return {
        "command": " ".join(command),
        "exit_status": proc.returncode,
        "seconds": seconds,
        "peak_rss_mb": peak,
        "load_before": load_before,
        "load_after": os.getloadavg(),
    }


def check_certificates(folder: Path) -> dict:
    """Every certificate through the standalone checker (in one child: it takes many)."""
    files = sorted(folder.glob("*.json"))
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-I", "-S", str(CHECKER), *map(str, files)],
        capture_output=True, text=True, cwd="/",
    )  # fmt: skip
    lines = proc.stdout.strip().splitlines()
    ok = sum(": OK: " in line for line in lines)
    return {
        "files": len(files),
        "accepted": ok,
        "exit_status": proc.returncode,
        "seconds": time.perf_counter() - t0,
        "checker_lines": len(CHECKER.read_text().splitlines()),
    }


def count(out: Path) -> dict:
    """What the records say (read back as the package reads a campaign folder)."""
    from lpbounds.studies.campaign import read_records

    frame = read_records(out)
    verdicts = frame["verdict"].astype(str).value_counts().to_dict()
    fv = frame["float_verdict"].astype(str)
    decided = fv.isin(["holds", "violated"])
    disagree = int((decided & (fv != frame["verdict"].astype(str))).sum())
    missed = int((frame["inside_bracket"].astype(str) == "False").sum())
    inst = frame[frame["campaign_index"] >= 0].drop_duplicates("instance")
    big = inst.assign(pairs=inst["n_states"] * inst["n_actions"]).sort_values(
        ["n_states", "n_actions"], ascending=False
    )
    top = big.iloc[0]
    exact = frame.dropna(subset=["exact_seconds"]).drop_duplicates(["instance", "check"])
    slow = exact.sort_values("exact_seconds", ascending=False).iloc[0]
    slow_inst = frame[frame["instance"] == slow["instance"]].iloc[0]
    return {
        "records": len(frame),
        "instances": int(inst["instance"].nunique()),
        "holds": int(verdicts.get("holds", 0)),
        "violated": int(verdicts.get("violated", 0)),
        "inconclusive": int(verdicts.get("inconclusive", 0)),
        "errors": int(verdicts.get("error", 0)),
        "float_inconclusive": int((fv == "inconclusive").sum()),
        "float_decided": int(decided.sum()),
        "disagree": disagree,
        "missed": missed,
        "largest": {
            "instance": str(top["instance"]),
            "states": int(top["n_states"]),
            "actions": int(top["n_actions"]),
        },
        "slowest": {
            "check": str(slow["check"]),
            "instance": str(slow["instance"]),
            "seconds": float(slow["exact_seconds"]),
            "states": int(slow_inst["n_states"]),
            "actions": int(slow_inst["n_actions"]),
        },
    }


def section(run: dict, checked: dict, c: dict, n: int, seed: int) -> str:
    lb, la = run["load_before"], run["load_after"]
    m, s = divmod(run["seconds"], 60)
    command = re.sub(r"--out \S+", "--out OUT", run["command"]).replace(" -q", "")
    return f"""## Exact verdicts: a {n}-instance campaign

`benchmarks/bench_exact_campaign.py`, {today()}; {machine()}.

    {command}
    python -I -S src/lpbounds/exact/check.py OUT/certificates/*

Load average {lb[0]:.1f} before, {la[0]:.1f} after (the machine is shared; the campaign ran
under `nice -n 10`, one process). Wall time **{int(m)} min {s:.0f} s**, peak resident set
{run["peak_rss_mb"]:.0f} MB, exit status {run["exit_status"]}.

{_table(checked, c)}
"""


def _actions(n: int) -> str:
    return f"{n} action{'s' if n != 1 else ''}"


def _table(checked: dict, c: dict) -> str:
    """The section's table of counts (two columns)."""
    big, slow = c["largest"], c["slowest"]
    rows = [
        ("instances", f"{c['instances']:,} (and Remark 2's soft-aggregation ALP)"),
        ("records", f"{c['records']:,}"),
        (
            "exact verdicts: holds / violated / inconclusive / errors",
            f"{c['holds']:,} / {c['violated']} / {c['inconclusive']} / {c['errors']}",
        ),
        (
            "float verdicts decided (holds or violated)",
            f"{c['float_decided']:,}, every one the exact verdict ({c['disagree']} disagreements)",
        ),
        ("float verdicts inconclusive, decided exactly", f"{c['float_inconclusive']:,}"),
        ("certified brackets that missed their exact optimum", f"{c['missed']}"),
        (
            "certificates",
            f"{checked['files']:,}, all {checked['accepted']:,} accepted by the checker "
            f"({checked['checker_lines']} lines, standard library only) in "
            f"{checked['seconds']:.0f} s",
        ),
        (
            "largest instance",
            f"{big['instance']}: {big['states']} states x {_actions(big['actions'])}",
        ),
        (
            "slowest claim",
            f"{slow['check']} on {slow['instance']} ({slow['states']} states x "
            f"{_actions(slow['actions'])}): {slow['seconds']:.1f} s of exact work",
        ),
    ]
    return "\n".join(["| | |", "|---|---|", *(f"| {a} | {b} |" for a, b in rows)])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", default=str(ROOT / "out" / "exact-campaign"))
    args = ap.parse_args()
    out = Path(args.out)
    run = run_campaign(args.n, args.seed, out)
    print(f"campaign: {run['seconds']:.0f} s, exit {run['exit_status']}", flush=True)
    checked = check_certificates(out / "certificates")
    c = count(out)
    # what the section states, checked against the folder before it is written
    assert checked["exit_status"] == 0 and checked["accepted"] == checked["files"] > 0
    assert c["inconclusive"] == 0 and c["errors"] == 0
    assert c["holds"] + c["violated"] == c["records"]
    RESULTS.mkdir(parents=True, exist_ok=True)
    data = {"n": args.n, "seed": args.seed, "run": run, "checked": checked, "counts": c}
    (RESULTS / "exact_campaign.json").write_text(json.dumps(data, indent=2) + "\n")
    write_section("exact-campaign", section(run, checked, c, args.n, args.seed))
    print(json.dumps(c, indent=2))


if __name__ == "__main__":
    main()
