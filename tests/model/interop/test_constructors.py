"""The one-call constructors' own rules: layouts, masks, terminal states, costs, errors.

Expected values come from numpy enumeration (``_reference.brute_force``) or closed forms.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
import scipy.sparse as sp

import lpbounds as lb
from lpbounds.errors import ValidationError

from ._reference import assert_policy_optimal, brute_force, exact


def _random_model(rng, n, m, sparsity=0.5):
    """A (m, n, n) stochastic P with zeros, and R (n, m)."""
    P = rng.random((m, n, n)) * (rng.random((m, n, n)) < sparsity)
    P[:, np.arange(n), rng.integers(0, n, n)] += 0.2
    return P / P.sum(axis=2, keepdims=True), rng.normal(size=(n, m))


# ---------------------------------------------------------------------- layouts
def test_square_q_is_read_in_quantecons_layout_and_both_readings_differ():
    rng = np.random.default_rng(0)
    Q_sas, R = _random_model(rng, 3, 3)  # read below as Q[s, a, s']
    v_default, _ = exact(lb.FiniteMDP.from_quantecon(R, Q_sas, 0.9))  # n == m: QuantEcon's
    v_sas, _ = exact(lb.FiniteMDP.from_quantecon(R, Q_sas, 0.9, layout="sas"))
    np.testing.assert_array_equal(v_default, v_sas)
    v_ass, _ = exact(lb.FiniteMDP.from_quantecon(R, Q_sas, 0.9, layout="ass"))
    np.testing.assert_allclose(v_sas, brute_force(Q_sas.transpose(1, 0, 2), R, 0.9)[0], rtol=1e-12)
    np.testing.assert_allclose(v_ass, brute_force(Q_sas, R, 0.9)[0], rtol=1e-12)
    assert np.abs(v_sas - v_ass).max() > 1e-3  # guessing would give a wrong V*


def test_unambiguous_shapes_decide_the_layout():
    rng = np.random.default_rng(1)
    P, R = _random_model(rng, 4, 2)  # P[a, s, s'], (2, 4, 4)
    v_ref = brute_force(P, R, 0.8)[0]
    for Q in (P, P.transpose(1, 0, 2)):  # (2, 4, 4) and (4, 2, 4) with R (4, 2)
        np.testing.assert_allclose(exact(lb.FiniteMDP.from_quantecon(R, Q, 0.8))[0], v_ref)
    with pytest.raises(ValidationError, match=r"layout='sas' must have shape \(4, 2, 4\)"):
        lb.FiniteMDP.from_quantecon(R, P, 0.8, layout="sas")


def test_quantecon_shaped_P_given_to_pymdptoolbox_gets_a_hint():
    rng = np.random.default_rng(2)
    P, R = _random_model(rng, 4, 2)
    with pytest.raises(ValidationError, match=r"looks like Q\[state, action, next\]"):
        lb.FiniteMDP.from_pymdptoolbox(P.transpose(1, 0, 2), R, 0.9)


# ---------------------------------------------------------------------- rewards
def test_R_as_a_nested_list_of_shape_n_by_A():
    # the reported bug: a list of shape (3, 2) was read as 3 per-transition matrices
    rng = np.random.default_rng(3)
    P, R = _random_model(rng, 3, 2)
    mdp = lb.FiniteMDP.from_matrices(P, R.tolist(), 0.9)
    np.testing.assert_array_equal(mdp.rewards, R)
    with pytest.raises(ValidationError, match=r"R\[action, state\] is transposed.*pass R\.T"):
        lb.FiniteMDP.from_matrices(P, R.T.tolist(), 0.9)


def test_object_arrays_of_numbers_are_arrays():
    rng = np.random.default_rng(8)
    P, R = _random_model(rng, 4, 2)
    mdp = lb.FiniteMDP.from_pymdptoolbox(P, np.array(list(R[:, 0]), dtype=object), 0.9)
    np.testing.assert_array_equal(mdp.rewards, np.repeat(R[:, :1], 2, axis=1))


def test_dict_of_matrices_and_sparse_R():
    rng = np.random.default_rng(4)
    P, R = _random_model(rng, 5, 3)
    mdp = lb.FiniteMDP.from_pymdptoolbox(dict(enumerate(P)), sp.csr_matrix(R), 0.9)
    np.testing.assert_allclose(exact(mdp)[0], brute_force(P, R, 0.9)[0], rtol=1e-12)
    with pytest.raises(ValidationError, match=r"keys 0\.\.A-1"):
        lb.FiniteMDP.from_pymdptoolbox({1: P[0], 2: P[1]}, R[:, :2], 0.9)


def test_minus_inf_reward_hints_at_masks_and_allowed_works():
    rng = np.random.default_rng(5)
    P, R = _random_model(rng, 4, 2)
    R[2, 1] = -np.inf
    with pytest.raises(ValidationError, match=r"state 2, action 1 is -inf.*allowed="):
        lb.FiniteMDP.from_matrices(P, R, 0.9)
    allowed = np.isfinite(R)
    P_masked = P.copy()
    P_masked[1, 2, :] = 0.0  # the row of an unavailable pair is ignored, even if empty
    mdp = lb.FiniteMDP.from_matrices(P_masked, R, 0.9, allowed=allowed)
    v_ref, optimal = brute_force(P, np.where(allowed, R, 0), 0.9, allowed)
    v, pol = exact(mdp)
    np.testing.assert_allclose(v, v_ref, rtol=1e-12)
    assert_policy_optimal(pol, optimal)
    # the same model from QuantEcon's convention (-inf = not available)
    v_qe, _ = exact(lb.FiniteMDP.from_quantecon(R, P_masked, 0.9, layout="ass"))
    np.testing.assert_allclose(v_qe, v_ref, rtol=1e-12)


# ---------------------------------------------------------------------- terminal states
def test_rows_short_of_one_need_terminal():
    P = [np.array([[0.5, 0.0], [0.0, 1.0]])]
    with pytest.raises(ValidationError, match=r"row 0 of P\[0\].*sum to 0\.5.*terminal=True"):
        lb.FiniteMDP.from_matrices(P, [1.0, 2.0], 0.9)


def test_terminal_true_adds_a_sink_kept_out_of_user_values():
    # state 0 stays w.p. 0.5 (reward 1), the process ends w.p. 0.5: V(0) = 1 / (1 - 0.45);
    # state 1 stays for ever with reward 2: V(1) = 20
    P = [np.array([[0.5, 0.0], [0.0, 1.0]])]
    mdp = lb.FiniteMDP.from_matrices(P, [1.0, 2.0], 0.9, terminal=True)
    assert (mdp.n_states, mdp.n_user_states, mdp.sink) == (3, 2, True)
    res = lb.solve_exact(mdp, "pi")
    assert res.values[2] == 0.0
    np.testing.assert_allclose(mdp.user_values(res.values), [1 / 0.55, 20.0], rtol=1e-12)
    np.testing.assert_array_equal(mdp.user_policy(res.policy), [0, 0])
    # a model without a sink reports every state
    plain = lb.FiniteMDP.from_matrices([np.eye(2)], [1.0, 2.0], 0.9)
    assert plain.user_values(lb.solve_exact(plain, "pi").values).shape == (2,)


def test_terminal_states_pay_their_reward_then_end():
    # 0 -> 1 -> 2 with rewards 1, 10 and 5; state 1 is terminal: V(1) = 10, V(0) = 1 + 9
    P = [np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])]
    mdp = lb.FiniteMDP.from_matrices(P, [1.0, 10.0, 5.0], 0.9, terminal=[1])
    v = mdp.user_values(lb.solve_exact(mdp, "pi").values)
    np.testing.assert_allclose(v, [1 + 0.9 * 10, 10.0, 5 / 0.1], rtol=1e-12)
    same = lb.FiniteMDP.from_matrices(P, [1.0, 10.0, 5.0], 0.9, terminal=[False, True, False])
    np.testing.assert_array_equal(same.successors, mdp.successors)
    with pytest.raises(ValidationError, match=r"terminal\[0\] = 7 is not a state"):
        lb.FiniteMDP.from_matrices(P, [1.0, 10.0, 5.0], 0.9, terminal=[7])


def test_from_transitions_terminal_state_without_rows():
    # state 2 is the goal: no rows at all; reaching it ends the process (value 0)
    rows = [[0, 0, 1, 1.0], [0, 1, 2, 1.0], [1, 0, 2, 0.5], [1, 0, 0, 0.5]]
    rewards = np.array([[1.0, 3.0], [2.0, 0.0], [0.0, 0.0]])
    with pytest.raises(ValidationError, match="state 2 has no allowed action"):
        lb.FiniteMDP.from_transitions(rows, 0.9, rewards)
    mdp = lb.FiniteMDP.from_transitions(rows, 0.9, rewards, terminal=[2])
    v = mdp.user_values(lb.solve_exact(mdp, "pi").values)
    # V(2) = 0; V(1) = 2 + 0.45 V(0); V(0) = max(1 + 0.9 V(1), 3): both by enumeration
    cands = []
    for a0 in (0, 1):
        A = np.array([[1.0, -0.9 if a0 == 0 else 0.0], [-0.45, 1.0]])
        b = np.array([1.0 if a0 == 0 else 3.0, 2.0])
        cands.append(np.linalg.solve(A, b))
    np.testing.assert_allclose(v, np.r_[np.maximum(*cands), 0.0], rtol=1e-12, atol=1e-12)


# ---------------------------------------------------------------------- costs
def test_sense_min_reports_costs_and_swaps_bounds():
    rng = np.random.default_rng(6)
    P, C = _random_model(rng, 5, 3)
    C = np.abs(C)
    mdp = lb.FiniteMDP.from_matrices(P, C, 0.9, sense="min")
    assert mdp.sense == "min"
    np.testing.assert_array_equal(mdp.rewards, -C)
    res = lb.solve_exact(mdp, "pi")
    cost_to_go = mdp.user_values(res.values)
    # minimum cost by enumeration: -(max of -C)
    np.testing.assert_allclose(cost_to_go, -brute_force(P, -C, 0.9)[0], rtol=1e-12)
    # a bracket of the stored (reward) problem becomes a bracket on the costs-to-go
    pb = lb.porteus_bounds(mdp, res.values + rng.normal(scale=0.5, size=5))
    lo, hi = mdp.user_bounds(pb.lower, pb.upper)
    assert np.all(lo <= cost_to_go + 1e-9) and np.all(cost_to_go <= hi + 1e-9)
    assert np.all(hi - lo > 0)
    lo_s, hi_s = mdp.user_bounds(-3.0, 5.0)  # a scalar c'V bracket
    assert (lo_s, hi_s) == (-5.0, 3.0)


def test_sink_flag_is_checked():
    succ = np.array([[[1]], [[0]]])
    with pytest.raises(ValidationError, match="sink=True: the last state 1 must be absorbing"):
        lb.FiniteMDP(succ, [1.0], [[0.0], [0.0]], 0.9, sink=True)
    succ = np.array([[[1]], [[1]]])
    with pytest.raises(ValidationError, match=r"must pay reward 0; rewards\[1, 0\] = 2"):
        lb.FiniteMDP(succ, [1.0], [[0.0], [2.0]], 0.9, sink=True)
    with pytest.raises(ValidationError, match="sense must be one of"):
        lb.FiniteMDP(succ, [1.0], [[0.0], [0.0]], 0.9, sense="minimise")


# ---------------------------------------------------------------------- transitions
def test_from_transitions_per_transition_rewards_match_matrices():
    rng = np.random.default_rng(7)
    P, _ = _random_model(rng, 4, 2)
    Rt = rng.normal(size=P.shape)
    a, x, y = np.nonzero(P)
    rows = np.c_[x, a, y, P[a, x, y], Rt[a, x, y]]
    mdp = lb.FiniteMDP.from_transitions(rows[rng.permutation(len(rows))], 0.9)
    ref = lb.FiniteMDP.from_matrices(P, Rt, 0.9)
    np.testing.assert_allclose(mdp.rewards, ref.rewards, atol=1e-14)
    np.testing.assert_allclose(exact(mdp)[0], brute_force(P, (P * Rt).sum(2).T, 0.9)[0])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({}, "exactly one of rewards= .* or reward_rows="),
        ({"rewards": np.zeros((2, 1)), "reward_rows": [[0, 0, 1]]}, "exactly one of"),
        ({"reward_rows": [[0, 0, 1.0]]}, r"pair \(state 1, action 0\) has transitions but no"),
        (
            {"reward_rows": [[0, 0, 1], [1, 0, 2], [1, 1, 3]], "n_actions": 2},
            r"reward_rows\[2\]: the pair \(state 1, action 1\) has no transition",
        ),
        ({"reward_rows": [[0, 0, 1], [1, 2, 3]]}, r"reward_rows\[1, 1\] = 2: the action"),
        (
            {"reward_rows": [[0, 0, 1], [1, 0, 2], [0, 0, 3]]},
            r"reward_rows\[2\]: the pair \(0, 0\) has two rewards",
        ),
        ({"rewards": np.zeros((2, 2))}, r"rewards must have shape \(2, 1\)"),
    ],
)
def test_from_transitions_reward_errors(kwargs, message):
    rows = [[0, 0, 1, 1.0], [1, 0, 0, 1.0]]
    with pytest.raises(ValidationError, match=message):
        lb.FiniteMDP.from_transitions(rows, 0.9, **kwargs)


def test_from_transitions_index_errors():
    with pytest.raises(ValidationError, match=r"rows\[1, 2\] = 0.5 is not a whole number"):
        lb.FiniteMDP.from_transitions([[0, 0, 0, 1.0], [0, 1, 0.5, 1.0]], 0.9, [[1, 1]])
    with pytest.raises(ValidationError, match=r"rows\[0, 2\] = 3: the next state is out of"):
        lb.FiniteMDP.from_transitions([[0, 0, 3, 1.0]], 0.9, [[1]], n_states=2)
    with pytest.raises(ValidationError, match=r"rows must have shape \(K, 4\)"):
        lb.FiniteMDP.from_transitions([[0, 0, 1.0]], 0.9, [[1]])


def test_to_quantecon_without_quantecon(monkeypatch):
    monkeypatch.setitem(sys.modules, "quantecon", None)
    monkeypatch.setitem(sys.modules, "quantecon.markov", None)
    mdp = lb.FiniteMDP.from_matrices([np.eye(2)], [1.0, 2.0], 0.9)
    with pytest.raises(ImportError, match=r"lpbounds\[interop\]"):
        mdp.to_quantecon()


def test_repr_shows_sense_and_sink_only_when_set():
    mdp = lb.FiniteMDP.from_matrices([np.eye(2) * 0.5], [1.0, 2.0], 0.9, terminal=True, sense="min")
    assert repr(mdp).endswith("sense='min', sink=True)")
    assert "sense" not in repr(lb.FiniteMDP.from_matrices([np.eye(2)], [1.0, 2.0], 0.9))


@pytest.mark.parametrize(
    ("build", "message"),
    [
        # a negative probability must not hide behind a duplicate that sums to one
        (
            lambda: lb.FiniteMDP.from_transitions([[0, 0, 0, -1], [0, 0, 0, 2]], 0.9, [[0]]),
            r"rows\[0, 3\] = -1.0: a probability is negative",
        ),
        (
            lambda: lb.FiniteMDP.from_quantecon(
                [1.0], sp.coo_matrix(([-1.0, 2.0], ([0, 0], [0, 0])), shape=(1, 1)), 0.9, [0], [0]
            ),
            r"Q\[0, :\] \(state 0, action 0\): the probability -1.0 of next state 0 is negative",
        ),
        # an index of 2**40 is refused before anything of that size is allocated
        (
            lambda: lb.FiniteMDP.from_transitions([[0, 0, 2**40, 1]], 0.9, reward_rows=[[0, 0, 1]]),
            r"1099511627777 states x 1 actions .* beyond the dense",
        ),
        (
            lambda: lb.FiniteMDP.from_quantecon([1.0], [[1.0]], 0.9, [0], [2**62]),
            r"4611686018427387905 actions .* beyond the dense",
        ),
        (
            lambda: lb.FiniteMDP.from_transitions(
                [[0, 0, 0, 1.0], [2, 0, 2, 1.0]], 0.9, reward_rows=[[0, 0, 1], [2, 0, 1]]
            ),
            r"state 1 has no allowed action .* terminal=",
        ),
        (lambda: lb.FiniteMDP.from_quantecon([], np.zeros((0, 2)), 0.9, [], []), "no pair"),
    ],
    ids=["hidden-negative", "hidden-negative-coo", "huge-state", "huge-action", "gap", "empty"],
)
def test_hostile_inputs(build, message):
    with pytest.raises(ValidationError, match=message):
        build()


def test_negative_entry_of_a_coo_P_is_not_summed_away():
    hidden = sp.coo_matrix(([-1.0, 2.0, 1.0], ([0, 0, 1], [0, 0, 1])), shape=(2, 2))
    with pytest.raises(ValidationError, match=r"row 0 of P\[0\]: the probability -1.0 of next"):
        lb.FiniteMDP.from_pymdptoolbox([hidden], [0.0, 0.0], 0.9)
