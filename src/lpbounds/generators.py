"""Seeded random MDPs (Garnet style) and random partitions, for tests, checks and studies."""

from __future__ import annotations

import numpy as np

from .errors import ValidationError
from .mdp import FiniteMDP, index_dtype
from .partition import Partition

__all__ = ["garnet", "random_partition"]


def garnet(
    n_states: int,
    n_actions: int,
    branching: int,
    discount: float = 0.9,
    seed: int | None = 0,
    *,
    shared_probabilities: bool = False,
    reward_range: tuple[float, float] = (0.0, 1.0),
    allowed_fraction: float = 1.0,
) -> FiniteMDP:
    """A Garnet-style random MDP ("generic average reward non-stationary environment test").

    Each (state, action) has ``branching`` successors drawn uniformly with replacement
    (repeats merge into one transition) and probabilities from uniform cut points of
    [0, 1] (or one shared distribution for every pair with ``shared_probabilities``);
    rewards are uniform on ``reward_range``.

    Parameters
    ----------
    n_states, n_actions, branching : int
    discount : float
    seed : int or None
        Seed of :func:`numpy.random.default_rng`; the same seed gives the same MDP.
    shared_probabilities : bool
        One distribution ``p_l`` for every pair (the paper's form).
    reward_range : (low, high)
    allowed_fraction : float
        Fraction of pairs allowed (each state keeps at least action 0).

    Returns
    -------
    FiniteMDP
    """
    if n_states < 1 or n_actions < 1 or branching < 1:
        raise ValidationError("n_states, n_actions and branching must be >= 1")
    if not 0 < allowed_fraction <= 1:
        raise ValidationError(f"allowed_fraction must lie in (0, 1]; got {allowed_fraction}")
    rng = np.random.default_rng(seed)
    succ = rng.integers(0, n_states, size=(n_states, n_actions, branching)).astype(
        index_dtype(n_states)
    )
    shape = (branching,) if shared_probabilities else (n_states, n_actions, branching)
    cuts = np.sort(rng.random((*shape[:-1], branching - 1)), axis=-1)
    zeros = np.zeros((*shape[:-1], 1))
    ones = np.ones((*shape[:-1], 1))
    probs = np.diff(np.concatenate([zeros, cuts, ones], axis=-1), axis=-1)
    lo, hi = reward_range
    rewards = rng.uniform(lo, hi, size=(n_states, n_actions))
    allowed = None
    if allowed_fraction < 1:
        allowed = rng.random((n_states, n_actions)) < allowed_fraction
        allowed[:, 0] = True
    return FiniteMDP(succ, probs, rewards, discount, allowed)


def random_partition(n_states: int, n_partitions: int, seed: int | None = 0) -> Partition:
    """A uniformly random partition of ``n_states`` states into exactly ``n_partitions`` sets."""
    if not 1 <= n_partitions <= n_states:
        raise ValidationError(
            f"n_partitions must lie in [1, n_states={n_states}]; got {n_partitions}"
        )
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, n_partitions, size=n_states)
    labels[rng.permutation(n_states)[:n_partitions]] = np.arange(n_partitions)
    return Partition(labels)
