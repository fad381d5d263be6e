"""Models from the neighbours: pymdptoolbox, QuantEcon's ``DiscreteDP`` and MDPSolver.

The converters behind :meth:`FiniteMDP.from_matrices <lpbounds.model.mdp.FiniteMDP.from_matrices>`,
:meth:`~lpbounds.model.mdp.FiniteMDP.from_pymdptoolbox`,
:meth:`~lpbounds.model.mdp.FiniteMDP.from_quantecon`,
:meth:`~lpbounds.model.mdp.FiniteMDP.from_transitions` and
:meth:`~lpbounds.model.mdp.FiniteMDP.to_quantecon` (the classmethods are thin wrappers; the
class is passed in, so this module never imports :mod:`lpbounds.model.mdp`).

Every input form is first brought to one intermediate: the *pairs* of the model, a
sparse matrix ``Q`` whose row ``k`` is the distribution of the next state after action
``a[k]`` in state ``s[k]``, with the expected reward ``r[k]`` (:func:`model_from_pairs`).
Pairs that are not listed are not available (the ``allowed`` mask). Rules shared by every
converter:

* a layout that the shapes do not decide is never guessed: ``Q`` of shape ``(n, n, n)``
  with as many actions as states needs ``layout="sas"`` (``Q[s, a, s']``, QuantEcon and
  MDPSolver) or ``layout="ass"`` (``P[a, s, s']``, pymdptoolbox);
* ``terminal=True`` adds one absorbing state with reward 0 (the *sink*, the last state)
  and sends to it the probability missing from every row that sums to less than one
  (but more than zero); ``terminal=[states]`` also ends the process after the listed
  states (every action of a listed state moves to the sink; ``terminal_reward="keep"``,
  the default, lets it pay its reward first, ``"zero"`` makes the listed states worth 0,
  Gymnasium's and POMDPs.jl's convention). Without ``terminal`` such rows are refused.
  The sink's value is 0 under every policy; :meth:`FiniteMDP.user_values
  <lpbounds.model.mdp.FiniteMDP.user_values>` drops it from reported vectors;
* a pair that is available (allowed, given a finite reward or a reward entry) but has
  no transition at all (an empty row, or no ``[s, a, s', p]`` row) is refused, naming
  the pair, unless its state is listed in ``terminal=``: it is never silently dropped
  (with its reward) nor silently sent to the sink. Mark a pair that is not available
  (``allowed=`` False, a reward of ``-inf``), or send a pair that ends the process to a
  state listed in ``terminal=``;
* ``sense="min"``: the rewards are costs to minimise; they are stored negated (the model
  is the reward-maximising problem of the negated costs) and the ``user_*`` helpers of
  :class:`~lpbounds.model.mdp.FiniteMDP` translate values and bounds back.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp

from ..errors import ValidationError
from ..tolerances import PROBABILITY_NEGATIVE_ATOL, PROBABILITY_SUM_ATOL
from ..validation import (
    as_array,
    as_float_array,
    check_array,
    check_choice,
    check_discount,
    check_int,
    first_index,
)

if TYPE_CHECKING:
    from .mdp import FiniteMDP

__all__ = [
    "from_matrices",
    "from_quantecon",
    "from_transitions",
    "model_from_pairs",
    "to_quantecon",
]

LAYOUTS = ("sas", "ass")
#: ``terminal_reward=``: what a state listed in ``terminal=`` pays before the sink
TERMINAL_REWARDS = ("keep", "zero")
_TERMINAL_HINT = (
    "pass terminal=True to send the missing probability to an absorbing end state "
    "(value 0), or fix the row"
)
_MASK_HINT = (
    "an action that is not available belongs in allowed= (from_matrices), or use "
    "FiniteMDP.from_quantecon, which reads -inf rewards as 'not available'"
)


# ---------------------------------------------------------------------- the shared builder
def _terminal_states(terminal: Any, n: int) -> tuple[bool, np.ndarray]:
    """``(add a sink, sorted indices of the states that end the process)`` from ``terminal=``."""
    none = np.zeros(0, dtype=np.int64)
    if terminal is None or terminal is False:
        return False, none
    if terminal is True:
        return True, none
    arr = as_array("terminal", terminal)
    if arr.dtype == bool:
        if arr.shape != (n,):
            raise ValidationError(f"terminal: a boolean mask needs shape ({n},); got {arr.shape}")
        return True, np.flatnonzero(arr).astype(np.int64)
    idx = check_array("terminal", arr, integer=True)
    if idx.ndim != 1:
        raise ValidationError(f"terminal must be True, state indices or a mask; got {idx.shape}")
    bad = (idx < 0) | (idx >= n)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValidationError(f"terminal[{k}] = {int(idx[k])} is not a state in [0, {n})")
    return True, np.unique(idx.astype(np.int64))


def _check_terminal_reward(terminal_reward: Any, terminal: Any) -> str:
    """``terminal_reward`` checked: ``"zero"`` needs states listed in ``terminal=``."""
    value = check_choice("terminal_reward", terminal_reward, TERMINAL_REWARDS)
    if value == "zero" and (terminal is None or terminal is False or terminal is True):
        raise ValidationError(
            f"terminal_reward='zero' applies to the states listed in terminal= (state "
            f"indices or a mask); terminal={terminal!r} lists none"
            + (" (its sink is worth 0 already)" if terminal is True else "")
        )
    return value


def _no_transition_hint(x: int, unavailable: str) -> str:
    """How to fix an available pair of state ``x`` without any transition."""
    return (
        "give its transitions; if taking it ends the process, send it to a state listed "
        "in terminal= (with terminal_reward='zero' the listed states are worth 0, as after "
        f"a terminated transition in Gymnasium), or list state {x} itself in terminal= "
        f"(every action of it then pays its reward and ends); if it is not available, "
        f"{unavailable}"
    )


def _check_nonempty(
    q: sp.csr_matrix,
    pairs: tuple[np.ndarray, np.ndarray],
    ends: np.ndarray,
    row_name: Callable[[int], str],
    unavailable: Callable[[int], str],
) -> None:
    """Refuse a pair with no transition (no positive entry) outside the terminal states."""
    rows = np.repeat(np.arange(q.shape[0]), np.diff(q.indptr))
    positive = np.bincount(rows[q.data > 0], minlength=q.shape[0])
    empty = (positive == 0) & ~ends
    if empty.any():
        k = int(np.flatnonzero(empty)[0])
        x, u = int(pairs[0][k]), int(pairs[1][k])
        raise ValidationError(
            f"{row_name(k)}: the pair (state {x}, action {u}) has no transition (no "
            f"probability on any next state; {int(empty.sum())} such pairs): "
            f"{_no_transition_hint(x, unavailable(k))}"
        )


def _check_rows(q: sp.csr_matrix, row_name: Callable[[int], str], sink: bool) -> np.ndarray:
    """Finite, non-negative entries; rows summing to one (to less only with a sink).

    Returns the probability each row misses (0 where complete). A row summing to more
    than one is refused here too, named in the input's own words (``row_name``), not left
    to :class:`~lpbounds.model.mdp.FiniteMDP`, whose message would name its own array.
    """
    rows = np.repeat(np.arange(q.shape[0]), np.diff(q.indptr))
    _check_entries(rows, q.indices, q.data, row_name)
    missing = 1.0 - np.asarray(q.sum(axis=1)).ravel()
    short = missing > PROBABILITY_SUM_ATOL
    off = (-missing > PROBABILITY_SUM_ATOL) | (short & (not sink))
    if off.any():
        k = int(np.flatnonzero(off)[0])
        raise ValidationError(
            f"{row_name(k)}: the probabilities sum to {1.0 - missing[k]:.12g}, not 1 "
            f"(tolerance {PROBABILITY_SUM_ATOL:g}; {int(off.sum())} such pairs)"
            + (f": {_TERMINAL_HINT}" if missing[k] > 0 else "")
        )
    return np.where(short, missing, 0.0)


def model_from_pairs(
    cls: type[FiniteMDP],
    q: Any,
    s: np.ndarray,
    a: np.ndarray,
    r: np.ndarray,
    shape: tuple[int, int],
    discount: float,
    *,
    row_name: Callable[[int], str],
    unavailable: Callable[[int], str],
    terminal: Any = None,
    terminal_reward: str = "keep",
    sense: str = "max",
    action_names: Any = None,
) -> FiniteMDP:
    """Build the model from its available pairs (the intermediate of every converter).

    Parameters
    ----------
    cls : type
        :class:`~lpbounds.model.mdp.FiniteMDP` (or a subclass).
    q : scipy.sparse matrix (K, n)
        Row ``k``: the next-state distribution of pair ``(s[k], a[k])``.
    s, a : ndarray of int (K,)
        The pairs, in range and without repetition (checked by the callers).
    r : ndarray (K,)
        Their expected rewards (finite).
    shape : (n, m)
        Numbers of states and actions.
    discount : float
    row_name : callable
        ``row_name(k)``: how the user's input names row ``k`` (for messages).
    unavailable : callable
        ``unavailable(k)``: how the user's input marks pair ``k`` not available (for the
        message refusing a pair without any transition outside the terminal states).
    terminal, terminal_reward, sense, action_names
        See the module docstring and :class:`~lpbounds.model.mdp.FiniteMDP`.
    """
    n, m = shape
    sink, term = _terminal_states(terminal, n)
    terminal_reward = _check_terminal_reward(terminal_reward, terminal)
    _check_coverage(s, term, shape)
    _check_raw_entries(q, row_name)
    q = sp.csr_matrix(q, dtype=np.float64)
    q.sum_duplicates()
    q.eliminate_zeros()
    q.sort_indices()
    ends = np.isin(s, term) if term.size else np.zeros(s.size, dtype=bool)
    _check_nonempty(q, (s, a), ends, row_name, unavailable)
    if ends.any():  # a terminal state's actions all move to the sink after their reward
        keep = np.repeat(~ends, np.diff(q.indptr)).astype(np.float64)
        q = sp.csr_matrix((q.data * keep, q.indices, q.indptr), shape=q.shape)
        q.eliminate_zeros()
        if terminal_reward == "zero":  # ... which is 0: the listed states are worth 0
            r = np.where(ends, 0.0, r)
    # a terminal state without any action gets action 0 (reward 0)
    extra = term[~np.isin(term, s)] if term.size else term
    if extra.size:
        s, a = np.concatenate([s, extra]), np.concatenate([a, np.zeros_like(extra)])
        r = np.concatenate([r, np.zeros(extra.size)])
        q = sp.vstack([q, sp.csr_matrix((extra.size, n))], format="csr")
        row_name = _with_terminal_rows(row_name, len(s) - extra.size, s)
    missing = _check_rows(q, row_name, sink)
    return _assemble(cls, q, s, a, r, missing, (n, m), discount, sink, sense, action_names)


def _check_size(shape: tuple[int, int]) -> None:
    """Refuse index ranges beyond the dense (state, action) layout (before any product)."""
    n, m = shape
    if n * m > 2**34:  # Python ints: no overflow here
        raise ValidationError(
            f"{n} states x {m} actions (from the largest indices given) is beyond the dense "
            f"(state, action) layout of FiniteMDP ({n * m:.3g} pairs > 2**34)"
        )


def _check_coverage(s: np.ndarray, term: np.ndarray, shape: tuple[int, int]) -> None:
    """Every state needs an action (checked before anything of size n is allocated)."""
    n, _ = shape
    _check_size(shape)
    if n <= s.size + term.size:  # a mask of size n is no larger than the input
        seen = np.zeros(n, dtype=bool)
        seen[s] = True
        seen[term] = True
        n_have = int(seen.sum())
        x = int(np.argmin(seen))
    else:  # more states than pairs: some state has none (found without an n-sized array)
        have = np.union1d(s, term)
        gap = np.flatnonzero(have != np.arange(have.size))
        n_have, x = int(have.size), int(gap[0]) if gap.size else int(have.size)
    if n_have < n:
        raise ValidationError(
            f"state {x} has no allowed action ({n - n_have} such states): no pair lists it"
            "; a state where the process ends can be passed in terminal="
        )


def _check_raw_entries(q: Any, row_name: Callable[[int], str]) -> None:
    """Negative or non-finite stored entries, before duplicates are summed (they could hide)."""
    if not sp.issparse(q):
        return
    data = q.data if q.format in ("csr", "csc", "coo") else q.tocoo().data  # lil: lists
    if np.isfinite(data).all() and not (data < -PROBABILITY_NEGATIVE_ATOL).any():
        return
    coo = q.tocoo()  # only to name the entry
    _check_entries(coo.row, coo.col, coo.data, row_name)


def _check_entries(
    rows: np.ndarray, cols: np.ndarray, data: np.ndarray, row_name: Callable[[int], str]
) -> None:
    """Refuse a non-finite or negative probability, naming its row and next state."""
    for bad, what in (
        (~np.isfinite(data), "not finite"),
        (data < -PROBABILITY_NEGATIVE_ATOL, "negative"),
    ):
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            raise ValidationError(
                f"{row_name(int(rows[j]))}: the probability {data[j]} of next state "
                f"{int(cols[j])} is {what}"
            )


def _with_terminal_rows(
    row_name: Callable[[int], str], k0: int, s: np.ndarray
) -> Callable[[int], str]:
    """Names of the rows added for terminal states listed without an action."""

    def name(k: int) -> str:
        return row_name(k) if k < k0 else f"terminal state {int(s[k])}"

    return name


def _assemble(
    cls: type[FiniteMDP],
    q: sp.csr_matrix,
    s: np.ndarray,
    a: np.ndarray,
    r: np.ndarray,
    missing: np.ndarray,
    shape: tuple[int, int],
    discount: float,
    sink: bool,
    sense: str,
    action_names: Any,
) -> FiniteMDP:
    """The successor/probability arrays of :class:`FiniteMDP` from checked pairs."""
    n, m = shape
    n_all = n + int(sink)
    counts = np.diff(q.indptr)
    to_sink = missing > 0.0
    n_out = max(int((counts + to_sink).max()), 1)
    idt = np.int32 if n_all < 2**31 - 1 else np.int64  # lpbounds.model.mdp.index_dtype's rule
    succ = np.broadcast_to(np.arange(n_all, dtype=idt)[:, None, None], (n_all, m, n_out)).copy()
    prob = np.zeros((n_all, m, n_out))
    start = (s * m + a) * n_out  # flat offset of each pair's first outcome
    flat = np.repeat(start - q.indptr[:-1], counts) + np.arange(q.nnz)
    succ.reshape(-1)[flat] = q.indices
    prob.reshape(-1)[flat] = q.data
    k = np.flatnonzero(to_sink)
    succ[s[k], a[k], counts[k]] = n  # the sink is the last state
    prob[s[k], a[k], counts[k]] = missing[k]
    rew = np.zeros((n_all, m))
    allowed = np.zeros((n_all, m), dtype=bool)
    rew[s, a] = r
    allowed[s, a] = True
    if sink:  # absorbing, reward 0, every action allowed (round-trips through pymdptoolbox)
        prob[n, :, 0] = 1.0
        allowed[n, :] = True
    return cls(succ, prob, rew, discount, allowed, action_names, copy=False, sense=sense, sink=sink)


# ---------------------------------------------------------------------- pymdptoolbox
def _items(x: Any, name: str) -> list[Any]:
    """The per-action items of a list, tuple, dict (keys 0..A-1) or object/3-d array."""
    if isinstance(x, Mapping):
        if set(x) != set(range(len(x))):
            raise ValidationError(f"{name}: a dict needs the keys 0..A-1; got {list(x)!r}")
        return [x[k] for k in range(len(x))]
    if isinstance(x, np.ndarray):
        if x.dtype == object and x.ndim == 1:
            return list(x)
        if x.ndim != 3:
            raise ValidationError(f"{name} must have shape (A, n, n); got {x.shape}")
        return list(x)
    try:
        return list(x)
    except TypeError as exc:
        raise ValidationError(f"{name} must be a sequence of A matrices") from exc


def _row_of(a: int) -> Callable[[int], str]:
    def name(x: int) -> str:
        return f"row {x} of P[{a}]"

    return name


def matrix_list(P: Any, name: str) -> list[sp.csr_matrix]:
    """``A`` CSR matrices from any of pymdptoolbox's forms of ``P`` (or of matrix ``R``)."""
    if sp.issparse(P) or isinstance(P, (str, bytes)) or P is None:
        raise ValidationError(f"{name} must be A matrices (a list or an (A, n, n) array)")
    items = _items(P, name)
    if not items:
        raise ValidationError(f"{name} has no actions")
    out = []
    for a, m in enumerate(items):
        if sp.issparse(m):
            if m.dtype.kind not in "iuf":
                raise ValidationError(f"{name}[{a}] must hold real numbers; got {m.dtype}")
            if name == "P":  # before the CSR conversion sums duplicate entries
                _check_raw_entries(m, _row_of(a))
        else:
            m = check_array(f"{name}[{a}]", m, finite=False)
            if m.ndim != 2:
                raise ValidationError(f"{name}[{a}] is not a matrix (shape {m.shape})")
        mat = sp.csr_matrix(m, dtype=np.float64)
        mat.sum_duplicates()
        mat.eliminate_zeros()
        mat.sort_indices()
        out.append(mat)
    return out


