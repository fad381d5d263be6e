r"""Shrinking a counterexample: the smallest instance found on which a verdict stays the same.

:func:`shrink` takes an instance (an MDP and a partition) and a test ``keep(mdp,
partition) -> bool`` ("the claim is still violated here") and makes the instance smaller
one step at a time, keeping a step only when the test still passes (the greedy descent of
delta debugging, as hypothesis shrinks a failing input):

1. fewer **states** -- chunks of states removed, halves first, then quarters, ..., single
   states; a transition into a removed state becomes a self-loop of its source;
2. fewer **blocks** -- all blocks merged into one, then pairs of blocks;
3. fewer **actions** -- each state's allowed actions moved to the front and the columns
   no state then needs dropped, a column of actions removed (when every state keeps one),
   single (state, action) pairs disallowed;
4. fewer **outcomes** -- an outcome's probability moved onto another outcome;
5. **rounder numbers** -- rewards rescaled by a power of ten towards ``max|R| = 1``,
   rounded to 1-3 significant digits, or set to 0 one by one; probabilities rounded to
   halves, quarters, tenths or hundredths (the largest of a row takes the remainder);
   the discount rounded (0, 0.5, 0.9, 0.99, or fewer digits); one shared distribution
   ``p_l`` where every allowed pair has the same.

Every step lowers ``(states, blocks, actions, outcomes, allowed pairs, digits, magnitude)``
in lexicographic order (``digits``: the significant decimal digits of the rewards,
probabilities and discount; ``magnitude``: ``|log10 max|R||``), so the descent ends; it
also ends after ``max_evaluations`` tests. The result is the last instance that passed,
never one that did not: the start itself is tested first, and when it does not pass there
is nothing to shrink (``Shrunk.shown`` is False: a caller writes no counterexample then).

:func:`model_toml` writes an instance as an instance file of ``kind = "explicit"`` (the
arrays in full, with a ``[partition] kind = "labels"``) that ``lpbounds solve`` and
``lpbounds verify`` read.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ValidationError
from ..model.instances import model_toml
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from ..outputs import write_text_atomic

__all__ = ["Keep", "Shrunk", "model_toml", "shrink", "size_of", "write_model"]

#: ``keep(mdp, partition)``: True when the candidate still shows the verdict being kept.
Keep = Callable[[FiniteMDP, Partition], bool]

Pair = tuple[FiniteMDP, Partition]


@dataclass(frozen=True)
class Shrunk:
    """The result of :func:`shrink`.

    Attributes
    ----------
    mdp, partition
        The smallest instance found (the input itself when no step was kept).
    evaluations : int
        How many candidates were tested (the start's own test not counted).
    steps : int
        How many of them were kept.
    shown : bool
        Whether the start passed ``keep``: when it did not, nothing was shrunk (the start
        is returned, ``evaluations`` and ``steps`` are 0) and it shows nothing.
    """

    mdp: FiniteMDP
    partition: Partition
    evaluations: int
    steps: int
    shown: bool = True


def size_of(mdp: FiniteMDP, partition: Partition) -> dict[str, int]:
    """``states``, ``actions``, ``outcomes`` and ``blocks`` of an instance."""
    return {
        "states": mdp.n_states,
        "actions": mdp.n_actions,
        "outcomes": mdp.n_outcomes,
        "blocks": partition.n_partitions,
    }


# ---------------------------------------------------------------------- the measure
def _digits(x: float) -> int:
    """Significant decimal digits of ``repr(x)`` (0 for 0.0)."""
    if x == 0.0 or not math.isfinite(x):
        return 0
    mantissa = repr(abs(float(x))).split("e")[0].replace(".", "").lstrip("0").rstrip("0")
    return max(1, len(mantissa))


def _array_digits(a: np.ndarray) -> int:
    return sum(_digits(float(t)) for t in np.asarray(a, dtype=np.float64).ravel())


def _measure(mdp: FiniteMDP, part: Partition) -> tuple[int, ...]:
    rewards = np.where(mdp.allowed, mdp.rewards, 0.0)
    rmax = float(np.abs(rewards).max(initial=0.0))
    magnitude = abs(round(math.log10(rmax))) if rmax > 0 else 0
    digits = _array_digits(rewards) + _array_digits(mdp.probabilities) + _digits(mdp.discount)
    return (
        mdp.n_states,
        part.n_partitions,
        mdp.n_actions,
        mdp.n_outcomes,
        int(mdp.allowed.sum()),
        digits,
        magnitude,
    )


# ---------------------------------------------------------------------- building candidates
def _make(
    succ: np.ndarray,
    probs: np.ndarray,
    rewards: np.ndarray,
    discount: float,
    allowed: np.ndarray,
    labels: np.ndarray,
) -> Pair | None:
    """A validated candidate (None if the arrays do not make one)."""
    _, compact = np.unique(labels, return_inverse=True)
    try:
        mdp = FiniteMDP(succ, probs, np.where(allowed, rewards, 0.0), discount, allowed)
        return mdp, Partition(compact.ravel())
    except ValidationError:
        return None


def _parts(mdp: FiniteMDP) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray]:
    return (
        np.array(mdp.successors),
        np.array(mdp.probabilities),
        np.array(mdp.rewards),
        float(mdp.discount),
        np.array(mdp.allowed),
    )


def _without_states(mdp: FiniteMDP, part: Partition, drop: np.ndarray) -> Pair | None:
    n = mdp.n_states
    keep = np.setdiff1d(np.arange(n), drop)
    if keep.size == 0:
        return None
    new = np.full(n, -1, dtype=np.int64)
    new[keep] = np.arange(keep.size)
    succ, probs, rewards, lam, allowed = _parts(mdp)
    s = new[succ[keep]]
    own = np.broadcast_to(np.arange(keep.size)[:, None, None], s.shape)
    s = np.where(s < 0, own, s)  # into a removed state: a self-loop instead
    p = probs if probs.ndim == 1 else probs[keep]
    return _make(s, p, rewards[keep], lam, allowed[keep], part.labels[keep])


def _state_moves(mdp: FiniteMDP, part: Partition) -> Iterator[Pair | None]:
    n = mdp.n_states
    chunk = n // 2
    while chunk >= 1:
        for start in range(0, n, chunk):
            yield _without_states(mdp, part, np.arange(start, min(n, start + chunk)))
        chunk //= 2


def _block_moves(mdp: FiniteMDP, part: Partition) -> Iterator[Pair | None]:
    m = part.n_partitions
    if m < 2:
        return
    succ, probs, rewards, lam, allowed = _parts(mdp)
    yield _make(succ, probs, rewards, lam, allowed, np.zeros(mdp.n_states, dtype=np.int64))
    pairs = (
        [(i, j) for i in range(m) for j in range(i + 1, m)]
        if m <= 8
        else [(i, i + 1) for i in range(m - 1)]
    )
    for i, j in pairs:
        labels = np.where(part.labels == j, i, part.labels)
        yield _make(succ, probs, rewards, lam, allowed, labels)


def _compacted(mdp: FiniteMDP, part: Partition) -> Pair | None:
    """Each state's allowed actions moved to the front (a relabelling per state), and the
    columns no state needs then dropped (None when every column is needed)."""
    succ, probs, rewards, lam, allowed = _parts(mdp)
    k = int(allowed.sum(axis=1).max(initial=0))
    if k >= mdp.n_actions:
        return None
    order = np.argsort(~allowed, axis=1, kind="stable")[:, :k]
    rows = np.arange(mdp.n_states)[:, None]
    p = probs if probs.ndim == 1 else probs[rows, order]
    return _make(succ[rows, order], p, rewards[rows, order], lam, allowed[rows, order], part.labels)


def _action_moves(mdp: FiniteMDP, part: Partition) -> Iterator[Pair | None]:
    succ, probs, rewards, lam, allowed = _parts(mdp)
    yield _compacted(mdp, part)
    if mdp.n_actions > 1:
        for u in range(mdp.n_actions):
            cols = [k for k in range(mdp.n_actions) if k != u]
            if not allowed[:, cols].any(axis=1).all():
                continue
            p = probs if probs.ndim == 1 else probs[:, cols]
            yield _make(succ[:, cols], p, rewards[:, cols], lam, allowed[:, cols], part.labels)
    for x, u in zip(*np.nonzero(allowed), strict=True):
        if allowed[x].sum() > 1:
            mask = allowed.copy()
            mask[x, u] = False
            yield _make(succ, probs, rewards, lam, mask, part.labels)


def _outcome_moves(mdp: FiniteMDP, part: Partition) -> Iterator[Pair | None]:
    n_out = mdp.n_outcomes
    if n_out < 2:
        return
    succ, probs, rewards, lam, allowed = _parts(mdp)
    for ll in range(n_out):
        onto = 1 if ll == 0 else 0
        rest = [k for k in range(n_out) if k != ll]
        p = probs.copy()
        p[..., onto] = p[..., onto] + p[..., ll]
        yield _make(succ[..., rest], p[..., rest], rewards, lam, allowed, part.labels)


def _significant(a: np.ndarray, k: int) -> np.ndarray:
    """Every entry rounded to ``k`` significant decimal digits (through its decimal text)."""
    return np.array([float(f"{float(t):.{k}g}") for t in a.ravel()]).reshape(a.shape)


def _reward_moves(mdp: FiniteMDP, part: Partition) -> Iterator[Pair | None]:
    succ, probs, rewards, lam, allowed = _parts(mdp)
    rewards = np.where(allowed, rewards, 0.0)
    rmax = float(np.abs(rewards).max(initial=0.0))
    if rmax > 0 and round(math.log10(rmax)) != 0:
        scaled = _significant(rewards / 10.0 ** round(math.log10(rmax)), 15)
        yield _make(succ, probs, scaled, lam, allowed, part.labels)
    for k in (1, 2, 3):
        yield _make(succ, probs, _significant(rewards, k), lam, allowed, part.labels)
    for x, u in zip(*np.nonzero((rewards != 0.0) & allowed), strict=True):
        r = rewards.copy()
        r[x, u] = 0.0
        yield _make(succ, probs, r, lam, allowed, part.labels)


def _rounded_rows(probs: np.ndarray, q: int) -> np.ndarray | None:
    """Each distribution rounded to multiples of ``1/q``, its largest entry taking the rest
    (None when that would be negative)."""
    p = np.atleast_2d(probs.reshape(-1, probs.shape[-1]))
    out = np.round(p * q) / q
    big = np.argmax(p, axis=1)
    rows = np.arange(p.shape[0])
    out[rows, big] = 0.0
    out[rows, big] = 1.0 - out.sum(axis=1)
    if (out < 0).any():
        return None
    return out.reshape(probs.shape)


def _number_moves(mdp: FiniteMDP, part: Partition) -> Iterator[Pair | None]:
    yield from _reward_moves(mdp, part)
    succ, probs, rewards, lam, allowed = _parts(mdp)
    if probs.ndim == 3 and (probs[allowed] == probs[allowed][0]).all():
        yield _make(succ, probs[allowed][0], rewards, lam, allowed, part.labels)  # one p_l
    for q in (2, 4, 10, 100):
        p = _rounded_rows(probs, q)
        if p is not None:
            yield _make(succ, p, rewards, lam, allowed, part.labels)
    for d in dict.fromkeys((0.0, 0.5, 0.9, 0.99, round(lam, 1), round(lam, 2), round(lam, 3))):
        if 0.0 <= d < 1.0 and d != lam:
            yield _make(succ, probs, rewards, float(d), allowed, part.labels)


_MOVES = (_state_moves, _block_moves, _action_moves, _outcome_moves, _number_moves)


def _candidates(mdp: FiniteMDP, part: Partition) -> Iterator[Pair]:
    """The candidates of one pass, most aggressive first, each strictly smaller."""
    here = _measure(mdp, part)
    for moves in _MOVES:
        for cand in moves(mdp, part):
            if cand is not None and _measure(*cand) < here:
                yield cand


def shrink(
    mdp: FiniteMDP,
    partition: Partition,
    keep: Keep,
    *,
    max_evaluations: int = 300,
    max_seconds: float | None = None,
) -> Shrunk:
    """The smallest instance found from ``(mdp, partition)`` on which ``keep`` stays True.

    Parameters
    ----------
    mdp, partition
        The instance to shrink. ``keep(mdp, partition)`` is tested first: a record read
        from disk may say more than the instance shows (edited, or of a solver that
        answers differently now), and a counterexample must show what it claims.
    keep : callable(FiniteMDP, Partition) -> bool
        True when a candidate still shows what is kept (e.g. a claim still *violated*).
    max_evaluations : int
        Most candidates tested.
    max_seconds : float, optional
        Stop testing new candidates after this long.

    Returns
    -------
    Shrunk
        With ``shown`` False when the start does not pass ``keep``.
    """
    if partition.n_states != mdp.n_states:
        raise ValidationError(
            f"partition has {partition.n_states} states; the MDP has {mdp.n_states}"
        )
    if not keep(mdp, partition):
        return Shrunk(mdp, partition, 0, 0, shown=False)
    deadline = None if max_seconds is None else time.monotonic() + float(max_seconds)
    current: Pair = (mdp, partition)
    evaluations = steps = 0
    moved = True
    while moved:
        moved = False
        for cand in _candidates(*current):
            if evaluations >= max_evaluations or (deadline and time.monotonic() > deadline):
                return Shrunk(*current, evaluations, steps)
            evaluations += 1
            if keep(*cand):
                current, steps, moved = cand, steps + 1, True
                break
    return Shrunk(*current, evaluations, steps)


# ---------------------------------------------------------------------- instance files
def write_model(
    path: str | Path, mdp: FiniteMDP, partition: Partition, header: Sequence[str] = ()
) -> Path:
    """Write :func:`model_toml` to ``path`` atomically; returns the path."""
    return write_text_atomic(path, model_toml(mdp, partition, header))
