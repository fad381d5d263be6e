"""Every fast path of the DP core against the plain path and an independent reference.

The post-decision form (:class:`lpbounds.rows.PostDecisionRows`) is used automatically by
``solve_exact`` (VI/MPI), ``evaluate_policy`` (iterative) and ``bellman_residual`` on a
FiniteMDP that has it. Passing ``exact_rows(mdp)`` forces the plain row kernels. The fast
path claims the *same arithmetic*, so the tests below ask for bit-identical results, and
compare both with plain-numpy references from ``conftest``.

Every test runs twice, with the library on the numpy twins of the kernels (the reference
arithmetic) and on the C kernels (what it runs; :mod:`lpbounds._kernels.dispatch`, the work
split over the threads even on these small models), and the tests at the end compare the
two paths with each other, bit for bit. Identical numbers could still be
identically wrong, so each result's certificate is also held to its promise both ways
against ``tests/_independent`` (numpy only): the true error within ``error_bound``, and
``error_bound`` no larger than the residual recomputed there implies.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds._kernels import ckernels as _kernels
from lpbounds._kernels import dispatch as _backend
from lpbounds._kernels import native, threads
from lpbounds._kernels import twins as _npkernels
from lpbounds.dp import exact_rows, post_decision_rows
from lpbounds.patrol import PatrolModel, PatrolParams
from lpbounds.rows import PostDecisionRows
from tests import _independent as ind
from tests.conftest import reference_bellman, reference_solve


def use_path(monkeypatch, path: str) -> None:
    """Send every kernel call of the library to one path: ``"numpy"``, the twins; ``"compiled"``,
    the C kernels with every call's work split over the threads (however small)."""
    if path == "numpy":
        monkeypatch.setattr(_backend, "kernels", lambda: _npkernels)
        monkeypatch.setattr(_backend, "row_sweeps", lambda: _npkernels)
    else:
        monkeypatch.setattr(_kernels, "PARALLEL_READS", 0)


@pytest.fixture(params=["numpy", "compiled"])
def kernel_path(request, monkeypatch):
    """Run a test on both kernel paths."""
    use_path(monkeypatch, request.param)
    return request.param


def post_decision_mdp(
    n: int, n_actions: int, n_out: int, discount: float, seed: int, allowed_fraction: float = 1.0
) -> lb.FiniteMDP:
    """A random MDP in post-decision form: ``succ[x, u] = g[f0[x, u]]`` with ``g[y, 0] = y``."""
    rng = np.random.default_rng(seed)
    g = rng.integers(0, n, size=(n, n_out))
    g[:, 0] = np.arange(n)
    f0 = rng.integers(0, n, size=(n, n_actions))
    p = rng.random(n_out) + 0.05
    allowed = rng.random((n, n_actions)) < allowed_fraction
    allowed[np.arange(n), rng.integers(0, n_actions, size=n)] = True
    rewards = rng.normal(size=(n, n_actions))
    return lb.FiniteMDP(g[f0], p / p.sum(), rewards, discount, allowed)


def small_patrol(**kw) -> lb.FiniteMDP:
    base = {"N": 8, "stations": (0, 3), "D": 3, "Gamma": 5}
    base.update(kw)
    return PatrolModel(PatrolParams(**base)).mdp()


PATROLS = [
    {},
    {"allow_empty_loiter": True},
    {"N": 7, "stations": (1, 3, 5), "D": 2, "Gamma": 4},
]


def check_dp(res, mdp: lb.FiniteMDP, what: str = "") -> None:
    """``res`` (a DPResult of ``mdp``) both ways, V* by value iteration on the successor
    arrays from ``res.values`` to 1e-14 (tests/_independent, with its own error bound)."""
    succ, p = mdp.successors, mdp.probabilities_full()

    def op(v):
        return ind.successor_bellman(succ, p, mdp.rewards, mdp.allowed, mdp.discount, v)

    ref = ind.fixed_point(op, res.values, mdp.discount)
    ind.assert_dp_certificate(res, op(res.values), mdp.discount, reference=ref.values,
                              reference_err=ref.error, what=what)  # fmt: skip


