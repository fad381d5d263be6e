"""The highspy backend and cvxpy's HiGHS path.

Every formulation solved with ``backend="highspy"`` must give what the cvxpy path gives
(same point within the certificate, duals with the same sign convention), both must lie
within their certificates of the exact optimum computed here by a plain loop over the
rows (no DP code, no LP), and the duals must pass the KKT checks recomputed here. The
cvxpy path must hand HiGHS the same LP as highspy (same IPM iteration count), a time
limit must keep the point with a valid bracket, and ``warm_start="policy"`` must reach
the same optimum with the occupation measures as duals.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.formulations import ALP, ELP, IB, RLP, SLP, soft_aggregation_basis
from lpbounds.formulations.rows_lp import RowsLP
from lpbounds.patrol import PatrolParams
from lpbounds.patrol.bounds import LBLP, UBLP
from tests import _independent as ind
from tests.conftest import reference_solve

from . import test_lp_battery as battery
from ._reference import transition_rows

SMALL_PATROL = PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4)


def rows_reference(rows: lb.BellmanRows, tol: float = 1e-13) -> np.ndarray:
    """The least feasible point of a row system by plain value iteration over its rows."""
    v = np.zeros(rows.n_vars)
    owner = np.asarray(rows.owner, dtype=np.int64)
    targets = np.asarray(rows.targets, dtype=np.int64)
    probs = np.broadcast_to(rows.probs, targets.shape)
    while True:
        q = rows.reward + rows.discount * (probs * v[targets]).sum(axis=1)
        nv = np.full(rows.n_vars, -np.inf)
        np.maximum.at(nv, owner, q)
        if np.abs(nv - v).max() < tol * max(1.0, np.abs(nv).max()):
            return nv
        v = nv


@functools.cache
def _forms() -> dict[str, RowsLP]:
    """The LPs of the tests, built once on first use (not at collection)."""
    mdp = lb.garnet(40, 3, 3, 0.9, seed=7, allowed_fraction=0.7)  # masked: some pairs forbidden
    part = lb.random_partition(40, 8, seed=2)
    small = lb.load_instance("patrol-small")
    rlp = RLP(mdp, part)
    mu = rlp.solve().mu
    return {
        "ELP garnet": ELP(mdp, np.random.default_rng(1).uniform(0.1, 1.0, 40)),
        "RLP garnet": rlp,
        "SLP garnet": SLP(mdp, part, mu),
        "IB garnet": IB(mdp, part, 2),
        "ELP patrol-small": ELP(small.mdp()),
        "RLP patrol-small": RLP(small.mdp(), small.partition()),
        "UBLP patrol-small": UBLP(SMALL_PATROL),
        "LBLP patrol-small": LBLP(SMALL_PATROL),
    }


NAMES = [
    "ELP garnet", "RLP garnet", "SLP garnet", "IB garnet", "ELP patrol-small",
    "RLP patrol-small", "UBLP patrol-small", "LBLP patrol-small",
]  # fmt: skip


def rows_apply(rows: lb.BellmanRows, v: np.ndarray) -> np.ndarray:
    """``(T v)(i) = max over the rows of i`` by a plain numpy expression over the rows."""
    targets = np.asarray(rows.targets, dtype=np.int64)
    probs = np.broadcast_to(rows.probs, targets.shape)
    q = rows.reward + rows.discount * (probs * v[targets]).sum(axis=1)
    out = np.full(rows.n_vars, -np.inf)
    np.maximum.at(out, np.asarray(rows.owner, dtype=np.int64), q)
    return out


def _within_certificate(res: lb.formulations.LPResult, ref: np.ndarray, form=None) -> str:
    """The bracket contains the exact optimum; with ``form``, it is also as narrow as the
    point's residual (recomputed over the rows here) allows and, OPTIMAL, within the
    requested accuracy (tests/_independent.assert_bracket). Returns the status."""
    assert res.lower_values is not None and res.upper_values is not None
    slack = 1e-12 * max(1.0, float(np.abs(ref).max()))  # the reference's own iteration error
    if form is not None:
        rows = form.rows
        r_abs = float(np.abs(rows.reward).max())
        return ind.assert_bracket(
            res, point=res.x, t_point=rows_apply(rows, res.x), discount=rows.discount,
            reward_absmax=r_abs, reward_floor=r_abs, n_terms=rows.n_outcomes, optimum=ref,
            optimum_err=slack / (1 - rows.discount),
            judged="both" if (form.c > 0).all() else "upper", what=form.name,
        )  # fmt: skip
    ref = ref[: res.values.size]  # IB: values are the first block v_1
    assert (res.lower_values <= ref + slack).all(), "exact optimum below the certified bracket"
    assert (ref <= res.upper_values + slack).all(), "exact optimum above the certified bracket"
    assert np.abs(res.values - ref).max() <= res.error_bound + slack
    return str(res.status)


@pytest.mark.parametrize("name", NAMES)
def test_highspy_equals_cvxpy_and_the_fixed_point_within_the_certificate(name):
    form = _forms()[name]
    ref = rows_reference(form.rows)
    via_cvxpy = form.solve("HIGHS")
    direct = form.solve("HIGHS", backend="highspy")
    assert direct.status is lb.Status.OPTIMAL and direct.solver == "HIGHS"
    for res in (via_cvxpy, direct):
        _within_certificate(res, ref)
        assert _within_certificate(res, ref, form) == "optimal"
        battery._kkt(form, res, 1e-6)
    # the same point within both certificates, the same duals (objective = b'y, y >= 0)
    assert np.abs(direct.values - via_cvxpy.values).max() <= (
        direct.error_bound + via_cvxpy.error_bound
    )
    assert abs(direct.objective - form.b @ direct.duals) <= 1e-7 * max(1.0, abs(direct.objective))
    assert np.abs(direct.duals - via_cvxpy.duals).max() <= 1e-6 * max(1.0, direct.duals.max())
    assert set(direct.group_duals) == set(via_cvxpy.group_duals)


@pytest.mark.parametrize("name", ["ELP garnet", "RLP patrol-small", "UBLP patrol-small"])
def test_cvxpy_hands_highs_the_rows_as_highspy_does(name):
    # cvxpy's stock HiGHS interface writes -A x <= -b, on which HiGHS' IPM takes a
    # different number of iterations (15 instead of 16 on patrol-small's RLP, 14 instead of
    # 16 on its UBLP, 42 instead of 30 on the paper's UBLP); lpbounds' adapter hands over
    # A x >= b, exactly what highspy gets
    form = _forms()[name]
    opts = {"highs_options": {"solver": "ipm", "run_crossover": "off"}}
    via_cvxpy = form.solve("HIGHS", **opts)
    direct = form.solve("HIGHS", backend="highspy", **opts)
    assert via_cvxpy.iterations == direct.iterations
    assert via_cvxpy.objective == pytest.approx(direct.objective, rel=1e-12, abs=1e-12)
    ref = rows_reference(form.rows)
    for res in (via_cvxpy, direct):  # IPM without crossover: an interior point, still certified
        _within_certificate(res, ref, form)


def test_alp_highspy_agrees_with_a_second_solver():
    mdp = lb.garnet(40, 3, 3, 0.9, seed=7, allowed_fraction=0.7)
    form = ALP(mdp, soft_aggregation_basis(40, 5, seed=3))
    direct = form.solve("HIGHS", backend="highspy")
    other = form.solve("CLARABEL")
    assert direct.objective == pytest.approx(other.objective, rel=1e-6)
    battery._kkt(form, direct, 1e-6)
    vstar = reference_solve(mdp)
    assert (direct.upper_values >= vstar - 1e-9).all()  # ALP's certified bound on V*
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    for res in (direct, other):
        status = ind.check_mdp_lp(res, "ALP", P, mdp.rewards, mdp.allowed, 0.9)
        assert status == "optimal"


@pytest.mark.parametrize("backend", ["cvxpy", "highspy"])
def test_time_limit_keeps_the_point_and_a_valid_bracket(backend):
    mdp = lb.garnet(3000, 3, 5, 0.9, seed=11)
    form = ELP(mdp)
    res = form.solve(
        "HIGHS", backend=backend, time_limit=0.01, raise_on_failure=False,
        highs_options={"solver": "ipm", "presolve": "off"},
    )  # fmt: skip
    assert res.status is lb.Status.TIME_LIMIT
    assert np.isfinite(res.x).all() and res.lower_values is not None
    ref = rows_reference(form.rows, tol=1e-12)
    assert (res.lower_values <= ref + 1e-9).all() and (ref <= res.upper_values + 1e-9).all()
    assert res.error_bound > 1e-6  # stopped early: the bracket is honest about it
    # ... and no more than honest: exactly as wide as the point's residual makes it
    assert _within_certificate(res, ref, form) == "time_limit"


@pytest.mark.parametrize(
    "name", ["ELP garnet", "RLP garnet", "ELP patrol-small", "LBLP patrol-small"]
)
def test_policy_warm_start_same_optimum_in_no_iterations(name):
    form = _forms()[name]
    ref = rows_reference(form.rows)
    res = form.solve("HIGHS", backend="highspy", warm_start="policy")
    assert res.status is lb.Status.OPTIMAL and res.extra["warm_start"] == "policy"
    assert res.iterations is not None and res.iterations <= 5
    _within_certificate(res, ref)
    assert _within_certificate(res, ref, form) == "optimal"
    battery._kkt(form, res, 1e-6)


def test_policy_warm_start_duals_are_the_occupation_measure():
    mdp = lb.garnet(40, 3, 3, 0.9, seed=7, allowed_fraction=0.7)
    cost = np.random.default_rng(1).uniform(0.1, 1.0, 40)
    res = ELP(mdp, cost).solve("HIGHS", backend="highspy", warm_start="policy")
    p, _, pairs = transition_rows(mdp)
    m = res.mu[pairs[:, 0], pairs[:, 1]]
    flow = res.mu.sum(axis=1) - mdp.discount * (p.T @ m)
    assert np.abs(flow - cost).max() <= 1e-9
    # one positive dual per state: the basis is the policy's
    assert ((res.mu > 0).sum(axis=1) == 1).all()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"backend": "scipy"}, "backend must be one of"),
        ({"backend": "highspy", "solver": "CLARABEL"}, "HiGHS only"),
        ({"warm_start": "policy"}, "needs backend='highspy'"),
        ({"backend": "highspy", "warm_start": "basis"}, "warm_start must be"),
        ({"backend": "highspy", "no_such_option": 1}, "no_such_option"),
        ({"backend": "highspy", "highs_options": {"solver": "nonsense"}}, "solver='nonsense'"),
    ],
)
def test_bad_backend_arguments_are_named(kwargs, match):
    form = _forms()["ELP garnet"]
    with pytest.raises(ValidationError, match=match):
        form.solve(**kwargs)


def test_highspy_refuses_extra_constraints_and_non_row_warm_starts():
    form = _forms()["RLP garnet"]
    with pytest.raises(ValidationError, match="extra_constraints need backend='cvxpy'"):
        form.solve(backend="highspy", extra_constraints=[form.v[0] <= form.v[1] + 100])
    mdp = lb.garnet(20, 2, 2, 0.9, seed=1)
    alp = ALP(mdp, soft_aggregation_basis(20, 3))
    with pytest.raises(ValidationError, match="no policy basis"):
        alp.solve(backend="highspy", warm_start="policy")


def test_cvxpy_path_reports_an_infeasible_modification_as_infeasible():
    # every feasible v dominates the fixed point (Fact 1), so v[0] <= min - 1 is infeasible
    form = _forms()["RLP garnet"]
    low = float(rows_reference(form.rows).min()) - 1.0
    res = form.solve("HIGHS", extra_constraints=[form.v[0] <= low], raise_on_failure=False)
    assert res.status is lb.Status.INFEASIBLE and np.isnan(res.x).all()
    assert res.extra["message"] == "infeasible" and res.extra["highs_status"] == "kInfeasible"


def test_dual_ray_of_a_highspy_without_get_dual_ray():
    """highspy 1.7 (the minimum version) has no getDualRay: an infeasible LP through the cvxpy
    path then carries no ray (NaN) instead of failing with AttributeError."""
    from lpbounds.formulations.highs import _dual_ray

    st, has_ray, ray = _dual_ray(object(), 3)
    assert st is None and has_ray is False and ray.shape == (3,) and np.isnan(ray).all()
