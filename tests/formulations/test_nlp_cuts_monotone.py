"""Monotone cuts and box resolution for the NLP.

Every round's master is checked at ``w*``: the certified lower point ``l`` and the upper
point ``h`` bracket it, and every master row (single-term rows, resolved rows, monotone
cuts, ``w >= l``) holds at ``w*``. ``w*`` comes from an independent plain-loop value
iteration of eq. 25 (no package code), checked against strategy iteration.
"""

from __future__ import annotations

import itertools

import cvxpy as cp
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lpbounds import FiniteMDP
from lpbounds.formulations import NLP
from lpbounds.formulations.nlp.cuts import highs_solve
from lpbounds.formulations.nlp.monotone import MonotoneMaster, monotone_cuts
from lpbounds.model.generators import garnet, random_partition
from lpbounds.model.partition import Partition
from lpbounds.status import Status
from tests import _independent as ind

#: slack of the checks at w*, relative to the problem's scale max|R| / (1 - lambda)
VALID_RTOL = 1e-9


def reference_w(mdp: FiniteMDP, part: Partition, tol_rel: float = 1e-14) -> np.ndarray:
    """Eq. 25's fixed point by plain loops (a state forbidding ``u`` makes (i, u) void)."""
    labels, m, lam = part.labels, part.n_partitions, mdp.discount
    probs = mdp.probabilities_full()
    members = [np.flatnonzero(labels == i) for i in range(m)]
    scale = np.abs(mdp.rewards).max() / (1 - lam)
    w = np.zeros(m)
    for _ in range(50_000):
        new = np.empty(m)
        for i in range(m):
            best = -np.inf
            for u in range(mdp.n_actions):
                if not mdp.allowed[members[i], u].all():
                    continue
                q = [
                    mdp.rewards[x, u] + lam * (probs[x, u] @ w[labels[mdp.successors[x, u]]])
                    for x in members[i]
                ]
                best = max(best, min(q))
            new[i] = best
        diff = np.abs(new - w).max()
        w = new
        if diff <= tol_rel * scale * (1 - lam):
            return w
    raise AssertionError("reference value iteration did not converge")


def masked_case(seed: int, n: int, a: int, l_out: int, m: int, allowed_p: float):
    """A random MDP with action masks and a partition whose parts share an action."""
    rng = np.random.default_rng(seed)
    succ = rng.integers(0, n, size=(n, a, l_out))
    probs = rng.dirichlet(np.ones(l_out))
    rewards = rng.uniform(-1.0, 1.0, size=(n, a))
    allowed = rng.random((n, a)) < allowed_p
    allowed[:, 0] = True  # every partition keeps action 0
    mdp = FiniteMDP(succ, probs, rewards, 0.9, allowed)
    labels = np.unique(rng.integers(0, m, size=n), return_inverse=True)[1].ravel()
    return mdp, Partition(labels)


def check_rounds(nlp: NLP, record, ref: np.ndarray) -> None:
    """``l <= w* <= h`` and every master row holds at ``w*``, in every round."""
    tol = VALID_RTOL * nlp.scale
    m = nlp.rows.n_vars
    for k, rnd in enumerate(record, 1):
        assert (rnd.lower <= ref + tol).all(), f"round {k}: l above w* by {(rnd.lower - ref).max()}"
        assert (rnd.new_lower <= ref + tol).all(), f"round {k}: the next l is above w*"
        assert (rnd.upper >= ref - tol).all(), f"round {k}: h below w* by {(ref - rnd.upper).max()}"
        q = rnd.rows.q_values(np.r_[ref, 0.0])
        own = rnd.rows.owner < m
        worst = float((q[own] - ref[rnd.rows.owner[own]]).max())
        assert worst <= tol, f"round {k}: a master row cuts w* off by {worst:.3e}"
        # the same master as an LP: w* satisfies it too
        lp = rnd.lp
        assert (lp.A @ ref - lp.row_lo).min() >= -tol, f"round {k}: an LP row cuts w* off"


def check_result(nlp: NLP, r, ref: np.ndarray | None = None) -> str:
    """The result's certified bracket on w* both ways (tests/_independent.check_nlp)."""
    mdp, part = nlp.mdp, nlp.partition
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    opt = None if ref is None else ind.Reference(ref, 1e-13 * nlp.scale)  # the loops' stop
    return ind.check_nlp(
        r, P, mdp.rewards, mdp.allowed, mdp.discount, part.labels, optimum=opt, what=r.method
    )


