"""Gymnasium's tabular environments: ``from_gymnasium`` against value iteration on ``P``.

The reference is computed here, independently of lpbounds: plain numpy value iteration
on Gymnasium's own ``env.unwrapped.P[s][a] = [(p, s', r, terminated), ...]``, where a
terminated transition pays its reward and nothing after it.
"""

from __future__ import annotations

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.formulations import RLP
from lpbounds.model.gymnasium import from_gymnasium

gym = pytest.importorskip("gymnasium")

FM = lb.FiniteMDP
REGISTERED = set(gym.envs.registry)
TAXI = "Taxi-v3" if "Taxi-v3" in REGISTERED else "Taxi-v4"  # 1.4 refuses the v3 id
CLIFF = "CliffWalking-v1" if "CliffWalking-v1" in REGISTERED else "CliffWalking-v0"

ENVS = {
    "FrozenLake-4x4-slippery": ("FrozenLake-v1", {"is_slippery": True}),
    "FrozenLake-4x4": ("FrozenLake-v1", {"is_slippery": False}),
    "FrozenLake-8x8-slippery": ("FrozenLake-v1", {"map_name": "8x8", "is_slippery": True}),
    "FrozenLake-8x8": ("FrozenLake-v1", {"map_name": "8x8", "is_slippery": False}),
    "Taxi": (TAXI, {}),
    "CliffWalking": (CLIFF, {}),
}
_CACHE: dict[str, object] = {}


def _env(name):
    if name not in _CACHE:
        env_id, kwargs = ENVS[name]
        _CACHE[name] = gym.make(env_id, **kwargs)
    return _CACHE[name]


def _table(env):
    """Gymnasium's P as flat arrays: state, action, p, next state, r, terminated."""
    P = env.unwrapped.P
    n, m = int(env.observation_space.n), int(env.action_space.n)
    t = np.array([(x, a, *e) for x in range(n) for a in range(m) for e in P[x][a]], float)
    return n, m, t


def value_iteration(env, discount):
    """V* of Gymnasium's P: ``V(s) = max_a sum p (r + discount * (0 if done else V(s')))``.

    Stops when the sup-norm change is below ``1e-13 * max|r|``; the error is then at most
    ``discount / (1 - discount)`` times that (below 1e-10 here).
    """
    n, m, t = _table(env)
    x, a, y = (t[:, k].astype(int) for k in (0, 1, 3))
    p, r, done = t[:, 2], t[:, 4], t[:, 5]
    pair = x * m + a
    stop = 1e-13 * max(1.0, np.abs(r).max())
    cont = discount * p * (1.0 - done)
    pr = p * r
    v = np.zeros(n)
    for _ in range(200_000):
        q = np.bincount(pair, weights=pr + cont * v[y], minlength=n * m).reshape(n, m)
        new = q.max(axis=1)
        if np.abs(new - v).max() < stop:
            return new
        v = new
    raise AssertionError("value iteration did not converge")


def _tight_tol(env):
    return 1e-12 * max(1.0, np.abs(_table(env)[2][:, 4]).max())


@pytest.mark.parametrize("discount", [0.9, 0.99])
@pytest.mark.parametrize("name", list(ENVS))
def test_values_match_value_iteration_on_p(name, discount):
    env = _env(name)
    n = int(env.observation_space.n)
    mdp = FM.from_gymnasium(env, discount) if hasattr(FM, "from_gymnasium") else None
    if mdp is None:  # before the classmethod is wired: the converter itself
        mdp = from_gymnasium(FM, env, discount)
    assert mdp.sink and mdp.n_states == n + 1 and mdp.n_user_states == n
    assert mdp.n_actions == int(env.action_space.n)
    ref = value_iteration(env, discount)
    # default settings: the default accuracy (DP_RTOL max|R|) passes a 1e-9 cross-check
    res = lb.solve_exact(mdp)
    v = mdp.user_values(res.values)
    assert v.shape == (n,)
    np.testing.assert_allclose(v, ref, rtol=0, atol=1e-9)
    assert abs(res.values[n]) <= 1e-9  # the sink (V* = 0; MPI's shift leaves a trace)
    assert np.all(res.lower_values[:n] - 1e-12 <= ref)
    assert np.all(ref <= res.upper_values[:n] + 1e-12)
    lo, hi = mdp.user_bounds(res.lower_values, res.upper_values)
    assert lo.shape == hi.shape == (n,)


