"""Pairs without transitions, and the two conventions for a terminal state's worth.

A pair given a reward (or allowed) but without any transition is refused, naming the
pair, unless it is marked not available or its state is listed in ``terminal=``: the
silent alternative (the pair disappears with its reward) turned Gymnasium's Taxi into a
model whose V* is about -20 everywhere. ``terminal_reward="keep"`` (default) lets a
listed state pay its reward once, ``"zero"`` makes it worth 0 (Gymnasium, POMDPs.jl).

Every expected value is computed here with numpy: the model with its sink written out
by hand, then every deterministic policy solved with ``(I - lambda P_pi) V = R_pi``
(``_reference.brute_force``), or value iteration on Gymnasium's own ``P``.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.model import interop

from ._reference import brute_force

FM = lb.FiniteMDP


def _values(mdp):
    res = lb.solve_exact(mdp, "pi")
    return mdp.user_values(res.values)


# ---------------------------------------------------------------------- references
def _reference(P, R, discount, terminal, terminal_reward, allowed=None):
    """V* (user states) of P (A, n, n), R (n, A) with ``terminal`` states, by hand.

    A sink (state n, reward 0, absorbing) takes the probability missing from every row;
    a listed state's actions all move to the sink; with ``"zero"`` they pay 0.
    """
    P = np.asarray(P, float)
    A, n, _ = P.shape
    Pf = np.zeros((A, n + 1, n + 1))
    Pf[:, :n, :n] = P
    Pf[:, :n, n] = 1.0 - P.sum(axis=2)
    Pf[:, terminal, :] = 0.0
    Pf[:, terminal, n] = 1.0
    Pf[:, n, n] = 1.0
    Rf = np.zeros((n + 1, A))
    Rf[:n] = R
    if terminal_reward == "zero":
        Rf[terminal] = 0.0
    allow = np.ones((n + 1, A), bool)
    if allowed is not None:
        allow[:n] = allowed
    v, _ = brute_force(Pf, np.where(allow, Rf, 0.0), discount, allow)
    return v[:n]


def _gym_value_iteration(P, n, A, discount, tol=1e-13):
    """V* of a Gymnasium ``P[s][a] = [(p, s', r, terminated)]``: a terminated transition
    pays its reward and nothing after it (plain numpy value iteration)."""
    table = np.array([(x, a, *t) for x in range(n) for a in range(A) for t in P[x][a]], float)
    x, a, y = (table[:, k].astype(int) for k in (0, 1, 3))
    p, r, done = table[:, 2], table[:, 4], table[:, 5]
    go_on = p * (1.0 - done)  # the continuation's weight
    v = np.zeros(n)
    for _ in range(100_000):
        q = np.zeros((n, A))
        np.add.at(q, (x, a), p * r + discount * go_on * v[y])
        new = q.max(axis=1)
        if np.abs(new - v).max() < tol:
            return new
        v = new
    raise AssertionError("value iteration did not converge")


def _gym_rows(P, n, A, keep_terminated):
    """The natural conversion: ``[s, a, s', p]`` rows and ``rewards[s, a] = sum p r``."""
    rows, rewards, landing = [], np.zeros((n, A)), set()
    for x in range(n):
        for a in range(A):
            for p, y, r, done in P[x][a]:
                rewards[x, a] += p * r
                if done:
                    landing.add(y)
                if keep_terminated or not done:
                    rows.append([x, a, y, p])
    return np.array(rows, float), rewards, sorted(landing)


# ---------------------------------------------------------------------- a Taxi-like model
# Gymnasium's P: states 0 (far), 1 (near), 2 (at the destination, passenger aboard) and
# 3 (delivered); actions 0 toward the destination, 1 away, 2 drop off. Dropping off at
# the destination ends the episode with +20 (the only terminated transition); elsewhere
# it is illegal (-10). Moving costs 1 and slips w.p. 0.2.
TAXI_LIKE = {
    0: {0: [(0.8, 1, -1.0, False), (0.2, 0, -1.0, False)], 1: [(1.0, 0, -1.0, False)],
        2: [(1.0, 0, -10.0, False)]},
    1: {0: [(0.8, 2, -1.0, False), (0.2, 1, -1.0, False)], 1: [(1.0, 0, -1.0, False)],
        2: [(1.0, 1, -10.0, False)]},
    2: {0: [(1.0, 2, -1.0, False)], 1: [(1.0, 1, -1.0, False)], 2: [(1.0, 3, 20.0, True)]},
    3: {0: [(1.0, 3, -1.0, False)], 1: [(1.0, 3, -1.0, False)], 2: [(1.0, 3, -10.0, False)]},
}  # fmt: skip
GAMMA = 0.95


@pytest.mark.parametrize("terminal", [None, True, [3]], ids=["none", "sink", "landing"])
def test_taxi_like_natural_conversion_names_the_drop_off_pair(terminal):
    # drop the terminated transition, keep its reward: the drop-off pair (2, 2) has a
    # reward and no row. It used to vanish with its reward (V* = -20 everywhere).
    rows, rewards, _ = _gym_rows(TAXI_LIKE, 4, 3, keep_terminated=False)
    with pytest.raises(
        ValidationError,
        match=r"rewards\[2, 2\] = 20: the pair \(state 2, action 2\) has no transition.*"
        r"terminal=.*rewards\[2, 2\] = -inf",
    ):
        FM.from_transitions(rows, GAMMA, rewards, terminal=terminal)


def test_taxi_like_with_gymnasium_convention_has_the_right_values():
    v_gym = _gym_value_iteration(TAXI_LIKE, 4, 3, GAMMA)
    rows, rewards, landing = _gym_rows(TAXI_LIKE, 4, 3, keep_terminated=True)
    assert landing == [3]
    mdp = interop.from_transitions(
        FM, rows, GAMMA, rewards, terminal=landing, terminal_reward="zero"
    )
    v = _values(mdp)
    # the states that can be in an episode get Gymnasium's values; the delivered state
    # is worth 0 by the convention (Gymnasium's own P never reads its value)
    np.testing.assert_allclose(v[:3], v_gym[:3], rtol=1e-10)
    assert v[3] == pytest.approx(0.0, abs=1e-12)
    assert v[2] == pytest.approx(20.0) and v[0] > 0  # not about -20
    # the other convention: the delivered state pays its best reward (-1) once
    keep = _values(interop.from_transitions(FM, rows, GAMMA, rewards, terminal=landing))
    assert keep[3] == pytest.approx(-1.0) and keep[2] == pytest.approx(20.0 - GAMMA)


def test_real_taxi_v3():
    pytest.importorskip("gymnasium")
    # the class behind Taxi-v3's env.unwrapped (Gymnasium >= 1.4 registers it as Taxi-v4
    # and refuses the v3 id; its defaults are v3's deterministic dynamics)
    from gymnasium.envs.toy_text.taxi import TaxiEnv

    env = TaxiEnv()
    P = env.P
    n, A = int(env.observation_space.n), int(env.action_space.n)
    rows, rewards, landing = _gym_rows(P, n, A, keep_terminated=False)
    with pytest.raises(ValidationError, match=r"the pair \(state \d+, action 5\) has no transit"):
        FM.from_transitions(rows, GAMMA, rewards, terminal=True)
    rows, rewards, landing = _gym_rows(P, n, A, keep_terminated=True)
    mdp = interop.from_transitions(
        FM, rows, GAMMA, rewards, terminal=landing, terminal_reward="zero"
    )
    v = _values(mdp)
    v_gym = _gym_value_iteration(P, n, A, GAMMA, tol=1e-10)
    # the states of an episode: the passenger is not at its destination (the 100 others
    # are never visited; Gymnasium's P keeps them going, so its values there differ)
    live = np.array([x for x in range(n) if list(env.decode(x))[2] != list(env.decode(x))[3]])
    assert live.size == 400 and not np.isin(landing, live).any()
    np.testing.assert_allclose(v[live], v_gym[live], rtol=1e-8, atol=1e-8)
    assert v[live].max() == pytest.approx(20.0) and v[live].min() > -5.0  # not about -20
    np.testing.assert_allclose(v[landing], 0.0, atol=1e-10)


# ---------------------------------------------------------------------- both conventions
def _tiny_model():
    """4 states, 2 actions; state 3's rows are empty (it has rewards only)."""
    rng = np.random.default_rng(11)
    P = rng.random((2, 4, 4)) * (rng.random((2, 4, 4)) < 0.6)
    P[:, np.arange(4), rng.integers(0, 4, 4)] += 0.3
    P /= P.sum(axis=2, keepdims=True)
    P[:, 3, :] = 0.0
    R = rng.normal(size=(4, 2)) * 3
    R[3] = [4.0, -2.0]  # nonzero: the pairs of state 3 are given
    return P, R


def _converters(P, R):
    x, a = np.divmod(np.arange(R.size), R.shape[1])  # every pair, row-major
    ax, xx, yy = np.nonzero(P)
    rows = np.c_[xx, ax, yy, P[ax, xx, yy]]
    return {
        "from_matrices": lambda **kw: interop.from_matrices(FM, list(P), R, 0.9, **kw),
        "from_matrices-sparse": lambda **kw: interop.from_matrices(
            FM, [sp.csr_matrix(m) for m in P], R, 0.9, **kw
        ),
        "from_quantecon-product": lambda **kw: interop.from_quantecon(
            FM, R, P.transpose(1, 0, 2), 0.9, **kw
        ),
        "from_quantecon-sa": lambda **kw: interop.from_quantecon(
            FM, R[x, a], sp.csr_matrix(P[a, x]), 0.9, x, a, **kw
        ),
        "from_transitions": lambda **kw: interop.from_transitions(FM, rows, 0.9, R, **kw),
        "from_transitions-reward_rows": lambda **kw: interop.from_transitions(
            FM, rows, 0.9, reward_rows=np.c_[x, a, R[x, a]], **kw
        ),
    }


@pytest.mark.parametrize("terminal_reward", ["keep", "zero"])
@pytest.mark.parametrize(
    "form",
    [
        "from_matrices",
        "from_matrices-sparse",
        "from_quantecon-product",
        "from_quantecon-sa",
        "from_transitions",
        "from_transitions-reward_rows",
    ],
)
def test_terminal_reward_conventions_against_numpy(form, terminal_reward):
    P, R = _tiny_model()
    terminal = [1, 3]  # state 1's rows are discarded; state 3 has none
    mdp = _converters(P, R)[form](terminal=terminal, terminal_reward=terminal_reward)
    v = _values(mdp)
    ref = _reference(P, R, 0.9, terminal, terminal_reward)
    np.testing.assert_allclose(v, ref, rtol=1e-12, atol=1e-12)
    if terminal_reward == "keep":
        np.testing.assert_allclose(v[terminal], R[terminal].max(axis=1), rtol=1e-12)
    else:
        np.testing.assert_allclose(v[terminal], 0.0, atol=1e-12)
    assert mdp.sink and mdp.n_user_states == 4
    np.testing.assert_array_equal(mdp.allowed[3], [True, True])  # its given pairs


def test_the_two_conventions_differ_and_keep_is_the_default():
    P, R = _tiny_model()
    build = _converters(P, R)["from_transitions"]
    default, keep, zero = (_values(build(terminal=[1, 3], **kw)) for kw in (
        {}, {"terminal_reward": "keep"}, {"terminal_reward": "zero"}))  # fmt: skip
    np.testing.assert_array_equal(default, keep)
    assert np.abs(keep - zero).max() > 1.0


def test_zero_convention_with_costs():
    # sense="min": a terminal state costs nothing more either way
    P, C = _tiny_model()
    C = np.abs(C)
    mdp = interop.from_matrices(
        FM, list(P), C, 0.9, terminal=[1, 3], terminal_reward="zero", sense="min"
    )
    cost = _values(mdp)
    np.testing.assert_allclose(
        cost, -_reference(P, -C, 0.9, [1, 3], "zero"), rtol=1e-12, atol=1e-12
    )
    np.testing.assert_allclose(cost[[1, 3]], 0.0, atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"terminal": [1], "terminal_reward": "none"}, r"terminal_reward must be one of"),
        ({"terminal_reward": "zero"}, r"terminal_reward='zero' applies to the states listed"),
        ({"terminal": True, "terminal_reward": "zero"}, r"terminal=True lists none"),
    ],
)
def test_terminal_reward_is_checked(kwargs, message):
    P, R = _tiny_model()
    P[:, 3, 3] = 1.0
    for build in _converters(P, R).values():
        with pytest.raises(ValidationError, match=message):
            build(**kwargs)


