"""Models from Gymnasium's tabular environments (the toy-text ``P`` tables).

The converter behind :meth:`FiniteMDP.from_gymnasium
<lpbounds.model.mdp.FiniteMDP.from_gymnasium>` (the classmethod is a thin wrapper; the
class is passed in, so this module never imports :mod:`lpbounds.model.mdp`). It never
imports Gymnasium either: any object with a tabular ``P`` and integer
``observation_space.n`` / ``action_space.n`` is read, so importing lpbounds does not need
Gymnasium installed.

Gymnasium's toy-text environments (FrozenLake, Taxi, CliffWalking, ...) expose their
whole model as ``env.unwrapped.P[s][a] = [(prob, next_state, reward, terminated), ...]``
with ``Discrete`` observation and action spaces. The reading, entry by entry:

* states and actions keep their Gymnasium indices ``0..n-1`` and ``0..A-1``; every action
  of every state must be listed (Gymnasium has no action masks);
* the reward of a pair is the expected reward of its transitions,
  ``r(s, a) = sum_k prob_k * reward_k``;
* a transition with ``terminated=True`` ends the episode after paying its reward: it
  moves to one added absorbing state with reward 0, the *sink*, index ``n`` (every action
  of the sink stays there with reward 0), so its value is 0 and
  ``V*(s) = max_a sum_k prob_k (reward_k + discount * (0 if terminated_k else V*(s'_k)))``,
  the value iteration of Gymnasium's own ``P``. The sink is FiniteMDP's
  (``mdp.sink`` is True, ``mdp.n_states = n + 1``): :meth:`FiniteMDP.user_values
  <lpbounds.model.mdp.FiniteMDP.user_values>`, ``user_bounds`` and ``user_policy`` drop
  it, so reported vectors have Gymnasium's ``n`` entries. Without any terminated
  transition of positive probability no sink is added (``sink="auto"``): a terminated
  entry of probability 0 is valid and changes nothing (it moves to the sink when there is
  one, else it stays on its own next state, with probability 0 either way);
* ``P`` is followed literally: the states where an episode ends (FrozenLake's holes and
  goal, whose every action is a terminated self-loop) keep their own entries, and no
  environment is special-cased;
* entries repeating a ``(next_state, terminated)`` of the same pair add up (slippery
  FrozenLake lists duplicates): the transition probability is their sum (eq. 2 of the
  paper).

Every entry is validated: a probability is a finite real in ``[0, 1]``, a next state an
integer in ``[0, n)``, a reward a finite real, ``terminated`` a bool; each pair's
probabilities sum to one within :data:`~lpbounds.tolerances.PROBABILITY_SUM_ATOL`. A bad
entry raises :class:`~lpbounds.errors.ValidationError` naming it as ``P[s][a][k]`` (or its
pair as ``P[s][a]``), in the table's own words: never the arrays it is converted to.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ValidationError
from ..tolerances import PROBABILITY_SUM_ATOL
from ..validation import check_discount, describe_value, is_int

if TYPE_CHECKING:
    from .mdp import FiniteMDP

__all__ = ["SINK_CHOICES", "from_gymnasium"]

#: ``sink=``: add the end state when a transition is terminated, always, or never
SINK_CHOICES = ("auto", True, False)

_TABULAR_HINT = (
    "from_gymnasium needs a tabular model, as the toy-text environments expose "
    "(env.unwrapped.P[s][a] = [(prob, next_state, reward, terminated), ...])"
)


def _scalar(x: Any) -> Any:
    """A 0-d array as its element (Gymnasium stores ``Discrete.n`` as a NumPy integer)."""
    return x.item() if isinstance(x, np.ndarray) and x.ndim == 0 else x


def _space_size(base: Any, env: Any, attr: str) -> int:
    """``n`` of a Discrete space (``observation_space`` or ``action_space``), starting at 0."""
    space = getattr(base, attr, None)
    if space is None:
        space = getattr(env, attr, None)
    if space is None:
        raise ValidationError(f"env.unwrapped has no attribute {attr}: {_TABULAR_HINT}")
    n = _scalar(getattr(space, "n", None))
    if not is_int(n):
        raise ValidationError(
            f"env.unwrapped.{attr} is {describe_value(space)}, not a Discrete space (no "
            f"integer attribute n): {_TABULAR_HINT}"
        )
    n = int(n)
    if n < 1:
        raise ValidationError(f"env.unwrapped.{attr}.n = {n}: the space is empty")
    start = _scalar(getattr(space, "start", 0))
    if not is_int(start) or int(start) != 0:
        raise ValidationError(
            f"env.unwrapped.{attr} starts at {start!r}: from_gymnasium reads Discrete spaces "
            "whose elements are 0..n-1 (the toy-text environments' spaces)"
        )
    return n


def _find_table(env: Any) -> tuple[Any, Any]:
    """``(P, the object holding the spaces)``: ``env.unwrapped.P`` or ``env.P``."""
    base = getattr(env, "unwrapped", env)
    for holder in (base, env):
        try:
            table = holder.P
        except AttributeError:
            continue
        except Exception as exc:  # a wrapper that forwards attributes and fails
            raise ValidationError(
                f"reading env.unwrapped.P failed ({exc!r}): {_TABULAR_HINT}"
            ) from exc
        if table is not None:
            return table, holder
    raise ValidationError(f"env.unwrapped has no attribute P: {_TABULAR_HINT}")


def _lookup(container: Any, key: int, name: str, what: str, size: int) -> Any:
    """``container[key]`` (a dict or a sequence), refusing a missing key naming it."""
    try:
        return container[key]
    except (KeyError, IndexError):
        raise ValidationError(
            f"{name} has no {what} {key} ({what}s are 0..{size - 1}): every {what} of the "
            "space must be listed"
        ) from None
    except TypeError:
        raise ValidationError(
            f"{name} is {describe_value(container)}, not a mapping or a list indexed by "
            f"{what}: {_TABULAR_HINT}"
        ) from None


def _check_size(container: Any, name: str, what: str, size: int) -> None:
    """A table with more keys than the space has elements is refused (a wrong space)."""
    try:
        count = len(container)
    except TypeError:
        return  # indexed above; no size to compare
    if count > size:
        keys = list(container.keys()) if isinstance(container, dict) else range(count)
        extra = next((k for k in keys if not (is_int(k) and 0 <= int(k) < size)), count - 1)
        raise ValidationError(
            f"{name} has {count} entries but the space has {size} {what}s ({what} {extra!r} "
            f"is not in 0..{size - 1})"
        )


def _real(name: str, x: Any, what: str) -> float:
    """A real number (Python or NumPy), refusing booleans and strings."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise ValidationError(f"{name}: the {what} {describe_value(x)} is not a real number")
    value = float(x)
    if not math.isfinite(value):
        raise ValidationError(f"{name}: the {what} {value} is not finite")
    return value


