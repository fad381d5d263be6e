"""One house: the DP loops of lpbounds.dp run on a public sweep protocol.

BellmanRows, PostDecisionRows and the matrix-free patrol operator implement
``lpbounds.rows.SweepOperator``; ``dp.mpi_loop`` and ``dp.evaluation_loop`` are the only
VI/MPI and policy-evaluation loops, and the matrix-free solve returns a ``DPResult``
equal, bit for bit, to the array path's. Static checks (ast): matrix_free.py defines no
loop of its own, and no module of lpbounds.patrol reaches into another module's
underscore names of lpbounds.dp or lpbounds.patrol.matrix_free.
"""

from __future__ import annotations

import ast
import inspect
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import lpbounds as lb
from lpbounds import dp
from lpbounds.dp import DPResult, LoopResult, exact_rows, mpi_loop, post_decision_rows
from lpbounds.patrol import matrix_free
from lpbounds.patrol.matrix_free import MatrixFreePatrol, solve_vstar
from lpbounds.patrol.matrix_free import evaluate_policy as mf_evaluate
from lpbounds.patrol.model import PatrolModel
from lpbounds.patrol.params import PatrolParams
from lpbounds.rows import BellmanRows, PolicySweeps, PostDecisionRows, SweepOperator
from lpbounds.status import Status

SRC = Path(dp.__file__).resolve().parents[1]
#: a small patrol (one range per C sweep) and one whose sweeps split over the threads
PARAMS = {
    "small": PatrolParams(N=5, stations=(0, 2), D=2, Gamma=6),
    "compiled": PatrolParams(N=6, stations=(0, 2, 4), D=2, Gamma=11),
}
PROTOCOL = ("sweep_max", "sweep_policy", "evaluator", "new_vector", "new_arg", "new_work")


@pytest.fixture(scope="module", params=list(PARAMS))
def patrol(request):
    params = PARAMS[request.param]
    mdp = PatrolModel(params).mdp()
    return mdp, MatrixFreePatrol(params)


def operators(mdp, mf):
    ps = post_decision_rows(mdp)
    assert ps is not None
    return {"rows": exact_rows(mdp), "post-decision": ps, "matrix-free": mf}


# ---------------------------------------------------------------------- the protocol
def test_every_operator_satisfies_the_protocol(patrol):
    mdp, mf = patrol
    for name, ops in operators(mdp, mf).items():
        assert isinstance(ops, SweepOperator), name
        for meth in ("sweep_max", "sweep_policy"):
            params = inspect.signature(getattr(ops, meth)).parameters
            for kw in ("work", "nchunks"):
                assert params[kw].kind is inspect.Parameter.KEYWORD_ONLY, (name, meth, kw)
        assert ops.n_vars == mdp.n_states and ops.discount == mdp.discount
        assert ops.sweep_reads > 0 and isinstance(ops.compiled, bool)
        v = ops.new_vector()
        assert v.shape == (mdp.n_states,) and v.dtype == np.float64
        arg = ops.new_arg()
        assert arg.shape == (mdp.n_states,) and not arg.any()
        assert isinstance(ops.evaluator(ops.new_work()), PolicySweeps)
    assert post_decision_rows(mdp).new_work().shape == (post_decision_rows(mdp).n_post,)
    assert exact_rows(mdp).new_work() is None and mf.new_work() is None


def test_a_non_operator_is_not_one():
    assert not isinstance(lb.garnet(5, 2, 2), SweepOperator)  # an MDP is not swept
    assert not isinstance(np.zeros(3), SweepOperator)


def test_the_sweeps_agree_on_every_operator(patrol):
    """One max sweep and one policy sweep, every chunk count: the same numbers everywhere
    (rows choose rows; the post-decision form and the matrix-free operator, actions)."""
    mdp, mf = patrol
    ops = operators(mdp, mf)
    rows = ops["rows"]
    v = np.random.default_rng(3).normal(size=mdp.n_states)
    want, want_arg = np.empty_like(v), rows.new_arg()
    stats = rows.sweep_max(v, want, want_arg)
    act = rows.action[want_arg].astype(np.int8)
    pol_want = np.empty_like(v)
    pol_stats = rows.sweep_policy(want_arg, v, pol_want)
    for name, op in ops.items():
        for nchunks in (None, 1, 7):
            out, arg = op.new_vector(), op.new_arg()
            work = op.new_work()
            assert op.sweep_max(v, out, arg, work=work, nchunks=nchunks) == stats, name
            assert np.array_equal(out, want), name
            choice = want_arg if name == "rows" else act
            assert np.array_equal(arg, choice), name
            assert op.sweep_policy(choice, v, out, work=work, nchunks=nchunks) == pol_stats
            assert np.array_equal(out, pol_want), name
            ev = op.evaluator(work)
            ev.set_policy(choice)
            assert ev.sweep(v, out) == pol_stats and np.array_equal(out, pol_want), name