# ---------------------------------------------------------------------- pairs without rows
ROWS = [[0, 0, 1, 1.0], [0, 1, 0, 1.0], [1, 0, 0, 1.0]]  # pair (1, 1) has no row


@pytest.mark.parametrize("terminal", [None, True])
def test_reward_on_a_pair_without_rows_is_refused(terminal):
    with pytest.raises(
        ValidationError, match=r"rewards\[1, 1\] = 5: the pair \(state 1, action 1\) has no tr"
    ):
        FM.from_transitions(ROWS, 0.9, [[1.0, 0.0], [2.0, 5.0]], terminal=terminal)
    with pytest.raises(
        ValidationError, match=r"reward_rows\[3\]: the pair \(state 1, action 1\) has no trans"
    ):
        FM.from_transitions(
            ROWS, 0.9, reward_rows=[[0, 0, 1], [0, 1, 0], [1, 0, 2], [1, 1, 0]], terminal=terminal
        )


@pytest.mark.parametrize("mark", [0.0, -np.inf, np.nan])
def test_zero_minus_inf_or_nan_marks_a_pair_without_rows_not_available(mark):
    mdp = FM.from_transitions(ROWS, 0.9, [[1.0, 0.0], [2.0, mark]])
    np.testing.assert_array_equal(mdp.allowed, [[True, True], [True, False]])
    # V(1) = 2 + 0.9 V(0), V(0) = max(1 + 0.9 V(1), 0 + 0.9 V(0)): by hand
    v0 = (1 + 0.9 * 2) / (1 - 0.81)
    np.testing.assert_allclose(_values(mdp), [v0, 2 + 0.9 * v0], rtol=1e-12)