def _reward_kind(R: Any) -> str:
    """``"matrices"`` (A per-transition matrices) or ``"array"`` (an (n,), (n, A) or 3-d array)."""
    if sp.issparse(R):
        return "array"
    if isinstance(R, np.ndarray):
        if R.dtype == object and R.ndim == 1:  # matrices, or numbers (state rewards)
            return "matrices" if any(sp.issparse(x) or np.ndim(x) == 2 for x in R) else "array"
        return "array"
    if isinstance(R, Mapping):
        return "matrices"
    if isinstance(R, (list, tuple)) and any(sp.issparse(x) for x in R):
        return "matrices"
    try:  # a rectangular nested list is an array, whatever its length
        arr = np.asarray(R)
    except (ValueError, TypeError):
        return "matrices"  # ragged: per-action items
    return "array" if arr.dtype != object else "matrices"


def _check_reward_values(arr: np.ndarray, allowed: np.ndarray) -> None:
    bad = ~np.isfinite(arr) & allowed
    if bad.any():
        x, u = first_index(bad)
        hint = f": {_MASK_HINT}" if arr[x, u] == -np.inf else ""
        raise ValidationError(
            f"the expected reward of state {x}, action {u} is {arr[x, u]}, not finite "
            f"({int(bad.sum())} such pairs){hint}"
        )


