"""Inexact policy iteration (``solve_exact(method="ipi")``) and its GMRES.

References are independent of lpbounds' kernels: a dense Howard policy iteration with
``numpy.linalg.solve`` (exact up to rounding) and dense matrix products. Each result's
certificate is held to its promise both ways (``tests/_independent.assert_dp_certificate``):
the true error is within ``error_bound`` and ``error_bound`` is no larger than the residual
recomputed here implies (an OPTIMAL one within ``(tol + rounding) / (1 - lambda)``).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.dp import exact_rows
from lpbounds.dp import krylov as _krylov
from lpbounds.patrol import PatrolModel, PatrolParams
from tests import _independent as ind


def dense_model(mdp: lb.FiniteMDP) -> tuple[np.ndarray, np.ndarray]:
    """``P`` (A, n, n) and ``R`` (n, A) with -inf at disallowed pairs, by plain loops."""
    n, a_n, n_out = mdp.successors.shape
    p = np.broadcast_to(mdp.probabilities, mdp.successors.shape)
    big = np.zeros((a_n, n, n))
    for x in range(n):
        for a in range(a_n):
            for ll in range(n_out):
                big[a, x, mdp.successors[x, a, ll]] += p[x, a, ll]
    return big, np.where(mdp.allowed, mdp.rewards, -np.inf)


def howard(mdp: lb.FiniteMDP) -> np.ndarray:
    """V* by dense policy iteration (a policy changes only for a strict gain)."""
    big, r = dense_model(mdp)
    n = mdp.n_states
    lam = mdp.discount
    pol = np.argmax(np.where(mdp.allowed, 0.0, -np.inf), axis=1)
    while True:
        p_pi = big[pol, np.arange(n)]
        v = np.linalg.solve(np.eye(n) - lam * p_pi, r[np.arange(n), pol])
        q = r + lam * np.einsum("axy,y->xa", big, v)
        cur = q[np.arange(n), pol]
        better = q.max(axis=1) > cur + 1e-12 * max(1.0, np.abs(v).max())
        if not better.any():
            return v
        pol = np.where(better, q.argmax(axis=1), pol)


def dense_bellman(mdp: lb.FiniteMDP, v: np.ndarray) -> np.ndarray:
    big, r = dense_model(mdp)
    return (r + mdp.discount * np.einsum("axy,y->xa", big, v)).max(axis=1)


def check(res, mdp, vstar, what=""):
    """The certificate both ways; ``vstar`` from :func:`howard` (exact to ~1e-13 relative)."""
    slack = 1e-13 * max(1.0, float(np.abs(vstar).max()))
    ind.assert_dp_certificate(res, dense_bellman(mdp, res.values), mdp.discount,
                              reference=vstar, reference_err=slack, what=what)  # fmt: skip


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 30),
    n_act=st.integers(1, 4),
    branching=st.integers(1, 4),
    discount=st.sampled_from([0.0, 0.5, 0.9, 0.99]),
    allowed=st.sampled_from([1.0, 0.6, 0.3]),
    shared=st.booleans(),
    seed=st.integers(0, 10_000),
)
def test_ipi_agrees_with_pi_and_its_certificate_bounds_the_true_error(
    n, n_act, branching, discount, allowed, shared, seed
):
    mdp = lb.garnet(
        n, n_act, branching, discount, seed=seed, allowed_fraction=allowed,
        shared_probabilities=shared,
    )  # fmt: skip
    ipi = lb.solve_exact(mdp, "ipi")
    pi = lb.solve_exact(mdp, "pi")
    assert ipi.converged and ipi.method == "ipi"
    assert ipi.residual <= ipi.tol
    vstar = howard(mdp)
    scale = max(1.0, float(np.abs(vstar).max()))
    err = float(np.abs(ipi.values - vstar).max())
    assert err <= ipi.error_bound + 1e-13 * scale, (err, ipi.error_bound)
    assert np.abs(ipi.values - pi.values).max() <= ipi.error_bound + pi.error_bound + 1e-13 * scale
    # the reported residual is the residual of the returned vector (dense recomputation)
    big, r = dense_model(mdp)
    tv = (r + discount * np.einsum("axy,y->xa", big, ipi.values)).max(axis=1)
    assert np.abs(tv - ipi.values).max() == pytest.approx(ipi.residual, abs=1e-12 * scale)
    assert mdp.allowed[np.arange(n), ipi.policy].all()
    check(ipi, mdp, vstar, "ipi")
    check(pi, mdp, vstar, "pi")


def test_error_bound_holds_at_loose_tolerances():
    mdp = lb.garnet(50, 3, 3, 0.95, seed=3, allowed_fraction=0.7)
    vstar = howard(mdp)
    for tol in (1e-1, 1e-3, 1e-6):
        res = lb.solve_exact(mdp, "ipi", tol=tol)
        assert res.residual <= tol
        assert np.abs(res.values - vstar).max() <= res.error_bound
        check(res, mdp, vstar, f"tol={tol}")


def test_post_decision_form_gives_the_numbers_of_the_rows():
    """The patrol's fast path runs the same GMRES on the same products: identical numbers."""
    mdp = PatrolModel(PatrolParams(N=8, stations=(0, 4), Gamma=5)).mdp()
    fast = lb.solve_exact(mdp, "ipi")
    plain = lb.solve_exact(exact_rows(mdp), "ipi")
    np.testing.assert_array_equal(fast.values, plain.values)
    np.testing.assert_array_equal(fast.policy_rows, plain.policy)
    assert fast.residual == plain.residual
    mpi = lb.solve_exact(mdp, "mpi")
    assert np.abs(fast.values - mpi.values).max() <= fast.error_bound + mpi.error_bound
    # both against V* by value iteration on the successor arrays (the patrol model's 180
    # states): valid, and no looser than their residuals
    ref = ind.fixed_point(
        lambda v: ind.successor_bellman(mdp.successors, mdp.probabilities_full(), mdp.rewards,
                                        mdp.allowed, mdp.discount, v),
        mpi.values, mdp.discount,
    )  # fmt: skip
    for res in (fast, plain, mpi):
        t = ind.successor_bellman(mdp.successors, mdp.probabilities_full(), mdp.rewards,
                                  mdp.allowed, mdp.discount, res.values)  # fmt: skip
        ind.assert_dp_certificate(res, t, mdp.discount, reference=ref.values,
                                  reference_err=ref.error, what=res.method)  # fmt: skip


