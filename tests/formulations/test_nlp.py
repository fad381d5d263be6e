"""Tests of the disjunctive lower-bound program NLP (paper eq. 25) and its four methods.

The reference is a deliberately simple loop written here from the paper's eq. 25: value
iteration on ``w(i) = max_u min_{x in S_i} [R_u(x) + lambda sum_l p_l w(f-bar(x,u,Y_l))]``
over the *states* of each partition (no merging of rows, no package kernels). ``V*`` comes
from dense policy iteration in ``tests/_independent`` (numpy only), and every result's
certified bracket is checked both ways there (contains ``w*``, no wider than its residual).
"""

from __future__ import annotations

import itertools
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lpbounds.errors import ConvergenceError, SolverNotInstalledError, ValidationError
from lpbounds.formulations import NLP
from lpbounds.formulations.nlp.cuts import (
    CutGeneratingLP,
    NLPMaster,
    cglp_data,
    highs_solve,
    master_data,
)
from lpbounds.model.generators import garnet, random_partition
from lpbounds.model.partition import Partition
from lpbounds.status import Status
from tests import _independent as ind

#: methods that must agree with the reference to this (relative to max(1, max|w*|))
AGREE_RTOL = 1e-9
#: slack of "bracket contains c'w*": the reference's own error (~1e-12 relative) plus rounding
BRACKET_RTOL = 1e-9


def reference_w(mdp, partition, tol_rel: float = 1e-14) -> np.ndarray:
    """Eq. 25's fixed point by plain loops over partitions, actions and member states.

    A state of ``S_i`` at which ``u`` is forbidden has the term ``R_u(x) = -inf``, so the
    min over ``S_i`` is ``-inf`` and ``(i, u)`` constrains nothing.
    """
    labels = partition.labels
    m = partition.n_partitions
    probs = mdp.probabilities_full()
    lam = mdp.discount
    members = [np.flatnonzero(labels == i) for i in range(m)]
    scale = np.abs(mdp.rewards).max() / (1 - lam)
    w = np.zeros(m)
    for _ in range(20_000):
        new = np.empty(m)
        for i in range(m):
            best_u = -np.inf
            for u in range(mdp.n_actions):
                worst = np.inf
                for x in members[i]:
                    if not mdp.allowed[x, u]:
                        worst = -np.inf  # u forbidden at x: R_u(x) = -inf, the min is -inf
                        break
                    q = mdp.rewards[x, u]
                    for k, p in zip(mdp.successors[x, u], probs[x, u], strict=True):
                        q += lam * p * w[labels[k]]
                    worst = min(worst, q)
                best_u = max(best_u, worst)
            new[i] = best_u
        diff = np.abs(new - w).max()
        w = new
        if diff <= tol_rel * scale * (1 - lam):
            return w
    raise AssertionError("reference value iteration did not converge")