# ---------------------------------------------------------------------- one loop
def test_mpi_loop_on_every_operator_gives_the_same_numbers(patrol):
    mdp, mf = patrol
    runs = {}
    for name, ops in operators(mdp, mf).items():
        tol = mf.default_tol()
        run = mpi_loop(ops, np.zeros(mdp.n_states), tol, 1000, "auto")
        assert isinstance(run, LoopResult) and run.converged, name
        runs[name] = run
    ref = runs["rows"]
    for name, run in runs.items():
        assert np.array_equal(run.values, ref.values), name
        assert (run.iterations, run.sweeps, run.residual) == (
            ref.iterations,
            ref.sweeps,
            ref.residual,
        ), name
        assert run.history == ref.history, name
    assert np.array_equal(runs["matrix-free"].arg, runs["post-decision"].arg)
    assert np.array_equal(exact_rows(mdp).action[ref.arg], runs["matrix-free"].arg)


def test_mpi_loop_overwrites_its_start_and_forms_the_result_in_place():
    mf = MatrixFreePatrol(PARAMS["small"])
    v = np.zeros(mf.n_vars)
    run = mpi_loop(mf, v, mf.default_tol(), 1000, 0)
    assert run.converged
    assert run.values is v or not np.shares_memory(run.values, v)  # one of its two vectors


@pytest.mark.parametrize("eval_sweeps", ["auto", 0, 5])
def test_matrix_free_solve_is_a_dp_result_equal_to_the_array_path(patrol, eval_sweeps):
    mdp, mf = patrol
    ref = lb.solve_exact(mdp, eval_sweeps=eval_sweeps)
    got = solve_vstar(mf, eval_sweeps=eval_sweeps)
    assert isinstance(got, DPResult)
    assert np.array_equal(got.values.view(np.int64), ref.values.view(np.int64))
    assert got.policy.dtype == np.int8 and np.array_equal(got.policy, ref.policy)
    assert got.policy_rows is got.policy  # no rows: the choices are the actions
    for field in ("residual", "error_bound", "tol", "iterations", "sweeps", "method"):
        assert getattr(got, field) == getattr(ref, field), field
    assert got.history == ref.history
    assert got.status is Status.OPTIMAL and got.converged


def test_matrix_free_iteration_limit_is_a_dp_result(patrol):
    mdp, mf = patrol
    ref = lb.solve_exact(mdp, max_iter=2, raise_on_failure=False)
    got = solve_vstar(mf, max_iter=2, raise_on_failure=False)
    assert isinstance(got, DPResult) and got.status is Status.ITERATION_LIMIT
    assert np.array_equal(got.values, ref.values) and got.error_bound == ref.error_bound
    with pytest.raises(lb.ConvergenceError, match="stopped after 2 iterations"):
        solve_vstar(mf, max_iter=2)


def test_matrix_free_evaluation_equals_the_array_path(patrol):
    mdp, mf = patrol
    pol = lb.greedy_policy(mdp, np.zeros(mdp.n_states))
    ref = lb.evaluate_policy(mdp, pol, method="iterative")
    got = mf_evaluate(mf, pol)
    assert np.array_equal(got.values, ref.values)
    assert (got.residual, got.error_bound, got.sweeps) == (
        ref.residual,
        ref.error_bound,
        ref.sweeps,
    )


