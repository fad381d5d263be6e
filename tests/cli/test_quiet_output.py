"""No third-party banner or log line on stdout or stderr unless ``--verbose``.

HiGHS prints "Running HiGHS ... Copyright ..." once per process, at the first
``highspy.Highs()``, whatever its options say (lpbounds.formulations.highs). Each command therefore
runs in a fresh process here, on the small models, as a user would run it; compare runs
with two worker processes so the workers' output is covered too. ``--verbose`` shows
the banner again, which proves the patterns below would see it.
"""

from __future__ import annotations

import logging
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from .test_cli import TINY_TOML

ROOT = Path(__file__).resolve().parents[2]
SMALL = str(ROOT / "models" / "patrol-small.toml")

#: Lines solvers print on their own: HiGHS' banner and log, Clarabel's and SCS's headers,
#: OSQP's, cvxpy's verbose frame.
BANNER = re.compile(
    r"Running HiGHS|HiGHS \d|Copyright|THIRD_PARTY_NOTICES|Clarabel\.rs|Clever Acronym|"
    r"SCS v\d|OSQP v\d|CVXPY\s+v\d|\(c\) Paul Goulart|Coefficient ranges",
)


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "100"}
    proc = subprocess.run(
        [sys.executable, "-m", "lpbounds.cli.main", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    return proc


def _commands(tmp: Path) -> dict[str, list[str]]:
    tiny = tmp / "tiny.toml"
    tiny.write_text(TINY_TOML)
    return {
        "solve": ["solve", SMALL, "--out", str(tmp / "solve")],
        "bounds": ["bounds", SMALL, "--lp"],
        "verify": ["verify", str(tiny), "--random", "0", "--costs", "1", "--solvers", "HIGHS"],
        "reproduce": [
            "reproduce",
            SMALL,
            "--out",
            str(tmp / "rep"),
            "--seeds",
            "1",
            "--steps",
            "200",
            "--no-figures",
        ],
        "compare": [
            "compare",
            str(tiny),
            "--formulations",
            "ELP",
            "RLP",
            "--solvers",
            "HIGHS:ipm",
            "CLARABEL",
            "--jobs",
            "2",
            "--out",
            str(tmp / "cmp"),
        ],
    }


def _assert_clean(proc: subprocess.CompletedProcess[str], what: str) -> None:
    for stream, text in (("stdout", proc.stdout), ("stderr", proc.stderr)):
        bad = [ln for ln in text.splitlines() if BANNER.search(ln)]
        assert not bad, f"{what}: third-party output on {stream}: {bad[:3]}"


@pytest.mark.parametrize("name", ["solve", "bounds", "verify", "reproduce", "compare"])
def test_every_subcommand_prints_no_solver_banner(name, tmp_path):
    proc = _run(_commands(tmp_path)[name], tmp_path)
    _assert_clean(proc, f"lpbounds {name}")
    assert proc.stdout.strip(), "the command printed its results"


def test_verbose_shows_what_the_default_hides(tmp_path):
    """The control: with --verbose the solver's banner is there, so the check can fail."""
    proc = _run(["bounds", SMALL, "--lp", "--verbose"], tmp_path)
    assert BANNER.search(proc.stdout + proc.stderr)


def test_quiet_prints_nothing_on_success(tmp_path):
    proc = _run(["bounds", SMALL, "--lp", "--quiet"], tmp_path)
    assert proc.stdout == "" and proc.stderr == ""


def test_an_example_script_prints_no_solver_banner(tmp_path):
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "patrol_bounds.py"), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    _assert_clean(proc, "examples/patrol_bounds.py")
    first = proc.stdout.splitlines()[0]
    assert first.startswith("patrol-small:"), first


def test_the_library_configures_no_logging():
    """Importing and solving adds no handler to the root logger; the lpbounds logger holds
    only a NullHandler until the command line configures it."""
    code = (
        "import logging, lpbounds as lb\n"
        "from lpbounds.formulations import RLP\n"
        "m = lb.garnet(12, 2, 3, 0.9, seed=1)\n"
        "RLP(m, lb.random_partition(12, 3, seed=1)).solve('HIGHS')\n"
        "log = logging.getLogger('lpbounds')\n"
        "print(len(logging.getLogger().handlers), log.level,"
        " [type(h).__name__ for h in log.handlers])\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert proc.returncode == 0, proc.stderr
    assert not BANNER.search(proc.stdout + proc.stderr)
    assert proc.stdout.split("\n")[-2] == f"0 {logging.NOTSET} ['NullHandler']"


def test_a_users_own_cvxpy_solve_and_the_nlp_milp_print_no_banner():
    """The models lpbounds builds are cvxpy problems users solve themselves; the banner
    is taken when lpbounds builds its first model (a Formulation or an NLP), so those
    solves are quiet too."""
    code = (
        "import lpbounds as lb\n"
        "from lpbounds.formulations import NLP, RLP\n"
        "m, p = lb.garnet(12, 2, 3, 0.9, seed=1), lb.random_partition(12, 3, seed=1)\n"
        "lp = RLP(m, p)\n"
        "print(round(lp.problem.solve(solver='HIGHS'), 6))\n"
        "print(NLP(m, p).solve('milp').status)\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert proc.returncode == 0, proc.stderr
    assert not BANNER.search(proc.stdout + proc.stderr), proc.stdout
    assert len(proc.stdout.splitlines()) == 2
