"""One battery for every LP formulation, run against HIGHS, CLARABEL and SCIPY.

In the style of scipy's ``LinprogCommonTests`` (one class, one solver per run) with
KKT checks of the returned primal and dual in the spirit of cvxpy's
``SolverTestHelper``: feasibility, dual sign, stationarity, complementarity, gap,
and every optimum against an independent exact reference.
"""

from __future__ import annotations

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.formulations import ALP, ELP, IB, LLP, RLP, SLP
from tests import _independent as ind
from tests.conftest import reference_solve

from ._reference import rlp_reference, transition_rows

SOLVERS = ["HIGHS", "CLARABEL", "SCIPY"]
RTOL = 1e-6  # LP_COMPARE_RTOL: interior point solvers stop near 1e-8 relative


def _tol(ref: np.ndarray) -> float:
    return RTOL * max(1.0, float(np.abs(ref).max()))


@pytest.fixture(scope="module")
def model() -> tuple[lb.FiniteMDP, lb.Partition, np.ndarray, np.ndarray]:
    mdp = lb.garnet(30, 3, 3, 0.9, seed=21, allowed_fraction=0.8)
    part = lb.random_partition(30, 6, seed=4)
    return mdp, part, reference_solve(mdp), rlp_reference(mdp, part)


def _certified(mdp, res, kind, **kw) -> None:
    """The bracket both ways (tests/_independent): it contains the exact optimum computed
    there, is as narrow as the point's residual allows and, OPTIMAL, within the accuracy."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    status = ind.check_mdp_lp(res, kind, P, mdp.rewards, mdp.allowed, mdp.discount, **kw)
    assert status == "optimal", status  # solve() raises otherwise


def _kkt(form, res, tol: float) -> None:
    """Feasibility, y >= 0, A'y = c, y'(Ax - b) = 0 and c'x = b'y, recomputed here."""
    a, b, c = form.A, form.b, form.c
    ax = a @ res.x
    scale = max(1.0, float(np.abs(b).max()))
    assert (ax - b).min() >= -tol * scale, f"primal infeasible by {-(ax - b).min():.3e}"
    assert res.duals.min() >= 0.0, "duals of >= rows must be non-negative"
    stat = np.abs(a.T @ res.duals - c).max()
    assert stat <= 1e-6 * max(1.0, np.abs(c).max()), f"stationarity |A'y - c| = {stat:.3e}"
    comp = abs(res.duals @ (ax - b))
    assert comp <= 1e-5 * scale * max(1.0, c.sum()), f"complementarity y'(Ax-b) = {comp:.3e}"
    gap = abs(c @ res.x - b @ res.duals)
    assert gap <= 1e-5 * scale * max(1.0, c.sum()), f"duality gap {gap:.3e}"


@pytest.mark.parametrize("solver", SOLVERS)
class TestLPBattery:
    def test_elp_is_vstar_and_mu_is_occupation_measure(self, solver, model):
        mdp, _, vstar, _ = model
        cost = np.random.default_rng(0).uniform(0.1, 1.0, mdp.n_states)
        form = ELP(mdp, cost)
        res = form.solve(solver)
        assert np.abs(res.values - vstar).max() <= _tol(vstar), "ELP optimum != V* (Lemma 1)"
        _kkt(form, res, 1e-6)
        _certified(mdp, res, "ELP", cost=cost)
        # mu is the discounted state-action frequency from c: sum_u mu(x,u) -
        # lam sum_{x',u'} mu(x',u') P(x | x',u') = c(x)
        p, _, pairs = transition_rows(mdp)
        m = res.mu[pairs[:, 0], pairs[:, 1]]
        flow = res.mu.sum(axis=1) - mdp.discount * (p.T @ m)
        assert np.abs(flow - cost).max() <= 1e-6, "ELP duals are not the occupation measure"

    def test_rlp_equals_reference_and_mu_balances(self, solver, model):
        mdp, part, _, vref = model
        form = RLP(mdp, part)
        res = form.solve(solver)
        assert np.abs(res.values - vref).max() <= _tol(vref), "RLP optimum != loop reference"
        assert np.abs(form.fixed_point() - vref).max() <= 1e-9 * max(1, np.abs(vref).max())
        _kkt(form, res, 1e-6)
        _certified(mdp, res, "RLP", labels=part.labels)
        # the pair duals mu-bar satisfy the partition-level flow balance with c-bar
        p, _, pairs = transition_rows(mdp)
        m = res.mu[pairs[:, 0], pairs[:, 1]]
        inflow = (p @ part.basis).T @ m
        out = np.bincount(part.labels[pairs[:, 0]], weights=m, minlength=part.n_partitions)
        cbar = part.sizes.astype(float)
        assert np.abs(out - mdp.discount * inflow - cbar).max() <= 1e-6, "mu-bar flow balance"
        assert res.mu[~mdp.allowed].max(initial=0.0) == 0.0, "mu on disallowed pairs"

    def test_slp_from_rlp_duals_is_rlp(self, solver, model):
        mdp, part, _, vref = model
        res = RLP(mdp, part).solve(solver)
        slp = SLP.from_rlp(res)
        sres = slp.solve(solver)
        assert np.abs(sres.values - vref).max() <= _tol(vref), "SLP(mu-bar) != RLP (Lemma 2)"
        assert np.abs(slp.fixed_point() - vref).max() <= _tol(vref), "reduced MDP value != v*"
        red = lb.solve_exact(slp.reduced_mdp()).values
        assert np.abs(red - vref).max() <= _tol(vref)
        _kkt(slp, sres, 1e-6)
        _certified(mdp, res, "RLP", labels=part.labels)
        # SLP(mu-bar) is the exact LP of its reduced MDP (Lemma 2): bracket on its V* = v*
        red_mdp = slp.reduced_mdp()
        red = ind.dense_transitions(red_mdp.successors, red_mdp.probabilities_full())
        terms = int(part.sizes.max()) * (mdp.n_outcomes + 1)  # SLP.row_rounding's sums
        st = ind.check_mdp_lp(sres, "ELP", red, red_mdp.rewards, red_mdp.allowed, mdp.discount,
                              row_terms=terms)  # fmt: skip
        assert st == "optimal"
        # SLP's duals mapped back through h are again an optimal RLP dual: same objective
        rlp_obj = part.sizes @ vref
        dual_obj = (mdp.rewards * sres.mu)[mdp.allowed].sum()
        assert abs(dual_obj - rlp_obj) <= 1e-5 * max(1.0, abs(rlp_obj)), "mapped-back dual"

    @pytest.mark.parametrize("L", [1, 2, 4])
    def test_ib_blocks_are_vstar(self, solver, model, L):
        mdp, part, _, vref = model
        form = IB(mdp, part, L, cost=np.linspace(0.0, 1.0, mdp.n_states))
        res = form.solve(solver)
        blocks = res.extra["blocks"]
        assert blocks.shape == (L, part.n_partitions)
        assert (blocks - vref).min() >= -_tol(vref), "an IB block beats v* (Theorem 2)"
        assert np.abs(form.fixed_point() - vref).max() <= 1e-9 * max(1, np.abs(vref).max())
        _kkt(form, res, 1e-6)
        cost = np.linspace(0.0, 1.0, mdp.n_states)  # the cost of the form above
        _certified(mdp, res, "IB", labels=part.labels, cost=cost, n_blocks=L)

    def test_llp_never_beats_rlp(self, solver, model):
        mdp, part, _, vref = model
        rng = np.random.default_rng(3)
        d = rng.uniform(0, 2, (mdp.n_states, mdp.n_actions))
        res = LLP(mdp, part, d).solve(solver)
        assert (res.values - vref).min() >= -_tol(vref), "LLP beats RLP (eq. 18 remark)"
        z = res.extra["z"]
        assert z.min() >= -_tol(vref), "surplus variables must be >= 0"
        res0 = LLP(mdp, part, np.zeros_like(d)).solve(solver)
        assert np.abs(res0.values - vref).max() <= _tol(vref), "LLP with d = 0 must be v*"
        _certified(mdp, res, "LLP", labels=part.labels)
        _certified(mdp, res0, "LLP", labels=part.labels)

    def test_alp_partition_basis_is_rlp_and_soft_basis_matches_linprog(self, solver, model):
        from scipy.optimize import linprog

        mdp, part, vstar, vref = model
        res = ALP(mdp, part.basis.toarray()).solve(solver)
        assert np.abs(res.values - vref).max() <= _tol(vref), "ALP with 0/1 basis != RLP"
        _certified(mdp, res, "ALP")
        phi = lb.formulations.soft_aggregation_basis(mdp.n_states, 4, seed=2)
        cost = np.random.default_rng(5).uniform(0.1, 1, mdp.n_states)
        form = ALP(mdp, phi, cost)
        res = form.solve(solver)
        p, r, pairs = transition_rows(mdp)
        a = phi[pairs[:, 0]] - mdp.discount * (p @ phi)  # built independently of lpbounds
        ref = linprog(phi.T @ cost, A_ub=-a, b_ub=-r, bounds=(None, None), method="highs")
        assert ref.status == 0
        assert abs(res.objective - ref.fun) <= 1e-6 * max(1, abs(ref.fun)), "ALP objective"
        assert (res.state_values - vstar).min() >= -_tol(vstar), "Phi r must be >= V*"
        _kkt(form, res, 1e-6)
        _certified(mdp, res, "ALP", cost=cost)
