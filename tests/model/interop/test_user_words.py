"""Converters speak the user's words: a valid table is accepted, a bad one refused naming
the user's own entry, never the arrays lpbounds converts it to.

The Gymnasium tables are plain dicts (no Gymnasium needed): ``P[s][a] = [(p, s', r,
terminated), ...]``. Values are compared with value iteration on the table itself.
"""

from __future__ import annotations

import copy
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.errors import ValidationError

FM = lb.FiniteMDP

#: Internal arrays a user of a converter never wrote.
INTERNAL = re.compile(r"\b(probabilities|successors|allowed|targets|indptr)\[")


class _Space:
    def __init__(self, n: int) -> None:
        self.n = n


class _Env:
    def __init__(self, P, n: int, m: int) -> None:
        self.P, self.observation_space, self.action_space = P, _Space(n), _Space(m)


def _vi(P, n, m, lam):
    """V* of the table by value iteration: a terminated entry pays and ends."""
    v = np.zeros(n)
    for _ in range(3000):
        new = np.array([
            max(sum(p * (r + (0.0 if d else lam * v[y])) for p, y, r, d in P[s][a])
                for a in range(m))
            for s in range(n)
        ])  # fmt: skip
        if np.abs(new - v).max() < 1e-14:
            break
        v = new
    return new


BASE = {
    0: {0: [(0.5, 1, 1.0, False), (0.5, 0, 0.0, False)], 1: [(1.0, 2, 2.0, False)]},
    1: {0: [(1.0, 0, -1.0, False)], 1: [(0.3, 2, 0.5, False), (0.7, 1, 0.0, False)]},
    2: {0: [(1.0, 2, 0.25, False)], 1: [(0.9, 0, 1.0, False), (0.1, 1, 3.0, False)]},
}


@pytest.mark.parametrize("sink", ["auto", False, True])
def test_a_terminated_entry_of_probability_0_is_accepted_and_changes_nothing(sink):
    """The issue's table: ``(0.0, s', r, True)`` is valid Gymnasium; it was refused as
    "rows[1, 2] = -1", an encoding the user never wrote. It adds nothing: V* is that of
    the table without it, bit for bit, with and without a sink."""
    P = copy.deepcopy(BASE)
    P[1][0].append((0.0, 2, 5.0, True))
    plain = FM.from_gymnasium(_Env(BASE, 3, 2), 0.9, sink=sink)
    mdp = FM.from_gymnasium(_Env(P, 3, 2), 0.9, sink=sink)
    assert mdp.n_states == plain.n_states == (4 if sink is True else 3)
    assert mdp.sink is (sink is True)
    v, v0 = lb.solve_exact(mdp), lb.solve_exact(plain)
    assert np.array_equal(v.values, v0.values)
    assert np.allclose(mdp.user_values(v.values), _vi(BASE, 3, 2, 0.9), atol=1e-9)


def test_zero_probability_terminated_entries_beside_a_real_one():
    """A positive terminated entry adds the sink; a zero one beside it moves there too,
    with probability 0: V* is value iteration on the table (terminated pays and ends)."""
    P = copy.deepcopy(BASE)
    P[0][1] = [(0.6, 2, 2.0, False), (0.4, 1, 7.0, True), (0.0, 0, 9.0, True)]
    P[2][0] = [(1.0, 2, 0.25, False), (0.0, 1, -4.0, True)]
    mdp = FM.from_gymnasium(_Env(P, 3, 2), 0.95)
    assert mdp.sink and mdp.n_states == 4
    got = mdp.user_values(lb.solve_exact(mdp).values)
    assert np.allclose(got, _vi(P, 3, 2, 0.95), atol=1e-8)


# ------------------------------------------------------------------ refusals, in words
def _corrupt(P, what: int, s: int, a: int, value: float):
    """One corruption of the table (what: which kind)."""
    entries = list(P[s][a])
    p, y, r, d = entries[0]
    if what == 0:  # probabilities summing above one
        entries[0] = (p + abs(value) + 0.01, y, r, d)
    elif what == 1:  # below one
        entries[0] = (p * 0.5, y, r, d)
    elif what == 2:  # a next state out of range
        entries[0] = (p, int(value) if int(value) not in range(3) else 7, r, d)
    elif what == 3:  # a non-finite reward
        entries[0] = (p, y, float("nan"), d)
    elif what == 4:  # a negative probability
        entries.append((-abs(value) - 0.1, 0, 0.0, False))
    elif what == 5:  # a zero-probability terminated entry: valid
        entries.append((0.0, y, value, True))
    elif what == 6:  # a duplicate next state: valid, they add up
        entries[0] = (p / 2, y, r, d)
        entries.append((p / 2, y, r, d))
    elif what == 7:  # a huge reward
        entries[0] = (p, y, 1e308 * np.sign(value or 1.0), d)
    P[s][a] = entries
    return P


@settings(max_examples=120, deadline=None)
@given(
    what=st.integers(0, 7),
    s=st.integers(0, 2),
    a=st.integers(0, 1),
    value=st.floats(-1e3, 1e3, allow_nan=False),
    sink=st.sampled_from(["auto", True, False]),
)
def test_property_gymnasium_errors_name_the_users_entry(what, s, a, value, sink):
    """Every refusal names ``P[s][a][k]`` or ``P[s][a]`` (or the environment), never an
    array of the conversion; valid tables are accepted."""
    P = _corrupt(copy.deepcopy(BASE), what, s, a, value)
    try:
        FM.from_gymnasium(_Env(P, 3, 2), 0.9, sink=sink)
    except ValidationError as exc:
        text = str(exc)
        assert what not in (5, 6), text
        assert not INTERNAL.search(text), text
        assert "rows[" not in text, text
        assert text.startswith(f"P[{s}][{a}]") or text.startswith("rewards: max|R|"), text


@pytest.mark.parametrize("extra", [0.2, -0.3])
def test_matrix_converters_name_the_users_row(extra):
    """A row of the user's matrices summing to 1.2 (refused by FiniteMDP before, which
    named its own ``probabilities[x, u, :]``) or to 0.7 is named as the user wrote it."""
    P = [np.array([[0.5, 0.5, 0.0], [0.0, 1.0, 0.0], [0.2, 0.3, 0.5]]) for _ in range(2)]
    P[1][2, 2] += extra
    R = np.zeros((3, 2))
    total = f"{1.0 + extra:.12g}".replace(".", r"\.")
    said = rf"the probabilities sum to {total}"
    with pytest.raises(ValidationError, match=rf"^row 2 of P\[1\]: {said}"):
        FM.from_matrices(P, R, 0.9)
    Q = np.stack(P, axis=1)  # Q[s, a, s']
    with pytest.raises(ValidationError, match=rf"^Q\[2, 1, :\]: {said}"):
        FM.from_quantecon(R, Q, 0.9)
    s_idx, a_idx = np.nonzero(np.ones((3, 2), bool))
    with pytest.raises(ValidationError, match=rf"^Q\[5, :\] \(state 2, action 1\): {said}"):
        FM.from_quantecon(np.zeros(6), Q[s_idx, a_idx], 0.9, s_idx, a_idx)
    rows = [[x, u, y, Q[x, u, y], 0.0] for x in range(3) for u in range(2) for y in range(3)]
    with pytest.raises(ValidationError, match=r"^the rows of pair \(state 2, action 1\)") as err:
        FM.from_transitions(rows, 0.9)
    assert not INTERNAL.search(str(err.value))
