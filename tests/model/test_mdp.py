"""FiniteMDP: validation at the boundary and pymdptoolbox-style conversions."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import lpbounds as lb
from lpbounds.errors import ValidationError


def _arrays(n=3, a=2, ll=2):
    succ = np.zeros((n, a, ll), dtype=int)
    succ[..., 1] = 1
    probs = np.array([0.25, 0.75])
    rewards = np.arange(n * a, dtype=float).reshape(n, a)
    return succ, probs, rewards


def test_valid_model_properties():
    succ, probs, rewards = _arrays()
    mdp = lb.FiniteMDP(succ, probs, rewards, 0.5)
    assert (mdp.n_states, mdp.n_actions, mdp.n_outcomes) == (3, 2, 2)
    assert mdp.shared_probabilities
    assert mdp.n_pairs == 6
    assert mdp.reward_absmax == 5.0
    assert not mdp.successors.flags.writeable


@pytest.mark.parametrize("discount", [-0.1, 1.0, 1.5, float("nan"), "x"])
def test_discount_outside_unit_interval(discount):
    succ, probs, rewards = _arrays()
    with pytest.raises(ValidationError, match="discount"):
        lb.FiniteMDP(succ, probs, rewards, discount)


def test_successor_out_of_range_is_named():
    succ, probs, rewards = _arrays()
    succ[2, 1, 0] = 7
    with pytest.raises(ValidationError, match=r"successors\[2, 1, 0\] = 7"):
        lb.FiniteMDP(succ, probs, rewards, 0.9)


def test_negative_successor():
    succ, probs, rewards = _arrays()
    succ[0, 0, 1] = -1
    with pytest.raises(ValidationError, match=r"successors\[0, 0, 1\] = -1"):
        lb.FiniteMDP(succ, probs, rewards, 0.9)


def test_probabilities_must_sum_to_one():
    succ, _, rewards = _arrays()
    with pytest.raises(ValidationError, match=r"sum to 0\.9"):
        lb.FiniteMDP(succ, [0.2, 0.7], rewards, 0.9)


def test_state_dependent_probabilities_bad_pair_named():
    succ, _, rewards = _arrays()
    p = np.full((3, 2, 2), 0.5)
    p[1, 0] = [0.5, 0.6]
    with pytest.raises(ValidationError, match=r"probabilities\[1, 0, :\] sum to 1.1"):
        lb.FiniteMDP(succ, p, rewards, 0.9)


def test_negative_probability_named():
    succ, _, rewards = _arrays()
    p = np.full((3, 2, 2), 0.5)
    p[2, 1] = [1.5, -0.5]
    with pytest.raises(ValidationError, match=r"probabilities\[2, 1, 1\] = -0.5 is negative"):
        lb.FiniteMDP(succ, p, rewards, 0.9)


def test_probability_sum_tolerance_is_the_documented_one():
    succ, _, rewards = _arrays()
    tol = lb.tolerances.PROBABILITY_SUM_ATOL
    lb.FiniteMDP(succ, [0.5, 0.5 + 0.5 * tol], rewards, 0.9)  # inside: accepted
    with pytest.raises(ValidationError):
        lb.FiniteMDP(succ, [0.5, 0.5 + 3 * tol], rewards, 0.9)


def test_state_without_allowed_action():
    succ, probs, rewards = _arrays()
    allowed = np.ones((3, 2), bool)
    allowed[1] = False
    with pytest.raises(ValidationError, match="state 1 has no allowed action"):
        lb.FiniteMDP(succ, probs, rewards, 0.9, allowed)


def test_nonfinite_reward_on_allowed_pair_only():
    succ, probs, rewards = _arrays()
    rewards[0, 1] = np.nan
    with pytest.raises(ValidationError, match=r"rewards\[0, 1\] = nan"):
        lb.FiniteMDP(succ, probs, rewards, 0.9)
    allowed = np.ones((3, 2), bool)
    allowed[0, 1] = False
    mdp = lb.FiniteMDP(succ, probs, rewards, 0.9, allowed)  # ignored where disallowed
    assert np.isfinite(mdp.rewards).all()


def test_shape_mismatches():
    succ, probs, rewards = _arrays()
    with pytest.raises(ValidationError, match="rewards must have shape"):
        lb.FiniteMDP(succ, probs, rewards[:2], 0.9)
    with pytest.raises(ValidationError, match="probabilities must have shape"):
        lb.FiniteMDP(succ, [1.0], rewards, 0.9)
    with pytest.raises(ValidationError, match="successors must have shape"):
        lb.FiniteMDP(succ[0], probs, rewards, 0.9)
    with pytest.raises(ValidationError, match="allowed must have shape"):
        lb.FiniteMDP(succ, probs, rewards, 0.9, np.ones((3, 3), bool))


def test_non_integer_successors():
    succ, probs, rewards = _arrays()
    with pytest.raises(ValidationError, match="integers"):
        lb.FiniteMDP(succ + 0.5, probs, rewards, 0.9)


def _random_matrices(rng, n, a):
    mats = []
    for _ in range(a):
        m = rng.random((n, n)) * (rng.random((n, n)) < 0.4)
        m[np.arange(n), rng.integers(0, n, n)] += 0.1
        mats.append(m / m.sum(axis=1, keepdims=True))
    return mats


@pytest.mark.parametrize("sparse", [False, True])
def test_from_matrices_round_trip(sparse):
    rng = np.random.default_rng(1)
    n, a = 7, 3
    mats = _random_matrices(rng, n, a)
    rew = rng.random((n, a))
    given = [sp.csr_matrix(m) for m in mats] if sparse else np.array(mats)
    mdp = lb.FiniteMDP.from_matrices(given, rew, 0.8)
    back, r2 = mdp.to_matrices()
    for m, b in zip(mats, back, strict=True):
        np.testing.assert_allclose(b.toarray(), m, atol=1e-15)
    np.testing.assert_array_equal(r2, rew)
    # the same V* as a direct solve over all deterministic policies of the matrices
    v = lb.solve_exact(mdp, "pi").values
    q = np.stack([rew[:, k] + 0.8 * mats[k] @ v for k in range(a)], axis=1)
    np.testing.assert_allclose(q.max(axis=1), v, atol=1e-10)


def test_from_matrices_transition_rewards_and_state_rewards():
    rng = np.random.default_rng(2)
    n, a = 5, 2
    mats = _random_matrices(rng, n, a)
    rmat = rng.random((a, n, n))
    mdp = lb.FiniteMDP.from_matrices(mats, rmat, 0.5)
    expected = np.stack([(mats[k] * rmat[k]).sum(axis=1) for k in range(a)], axis=1)
    np.testing.assert_allclose(mdp.rewards, expected, atol=1e-14)
    state_r = rng.random(n)
    mdp2 = lb.FiniteMDP.from_matrices(mats, state_r, 0.5)
    np.testing.assert_array_equal(mdp2.rewards, np.repeat(state_r[:, None], a, axis=1))


def test_from_matrices_errors():
    rng = np.random.default_rng(3)
    mats = _random_matrices(rng, 4, 2)
    bad = [m.copy() for m in mats]
    bad[1][2] = 0.0
    with pytest.raises(ValidationError, match=r"row 2 of P\[1\] is empty"):
        lb.FiniteMDP.from_matrices(bad, np.zeros((4, 2)), 0.9)
    bad = [m.copy() for m in mats]
    bad[0][3, 0] += 0.2
    with pytest.raises(ValidationError, match=r"row 3 of P\[0\]: the probabilities sum to 1\.2"):
        lb.FiniteMDP.from_matrices(bad, np.zeros((4, 2)), 0.9)
    with pytest.raises(ValidationError, match="R must have shape"):
        lb.FiniteMDP.from_matrices(mats, np.zeros((3, 2)), 0.9)
    with pytest.raises(ValidationError, match=r"P\[1\] has shape"):
        lb.FiniteMDP.from_matrices([mats[0], np.eye(3)], np.zeros((4, 2)), 0.9)


def test_to_matrices_with_disallowed_actions():
    succ, probs, rewards = _arrays()
    allowed = np.ones((3, 2), bool)
    allowed[1, 1] = False
    mdp = lb.FiniteMDP(succ, probs, rewards, 0.9, allowed)
    with pytest.raises(ValidationError, match="action 1 is not allowed in state 1"):
        mdp.to_matrices()
    P, R = mdp.to_matrices(disallowed_reward=-1e6)
    assert P[1][1, 1] == 1.0 and R[1, 1] == -1e6
    # the masked model and the penalised matrices have the same V*
    v_masked = lb.solve_exact(mdp).values
    v_pen = lb.solve_exact(lb.FiniteMDP.from_matrices(P, R, 0.9)).values
    np.testing.assert_allclose(v_masked, v_pen, atol=1e-8)


def test_copy_false_hands_arrays_over_without_copying():
    succ, probs, rewards = _arrays()
    succ = succ.astype(np.int32)
    owned = lb.FiniteMDP(succ, probs, rewards, 0.9, copy=False)
    assert np.shares_memory(owned.successors, succ)
    assert np.shares_memory(owned.rewards, rewards)
    assert not owned.successors.flags.writeable
    copied = lb.FiniteMDP(succ.copy(), probs, rewards.copy(), 0.9)
    assert not np.shares_memory(copied.successors, succ)


def test_disallowed_successors_out_of_range_are_made_self_loops_on_a_copy():
    succ, probs, rewards = _arrays()
    succ[1, 1, :] = 99  # out of range, but the pair is disallowed: never read
    allowed = np.ones((3, 2), bool)
    allowed[1, 1] = False
    given = succ.copy()
    mdp = lb.FiniteMDP(succ, probs, rewards, 0.9, allowed)
    np.testing.assert_array_equal(mdp.successors[1, 1], [1, 1])
    np.testing.assert_array_equal(succ, given)  # the caller's array is untouched
    assert mdp.rewards[1, 1] == 0.0  # disallowed rewards are stored as 0


def test_indices_are_range_checked_before_the_cast_to_int32():
    """An int64 successor 2**32 + 1 used to be cast to int32 first and wrap to state 1."""
    succ, probs, rewards = _arrays()
    succ = succ.astype(np.int64)
    succ[2, 1, 0] = 2**32 + 1
    assert np.int32(succ[2, 1, 0].astype(np.int32)) == 1  # what the old cast produced
    with pytest.raises(ValidationError, match=r"successors\[2, 1, 0\] = 4294967297 is out of"):
        lb.FiniteMDP(succ, probs, rewards, 0.9)
    # on a disallowed pair the same entry is never read: stored as a self-loop
    allowed = np.ones((3, 2), bool)
    allowed[2, 1] = False
    mdp = lb.FiniteMDP(succ, probs, rewards, 0.9, allowed)
    np.testing.assert_array_equal(mdp.successors[2, 1], [2] * succ.shape[2])


@pytest.mark.parametrize("bad", [False, True, "0.9", None, 0.9 + 0j])
def test_discount_is_never_coerced(bad):
    succ, probs, rewards = _arrays()
    with pytest.raises(ValidationError, match="discount must be a real number"):
        lb.FiniteMDP(succ, probs, rewards, bad)


def test_copy_true_copies_views_of_the_callers_arrays():
    """A view (``a[::1]``, a memmap) is not the same object as the caller's array but is
    the same memory: ``copy=True`` must still copy it, or a later write by the caller
    would change the model behind its read-only arrays."""
    succ, probs, rewards = _arrays()
    succ = succ.astype(np.int32)
    mdp = lb.FiniteMDP(succ[::1], probs, rewards[::1], 0.9)
    assert not np.shares_memory(mdp.successors, succ)
    assert not np.shares_memory(mdp.rewards, rewards)
    rewards[0, 0] = 99.0
    assert mdp.rewards[0, 0] == 0.0
