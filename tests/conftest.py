"""Shared fixtures: tiny MDPs with closed-form answers and seeded random MDPs."""

from __future__ import annotations

import numpy as np
import pytest

import lpbounds as lb


def two_state_mdp(discount: float = 0.9) -> lb.FiniteMDP:
    """State 0: stay (reward 1) or move to 1 (reward 0); state 1: stay (reward 2) only.

    V*(1) = 2 / (1 - lam); V*(0) = max(1 / (1 - lam), lam * V*(1)).
    """
    succ = np.array([[[0], [1]], [[1], [1]]])
    rewards = np.array([[1.0, 0.0], [2.0, 0.0]])
    allowed = np.array([[True, True], [True, False]])
    return lb.FiniteMDP(succ, [1.0], rewards, discount, allowed)


def two_state_closed_form(discount: float) -> np.ndarray:
    v1 = 2.0 / (1.0 - discount)
    return np.array([max(1.0 / (1.0 - discount), discount * v1), v1])


@pytest.fixture
def small_mdp() -> lb.FiniteMDP:
    return lb.garnet(40, 3, 3, 0.9, seed=5)


@pytest.fixture
def small_partition() -> lb.Partition:
    return lb.random_partition(40, 6, seed=3)


def reference_bellman(mdp: lb.FiniteMDP, v: np.ndarray) -> np.ndarray:
    """Q-values by a plain numpy expression (independent of the kernels), -inf if disallowed."""
    p = np.broadcast_to(mdp.probabilities, mdp.successors.shape)
    q = mdp.rewards + mdp.discount * (p * v[mdp.successors]).sum(axis=2)
    return np.where(mdp.allowed, q, -np.inf)


def reference_solve(mdp: lb.FiniteMDP) -> np.ndarray:
    """V* by plain value iteration in numpy to 1e-13 (slow, simple, independent)."""
    v = np.zeros(mdp.n_states)
    while True:
        nv = reference_bellman(mdp, v).max(axis=1)
        if np.abs(nv - v).max() < 1e-13 * max(1.0, np.abs(nv).max()):
            return nv
        v = nv