def check_evaluation(ev, mdp: lb.FiniteMDP, policy, what: str = "") -> None:
    """A PolicyEvaluation both ways at the default tolerance ``1e-10 max|R| / (1 - lambda)``,
    V_pi by a dense solve (tests/_independent.policy_value)."""
    succ, p, lam = mdp.successors, mdp.probabilities_full(), mdp.discount
    ref = ind.policy_value(ind.dense_transitions(succ, p), mdp.rewards, policy, lam)
    t = ind.policy_operator(succ, p, mdp.rewards, policy, lam, ev.values)
    tol = 1e-10 * float(np.abs(mdp.rewards[mdp.allowed]).max()) / (1 - lam)
    ind.assert_dp_certificate(ev, t, lam, reference=ref.values, reference_err=ref.error,
                              tol=tol, what=what)  # fmt: skip


def assert_same_result(fast: lb.DPResult, plain: lb.DPResult, rows: lb.BellmanRows) -> None:
    assert np.array_equal(fast.values, plain.values), "fast path values differ from plain"
    assert np.array_equal(fast.policy_rows, plain.policy_rows), "policy rows differ"
    assert np.array_equal(fast.policy, rows.action[plain.policy_rows]), "actions differ"
    assert (fast.iterations, fast.sweeps) == (plain.iterations, plain.sweeps)
    assert fast.residual == plain.residual
    assert fast.error_bound == plain.error_bound
    assert fast.tol == plain.tol


@pytest.mark.usefixtures("kernel_path")
@pytest.mark.parametrize("kw", PATROLS)
@pytest.mark.parametrize("method", ["vi", "mpi"])
def test_patrol_fast_solve_equals_plain_bit_for_bit(kw, method):
    mdp = small_patrol(**kw)
    assert post_decision_rows(mdp) is not None, "the patrol MDP has a post-decision form"
    rows = exact_rows(mdp)
    fast = lb.solve_exact(mdp, method)
    plain = lb.solve_exact(rows, method)
    assert_same_result(fast, plain, rows)
    # and both against an independent numpy value iteration, within the reported bound
    ref = reference_solve(mdp)
    err = np.abs(fast.values - ref).max()
    assert err <= fast.error_bound + 1e-12, f"|V - V*| = {err} > bound {fast.error_bound}"
    q = reference_bellman(mdp, fast.values)
    true_res = np.abs(q.max(axis=1) - fast.values).max()
    assert true_res == pytest.approx(fast.residual, abs=1e-13), "residual not the true one"
    check_dp(fast, mdp, method)


@pytest.mark.usefixtures("kernel_path")
@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("allowed_fraction", [1.0, 0.6])
def test_random_post_decision_mdp_equals_plain(seed, allowed_fraction):
    mdp = post_decision_mdp(300, 3, 4, 0.9, seed, allowed_fraction)
    ps = post_decision_rows(mdp)
    assert ps is not None
    rows = exact_rows(mdp)
    for method in ("vi", "mpi"):
        kw = {"eval_sweeps": 3, "tol": 1e-9, "initial": np.linspace(-1, 1, 300)}
        fast = lb.solve_exact(mdp, method, **kw)
        assert_same_result(fast, lb.solve_exact(rows, method, **kw), rows)
        check_dp(fast, mdp, method)
    # the form's operator against the plain numpy Bellman operator
    v = np.random.default_rng(seed).normal(size=mdp.n_states)
    out = np.empty_like(v)
    act = ps.new_arg()
    lo, hi = ps.sweep_max(v, out, act, nchunks=7)  # nchunks: ignored by the C sweeps
    q = reference_bellman(mdp, v)
    np.testing.assert_allclose(out, q.max(axis=1), rtol=0, atol=1e-14, err_msg="T v")
    assert np.array_equal(act, q.argmax(axis=1)), "first maximising action"
    assert (lo, hi) == ((out - v).min(), (out - v).max())
    assert np.array_equal(ps.rows_of(act), rows.pair_row[np.arange(mdp.n_states), act])