def _read_entry(name: str, entry: Any, n: int) -> tuple[float, int, float, bool]:
    """``(prob, next_state, reward, terminated)`` of one entry, checked."""
    if isinstance(entry, (str, bytes)) or not isinstance(entry, Sequence | np.ndarray):
        raise ValidationError(
            f"{name} is {describe_value(entry)}, not a tuple (prob, next_state, reward, terminated)"
        )
    if len(entry) != 4:
        raise ValidationError(
            f"{name} has {len(entry)} fields; expected 4 (prob, next_state, reward, terminated)"
        )
    p_raw, y_raw, r_raw, done_raw = entry
    p = _real(name, p_raw, "probability")
    if not 0.0 <= p <= 1.0:
        raise ValidationError(f"{name}: the probability {p} is not in [0, 1]")
    if not is_int(y_raw):
        raise ValidationError(f"{name}: the next state {describe_value(y_raw)} is not an integer")
    y = int(y_raw)
    if not 0 <= y < n:
        raise ValidationError(
            f"{name}: the next state {y} is out of range [0, {n}) (observation_space.n = {n})"
        )
    r = _real(name, r_raw, "reward")
    if not isinstance(done_raw, (bool, np.bool_)):
        raise ValidationError(f"{name}: terminated is {describe_value(done_raw)}, not a bool")
    return p, y, r, bool(done_raw)


