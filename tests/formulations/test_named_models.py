"""The cvxpy models in the paper's symbols.

Item 1: every formulation's ``problem`` has one named variable per symbol and one named
vector constraint per equation; the groups are checked against the paper's equations with
an independent numpy evaluation of the Bellman right-hand sides (``_reference``), and the
duals per group against the closed-form dual mass ``sum(c-bar) / (1 - lambda)``.

Item 2: ``solve(extra_constraints=[...])``. For constraints ``v(i) >= v(j) + a`` the
feasible set stays closed under the componentwise min, so the modified LP still has a
least element (Theorem 1 survives); the reference computes it by monotone iteration in
numpy, ``v <- max(T v, v(j) + a on i)``, from RLP's ``v*`` upwards.
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

import lpbounds as lb
from lpbounds.errors import SolverError, ValidationError
from lpbounds.formulations import ALP, ELP, IB, LLP, RLP, SLP
from lpbounds.formulations.alp import soft_aggregation_basis
from lpbounds.patrol import PatrolParams
from lpbounds.patrol.bounds import LBLP, UBLP
from lpbounds.status import Status
from tests import _independent as ind
from tests.conftest import reference_solve

from ._reference import _q_partition, rlp_reference


def _model(n=30, m=5, seed=1):
    return lb.garnet(n, 3, 3, 0.9, seed=seed), lb.random_partition(n, m, seed=seed)


def _check(mdp, res, kind, **kw):
    """The certified bracket both ways against references computed in tests/_independent."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    return ind.check_mdp_lp(res, kind, P, mdp.rewards, mdp.allowed, mdp.discount, **kw)


def _check_modified(mdp, res, labels=None):
    """A modified solve's bracket is the certificate of its point on the ORIGINAL rows: it
    contains the original optimum and is as narrow as the point's residual allows; only the
    upper side (feasibility) is judged, and error_bound is inf by design."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    R, allowed, lam = mdp.rewards, mdp.allowed, mdp.discount
    if labels is None:  # ELP: per state
        opt = ind.policy_iteration(P, R, allowed, lam)
        t = ind.bellman(P, R, allowed, lam, res.values)
    else:
        opt = ind.rlp_optimum(P, R, allowed, lam, labels)
        t = ind.rlp_operator(P, R, allowed, lam, labels, res.values)
    assert res.modified and res.error_bound == np.inf
    return ind.assert_bracket(
        res, point=res.values, t_point=t, discount=lam,
        reward_absmax=float(np.abs(R).max()), n_terms=mdp.n_outcomes, optimum=opt.values,
        optimum_err=opt.error, judged="upper", check_error_bound=False, what="modified",
    )  # fmt: skip


# ------------------------------------------------------------------ item 1: names
def _names(form):
    return list(form.variables), list(form.constraints)


def test_each_formulation_names_its_variables_and_groups_after_the_paper():
    mdp, part = _model()
    m = part.n_partitions
    cases = {
        "ELP": (ELP(mdp), ["V"], ["bellman"]),
        "RLP": (RLP(mdp, part), ["v"], ["bellman"]),
        "SLP": (SLP(mdp, part, "uniform"), ["v"], ["surrogate"]),
        "IB": (IB(mdp, part, 3), ["v_1", "v_2", "v_3"], ["bellman_1", "bellman_2", "bellman_3"]),
        "LLP": (
            LLP(mdp, part, np.ones((30, 3))),
            ["v", "z"],
            ["surplus_lower", "surplus_upper", "z_nonneg"],
        ),
        "ALP": (ALP(mdp, soft_aggregation_basis(30, 4)), ["r"], ["bellman"]),
    }
    params = PatrolParams(N=6, stations=(0, 3), D=2, Gamma=3)
    cases["UBLP"] = (UBLP(params), ["w"], ["bellman"])
    cases["LBLP"] = (LBLP(params), ["w"], ["bellman"])
    for name, (form, variables, groups) in cases.items():
        assert _names(form) == (variables, groups), name
        # one cvxpy object per group, never one per row
        assert len(form.problem.constraints) == len(groups), name
        assert sum(c.size for c in form.problem.constraints) == form.A.shape[0], name
        assert sum(v.size for v in form.problem.variables()) == form.A.shape[1], name
        assert [v.name() for v in form.variables.values()] == variables, name
    assert RLP(mdp, part).v.shape == (m,) and ELP(mdp).V.shape == (30,)
    assert [v.name() for v in IB(mdp, part, 3).v] == ["v_1", "v_2", "v_3"]
    assert ALP(mdp, np.ones((30, 1))).r.shape == (1,)
    llp = LLP(mdp, part, np.ones((30, 3)))
    assert llp.z.shape == (int(mdp.allowed.sum()),) and llp.v.shape == (m,)
    assert UBLP(params).w.shape == (params.n_partitions,)


def _group_violation(con):
    """``max (b - lhs)^+`` of a ``lhs >= b`` group at the variables' current values."""
    return float(np.max(con.violation(), initial=0.0))