def expected_rewards(R: Any, mats: list[sp.csr_matrix], allowed: np.ndarray) -> np.ndarray:
    """``R[x, a]`` (n, A) from pymdptoolbox's forms: (n,), (n, A), (A, n, n) or A matrices."""
    n, n_actions = allowed.shape
    if _reward_kind(R) == "array":
        arr = np.asarray(R.toarray()) if sp.issparse(R) else R
        arr = as_float_array("R", arr, finite=False)
        if arr.shape == (n,):
            out = np.repeat(arr[:, None], n_actions, axis=1)
        elif arr.shape == (n, n_actions):
            out = arr
        elif arr.shape == (n_actions, n, n):
            return _transition_rewards([sp.csr_matrix(x) for x in arr], mats, allowed)
        else:
            hint = (
                " (R[action, state] is transposed: pymdptoolbox's R is R[state, action]; pass R.T)"
                if arr.shape == (n_actions, n)
                else ""
            )
            raise ValidationError(
                f"R must have shape {(n,)}, {(n, n_actions)} or {(n_actions, n, n)}; "
                f"got {arr.shape}{hint}"
            )
        _check_reward_values(out, allowed)
        return out
    return _transition_rewards(matrix_list(R, "R"), mats, allowed)


def _transition_rewards(
    rmats: list[sp.csr_matrix], mats: list[sp.csr_matrix], allowed: np.ndarray
) -> np.ndarray:
    """``sum_y P[a][x, y] R[a][x, y]`` for each pair."""
    n, n_actions = allowed.shape
    if len(rmats) != n_actions:
        raise ValidationError(f"R has {len(rmats)} matrices for {n_actions} actions")
    cols = []
    for a in range(n_actions):
        if rmats[a].shape != (n, n):
            raise ValidationError(f"R[{a}] has shape {rmats[a].shape}; expected {(n, n)}")
        cols.append(np.asarray(mats[a].multiply(rmats[a]).sum(axis=1)).ravel())
    out = np.stack(cols, axis=1)
    _check_reward_values(out, allowed)
    return out