@pytest.mark.usefixtures("kernel_path")
@pytest.mark.parametrize("max_codes", [0, 8, 65_536])
def test_reward_storage_variants_equal_plain(monkeypatch, max_codes):
    # 0: float rewards; 8: too few codes for the rewards, so float; 65,536: uint16 codes
    monkeypatch.setattr(PostDecisionRows, "MAX_REWARD_CODES", max_codes)
    mdp = post_decision_mdp(400, 3, 3, 0.9, seed=9, allowed_fraction=0.7)
    ps = PostDecisionRows.detect(mdp)
    if max_codes < 400:
        assert ps.reward_codes is None
    else:
        assert ps.reward_codes.dtype == np.uint16
        assert np.array_equal(ps.reward_table[ps.reward_codes], mdp.rewards), "codes lossy"
    mdp.__dict__["_post_decision"] = ps
    rows = exact_rows(mdp)
    for method in ("vi", "mpi"):
        fast = lb.solve_exact(mdp, method)
        assert_same_result(fast, lb.solve_exact(rows, method), rows)
        check_dp(fast, mdp, method)


@pytest.mark.usefixtures("kernel_path")
def test_patrol_rewards_are_coded_exactly():
    mdp = small_patrol()
    ps = post_decision_rows(mdp)
    assert ps.reward_codes is not None and ps.reward_codes.dtype == np.uint8
    assert np.array_equal(ps.reward_table[ps.reward_codes], mdp.rewards)
    # bit for bit, including the sign of zero
    assert np.array_equal(
        ps.reward_table[ps.reward_codes].view(np.int64), np.asarray(mdp.rewards).view(np.int64)
    )


@pytest.mark.usefixtures("kernel_path")
def test_detection_rejects_mdps_without_the_form():
    assert post_decision_rows(lb.garnet(200, 3, 4, 0.9, seed=2, shared_probabilities=True)) is None
    assert post_decision_rows(lb.garnet(200, 3, 4, 0.9, seed=2)) is None  # per-pair probs
    # one changed outcome in one pair breaks the form: verification must notice
    good = post_decision_mdp(200, 3, 4, 0.9, seed=4)
    assert PostDecisionRows.detect(good) is not None
    succ = np.array(good.successors)
    x = int(np.flatnonzero(good.allowed[:, 1])[-1])
    succ[x, 1, 2] = (succ[x, 1, 2] + 1) % 200
    bad = lb.FiniteMDP(succ, good.probabilities, good.rewards, 0.9, good.allowed)
    shared = np.isin(bad.successors[:, :, 0], bad.successors[x, 1, 0]).sum()
    if shared > 1:  # another pair reaches the same post-decision state: must be rejected
        assert PostDecisionRows.detect(bad) is None
    # a disallowed pair's successors are never read
    succ2 = np.array(good.successors)
    allowed = np.array(good.allowed)
    allowed[0, 2] = False
    succ2[0, 2] = [5, 6, 7, 8]
    mdp2 = lb.FiniteMDP(succ2, good.probabilities, good.rewards, 0.9, allowed)
    assert PostDecisionRows.detect(mdp2) is not None


@pytest.mark.usefixtures("kernel_path")
def test_detection_notices_a_single_inconsistent_pair():
    # two pairs with the same first successor and different tuples
    succ = np.array([[[1, 0]], [[1, 1]], [[2, 0]]])
    mdp = lb.FiniteMDP(succ, [0.5, 0.5], np.zeros((3, 1)), 0.9)
    assert PostDecisionRows.detect(mdp) is None