def test_plus_inf_on_a_pair_without_rows_is_refused():
    with pytest.raises(ValidationError, match=r"rewards\[1, 1\] = inf is not finite"):
        FM.from_transitions(ROWS, 0.9, [[1.0, 0.0], [2.0, np.inf]], terminal=[1])


def test_rows_with_zero_probability_only_are_no_transition():
    rows = [*ROWS, [1, 1, 0, 0.0]]
    with pytest.raises(ValidationError, match=r"pair \(state 1, action 1\) has no transition"):
        FM.from_transitions(rows, 0.9, [[1.0, 0.0], [2.0, 5.0]], terminal=True)


def test_terminal_state_pairs_without_rows_pay_their_reward():
    # state 2 is listed and has no row: its given rewards are its actions (keep), or 0
    rows = [[0, 0, 1, 1.0], [0, 1, 2, 1.0], [1, 0, 2, 0.5], [1, 0, 0, 0.5]]
    rewards = np.array([[1.0, 3.0], [2.0, 0.0], [0.0, 7.0]])
    P = np.zeros((2, 3, 3))
    for x, a, y, p in rows:
        P[a, x, y] += p
    allowed = np.array([[True, True], [True, False], [False, True]])
    for terminal_reward in ("keep", "zero"):
        mdp = interop.from_transitions(
            FM, rows, 0.9, rewards, terminal=[2], terminal_reward=terminal_reward
        )
        np.testing.assert_array_equal(mdp.allowed[:3], allowed)
        ref = _reference(P, rewards, 0.9, [2], terminal_reward, allowed)
        np.testing.assert_allclose(_values(mdp), ref, rtol=1e-12, atol=1e-12)
    v = _values(FM.from_transitions(rows, 0.9, rewards, terminal=[2]))
    assert v[2] == pytest.approx(7.0, rel=1e-12)  # it used to be 0 (its rewards ignored)
    # with reward_rows: an entry for a listed state's pair without rows is its reward
    mdp = FM.from_transitions(
        rows, 0.9, reward_rows=[[0, 0, 1], [0, 1, 3], [1, 0, 2], [2, 1, 7]], terminal=[2]
    )
    np.testing.assert_allclose(_values(mdp), _reference(P, rewards, 0.9, [2], "keep", allowed))