@pytest.mark.parametrize("mixed", [False, True], ids=["sink-alone", "sink-mixed"])
@pytest.mark.parametrize("name", ["FrozenLake-4x4-slippery", "Taxi", "CliffWalking"])
def test_rlp_upper_bound_holds(name, mixed):
    """With the partition of the model (the sink alone) and with that of the state count,
    which puts the sink among live states: a valid bound either way, the second said."""
    env = _env(name)
    mdp = from_gymnasium(FM, env, 0.9)
    v_star = lb.solve_exact(mdp, tol=_tight_tol(env)).values
    if mixed:
        partition = lb.random_partition(mdp.n_states, 4, seed=0)
        with pytest.warns(lb.errors.PartitionWarning, match="holds the sink"):
            form = RLP(mdp, partition)
    else:
        partition = lb.random_partition(mdp, 4, seed=0)
        form = RLP(mdp, partition)
    res = form.solve()
    assert res.status == lb.Status.OPTIMAL
    assert np.all(partition.lift(res.upper_values) >= v_star - 1e-9)


def test_wrapped_and_unwrapped_give_the_same_model():
    env = _env("FrozenLake-4x4-slippery")
    a, b = (from_gymnasium(FM, e, 0.9) for e in (env, env.unwrapped))
    np.testing.assert_array_equal(a.successors, b.successors)
    np.testing.assert_array_equal(a.probabilities, b.probabilities)
    np.testing.assert_array_equal(a.rewards, b.rewards)


# ---------------------------------------------------------------------- small fake envs
class _Space:
    def __init__(self, n):
        self.n = n


class _Env:
    """What from_gymnasium reads: P and two Discrete-like spaces (no Gymnasium)."""

    def __init__(self, P, n, m):
        self.P = P
        self.observation_space = _Space(n)
        self.action_space = _Space(m)


# state 0: action 0 stays (reward 1, listed as two halves), action 1 ends with +5 w.p.
# 0.5 (else moves to 1); state 1: both actions move to 0 with reward 0
TWO = {
    0: {0: [(0.5, 0, 1.0, False), (0.5, 0, 1.0, False)],
        1: [(0.5, 1, 5.0, True), (0.5, 1, 0.0, False)]},
    1: {0: [(1.0, 0, 0.0, False)], 1: [(1.0, 0, 0.0, False)]},
}  # fmt: skip


def _copy(P):
    return {x: {a: list(e) for a, e in acts.items()} for x, acts in P.items()}


def test_fake_env_by_hand():
    mdp = from_gymnasium(FM, _Env(TWO, 2, 2), 0.9)
    assert mdp.sink and mdp.n_states == 3
    np.testing.assert_allclose(mdp.rewards, [[1.0, 2.5], [0.0, 0.0], [0.0, 0.0]])
    full = mdp.probabilities_full()
    # duplicates add up: P_0(0, 0) = 1; action 1 of state 0 reaches 1 and the sink
    dense = np.zeros((3, 2, 3))
    for x in range(3):
        for a in range(2):
            np.add.at(dense[x, a], mdp.successors[x, a], full[x, a])
    np.testing.assert_allclose(dense[0, 0], [1, 0, 0])
    np.testing.assert_allclose(dense[0, 1], [0, 0.5, 0.5])
    np.testing.assert_allclose(dense[2], [[0, 0, 1], [0, 0, 1]])
    # V(0) = max(1 + .9 V(0), 2.5 + .45 V(1)), V(1) = .9 V(0): action 0, V(0) = 10
    v = mdp.user_values(lb.solve_exact(mdp, tol=1e-13).values)
    np.testing.assert_allclose(v, [10.0, 9.0], rtol=1e-12)


def test_sink_option():
    cont = _copy(TWO)
    cont[0][1] = [(1.0, 1, 2.5, False)]
    plain = from_gymnasium(FM, _Env(cont, 2, 2), 0.9)
    assert not plain.sink and plain.n_states == 2  # nothing terminated: no sink
    forced = from_gymnasium(FM, _Env(cont, 2, 2), 0.9, sink=True)
    assert forced.sink and forced.n_states == 3
    with pytest.raises(ValidationError, match=r"P\[0\]\[1\]\[0\] is terminated but sink=False"):
        from_gymnasium(FM, _Env(TWO, 2, 2), 0.9, sink=False)
    with pytest.raises(ValidationError, match=r"sink must be 'auto', True or False"):
        from_gymnasium(FM, _Env(TWO, 2, 2), 0.9, sink="yes")