@pytest.mark.usefixtures("kernel_path")
@pytest.mark.parametrize("kw", PATROLS[:2])
def test_fast_policy_evaluation_matches_direct_solve(kw):
    mdp = small_patrol(**kw)
    sol = lb.solve_exact(mdp)
    rng = np.random.default_rng(0)
    pol = np.array(sol.policy)
    flip = rng.random(mdp.n_states) < 0.3
    pol[flip & mdp.allowed[:, 1]] = 1  # another valid policy
    fast = lb.evaluate_policy(mdp, pol, method="iterative")
    # independent: sparse LU of (I - lam P_pi) V = R_pi from to_matrices()
    P, R = mdp.to_matrices(disallowed_reward=-1e9)
    n = mdp.n_states
    p_pi = sp.vstack([P[pol[x]][x] for x in range(n)]).tocsc()
    want = spla.spsolve(sp.identity(n, format="csc") - mdp.discount * p_pi, R[np.arange(n), pol])
    err = np.abs(fast.values - want).max()
    assert err <= fast.error_bound + 1e-12, f"|V - V_pi| = {err} > bound {fast.error_bound}"
    check_evaluation(fast, mdp, pol, "fast evaluation")
    plain = lb.evaluate_policy(
        exact_rows(mdp), exact_rows(mdp).pair_row[np.arange(n), pol], method="iterative"
    )
    assert np.array_equal(fast.values, plain.values), "fast and plain evaluation differ"
    assert fast.residual == pytest.approx(plain.residual, abs=1e-15)
    with pytest.raises(lb.ValidationError, match="not allowed"):
        bad = np.array(pol)
        bad[int(np.flatnonzero(~mdp.allowed[:, 2])[0])] = 2
        lb.evaluate_policy(mdp, bad, method="iterative")


@pytest.mark.usefixtures("kernel_path")
def test_fast_bellman_residual_equals_plain():
    mdp = small_patrol()
    v = np.random.default_rng(1).normal(size=mdp.n_states)
    fast = lb.bellman_residual(mdp, v)
    plain = lb.bellman_residual(exact_rows(mdp), v)
    ref = np.abs(reference_bellman(mdp, v).max(axis=1) - v).max()
    assert fast == plain
    assert fast == pytest.approx(ref, abs=1e-13)


@pytest.mark.usefixtures("kernel_path")
@settings(
    max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    n=st.integers(2, 60),
    a=st.integers(1, 4),
    ll=st.integers(1, 4),
    lam=st.sampled_from([0.0, 0.5, 0.9, 0.97]),
    frac=st.sampled_from([1.0, 0.5]),
    seed=st.integers(0, 10_000),
)
def test_property_fast_equals_plain(n, a, ll, lam, frac, seed):
    mdp = post_decision_mdp(n, a, ll, lam, seed, frac)
    rows = exact_rows(mdp)
    for method in ("vi", "mpi"):
        fast = lb.solve_exact(mdp, method)
        assert_same_result(fast, lb.solve_exact(rows, method), rows)
        check_dp(fast, mdp, method)


# ---------------------------------------------------------------------- numpy twins vs C
def on_path(monkeypatch, path: str, func):
    """``func()`` with every operation sent to one kernel path."""
    use_path(monkeypatch, path)
    try:
        return func()
    finally:
        monkeypatch.undo()


def masked_mdp(
    n: int,
    n_actions: int,
    n_out: int,
    discount: float,
    seed: int,
    shared: bool,
    part: lb.Partition | None = None,
) -> lb.FiniteMDP:
    """A random MDP with an action mask, repeated successors and zero probabilities (so
    the merge, padding and tie rules are all exercised) and rewards with exact ties.
    With ``part``, the states of each partition share an allowed action (the NLP's rule)."""
    rng = np.random.default_rng(seed)
    succ = rng.integers(0, n, size=(n, n_actions, n_out))
    succ[:, :, -1] = succ[:, :, 0]  # a repeated target in every tuple
    shape = (n_out,) if shared else (n, n_actions, n_out)
    p = rng.random(shape)
    p[..., 1 % n_out] = 0.0 if n_out > 2 else p[..., 1 % n_out]
    p /= p.sum(axis=-1, keepdims=True)
    allowed = rng.random((n, n_actions)) < 0.7
    allowed[np.arange(n), rng.integers(0, n_actions, size=n)] = True
    if part is not None:
        allowed[np.arange(n), part.labels % n_actions] = True
    rewards = rng.integers(-3, 4, size=(n, n_actions)).astype(float) / 2  # ties on purpose
    return lb.FiniteMDP(succ, p, rewards, discount, allowed)


