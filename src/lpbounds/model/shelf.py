"""The shelf: MDPs everyone knows, as named instances beside the garnets and the patrol.

Each model mirrors a published example, with the source's parameters as defaults:

========================  ============================================================
``forest``                pymdptoolbox's forest management,
                          ``mdptoolbox.example.forest(S=3, r1=4, r2=2, p=0.1)``
``gridworld``             Sutton and Barto (2018), *Reinforcement Learning*, 2nd ed.,
                          Example 3.5 (the 5 x 5 grid with the jumps A -> A', B -> B')
``admission_queue``       MDPSolver's queue (``Python/tests/example_model.py`` and
                          ``test2.py`` of the MDPSolver repository): admission control
                          of two customer types to a loss system of 100 servers
``inventory``             Sargent and Stachurski, *Dynamic Programming*, Vol. I,
                          Chapter 5, ``inventory_dp.py``:
                          ``create_inventory_model(β=0.98, K=40, c=0.2, κ=2, p=0.6)``
``savings``               QuantEcon's lecture *Discrete State Dynamic Programming*: the
                          consumption-saving model ``SimpleOG(B=10, M=5, α=0.5, β=0.9)``
``gymnasium_model``       a Gymnasium toy-text environment (FrozenLake, Taxi,
                          CliffWalking) through :meth:`FiniteMDP.from_gymnasium
                          <lpbounds.model.mdp.FiniteMDP.from_gymnasium>`; needs Gymnasium
========================  ============================================================

Every function takes the model's parameters by their names in the source and returns a
:class:`~lpbounds.model.mdp.FiniteMDP`; :func:`block_partition` and :func:`grid_partition`
give the default partitions of the instance files. The instance files
``models/forest.toml``, ``gridworld.toml``, ``queue.toml``, ``inventory.toml``,
``savings.toml``, ``frozenlake.toml``, ``taxi.toml`` and ``cliffwalking.toml`` hold the
parameters (a ``[model]`` table whose keys are the function's arguments) and cite their
source; :data:`SHELF_KINDS` maps each ``[model] kind`` to its function, and
:func:`model_sizes` / :func:`partition_size` read a file's sizes from its parameters
without building the model.

Gymnasium is optional: building a Gymnasium model without it raises
:class:`~lpbounds.errors.SolverNotInstalledError` (an ``ImportError``) with the install
command, ``pip install "lpbounds[interop]"``.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import SolverNotInstalledError, ValidationError
from ..validation import (
    check_allocation,
    check_bool,
    check_discount,
    check_int,
    check_real,
    describe_value,
)
from .mdp import FiniteMDP, index_dtype
from .partition import Partition, with_sink_block

if TYPE_CHECKING:
    from .instances import Instance

__all__ = [
    "GYMNASIUM_HINT",
    "SHELF_KINDS",
    "ModelSizes",
    "ShelfKind",
    "admission_queue",
    "block_partition",
    "build_blocks",
    "build_grid",
    "build_model",
    "cliff_walking",
    "forest",
    "frozen_lake",
    "grid_partition",
    "gridworld",
    "gymnasium_model",
    "inventory",
    "model_sizes",
    "partition_size",
    "savings",
    "table_arguments",
    "taxi",
]

#: What to install for the Gymnasium models.
GYMNASIUM_HINT = 'pip install "lpbounds[interop]"'

#: Sutton and Barto's jumps (Example 3.5): from A = (0, 1) to A' = (4, 1) paying 10, from
#: B = (0, 3) to B' = (2, 3) paying 5, as ``(row, col, to_row, to_col, reward)``.
SUTTON_BARTO_JUMPS: tuple[tuple[int, int, int, int, float], ...] = (
    (0, 1, 4, 1, 10.0),
    (0, 3, 2, 3, 5.0),
)


# ---------------------------------------------------------------------- table reading
def table_arguments(table: Mapping[str, Any], function: Callable[..., Any], where: str) -> dict:
    """The arguments of ``function`` a table gives, its defaults for the others.

    ``kind`` is not an argument; any other key that is not a parameter of ``function``
    is refused, naming it, as is a missing parameter without default.
    """
    params = inspect.signature(function).parameters
    unknown = sorted(k for k in table if k != "kind" and k not in params)
    if unknown:
        raise ValidationError(
            f"unknown key {', '.join(unknown)} in [{where}] (allowed: {', '.join(params)})"
        )
    out = {}
    for name, param in params.items():
        if name in table:
            out[name] = table[name]
        elif param.default is inspect.Parameter.empty:
            raise ValidationError(f"missing key {name} in [{where}]")
        else:
            out[name] = param.default
    return out


def _sequence(name: str, x: Any, length: int | None = None) -> list[Any]:
    """``x`` as a list (a list or tuple, of ``length`` items when given)."""
    if isinstance(x, (str, bytes)) or not isinstance(x, (list, tuple)):
        raise ValidationError(f"{name} must be a list; got {describe_value(x)}")
    if length is not None and len(x) != length:
        raise ValidationError(f"{name} must have {length} items; got {len(x)}")
    return list(x)


def _check_entries(prefix: str, n: int, n_actions: int, n_outcomes: int) -> None:
    """Refuse sizes whose successor and probability arrays do not fit in memory."""
    entries = n * n_actions * n_outcomes
    check_allocation(
        f"{prefix}: {n:,} states x {n_actions:,} actions x {n_outcomes:,} outcomes",
        entries * (8 + np.dtype(index_dtype(n)).itemsize),
        "the successors and probabilities",
    )


# ---------------------------------------------------------------------- forest
def _check_forest(prefix: str, a: Mapping[str, Any]) -> dict:
    return {
        "S": check_int(f"{prefix}S", a["S"], lo=2),
        "r1": check_real(f"{prefix}r1", a["r1"]),
        "r2": check_real(f"{prefix}r2", a["r2"]),
        "p": check_real(f"{prefix}p", a["p"], lo=0.0, hi=1.0),
        "discount": check_discount(a["discount"], f"{prefix}discount"),
    }


def _build_forest(a: Mapping[str, Any]) -> FiniteMDP:
    n, p = a["S"], a["p"]
    _check_entries("forest", n, 2, 2)
    succ = np.zeros((n, 2, 2), dtype=np.int64)
    succ[:, 0, 1] = np.minimum(np.arange(n) + 1, n - 1)  # wait: one year older (or oldest)
    prob = np.zeros((n, 2, 2))
    prob[:, 0, 0], prob[:, 0, 1] = p, 1.0 - p  # a fire resets the forest to age 0
    prob[:, 1, 0] = 1.0  # cut: back to age 0
    rewards = np.zeros((n, 2))
    rewards[n - 1, 0] = a["r1"]
    rewards[1:, 1] = 1.0
    rewards[n - 1, 1] = a["r2"]
    return FiniteMDP(succ, prob, rewards, a["discount"], action_names=("wait", "cut"), copy=False)


def forest(
    S: int = 3, r1: float = 4, r2: float = 2, p: float = 0.1, discount: float = 0.9
) -> FiniteMDP:
    """pymdptoolbox's forest management problem (``mdptoolbox.example.forest``).

    A forest in age classes ``0..S-1`` is managed yearly by *wait* (action 0) or *cut*
    (action 1). Waiting ages it by one class (the oldest stays oldest), except that a fire,
    with probability ``p``, resets it to age 0; cutting resets it to age 0. Waiting pays
    ``r1`` in the oldest class and 0 elsewhere; cutting pays 0 at age 0, 1 in the middle
    classes and ``r2`` in the oldest. The transition matrices and rewards are exactly those
    of ``mdptoolbox.example.forest(S, r1, r2, p)`` (pymdptoolbox 4.0b3).

    Parameters
    ----------
    S : int
        Number of age classes, at least 2 (pymdptoolbox's default 3).
    r1, r2 : float
        Rewards of waiting and of cutting in the oldest class (defaults 4 and 2).
    p : float
        Probability of a fire, in ``[0, 1]`` (default 0.1).
    discount : float
        Default 0.9, the discount of pymdptoolbox's ``PolicyIteration`` example on this
        model, whose exact values are ``(26.244, 29.484, 33.484)``.
    """
    return _build_forest(
        _check_forest("", {"S": S, "r1": r1, "r2": r2, "p": p, "discount": discount})
    )


# ---------------------------------------------------------------------- gridworld
#: Sutton and Barto's actions, in their order, as (row, column) steps.
_GRID_MOVES: tuple[tuple[str, int, int], ...] = (
    ("north", -1, 0),
    ("south", 1, 0),
    ("east", 0, 1),
    ("west", 0, -1),
)


def _check_jumps(prefix: str, jumps: Any, rows: int, cols: int) -> list[tuple[int, int, float]]:
    """``(from_state, to_state, reward)`` of each jump ``[row, col, to_row, to_col, reward]``."""
    out: list[tuple[int, int, float]] = []
    seen: set[int] = set()
    for k, item in enumerate(_sequence(f"{prefix}jumps", jumps)):
        name = f"{prefix}jumps[{k}]"
        r0, c0, r1, c1, reward = _sequence(name, item, 5)
        cells = []
        for j, (r, c) in enumerate(((r0, c0), (r1, c1))):
            rr = check_int(f"{name}[{2 * j}]", r, lo=0, hi=rows - 1)
            cc = check_int(f"{name}[{2 * j + 1}]", c, lo=0, hi=cols - 1)
            cells.append(rr * cols + cc)
        if cells[0] in seen:
            raise ValidationError(f"{name}: a second jump from the cell ({r0}, {c0})")
        seen.add(cells[0])
        out.append((cells[0], cells[1], check_real(f"{name}[4]", reward)))
    return out


def _check_gridworld(prefix: str, a: Mapping[str, Any]) -> dict:
    rows = check_int(f"{prefix}rows", a["rows"], lo=1)
    cols = check_int(f"{prefix}cols", a["cols"], lo=1)
    return {
        "rows": rows,
        "cols": cols,
        "jumps": _check_jumps(prefix, a["jumps"], rows, cols),
        "off_grid_reward": check_real(f"{prefix}off_grid_reward", a["off_grid_reward"]),
        "discount": check_discount(a["discount"], f"{prefix}discount"),
    }


def _build_gridworld(a: Mapping[str, Any]) -> FiniteMDP:
    rows, cols = a["rows"], a["cols"]
    n = rows * cols
    _check_entries("gridworld", n, 4, 1)
    r, c = np.divmod(np.arange(n), cols)
    succ = np.empty((n, 4, 1), dtype=np.int64)
    rewards = np.zeros((n, 4))
    for u, (_, dr, dc) in enumerate(_GRID_MOVES):
        nr, nc = r + dr, c + dc
        off = (nr < 0) | (nr >= rows) | (nc < 0) | (nc >= cols)
        succ[:, u, 0] = np.where(off, np.arange(n), nr * cols + nc)  # off the grid: stay
        rewards[:, u] = np.where(off, a["off_grid_reward"], 0.0)
    for src, dst, reward in a["jumps"]:  # every action of a jump cell jumps
        succ[src, :, 0] = dst
        rewards[src, :] = reward
    names = tuple(m[0] for m in _GRID_MOVES)
    return FiniteMDP(succ, [1.0], rewards, a["discount"], action_names=names, copy=False)


def gridworld(
    rows: int = 5,
    cols: int = 5,
    jumps: Sequence[Sequence[float]] = SUTTON_BARTO_JUMPS,
    off_grid_reward: float = -1.0,
    discount: float = 0.9,
) -> FiniteMDP:
    """Sutton and Barto's gridworld (*Reinforcement Learning*, 2nd ed., 2018, Example 3.5).

    The cells of a ``rows x cols`` grid are the states, numbered row by row from the top
    left (``state = row * cols + col``). Four deterministic actions move north, south,
    east, west; a move off the grid leaves the agent where it is and pays
    ``off_grid_reward``, any other move pays 0, except from a jump cell: there every
    action pays the jump's reward and moves to its target. With the defaults (A = (0, 1)
    -> A' = (4, 1) paying 10, B = (0, 3) -> B' = (2, 3) paying 5, discount 0.9) this is the
    book's example, whose optimal values Example 3.8 lists (``V*(A) = 10 / (1 - 0.9^5)``,
    about 24.4).

    Parameters
    ----------
    rows, cols : int
    jumps : sequence of (row, col, to_row, to_col, reward)
        At most one jump per cell.
    off_grid_reward : float
    discount : float
    """
    args = {"rows": rows, "cols": cols, "jumps": jumps, "off_grid_reward": off_grid_reward}
    return _build_gridworld(_check_gridworld("", {**args, "discount": discount}))


# ---------------------------------------------------------------------- admission queue
def _check_queue(prefix: str, a: Mapping[str, Any]) -> dict:
    rates = _sequence(f"{prefix}arrival_rates", a["arrival_rates"])
    if not rates:
        raise ValidationError(f"{prefix}arrival_rates must list at least one customer type")
    rates = [
        check_real(f"{prefix}arrival_rates[{k}]", x, lo=0.0, lo_open=True)
        for k, x in enumerate(rates)
    ]
    rewards = _sequence(f"{prefix}rewards", a["rewards"], len(rates))
    return {
        "capacity": check_int(f"{prefix}capacity", a["capacity"], lo=1),
        "arrival_rates": rates,
        "service_rate": check_real(
            f"{prefix}service_rate", a["service_rate"], lo=0.0, lo_open=True
        ),
        "rewards": [check_real(f"{prefix}rewards[{k}]", x) for k, x in enumerate(rewards)],
        "discount": check_discount(a["discount"], f"{prefix}discount"),
    }


def _seen_by_next_arrival(capacity: int, lam: float, mu: float) -> np.ndarray:
    """``q[K, j]``: probability that the next arrival finds ``j`` customers when ``K`` are in
    service now, each finishing at rate ``mu``, arrivals at rate ``lam``.

    Until the next arrival the ``K`` customers leave one by one: with ``i`` in service the
    next event is a departure with probability ``g_i = i mu / (i mu + lam)``, so
    ``q[K, j] = (prod_{i=j+1..K} g_i) * lam / (j mu + lam)``, computed in logarithms.
    """
    k = np.arange(capacity + 1, dtype=np.float64)
    log_g = np.log(k[1:] * mu) - np.log(k[1:] * mu + lam)
    log_prod = np.concatenate([[0.0], np.cumsum(log_g)])  # log prod_{i=1..m} g_i
    log_d = math.log(lam) - np.log(k * mu + lam)
    log_q = log_prod[:, None] - log_prod[None, :] + log_d[None, :]
    below = np.arange(capacity + 1)[None, :] <= np.arange(capacity + 1)[:, None]
    return np.where(below, np.exp(np.where(below, log_q, 0.0)), 0.0)


def _build_queue(a: Mapping[str, Any]) -> FiniteMDP:
    cap, rates = a["capacity"], np.asarray(a["arrival_rates"], dtype=np.float64)
    ns, types = cap + 1, rates.size
    n = types * ns
    _check_entries("admission_queue", n, 2, n)
    lam = float(rates.sum())
    q = _seen_by_next_arrival(cap, lam, a["service_rate"])
    k = np.tile(np.arange(ns), types)  # customers found by the arrival of state s
    t = np.repeat(np.arange(types), ns)  # its type
    after = np.stack([k, np.minimum(k + 1, cap)], axis=1)  # K after reject / accept
    # outcome o = t' * ns + j: the next arrival is of type t' and finds j customers
    prob = (rates / lam)[None, None, :, None] * q[after][:, :, None, :]
    succ = np.broadcast_to(np.arange(n, dtype=index_dtype(n)), (n, 2, n))
    rewards = np.zeros((n, 2))
    rewards[:, 1] = np.asarray(a["rewards"], dtype=np.float64)[t]
    allowed = np.ones((n, 2), dtype=bool)
    allowed[:, 1] = k < cap  # a full system cannot accept
    return FiniteMDP(
        np.ascontiguousarray(succ), prob.reshape(n, 2, n), rewards, a["discount"], allowed,
        action_names=("reject", "accept"), copy=False,
    )  # fmt: skip


def admission_queue(
    capacity: int = 100,
    arrival_rates: Sequence[float] = (50.0, 10.0),
    service_rate: float = 0.75,
    rewards: Sequence[float] = (1.0, 1000.0),
    discount: float = 0.99,
) -> FiniteMDP:
    """MDPSolver's queue: admission control of customer types to a loss system.

    ``capacity`` servers, no waiting room; customers of type ``t`` arrive at rate
    ``arrival_rates[t]`` (Poisson), each served at rate ``service_rate`` (exponential). The
    system is observed at each arrival: the state is ``(t, j)``, the arriving type and the
    number ``j`` of customers in the system, numbered ``t * (capacity + 1) + j``. Action 0
    rejects the customer, action 1 accepts it (not allowed when ``j = capacity``) and pays
    ``rewards[t]``. The next state is the next arrival's type and the number it finds.

    The defaults are MDPSolver's example (``Python/tests/test2.py`` with
    ``example_model.py``, MDPSolver 0.10: capacity 100, arrival rates 50 and 10, service
    rate 3/4, rewards 1 and 1000, discount 0.99; 202 states), whose test expects the mean
    of the optimal values to round to 17075. MDPSolver's ``exitDist`` computes the
    distribution found by the next arrival by iterating a transient chain until less than
    1e-9 of the probability is left; here it is the closed form
    (:func:`_seen_by_next_arrival`), so the rows sum to one.

    Parameters
    ----------
    capacity : int
    arrival_rates : sequence of float
        One rate per customer type, each > 0.
    service_rate : float
        > 0.
    rewards : sequence of float
        The reward of accepting each type.
    discount : float
    """
    args = {"capacity": capacity, "arrival_rates": arrival_rates, "service_rate": service_rate}
    return _build_queue(_check_queue("", {**args, "rewards": rewards, "discount": discount}))


# ---------------------------------------------------------------------- inventory
def _check_inventory(prefix: str, a: Mapping[str, Any]) -> dict:
    return {
        "K": check_int(f"{prefix}K", a["K"], lo=0),
        "c": check_real(f"{prefix}c", a["c"]),
        "kappa": check_real(f"{prefix}kappa", a["kappa"]),
        "p": check_real(f"{prefix}p", a["p"], lo=0.0, hi=1.0, lo_open=True),
        "discount": check_discount(a["discount"], f"{prefix}discount"),
    }


def _build_inventory(a: Mapping[str, Any]) -> FiniteMDP:
    big_k, p = a["K"], a["p"]
    n = big_k + 1
    _check_entries("inventory", n, n, n)
    x = np.arange(n)[:, None, None]  # stock
    u = np.arange(n)[None, :, None]  # order
    d = np.arange(n)[None, None, :]  # outcome: demand d < x, or d = x for "demand >= x"
    stay = (1.0 - p) ** np.arange(n)  # P(D >= m) = (1 - p)^m
    prob = np.where(d < x, p * stay[d], np.where(d == x, stay[x], 0.0))
    succ = np.minimum(np.where(d < x, x - d, 0) + u, big_k)  # min only off the allowed pairs
    sales = (1.0 - p) * (1.0 - stay) / p  # E min(x, D) = sum_{m=1..x} P(D >= m)
    order = np.arange(n, dtype=np.float64)
    rewards = sales[:, None] - a["c"] * order[None, :] - a["kappa"] * (order > 0)[None, :]
    allowed = order[None, :] <= big_k - order[:, None]
    return FiniteMDP(
        succ.astype(index_dtype(n)), np.broadcast_to(prob, (n, n, n)).copy(), rewards,
        a["discount"], allowed, copy=False,
    )  # fmt: skip


def inventory(
    K: int = 40, c: float = 0.2, kappa: float = 2.0, p: float = 0.6, discount: float = 0.98
) -> FiniteMDP:
    """Sargent and Stachurski's inventory problem (*Dynamic Programming*, Vol. I, Ch. 5).

    The state is the stock ``x`` in ``0..K``, the action the order ``a`` in ``0..K - x``;
    demand ``D`` is geometric, ``P(D = d) = (1 - p)^d p``. The period's profit is
    ``E min(x, D) - c a - kappa [a > 0]`` and the next stock ``max(x - D, 0) + a``. The
    defaults are ``create_inventory_model(β=0.98, K=40, c=0.2, κ=2, p=0.6)`` of the book's
    ``inventory_dp.py``. The book sums the demand up to ``d_max = 101``; here the tail
    ``D >= x`` is one outcome with its exact probability ``(1 - p)^x`` (the two differ by
    less than ``(1 - p)^101``, 1e-40 at the defaults).

    Parameters
    ----------
    K : int
        Largest stock.
    c, kappa : float
        Cost per unit ordered and fixed cost of an order.
    p : float
        Demand parameter in ``(0, 1]``.
    discount : float
    """
    args = {"K": K, "c": c, "kappa": kappa, "p": p, "discount": discount}
    return _build_inventory(_check_inventory("", args))


# ---------------------------------------------------------------------- savings
def _check_savings(prefix: str, a: Mapping[str, Any]) -> dict:
    return {
        "B": check_int(f"{prefix}B", a["B"], lo=0),
        "M": check_int(f"{prefix}M", a["M"], lo=0),
        "alpha": check_real(f"{prefix}alpha", a["alpha"], lo=0.0, lo_open=True),
        "discount": check_discount(a["discount"], f"{prefix}discount"),
    }


def _build_savings(a: Mapping[str, Any]) -> FiniteMDP:
    big_b, big_m = a["B"], a["M"]
    n, m = big_b + big_m + 1, big_m + 1
    _check_entries("savings", n, m, big_b + 1)
    s = np.arange(n, dtype=np.float64)[:, None]
    store = np.arange(m, dtype=np.float64)[None, :]
    allowed = store <= s
    rewards = np.where(allowed, np.maximum(s - store, 0.0) ** a["alpha"], 0.0)
    # the next stock is a + U, U uniform on 0..B: one shared distribution
    succ = np.arange(m)[None, :, None] + np.arange(big_b + 1)[None, None, :]
    succ = np.broadcast_to(succ, (n, m, big_b + 1)).astype(index_dtype(n))
    prob = np.full(big_b + 1, 1.0 / (big_b + 1))
    return FiniteMDP(succ, prob, rewards, a["discount"], allowed, copy=False)


def savings(B: int = 10, M: int = 5, alpha: float = 0.5, discount: float = 0.9) -> FiniteMDP:
    """QuantEcon's consumption-saving problem (lecture *Discrete State Dynamic Programming*).

    A household starts a period with stock ``s`` in ``0..B + M``, stores ``a`` in
    ``0..min(s, M)`` and consumes ``s - a``, with utility ``(s - a)^alpha``; the next stock
    is ``a + U`` with ``U`` uniform on ``0..B``. The defaults are the lecture's
    ``SimpleOG(B=10, M=5, α=0.5, β=0.9)`` (16 states, 6 actions), the ``DiscreteDP(R, Q, β)``
    it solves by policy iteration; QuantEcon's ``R = -inf`` for ``a > s`` is
    ``allowed[s, a] = False`` here.

    Parameters
    ----------
    B : int
        Largest output draw.
    M : int
        Storage bound.
    alpha : float
        Exponent of the utility, > 0.
    discount : float
        QuantEcon's ``β``.
    """
    return _build_savings(
        _check_savings("", {"B": B, "M": M, "alpha": alpha, "discount": discount})
    )


# ---------------------------------------------------------------------- Gymnasium
def _check_gymnasium(prefix: str, a: Mapping[str, Any]) -> dict:
    ids = a["env_id"]
    ids = [ids] if isinstance(ids, str) else _sequence(f"{prefix}env_id", ids)
    if not ids or not all(isinstance(i, str) and i for i in ids):
        got = describe_value(a["env_id"])
        raise ValidationError(f"{prefix}env_id must be a Gymnasium id or a list of ids; got {got}")
    kwargs = {} if a["kwargs"] is None else a["kwargs"]
    if not isinstance(kwargs, Mapping) or not all(isinstance(k, str) for k in kwargs):
        raise ValidationError(
            f"{prefix}kwargs must be a table of keyword arguments; got {describe_value(kwargs)}"
        )
    names = a["action_names"]
    if names is not None:
        names = _sequence(f"{prefix}action_names", names)
    return {
        "env_id": ids,
        "discount": check_discount(a["discount"], f"{prefix}discount"),
        "kwargs": dict(kwargs),
        "action_names": names,
    }


def _import_gymnasium(what: str) -> Any:
    try:
        import gymnasium
    except ImportError:
        raise SolverNotInstalledError(
            f"{what} needs Gymnasium, which is not installed: {GYMNASIUM_HINT}"
        ) from None
    return gymnasium


def _build_gymnasium(a: Mapping[str, Any]) -> FiniteMDP:
    ids = a["env_id"]
    gym = _import_gymnasium(f"the Gymnasium model {ids[0]}")
    env_id = next((i for i in ids if i in gym.envs.registry), None)
    if env_id is None:
        raise ValidationError(
            f"env_id: Gymnasium {gym.__version__} registers none of {', '.join(ids)}"
        )
    try:
        env = gym.make(env_id, **a["kwargs"])
    except (TypeError, ValueError, KeyError, gym.error.Error) as exc:
        # KeyError: FrozenLake's unknown map_name
        raise ValidationError(f"kwargs of {env_id}: Gymnasium refused them: {exc!r}") from exc
    try:
        return FiniteMDP.from_gymnasium(env, a["discount"], action_names=a["action_names"])
    finally:
        env.close()


def gymnasium_model(
    env_id: str | Sequence[str],
    discount: float = 0.99,
    kwargs: Mapping[str, Any] | None = None,
    action_names: Sequence[str] | None = None,
) -> FiniteMDP:
    """A Gymnasium toy-text environment as a :class:`FiniteMDP` (needs Gymnasium).

    ``gymnasium.make(env_id, **kwargs)`` read by :meth:`FiniteMDP.from_gymnasium
    <lpbounds.model.mdp.FiniteMDP.from_gymnasium>`: Gymnasium's states and actions, the
    expected rewards of ``env.unwrapped.P``, and an absorbing sink (the last state, worth
    0) for the terminated transitions.

    Parameters
    ----------
    env_id : str or sequence of str
        A registered id, or ids tried in order, the first registered one used (Taxi is
        ``Taxi-v4`` from Gymnasium 1.3 on, ``Taxi-v3`` before; with the default options the
        two are the same model).
    discount : float
        Gymnasium has none (the discount is the agent's); default 0.99.
    kwargs : mapping, optional
        Keyword arguments of ``gymnasium.make`` (``map_name``, ``is_slippery``, ...).
    action_names : sequence of str, optional

    Raises
    ------
    SolverNotInstalledError
        Gymnasium is not installed (``pip install "lpbounds[interop]"``).
    ValidationError
        No id registered, options Gymnasium refuses, or a ``P`` that
        :meth:`~lpbounds.model.mdp.FiniteMDP.from_gymnasium` refuses.
    """
    args = {"env_id": env_id, "discount": discount, "kwargs": kwargs}
    return _build_gymnasium(_check_gymnasium("", {**args, "action_names": action_names}))


def frozen_lake(
    map_name: str = "4x4", is_slippery: bool = True, discount: float = 0.99
) -> FiniteMDP:
    """Gymnasium's ``FrozenLake-v1`` (17 states with the sink at 4x4; needs Gymnasium)."""
    return gymnasium_model(
        "FrozenLake-v1", discount, {"map_name": map_name, "is_slippery": is_slippery},
        action_names=("left", "down", "right", "up"),
    )  # fmt: skip


def taxi(discount: float = 0.99) -> FiniteMDP:
    """Gymnasium's Taxi (``Taxi-v4``, or ``Taxi-v3`` before Gymnasium 1.3; 501 states with
    the sink; needs Gymnasium)."""
    return gymnasium_model(
        ("Taxi-v4", "Taxi-v3"), discount,
        action_names=("south", "north", "east", "west", "pickup", "dropoff"),
    )  # fmt: skip


def cliff_walking(discount: float = 0.99) -> FiniteMDP:
    """Gymnasium's CliffWalking (``CliffWalking-v1``, or ``-v0`` before it; 49 states with
    the sink; needs Gymnasium)."""
    return gymnasium_model(
        ("CliffWalking-v1", "CliffWalking-v0"), discount,
        action_names=("up", "right", "down", "left"),
    )  # fmt: skip


# ---------------------------------------------------------------------- sizes
@dataclass(frozen=True)
class ModelSizes:
    """Sizes of a model read from its parameters (None: not known without building it)."""

    n_states: int | None
    n_actions: int | None
    #: outcomes per pair, ``L`` of ``successors (n, A, L)``
    n_outcomes: int | None
    n_pairs: int | None
    discount: float
    sink: bool | None = False


def _forest_sizes(a: Mapping[str, Any]) -> ModelSizes:
    return ModelSizes(a["S"], 2, 2, 2 * a["S"], a["discount"])


def _gridworld_sizes(a: Mapping[str, Any]) -> ModelSizes:
    n = a["rows"] * a["cols"]
    return ModelSizes(n, 4, 1, 4 * n, a["discount"])


def _queue_sizes(a: Mapping[str, Any]) -> ModelSizes:
    types = len(a["arrival_rates"])
    n = types * (a["capacity"] + 1)
    return ModelSizes(n, 2, n, 2 * n - types, a["discount"])


def _inventory_sizes(a: Mapping[str, Any]) -> ModelSizes:
    n = a["K"] + 1
    return ModelSizes(n, n, n, n * (n + 1) // 2, a["discount"])


def _savings_sizes(a: Mapping[str, Any]) -> ModelSizes:
    n, m = a["B"] + a["M"] + 1, a["M"] + 1
    pairs = m * (m + 1) // 2 + (n - m) * m  # stock s stores 0..min(s, M)
    return ModelSizes(n, m, a["B"] + 1, pairs, a["discount"])


def _gymnasium_sizes(a: Mapping[str, Any]) -> ModelSizes:
    return ModelSizes(None, None, None, None, a["discount"], None)


# ---------------------------------------------------------------------- the kinds
@dataclass(frozen=True)
class ShelfKind:
    """A ``[model] kind`` of the shelf: its public function (whose parameters are the
    table's keys), the checks of those keys, the builder and the sizes."""

    function: Callable[..., FiniteMDP]
    check: Callable[[str, Mapping[str, Any]], dict]
    build: Callable[[Mapping[str, Any]], FiniteMDP]
    sizes: Callable[[Mapping[str, Any]], ModelSizes]
    needs: tuple[str, ...] = ()

    def arguments(self, table: Mapping[str, Any], prefix: str = "[model] ") -> dict:
        """The checked arguments of a ``[model]`` table."""
        return self.check(prefix, table_arguments(table, self.function, "model"))


#: ``[model] kind`` -> the shelf's function, checks, builder and sizes.
SHELF_KINDS: dict[str, ShelfKind] = {
    "forest": ShelfKind(forest, _check_forest, _build_forest, _forest_sizes),
    "gridworld": ShelfKind(gridworld, _check_gridworld, _build_gridworld, _gridworld_sizes),
    "admission_queue": ShelfKind(admission_queue, _check_queue, _build_queue, _queue_sizes),
    "inventory": ShelfKind(inventory, _check_inventory, _build_inventory, _inventory_sizes),
    "savings": ShelfKind(savings, _check_savings, _build_savings, _savings_sizes),
    "gymnasium": ShelfKind(
        gymnasium_model, _check_gymnasium, _build_gymnasium, _gymnasium_sizes, ("gymnasium",)
    ),
}


def _kind(table: Mapping[str, Any]) -> ShelfKind:
    kind = table.get("kind") if isinstance(table, Mapping) else None
    if not isinstance(kind, str) or kind not in SHELF_KINDS:
        raise ValidationError(f"[model] kind {kind!r} is not a shelf model")
    return SHELF_KINDS[kind]


def build_model(table: Mapping[str, Any]) -> FiniteMDP:
    """``MODEL_KINDS`` builder of every shelf kind: the MDP of a ``[model]`` table."""
    spec = _kind(table)
    return spec.build(spec.arguments(table))


def model_sizes(table: Mapping[str, Any]) -> ModelSizes:
    """The sizes of a shelf ``[model]`` table from its parameters, without building it
    (a Gymnasium model's are not known without Gymnasium: None)."""
    spec = _kind(table)
    return spec.sizes(spec.arguments(table))


# ---------------------------------------------------------------------- partitions
def block_partition(n_states: int | FiniteMDP, size: int, sink: bool = False) -> Partition:
    """States ``0..n_states-1`` in consecutive blocks of ``size`` (the last may be smaller);
    with ``sink``, one more state, the sink, in a block of its own.

    Given a model instead of ``n_states``, its states: those before its sink (all of them
    without one) in blocks, and its sink (``mdp.sink``) in a block of its own; ``sink=True``
    is then refused unless the model has one.
    """
    sink = check_bool("sink", sink)
    if isinstance(n_states, FiniteMDP):
        mdp = n_states
        if sink and not mdp.sink:
            raise ValidationError("sink=True but the model has no sink (mdp.sink is False)")
        n_states, sink = mdp.n_user_states, mdp.sink
    n = check_int("n_states", n_states, lo=1)
    size = check_int("size", size, lo=1)
    return with_sink_block(np.arange(n) // size, sink)


def grid_partition(
    rows: int, cols: int, tile: Sequence[int], inner: int = 1, sink: bool = False
) -> Partition:
    """Tiles of a grid: state ``s = cell * inner + k`` with ``cell = row * cols + col``.

    States whose cells lie in the same ``tile = (height, width)`` block of the grid and
    that have the same ``k`` share a partition (``inner = 1``: one state per cell, as in a
    gridworld; Taxi has 20 per cell, the passenger's place and destination). With
    ``sink``, one more state, the sink, in a partition of its own.
    """
    rows = check_int("rows", rows, lo=1)
    cols = check_int("cols", cols, lo=1)
    inner = check_int("inner", inner, lo=1)
    h, w = (check_int(f"tile[{k}]", v, lo=1) for k, v in enumerate(_sequence("tile", tile, 2)))
    cell, k = np.divmod(np.arange(rows * cols * inner), inner)
    r, c = np.divmod(cell, cols)
    tiles_across = -(-cols // w)
    labels = ((r // h) * tiles_across + c // w) * inner + k
    return with_sink_block(labels, check_bool("sink", sink))


def _user_states(instance: Instance) -> tuple[int, bool]:
    """The number of the user's states of an instance's MDP, and whether it has a sink."""
    mdp = instance.mdp()
    return mdp.n_user_states, mdp.sink


def build_blocks(table: Mapping[str, Any], instance: Instance) -> Partition:
    """``PARTITION_KINDS["blocks"]``: ``[partition] size`` consecutive states per block."""
    args = table_arguments(table, _blocks_signature, "partition")
    size = check_int("[partition] size", args["size"], lo=1)
    n, sink = _user_states(instance)
    return block_partition(n, size, sink)


def build_grid(table: Mapping[str, Any], instance: Instance) -> Partition:
    """``PARTITION_KINDS["grid"]``: ``[partition] rows, cols, tile = [h, w], inner``."""
    args = _grid_arguments(table)
    n, sink = _user_states(instance)
    cells = args["rows"] * args["cols"] * args["inner"]
    if cells != n:
        raise ValidationError(
            f"[partition] rows x cols x inner = {args['rows']} x {args['cols']} x "
            f"{args['inner']} = {cells:,} states, but the model has {n:,}"
        )
    return grid_partition(args["rows"], args["cols"], args["tile"], args["inner"], sink)


def _blocks_signature(size: int) -> None:
    """The keys of a ``[partition] kind = "blocks"`` table."""


def _grid_signature(rows: int, cols: int, tile: Sequence[int], inner: int = 1) -> None:
    """The keys of a ``[partition] kind = "grid"`` table."""


def _grid_arguments(table: Mapping[str, Any]) -> dict:
    args = table_arguments(table, _grid_signature, "partition")
    tile = _sequence("[partition] tile", args["tile"], 2)
    return {
        "rows": check_int("[partition] rows", args["rows"], lo=1),
        "cols": check_int("[partition] cols", args["cols"], lo=1),
        "tile": [check_int(f"[partition] tile[{k}]", v, lo=1) for k, v in enumerate(tile)],
        "inner": check_int("[partition] inner", args["inner"], lo=1),
    }


def partition_size(table: Mapping[str, Any], sizes: ModelSizes) -> int | None:
    """The number of sets of a ``blocks`` or ``grid`` ``[partition]`` table, from the
    table and the model's sizes (None when they are not known without building it)."""
    if not isinstance(table, Mapping):
        raise ValidationError(f"[partition] must be a table; got {describe_value(table)}")
    if sizes.sink is None:
        return None
    extra = int(sizes.sink)
    if table.get("kind") == "grid":
        a = _grid_arguments(table)
        h, w = a["tile"]
        return -(-a["rows"] // h) * -(-a["cols"] // w) * a["inner"] + extra
    if table.get("kind") == "blocks" and sizes.n_states is not None:
        args = table_arguments(table, _blocks_signature, "partition")
        size = check_int("[partition] size", args["size"], lo=1)
        return -(-(sizes.n_states - extra) // size) + extra
    return None