def _layout_hint(P: Any) -> str:
    shape = getattr(P, "shape", None)
    if shape is not None and len(shape) == 3 and shape[0] == shape[2] != shape[1]:
        return (
            f" (shape {tuple(shape)} looks like Q[state, action, next] of QuantEcon or "
            "MDPSolver: use FiniteMDP.from_quantecon, or P.transpose(1, 0, 2))"
        )
    return ""


# intended parallel: the signature of FiniteMDP.from_matrices, its thin wrapper
def from_matrices(
    cls: type[FiniteMDP],
    P: Any,
    R: Any,
    discount: Any,
    *,
    allowed: Any = None,
    terminal: Any = None,
    terminal_reward: str = "keep",
    sense: str = "max",
    action_names: Any = None,
) -> FiniteMDP:
    """The converter of :meth:`FiniteMDP.from_matrices` (pymdptoolbox's convention).

    Every pair of ``allowed`` (default: all) is available. Its row of ``P`` must sum to
    one; with ``terminal=`` a row summing to less (but to more than 0) sends the rest to
    the sink. An allowed pair whose row is empty (all zeros) is refused, naming the pair,
    unless its state is listed in ``terminal=``: mark it ``allowed[x, a] = False`` if it
    is not available.

    ``terminal_reward`` : {"keep", "zero"}
        What a state listed in ``terminal=`` pays: ``"keep"`` (default) each of its
        allowed actions pays ``R[x, a]`` once and moves to the sink (its value is the
        best of them); ``"zero"`` its rewards are replaced by 0 (it is worth 0, as a state
        reached by a terminated transition in Gymnasium or a POMDPs.jl terminal state).
        Either way its rows of ``P`` are discarded. ``"zero"`` needs listed states.
    """
    discount = check_discount(discount)
    sense = check_choice("sense", sense, ("max", "min"))
    terminal_reward = _check_terminal_reward(terminal_reward, terminal)
    mats = matrix_list(P, "P")
    n_actions, n = len(mats), mats[0].shape[0]
    if n == 0:
        raise ValidationError("P[0] has no state (shape (0, 0))")
    for a, m in enumerate(mats):
        if m.shape != (n, n):
            raise ValidationError(f"P[{a}] has shape {m.shape}; expected {(n, n)}{_layout_hint(P)}")
    allow = cls._check_allowed(allowed, n, n_actions)
    _, term = _terminal_states(terminal, n)
    nnz = np.stack([np.diff(m.indptr) for m in mats], axis=1)  # (n, A); zeros eliminated
    empty = (nnz == 0) & allow
    empty[term] = False  # a listed state's rows are discarded
    if empty.any():
        x, a = first_index(empty)
        raise ValidationError(
            f"row {x} of P[{a}] is empty (sums to 0, not 1): the pair (state {x}, action "
            f"{a}) is allowed but has no transition ({int(empty.sum())} such pairs): "
            + _no_transition_hint(x, f"pass allowed[{x}, {a}] = False (from_matrices)")
        )
    rew = expected_rewards(R, mats, allow)
    x_idx, a_idx = np.nonzero(allow)
    stacked = sp.vstack(mats, format="csr")
    q = stacked[a_idx * n + x_idx]
    return model_from_pairs(
        cls, q, x_idx, a_idx, rew[x_idx, a_idx], (n, n_actions), discount,
        row_name=lambda k: f"row {int(x_idx[k])} of P[{int(a_idx[k])}]",
        unavailable=lambda k: (
            f"pass allowed[{int(x_idx[k])}, {int(a_idx[k])}] = False (from_matrices)"
        ),
        terminal=terminal, terminal_reward=terminal_reward, sense=sense,
        action_names=action_names,
    )  # fmt: skip


