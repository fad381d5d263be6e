"""Shared fixtures: tiny MDPs with closed-form answers and seeded random MDPs; and the
hypothesis profile every property test runs under."""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

import lpbounds as lb

#: The property tests' profile, loaded before any test module is imported (so that a
#: test's own ``@settings(max_examples=...)`` inherits the rest): ``derandomize`` seeds
#: each test's examples from a hash of the test function, so every run -- CI, a laptop,
#: any pytest-randomly order, any xdist worker -- tries the same examples, and a test
#: that catches a weakened promise catches it every run, not in 7 runs of 8 (issue 35).
#: No example database (derandomize implies none), no deadline (solver times vary with
#: the machine's load). ``HYPOTHESIS_PROFILE=explore`` runs unseeded, to look for new
#: counterexamples (pin what it finds with ``@example`` so that CI keeps it).
settings.register_profile(
    "lpbounds-ci",
    derandomize=True,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "explore",
    derandomize=False,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "lpbounds-ci"))


def pytest_configure(config: pytest.Config) -> None:
    """Before pytest-xdist starts its workers, import QuantEcon once in the controller.

    Its import compiles numba gufuncs with ``cache=True`` (quantecon.random.utilities). In a
    fresh environment two workers importing it at once wrote that cache together, and from
    then on every import of QuantEcon aborted the interpreter inside llvmlite ("Fatal
    Python error: Aborted", seen in CI). One import here writes the cache before any worker
    reads it."""
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return  # a worker, or a run without workers
    try:
        import quantecon  # noqa: F401
    except ImportError:
        pass


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
    """V* by policy iteration with dense numpy solves (slow, simple, independent of lpbounds).

    Each policy is evaluated exactly by ``np.linalg.solve(I - lambda P_pi, r_pi)`` (error
    about ``cond * eps * max|V|``, 1e-14 of the value scale here) and improved where
    a Q-value beats the current action by more than 1e-12 of the values' size, so the
    answer does not carry a value iteration's ``lambda / (1 - lambda)`` times its last
    step: at discount 0.99 that term alone was as large as lpbounds' own error bound.
    """
    n = mdp.n_states
    p = np.broadcast_to(mdp.probabilities, mdp.successors.shape)
    rows = np.arange(n)
    pol = reference_bellman(mdp, np.zeros(n)).argmax(axis=1)
    for _ in range(100 * mdp.n_actions + 100):
        a = np.zeros((n, n))
        np.add.at(a, (rows[:, None], mdp.successors[rows, pol]), p[rows, pol])
        v = np.linalg.solve(np.eye(n) - mdp.discount * a, mdp.rewards[rows, pol])
        q = reference_bellman(mdp, v)
        better = q.max(axis=1) > q[rows, pol] + 1e-12 * max(1.0, float(np.abs(v).max()))
        if not better.any():
            return v
        pol = np.where(better, q.argmax(axis=1), pol)
    raise AssertionError("reference policy iteration did not settle")