def fresh(mdp: lb.FiniteMDP) -> lb.FiniteMDP:
    """The same model without the caches (exact rows, post-decision form) of a previous path."""
    return lb.FiniteMDP(mdp.successors, mdp.probabilities, mdp.rewards, mdp.discount, mdp.allowed)


def assert_rows_identical(a: lb.BellmanRows, b: lb.BellmanRows) -> None:
    for name in ("indptr", "owner", "action", "reward", "targets", "probs", "pair_row"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype, name
        assert np.array_equal(x, y), f"{name} differs between the paths"
        if x.dtype.kind == "f":  # bit for bit, signed zeros included
            assert np.array_equal(np.asarray(x).view(np.int64), np.asarray(y).view(np.int64)), name
    assert np.array_equal(a.pair_tight, b.pair_tight)


def bits(x) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64).view(np.int64)


@pytest.mark.parametrize("shared", [True, False])
@pytest.mark.parametrize("seed", range(3))
def test_numpy_operators_equal_compiled_bit_for_bit(monkeypatch, seed, shared):
    part = lb.random_partition(120, 17, seed=seed)
    mdp = masked_mdp(120, 3, 4, 0.9, seed, shared, part)
    v = np.random.default_rng(seed + 100).normal(size=mdp.n_states) * 10

    def run():
        rows = lb.BellmanRows.from_mdp(mdp)
        agg_max = lb.BellmanRows.aggregate(mdp, part, reduce="max")
        agg_min = lb.BellmanRows.aggregate(mdp, part, reduce="min")
        w = v[: part.n_partitions]
        q = rows.q_values(v)
        tv, arg = rows.apply_max(v)
        gv, garg = agg_min.apply_maxmin(w)
        pol = rows.evaluate_rows(arg, v)
        out = np.empty(mdp.n_states)
        stats = rows.sweep_policy(arg, v, out)
        cert = lb.certify(agg_max, w)
        return rows, agg_max, agg_min, q, tv, arg, gv, garg, pol, stats, cert

    a = on_path(monkeypatch, "numpy", run)
    b = on_path(monkeypatch, "compiled", run)
    for x, y in zip(a[:3], b[:3], strict=True):
        assert_rows_identical(x, y)
    for name, x, y in zip(("q", "Tv", "arg", "Gv", "Garg", "T_pi v"), a[3:9], b[3:9], strict=True):
        assert np.array_equal(bits(x), bits(y)), f"{name} differs between the paths"
    assert a[9] == b[9]
    ca, cb = a[10], b[10]
    assert np.array_equal(bits(ca.lower), bits(cb.lower))
    assert np.array_equal(bits(ca.upper), bits(cb.upper))
    assert (ca.error_bound, ca.residual, ca.margin) == (cb.error_bound, cb.residual, cb.margin)
    # and against the plain loop reference: first maximising row of every state
    ref = reference_bellman(mdp, v)
    assert np.array_equal(a[4], ref.max(axis=1))
    assert np.array_equal(a[0].action[a[5]], ref.argmax(axis=1))


@pytest.mark.parametrize("method", ["mpi", "vi", "pi"])
@pytest.mark.parametrize("shared", [True, False])
def test_numpy_solve_equals_compiled_bit_for_bit(monkeypatch, method, shared):
    mdp = masked_mdp(150, 4, 3, 0.95, seed=11, shared=shared)
    a = on_path(monkeypatch, "numpy", lambda: lb.solve_exact(fresh(mdp), method))
    b = on_path(monkeypatch, "compiled", lambda: lb.solve_exact(fresh(mdp), method))
    assert np.array_equal(bits(a.values), bits(b.values)), "values differ between the paths"
    assert np.array_equal(a.policy, b.policy)
    assert np.array_equal(a.policy_rows, b.policy_rows)
    assert (a.residual, a.error_bound, a.iterations, a.sweeps) == (
        b.residual,
        b.error_bound,
        b.iterations,
        b.sweeps,
    )
    # the certified bound holds against an independent value iteration, allowing for the
    # reference's own error (its residual / (1 - lambda): the bound is nearly tight here)
    ref = reference_solve(mdp)
    ref_err = np.abs(reference_bellman(mdp, ref).max(axis=1) - ref).max() / (1 - mdp.discount)
    assert np.abs(a.values - ref).max() <= a.error_bound + 1.01 * ref_err + 1e-13
    check_dp(a, mdp, f"{method} numpy")
    check_dp(b, mdp, f"{method} compiled")