# ---------------------------------------------------------------------- QuantEcon
def _is_discrete_dp(obj: Any) -> bool:
    return all(hasattr(obj, k) for k in ("R", "Q", "beta")) and not isinstance(
        obj, (np.ndarray, list, tuple)
    )


def _quantecon_rewards(R: Any, name: str = "R") -> tuple[np.ndarray, np.ndarray]:
    """Rewards and the availability mask (``-inf`` = not available; NaN, ``+inf`` refused)."""
    rew = as_float_array(name, R, finite=False)
    bad = np.isnan(rew) | (rew == np.inf)
    if bad.any():
        idx = first_index(bad)
        raise ValidationError(
            f"{name}[{', '.join(map(str, idx))}] = {rew[idx]}: rewards must be finite, or "
            "-inf for an action that is not available"
        )
    return rew, rew > -np.inf


def _product_layout(q: np.ndarray, n: int, m: int, layout: Any) -> str:
    """The axis order of a 3-d ``Q`` given to :func:`from_quantecon`.

    Without ``layout=``, QuantEcon's own ``Q[state, action, next]`` whenever the shape
    allows it, as many actions as states included (the savings and cake-eating problems,
    where the actions are next period's grid points: there ``(n, m, n) == (m, n, n)`` and
    QuantEcon's reading is the one a user of ``DiscreteDP`` means); pymdptoolbox's
    ``P[action, state, next]`` only when the shape says so. ``layout="ass"`` reads a square
    ``Q`` the pymdptoolbox way.
    """
    sas, ass = (n, m, n), (m, n, n)
    if layout is not None:
        layout = check_choice("layout", layout, LAYOUTS)
        want = sas if layout == "sas" else ass
        if q.shape != want:
            raise ValidationError(f"Q with layout={layout!r} must have shape {want}; got {q.shape}")
        return layout
    if q.shape == sas:  # QuantEcon's own layout, also when n == m (then sas == ass)
        return "sas"
    if q.shape == ass:
        return "ass"
    raise ValidationError(
        f"Q must have shape {sas} (Q[state, action, next], R of shape {(n, m)}) or {ass} "
        f"(P[action, state, next]); got {q.shape}"
    )


def _quantecon_product(
    cls: type[FiniteMDP],
    R: Any,
    Q: Any,
    beta: float,
    layout: Any,
    terminal: Any,
    terminal_reward: str,
    action_names: Any,
) -> FiniteMDP:
    rew, avail = _quantecon_rewards(R)
    if rew.ndim != 2:
        raise ValidationError(f"R must have shape (n, m) (or (L,) with s_indices); got {rew.shape}")
    n, m = rew.shape
    if sp.issparse(Q):
        raise ValidationError(
            "a sparse Q needs the state-action-pair form: pass s_indices and a_indices"
        )
    q = as_float_array("Q", Q, finite=False)
    if q.ndim != 3:
        raise ValidationError(f"Q must be 3-d (n, m, n) with R of shape {(n, m)}; got {q.shape}")
    order = _product_layout(q, n, m, layout)
    if order == "ass":
        q = q.transpose(1, 0, 2)
    x_idx, a_idx = np.nonzero(avail)
    lab = "Q" if order == "sas" else "P"
    return model_from_pairs(
        cls, sp.csr_matrix(q[x_idx, a_idx]), x_idx, a_idx, rew[x_idx, a_idx], (n, m), beta,
        row_name=lambda k: (
            f"{lab}[{x_idx[k]}, {a_idx[k]}, :]" if order == "sas"
            else f"{lab}[{a_idx[k]}, {x_idx[k]}, :]"
        ),
        unavailable=lambda k: f"set R[{x_idx[k]}, {a_idx[k]}] = -inf (QuantEcon's mark)",
        terminal=terminal, terminal_reward=terminal_reward, action_names=action_names,
    )  # fmt: skip


def _pair_indices(s_indices: Any, a_indices: Any, n_pairs: int, n: int) -> tuple[Any, Any]:
    out = []
    for name, idx in (("s_indices", s_indices), ("a_indices", a_indices)):
        arr = check_array(name, idx, integer=True)
        if arr.shape != (n_pairs,):
            raise ValidationError(
                f"{name} must have shape ({n_pairs},) (one per row of Q); got {arr.shape}"
            )
        out.append(arr)
    s, a = out
    for name, arr, hi in (("s_indices", s, n), ("a_indices", a, None)):
        bad = (arr < 0) | (arr >= hi) if hi is not None else arr < 0
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            rng = f"[0, {hi})" if hi is not None else ">= 0"
            raise ValidationError(f"{name}[{k}] = {int(arr[k])} is out of range {rng}")
    s, a = s.astype(np.int64), a.astype(np.int64)
    m = int(a.max()) + 1 if a.size else 1
    _check_size((n, m))
    key = s * m + a
    order = np.argsort(key, kind="stable")
    dup = np.flatnonzero(key[order][1:] == key[order][:-1])
    if dup.size:
        i, j = sorted((int(order[dup[0]]), int(order[dup[0] + 1])))
        raise ValidationError(
            f"the pair (state {int(s[i])}, action {int(a[i])}) is listed twice: "
            f"s_indices/a_indices[{i}] and [{j}]"
        )
    return s, a


