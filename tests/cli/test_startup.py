"""Start-up: ``import lpbounds``, ``lpbounds [SUBCOMMAND] --help`` and the commands whose
work needs no LP (``solve`` by exact DP, ``models``) load none of the heavy dependencies,
the lazy public names behave like eager ones, and no solve, small or large, needs a JIT
compiler: the kernels are C, built at install (numba is no dependency).

Each check runs in a fresh interpreter: what a module imports is only visible there.
Timings are measured by ``benchmarks/bench_startup.py``, never asserted here.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import lpbounds
from lpbounds.cli.main import COMMANDS

ROOT = Path(__file__).resolve().parents[2]

#: Packages a command loads only when its work needs them: the LP stack (cvxpy and the
#: scipy.stats it imports, the solvers), the figures, the tables of studies, the optional
#: Gymnasium and Dask, and numba (no dependency any more, but still installed beside
#: lpbounds by QuantEcon: it must not come back through an import).
HEAVY = (
    "cvxpy", "matplotlib", "pandas", "gymnasium", "numba", "dask", "scipy.stats", "highspy",
    "clarabel",
)  # fmt: skip
#: The heavy dependencies, the patrol package and the DP core, none needed to print help.
NOT_FOR_HELP = (*HEAVY, "lpbounds.patrol", "lpbounds.dp", "lpbounds.studies.compare", "numpy")


def imported_by(code: str, modules: tuple[str, ...] = HEAVY) -> list[str]:
    """Which of ``modules`` a fresh interpreter has loaded after running ``code``."""
    probe = (
        f"{code}\nimport sys, json\n"
        f"print(json.dumps(sorted(m for m in {modules!r} if m in sys.modules)))"
    )
    proc = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_import_lpbounds_loads_no_heavy_dependency():
    assert imported_by("import lpbounds") == []


def test_the_probe_sees_a_heavy_import():
    # the checks here can fail: the same probe reports cvxpy (and the scipy.stats it
    # imports) once a formulation loads, and nothing for the formulations' table of contents
    assert imported_by("import lpbounds.formulations") == []
    assert "cvxpy" in imported_by("from lpbounds.formulations import RLP")
    assert "scipy.stats" in imported_by("from lpbounds.formulations import RLP")


def _command(argv: list[str]) -> str:
    """Code that runs ``lpbounds ARGV`` in this process (help's SystemExit is its end)."""
    return (
        f"import sys\nsys.argv = {['lpbounds', *argv]!r}\nfrom lpbounds.cli.main import main\n"
        "try:\n    code = main()\nexcept SystemExit as exc:\n    code = exc.code\n"
        "assert code == 0, code\n"
    )


@pytest.mark.parametrize(
    "argv",
    [
        ["solve", "forest"],  # a shelf model, exact DP
        ["solve", "models/garnet-small.toml"],  # an instance file, exact DP
        ["models"],  # the listing: sizes from parameters, Gymnasium only looked for
    ],
    ids=lambda a: " ".join(a),
)
def test_a_command_loads_only_what_its_work_needs(argv, monkeypatch):
    """Exact DP needs no LP stack, no figures, no tables of studies; the model listing
    needs none of them either, nor Gymnasium (``importlib.util.find_spec`` tells whether
    it is installed)."""
    monkeypatch.chdir(ROOT)
    assert imported_by(_command(argv)) == []


@pytest.mark.parametrize("command", ["", *COMMANDS])
def test_help_loads_no_heavy_dependency(command):
    argv = [*([command] if command else []), "--help"]
    assert imported_by(_command(argv), NOT_FOR_HELP) == []


def test_a_small_first_solve_needs_no_jit():
    code = """
import lpbounds as lb
mdp = lb.garnet(300, 3, 4, 0.9, seed=7)
dp = lb.solve_exact(mdp)
rows = lb.BellmanRows.aggregate(mdp, lb.random_partition(300, 30, seed=11))
cert = lb.certify(rows, lb.solve_exact(rows).values)
assert dp.error_bound < 1e-7 and cert.error_bound < 1e-6
"""
    assert imported_by(code, ("numba", "llvmlite")) == []


def test_a_large_solve_and_aggregation_need_no_numba():
    """A random MDP whose sweeps split over the threads runs on the C kernels (the row
    sweeps, and the aggregation, Q-values and game operator of its RLP and NLP rows): its
    process imports no numba (0.5 s of start-up and first call, docs/benchmarks.md)."""
    code = """
import lpbounds as lb
from lpbounds._kernels import ckernels
mdp = lb.garnet(20_000, 3, 5, 0.9, seed=7)  # 300,000 reads per sweep
assert mdp.n_states * 15 >= ckernels.PARALLEL_READS
dp = lb.solve_exact(mdp)
ev = lb.evaluate_policy(mdp, dp.policy, method="iterative")
assert dp.error_bound < 1e-9 and ev.error_bound < 1e-9
part = lb.random_partition(20_000, 2_000, seed=1)
low = lb.BellmanRows.aggregate(mdp, part, reduce="min")
low.apply_maxmin(low.q_values(dp.values[:2_000])[:2_000] * 0)
"""
    kernels = ("numba", "lpbounds._kernels.native", "lpbounds._kernels.ckernels")
    want = ["lpbounds._kernels.ckernels", "lpbounds._kernels.native"]
    assert imported_by(code, kernels) == want


@pytest.mark.parametrize("name", lpbounds.__all__)
def test_every_public_name_resolves_as_before(name):
    value = getattr(lpbounds, name)
    module = lpbounds._LAZY.get(name)
    if module is not None:  # the object the defining module exports, not a copy
        assert value is getattr(importlib.import_module(f"lpbounds.{module}"), name)
    namespace: dict[str, object] = {}
    exec(f"from lpbounds import {name}", namespace)
    assert namespace[name] is value
    assert name in dir(lpbounds)


def test_lazy_names_are_exactly_the_public_ones():
    eager = {"ConvergenceError", "LPBoundsError", "SolverError", "SolverNotInstalledError"}
    eager |= {"ValidationError", "Status", "Verdict", "__version__"}
    assert set(lpbounds._LAZY) | eager == set(lpbounds.__all__)


def test_unknown_attribute_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'solve_exactly'"):
        lpbounds.solve_exactly  # noqa: B018
    assert not hasattr(lpbounds, "numpy")


def test_submodules_are_reachable_as_attributes():
    code = "import lpbounds\nassert lpbounds.rows.BellmanRows is lpbounds.BellmanRows"
    assert imported_by(code) == []


def test_an_empty_numba_cache_stays_empty(tmp_path):
    """In a fresh environment nothing compiles: a large RLP aggregation, its fixed point and
    a post-decision solve write nothing into numba's (empty) cache and announce nothing."""
    code = """
import lpbounds as lb
mdp = lb.garnet(50_000, 3, 5, 0.9, seed=3, shared_probabilities=True)
rows = lb.BellmanRows.aggregate(mdp, lb.random_partition(50_000, 500, seed=4))
assert lb.solve_exact(rows).error_bound < 1e-6
import numpy as np
rng = np.random.default_rng(5)  # a model in post-decision form: succ[x, u] = g[f0[x, u]]
g = rng.integers(0, 50_000, size=(50_000, 4))
g[:, 0] = np.arange(50_000)
post = lb.FiniteMDP(g[rng.integers(0, 50_000, size=(50_000, 3))], [0.4, 0.3, 0.2, 0.1],
                    rng.normal(size=(50_000, 3)), 0.9)
assert lb.solve_exact(post).error_bound < 1e-6
assert lb.dp.post_decision_rows(post) is not None
"""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=env
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert list(tmp_path.iterdir()) == []
    assert "compil" not in proc.stderr, proc.stderr[-2000:]
