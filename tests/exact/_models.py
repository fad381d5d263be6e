"""Hypothesis strategies of tiny stored models for the exact tests (reproducible: every
test using them runs derandomized)."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from lpbounds.model.mdp import FiniteMDP
from lpbounds.model.partition import Partition

#: Discounts up to 0.9999 (the hardest for floating point: the value scale is 1e4 max|R|).
DISCOUNTS = st.sampled_from([0.0, 0.5, 0.9, 0.99, 0.999, 0.9999]) | st.floats(0.0, 0.9999)


@st.composite
def stored_mdps(draw, max_states: int = 4, max_actions: int = 3, max_outcomes: int = 3,
                action0: bool = False) -> FiniteMDP:  # fmt: skip
    """A random MDP as stored: masks (each state keeps an action; with ``action0`` action 0
    everywhere), reward scales 1e-6..1e6, and rows summing to 1 within the accepted
    tolerance (each row scaled by 1 + delta, |delta| <= 9e-10: the stored model, not the
    intended one)."""
    n = draw(st.integers(1, max_states))
    na = draw(st.integers(1, max_actions))
    nl = draw(st.integers(1, max_outcomes))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    discount = draw(DISCOUNTS)
    scale = 10.0 ** draw(st.integers(-6, 6))
    shared = draw(st.booleans())
    shape = (nl,) if shared else (n, na, nl)
    p = rng.random(shape) + 0.05
    p /= p.sum(axis=-1, keepdims=True)
    if draw(st.booleans()):  # rows off 1 by up to 9e-10: accepted as stored
        delta = rng.uniform(-9e-10, 9e-10, (*shape[:-1], 1))
        p = p * (1.0 + delta)
    succ = rng.integers(0, n, (n, na, nl))
    rewards = rng.uniform(-1.0, 1.0, (n, na)) * scale
    allowed = rng.random((n, na)) < 0.6
    allowed[np.arange(n), 0 if action0 else rng.integers(0, na, n)] = True
    if action0:
        allowed[:, 0] = True
    return FiniteMDP(succ, p, rewards, discount, allowed)


@st.composite
def with_partition(draw, mdps, max_parts: int = 2) -> tuple[FiniteMDP, Partition]:
    """An MDP of ``mdps`` and a random partition of its states (every part non-empty)."""
    mdp = draw(mdps)
    n = mdp.n_states
    m = draw(st.integers(1, min(max_parts, n)))
    labels = np.array(list(range(m)) + draw(st.lists(st.integers(0, m - 1), min_size=n - m,
                                                     max_size=n - m)))  # fmt: skip
    perm = np.random.default_rng(draw(st.integers(0, 2**16))).permutation(n)
    return mdp, Partition(labels[perm], m)