def test_numpy_post_decision_form_equals_compiled(monkeypatch):
    mdp = post_decision_mdp(500, 3, 4, 0.9, seed=5, allowed_fraction=0.6)

    def run():
        m = fresh(mdp)
        ps = post_decision_rows(m)
        res = lb.solve_exact(m, "mpi")
        ev = lb.evaluate_policy(m, res.policy, method="iterative")
        return ps, res, ev, lb.bellman_residual(m, res.values)

    (pa, ra, ea, da), (pb, rb, eb, db) = (
        on_path(monkeypatch, p, run) for p in ("numpy", "compiled")
    )
    assert pa is not None and pb is not None
    assert np.array_equal(pa.first, pb.first) and np.array_equal(pa.outcomes, pb.outcomes)
    assert np.array_equal(pa.reward_table[pa.reward_codes], pb.reward_table[pb.reward_codes])
    assert np.array_equal(bits(ra.values), bits(rb.values))
    assert np.array_equal(ra.policy_rows, rb.policy_rows)
    assert (ra.residual, ra.error_bound) == (rb.residual, rb.error_bound)
    assert np.array_equal(bits(ea.values), bits(eb.values)) and ea.residual == eb.residual
    assert da == db
    assert da == pytest.approx(ra.residual, rel=0, abs=1e-13)  # measured on u + c, not u
    check_dp(ra, mdp, "mpi")
    check_evaluation(ea, mdp, ra.policy, "iterative evaluation")


def test_numpy_twins_of_the_helper_kernels_equal_compiled():
    rng = np.random.default_rng(3)
    succ = rng.integers(-2, 12, size=(9, 3, 4))
    allow = rng.random((9, 3)) < 0.6
    assert _npkernels.check_successors(succ, allow, 10) == native.check_successors(succ, allow, 10)
    owner = rng.integers(0, 50, size=200).astype(np.int32)
    action = rng.integers(0, 4, size=200).astype(np.int32)
    targets = rng.integers(0, 50, size=(200, 3)).astype(np.int32)
    pbits = rng.random((200, 3)).view(np.int64)
    h1, h2 = np.empty(200, dtype=np.uint64), np.empty(200, dtype=np.uint64)
    _npkernels.hash_rows(owner, action, targets, pbits, h1)
    _kernels.hash_rows(owner, action, targets, pbits, h2)
    assert np.array_equal(h1, h2)
    reward = rng.integers(0, 20, size=(30, 3)) * 0.1
    for max_codes in (5, 256):
        got = []
        for kern in (_npkernels, _kernels):
            codes = np.empty(reward.shape, dtype=np.uint16)
            table = np.empty(max_codes)
            count = kern.reward_codes(reward, max_codes, codes, table)
            got.append(count)
            if count > 0:
                assert np.array_equal(table[codes], reward)
        assert got[0] == got[1] == (-1 if max_codes == 5 else len(np.unique(reward)))


