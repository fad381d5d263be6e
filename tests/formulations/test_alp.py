"""ALP with a general basis (Remark 2): an upper bound whose optimum depends on the cost."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import linprog

import lpbounds as lb
from lpbounds.errors import SolverError, SolverNotInstalledError, ValidationError
from lpbounds.formulations import ALP, RLP, find_cost_dependent_alp
from tests import _independent as ind

from ._reference import transition_rows


def _check(mdp, res, kind="ALP", **kw):
    """The bracket of ``res`` against references computed here (see tests/_independent)."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    return ind.check_mdp_lp(res, kind, P, mdp.rewards, mdp.allowed, mdp.discount, **kw)


def _linprog_alp(mdp, phi, cost):
    p, r, pairs = transition_rows(mdp)
    a = phi[pairs[:, 0]] - mdp.discount * (p @ phi)
    res = linprog(phi.T @ cost, A_ub=-a, b_ub=-r, bounds=(None, None), method="highs")
    assert res.status == 0
    return res


def test_remark_2_example_is_cost_dependent_by_an_independent_solve():
    ex = find_cost_dependent_alp(0)
    assert np.allclose(ex.basis.sum(axis=1), 1.0) and (ex.basis > 0).all(), "soft aggregation"
    assert (ex.cost1 > 0).all() and (ex.cost2 > 0).all()
    r1 = _linprog_alp(ex.mdp, ex.basis, ex.cost1)
    r2 = _linprog_alp(ex.mdp, ex.basis, ex.cost2)
    # r(c2) is feasible but strictly worse than r(c1) under c1: the optimal sets differ
    worse = ex.cost1 @ (ex.basis @ r2.x) - r1.fun
    assert worse > 1e-3, f"c1' Phi r(c2) - min = {worse:.3g}"
    assert abs(ex.excess - worse) <= 1e-6 * max(1.0, abs(r1.fun))
    # while RLP (a 0/1 basis) on the same MDP does not depend on the cost (Theorem 1)
    part = lb.random_partition(ex.mdp.n_states, 2, seed=0)
    res1 = RLP(ex.mdp, part, ex.cost1).solve()
    res2 = RLP(ex.mdp, part, ex.cost2).solve()
    assert np.abs(res1.values - res2.values).max() <= 1e-8
    for res, cost in ((res1, ex.cost1), (res2, ex.cost2)):
        assert _check(ex.mdp, res, "RLP", labels=part.labels, cost=cost) == "optimal"
    # both ALP optima are certified upper bounds on V*, tight at their own points
    for res, cost in ((ex.first, ex.cost1), (ex.second, ex.cost2)):
        assert _check(ex.mdp, res, cost=cost) == "optimal"


def test_sparse_and_dense_basis_agree():
    mdp = lb.garnet(15, 2, 2, 0.9, seed=2)
    phi = lb.formulations.soft_aggregation_basis(15, 3, seed=1)
    a = ALP(mdp, phi).solve()
    b = ALP(mdp, sp.csr_matrix(phi)).solve()
    assert abs(a.objective - b.objective) <= 1e-9 * max(1, abs(a.objective))
    assert _check(mdp, a) == _check(mdp, b) == "optimal"


def test_infeasible_basis_is_reported():
    """A basis without the constant direction can make the Bellman inequalities infeasible."""
    mdp = lb.garnet(4, 1, 1, 0.9, seed=0, reward_range=(1.0, 2.0))
    phi = np.array([[1.0], [-1.0], [0.0], [0.0]])  # Phi r >= R > 0 impossible in states 2, 3
    with pytest.raises(SolverError, match="infeasible"):
        ALP(mdp, phi).solve()
    res = ALP(mdp, phi).solve(raise_on_failure=False)
    assert res.status.value == "infeasible"


@pytest.mark.parametrize(
    ("basis", "match"),
    [(np.ones((5, 2)), "shape"), (np.ones(6), "2-d"), (np.zeros((6, 0)), "shape")],
)
def test_bad_basis(basis, match):
    mdp = lb.garnet(6, 2, 2, seed=1)
    with pytest.raises(ValidationError, match=match):
        ALP(mdp, basis)


def test_bad_cost_and_unknown_solver():
    mdp = lb.garnet(6, 2, 2, seed=1)
    phi = np.ones((6, 1))
    with pytest.raises(ValidationError, match="negative"):
        ALP(mdp, phi, cost=-np.ones(6))
    with pytest.raises(ValidationError, match="length 6"):
        ALP(mdp, phi, cost=np.ones(7))
    with pytest.raises(SolverNotInstalledError, match="unknown solver"):
        ALP(mdp, phi).solve("NOT_A_SOLVER")
    with pytest.raises(SolverNotInstalledError, match="pip install"):
        ALP(mdp, phi).solve("MOSEK")