#: One entry of ``P`` as read: ``(s, a, next_state, prob, reward, terminated)``.
Entry = tuple[int, int, int, float, float, bool]


def _read_table(
    table: Any, n: int, m: int
) -> tuple[list[Entry], list[tuple[int, int, int]], tuple[int, int, int] | None]:
    """The entries of ``P`` in order, their places ``(s, a, k)`` (to name them), and the
    first terminated entry of positive probability ``(s, a, k)`` (None without one)."""
    _check_size(table, "P", "state", n)
    rows: list[Entry] = []
    places: list[tuple[int, int, int]] = []
    first_done: tuple[int, int, int] | None = None
    for s in range(n):
        actions = _lookup(table, s, "P", "state", n)
        _check_size(actions, f"P[{s}]", "action", m)
        for a in range(m):
            entries = _lookup(actions, a, f"P[{s}]", "action", m)
            if isinstance(entries, (str, bytes)) or not isinstance(entries, Sequence):
                raise ValidationError(
                    f"P[{s}][{a}] is {describe_value(entries)}, not a list of "
                    "(prob, next_state, reward, terminated)"
                )
            if len(entries) == 0:
                raise ValidationError(
                    f"P[{s}][{a}] is empty: the pair (state {s}, action {a}) has no transition"
                )
            total = 0.0
            for k, entry in enumerate(entries):
                p, y, r, done = _read_entry(f"P[{s}][{a}][{k}]", entry, n)
                total += p
                if done and p > 0.0 and first_done is None:
                    first_done = (s, a, k)
                rows.append((s, a, y, p, r, done))
                places.append((s, a, k))
            if abs(total - 1.0) > PROBABILITY_SUM_ATOL:
                raise ValidationError(
                    f"P[{s}][{a}]: the probabilities of its {len(entries)} entries sum to "
                    f"{total:.12g}, not 1 (tolerance {PROBABILITY_SUM_ATOL:g})"
                )
    return rows, places, first_done


def _transition_rows(rows: list[Entry], n: int, m: int, add_sink: bool) -> np.ndarray:
    """``[s, a, next, p, r]`` rows for :func:`~lpbounds.model.interop.from_transitions`: a
    terminated entry moves to the sink (index ``n``) when there is one; without one every
    terminated entry has probability 0 (a positive one needs the sink) and keeps its own
    next state, where it adds nothing. With the sink, its ``m`` self-loops come last."""
    arr = np.array([row[:5] for row in rows], dtype=np.float64).reshape(-1, 5)
    if add_sink:
        done = np.array([row[5] for row in rows], dtype=bool)
        arr[done, 2] = n
        loops = np.zeros((m, 5))
        loops[:, 0], loops[:, 1], loops[:, 2], loops[:, 3] = n, np.arange(m), n, 1.0
        arr = np.concatenate([arr, loops])
    return arr