def check_result(mdp, part, r, ref=None) -> str:
    """The result's certified bracket on w* both ways (tests/_independent.check_nlp): it
    contains w* (``ref``, with the loops' own error, or computed there), is no wider than
    the point's residual allows and, OPTIMAL, within ``gap_rtol`` of the scale."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    opt = None
    if ref is not None:  # reference_w stops at 1e-14 of the scale: its error is below 1e-13
        opt = ind.Reference(ref, 1e-13 * np.abs(mdp.rewards).max() / (1 - mdp.discount))
    return ind.check_nlp(
        r, P, mdp.rewards, mdp.allowed, mdp.discount, part.labels, optimum=opt, what=r.method
    )


def instance(n: int, a: int, l_out: int, m: int, seed: int):
    mdp = garnet(n, a, l_out, 0.9, seed=seed)
    return mdp, random_partition(n, m, seed=seed)


SMALL = [(8, 2, 2, 3, 0), (12, 3, 2, 4, 1), (20, 2, 3, 5, 2), (30, 3, 3, 6, 3)]


# ---------------------------------------------------------------------- exact methods
@pytest.mark.parametrize("spec", SMALL, ids=lambda s: "n{}-A{}-L{}-M{}-s{}".format(*s))
def test_exact_methods_agree_with_reference_and_bound_v_star(spec):
    mdp, part = instance(*spec)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    tol = AGREE_RTOL * max(1.0, np.abs(ref).max())
    methods = ("fixed-point", "strategy-iteration") + (("milp",) if spec[0] <= 20 else ())
    results = {m: nlp.solve(m) for m in methods}
    for method, r in results.items():
        err = np.abs(r.values - ref).max()
        assert err <= tol, f"{method}: max|w - w_ref| = {err:.2e} > {tol:.1e}"
        assert r.converged, f"{method} did not converge: {r.stop_reason}"
        opt = float(nlp.cost @ ref)
        slack = BRACKET_RTOL * max(1.0, abs(opt))
        assert r.lower_bound - slack <= opt <= r.upper_bound + slack, (
            f"{method}: bracket [{r.lower_bound}, {r.upper_bound}] misses c'w* = {opt}"
        )
        np.testing.assert_allclose(r.state_values, ref[part.labels], rtol=0, atol=tol)
        assert check_result(mdp, part, r, ref) == "optimal", method
    # w*(i) <= min over S_i of V* (exact DP), and the certified lower_values too
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    v_star = ind.policy_iteration(P, mdp.rewards, mdp.allowed, mdp.discount).values
    vmin = part.aggregate(v_star, "min")
    slack = 1e-9 * max(1.0, np.abs(v_star).max())
    w = results["strategy-iteration"]
    assert (w.values <= vmin + slack).all(), f"w* - min V*: {(w.values - vmin).max():.2e} > 0"
    assert (w.lower_values <= ref + slack).all(), "lower_values exceed w*"


def test_singleton_partition_gives_v_star():
    """With one state per partition every disjunction has one term: w* = V* (exact DP)."""
    mdp = garnet(12, 3, 2, 0.9, seed=11)
    part = Partition(np.arange(12))
    nlp = NLP(mdp, part)
    assert (nlp.disj_size == 1).all()
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    ref = ind.policy_iteration(P, mdp.rewards, mdp.allowed, mdp.discount)
    v_star = ref.values
    tol = AGREE_RTOL * max(1.0, np.abs(v_star).max())
    for method in ("fixed-point", "strategy-iteration", "milp", "cutting-planes"):
        r = nlp.solve(method)
        assert np.abs(r.values - v_star).max() <= tol, f"{method}: w* != V* on singletons"
        assert r.converged, r.summary()
        assert ind.check_nlp(r, P, mdp.rewards, mdp.allowed, 0.9, part.labels,
                             optimum=ref, what=method) == "optimal"  # fmt: skip


def test_disallowed_actions():
    """(i, u) counts only if u is allowed at every state of S_i (reference: -inf term)."""
    mdp = garnet(15, 3, 2, 0.9, seed=5, allowed_fraction=0.6)
    part = random_partition(15, 4, seed=5)
    ref = reference_w(mdp, part)
    nlp = NLP(mdp, part)
    tol = AGREE_RTOL * max(1.0, np.abs(ref).max())
    for method in ("fixed-point", "strategy-iteration", "milp"):
        r = nlp.solve(method)
        err = np.abs(r.values - ref).max()
        assert err <= tol, f"{method}: {err:.2e}"
        assert check_result(mdp, part, r, ref) == "optimal", method
    r = nlp.solve("cutting-planes", cuts="lift-and-project", max_iter=30)
    _check_bracket_every_round(nlp, r, ref)
    check_result(mdp, part, r, ref)  # whatever status 30 rounds reach


def test_strategy_iteration_upper_bounds_decrease():
    mdp, part = instance(30, 3, 3, 6, 3)
    r = NLP(mdp, part).solve("strategy-iteration")
    ups = [e.upper for e in r.log]
    assert all(b <= a + 1e-12 * max(1.0, abs(a)) for a, b in itertools.pairwise(ups)), (
        f"strategy-iteration upper bounds increased: {ups}"
    )


def test_cost_independence():
    """w* is the least element (Fact 2): every c > 0 gives the same minimiser."""
    mdp, part = instance(10, 2, 2, 3, 1)
    ref = reference_w(mdp, part)
    rng = np.random.default_rng(7)
    tol = AGREE_RTOL * max(1.0, np.abs(ref).max())
    for _ in range(2):
        c = rng.uniform(0.1, 5.0, size=part.n_partitions)
        nlp = NLP(mdp, part, partition_cost=c)
        w = nlp.solve("milp").values  # the MILP's minimiser depends on c only if w* does
        assert np.abs(w - ref).max() <= tol, f"MILP minimiser changed with cost {c}"
        cp_res = nlp.solve("cutting-planes", max_iter=40)
        check_result(mdp, part, cp_res, ref)
        opt = float(c @ ref)
        slack = BRACKET_RTOL * max(1.0, abs(opt))
        assert cp_res.lower_bound <= opt + slack <= cp_res.upper_bound + 2 * slack
    # state weights: c-bar is their sum over each partition
    c_state = rng.uniform(0.5, 2.0, size=mdp.n_states)
    nlp = NLP(mdp, part, cost=c_state)
    np.testing.assert_allclose(nlp.cost, np.bincount(part.labels, weights=c_state))
    assert np.abs(nlp.solve("strategy-iteration").values - ref).max() <= tol


# ---------------------------------------------------------------------- cutting planes
def _check_bracket_every_round(nlp, r, ref):
    opt = float(nlp.cost @ ref)
    slack = BRACKET_RTOL * max(1.0, abs(opt))
    for e in r.log:
        assert e.lower <= opt + slack, (
            f"round {e.iteration}: lower bound {e.lower!r} > c'w* = {opt!r}: an invalid cut"
        )
        assert e.upper >= opt - slack, f"round {e.iteration}: upper bound {e.upper!r} < c'w*"
    # every cut is satisfied by w* (validity checked directly)
    alpha, beta = r.extra["cut_alpha"], r.extra["cut_beta"]
    if len(beta):
        lhs = alpha @ ref
        worst = float((beta - lhs).max())
        assert worst <= 1e-9 * max(1.0, np.abs(beta).max()), f"a cut cuts w* off by {worst:.2e}"


@pytest.mark.parametrize(
    "spec", [(8, 2, 2, 3, 0), (10, 2, 2, 3, 1)], ids=lambda s: f"n{s[0]}-s{s[4]}"
)
def test_cutting_planes_bracket_valid_every_round_and_closes(spec):
    mdp, part = instance(*spec)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    r = nlp.solve("cutting-planes", cuts="lift-and-project", max_iter=60)
    _check_bracket_every_round(nlp, r, ref)
    assert r.converged, f"expected convergence on this instance: {r.summary()}"
    assert r.gap <= r.gap_rtol * max(1.0, abs(r.upper_bound)), r.summary()
    assert r.cuts == sum(e.cuts_added for e in r.log)
    assert r.iterations == len(r.log)
    # converged by its own bracket on c'w*; the certificate of the returned incumbent
    check_result(mdp, part, r, ref)


@pytest.mark.parametrize("spec", [(15, 2, 2, 4, 0), (20, 3, 3, 5, 5)], ids=["n15-s0", "n20-s5"])
def test_cutting_planes_bracket_valid_on_harder_instances(spec):
    """25 rounds of 10 cuts on instances that need ~80-130 rounds: every cut stays valid."""
    mdp, part = instance(*spec)
    nlp = NLP(mdp, part)
    r = nlp.solve("cutting-planes", cuts="lift-and-project", max_iter=25)
    assert r.cuts > 25, f"expected many cuts; got {r.cuts}"
    _check_bracket_every_round(nlp, r, reference_w(mdp, part))
    # the lower bound never decreases (cuts only shrink the master)
    lows = [e.lower for e in r.log]
    assert all(b >= a for a, b in itertools.pairwise(lows)), lows


def test_cutting_planes_stop_at_round_limit_is_reported():
    """A run stopped at its round limit says so: ITERATION_LIMIT, bracket kept and valid."""
    mdp, part = instance(15, 2, 2, 4, 0)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    r = nlp.solve("cutting-planes", cuts="lift-and-project", max_iter=3, cuts_per_round=1)
    assert r.stop_reason == "max_rounds" and r.iterations == 3, r.summary()
    assert r.status is Status.ITERATION_LIMIT and not r.converged, r.summary()
    lo, hi = r.extra["method_bracket"]
    assert hi - lo > 1.0 and r.gap > 1.0, "the bracket is still open after 3 rounds"
    _check_bracket_every_round(nlp, r, ref)
    _check_certified(nlp, r, ref)
    assert check_result(mdp, part, r, ref) == "iteration_limit"
    with pytest.raises(ConvergenceError, match="NOT converged"):
        nlp.solve(
            "cutting-planes",
            cuts="lift-and-project",
            max_iter=3,
            cuts_per_round=1,
            raise_on_failure=True,
        )


def _check_certified(nlp, r, ref):
    """lower_values <= w* <= upper_values and the bracket on c'w* contains c'w* (ref's
    own error, ~1e-14 relative, is the only slack)."""
    slack = 1e-12 * max(1.0, np.abs(ref).max())
    assert (r.lower_values <= ref + slack).all(), f"{r.method}: lower_values above w*"
    assert (ref - slack <= r.upper_values).all(), f"{r.method}: upper_values below w*"
    opt = float(nlp.cost @ ref)
    s = slack * float(nlp.cost.sum())
    assert r.lower_bound <= opt + s and opt - s <= r.upper_bound, (r.lower_bound, opt)


@pytest.mark.parametrize("method", ["fixed-point", "strategy-iteration"])
def test_iteration_limit_keeps_a_certified_bracket(method):
    mdp, part = instance(30, 3, 3, 6, 3)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    r = nlp.solve(method, max_iter=1 if method == "strategy-iteration" else 3)
    assert r.status is Status.ITERATION_LIMIT and not r.converged, r.summary()
    assert r.stop_reason == "max_iter"
    assert r.gap > 1e-3, "one strategy / three sweeps do not close the bracket here"
    _check_certified(nlp, r, ref)
    assert check_result(mdp, part, r, ref) == "iteration_limit"  # wide, as its residual says
    full = nlp.solve(method)
    assert full.status is Status.OPTIMAL and full.converged, full.summary()
    _check_certified(nlp, full, ref)
    assert check_result(mdp, part, full, ref) == "optimal"
    # OPTIMAL means the certified bracket closed to gap_rtol in the problem's units
    assert full.relative_gap <= full.gap_rtol, full.relative_gap


@pytest.mark.parametrize("solver", ["HIGHS", "SCIPY"])
def test_milp_honours_time_limit(solver):
    """Without a limit this MILP ran 178 s (HiGHS, measured); time_limit=5 stops it."""
    mdp, part = instance(40, 3, 3, 8, 1)
    nlp = NLP(mdp, part)
    exact = nlp.solve("strategy-iteration")
    t0 = time.perf_counter()
    r = nlp.solve("milp", solver=solver, time_limit=5)
    elapsed = time.perf_counter() - t0
    assert elapsed <= 5 + 3, f"milp with time_limit=5 ran {elapsed:.1f} s"
    assert "time_limit" in r.stop_reason, r.summary()
    # the status is judged from the point: TIME_LIMIT, or OPTIMAL when the incumbent found
    # in time is certified optimal (HiGHS sometimes finds w*'s strategy within 5 s)
    assert r.status in (Status.TIME_LIMIT, Status.OPTIMAL), r.summary()
    if r.converged:
        assert r.relative_gap <= 1.01 * r.gap_rtol, r.summary()
    assert r.lower_bound <= exact.upper_bound and exact.lower_bound <= r.upper_bound
    assert (r.lower_values <= exact.upper_values).all()
    assert (exact.lower_values <= r.upper_values).all()
    assert check_result(mdp, part, exact) == "optimal"
    assert check_result(mdp, part, r) in ("time_limit", "optimal")


def test_each_method_accepts_only_its_keywords():
    mdp, part = instance(8, 2, 2, 3, 0)
    nlp = NLP(mdp, part)
    msg = "method 'milp' does not accept the keyword 'cuts_per_round'; it belongs to 'cutting"
    with pytest.raises(ValidationError, match=msg):
        nlp.solve("milp", cuts_per_round=3)
    with pytest.raises(ValidationError, match="'fixed-point' does not accept the keyword 'time_"):
        nlp.solve("fixed-point", time_limit=1.0)
    with pytest.raises(ValidationError, match=r"'strategy-iteration' does not accept .*'solver'"):
        nlp.solve("strategy-iteration", solver="HIGHS")
    with pytest.raises(ValidationError, match="does not accept the keyword 'verbose'"):
        nlp.solve("milp", verbose=True)  # solver options go in solver_options=
    with pytest.raises(ValidationError, match="time_limit must be a finite number"):
        nlp.solve("milp", time_limit=-1)
    with pytest.raises(ValidationError, match="solver_options must be a dict"):
        nlp.solve("milp", solver_options=["x"])
    with pytest.raises(ValidationError, match="supports the solvers HIGHS and SCIPY"):
        nlp.solve("milp", solver="CLARABEL", time_limit=1.0)
    r = nlp.solve("milp", solver_options={"mip_rel_gap": 1e-9})
    assert r.converged, r.summary()


def test_persistent_master_matches_cold_solves():
    """The persistent HiGHS master's value = a cold cvxpy solve of the same master (2 solvers)."""
    mdp, part = instance(15, 2, 2, 4, 0)
    nlp = NLP(mdp, part)
    r = nlp.solve("cutting-planes", cuts="lift-and-project", max_iter=8)
    k = r.extra["cuts_in_last_master"]
    a, b = nlp.term_matrix
    single = nlp.single_rows
    import scipy.sparse as sp

    g = sp.vstack([a[single], sp.csr_matrix(r.extra["cut_alpha"][:k])], format="csr")
    h = np.r_[b[single], r.extra["cut_beta"][:k]]
    m = nlp.rows.n_vars
    lo, hi = np.full(m, nlp.box[0]), np.full(m, nlp.box[1])
    persistent = r.extra["master_objective"]
    for solver in ("HIGHS", "CLARABEL"):
        cold = NLPMaster.build(nlp.cost, g, h, lo, hi).solve(solver)
        assert abs(cold.objective - persistent) <= 1e-6 * max(1.0, abs(persistent)), (
            f"{solver}: cold master {cold.objective!r} vs persistent {persistent!r}"
        )
    # the CGLP: highspy vs cvxpy on the same data
    wbar = r.extra["master_point"]
    d = int(np.flatnonzero(nlp.disj_size >= 2)[0])
    sl = slice(nlp.disj_start[d], nlp.disj_start[d + 1])
    data = cglp_data(wbar, g, h, lo, hi, a[sl], b[sl])
    hs = highs_solve(data)
    cv = CutGeneratingLP(data).solve("HIGHS")
    assert abs(hs.objective - cv.objective) <= 1e-9, (hs.objective, cv.objective)
    # and the master data helper agrees with itself through highspy
    hm = highs_solve(master_data(nlp.cost, g, h, lo, hi))
    assert abs(hm.objective - persistent) <= 1e-7 * max(1.0, abs(persistent))