def test_lists_instead_of_dicts():
    P = [[TWO[x][a] for a in range(2)] for x in range(2)]
    a, b = from_gymnasium(FM, _Env(P, 2, 2), 0.9), from_gymnasium(FM, _Env(TWO, 2, 2), 0.9)
    np.testing.assert_array_equal(a.rewards, b.rewards)


# ---------------------------------------------------------------------- errors
def test_no_table():
    class NoP:
        observation_space = _Space(2)
        action_space = _Space(2)

    with pytest.raises(ValidationError, match=r"env.unwrapped has no attribute P: .*tabular"):
        from_gymnasium(FM, NoP(), 0.9)
    with pytest.raises(ValidationError, match=r"no attribute P"):
        from_gymnasium(FM, gym.make("CartPole-v1"), 0.9)


def test_spaces_must_be_discrete():
    env = _Env(TWO, 2, 2)
    env.observation_space = object()
    with pytest.raises(ValidationError, match=r"observation_space is .* not a Discrete space"):
        from_gymnasium(FM, env, 0.9)
    env = _Env(TWO, 2, 2)
    del env.action_space
    with pytest.raises(ValidationError, match=r"env.unwrapped has no attribute action_space"):
        from_gymnasium(FM, env, 0.9)
    env = _Env(TWO, 2, 2)
    env.action_space.start = 1
    with pytest.raises(ValidationError, match=r"action_space starts at 1"):
        from_gymnasium(FM, env, 0.9)


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ((1.5, 0, 1.0, False), r"P\[0\]\[0\]\[1\]: the probability 1.5 is not in \[0, 1\]"),
        ((-0.5, 0, 1.0, False), r"P\[0\]\[0\]\[1\]: the probability -0.5 is not in"),
        ((np.nan, 0, 1.0, False), r"P\[0\]\[0\]\[1\]: the probability nan is not finite"),
        ((0.5, 2, 1.0, False), r"P\[0\]\[0\]\[1\]: the next state 2 is out of range \[0, 2\)"),
        ((0.5, -1, 1.0, False), r"P\[0\]\[0\]\[1\]: the next state -1 is out of range"),
        ((0.5, 1.0, 1.0, False), r"P\[0\]\[0\]\[1\]: the next state .* is not an integer"),
        ((0.5, 0, np.inf, False), r"P\[0\]\[0\]\[1\]: the reward inf is not finite"),
        ((0.5, 0, "1", False), r"P\[0\]\[0\]\[1\]: the reward .* is not a real number"),
        ((0.5, 0, 1.0, "no"), r"P\[0\]\[0\]\[1\]: terminated is .* not a bool"),
        ((0.5, 0, 1.0), r"P\[0\]\[0\]\[1\] has 3 fields; expected 4"),
        ((0.25, 0, 1.0, False), r"P\[0\]\[0\]: the probabilities of its 2 entries sum to 0.75"),
    ],
)
def test_bad_entries_are_named(entry, message):
    P = _copy(TWO)
    P[0][0][1] = entry
    with pytest.raises(ValidationError, match=message):
        from_gymnasium(FM, _Env(P, 2, 2), 0.9)


def test_missing_action_state_or_transitions():
    P = _copy(TWO)
    del P[1][1]
    with pytest.raises(ValidationError, match=r"P\[1\] has no action 1 \(actions are 0..1\)"):
        from_gymnasium(FM, _Env(P, 2, 2), 0.9)
    with pytest.raises(ValidationError, match=r"P has no state 1"):
        from_gymnasium(FM, _Env({0: TWO[0]}, 2, 2), 0.9)
    P = _copy(TWO)
    P[1][0] = []
    with pytest.raises(ValidationError, match=r"P\[1\]\[0\] is empty"):
        from_gymnasium(FM, _Env(P, 2, 2), 0.9)
    with pytest.raises(ValidationError, match=r"P\[0\] has 2 entries but the space has 1 action"):
        from_gymnasium(FM, _Env(TWO, 2, 1), 0.9)
    with pytest.raises(ValidationError, match=r"discount"):
        from_gymnasium(FM, _Env(TWO, 2, 2), 1.0)


def test_gymnasium_is_not_imported_by_lpbounds():
    import subprocess
    import sys

    code = (
        "import sys, lpbounds as lb, lpbounds.model.gymnasium, lpbounds.model.mdp; "
        "print('gymnasium' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