def _quantecon_sa(
    cls: type[FiniteMDP],
    R: Any,
    Q: Any,
    beta: float,
    s_indices: Any,
    a_indices: Any,
    terminal: Any,
    terminal_reward: str,
    action_names: Any,
) -> FiniteMDP:
    if sp.issparse(Q):
        if Q.dtype.kind not in "iuf":
            raise ValidationError(f"Q must hold real numbers; got {Q.dtype}")
        q = sp.csr_matrix(Q, dtype=np.float64)
    else:
        qd = as_float_array("Q", Q, finite=False)
        if qd.ndim != 2:
            raise ValidationError(f"Q must be 2-d (L, n) with s_indices; got {qd.shape}")
        q = sp.csr_matrix(qd)
    n_pairs, n = q.shape
    if n_pairs == 0 or n == 0:
        raise ValidationError(f"Q has no pair or no state (shape {q.shape})")
    rew, avail = _quantecon_rewards(R)
    if rew.shape != (n_pairs,):
        raise ValidationError(f"R must have shape ({n_pairs},) (one per row of Q); got {rew.shape}")
    s, a = _pair_indices(s_indices, a_indices, n_pairs, n)
    m = int(a.max()) + 1
    if sp.issparse(Q):  # before the CSR conversion sums duplicate entries
        _check_raw_entries(Q, lambda k: f"Q[{k}, :] (state {s[k]}, action {a[k]})")
    keep = np.flatnonzero(avail)
    return model_from_pairs(
        cls, q[keep], s[keep], a[keep], rew[keep], (n, m), beta,
        row_name=lambda k: f"Q[{keep[k]}, :] (state {s[keep[k]]}, action {a[keep[k]]})",
        unavailable=lambda k: (
            f"set R[{keep[k]}] = -inf (QuantEcon's mark) or leave the pair out of "
            "s_indices/a_indices"
        ),
        terminal=terminal, terminal_reward=terminal_reward, action_names=action_names,
    )  # fmt: skip


# intended parallel: the signature of FiniteMDP.from_quantecon, its thin wrapper
def from_quantecon(
    cls: type[FiniteMDP],
    R: Any,
    Q: Any = None,
    beta: Any = None,
    s_indices: Any = None,
    a_indices: Any = None,
    *,
    layout: str | None = None,
    terminal: Any = None,
    terminal_reward: str = "keep",
    action_names: Any = None,
) -> FiniteMDP:
    """The converter of :meth:`FiniteMDP.from_quantecon`.

    A pair is available when its reward is not ``-inf`` (product form) or when it is
    listed in ``s_indices``/``a_indices`` with a reward other than ``-inf``. An available
    pair whose row of ``Q`` is all zeros is refused, naming the pair, unless its state is
    listed in ``terminal=`` (QuantEcon itself would read it as a pair that leaves the
    model: mark a pair that is not available with ``-inf``).

    ``terminal_reward`` : {"keep", "zero"}
        What a state listed in ``terminal=`` pays: ``"keep"`` (default) each of its
        available actions pays its reward once and moves to the sink; ``"zero"`` its
        rewards are replaced by 0 (it is worth 0, Gymnasium's and POMDPs.jl's
        convention). Either way its rows of ``Q`` are discarded. ``"zero"`` needs listed
        states.
    """
    terminal_reward = _check_terminal_reward(terminal_reward, terminal)
    if Q is None and beta is None and _is_discrete_dp(R):
        ddp = R
        sa = getattr(ddp, "_sa_pair", getattr(ddp, "s_indices", None) is not None)
        beta = check_discount(ddp.beta)
        if sa:
            return _quantecon_sa(
                cls, ddp.R, ddp.Q, beta, ddp.s_indices, ddp.a_indices, terminal,
                terminal_reward, action_names,
            )  # fmt: skip
        return _quantecon_product(
            cls, ddp.R, ddp.Q, beta, "sas", terminal, terminal_reward, action_names
        )
    if Q is None or beta is None:
        raise ValidationError(
            "from_quantecon takes a DiscreteDP, or R, Q and beta (with s_indices and "
            "a_indices for the state-action-pair form)"
        )
    beta = check_discount(beta)
    if (s_indices is None) != (a_indices is None):
        raise ValidationError("s_indices and a_indices go together: pass both or neither")
    if s_indices is None:
        return _quantecon_product(cls, R, Q, beta, layout, terminal, terminal_reward, action_names)
    if layout is not None:
        raise ValidationError("layout= applies to the product form (3-d Q) only")
    return _quantecon_sa(
        cls, R, Q, beta, s_indices, a_indices, terminal, terminal_reward, action_names
    )