def garnet_case(n: int, m: int, seed: int):
    return garnet(n, 3, 3, 0.9, seed=seed), random_partition(n, m, seed=seed)


@pytest.mark.parametrize("resolve", [True, False], ids=["resolve", "cuts-only"])
@pytest.mark.parametrize("spec", [(30, 5, 0), (60, 8, 3)], ids=["n30", "n60"])
def test_bracket_and_rows_valid_every_round_and_closes(spec, resolve):
    mdp, part = garnet_case(*spec)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    record: list = []
    out = monotone_cuts(nlp, gap_rtol=1e-10, max_rounds=400, resolve=resolve, record=record)
    assert out.stop_reason == "gap closed", out.stop_reason
    check_rounds(nlp, record, ref)
    assert len(record) == out.rounds
    # the lower side rises monotonically and the final bracket is tight around w*
    lows = [e.lower for e in out.log]
    assert all(b >= a for a, b in itertools.pairwise(lows)), lows
    assert np.abs(out.lower_values - ref).max() <= 1e-9 * nlp.scale
    assert np.abs(out.upper_values - ref).max() <= 1e-9 * nlp.scale
    if resolve:  # the resolution rule makes the method finite in practice (docs/nlp.md)
        assert out.rounds < 80 and out.resolved > 0, (out.rounds, out.resolved)


def test_resolution_needs_fewer_rounds_than_cuts_alone():
    """Cuts alone converge like value iteration; resolution closes far sooner (garnet)."""
    nlp = NLP(*garnet_case(100, 10, 1))
    a = monotone_cuts(nlp, gap_rtol=1e-9, max_rounds=500, resolve=False)
    b = monotone_cuts(nlp, gap_rtol=1e-9, max_rounds=500, resolve=True)
    assert a.stop_reason == b.stop_reason == "gap closed"
    assert b.rounds < a.rounds / 2, (a.rounds, b.rounds)


case_args = dict(
    seed=st.integers(0, 10_000),
    n=st.integers(2, 14),
    a=st.integers(1, 3),
    l_out=st.integers(1, 3),
    m=st.integers(1, 5),
    allowed_p=st.floats(0.3, 1.0),
)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(masked=st.booleans(), **case_args)
def test_property_bracket_contains_w_star_every_round(masked, **kw):
    if not masked:
        kw["allowed_p"] = 1.0
    mdp, part = masked_case(**kw)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    record: list = []
    out = monotone_cuts(nlp, gap_rtol=1e-10, max_rounds=400, record=record)
    check_rounds(nlp, record, ref)
    assert out.stop_reason == "gap closed", out.stop_reason
    # through NLP.solve: equal to strategy iteration within the certificates
    r = nlp.solve("cutting-planes")
    si = nlp.solve("strategy-iteration")
    assert r.status is Status.OPTIMAL, r.summary()
    assert r.lower_bound <= si.upper_bound and si.lower_bound <= r.upper_bound
    assert (r.lower_values <= ref + 1e-9 * nlp.scale).all()
    assert (r.upper_values >= ref - 1e-9 * nlp.scale).all()
    assert check_result(nlp, r, ref) == check_result(nlp, si, ref) == "optimal"


@pytest.mark.parametrize("backend", ["highspy", "cvxpy"])
def test_lp_backends_follow_the_row_system(backend):
    """Solving each master as an LP gives the same rounds as the row-system solve."""
    nlp = NLP(*garnet_case(40, 6, 2))
    ref = reference_w(nlp.mdp, nlp.partition)
    rows_out = monotone_cuts(nlp, gap_rtol=1e-9, max_rounds=200)
    record: list = []
    lp_out = monotone_cuts(nlp, gap_rtol=1e-9, max_rounds=200, backend=backend, record=record)
    check_rounds(nlp, record, ref)
    assert lp_out.stop_reason == "gap closed"
    assert abs(lp_out.rounds - rows_out.rounds) <= 2, (lp_out.rounds, rows_out.rounds)