def test_the_matrix_free_loops_keep_two_value_vectors():
    """Peak traced memory of a solve and an evaluation: two float64 vectors, the int8
    policies, and change (a third vector, as ``u + c`` into a new array, would fail)."""
    mf = MatrixFreePatrol(PatrolParams(N=6, stations=(0, 2, 4), D=2, Gamma=15))
    vec = 8 * mf.n_vars
    sol = solve_vstar(mf)  # a first solve (the reward scale cached): not measured
    mf_evaluate(mf, sol.policy)
    del sol
    for run in (lambda: solve_vstar(mf), lambda: mf_evaluate(mf, np.zeros(mf.n_vars, np.int8))):
        tracemalloc.start()
        try:
            out = run()
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        del out
        assert peak <= 2 * vec + 2 * mf.n_vars + vec // 2, f"peak {peak / vec:.2f} vectors"


def test_a_non_row_system_has_no_game():
    mf = MatrixFreePatrol(PARAMS["small"])
    with pytest.raises(lb.ValidationError, match="game operator needs BellmanRows"):
        mpi_loop(mf, np.zeros(mf.n_vars), 1e-6, 10, 0, game=True)


# ---------------------------------------------------------------------- static checks
def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def _calls(node: ast.AST) -> set[str]:
    """Names of the methods and functions called inside ``node``."""
    out = set()
    for n in ast.walk(node):
        if isinstance(n, ast.Call):
            f = n.func
            out.add(f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", ""))
    return out


def test_matrix_free_defines_no_loop_of_its_own():
    tree = _tree(Path(matrix_free.__file__))
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    assert not names & {"PorteusShift", "EvalPlan", "ThreadChoice"}, "the loop's parts"
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        assert fn.name.lstrip("_") not in {"mpi", "evaluate", "iterate", "vi"}, fn.name
        for loop in ast.walk(fn):
            if isinstance(loop, ast.For) and isinstance(loop.iter, ast.Call):
                args = ast.dump(loop.iter)
                assert "max_iter" not in args and "max_sweeps" not in args, fn.name
            if isinstance(loop, ast.For | ast.While):
                calls = _calls(loop)
                assert not calls & {"sweep_max", "sweep_policy"}, f"{fn.name} loops on sweeps"
    solver_calls = {fn.name: _calls(fn) for fn in tree.body if isinstance(fn, ast.FunctionDef)}
    assert "mpi_loop" in solver_calls["solve_vstar"]
    assert "evaluation_loop" in solver_calls["evaluate_policy"]


def _module_aliases(tree: ast.Module, modules: set[str]) -> set[str]:
    """Local names bound to one of ``modules`` (``import a.b as x``, ``from . import b``)."""
    out = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.Import):
            for a in n.names:
                if a.name.split(".")[-1] in modules:
                    out.add(a.asname or a.name)
        elif isinstance(n, ast.ImportFrom):
            for a in n.names:
                if a.name in modules:
                    out.add(a.asname or a.name)
    return out


@pytest.mark.parametrize("path", sorted((SRC / "patrol").glob("*.py")), ids=lambda p: p.name)
def test_no_patrol_module_uses_private_names_of_dp_or_matrix_free(path):
    owners = {"dp", "matrix_free"} - {path.stem}
    tree = _tree(path)
    for n in ast.walk(tree):
        if isinstance(n, ast.ImportFrom) and (n.module or "").split(".")[-1] in owners:
            private = [a.name for a in n.names if a.name.startswith("_")]
            assert not private, f"{path.name} imports {private} from {n.module}"
    aliases = _module_aliases(tree, owners)
    for n in ast.walk(tree):
        if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name):
            if n.value.id in aliases:
                assert not n.attr.startswith("_"), f"{path.name}: {n.value.id}.{n.attr}"
    if path.stem == "beyond":  # the operator's own state, through its public methods
        for n in ast.walk(tree):
            if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name):
                assert not (n.value.id == "mf" and n.attr.startswith("_")), f"mf.{n.attr}"


def test_dp_uses_only_the_public_protocol():
    """dp reaches the operators through SweepOperator's methods, not their private ones."""
    privates = {"_sweep_max", "_sweep_policy", "_sweep_maxmin", "_evaluator", "_chunks"}
    modules = sorted((SRC / "dp").glob("*.py"))
    assert {p.stem for p in modules} >= {"__init__", "loop", "evaluation"}
    for path in modules:
        used = {n.attr for n in ast.walk(_tree(path)) if isinstance(n, ast.Attribute)}
        assert not used & privates, path.name
    for cls in (BellmanRows, PostDecisionRows, MatrixFreePatrol):
        for meth in PROTOCOL:
            assert callable(getattr(cls, meth)), (cls.__name__, meth)