def test_from_matrices_allowed_pair_with_an_empty_row():
    P = np.array([[[0.5, 0.5], [0.0, 0.0]], [[0.0, 1.0], [1.0, 0.0]]])  # row 1 of P[0]
    R = [[1.0, 2.0], [5.0, 0.0]]
    for terminal in (None, True):  # with a sink it used to end there, paying 5
        with pytest.raises(
            ValidationError,
            match=r"row 1 of P\[0\] is empty.*the pair \(state 1, action 0\) is allowed but has "
            r"no transition.*allowed\[1, 0\] = False",
        ):
            FM.from_matrices(P, R, 0.9, terminal=terminal)
    allowed = [[True, True], [False, True]]
    mdp = FM.from_matrices(P, R, 0.9, allowed=allowed, terminal=True)
    np.testing.assert_allclose(_values(mdp), _reference(P, R, 0.9, [], "keep", allowed))
    listed = FM.from_matrices(P, R, 0.9, terminal=[1])
    np.testing.assert_allclose(_values(listed), _reference(P, R, 0.9, [1], "keep"))


def test_from_quantecon_pair_with_an_empty_row():
    Q = np.array([[[0.5, 0.5], [0.0, 1.0], [1.0, 0.0]], [[0.0, 0.0], [1.0, 0.0], [0, 1.0]]])
    R = np.array([[1.0, 2.0, 0.0], [5.0, 0.0, 1.0]])  # pair (1, 0): reward 5, no transition
    for terminal in (None, True):
        with pytest.raises(
            ValidationError,
            match=r"Q\[1, 0, :\]: the pair \(state 1, action 0\) has no transition.*"
            r"R\[1, 0\] = -inf",
        ):
            FM.from_quantecon(R, Q, 0.9, terminal=terminal)
        with pytest.raises(
            ValidationError,
            match=r"Q\[3, :\] \(state 1, action 0\): the pair \(state 1, action 0\) has no "
            r"transition.*R\[3\] = -inf",
        ):
            FM.from_quantecon(R.ravel(), Q.reshape(6, 2), 0.9, [0, 0, 0, 1, 1, 1], [0, 1, 2] * 2,
                              terminal=terminal)  # fmt: skip
    masked = R.copy()
    masked[1, 0] = -np.inf  # QuantEcon's mark: not available
    mdp = FM.from_quantecon(masked, Q, 0.9, terminal=True)
    allowed = np.isfinite(masked)
    P = Q.transpose(1, 0, 2)
    np.testing.assert_allclose(_values(mdp), _reference(P, R, 0.9, [], "keep", allowed))
