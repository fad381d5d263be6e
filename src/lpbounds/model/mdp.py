"""Finite discounted MDPs in the paper's form ``x' = f(x, u, Y_l)`` (Section 2, eq. 1-2).

A :class:`FiniteMDP` stores, for every state ``x`` and action ``u``, the ``L`` outcomes
``f(x, u, Y_l)`` (``successors[x, u, l]``) with their probabilities ``p_l``
(``probabilities[l]``, or ``probabilities[x, u, l]`` when they depend on the pair), the
one-step reward ``R_u(x)`` (``rewards[x, u]``), the discount ``lambda`` and a mask of the
allowed actions ``U_x`` (``allowed[x, u]``). Several outcomes may lead to the same state:
the transition probability ``P_u(x, y)`` is the sum of the ``p_l`` with
``f(x, u, Y_l) = y`` (eq. 2).

All input is validated here, at the boundary (with the shared checks of
:mod:`lpbounds.validation`), and a bad entry raises
:class:`~lpbounds.errors.ValidationError` naming it. Arrays are stored read-only.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ValidationError
from ..stochastic import check_rows
from ..validation import (
    as_array,
    as_float_array,
    check_array,
    check_bool,
    check_choice,
    check_discount,
    check_indices,
    check_real,
    check_value_scale,
    first_index,
)

if TYPE_CHECKING:  # scipy.sparse is imported where a matrix is built (0.1 s at start-up)
    import scipy.sparse as sp

__all__ = ["FiniteMDP", "index_dtype"]


def index_dtype(n: int) -> type[np.signedinteger[Any]]:
    """Smallest signed integer type that indexes ``n`` items (int32 or int64)."""
    return np.int32 if n < 2**31 - 1 else np.int64


def _check_successors(succ: np.ndarray, allow: np.ndarray, n: int) -> tuple[int, int, int]:
    """Out-of-range successors: (count on allowed pairs, first flat index, count elsewhere).

    Compiled (C, one pass, no temporaries: full-size boolean masks cost GBs at 33 M
    states; :func:`lpbounds._kernels.dispatch.row_sweeps`).
    """
    from .._kernels import dispatch as _backend

    bad, first, bad_disallowed = _backend.row_sweeps().check_successors(succ, allow, n)
    return int(bad), int(first), int(bad_disallowed)


def _shares(stored: np.ndarray, given: Any) -> bool:
    """True when ``stored`` may be the caller's memory (a view, a memmap, the array itself)."""
    return isinstance(given, np.ndarray) and np.may_share_memory(stored, given)


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


