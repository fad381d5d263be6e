"""Seeded random MDPs (Garnet style) and random partitions, for tests, checks and studies."""

from __future__ import annotations

import math

import numpy as np

from ..errors import ValidationError
from ..validation import (
    check_allocation,
    check_bool,
    check_discount,
    check_int,
    check_real,
    check_seed,
    check_value_scale,
)
from .mdp import FiniteMDP, index_dtype
from .partition import Partition, with_sink_block

__all__ = [
    "check_garnet_rewards",
    "check_garnet_size",
    "garnet",
    "garnet_bytes",
    "random_partition",
]


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
    n_states = check_int("n_states", n_states, lo=1)
    n_actions = check_int("n_actions", n_actions, lo=1)
    branching = check_int("branching", branching, lo=1)
    lam = check_discount(discount)
    seed = check_seed("seed", seed)
    shared_probabilities = check_bool("shared_probabilities", shared_probabilities)
    lo, hi = _check_range("reward_range", reward_range)
    check_garnet_rewards("reward_range", lo, hi, lam)
    check_garnet_size(n_states, n_actions, branching, shared_probabilities)
    allowed_fraction = check_real(
        "allowed_fraction", allowed_fraction, lo=0.0, hi=1.0, lo_open=True
    )
    rng = np.random.default_rng(seed)
    succ = rng.integers(0, n_states, size=(n_states, n_actions, branching)).astype(
        index_dtype(n_states)
    )
    shape = (branching,) if shared_probabilities else (n_states, n_actions, branching)
    cuts = np.sort(rng.random((*shape[:-1], branching - 1)), axis=-1)
    zeros = np.zeros((*shape[:-1], 1))
    ones = np.ones((*shape[:-1], 1))
    probs = np.diff(np.concatenate([zeros, cuts, ones], axis=-1), axis=-1)
    rewards = rng.uniform(lo, hi, size=(n_states, n_actions))
    allowed = None
    if allowed_fraction < 1:
        allowed = rng.random((n_states, n_actions)) < allowed_fraction
        allowed[:, 0] = True
    return FiniteMDP(succ, probs, rewards, discount, allowed)


def random_partition(
    n_states: int | FiniteMDP, n_partitions: int, seed: int | None = 0
) -> Partition:
    """A uniformly random partition into exactly ``n_partitions`` sets.

    Parameters
    ----------
    n_states : int or FiniteMDP
        The number of states, or the model whose states are partitioned. A model with a
        sink (``mdp.sink``: the absorbing end state a converter adds, worth 0 under every
        policy) gets the sink in a set of its own, the last (index ``n_partitions - 1``),
        and its other ``n - 1`` states split at random into the ``n_partitions - 1``
        others: a set that mixes the sink with live states gives them loose bounds
        (:func:`lpbounds.model.checks.sink_block`). A model without a sink gets the
        partition of its state count (the same labels).
    n_partitions : int
        ``M``, in ``[1, n]`` (in ``[2, n]`` for a model with a sink).
    seed : int or None
        Seed of :func:`numpy.random.default_rng`; the same seed gives the same partition.

    Returns
    -------
    Partition
        Every set non-empty; each state's set uniform among those that keep every set used.
    """
    sink = isinstance(n_states, FiniteMDP) and n_states.sink
    if isinstance(n_states, FiniteMDP):
        n_states = n_states.n_states
    n_states = check_int("n_states", n_states, lo=1)
    n_partitions = check_int("n_partitions", n_partitions, lo=1)
    low = 2 if sink else 1
    if not low <= n_partitions <= n_states:
        why = " (the model has a sink, kept in a set of its own)" if sink else ""
        raise ValidationError(
            f"n_partitions must lie in [{low}, n_states={n_states}]{why}; got {n_partitions}"
        )
    # the labels, the permutation that places one state in each set, and their range
    check_allocation(f"n_states = {n_states}", 8 * (2 * n_states + n_partitions), "the labels")
    seed = check_seed("seed", seed)
    rng = np.random.default_rng(seed)
    live, sets = n_states - int(sink), n_partitions - int(sink)
    labels = rng.integers(0, sets, size=live)
    labels[rng.permutation(live)[:sets]] = np.arange(sets)
    return with_sink_block(labels, sink)


def garnet_bytes(
    n_states: int, n_actions: int, branching: int, shared_probabilities: bool = False
) -> int:
    """Bytes of the arrays :func:`garnet` allocates from its sizes: ``n * A * L``
    successors drawn as int64 and cast to the index dtype (both alive at once), their
    float64 probabilities (``L`` of them when shared) and ``n * A`` float64 rewards. Python
    integers: no overflow, whatever the sizes."""
    pairs = n_states * n_actions
    entries = pairs * branching
    index = np.dtype(index_dtype(n_states)).itemsize
    probabilities = branching if shared_probabilities else entries
    return entries * (8 + index) + 8 * probabilities + 8 * pairs


def check_garnet_size(
    n_states: int,
    n_actions: int,
    branching: int,
    shared_probabilities: bool = False,
    prefix: str = "",
) -> None:
    """Refuse sizes whose arrays (:func:`garnet_bytes`) exceed this machine's memory,
    before anything is allocated; the message names the largest size first (with
    ``prefix``, e.g. ``"[model] "``), the bytes needed and the bytes available."""
    sizes = {"n_states": n_states, "n_actions": n_actions, "branching": branching}
    first = max(sizes, key=lambda k: sizes[k])
    others = ", ".join(f"{k} = {v}" for k, v in sizes.items() if k != first)
    check_allocation(
        f"{prefix}{first} = {sizes[first]} (with {others})",
        garnet_bytes(n_states, n_actions, branching, shared_probabilities),
        "the successors, probabilities and rewards",
    )


def check_garnet_rewards(name: str, low: float, high: float, discount: float) -> None:
    """Refuse a reward range whose value scale ``max|R| / (1 - discount)`` is beyond
    :data:`~lpbounds.validation.MAX_VALUE_SCALE`, or whose width ``high - low`` is not
    a float64 (the draw would overflow), before anything is drawn."""
    check_value_scale(max(abs(low), abs(high)), discount, name)
    if not math.isfinite(high - low):
        raise ValidationError(
            f"{name} = ({low}, {high}): the width high - low overflows float64"
        )  # pragma: no cover - MAX_VALUE_SCALE keeps the width finite


def _check_range(name: str, value: object) -> tuple[float, float]:
    """A pair ``(low, high)`` of finite reals with ``low <= high``."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ValidationError(f"{name} must be a pair (low, high); got {value!r}")
    lo = check_real(f"{name}[0]", value[0])
    hi = check_real(f"{name}[1]", value[1])
    if lo > hi:
        raise ValidationError(f"{name} = ({lo}, {hi}) has low > high")
    return lo, hi
