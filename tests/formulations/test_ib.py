"""IB (eq. 20-22) and LLP (eq. 18): lifting never beats RLP (Theorem 2)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.formulations import IB, LLP
from tests import _independent as ind

from ._reference import rlp_reference


def _dense(mdp):
    return ind.dense_transitions(mdp.successors, mdp.probabilities_full()), mdp.rewards


def test_ib_rows_are_cyclic_copies_of_rlp_rows():
    mdp = lb.garnet(12, 2, 2, 0.9, seed=4)
    part = lb.random_partition(12, 3, seed=4)
    ib = IB(mdp, part, 3)
    base = lb.BellmanRows.aggregate(mdp, part)
    a, b = ib.rows.constraint_matrix()
    a0, b0 = base.constraint_matrix()
    m, r = part.n_partitions, base.n_rows
    d = a0.toarray()
    own = np.zeros_like(d)
    own[np.arange(r), base.owner] = 1.0
    lam_p = own - d  # lambda * P-bar
    for j in range(3):  # rows of block j: E into block j, -lambda P into block j-1 (mod 3)
        blk = a[j * r : (j + 1) * r].toarray()
        expect = np.zeros((r, 3 * m))
        expect[:, j * m : (j + 1) * m] += own
        k = (j - 1) % 3
        expect[:, k * m : (k + 1) * m] -= lam_p
        assert np.allclose(blk, expect), f"block {j}"
        assert np.array_equal(b[j * r : (j + 1) * r], b0)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(2, 20),
    seed=st.integers(0, 10_000),
    L=st.integers(1, 5),
    data=st.data(),
)
def test_every_ib_block_and_llp_dominate_vstar(n, seed, L, data):
    m = data.draw(st.integers(1, n))
    mdp = lb.garnet(n, 2, 2, 0.85, seed=seed, reward_range=(-1.0, 1.0))
    part = lb.random_partition(n, m, seed=seed)
    rng = np.random.default_rng(seed)
    cost = rng.uniform(0, 1, n) * (rng.random(n) < 0.7)  # zeros allowed
    vref = rlp_reference(mdp, part)
    tol = 1e-6 * max(1.0, np.abs(vref).max())
    res = IB(mdp, part, L, cost).solve("HIGHS")
    assert (res.extra["blocks"] - vref).min() >= -tol, "an IB block is below v* (Theorem 2)"
    P, R = _dense(mdp)
    ind.check_mdp_lp(res, "IB", P, R, mdp.allowed, 0.85, labels=part.labels, cost=cost,
                     n_blocks=L, what=f"IB L={L}")  # fmt: skip
    d = rng.uniform(0, 3, (n, 2))
    res = LLP(mdp, part, d, cost).solve("HIGHS")
    assert (res.values - vref).min() >= -tol, "LLP's v is below v*"
    ind.check_mdp_lp(res, "LLP", P, R, mdp.allowed, 0.85, labels=part.labels, cost=cost)
    z = res.extra["z"]
    q = mdp.rewards + mdp.discount * (
        mdp.probabilities_full() * res.values[part.labels[mdp.successors]]
    ).sum(axis=2)
    assert np.allclose(z, part.lift(res.values)[:, None] - q, atol=1e-6), "z is the surplus"


def test_llp_can_be_strictly_worse_than_rlp():
    """With d > 0 the LLP optimum may exceed v* (never go below): a seeded instance where the
    effective cost c-bar + A'd has a negative entry (found by a search over seeds 0..1)."""
    mdp = lb.garnet(4, 2, 2, 0.9, seed=1)
    part = lb.random_partition(4, 2, seed=1)
    rng = np.random.default_rng(1)
    d = rng.uniform(0, 5, (4, 2))
    cost = rng.uniform(0, 1, 4) * (rng.random(4) < 0.5)
    vref = rlp_reference(mdp, part)
    res = LLP(mdp, part, d, cost).solve("HIGHS")
    assert (res.values - vref).min() >= -1e-9, "LLP's v is below v*"
    assert (res.values - vref).max() > 0.1, "expected a strictly worse v with this d"
    # LLP's bracket is on RLP's v*: its upper side (feasibility) is tight at the point, its
    # lower side as wide as the point's distance above v* requires
    P, R = _dense(mdp)
    ind.check_mdp_lp(res, "LLP", P, R, mdp.allowed, 0.9, labels=part.labels, cost=cost)
    assert res.error_bound > 0.1 * (1 - 0.9), "a point 0.1 above v* cannot be certified close"
    # the other solvers agree on the LLP optimum value
    for solver in ("CLARABEL", "SCIPY"):
        other = LLP(mdp, part, d, cost).solve(solver)
        assert abs(other.objective - res.objective) <= 1e-6 * max(1.0, abs(res.objective))
        ind.check_mdp_lp(other, "LLP", P, R, mdp.allowed, 0.9, labels=part.labels, cost=cost)


@pytest.mark.parametrize("L", [0, -1, 2.5, True, "2"])
def test_bad_L(L):
    mdp, part = lb.garnet(5, 2, 2, seed=1), lb.random_partition(5, 2)
    with pytest.raises(ValidationError, match="L must be"):
        IB(mdp, part, L)


def test_bad_ib_cost_and_llp_d():
    mdp, part = lb.garnet(5, 2, 2, seed=1), lb.random_partition(5, 2)
    with pytest.raises(ValidationError, match="negative"):
        IB(mdp, part, 2, cost=[1, 1, -1, 1, 1])
    with pytest.raises(ValidationError, match="length 5"):
        IB(mdp, part, 2, cost=[1, 1])
    with pytest.raises(ValidationError, match="shape"):
        LLP(mdp, part, np.ones(5))
    with pytest.raises(ValidationError, match=r"d\[1, 0\]"):
        LLP(mdp, part, np.array([[0, 0], [-1, 0], [0, 0], [0, 0], [0, 0]]))
    with pytest.raises(ValidationError, match="states"):
        IB(mdp, lb.random_partition(4, 2), 1)
