"""Start-up: ``import lpbounds`` and ``lpbounds [SUBCOMMAND] --help`` load none of the heavy
dependencies, the lazy public names behave like eager ones, and a small model's first solve
needs no compiled kernel (so it never waits for numba).

Each check runs in a fresh interpreter: what a module imports is only visible there.
Timings are measured by ``benchmarks/bench_startup.py``, never asserted here.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from types import SimpleNamespace

import pytest

import lpbounds
from lpbounds._kernels import dispatch as _backend
from lpbounds.cli.main import COMMANDS

HEAVY = ("cvxpy", "matplotlib", "pandas", "numba")
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
    # the check above can fail: the same probe reports numba once the DP kernels load
    assert imported_by("import lpbounds._kernels.compiled") == ["numba"]


@pytest.mark.parametrize("command", ["", *COMMANDS])
def test_help_loads_no_heavy_dependency(command):
    argv = ["lpbounds", *([command] if command else []), "--help"]
    code = (
        f"import sys\nsys.argv = {argv!r}\nfrom lpbounds.cli.main import main\n"
        "try:\n    main()\nexcept SystemExit as exc:\n    assert exc.code == 0, exc.code\n"
    )
    assert imported_by(code, NOT_FOR_HELP) == []


def test_a_small_first_solve_needs_no_compiled_kernel():
    code = """
import lpbounds as lb
mdp = lb.garnet(300, 3, 4, 0.9, seed=7)
dp = lb.solve_exact(mdp)
rows = lb.BellmanRows.aggregate(mdp, lb.random_partition(300, 30, seed=11))
cert = lb.certify(rows, lb.solve_exact(rows).values)
assert dp.error_bound < 1e-7 and cert.error_bound < 1e-6
"""
    compiled = ("numba", "lpbounds._kernels.compiled", "lpbounds._kernels.aggregate")
    assert imported_by(code, compiled) == []


def test_a_large_row_solve_needs_no_numba():
    """A random MDP above the numpy path's size runs on the native (C) row sweeps: its
    process imports no numba (0.5 s of start-up and first call, docs/benchmarks.md)."""
    code = """
import lpbounds as lb
from lpbounds._kernels import dispatch
mdp = lb.garnet(20_000, 3, 5, 0.9, seed=7)  # 300,000 reads per sweep
assert mdp.n_states * 15 >= dispatch.SMALL_READS
dp = lb.solve_exact(mdp)
ev = lb.evaluate_policy(mdp, dp.policy, method="iterative")
assert dp.error_bound < 1e-9 and ev.error_bound < 1e-9
"""
    assert imported_by(code, ("numba", "lpbounds._kernels.native")) == ["lpbounds._kernels.native"]


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


def _dispatcher(index_path: str, overloads: dict[object, object]) -> SimpleNamespace:
    cache = SimpleNamespace(_cache_file=SimpleNamespace(_index_path=index_path))
    return SimpleNamespace(_cache=cache, overloads=overloads)


def test_needs_compile_reads_the_cache_index(tmp_path):
    index = tmp_path / "k.nbi"
    index.write_bytes(b"")
    cached = SimpleNamespace(k=_dispatcher(str(index), {}))
    missing = SimpleNamespace(k=_dispatcher(str(tmp_path / "none.nbi"), {}))
    loaded = SimpleNamespace(k=_dispatcher(str(tmp_path / "none.nbi"), {"sig": object()}))
    assert not _backend._needs_compile(cached, ("k",))  # type: ignore[arg-type]
    assert _backend._needs_compile(missing, ("k",))  # type: ignore[arg-type]
    assert not _backend._needs_compile(loaded, ("k",))  # type: ignore[arg-type]
    # a group is announced only when none of its kernels is cached or loaded: one cached
    # kernel means the cache is warm (the group's unused kernels must not announce a
    # compile on every run)
    group = SimpleNamespace(
        k=_dispatcher(str(tmp_path / "none.nbi"), {}), j=_dispatcher(str(index), {})
    )
    assert not _backend._needs_compile(group, ("k", "j"))  # type: ignore[arg-type]
    both_missing = SimpleNamespace(k=missing.k, j=missing.k)
    assert _backend._needs_compile(both_missing, ("k", "j"))  # type: ignore[arg-type]


def test_an_empty_numba_cache_is_detected(tmp_path):
    """In a fresh environment every kernel group would compile (and would be announced)."""
    code = (
        "from lpbounds._kernels import aggregate as _aggregate, compiled as _kernels\n"
        "from lpbounds._kernels import dispatch as _backend\n"
        "mods = {'aggregate': _aggregate}\n"
        "assert all(_backend._needs_compile(mods.get(g, _kernels), names)\n"
        "           for g, (_, _, names) in _backend._GROUPS.items())\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=env
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