def test_ib_groups_implement_eq_21_and_22_block_by_block():
    """``bellman_1``: v_1 >= R + lam P v_L (eq. 22); ``bellman_{j+1}``: v_{j+1} >= R + lam P v_j
    (eq. 21). At random blocks each group's largest violation equals the numpy one."""
    mdp, part = _model(24, 4, seed=3)
    L = 3
    ib = IB(mdp, part, L)
    rng = np.random.default_rng(0)
    blocks = rng.uniform(0, 10, size=(L, part.n_partitions))
    for j, var in enumerate(ib.v):
        var.value = blocks[j]
    labels = part.labels
    for j in range(L):  # group bellman_{j+1} is owned by v_{j+1}, its targets in v_j (cyclic)
        q = _q_partition(mdp, labels, blocks[(j - 1) % L]).max(axis=1)
        owner_val = blocks[j][labels]
        expected = max(0.0, float((q - owner_val).max()))
        got = _group_violation(ib.constraints[f"bellman_{j + 1}"])
        assert got == pytest.approx(expected, rel=1e-12, abs=1e-12), j


def test_rlp_bellman_group_is_eq_9_and_duals_come_per_group():
    mdp, part = _model(40, 6, seed=4)
    rlp = RLP(mdp, part)
    vstar = rlp_reference(mdp, part)
    rlp.v.value = vstar
    assert _group_violation(rlp.constraints["bellman"]) <= 1e-9  # v* is feasible
    rlp.v.value = vstar - 0.1
    # below v* by t: the violation is t (1 - lam) at least (every row has sum p = 1)
    assert _group_violation(rlp.constraints["bellman"]) >= 0.1 * (1 - 0.9) - 1e-9
    res = rlp.solve("HIGHS")
    assert _check(mdp, res, "RLP", labels=part.labels) == "optimal"
    assert list(res.group_duals) == ["bellman"]
    np.testing.assert_array_equal(res.group_duals["bellman"], res.duals)
    # flow balance summed over partitions: sum y (1 - lam) = sum c-bar (stochastic rows)
    total = res.group_duals["bellman"].sum() * (1 - mdp.discount)
    assert total == pytest.approx(part.n_states, rel=1e-7)


def test_ib_dual_mass_per_group_is_sum_cbar_over_one_minus_lambda():
    """Stationarity of block ``v_j`` summed over its entries: ``Y_j - lam Y_{j+1} = sum c-bar``
    (``Y_j`` the dual mass of bellman_j), whose only solution is ``Y_j = sum c-bar / (1-lam)``."""
    mdp, part = _model(30, 5, seed=2)
    res = IB(mdp, part, 4).solve("HIGHS")
    assert _check(mdp, res, "IB", labels=part.labels, n_blocks=4) == "optimal"
    assert list(res.group_duals) == [f"bellman_{j}" for j in range(1, 5)]
    np.testing.assert_array_equal(np.concatenate(list(res.group_duals.values())), res.duals)
    for name, y in res.group_duals.items():
        assert y.sum() == pytest.approx(30 / (1 - 0.9), rel=1e-7), name


def test_llp_groups_and_their_duals():
    mdp, part = _model(20, 4, seed=5)
    d = np.random.default_rng(1).random((20, 3))
    res = LLP(mdp, part, d).solve("HIGHS")
    assert _check(mdp, res, "LLP", labels=part.labels) == "optimal"
    k = int(mdp.allowed.sum())
    assert {g: y.size for g, y in res.group_duals.items()} == {
        "surplus_lower": k,
        "surplus_upper": k,
        "z_nonneg": k,
    }
    # z is the surplus of each pair's inequality: at the optimum z = A_pair v - R >= 0
    z = res.extra["z"][mdp.allowed]
    q = _q_partition(mdp, part.labels, res.values)[mdp.allowed]
    np.testing.assert_allclose(z, res.values[part.labels][np.nonzero(mdp.allowed)[0]] - q,
                               atol=1e-7)  # fmt: skip


