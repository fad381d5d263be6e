"""Numbers the documentation states about runs, against a fresh run of the same thing.

docs/tolerances.md's table of the LP solvers' certified accuracy is written by
``benchmarks/bench_lp_accuracy.py``; here every row is solved again (the ``patrol-paper``
rows, two minutes, only with ``-m slow``) and must have the page's status and a certified
error within a factor of :data:`SOLVER_FACTOR` of the page's: the page records one version
of each solver and CI installs the newest, so the digits may move, not the order of
magnitude or the verdict. The page's prose numbers about ``solve_exact``'s default accuracy
on FrozenLake are recomputed against an independent dense policy iteration and must round
to the page's two digits (the computation is deterministic: the same sweeps stop at the
same residual). docs/interop.md's FrozenLake errors are asserted by the page's own code
(tests/model/interop/test_interop_docs.py runs it).
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.tolerances import DP_NOISE_ULPS
from tests import _independent as ind

ROOT = Path(__file__).resolve().parents[2]
TOLERANCES = ROOT / "docs" / "tolerances.md"
#: a fresh certified error may differ from the page's by this factor either way
SOLVER_FACTOR = 10.0
EPS = float(np.finfo(np.float64).eps)


def _bench():
    spec = importlib.util.spec_from_file_location(
        "bench_lp_accuracy", ROOT / "benchmarks" / "bench_lp_accuracy.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


BENCH = _bench()


def page_table() -> dict[tuple[str, str, str], tuple[str, float]]:
    """(model, LP, solver) -> (status, relative error) as docs/tolerances.md shows them."""
    text = TOLERANCES.read_text()
    body = re.search(r"<!-- lp-accuracy:start -->(.*?)<!-- lp-accuracy:end -->", text, re.S)
    assert body, "docs/tolerances.md has no lp-accuracy section"
    out = {}
    for line in body.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4 or cells[0] in ("model", "---"):
            continue
        for solver, text_cell in zip(BENCH.SOLVERS, cells[2:], strict=True):
            err = float(text_cell.split()[0])
            status = re.search(r"\*\*(\w+)\*\*", text_cell)
            out[cells[0], cells[1], solver] = (status.group(1) if status else "optimal", err)
    return out


PAGE = page_table()
SLOW = "patrol-paper"


def test_the_page_shows_every_row_of_the_benchmark():
    assert {(m, lp) for m, lp, _ in PAGE} == set(BENCH.ROWS)


def _check(model: str, lp: str) -> None:
    for solver in BENCH.SOLVERS:
        status, err = PAGE[model, lp, solver]
        fresh = BENCH.measure(model, lp, solver)
        where = f"{model} {lp} {solver}"
        assert fresh["status"] == status, f"{where}: the page says {status}, a run {fresh}"
        ratio = fresh["relative_error"] / err
        assert 1 / SOLVER_FACTOR <= ratio <= SOLVER_FACTOR, f"{where}: page {err:.1e}, run {fresh}"


@pytest.mark.parametrize(
    ("model", "lp"),
    [r for r in BENCH.ROWS if not r[0].startswith(SLOW)],
    ids=[f"{m} {lp}" for m, lp in BENCH.ROWS if not m.startswith(SLOW)],
)
def test_lp_accuracy_row_matches_a_fresh_run(model, lp):
    _check(model, lp)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("model", "lp"),
    [r for r in BENCH.ROWS if r[0].startswith(SLOW)],
    ids=[f"{m} {lp}" for m, lp in BENCH.ROWS if m.startswith(SLOW)],
)
def test_lp_accuracy_row_at_the_papers_size_matches_a_fresh_run(model, lp):
    _check(model, lp)


def test_the_table_check_fails_on_a_wrong_page(monkeypatch):
    """A page whose number is off by more than the factor, or whose status is not the
    run's, fails the check (so the check can fail)."""
    model, lp = BENCH.ROWS[0]
    status, err = PAGE[model, lp, "HIGHS"]
    monkeypatch.setitem(PAGE, (model, lp, "HIGHS"), (status, err * 100))
    with pytest.raises(AssertionError, match="page"):
        _check(model, lp)
    monkeypatch.setitem(PAGE, (model, lp, "HIGHS"), ("inaccurate", err))
    with pytest.raises(AssertionError, match="the page says inaccurate"):
        _check(model, lp)