def test_cvxpy_backend_gives_valid_bracket():
    mdp, part = instance(8, 2, 2, 3, 0)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    r = nlp.solve("cutting-planes", cuts="lift-and-project", backend="cvxpy", max_iter=4)
    _check_bracket_every_round(nlp, r, ref)
    assert r.solver.endswith("(cvxpy)")


def test_progress_bar_runs():
    mdp, part = instance(8, 2, 2, 3, 0)
    r = NLP(mdp, part).solve("strategy-iteration", progress=True)
    assert r.converged
    assert check_result(mdp, part, r) == "optimal"


# ---------------------------------------------------------------------- bad input
def test_bad_input_errors():
    mdp, part = instance(8, 2, 2, 3, 0)
    with pytest.raises(ValidationError, match=r"cost\[2\] = -1.0 is negative"):
        NLP(mdp, part, cost=np.r_[1.0, 1.0, -1.0, np.ones(5)])
    with pytest.raises(ValidationError, match="cost must have length 8"):
        NLP(mdp, part, cost=np.ones(7))
    with pytest.raises(ValidationError, match="partition_cost must have length 3"):
        NLP(mdp, part, partition_cost=np.ones(4))
    with pytest.raises(ValidationError, match="not both"):
        NLP(mdp, part, cost=np.ones(8), partition_cost=np.ones(3))
    with pytest.raises(ValidationError, match="the partition has 9 states"):
        NLP(mdp, Partition(np.zeros(9, dtype=int)))
    nlp = NLP(mdp, part)
    with pytest.raises(ValidationError, match="unknown NLP method 'simplex'"):
        nlp.solve("simplex")
    with pytest.raises(ValidationError, match="backend='highspy' solves with HiGHS"):
        nlp.solve("cutting-planes", cuts="lift-and-project", solver="CLARABEL")
    with pytest.raises(ValidationError, match="backend must be"):
        nlp.solve("cutting-planes", cuts="lift-and-project", backend="gurobi")
    with pytest.raises(ValidationError, match=r"backend must be one of .*'rows'.*'gurobi'"):
        nlp.solve("cutting-planes", backend="gurobi")
    with pytest.raises(ValidationError, match=r"cuts must be one of .*'balas'"):
        nlp.solve("cutting-planes", cuts="balas")
    with pytest.raises(ValidationError, match="resolve must be True or False; got 'yes'"):
        nlp.solve("cutting-planes", resolve="yes")
    with pytest.raises(ValidationError, match="cuts_per_round must be >= 1"):
        nlp.solve("cutting-planes", cuts="lift-and-project", cuts_per_round=0)
    with pytest.raises(ValidationError, match="max_iter must be an integer >= 1"):
        nlp.solve("strategy-iteration", max_iter=0)
    with pytest.raises(SolverNotInstalledError, match="unknown solver"):
        nlp.solve("milp", solver="NOSUCHSOLVER")