# ------------------------------------------------------------------ item 2: modifications
def least_point_with_links(mdp, labels, m, links, v0, tol=1e-13):
    """Least ``v >= v0`` with ``v(i) >= max_{x in S_i, u} q(x, u; v)`` and ``v(i) >= v(j) + a``
    for each ``(i, j, a)`` in ``links``: monotone iteration from below (numpy only)."""
    v = v0.copy()
    for _ in range(100_000):
        q = _q_partition(mdp, labels, v).max(axis=1)
        new = np.full(m, -np.inf)
        np.maximum.at(new, labels, q)
        for i, j, a in links:
            new[i] = max(new[i], v[j] + a)
        new = np.maximum(new, v)
        if np.abs(new - v).max() <= tol * max(1.0, np.abs(new).max()):
            return new
        v = new
    raise AssertionError("reference iteration did not converge")


@pytest.mark.parametrize("solver", ["HIGHS", "CLARABEL"])
def test_rlp_with_v_i_below_v_j_keeps_theorem_1(solver):
    mdp, part = _model(60, 8, seed=7)
    m = part.n_partitions
    vstar = rlp_reference(mdp, part)
    i, j = int(np.argmax(vstar)), int(np.argmin(vstar))  # v*(i) > v*(j): the constraint binds
    ref = least_point_with_links(mdp, part.labels, m, [(j, i, 0.0)], vstar)
    assert ref[j] > vstar[j] + 1e-3, "the reference must move: the test would not bind"
    vtrue = reference_solve(mdp)
    scale = np.abs(mdp.rewards).max() / (1 - mdp.discount)
    for cost in (None, np.random.default_rng(3).uniform(0.1, 2.0, 60)):
        rlp = RLP(mdp, part, cost)
        res = rlp.solve(solver, extra_constraints=[rlp.v[i] <= rlp.v[j]])
        assert res.status is Status.OPTIMAL and res.modified
        assert _check_modified(mdp, res, part.labels) == "optimal"
        # the modified optimum is the least element of the smaller set, for every cost
        assert np.abs(res.values - ref).max() <= 1e-6 * scale
        assert res.extra_residuals[0] <= res.residual_tol
        assert res.extra_duals[0][0] > 1e-6, "a binding constraint has a positive dual"
        # still certified: upper_values bound V*, lower_values bound v* and the new optimum
        assert (part.lift(res.upper_values) >= vtrue - 1e-9 * scale).all()
        assert (res.lower_values <= vstar + 1e-9 * scale).all()
        lo, hi = res.objective_bracket
        assert hi == np.inf and lo <= rlp.c @ ref + 1e-9 * scale * rlp.c.sum()
        assert res.error_bound == np.inf and res.relative_error == np.inf
        # the status did not come from the original certificate's downward residual
        assert res.certificate.residual_down > res.residual_tol
        # the formulation is unchanged: a plain solve gives v* again
        assert len(rlp.problem.constraints) == 1
        plain = rlp.solve(solver)
        assert np.abs(plain.values - vstar).max() <= 1e-6 * scale
        assert _check(mdp, plain, "RLP", labels=part.labels, cost=cost) == "optimal"


def test_non_binding_constraint_leaves_v_star_and_has_zero_dual():
    mdp, part = _model(40, 6, seed=8)
    vstar = rlp_reference(mdp, part)
    i, j = int(np.argmax(vstar)), int(np.argmin(vstar))
    rlp = RLP(mdp, part)
    res = rlp.solve("HIGHS", extra_constraints=[rlp.v[j] <= rlp.v[i]])
    assert res.ok and np.abs(res.values - vstar).max() <= 1e-8 * np.abs(vstar).max()
    assert _check_modified(mdp, res, part.labels) == "optimal"
    assert abs(res.extra_duals[0][0]) <= 1e-9
    assert res.kkt_gap <= res.accuracy * 10 * 40


def test_equality_and_elp_modifications_against_the_reference():
    mdp, part = _model(30, 5, seed=9)
    vstar = rlp_reference(mdp, part)
    i, j = int(np.argmin(vstar)), int(np.argmax(vstar))
    # v(i) == v(j) + 0.5 is v(i) >= v(j) + 0.5 and v(j) >= v(i) - 0.5; min-closed as well
    ref = least_point_with_links(mdp, part.labels, 5, [(i, j, 0.5), (j, i, -0.5)], vstar)
    rlp = RLP(mdp, part)
    res = rlp.solve("HIGHS", extra_constraints=[rlp.v[i] == rlp.v[j] + 0.5])
    assert res.ok and np.abs(res.values - ref).max() <= 1e-7 * np.abs(ref).max()
    assert _check_modified(mdp, res, part.labels) == "optimal"
    assert res.extra_duals[0].shape == (1,)
    # ELP with V(0) >= V*(0) + 1: the reference on singleton partitions
    vtrue = reference_solve(mdp)
    elp = ELP(mdp)
    floor = vtrue[0] + 1.0
    res = elp.solve("HIGHS", extra_constraints=[elp.V[0] >= floor])
    ident = np.arange(30)
    ref = least_point_with_links(mdp, ident, 30, [], np.where(ident == 0, floor, vtrue))
    assert res.ok and np.abs(res.values - ref).max() <= 1e-7 * np.abs(ref).max()
    assert (res.upper_values >= vtrue - 1e-9).all()  # still an upper bound on V*
    assert _check_modified(mdp, res) == "optimal"