def test_iteration_limit_keeps_a_valid_certificate():
    mdp = lb.garnet(40, 3, 3, 0.99, seed=5)
    vstar = howard(mdp)
    res = lb.solve_exact(mdp, "ipi", max_iter=1, raise_on_failure=False)
    assert res.status is lb.Status.ITERATION_LIMIT
    assert np.abs(res.values - vstar).max() <= res.error_bound
    check(res, mdp, vstar, "max_iter=1")  # wide, but exactly as its residual makes it
    with pytest.raises(lb.ConvergenceError, match="ipi stopped after 1 iterations"):
        lb.solve_exact(mdp, "ipi", max_iter=1)


def test_unknown_method_names_ipi():
    with pytest.raises(lb.ValidationError, match="'ipi'"):
        lb.solve_exact(lb.garnet(5, 2, 2), "krylov")


@pytest.mark.parametrize("precondition", [False, True])
def test_gmres_reaches_the_max_norm_target(precondition):
    rng = np.random.default_rng(0)
    n = 120
    p = rng.random((n, n)) * (rng.random((n, n)) < 0.05)
    p[np.arange(n), np.arange(n)] += 2.0  # self-loops: what the preconditioner is for
    p /= p.sum(axis=1, keepdims=True)
    a = np.eye(n) - 0.97 * p
    b = rng.standard_normal(n)
    dinv = 1.0 / np.diag(a) if precondition else None
    for target in (1e-2, 1e-6, 1e-11):
        d, k = _krylov.gmres(lambda z: a @ z, b, target, 15, 10_000, dinv)
        assert np.abs(b - a @ d).max() <= target
        assert k < 200  # restarted GMRES, not a stalled loop
    d, k = _krylov.gmres(lambda z: a @ z, b, 1e-14, 15, 7, dinv)
    assert k <= 8  # the product limit (plus the final residual) is respected


def test_gmres_zero_right_hand_side():
    d, k = _krylov.gmres(lambda z: 2 * z, np.zeros(5), 1e-12, 4, 100)
    assert k == 0 and not d.any()
