"""RLP (eq. 9) and ELP (eq. 8): Theorem 1 on random MDPs, result statuses, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.errors import SolverError, ValidationError
from lpbounds.formulations import ELP, RLP
from tests import _independent as ind
from tests.conftest import reference_solve

from ._reference import rlp_reference


def _dense(mdp):
    return ind.dense_transitions(mdp.successors, mdp.probabilities_full()), mdp.rewards


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(2, 30),
    n_act=st.integers(1, 3),
    seed=st.integers(0, 10_000),
    data=st.data(),
)
def test_theorem_1_on_random_mdps_and_costs(n, n_act, seed, data):
    """The optimum is v* wherever c-bar > 0 and dominates v* everywhere, for any c >= 0."""
    m = data.draw(st.integers(1, n))
    solver = data.draw(st.sampled_from(["HIGHS", "CLARABEL"]))
    mdp = lb.garnet(n, n_act, 3, 0.9, seed=seed, reward_range=(-2.0, 1.0), allowed_fraction=0.8)
    part = lb.random_partition(n, m, seed=seed)
    rng = np.random.default_rng(seed)
    cost = rng.uniform(0, 1, n) * (rng.random(n) < 0.6)
    if not cost.any():
        cost[0] = 1.0
    vref = rlp_reference(mdp, part)
    tol = 1e-6 * max(1.0, np.abs(vref).max())
    res = RLP(mdp, part, cost).solve(solver)
    cbar = np.bincount(part.labels, weights=cost, minlength=m)
    assert (res.values - vref).min() >= -tol, "a feasible point below v*"
    assert np.abs(res.values - vref)[cbar > 0].max(initial=0) <= tol, "optimum != v* on c > 0"
    assert (res.state_values - reference_solve(mdp)).min() >= -tol, "Phi v* must be >= V*"
    # the certified bracket: contains v*, as narrow as the point's residual allows, and
    # (OPTIMAL) within the requested accuracy; both sides where every c-bar is positive
    P, R = _dense(mdp)
    status = ind.check_mdp_lp(
        res, "RLP", P, R, mdp.allowed, 0.9, labels=part.labels, cost=cost, what=solver
    )
    assert status == "optimal"  # solve() raises otherwise


def test_status_comes_from_the_certificate_not_the_solver():
    mdp = lb.garnet(20, 2, 2, 0.9, seed=1)
    form = ELP(mdp)
    # an accuracy no floating-point point can meet: the certificate says INACCURATE,
    # whatever the solver claimed, and the bracket is still returned
    res = form.solve("SCS", accuracy=1e-300, raise_on_failure=False)
    assert res.status.value == "inaccurate"
    assert res.certificate is not None and res.certificate.residual > res.residual_tol
    assert res.primal_residual == pytest.approx(max(0.0, (form.b - form.A @ res.x).max()))
    # the INACCURATE bracket still contains V* and is exactly as wide as SCS's residual
    # (recomputed here) implies: inaccurate, not vacuous
    P, R = _dense(mdp)
    assert ind.check_mdp_lp(res, "ELP", P, R, mdp.allowed, 0.9, what="SCS") == "inaccurate"
    assert np.isfinite(res.error_bound) and res.relative_error < 1e-2
    with pytest.raises(SolverError, match="certified error"):
        form.solve("SCS", accuracy=1e-300)
    ok = form.solve("HIGHS")
    assert ok.ok and ok.certificate is not None and ok.certificate.residual <= ok.residual_tol
    assert ok.compile_seconds >= 0 and ok.solve_seconds >= 0 and ok.solver == "HIGHS"
    assert ind.check_mdp_lp(ok, "ELP", P, R, mdp.allowed, 0.9, what="HIGHS") == "optimal"


@pytest.mark.parametrize("accuracy", [0, -1e-6, float("nan"), float("inf"), "abc", True, None])
def test_accuracy_must_be_a_positive_number(accuracy):
    with pytest.raises(ValidationError, match="accuracy"):
        ELP(lb.garnet(4, 2, 2, 0.9, seed=1)).solve("HIGHS", accuracy=accuracy)


def test_bad_input():
    mdp = lb.garnet(6, 2, 2, seed=1)
    part = lb.random_partition(6, 2)
    with pytest.raises(ValidationError, match="negative"):
        RLP(mdp, part, cost=[1, 1, 1, -1, 1, 1])
    with pytest.raises(ValidationError, match="length 6"):
        RLP(mdp, part, cost=[1, 1])
    with pytest.raises(ValidationError, match="not both"):
        RLP(mdp, part, cost=np.ones(6), partition_cost=np.ones(2))
    with pytest.raises(ValidationError, match="partition_cost"):
        RLP(mdp, part, partition_cost=np.ones(3))
    with pytest.raises(ValidationError, match="states"):
        RLP(mdp, lb.random_partition(7, 2))
    with pytest.raises(ValidationError, match="negative"):
        ELP(mdp, cost=-np.ones(6))
    with pytest.raises(ValidationError, match="finite"):
        ELP(mdp, cost=np.full(6, np.inf))


def test_highs_interior_point_with_crossover_through_highs_options():
    mdp = lb.garnet(40, 3, 3, 0.9, seed=2)
    part = lb.random_partition(40, 5, seed=2)
    res = RLP(mdp, part).solve("HIGHS", highs_options={"solver": "ipm", "run_crossover": "on"})
    vref = rlp_reference(mdp, part)
    assert np.abs(res.values - vref).max() <= 1e-6 * max(1.0, np.abs(vref).max())
    assert res.solver_options == {"highs_options": {"solver": "ipm", "run_crossover": "on"}}
    P, R = _dense(mdp)
    assert ind.check_mdp_lp(res, "RLP", P, R, mdp.allowed, 0.9, labels=part.labels) == "optimal"