def to_quantecon(mdp: FiniteMDP, form: str = "sa") -> Any:
    """The converter of :meth:`FiniteMDP.to_quantecon`."""
    check_choice("form", form, ("sa", "product"))
    try:
        from quantecon.markov import DiscreteDP
    except ImportError as exc:  # an optional dependency
        raise ImportError(
            "FiniteMDP.to_quantecon needs QuantEcon: pip install 'lpbounds[interop]'"
        ) from exc
    n, m, n_out = mdp.n_states, mdp.n_actions, mdp.n_outcomes
    x_idx, a_idx = np.nonzero(mdp.allowed)
    probs = mdp.probabilities_full()
    rows = np.repeat(np.arange(x_idx.size), n_out)
    q = sp.csr_matrix(
        (np.asarray(probs[x_idx, a_idx]).ravel(), (rows, mdp.successors[x_idx, a_idx].ravel())),
        shape=(x_idx.size, n),
    )
    q.sum_duplicates()
    q.eliminate_zeros()
    r = np.array(mdp.rewards[x_idx, a_idx], dtype=np.float64)
    if form == "sa":
        return DiscreteDP(r, q, mdp.discount, x_idx, a_idx)
    rew = np.full((n, m), -np.inf)
    rew[x_idx, a_idx] = r
    dense = np.zeros((n, m, n))
    dense[np.arange(n)[:, None], np.arange(m)[None, :], np.arange(n)[:, None]] = 1.0
    dense[x_idx, a_idx] = q.toarray()
    return DiscreteDP(rew, dense, mdp.discount)


# ---------------------------------------------------------------------- MDPSolver
def _index_column(
    rows: np.ndarray,
    c: int,
    what: str,
    hi: int | None,
    name: str = "rows",
    entry: Callable[[int], str] | None = None,
) -> np.ndarray:
    """Column ``c`` of ``rows`` as indices in ``[0, hi)``; a bad one is named
    ``name[i, c]``, or ``entry(i)`` (the caller's own name of row ``i``)."""
    col = rows[:, c]

    def where(i: int) -> str:
        return f"{name}[{i}, {c}]" if entry is None else f"{entry(i)}: the {what}"

    frac = ~np.isfinite(col) | (col != np.round(col)) if col.dtype.kind == "f" else None
    if frac is not None and frac.any():
        i = int(np.flatnonzero(frac)[0])
        raise ValidationError(f"{where(i)} = {col[i]} is not a whole number (the {what})")
    col = col.astype(np.int64)
    bad = (col < 0) | (col >= hi) if hi is not None else col < 0
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        rng = f"[0, {hi})" if hi is not None else ">= 0"
        raise ValidationError(f"{where(i)} = {int(col[i])}: the {what} is out of range {rng}")
    return col


class _Given:
    """Pairs given a reward but no row: their indices, rewards and names (for messages)."""

    def __init__(
        self,
        s: np.ndarray,
        a: np.ndarray,
        r: np.ndarray,
        name: Callable[[int], str],
        unavailable: Callable[[int], str],
    ) -> None:
        self.s, self.a, self.r, self.name, self.unavailable = s, a, r, name, unavailable


_NONE_GIVEN = _Given(
    np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0), str, str
)


def _pair_rewards(
    pair_s: np.ndarray,
    pair_a: np.ndarray,
    shape: tuple[int, int],
    rewards: Any,
    reward_rows: Any,
) -> tuple[np.ndarray, _Given]:
    """Rewards of the pairs with rows, and the pairs given a reward without any row.

    From an (n, A) matrix (an entry of a pair without rows other than 0, -inf or NaN
    gives it a reward) or from [s, a, r] rows (every entry gives its pair a reward).
    """
    if (rewards is None) == (reward_rows is None):
        raise ValidationError(
            "rows with 4 columns [s, a, s', p] need exactly one of rewards= (an (n, A) "
            "array) or reward_rows= ([s, a, r] rows); 5 columns [s, a, s', p, r] need neither"
        )
    n, m = shape
    if rewards is not None:
        arr = as_float_array("rewards", rewards, finite=False)
        if arr.shape != (n, m):
            raise ValidationError(
                f"rewards must have shape {(n, m)} (states, actions); got {arr.shape}"
            )
        out = arr[pair_s, pair_a]
        bad = ~np.isfinite(out)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ValidationError(
                f"rewards[{pair_s[k]}, {pair_a[k]}] = {out[k]} is not finite on a pair with "
                "transitions"
            )
        given = (arr != 0.0) & ~np.isnan(arr) & (arr != -np.inf)
        given[pair_s, pair_a] = False
        gs, ga = (x.astype(np.int64) for x in np.nonzero(given))
        gr = arr[gs, ga]
        inf = np.flatnonzero(gr == np.inf)
        if inf.size:
            x, u = int(gs[inf[0]]), int(ga[inf[0]])
            raise ValidationError(
                f"rewards[{x}, {u}] = inf is not finite (the pair (state {x}, action {u}) has "
                "no row; it is not available when its entry is 0, -inf or NaN)"
            )
        return out, _Given(
            gs, ga, gr,
            lambda j: f"rewards[{gs[j]}, {ga[j]}] = {float(gr[j]):.12g}",
            lambda j: f"set rewards[{gs[j]}, {ga[j]}] = -inf (or 0)",
        )  # fmt: skip
    rr = check_array("reward_rows", reward_rows)
    if rr.ndim != 2 or rr.shape[1] != 3:
        raise ValidationError(f"reward_rows must have shape (K, 3) [s, a, r]; got {rr.shape}")
    rs = _index_column(rr, 0, "state", n, "reward_rows")
    ra = _index_column(rr, 1, "action", m, "reward_rows")
    rkey = rs * m + ra
    order = np.argsort(rkey, kind="stable")
    twice = np.flatnonzero(rkey[order][1:] == rkey[order][:-1])
    if twice.size:
        i = int(order[twice[0] + 1])
        raise ValidationError(f"reward_rows[{i}]: the pair ({rs[i]}, {ra[i]}) has two rewards")
    key = pair_s * m + pair_a  # sorted (np.unique in from_transitions)
    pos = np.minimum(np.searchsorted(key, rkey), key.size - 1)
    absent = key[pos] != rkey
    out = np.full(len(pair_s), np.nan)
    out[pos[~absent]] = rr[~absent, 2]
    miss = np.isnan(out)
    if miss.any():
        k = int(np.flatnonzero(miss)[0])
        raise ValidationError(
            f"the pair (state {pair_s[k]}, action {pair_a[k]}) has transitions but no reward "
            f"in reward_rows ({int(miss.sum())} such pairs)"
        )
    idx = np.flatnonzero(absent)
    return out, _Given(
        rs[idx], ra[idx], np.asarray(rr[idx, 2], dtype=np.float64),
        lambda j: f"reward_rows[{idx[j]}]",
        lambda j: f"leave the pair out of reward_rows (drop reward_rows[{idx[j]}])",
    )  # fmt: skip