# ---------------------------------------------------------------------- property
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(2, 12),
    a=st.integers(1, 3),
    l_out=st.integers(1, 3),
    m_frac=st.floats(0.1, 1.0),
    seed=st.integers(0, 10_000),
    discount=st.sampled_from([0.5, 0.9, 0.95]),
)
def test_property_game_fixed_point_equals_milp(n, a, l_out, m_frac, seed, discount):
    mdp = garnet(n, a, l_out, discount, seed=seed, reward_range=(-1.0, 2.0))
    m = max(1, round(m_frac * n))
    part = random_partition(n, m, seed=seed + 1)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    tol = AGREE_RTOL * max(1.0, np.abs(ref).max())
    fp_res, milp_res = nlp.solve("fixed-point"), nlp.solve("milp")
    fp, milp = fp_res.values, milp_res.values
    assert check_result(mdp, part, fp_res, ref) == check_result(mdp, part, milp_res, ref)
    assert np.abs(fp - ref).max() <= tol, f"fixed point vs reference {np.abs(fp - ref).max():.2e}"
    assert np.abs(milp - ref).max() <= tol, f"milp vs reference {np.abs(milp - ref).max():.2e}"


def test_the_progress_text_never_shows_nan():
    """The progress bar's bracket before a method has an end: "-", not "[nan, ...]"."""
    from lpbounds.formulations.nlp.problem import progress_status
    from lpbounds.formulations.nlp.results import NLPIteration

    nan = float("nan")
    first = NLPIteration(iteration=0, lower=nan, upper=3.25, gap=nan, cuts_added=4, seconds=0.1)
    assert progress_status(first) == "it 0  [-, 3.25]  gap -  cuts +4"
    later = NLPIteration(iteration=3, lower=3.0, upper=3.25, gap=0.25, cuts_added=0, seconds=1.0)
    assert progress_status(later) == "it 3  [3, 3.25]  gap 2.50e-01"
