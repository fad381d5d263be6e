"""Accepted rows that do not sum to exactly 1: every DP bound holds for the model as stored.

The reference is exact: V* of the stored model (its float64 entries are rationals) in
rational arithmetic (``fractions.Fraction``, tests/_exact.py: policy iteration, then the
Bellman equation checked exactly), independent of lpbounds.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.stochastic import RowSums, row_sums
from tests import _exact as ex

EPS = float(np.finfo(np.float64).eps)


# ---------------------------------------------------------------------- the two examples
def test_row_summing_above_one_gets_the_stored_models_value():
    """Issue example: rows 0.5 + (0.5 + 9e-10) at discount 0.99999; V* = 1/(1 - lambda s)."""
    mdp = lb.FiniteMDP([[[0, 0]]], [0.5, 0.5 + 9e-10], [[1.0]], 0.99999)
    truth = float(1 / (1 - Fraction(0.99999) * (Fraction(0.5) + Fraction(0.5 + 9e-10))))
    assert truth == pytest.approx(100009.0007, abs=1e-4)
    for method in ("mpi", "vi", "pi", "ipi"):
        res = lb.solve_exact(mdp, method=method)
        assert res.status is lb.Status.OPTIMAL
        err = abs(float(res.values[0]) - truth)
        assert err <= res.error_bound, (method, err, res.error_bound)
        # and the bound is not vacuous: at most the requested tolerance's bound
        assert res.error_bound <= 2 * res.tol / (1 - 0.99999 * (1 + 9e-10)), method
    pb = lb.porteus_bounds(mdp, [100000.0])  # the value the old code returned
    assert pb.lower[0] <= truth <= pb.upper[0]
    assert pb.upper[0] - pb.lower[0] <= 20.0  # tight: the old answer is 9 away
    ev = lb.evaluate_policy(mdp, [0], method="iterative")
    assert abs(float(ev.values[0]) - truth) <= ev.error_bound


def test_effective_discount_at_least_one_is_refused_naming_the_row():
    with pytest.raises(ValidationError, match=r"effective discount .* probabilities"):
        lb.FiniteMDP([[[0, 0]]], [0.5, 0.5 + 9e-10], [[1.0]], 1 - 1e-10)
    probs = np.array([[[1.0, 0.0], [0.5, 0.5]], [[0.5, 0.5 + 9e-10], [1.0, 0.0]]])
    succ = np.zeros((2, 2, 2), dtype=np.int64)
    with pytest.raises(ValidationError, match=r"probabilities\[1, 0, :\]"):
        lb.FiniteMDP(succ, probs, np.ones((2, 2)), 1 - 1e-10)
    with pytest.raises(ValidationError, match=r"effective discount .* probs"):
        lb.BellmanRows.from_arrays([0], [0], [1.0], [[0, 0]], [0.5, 0.5 + 9e-10], 1 - 1e-10, 1)
    # the same rows at a discount that leaves a contraction are accepted
    lb.FiniteMDP(succ, probs, np.ones((2, 2)), 0.99999)


def test_model_and_row_system_accept_the_same_rows():
    """One rule: -1e-13 entries (clipped) and sums 1 +- 9e-10 pass both, 1 + 2e-9 neither."""
    good = [0.5 + 9e-10, 0.5, -1e-13]
    mdp = lb.FiniteMDP([[[0, 0, 0]]], good, [[1.0]], 0.9)
    rows = lb.BellmanRows.from_arrays([0], [0], [1.0], [[0, 0, 0]], good, 0.9, 1)
    assert mdp.probabilities.min() == 0.0 and rows.probs.min() == 0.0
    bad = [0.5 + 2e-9, 0.5, 0.0]
    with pytest.raises(ValidationError, match="sum to"):
        lb.FiniteMDP([[[0, 0, 0]]], bad, [[1.0]], 0.9)
    with pytest.raises(ValidationError, match="sum to"):
        lb.BellmanRows.from_arrays([0], [0], [1.0], [[0, 0, 0]], bad, 0.9, 1)
    for make in (
        lambda p: lb.FiniteMDP([[[0, 0, 0]]], p, [[1.0]], 0.9),
        lambda p: lb.BellmanRows.from_arrays([0], [0], [1.0], [[0, 0, 0]], p, 0.9, 1),
    ):
        with pytest.raises(ValidationError, match="negative"):
            make([1.0 + 1e-11, 1e-11, -2e-11])


def test_row_sums_bound_the_exact_sums():
    p = np.array([[0.1, 0.2, 0.7], [0.3, 0.3, 0.4 + 5e-10]])
    rs = row_sums(p)
    for row in p:
        exact = sum(Fraction(float(x)) for x in row)
        assert Fraction(rs.lo) <= exact <= Fraction(rs.hi)
    assert rs.delta == pytest.approx(5e-10, rel=1e-3)
    assert RowSums(1.0, 1.0, 5).delta < 4e-15  # stochastic rows: only the rounding allowance
    shared = np.broadcast_to(np.array([0.25, 0.75]), (1000, 2))
    assert row_sums(shared).computed_max == 1.0


# ---------------------------------------------------------------------- property test
@st.composite
def perturbed_mdps(draw):
    n = draw(st.integers(1, 4))
    n_act = draw(st.integers(1, 2 if n > 3 else 3))
    n_out = draw(st.integers(1, 3))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    succ = rng.integers(0, n, size=(n, n_act, n_out))
    probs = rng.random((n, n_act, n_out)) + 0.05
    probs /= probs.sum(axis=2, keepdims=True)
    # move each row's sum anywhere inside the accepted tolerance
    shift = draw(st.sampled_from([-9e-10, -3e-10, 0.0, 1e-12, 4e-10, 9e-10]))
    jitter = rng.uniform(-1, 1, size=(n, n_act)) * 0.1e-9
    probs[:, :, 0] += shift + jitter * (shift != 0)
    allowed = rng.random((n, n_act)) < 0.7
    allowed[np.arange(n), rng.integers(0, n_act, size=n)] = True
    scale = draw(st.sampled_from([1e-3, 1.0, 1e3]))
    rewards = np.round(rng.uniform(-1, 1, size=(n, n_act)), 3) * scale
    discount = draw(st.sampled_from([0.0, 0.5, 0.9, 0.99, 0.999, 0.9999, 0.99999]))
    return succ, probs, rewards, discount, allowed


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(perturbed_mdps())
def test_every_dp_bound_holds_for_the_stored_rows(case):
    succ, probs, rewards, discount, allowed = case
    mdp = lb.FiniteMDP(succ, probs, rewards, discount, allowed)
    exact = ex.mdp_groups(mdp.successors, mdp.probabilities, mdp.rewards, allowed, discount)
    truth = ex.rounded(ex.fixed_point(exact))
    # the reference is exact up to its final rounding to float64
    ref_err = 2 * EPS * float(np.abs(truth).max(initial=0.0))
    scale = float(np.abs(mdp.rewards[mdp.allowed]).max()) / (1 - discount)
    # plain VI needs about log(1e-10) / log(lambda) sweeps on a periodic chain (the
    # Porteus shift removes only the constant error mode): 2.3e5 at 0.9999
    # and MPI too on disconnected self-loops (no policy change, every mode at lambda): at
    # 0.99999 it stops at its iteration limit, with a bound that must still hold
    methods = ("mpi", "vi", "pi", "ipi") if discount <= 0.999 else ("mpi", "pi", "ipi")
    for method in methods:
        slow = method == "mpi" and discount > 0.999
        res = lb.solve_exact(
            mdp, method=method, max_iter=2000 if slow else 100_000, raise_on_failure=not slow
        )
        err = float(np.abs(res.values - truth).max())
        assert err <= res.error_bound + ref_err, (method, err, res.error_bound)
        if res.status is not lb.Status.OPTIMAL:
            assert slow and res.status is lb.Status.ITERATION_LIMIT, (method, res.status)
            continue
        # not vacuous: an OPTIMAL answer's bound is that of its tolerance (1e-10 scale)
        assert res.error_bound <= 1.01 * res.tol / (1 - discount * 1.000000001) + 1e-12 * (
            1 + scale
        ), method
    # Porteus brackets from the answer and from a visibly wrong vector
    rng = np.random.default_rng(0)
    for v in (res.values, truth + rng.uniform(-1, 1, truth.size) * 0.01 * (1 + scale)):
        pb = lb.porteus_bounds(mdp, v)
        slack = 16 * EPS * (1 + float(np.abs(truth).max())) / (1 - discount * 1.000000001)
        assert np.all(pb.lower <= truth + slack + ref_err)
        assert np.all(truth <= pb.upper + slack + ref_err)
        assert np.all(pb.lower_paper <= truth + slack + ref_err)
    # policy evaluation of the optimal policy
    for method in ("direct", "iterative"):
        try:
            ev = lb.evaluate_policy(mdp, res.policy, method=method)
        except lb.ConvergenceError:  # sweeps on self-loops at 0.99999: 2e6 > max_sweeps
            assert method == "iterative" and discount > 0.999
            continue
        vpi = ex.rounded(
            ex.policy_value(mdp.successors, mdp.probabilities, mdp.rewards, discount, res.policy)
        )
        assert float(np.abs(ev.values - vpi).max()) <= ev.error_bound + ref_err, method


def test_game_value_of_non_stochastic_rows():
    """solve_game (Fact 2's max-min) on rows summing to 1 + 9e-10, against exact algebra."""
    # one variable, one action, two terms: w = min(1 + lam s1 w, 2 + lam s2 w)
    lam = 0.99999
    p1, p2 = [0.5, 0.5 + 9e-10], [0.25, 0.75 - 9e-10]
    rows = lb.BellmanRows.from_arrays([0, 0], [0, 0], [1.0, 1.0], [[0, 0], [0, 0]],
                                      [p1, p2], lam, 1)  # fmt: skip
    res = lb.solve_game(rows)
    s = [sum(Fraction(x) for x in p) for p in (p1, p2)]
    truth = float(min(1 / (1 - Fraction(lam) * si) for si in s))  # the smaller fixed point
    assert abs(float(res.values[0]) - truth) <= res.error_bound
    assert abs(truth - 1 / (1 - lam)) > 100 * res.error_bound  # the old answer is excluded