def from_gymnasium(
    cls: type[FiniteMDP],
    env: Any,
    discount: Any,
    *,
    sink: Any = "auto",
    action_names: Any = None,
) -> FiniteMDP:
    """A Gymnasium tabular environment (its ``P``) as a :class:`FiniteMDP`.

    The converter behind :meth:`FiniteMDP.from_gymnasium` (see the module docstring).

    Parameters
    ----------
    cls : type
        :class:`~lpbounds.model.mdp.FiniteMDP` (or a subclass).
    env : object
        A Gymnasium environment (wrapped or ``env.unwrapped``) whose ``unwrapped`` (or
        itself) has ``P[s][a] = [(prob, next_state, reward, terminated), ...]`` (a dict or
        a list per state, then per action) and ``Discrete`` spaces ``observation_space``
        (``n`` states) and ``action_space`` (``A`` actions), as the toy-text environments
        do. Gymnasium itself is not needed: any object of that shape is read.
    discount : float
        In ``[0, 1)``; Gymnasium's environments have none (it is the agent's).
    sink : {"auto", True, False}
        The absorbing end state (index ``n``, reward 0) that terminated transitions move
        to. ``"auto"`` (default): added when some transition is terminated; ``True``:
        always (a model of ``n + 1`` states even without one); ``False``: never, and a
        terminated transition is refused, naming it (for a continuing task).
    action_names : sequence of str, optional
        Labels of the ``A`` actions (default ``"0", "1", ...``).

    Returns
    -------
    FiniteMDP
        States ``0..n-1`` and actions ``0..A-1`` as in Gymnasium; with a sink,
        ``mdp.sink`` is True and the sink is state ``mdp.n_states - 1 == n``, worth 0.
        ``mdp.user_values(v)`` / ``user_bounds`` / ``user_policy`` drop it (equivalently,
        slice ``[:n]``). The reward of a pair is ``sum_k prob_k * reward_k``; a
        terminated transition pays its reward and moves to the sink, so
        ``V*(s) = max_a sum_k prob_k (reward_k + discount * (0 if terminated_k else
        V*(s'_k)))``. Entries repeating a next state add up.

    Raises
    ------
    ValidationError
        No tabular ``P`` (``"env.unwrapped has no attribute P: ..."``), a space that is
        not Discrete (no integer ``n``) or does not start at 0, a missing state or action
        in ``P``, an empty list of transitions, or a bad entry, named ``P[s][a][k]``: a
        probability not a finite real in ``[0, 1]``, a next state not an integer in
        ``[0, n)``, a reward not finite, ``terminated`` not a bool; probabilities of a
        pair not summing to one; a terminated transition with ``sink=False``.

    Notes
    -----
    ``P`` is read as it is, with no special case: the states where an episode ends
    (FrozenLake's holes and goal) keep their own entries, which Gymnasium lists as
    terminated self-loops (so they are worth 0 here too). Taxi's states where the
    passenger sits at its destination are never reached in an episode; ``P`` still
    lists moves for them, and they are converted like the others.
    """
    if not any(sink is c or (isinstance(c, str) and sink == c) for c in SINK_CHOICES):
        raise ValidationError(f"sink must be 'auto', True or False; got {describe_value(sink)}")
    discount = check_discount(discount)
    table, holder = _find_table(env)
    n = _space_size(holder, env, "observation_space")
    m = _space_size(holder, env, "action_space")
    rows, places, first_done = _read_table(table, n, m)
    if first_done is not None and sink is False:
        s, a, k = first_done
        raise ValidationError(
            f"P[{s}][{a}][{k}] is terminated but sink=False: a terminated transition ends "
            "the episode, which needs the end state (sink='auto' or True)"
        )
    add_sink = sink is True or (sink == "auto" and first_done is not None)
    arr = _transition_rows(rows, n, m, add_sink)

    def entry(i: int) -> str:  # the user's own name of row i (the sink's loops come last)
        if i < len(places):
            return "P[{}][{}][{}]".format(*places[i])
        return f"the end state's self-loop (action {i - len(places)})"

    from .interop import from_transitions  # with scipy.sparse: only when a converter runs

    built = from_transitions(
        cls, arr, discount, n_states=n + int(add_sink), n_actions=m, action_names=action_names,
        entry_name=entry,
    )  # fmt: skip
    if not add_sink:
        return built
    return cls(
        built.successors, built.probabilities, built.rewards, discount,
        allowed=built.allowed, action_names=built.action_names, copy=False, sink=True,
    )  # fmt: skip