def test_ib_modification_and_a_vector_constraint():
    mdp, part = _model(30, 5, seed=10)
    vstar = rlp_reference(mdp, part)
    ib = IB(mdp, part, 2)
    # v_2 >= v_1 + 0.25 entrywise: one vector constraint; v_1 >= v* still holds (Theorem 2)
    res = ib.solve("HIGHS", extra_constraints=[ib.v[1] >= ib.v[0] + 0.25])
    assert res.ok and res.extra_duals[0].shape == (5,)
    blocks = res.extra["blocks"]
    assert (blocks[1] >= blocks[0] + 0.25 - 1e-7).all()
    assert (blocks >= vstar - 1e-7).all()
    # block v_1's bracket is the certificate of all blocks on the original cyclic rows
    P = ind.dense_transitions(mdp.successors, mdp.probabilities_full())
    ref = ind.rlp_optimum(P, mdp.rewards, mdp.allowed, 0.9, part.labels)
    status = ind.assert_bracket(
        res, point=res.x, t_point=ind.ib_operator(P, mdp.rewards, mdp.allowed, 0.9,
                                                  part.labels, res.x, 2),
        discount=0.9, reward_absmax=float(np.abs(mdp.rewards).max()), n_terms=3,
        optimum=np.tile(ref.values, 2), optimum_err=ref.error, judged="upper",
        check_error_bound=False, what="IB modified",
    )  # fmt: skip
    assert status == "optimal" and res.error_bound == np.inf


def test_infeasible_modification_has_no_point():
    mdp, part = _model(20, 4, seed=11)
    rlp = RLP(mdp, part)
    res = rlp.solve("HIGHS", extra_constraints=[rlp.v[0] <= -1e6], raise_on_failure=False)
    assert res.status is Status.INFEASIBLE and np.isnan(res.values).all()
    with pytest.raises(SolverError, match="infeasible"):
        rlp.solve("HIGHS", extra_constraints=[rlp.v[0] <= -1e6])


def test_an_inaccurate_modified_point_is_reported_as_such():
    mdp, part = _model(20, 4, seed=12)
    vstar = rlp_reference(mdp, part)
    rlp = RLP(mdp, part)
    i, j = int(np.argmax(vstar)), int(np.argmin(vstar))
    res = rlp.solve(
        "SCS", accuracy=1e-300, extra_constraints=[rlp.v[i] <= rlp.v[j]], raise_on_failure=False
    )
    assert res.status is Status.INACCURATE and res.modified
    assert _check_modified(mdp, res, part.labels) == "inaccurate"  # still a valid bracket
    with pytest.raises(SolverError, match="kkt_gap"):
        rlp.solve("SCS", accuracy=1e-300, extra_constraints=[rlp.v[i] <= rlp.v[j]])


def test_bad_extra_constraints_are_refused_by_name():
    mdp, part = _model(20, 4, seed=13)
    rlp = RLP(mdp, part)
    other = cp.Variable(4, name="t")
    cases = [
        ([rlp.v[0] <= other[0]], "variable 't'"),
        ([cp.square(rlp.v[0]) <= 1], "not affine"),
        ([rlp.v[0]], "extra_constraints\\[0\\] must be a cvxpy constraint"),
        ([rlp.v >= 0, cp.norm(rlp.v, 1) <= 3], "extra_constraints\\[1\\]"),
        ([rlp.constraints["bellman"]], "already in RLP.problem"),
        ("v <= 1", "list of cvxpy constraints"),
        ([cp.PSD(cp.Variable((2, 2)))], "written with <=, >= or =="),
    ]
    for extra, msg in cases:
        with pytest.raises(ValidationError, match=msg):
            rlp.solve("HIGHS", extra_constraints=extra)
    # the problem itself is untouched by a refused or an accepted modification
    assert len(rlp.modified_problem([rlp.v[0] <= rlp.v[1]]).constraints) == 2
    assert len(rlp.problem.constraints) == 1