@settings(
    max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    n=st.integers(1, 40),
    a=st.integers(1, 4),
    ll=st.integers(1, 5),
    m=st.integers(1, 8),
    lam=st.sampled_from([0.0, 0.5, 0.9]),
    shared=st.booleans(),
    seed=st.integers(0, 10_000),
)
def test_property_numpy_equals_compiled(monkeypatch, n, a, ll, m, lam, shared, seed):
    mdp = masked_mdp(n, a, ll, lam, seed, shared)
    part = lb.random_partition(n, min(m, n), seed=seed)
    v = np.random.default_rng(seed).normal(size=n)

    def run():
        m_ = fresh(mdp)
        rows = lb.BellmanRows.aggregate(m_, part, reduce="max")
        return rows, lb.solve_exact(m_), rows.apply_max(v[: part.n_partitions])

    (ra, sa, ta), (rb, sb, tb) = (on_path(monkeypatch, p, run) for p in ("numpy", "compiled"))
    assert_rows_identical(ra, rb)
    assert np.array_equal(bits(sa.values), bits(sb.values)) and sa.residual == sb.residual
    check_dp(sa, mdp, "mpi")
    assert np.array_equal(bits(ta[0]), bits(tb[0])) and np.array_equal(ta[1], tb[1])


def test_no_kernel_compiles_or_announces_a_compile(monkeypatch, caplog):
    """The kernels are C, built at install: no call, small or split over the threads, compiles
    anything or says so (numba's kernels announced their first compile once per group)."""
    use_path(monkeypatch, "compiled")
    with caplog.at_level("WARNING", logger="lpbounds"):
        mdp = lb.garnet(30, 2, 3, 0.9, seed=1)
        for _ in range(3):
            lb.solve_exact(exact_rows(fresh(mdp)))  # the row sweeps
            lb.BellmanRows.from_mdp(mdp).q_values(np.zeros(30))  # the row kernels
            agg = lb.BellmanRows.aggregate(mdp, lb.random_partition(30, 4, seed=1), "min")
            agg.apply_maxmin(np.zeros(4))  # the aggregation kernels and the game operator
            lb.solve_exact(post_decision_mdp(40, 2, 3, 0.9, seed=2))  # the post-decision form
        lb.solve_exact(lb.garnet(30, 2, 3, 0.9, seed=1))
    assert not caplog.records, [r.getMessage() for r in caplog.records]


# ---------------------------------------------------------------------- thread choice
def _two_threads():
    """The kernels' thread count (:mod:`lpbounds._kernels.threads`), when there are two CPUs."""
    if threads.default_threads() < 2:
        pytest.skip("one CPU here")
    return threads


@pytest.mark.parametrize("form", ["post-decision", "rows"])
@pytest.mark.parametrize("method", ["mpi", "vi"])
def test_thread_choice_changes_no_number(monkeypatch, form, method):
    """Calibrated threads (re-timed every sweep), one thread and two give identical results."""
    pool = _two_threads()
    from lpbounds import dp
    from lpbounds.dp import threads as dp_threads  # where ThreadChoice reads the threshold

    use_path(monkeypatch, "compiled")  # every sweep split over the threads
    monkeypatch.setattr(dp_threads, "SERIAL_SWEEP_READS", 0)  # the choice runs on this model
    monkeypatch.setattr(dp.ThreadChoice, "RECHECK", 1)  # and switches as often as it can
    mdp = PatrolModel(PatrolParams(N=6, stations=(0, 3), Gamma=4)).mdp()
    model = mdp if form == "post-decision" else exact_rows(mdp)
    before = pool.get_threads()
    results = []
    for k in (2, 1, 2):
        pool.set_threads(k)
        try:
            results.append(lb.solve_exact(model, method, tol=1e-6))
        finally:
            pool.set_threads(before)
    for r in results[1:]:
        np.testing.assert_array_equal(r.values, results[0].values)
        np.testing.assert_array_equal(r.policy, results[0].policy)
        assert r.history == results[0].history
    assert pool.get_threads() == before  # restored


