"""The one HiGHS layer (lpbounds.formulations.highs): nothing at import, quiet solves, and
one status mapping that covers every HiGHS model status."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from lpbounds.formulations.highs import STATUS_MAP, status_of
from lpbounds.status import Status

ROOT = Path(__file__).resolve().parents[2]


def _python(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT
    )


def test_importing_the_formulations_constructs_no_highs_and_leaves_fd1_alone():
    """``import lpbounds.formulations`` constructs no ``highspy.Highs``, duplicates no file
    descriptor and prints nothing; the banner flag stays unset until a model is built."""
    code = (
        "import os, highspy\n"
        "made, dups = [], []\n"
        "real_highs, real_dup2 = highspy.Highs, os.dup2\n"
        "def counting_highs(*a, **k):\n"
        "    made.append(1)\n"
        "    return real_highs(*a, **k)\n"
        "def counting_dup2(*a, **k):\n"
        "    dups.append(a)\n"
        "    return real_dup2(*a, **k)\n"
        "highspy.Highs, os.dup2 = counting_highs, counting_dup2\n"
        "import lpbounds.formulations\n"
        "from lpbounds.formulations import highs\n"
        "print('highs', len(made), 'dup2', len(dups), 'silenced', highs.highs_banner_silenced())\n"
        "import lpbounds as lb\n"
        "m = lb.garnet(6, 2, 2, 0.9, seed=0)\n"
        "lpbounds.formulations.RLP(m, lb.random_partition(6, 2, seed=0))\n"
        "print('after a model', highs.highs_banner_silenced(), len(made) >= 1)\n"
    )
    proc = _python(code)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines == ["highs 0 dup2 0 silenced False", "after a model True True"], proc.stdout


def test_building_and_solving_an_rlp_with_highs_prints_nothing():
    code = (
        "import lpbounds as lb\n"
        "from lpbounds.formulations import RLP\n"
        "m = lb.garnet(12, 2, 3, 0.9, seed=1)\n"
        "p = lb.random_partition(12, 3, seed=1)\n"
        "r = RLP(m, p).solve('HIGHS')\n"
        "r2 = RLP(m, p).solve('HIGHS', backend='highspy')\n"
        "assert r.status.value == 'optimal' and r2.status.value == 'optimal'\n"
    )
    proc = _python(code)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "", proc.stdout


def test_the_status_map_covers_every_highs_model_status():
    highspy = pytest.importorskip("highspy")
    names = list(highspy.HighsModelStatus.__members__)
    assert names, "highspy has no model statuses?"
    missing = [n for n in names if n not in STATUS_MAP]
    assert missing == []
    for n in names:
        assert isinstance(status_of(n), Status)
    assert status_of("kOptimal") is Status.OPTIMAL
    assert status_of("kTimeLimit") is Status.TIME_LIMIT
    assert status_of("kInfeasible") is Status.INFEASIBLE
    assert status_of("a name a later highspy adds") is Status.SOLVER_ERROR
    # only an optimum maps to OPTIMAL (the NLP's cut loop relies on it)
    assert [n for n, s in STATUS_MAP.items() if s is Status.OPTIMAL] == ["kOptimal"]