def test_frozenlake_default_accuracy_as_the_page_says():
    """docs/tolerances.md: "on FrozenLake 4x4 at discount 0.99 the default V* is X from the
    exact values (it was Y with the earlier default 1e-10 * max|R| / (1 - lambda))"."""
    gym = pytest.importorskip("gymnasium", reason="the interop extra")
    found = re.search(
        r"the default V\* is (\S+) from the exact\s+values \(it was (\S+) with the earlier",
        TOLERANCES.read_text(),
    )
    assert found, "docs/tolerances.md no longer states FrozenLake's default accuracy"
    now, before = float(found.group(1)), float(found.group(2))
    mdp = lb.FiniteMDP.from_gymnasium(gym.make("FrozenLake-v1").unwrapped, 0.99)
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    ref = ind.policy_iteration(P, mdp.rewards, mdp.allowed, mdp.discount)
    rmax = float(np.abs(mdp.rewards[mdp.allowed]).max())
    runs = {
        "default": (lb.solve_exact(mdp), now),
        "earlier default": (lb.solve_exact(mdp, tol=1e-10 * rmax / (1 - mdp.discount)), before),
    }
    for what, (res, said) in runs.items():
        error = float(np.abs(res.values - ref.values).max())
        assert error <= res.error_bound + ref.error  # the run's own bound holds
        assert f"{error:.1e}" == f"{said:.1e}", f"{what}: the page says {said}, a run {error:.2e}"


def test_periodic_floor_number_is_the_formula():
    """docs/tolerances.md: the periodic-chain floor ``2 eps / (1 - lambda)^2`` of the value
    scale is "4.4e-10 at 0.999"."""
    found = re.search(r"\((\S+) at 0\.999\)", TOLERANCES.read_text())
    assert found
    assert f"{DP_NOISE_ULPS * EPS / (1 - 0.999) ** 2:.1e}" == found.group(1)


VERIFY_PAGE = ROOT / "docs" / "verify.md"


@pytest.mark.slow
def test_verify_page_describes_the_default_run():
    """docs/verify.md's default run (about 12 s): the models it names, the records per
    solver, the solver-free and cross-solver counts, every one holding, and the widest
    certified width relative to the requested accuracy per solver (the page's percent,
    within :data:`SOLVER_FACTOR`: a newer solver may move the digits)."""
    pytest.importorskip("gymnasium")  # the page's run has the Gymnasium models
    from lpbounds.studies.verify import run_verification

    text = " ".join(VERIFY_PAGE.read_text().split())
    para = text[text.index("The default run (") :]
    para = para[: para.index("name one to verify it.")]
    records = run_verification().records
    names = {r["instance"] for r in records}
    for model in re.findall(r"\b(garnet-small|patrol-small|forest|gridworld|inventory|queue|"
                            r"savings|frozenlake|cliffwalking|taxi)\b", para):  # fmt: skip
        assert model in names, model
    per_solver, free, cross = (int(x) for x in re.search(
        r"all (\d+) per solver hold, plus the (\d+) solver-free and (\d+) cross-solver", para
    ).groups())  # fmt: skip
    counts: dict[str, int] = {}
    for r in records:
        counts[r["solver"]] = counts.get(r["solver"], 0) + 1
    assert all(r["verdict"] == "holds" for r in records)
    assert counts.pop("exact") == free and counts.pop("all") == cross
    assert set(counts.values()) == {per_solver}, counts
    widest = re.findall(r"(\d+) % for ([A-Za-z ]+?) \(", para)
    assert {s for _, names in widest for s in names.split(" and ")} == {
        "HiGHS",
        "SciPy",
        "Clarabel",
    }
    for pct, names in widest:
        for solver in names.split(" and "):
            fresh = max(  # Remark 2's records ask for no accuracy (0): left out
                r["width"] / r["accuracy"]
                for r in records
                if r["solver"] == solver.upper() and r["accuracy"]
            )
            page = int(pct) / 100
            assert page / SOLVER_FACTOR <= fresh <= page * SOLVER_FACTOR, (solver, fresh, page)