def test_thread_choice_follows_the_timings(monkeypatch):
    pool = _two_threads()
    from lpbounds import dp
    from lpbounds.dp import threads as dp_threads  # where ThreadChoice reads the threshold

    monkeypatch.setattr(dp_threads, "SERIAL_SWEEP_READS", 0)
    before = pool.get_threads()
    pool.set_threads(2)
    try:
        rows = exact_rows(lb.garnet(20, 2, 2))
        for fast, slow in ((1, 2), (2, 1)):
            ch = dp.ThreadChoice(rows)
            assert ch.many == 2
            n_cal = ch.n_calibrate
            for i in range(n_cal):
                k = ch.start("max")
                assert k == (1 if i == 1 else 2)  # sweep 0 untimed, one sample on 1 thread
                ch.stop("max", k, 1.0 if k == fast else 3.0)
            assert ch.chosen["max"] == fast
            # another kind adopts the choice instead of paying for its own samples
            kp = ch.start("policy")
            assert kp == fast
            ch.stop("policy", kp, 1.0)
            for _ in range(n_cal, ch.RECHECK):  # no recheck before RECHECK sweeps
                k = ch.start("max")
                assert k == fast and pool.get_threads() == fast
                ch.stop("max", k, 1.0)
            k = ch.start("max")  # the recheck: the other count, once
            assert k == slow
            ch.stop("max", k, 1.5)  # slower: kept as it was
            assert ch.chosen["max"] == fast
            for _ in range(ch.RECHECK - 1):
                ch.stop("max", ch.start("max"), 1.0)
            k = ch.start("max")
            assert k == slow
            ch.stop("max", k, 0.4)  # much faster: switched, for this kind only
            assert ch.chosen["max"] == slow and ch.chosen["policy"] == fast
            ch.restore()
            assert pool.get_threads() == 2
        # all threads only when clearly faster (PREFER): 10% is not enough
        ch = dp.ThreadChoice(rows)
        for _ in range(ch.n_calibrate):
            k = ch.start("policy")
            ch.stop("policy", k, 0.9 if k == 2 else 1.0)
        assert ch.chosen["policy"] == 1 and ch.start("max") == 1
        ch.restore()
        # one slow sweep of the chosen count does not flip the choice (median of three)
        ch = dp.ThreadChoice(rows)
        for _ in range(ch.n_calibrate):
            k = ch.start("max")
            ch.stop("max", k, 1.0 if k == 2 else 3.0)
        for i in range(ch.n_calibrate, ch.RECHECK):
            k = ch.start("max")
            ch.stop("max", k, 5.0 if i == ch.RECHECK - 1 else 1.0)
        k = ch.start("max")
        assert k == 1
        ch.stop("max", k, 3.0)  # faster than the last sweep (5.0), not than the median
        assert ch.chosen["max"] == 2
        ch.restore()
    finally:
        pool.set_threads(before)


# ---------------------------------------------------------------------- packed policy rows
@pytest.mark.usefixtures("kernel_path")
@settings(
    max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    n=st.integers(1, 50),
    a=st.integers(1, 4),
    ll=st.integers(1, 4),
    shared=st.booleans(),
    frac=st.sampled_from([1.0, 0.5]),
    seed=st.integers(0, 10_000),
)
def test_property_packed_sweep_equals_the_in_place_sweep(n, a, ll, shared, frac, seed):
    """MPI's evaluation sweeps run on the policy's rows gathered into contiguous arrays
    (rows.PackedSweeps); each row is computed as by the in-place sweep, so the numbers are
    the same bit for bit, shared or per-row probabilities, with masks, policy changed
    between sweeps (the gather reuses its buffers)."""
    from lpbounds.rows import PackedSweeps

    mdp = lb.garnet(n, a, ll, 0.9, seed=seed, shared_probabilities=shared, allowed_fraction=frac)
    rows = exact_rows(mdp)
    rng = np.random.default_rng(seed)
    packed = rows.evaluator()
    assert isinstance(packed, PackedSweeps)
    assert packed.shared == shared or ll == 1  # one outcome: every row's probability is 1
    for _ in range(2):  # a second policy into the same buffers
        counts = np.diff(rows.indptr)
        sel = rows.indptr[:-1] + (rng.random(n) * counts).astype(np.int64)
        v = rng.normal(size=n)
        want = np.empty(n)
        lo, hi = rows.sweep_policy(sel, v, want)
        packed.set_policy(sel)
        got = np.empty(n)
        assert packed.sweep(v, got) == (lo, hi)
        assert np.array_equal(got, want)