def test_row_system_master_matches_cold_cvxpy_master():
    """Every round's row-system least element = a cold solve of the master LP (2 solvers),
    and ``NLP.master`` after a solve is the last round's master."""
    nlp = NLP(*garnet_case(50, 7, 4))
    record: list = []
    monotone_cuts(nlp, gap_rtol=1e-9, max_rounds=200, record=record)
    tol = 1e-9 * nlp.scale
    for rnd in record[:: max(1, len(record) // 6)]:
        sol = highs_solve(rnd.lp)
        assert sol.status == "optimal"
        assert np.abs(sol.x - rnd.point).max() <= tol, np.abs(sol.x - rnd.point).max()
    res = nlp.solve("cutting-planes")
    assert check_result(nlp, res) == "optimal"
    master = nlp.master
    assert isinstance(master, MonotoneMaster)
    assert set(master.constraints) >= {"box_lower", "box_upper"}
    assert set(master.constraints) & {"resolved", "cuts"}
    master.problem.solve(solver="HIGHS")
    assert master.problem.status == cp.OPTIMAL
    # its optimum is c' of the last round's least element, below c'w* and near it
    last = res.log[-1].master_objective
    assert abs(master.problem.value - last) <= 1e-9 * nlp.scale * nlp.cost.sum()
    assert master.problem.value <= res.upper_bound


def test_solve_default_is_monotone_and_closes_on_a_garnet():
    """The default cutting planes close a 300-state, 30-partition garnet to 1e-9."""
    mdp, part = garnet_case(300, 30, 5)
    nlp = NLP(mdp, part)
    r = nlp.solve("cutting-planes", gap_rtol=1e-9)
    si = nlp.solve("strategy-iteration")
    assert r.extra["cut_family"] == "monotone"
    assert r.status is Status.OPTIMAL and r.stop_reason == "gap closed", r.summary()
    lo, hi = r.extra["method_bracket"]
    assert hi - lo <= 1e-9 * nlp.cost.sum() * nlp.scale
    assert lo <= si.upper_bound and si.lower_bound <= hi
    assert np.abs(r.values - si.values).max() <= 1e-9 * nlp.scale
    assert check_result(nlp, r) == check_result(nlp, si) == "optimal"
    assert r.upper_bound - r.lower_bound <= 1e-9 * nlp.cost.sum() * nlp.scale * (1 + 1e-6)


def test_round_limit_is_reported():
    nlp = NLP(*garnet_case(60, 8, 3))
    r = nlp.solve("cutting-planes", max_iter=2)
    assert r.iterations == 2 and r.stop_reason == "max_rounds"
    lo, hi = r.extra["method_bracket"]
    assert hi - lo > 1.0
    # the returned point's certificate: valid, as wide as its residual, honestly not OPTIMAL
    assert check_result(nlp, r) == "iteration_limit"


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cuts_match_a_dense_hand_computation(seed):
    """The first round's cuts, recomputed by plain loops: amin = min_k lambda P_k entrywise,
    right-hand side min_k f_k(l) - amin'l (small garnets, whose terms share successors)."""
    mdp, part = garnet(12, 2, 3, 0.9, seed=seed), random_partition(12, 2, seed=seed)
    nlp = NLP(mdp, part)
    record: list = []
    monotone_cuts(nlp, gap_rtol=1e-9, max_rounds=1, resolve=False, record=record)
    rnd, rows, m, lam = record[0], nlp.rows, nlp.rows.n_vars, nlp.rows.discount
    l = rnd.lower
    alphas, rhos = [], []
    for d in range(nlp.n_disjunctions):
        terms = range(nlp.disj_start[d], nlp.disj_start[d + 1])
        if len(terms) < 2:
            continue
        dense = np.zeros((len(terms), m))
        for k, t in enumerate(terms):
            for j, p in zip(rows.targets[t], np.asarray(rows.probs)[t], strict=True):
                dense[k, j] += lam * p
        f = [rows.reward[t] + dense[k] @ l for k, t in enumerate(terms)]
        amin = dense.min(axis=0)
        alpha = -amin
        alpha[nlp.disj_owner[d]] += 1.0
        alphas.append(alpha)
        rhos.append(min(f) - amin @ l)
    n0 = rnd.n_single + rnd.n_resolved
    got_a = rnd.lp.A[n0:].toarray()
    got_b = rnd.lp.row_lo[n0:]
    assert got_a.shape == (len(alphas), m)
    np.testing.assert_allclose(got_a, np.array(alphas), atol=1e-14)
    np.testing.assert_allclose(got_b, np.array(rhos), atol=1e-11 * nlp.scale)
    assert (got_b <= np.array(rhos) + 1e-15 * nlp.scale).all(), "the margin must lower rho"
    assert np.array(alphas)[:, :].min() < 0, "expected shared successors (amin > 0 somewhere)"