# intended parallel: the signature of FiniteMDP.from_transitions, its thin wrapper
def from_transitions(
    cls: type[FiniteMDP],
    rows: Any,
    discount: Any,
    rewards: Any = None,
    *,
    reward_rows: Any = None,
    n_states: Any = None,
    n_actions: Any = None,
    terminal: Any = None,
    terminal_reward: str = "keep",
    sense: str = "max",
    action_names: Any = None,
    entry_name: Callable[[int], str] | None = None,
) -> FiniteMDP:
    """The converter of :meth:`FiniteMDP.from_transitions`.

    ``entry_name`` : callable, optional
        ``entry_name(i)``: how the caller's own input names ``rows[i]`` in messages (a
        converter built on this one: Gymnasium's ``P[s][a][k]``); default ``rows[i]``.

    Which pairs are available:

    * a pair with rows is available (its reward must be finite);
    * a pair without rows is not available when nothing gives it a reward: its entry of
      ``rewards`` is 0, ``-inf`` or NaN, it has no entry in ``reward_rows``, or the
      rewards are the fifth column of ``rows``;
    * a pair without rows that is given a reward (any other entry of ``rewards``, an
      entry of ``reward_rows``) is available only when its state is listed in
      ``terminal=`` (it pays its reward and the process ends); otherwise it is refused
      naming the pair: such a pair is what dropping Gymnasium's terminated transitions
      leaves (Taxi's drop-off), and dropping it with its reward would change ``V*``.
      Rows whose probabilities are all 0 count as no row.

    ``terminal_reward`` : {"keep", "zero"}
        What a state listed in ``terminal=`` pays: ``"keep"`` (default) each of its
        available pairs pays its reward once and moves to the sink (the state's value is
        the best of them); ``"zero"`` its rewards are replaced by 0, so the state is worth
        0 (Gymnasium's convention: keep the terminated transitions ``[s, a, s', p]``, give
        ``s, a`` the transition's reward and list every such ``s'`` in ``terminal=``;
        POMDPs.jl's terminal states). Either way its rows are discarded. ``"zero"`` needs
        listed states.
    """
    discount = check_discount(discount)
    sense = check_choice("sense", sense, ("max", "min"))
    terminal_reward = _check_terminal_reward(terminal_reward, terminal)
    tr = check_array("rows", rows, nonempty=True)
    if tr.ndim != 2 or tr.shape[1] not in (4, 5):
        raise ValidationError(
            f"rows must have shape (K, 4) [s, a, s', p] or (K, 5) [s, a, s', p, r]; got {tr.shape}"
        )
    tr = np.asarray(tr, dtype=np.float64)
    hi_s = None if n_states is None else check_int("n_states", n_states, lo=1)
    hi_a = None if n_actions is None else check_int("n_actions", n_actions, lo=1)
    s = _index_column(tr, 0, "state", hi_s, entry=entry_name)
    a = _index_column(tr, 1, "action", hi_a, entry=entry_name)
    nxt = _index_column(tr, 2, "next state", hi_s, entry=entry_name)
    row = (lambda i: f"rows[{i}]") if entry_name is None else entry_name
    n = hi_s if hi_s is not None else int(max(s.max(), nxt.max())) + 1
    m = hi_a if hi_a is not None else int(a.max()) + 1
    _check_size((n, m))
    key, first_row, inv = np.unique(s * m + a, return_index=True, return_inverse=True)
    pair_s, pair_a = key // m, key % m
    p = tr[:, 3]
    neg = p < -PROBABILITY_NEGATIVE_ATOL
    if neg.any():
        i = int(np.flatnonzero(neg)[0])
        where = f"rows[{i}, 3]" if entry_name is None else f"{row(i)}: the probability"
        raise ValidationError(f"{where} = {p[i]}: a probability is negative")
    q = sp.csr_matrix((p, (inv, nxt)), shape=(key.size, n))  # repeated next states add up
    if tr.shape[1] == 5:
        if rewards is not None or reward_rows is not None:
            raise ValidationError("rows with a reward column take no rewards= or reward_rows=")
        pr = p * tr[:, 4]
        bad = ~np.isfinite(pr)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValidationError(
                f"{row(i)}: probability {p[i]} times reward {tr[i, 4]} is not finite"
            )
        r = np.bincount(inv, weights=pr, minlength=key.size)
        given, drop = _NONE_GIVEN, ""
    else:
        r, given = _pair_rewards(pair_s, pair_a, (n, m), rewards, reward_rows)
        drop = " and its reward"
    k0 = key.size
    if given.s.size:  # pairs given a reward but no row: empty rows (refused unless terminal)
        pair_s, pair_a = np.concatenate([pair_s, given.s]), np.concatenate([pair_a, given.a])
        r = np.concatenate([r, given.r])
        q = sp.vstack([q, sp.csr_matrix((given.s.size, n))], format="csr")

    def row_name(k: int) -> str:
        if k >= k0:
            return given.name(k - k0)
        return (
            f"the rows of pair (state {pair_s[k]}, action {pair_a[k]}) "
            f"(first: {row(int(first_row[k]))})"
        )

    return model_from_pairs(
        cls, q, pair_s, pair_a, r, (n, m), discount,
        row_name=row_name,
        unavailable=lambda k: given.unavailable(k - k0) if k >= k0 else f"drop its rows{drop}",
        terminal=terminal, terminal_reward=terminal_reward, sense=sense,
        action_names=action_names,
    )  # fmt: skip