class FiniteMDP:
    r"""A finite discounted Markov decision process (maximisation of discounted reward).

    Bellman's equation (paper eq. 3) reads

    .. math:: V^*(x) = \max_{u \in U_x} \Big\{ R_u(x) + \lambda \sum_{l} p_l\,
              V^*(f(x, u, Y_l)) \Big\}.

    Parameters
    ----------
    successors : array_like of int, shape (n, A, L)
        ``successors[x, u, l] = f(x, u, Y_l)``, a state index in ``0..n-1``.
    probabilities : array_like of float, shape (L,) or (n, A, L)
        ``p_l``, shared by every pair, or one distribution per (state, action).
        Each allowed pair's probabilities must be non-negative and sum to one within
        :data:`~lpbounds.tolerances.PROBABILITY_SUM_ATOL` (the rule of
        :func:`lpbounds.stochastic.check_rows`, shared with ``BellmanRows``). They are
        stored as given, not renormalised: every error bound and certificate holds for
        the rows as stored (:class:`lpbounds.stochastic.RowSums`).
    rewards : array_like of float, shape (n, A)
        ``R_u(x)``; must be finite on allowed pairs (other entries are ignored).
    discount : float
        ``lambda`` in ``[0, 1)``.
    allowed : array_like of bool, shape (n, A), optional
        ``allowed[x, u]`` is True when ``u`` is in ``U_x``; every state needs one.
        Default: every action is allowed everywhere.
    action_names : sequence of str, optional
        Labels of the ``A`` actions, used in reports (default ``"0", "1", ...``).
    copy : bool
        Copy the arrays (default). ``copy=False`` hands them over: arrays already of
        the stored dtype are kept without a copy (and made read-only), which model
        builders use at tens of millions of states; do not modify them afterwards.
    sense : {"max", "min"}
        ``"min"``: ``rewards`` are costs to minimise. They are stored negated
        (``self.rewards = -costs``), so the model is the reward-maximising problem every
        method of lpbounds solves: its values are ``-`` the costs-to-go, and an upper
        bound on them is minus a *lower* bound on the costs. :meth:`user_values`,
        :meth:`user_bounds` and :meth:`user_policy` translate results back; results
        themselves (``DPResult``, ``LPResult``, ...) stay in the reward sense. The
        negated rewards are a new array even with ``copy=False``.
    sink : bool
        True when the last state is an absorbing end state added by a converter
        (``terminal=`` of :meth:`from_matrices` and the other ``from_*`` constructors):
        every allowed action of it must stay there with reward 0, so its value is 0
        under every policy. The ``user_*`` helpers drop it.

    Raises
    ------
    ValidationError
        Naming the first offending entry (shape, dtype, index, probability, reward,
        discount), or an effective discount ``discount * max row sum`` that is not below
        1 (no discounted value exists). Booleans, strings and complex numbers are refused
        before any cast; successor indices are range-checked in the dtype given, before
        the cast to the index dtype. A model whose value scale ``max|R| / (1 - discount)`` exceeds
        :data:`~lpbounds.validation.MAX_VALUE_SCALE` (1e300) is refused: its values
        would overflow float64 in DP and in the LPs' certificates.

    Notes
    -----
    Successors of disallowed pairs are never read; they are replaced by the state
    itself so that every stored index is in range.
    """

    def __init__(
        self,
        successors: Any,
        probabilities: Any,
        rewards: Any,
        discount: float,
        allowed: Any = None,
        action_names: Sequence[str] | None = None,
        *,
        copy: bool = True,
        sense: str = "max",
        sink: bool = False,
    ) -> None:
        copy = check_bool("copy", copy)
        self.sense = check_choice("sense", sense, ("max", "min"))
        sink = check_bool("sink", sink)
        succ = check_array("successors", successors, integer=True)
        if succ.ndim != 3:
            raise ValidationError(
                f"successors must have shape (n_states, n_actions, n_outcomes); got {succ.shape}"
            )
        n, n_actions, n_out = succ.shape
        if n == 0 or n_actions == 0 or n_out == 0:
            raise ValidationError(f"successors has an empty dimension: shape {succ.shape}")
        self.discount = self._check_discount(discount)
        allow = self._check_allowed(allowed, n, n_actions)
        succ = self._store_successors(succ, successors, allow, copy)
        rew = self._check_rewards(rewards, allow, copy)
        if self.sense == "min":  # costs: the reward-maximising problem of -costs
            rew = np.negative(rew) + 0.0
        check_value_scale(max(float(rew.max()), -float(rew.min())), self.discount)

        probs = self._check_probabilities(probabilities, allow, succ.shape, self.discount)
        self.probabilities = _readonly(probs)
        self.successors = _readonly(succ)
        self.rewards = _readonly(rew)
        self.allowed = _readonly(allow.copy())
        self.action_names = self._check_action_names(action_names, n_actions)
        self.sink = self._check_sink(sink)

    # ------------------------------------------------------------------ validation
    @staticmethod
    def _check_discount(discount: float) -> float:
        return check_discount(discount)

    @staticmethod
    def _check_allowed(allowed: Any, n: int, n_actions: int) -> np.ndarray:
        if allowed is None:
            return np.ones((n, n_actions), dtype=bool)
        allow = as_array("allowed", allowed)
        if allow.dtype != bool:
            try:
                allow = check_array("allowed", allow, integer=True)
            except ValidationError as exc:
                raise ValidationError(f"{exc} (allowed must be boolean, or 0/1)") from None
        if allow.shape != (n, n_actions):
            raise ValidationError(
                f"allowed must have shape {(n, n_actions)} (n_states, n_actions); got {allow.shape}"
            )
        if allow.dtype != bool:
            bad = (allow != 0) & (allow != 1)
            if bad.any():
                x, u = first_index(bad)
                raise ValidationError(
                    f"allowed must be boolean (or 0/1); allowed[{x}, {u}] = {allow[x, u]}"
                )
            allow = allow.astype(bool)
        no_action = ~allow.any(axis=1)
        if no_action.any():
            x = int(np.flatnonzero(no_action)[0])
            raise ValidationError(
                f"state {x} has no allowed action ({int(no_action.sum())} such states)"
            )
        return allow

    @staticmethod
    def _store_successors(
        succ: np.ndarray, given: Any, allow: np.ndarray, copy: bool
    ) -> np.ndarray:
        """Range-check ``succ`` in its own dtype, then store it as the index dtype.

        The check runs before the cast: an int64 ``2**32 + 1`` must be refused, not
        wrapped to a valid int32 index. An array already of the index dtype is checked
        by one compiled pass without temporaries (and kept, with ``copy=False``).
        """
        n = succ.shape[0]
        idt = index_dtype(n)
        if succ.dtype == idt:
            n_bad, first, n_bad_disallowed = _check_successors(succ, allow, n)
            if n_bad:
                x, u, ll = np.unravel_index(first, succ.shape)
                raise ValidationError(
                    f"successors[{x}, {u}, {ll}] = {int(succ[x, u, ll])} is out of range "
                    f"[0, {n}) ({n_bad} such entries)"
                )
            owned = not copy and succ.flags.c_contiguous
            out = succ if owned else np.ascontiguousarray(succ)
            if copy and _shares(out, given):
                out = out.copy()
        else:  # a cast is needed anyway: check in the given dtype, then cast
            _, n_bad_disallowed = check_indices("successors", succ, n, where=allow[:, :, None])
            with np.errstate(invalid="ignore"):  # disallowed entries may not fit: replaced
                out = np.ascontiguousarray(succ, dtype=idt)
        if n_bad_disallowed:  # never read, but keep every stored index in range
            if not out.flags.writeable or (copy and _shares(out, given)):
                out = out.copy()
            rows, cols = np.nonzero(~allow)
            out[rows, cols, :] = rows[:, None].astype(idt)
        return out

    def _check_sink(self, sink: bool) -> bool:
        """A sink must be absorbing with reward 0 (so its value is 0 and can be dropped)."""
        if not sink:
            return False
        x = self.n_states - 1
        probs = self.probabilities_full()[x]
        leaves = (self.successors[x] != x) & (probs > 0) & self.allowed[x][:, None]
        if leaves.any():
            u, ll = first_index(leaves)
            raise ValidationError(
                f"sink=True: the last state {x} must be absorbing; successors[{x}, {u}, {ll}]"
                f" = {int(self.successors[x, u, ll])} with probability {probs[u, ll]}"
            )
        paid = (self.rewards[x] != 0.0) & self.allowed[x]
        if paid.any():
            u = int(np.flatnonzero(paid)[0])
            raise ValidationError(
                f"sink=True: the last state {x} must pay reward 0; rewards[{x}, {u}] = "
                f"{self.rewards[x, u]}"
            )
        return True

    @staticmethod
    def _check_rewards(rewards: Any, allow: np.ndarray, copy: bool) -> np.ndarray:
        rew = as_float_array("rewards", rewards, finite=False)
        if rew.shape != allow.shape:
            raise ValidationError(
                f"rewards must have shape {allow.shape} (n_states, n_actions); got {rew.shape}"
            )
        nonfinite = ~np.isfinite(rew) & allow
        if nonfinite.any():
            x, u = first_index(nonfinite)
            hint = (
                "; an action that is not available belongs in allowed=, not a -inf reward"
                if rew[x, u] == -np.inf
                else ""
            )
            raise ValidationError(
                f"rewards[{x}, {u}] = {rew[x, u]} is not finite on an allowed pair "
                f"({int(nonfinite.sum())} such entries){hint}"
            )
        if not (rew[~allow] == 0.0).all():
            rew = np.where(allow, rew, 0.0)  # disallowed rewards are stored as 0
        elif copy and _shares(rew, rewards):
            rew = rew.copy()
        return rew

    @staticmethod
    def _check_action_names(action_names: Any, n_actions: int) -> tuple[str, ...]:
        if action_names is None:
            return tuple(str(u) for u in range(n_actions))
        if isinstance(action_names, (str, bytes)) or not isinstance(action_names, Sequence):
            raise ValidationError(
                f"action_names must be a sequence of {n_actions} strings; got {action_names!r}"
            )
        if len(action_names) != n_actions:
            raise ValidationError(
                f"action_names has {len(action_names)} names for {n_actions} actions"
            )
        for u, name in enumerate(action_names):
            if not isinstance(name, str):
                raise ValidationError(f"action_names[{u}] = {name!r} is not a string")
        return tuple(action_names)

    @staticmethod
    def _check_probabilities(
        probabilities: Any, allow: np.ndarray, shape: tuple[int, int, int], discount: float
    ) -> np.ndarray:
        """The shared row-sum rule (:func:`lpbounds.stochastic.check_rows`) on the allowed
        pairs, and the effective discount ``lambda * max row sum`` below 1."""
        p = as_float_array("probabilities", probabilities, finite=False)
        _n, _n_actions, n_out = shape
        if p.shape == (n_out,):
            if not np.all(np.isfinite(p)):
                raise ValidationError(f"probabilities must be finite; got {p}")
            check_rows("probabilities", p, discount)
            return np.clip(p, 0.0, None)
        if p.shape != shape:
            raise ValidationError(
                f"probabilities must have shape ({n_out},) or {shape}; got {p.shape}"
            )
        nonfinite = ~np.isfinite(p) & allow[:, :, None]
        if nonfinite.any():
            x, u, ll = first_index(nonfinite)
            raise ValidationError(f"probabilities[{x}, {u}, {ll}] = {p[x, u, ll]} is not finite")
        check_rows("probabilities", p, discount, where=allow)
        p = np.clip(p, 0.0, None)
        p[~allow] = 0.0
        p[~allow, 0] = 1.0
        return p

    # ------------------------------------------------------------------ properties
    @property
    def n_states(self) -> int:
        """Number of states ``|S|``."""
        return int(self.successors.shape[0])

    @property
    def n_actions(self) -> int:
        """Number of actions ``A`` (the union of every ``U_x``)."""
        return int(self.successors.shape[1])

    @property
    def n_outcomes(self) -> int:
        """Number of outcomes ``L`` (``m + 1`` in the paper) of each (state, action)."""
        return int(self.successors.shape[2])

    @property
    def shared_probabilities(self) -> bool:
        """True when one distribution ``p_l`` serves every (state, action)."""
        return self.probabilities.ndim == 1

    @property
    def n_pairs(self) -> int:
        """Number of allowed (state, action) pairs, i.e. of Bellman inequalities (eq. 5)."""
        return int(self.allowed.sum())

    @property
    def reward_absmax(self) -> float:
        """``max |R_u(x)|`` over the allowed pairs."""
        return float(np.abs(self.rewards[self.allowed]).max())

    def probabilities_full(self) -> np.ndarray:
        """Probabilities as an (n, A, L) array (a read-only broadcast view when shared)."""
        if self.shared_probabilities:
            return np.broadcast_to(self.probabilities, self.successors.shape)
        return self.probabilities

    @property
    def n_user_states(self) -> int:
        """Number of the user's states: ``n_states`` without the added sink, if any."""
        return self.n_states - int(self.sink)

    def _user_entries(self, name: str, x: Any) -> Any:
        """A state vector without the sink (a scalar is returned as a float)."""
        arr = as_float_array(name, x, finite=False)
        if arr.ndim == 0:
            return float(arr)
        if arr.shape != (self.n_states,):
            raise ValidationError(
                f"{name}: expected a scalar or a vector of length {self.n_states}; "
                f"got shape {arr.shape}"
            )
        return arr[: self.n_user_states].copy()

    def user_values(self, values: Any) -> Any:
        """Values in the user's terms: without the sink, and costs-to-go when ``sense="min"``.

        Parameters
        ----------
        values : array_like (n_states,) or float
            Values of this model (e.g. ``solve_exact(mdp).values``, an LP's ``values``,
            or a scalar such as ``c'V``).

        Returns
        -------
        ndarray (n_user_states,) or float
        """
        v = self._user_entries("values", values)
        return -v if self.sense == "min" else v

    def user_bounds(self, lower: Any, upper: Any) -> tuple[Any, Any]:
        """A bracket ``lower <= V <= upper`` of this model, in the user's terms.

        With ``sense="min"`` the bracket on the costs-to-go is ``(-upper, -lower)``:
        an upper bound on the negated-reward values is a lower bound on the costs.
        Vectors lose the sink entry; scalars (``c'V`` brackets) are translated alone.

        Returns
        -------
        (lower, upper) : tuple of ndarray (n_user_states,) or of floats
        """
        lo = self._user_entries("lower", lower)
        hi = self._user_entries("upper", upper)
        return (-hi, -lo) if self.sense == "min" else (lo, hi)

    def user_policy(self, policy: Any) -> np.ndarray:
        """A policy (one action per state) without the sink's entry."""
        pol = check_array("policy", policy, integer=True)
        if pol.shape != (self.n_states,):
            raise ValidationError(
                f"policy: expected a vector of length {self.n_states}; got shape {pol.shape}"
            )
        return np.array(pol[: self.n_user_states], dtype=np.int64)

    def __repr__(self) -> str:
        extra = "".join(
            f", {k}={v!r}" for k, v in (("sense", self.sense), ("sink", self.sink))
            if v != {"sense": "max", "sink": False}[k]
        )  # fmt: skip
        return (
            f"FiniteMDP(n_states={self.n_states}, n_actions={self.n_actions}, "
            f"n_outcomes={self.n_outcomes}, discount={self.discount}, "
            f"allowed_pairs={self.n_pairs}{extra})"
        )

    # ------------------------------------------------------------------ conversions
    # intended parallel: each from_* repeats its interop converter's signature (documented here,
    # scipy.sparse imported only when one runs); the arguments are handled in interop alone
    @classmethod
    def from_matrices(
        cls,
        P: Any,
        R: Any,
        discount: float,
        *,
        allowed: Any = None,
        terminal: Any = None,
        terminal_reward: str = "keep",
        sense: str = "max",
        action_names: Sequence[str] | None = None,
    ) -> FiniteMDP:
        """Build an MDP from transition matrices in pymdptoolbox's convention.

        Parameters
        ----------
        P : (A, n, n) array, or A (n, n) matrices, dense or scipy.sparse
            ``P[a][x, y]`` is the probability of moving from ``x`` to ``y`` under ``a``.
            The A matrices may come as a list, a tuple, a dict with keys ``0..A-1`` or a
            1-d object array (``np.array([csr0, csr1])``). Each row of an allowed pair
            must sum to one (see ``terminal``).
        R : array (n,), (n, A), (A, n, n), or A (n, n) matrices (dense or sparse)
            State rewards, expected rewards ``R[x, a]``, or transition rewards
            ``R[a][x, y]`` (whose expectation ``sum_y P[a][x, y] R[a][x, y]`` is used).
            A rectangular nested list is read by its shape like an array (a list of
            shape (n, A) is ``R[x, a]``); only a list holding sparse matrices, or
            matrices of their own, is A per-transition matrices.
        discount : float
            The discount in ``[0, 1)``.
        allowed : array_like of bool (n, A), optional
            Actions available in each state; the rows of ``P`` and entries of ``R`` of
            the other pairs are ignored (they may be empty, or ``-inf``).
        terminal : True or array_like of states, optional
            ``True``: rows summing to less than one send the missing probability to an
            added absorbing state with reward 0, the *sink*, appended as the last state
            (``n_states = n + 1``, ``self.sink`` is True). A list of states (or a mask of
            shape (n,)) also ends the process after them: each of their actions pays its
            reward and moves to the sink. Drop the sink from reported vectors with
            :meth:`user_values` / :meth:`user_bounds` / :meth:`user_policy` (or slice
            ``[:n]``: user states keep their indices). Default: rows must sum to one.
            An allowed pair whose row has no probability at all is refused, naming the
            pair, unless its state is listed (``docs/interop.md``: no pair vanishes).
        terminal_reward : {"keep", "zero"}
            What a state listed in ``terminal=`` pays: ``"keep"`` (default) each of its
            actions pays its reward once and moves to the sink; ``"zero"``: it is worth
            0 (Gymnasium's and POMDPs.jl's convention for a terminal state).
        sense : {"max", "min"}
            ``"min"`` when ``R`` holds costs (see the class parameters).
        action_names : sequence of str, optional

        Returns
        -------
        FiniteMDP
            With ``L`` = the largest number of non-zeros in a row of ``P`` (plus one for
            a row that moves to the sink) and the outcomes of each pair listed in column
            order (padded with probability 0).
        """
        from . import interop  # with scipy.sparse: only when a converter runs

        return interop.from_matrices(
            cls, P, R, discount, allowed=allowed, terminal=terminal,
            terminal_reward=terminal_reward, sense=sense, action_names=action_names,
        )  # fmt: skip

    @classmethod
    def from_pymdptoolbox(
        cls,
        P: Any,
        R: Any,
        discount: float,
        *,
        terminal: Any = None,
        terminal_reward: str = "keep",
        sense: str = "max",
    ) -> FiniteMDP:
        """Build an MDP from pymdptoolbox's ``(transitions, reward, discount)``.

        Every form pymdptoolbox accepts: ``P`` as an (A, n, n) array or A dense or
        sparse (n, n) matrices in a list, tuple, dict or 1-d object array; ``R`` as
        (n,), (n, A) (dense or sparse), (A, n, n), or A dense or sparse matrices.
        The same reading as :meth:`from_matrices` (see it for ``terminal``,
        ``terminal_reward`` and ``sense``); pymdptoolbox has no action masks.
        """
        from . import interop  # with scipy.sparse: only when a converter runs

        return interop.from_matrices(
            cls, P, R, discount, terminal=terminal, terminal_reward=terminal_reward,
            sense=sense,
        )  # fmt: skip

    @classmethod
    def from_quantecon(
        cls,
        R: Any,
        Q: Any = None,
        beta: Any = None,
        s_indices: Any = None,
        a_indices: Any = None,
        *,
        layout: str | None = None,
        terminal: Any = None,
        terminal_reward: str = "keep",
        action_names: Sequence[str] | None = None,
    ) -> FiniteMDP:
        """Build an MDP from QuantEcon's ``DiscreteDP`` or from its arguments.

        ``from_quantecon(ddp)`` reads a ``quantecon.markov.DiscreteDP`` object;
        ``from_quantecon(R, Q, beta)`` its product form (``R[s, a]`` (n, m),
        ``Q[s, a, s']`` (n, m, n)); ``from_quantecon(R, Q, beta, s_indices,
        a_indices)`` its state-action-pair form (``R`` (L,), ``Q`` (L, n) dense or
        sparse, one row per available pair). QuantEcon itself is not needed.

        Parameters
        ----------
        R, Q, beta, s_indices, a_indices
            As for ``DiscreteDP``. A reward ``-inf`` means "action not available" (it
            becomes ``allowed[s, a] = False``, and that pair's row of ``Q`` is ignored);
            NaN and ``+inf`` are refused.
        layout : {"sas", "ass"}, optional
            The order of the axes of a 3-d ``Q``: ``"sas"`` is ``Q[state, action,
            next]`` (QuantEcon, MDPSolver), ``"ass"`` is ``P[action, state, next]``
            (pymdptoolbox). By default QuantEcon's ``"sas"`` whenever the shape allows
            it, also with as many actions as states (QuantEcon's savings and cake-eating
            problems, whose actions are next period's grid points); ``"ass"`` only when
            the shape says so or when passed.
        terminal : True or array_like of states, optional
            See :meth:`from_matrices`.
        terminal_reward : {"keep", "zero"}
            See :meth:`from_matrices`.
        action_names : sequence of str, optional

        Raises
        ------
        ValidationError
            For a ``Q`` of neither shape, a pair listed twice, an index out
            of range, a state with no available action, a row not summing to one.
        """
        from . import interop  # with scipy.sparse: only when a converter runs

        return interop.from_quantecon(
            cls, R, Q, beta, s_indices, a_indices, layout=layout, terminal=terminal,
            terminal_reward=terminal_reward, action_names=action_names,
        )  # fmt: skip

    @classmethod
    def from_transitions(
        cls,
        rows: Any,
        discount: float,
        rewards: Any = None,
        *,
        reward_rows: Any = None,
        n_states: int | None = None,
        n_actions: int | None = None,
        terminal: Any = None,
        terminal_reward: str = "keep",
        sense: str = "max",
        action_names: Sequence[str] | None = None,
    ) -> FiniteMDP:
        """Build an MDP from ``[s, a, s', p]`` rows (MDPSolver's elementwise format).

        Parameters
        ----------
        rows : array_like (K, 4) or (K, 5)
            ``[state, action, next_state, probability]``, or with a fifth column the
            reward of that transition (the pair's reward is then ``sum p * r``). A pair
            with rows is available; rows repeating a next state add up (eq. 2).
        discount : float
        rewards : array_like (n, A), optional
            ``R[s, a]`` (MDPSolver's ``rewards``). A pair without rows is not available
            when its entry is 0, ``-inf`` or NaN; any other reward on a pair without rows
            is refused, naming the pair, unless its state is listed in ``terminal=``
            (then it pays that reward and ends): a pair never vanishes silently
            (``docs/interop.md``).
        reward_rows : array_like (K', 3), optional
            ``[state, action, reward]`` (MDPSolver's ``rewardsElementwise``): one per
            available pair. With 4 columns, exactly one of ``rewards`` and
            ``reward_rows`` is required (never guessed from a shape).
        n_states, n_actions : int, optional
            Default: one more than the largest index in ``rows``.
        terminal, terminal_reward, sense, action_names
            See :meth:`from_matrices`.
        """
        from . import interop  # with scipy.sparse: only when a converter runs

        return interop.from_transitions(
            cls, rows, discount, rewards, reward_rows=reward_rows, n_states=n_states,
            n_actions=n_actions, terminal=terminal, terminal_reward=terminal_reward,
            sense=sense, action_names=action_names,
        )  # fmt: skip

    @classmethod
    def from_gymnasium(
        cls,
        env: Any,
        discount: float,
        *,
        sink: Any = "auto",
        action_names: Sequence[str] | None = None,
    ) -> FiniteMDP:
        """Build an MDP from a Gymnasium environment with a tabular model ``env.unwrapped.P``.

        ``P[s][a] = [(prob, next_state, reward, terminated), ...]`` (the toy-text
        environments: FrozenLake, Taxi, CliffWalking, ...). Each pair's reward is the
        expected transition reward ``sum p r``; a terminated transition goes to one added
        absorbing zero-reward sink (the last state, ``mdp.sink``), which ``user_values``
        and the other reported vectors leave out, so they have Gymnasium's indices.
        Gymnasium itself is never imported. See
        :func:`lpbounds.model.gymnasium.from_gymnasium` for ``sink=`` and the checks.
        """
        from . import gymnasium as gym_interop  # imported when a converter runs

        return gym_interop.from_gymnasium(cls, env, discount, sink=sink, action_names=action_names)

    def to_quantecon(self, form: str = "sa") -> Any:
        """This model as a ``quantecon.markov.DiscreteDP`` (needs QuantEcon installed).

        Parameters
        ----------
        form : {"sa", "product"}
            ``"sa"`` (default): the state-action-pair form with a sparse ``Q``, one row
            per allowed pair. ``"product"``: dense ``R`` (n, m) with ``-inf`` where an
            action is not allowed and ``Q`` (n, m, n) (memory ``n * m * n``).

        Notes
        -----
        QuantEcon maximises: a ``sense="min"`` model is exported as its stored,
        negated-cost rewards, and an added sink as an ordinary state.
        """
        from . import interop  # with scipy.sparse: only when a converter runs

        return interop.to_quantecon(self, form)

    def to_matrices(
        self, disallowed_reward: float | None = None
    ) -> tuple[list[sp.csr_matrix], np.ndarray]:
        """Transition matrices and expected rewards in pymdptoolbox's convention.

        Parameters
        ----------
        disallowed_reward : float, optional
            pymdptoolbox has no action masks. If some action is disallowed somewhere,
            pass a (very negative) reward: disallowed pairs become self-loops with it.

        Returns
        -------
        P : list of A scipy.sparse.csr_matrix, each (n, n)
        R : ndarray (n, A)
        """
        n = self.n_states
        if not self.allowed.all() and disallowed_reward is None:
            x, u = first_index(~self.allowed)
            raise ValidationError(
                f"action {u} is not allowed in state {x}; pymdptoolbox matrices cannot "
                "express that: pass disallowed_reward= (a very negative number)"
            )
        import scipy.sparse as sp

        probs = self.probabilities_full()
        mats = []
        rows = np.repeat(np.arange(n), self.n_outcomes)
        for a in range(self.n_actions):
            succ_a = np.array(self.successors[:, a, :])
            prob_a = np.array(probs[:, a, :])
            off = ~self.allowed[:, a]
            if off.any():  # pymdptoolbox has no masks: a disallowed pair is a self-loop
                succ_a[off] = np.flatnonzero(off)[:, None]
                prob_a[off] = 0.0
                prob_a[off, 0] = 1.0
            m = sp.csr_matrix((prob_a.ravel(), (rows, succ_a.ravel())), shape=(n, n))
            m.sum_duplicates()
            m.eliminate_zeros()
            mats.append(m)
        rew = np.array(self.rewards, dtype=np.float64)
        if disallowed_reward is not None:
            rew[~self.allowed] = check_real("disallowed_reward", disallowed_reward)
        return mats, rew
