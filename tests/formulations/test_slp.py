"""SLP (eq. 12): surrogate rows, the reduced MDP of Theorem 1's proof, hard aggregation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.formulations import ELP, RLP, SLP
from tests import _independent as ind
from tests.conftest import reference_solve

from ._reference import hard_aggregation_reference, rlp_reference


def _reduced_by_loops(mdp: lb.FiniteMDP, part: lb.Partition, mu: np.ndarray):
    """r_u(i) and P-tilde_u(i, j) of step 2, by plain loops over (i, u, x, l)."""
    m, n_act = part.n_partitions, mdp.n_actions
    p = mdp.probabilities_full()
    r = np.zeros((m, n_act))
    pt = np.zeros((m, n_act, m))
    used = np.zeros((m, n_act), dtype=bool)
    for i in range(m):
        for u in range(n_act):
            xs = part.members(i)
            tot = sum(mu[x, u] for x in xs)
            if tot <= 0:
                continue
            used[i, u] = True
            for x in xs:
                h = mu[x, u] / tot
                r[i, u] += h * mdp.rewards[x, u]
                for l in range(mdp.n_outcomes):
                    pt[i, u, part.labels[mdp.successors[x, u, l]]] += h * p[x, u, l]
    return r, pt, used


def _check_slp(mdp, part, mu, form, res):
    """SLP(mu)'s bracket against the reduced MDP of the loops above (its exact LP): contains
    the reduced MDP's V*, as narrow as the point's residual allows, OPTIMAL within accuracy."""
    r, pt, used = _reduced_by_loops(mdp, part, mu)
    P = np.transpose(pt, (1, 0, 2))  # (A, M, M)
    # the surrogate rows are sums over a partition's states: their rounding widens the
    # certificate to eq. 12's exact rows (SLP.row_rounding)
    terms = int(part.sizes.max()) * (mdp.n_outcomes + 1)
    return ind.check_mdp_lp(res, "ELP", P, r, used, mdp.discount, cost=form.c, what="SLP",
                            row_terms=terms)  # fmt: skip


def _check_rlp(mdp, part, res, cost=None):
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    return ind.check_mdp_lp(
        res, "RLP", P, mdp.rewards, mdp.allowed, mdp.discount, labels=part.labels, cost=cost
    )


def test_reduced_mdp_matches_step_2_by_loops():
    mdp = lb.garnet(25, 3, 3, 0.85, seed=8, allowed_fraction=0.7)
    part = lb.random_partition(25, 5, seed=2)
    mu = np.random.default_rng(1).uniform(0, 1, (25, 3)) * mdp.allowed
    mu[mu < 0.3] = 0.0  # some pairs, and perhaps some (i, u), get no weight
    slp = SLP(mdp, part, mu)
    red = slp.reduced_mdp()
    r, pt, used = _reduced_by_loops(mdp, part, mu)
    assert np.array_equal(red.allowed, used), "U_i = {u : sum_x mu_u^i(x) > 0}"
    assert np.allclose(red.rewards[used], r[used], atol=1e-12), "r_u(i)"
    dense = np.zeros_like(pt)
    p = red.probabilities_full()
    for i, u in np.argwhere(used):
        np.add.at(dense[i, u], red.successors[i, u], p[i, u])
    assert np.allclose(dense[used], pt[used], atol=1e-12), "P-tilde_u(i, j)"
    # SLP's LP is the exact LP of the reduced MDP: same optimum for any cost
    res = slp.solve()
    assert np.allclose(res.values, ELP(red).solve().values, atol=1e-8)
    assert _check_slp(mdp, part, mu, slp, res) == "optimal"
    assert np.allclose(slp.fixed_point(), reference_solve(red), atol=1e-8)


def test_unnormalised_rows_of_eq_12_are_satisfied_by_fixed_point():
    """eq. 12 exactly: sum_x mu v(i) >= sum_x mu [R + lam sum_l p_l v(f-bar)] at the optimum."""
    mdp = lb.garnet(20, 2, 2, 0.9, seed=3)
    part = lb.random_partition(20, 4, seed=3)
    mu = np.random.default_rng(2).uniform(0.5, 3.0, (20, 2))
    w = SLP(mdp, part, mu).fixed_point()
    p = mdp.probabilities_full()
    q = mdp.rewards + mdp.discount * (p * w[part.labels[mdp.successors]]).sum(axis=2)
    for i in range(part.n_partitions):
        xs = part.members(i)
        lhs = (mu[xs] * w[i]).sum(axis=0)
        rhs = (mu[xs] * q[xs]).sum(axis=0)
        assert (lhs - rhs).min() >= -1e-8, f"eq. 12 violated at partition {i}"
        assert np.isclose((lhs - rhs).min(), 0, atol=1e-7), "some row of i must be tight"


def test_hard_aggregation_is_not_a_bound():
    """Remark 1: mu uniform = hard aggregation; on this instance it is below V* somewhere."""
    mdp = lb.garnet(60, 3, 3, 0.9, seed=7)
    part = lb.random_partition(60, 6, seed=11)
    vstar = reference_solve(mdp)
    slp = SLP(mdp, part, "uniform")
    w = slp.fixed_point()
    assert np.allclose(w, hard_aggregation_reference(mdp, part), atol=1e-8)
    res = slp.solve()
    assert np.allclose(res.values, w, atol=1e-7)
    assert _check_slp(mdp, part, slp.mu, slp, res) == "optimal"
    gap = (part.lift(w) - vstar).min()
    assert gap < -0.1, f"expected Phi w < V* somewhere (min gap {gap:.3g})"
    # ... while RLP is a bound, and SLP(mu) <= RLP for any mu (a relaxation)
    vref = rlp_reference(mdp, part)
    assert (part.lift(vref) - vstar).min() >= -1e-9
    assert (w - vref).max() <= 1e-9


def test_zero_cost_unreachable_partition_gets_no_dual_weight():
    """The gap in step 1 of the proof: c-bar(i) = 0 and nothing leads to i -> no row for i."""
    succ = np.array([[[0]], [[1]], [[0]]])  # state 2 -> 0; nothing enters state 2
    mdp = lb.FiniteMDP(succ, [1.0], np.array([[1.0], [2.0], [0.5]]), 0.9)
    part = lb.Partition([0, 1, 2])
    res = RLP(mdp, part, cost=[1.0, 1.0, 0.0]).solve("HIGHS")
    assert res.mu[2, 0] == 0.0
    assert _check_rlp(mdp, part, res, cost=[1.0, 1.0, 0.0]) == "optimal"
    with pytest.raises(ValidationError, match="partition 2"):
        SLP.from_rlp(res)
    # with a positive cost every partition gets weight and Lemma 2 holds
    res = RLP(mdp, part).solve("HIGHS")
    assert np.allclose(SLP.from_rlp(res).fixed_point(), rlp_reference(mdp, part), atol=1e-9)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(2, 25),
    n_act=st.integers(1, 3),
    branching=st.integers(1, 3),
    seed=st.integers(0, 10_000),
    data=st.data(),
)
def test_lemma_2_on_random_mdps(n, n_act, branching, seed, data):
    m = data.draw(st.integers(1, n))
    mdp = lb.garnet(n, n_act, branching, 0.8, seed=seed, allowed_fraction=0.8)
    part = lb.random_partition(n, m, seed=seed + 1)
    cost = np.random.default_rng(seed).uniform(0.1, 1.0, n)
    res = RLP(mdp, part, cost).solve("HIGHS")
    assert _check_rlp(mdp, part, res, cost) == "optimal"
    vref = rlp_reference(mdp, part)
    slp = SLP.from_rlp(res)
    tol = 1e-6 * max(1.0, np.abs(vref).max())
    assert np.abs(slp.fixed_point() - vref).max() <= tol, "reduced MDP value != v*"
    sres = slp.solve("HIGHS")  # Lemma 2 as an LP: SLP(mu-bar)'s certified bracket holds v*
    assert _check_slp(mdp, part, slp.mu, slp, sres) == "optimal"
    assert (sres.lower_values <= vref + tol).all() and (vref - tol <= sres.upper_values).all()
    # any mu >= 0 gives a relaxation: its value is <= v*
    mu = np.random.default_rng(seed + 2).uniform(0.0, 1.0, (n, n_act)) * mdp.allowed
    assert (SLP(mdp, part, mu).fixed_point() - vref).max() <= tol


# ---------------------------------------------------------------------- bad input
@pytest.fixture
def tiny():
    return lb.garnet(6, 2, 2, 0.9, seed=1), lb.random_partition(6, 2, seed=1)


@pytest.mark.parametrize(
    ("mu", "match"),
    [
        (np.ones((6, 3)), "shape"),
        (np.ones(6), "shape"),
        (-np.ones((6, 2)), "negative"),
        (np.full((6, 2), np.nan), "not finite"),
        ("hard", "uniform"),
    ],
)
def test_bad_mu(tiny, mu, match):
    mdp, part = tiny
    with pytest.raises(ValidationError, match=match):
        SLP(mdp, part, mu)


def test_mu_on_disallowed_pair_and_empty_partition():
    mdp = lb.garnet(6, 2, 2, 0.9, seed=1, allowed_fraction=0.5)
    part = lb.random_partition(6, 2, seed=1)
    x = int(np.flatnonzero(~mdp.allowed[:, 1])[0])
    mu = np.zeros((6, 2))
    mu[x, 1] = 1.0
    with pytest.raises(ValidationError, match="not allowed"):
        SLP(mdp, part, mu)
    mu = mdp.allowed * 1.0
    mu[part.members(1)] = 0.0
    with pytest.raises(ValidationError, match="partition 1"):
        SLP(mdp, part, mu)


def test_bad_cost_and_from_non_rlp(tiny):
    mdp, part = tiny
    with pytest.raises(ValidationError, match="negative"):
        SLP(mdp, part, "uniform", cost=-np.ones(6))
    with pytest.raises(ValidationError, match="length 6"):
        SLP(mdp, part, "uniform", cost=np.ones(5))
    with pytest.raises(ValidationError, match="RLP"):
        SLP.from_rlp(ELP(mdp).solve())
    with pytest.raises(ValidationError, match="states"):
        SLP(mdp, lb.random_partition(5, 2), "uniform")
