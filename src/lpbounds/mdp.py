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
from typing import Any

import numba
import numpy as np
import scipy.sparse as sp

from .errors import ValidationError
from .tolerances import PROBABILITY_NEGATIVE_ATOL, PROBABILITY_SUM_ATOL
from .validation import (
    as_array,
    as_float_array,
    check_array,
    check_bool,
    check_indices,
    check_real,
    check_value_scale,
    first_index,
)

__all__ = ["FiniteMDP", "index_dtype"]


def index_dtype(n: int) -> type[np.signedinteger[Any]]:
    """Smallest signed integer type that indexes ``n`` items (int32 or int64)."""
    return np.int32 if n < 2**31 - 1 else np.int64


@numba.njit(cache=True, nogil=True)
def _check_successors(succ, allow, n):  # pragma: no cover - compiled
    """Out-of-range successors: (count on allowed pairs, first flat index, count elsewhere).

    One pass and no temporaries (full-size boolean masks cost GBs at 33 M states).
    """
    n_states, n_actions, n_out = succ.shape
    bad = 0
    first = -1
    bad_disallowed = 0
    for x in range(n_states):
        for u in range(n_actions):
            for ll in range(n_out):
                k = succ[x, u, ll]
                if k < 0 or k >= n:
                    if allow[x, u]:
                        if first < 0:
                            first = (x * n_actions + u) * n_out + ll
                        bad += 1
                    else:
                        bad_disallowed += 1
    return bad, first, bad_disallowed


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
        :data:`~lpbounds.tolerances.PROBABILITY_SUM_ATOL`.
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

    Raises
    ------
    ValidationError
        Naming the first offending entry (shape, dtype, index, probability, reward,
        discount). Booleans, strings and complex numbers are refused before any cast;
        successor indices are range-checked in the dtype given, before the cast to the
        index dtype. A model whose value scale ``max|R| / (1 - discount)`` exceeds
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
    ) -> None:
        copy = check_bool("copy", copy)
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
        check_value_scale(max(float(rew.max()), -float(rew.min())), self.discount)

        self.probabilities = _readonly(self._check_probabilities(probabilities, allow, succ.shape))
        self.successors = _readonly(succ)
        self.rewards = _readonly(rew)
        self.allowed = _readonly(allow.copy())
        self.action_names = self._check_action_names(action_names, n_actions)

    # ------------------------------------------------------------------ validation
    @staticmethod
    def _check_discount(discount: float) -> float:
        return check_real("discount", discount, lo=0.0, hi=1.0, hi_open=True)

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
            raise ValidationError(
                f"rewards[{x}, {u}] = {rew[x, u]} is not finite on an allowed pair "
                f"({int(nonfinite.sum())} such entries)"
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
        probabilities: Any, allow: np.ndarray, shape: tuple[int, int, int]
    ) -> np.ndarray:
        p = as_float_array("probabilities", probabilities, finite=False)
        _n, _n_actions, n_out = shape
        if p.shape == (n_out,):
            where = "probabilities"
            if not np.all(np.isfinite(p)):
                raise ValidationError(f"probabilities must be finite; got {p}")
            if (p < -PROBABILITY_NEGATIVE_ATOL).any():
                ll = int(np.flatnonzero(p < -PROBABILITY_NEGATIVE_ATOL)[0])
                raise ValidationError(f"{where}[{ll}] = {p[ll]} is negative")
            total = p.sum()
            if abs(total - 1.0) > PROBABILITY_SUM_ATOL:
                raise ValidationError(
                    f"{where} sum to {float(total):.12g}, not 1 "
                    f"(tolerance {PROBABILITY_SUM_ATOL:g})"
                )
            return np.clip(p, 0.0, None)
        if p.shape != shape:
            raise ValidationError(
                f"probabilities must have shape ({n_out},) or {shape}; got {p.shape}"
            )
        nonfinite = ~np.isfinite(p) & allow[:, :, None]
        if nonfinite.any():
            x, u, ll = first_index(nonfinite)
            raise ValidationError(f"probabilities[{x}, {u}, {ll}] = {p[x, u, ll]} is not finite")
        neg = (p < -PROBABILITY_NEGATIVE_ATOL) & allow[:, :, None]
        if neg.any():
            x, u, ll = first_index(neg)
            raise ValidationError(
                f"probabilities[{x}, {u}, {ll}] = {p[x, u, ll]} is negative "
                f"({int(neg.sum())} such entries)"
            )
        sums = p.sum(axis=2)
        off = (np.abs(sums - 1.0) > PROBABILITY_SUM_ATOL) & allow
        if off.any():
            x, u = first_index(off)
            raise ValidationError(
                f"probabilities[{x}, {u}, :] sum to {float(sums[x, u]):.12g}, not 1 "
                f"(tolerance {PROBABILITY_SUM_ATOL:g}; {int(off.sum())} such pairs)"
            )
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

    def __repr__(self) -> str:
        return (
            f"FiniteMDP(n_states={self.n_states}, n_actions={self.n_actions}, "
            f"n_outcomes={self.n_outcomes}, discount={self.discount}, "
            f"allowed_pairs={self.n_pairs})"
        )

    # ------------------------------------------------------------------ conversions
    @classmethod
    def from_matrices(cls, P: Any, R: Any, discount: float) -> FiniteMDP:
        """Build an MDP from transition matrices in pymdptoolbox's convention.

        Parameters
        ----------
        P : array (A, n, n) or sequence of A (n, n) matrices, dense or scipy.sparse
            ``P[a][x, y]`` is the probability of moving from ``x`` to ``y`` under ``a``;
            each row must sum to one.
        R : array (n,), (n, A), or (A, n, n) / sequence of A (n, n) matrices
            State rewards, expected rewards ``R[x, a]``, or transition rewards
            ``R[a][x, y]`` (whose expectation ``sum_y P[a][x, y] R[a][x, y]`` is used).
        discount : float
            The discount in ``[0, 1)``.

        Returns
        -------
        FiniteMDP
            With ``L`` = the largest number of non-zeros in a row of ``P`` and the
            outcomes of each pair listed in column order (padded with probability 0).
        """
        cls._check_discount(discount)
        mats = cls._matrix_list(P, "P")
        n_actions = len(mats)
        n = mats[0].shape[0]
        if n == 0:
            raise ValidationError("P[0] has no state (shape (0, 0))")
        for a, m in enumerate(mats):
            if m.shape != (n, n):
                raise ValidationError(f"P[{a}] has shape {m.shape}; expected {(n, n)}")
        nnz = np.stack([np.diff(m.indptr) for m in mats], axis=1)  # (n, A)
        empty = nnz == 0
        if empty.any():
            x, a = first_index(empty)
            raise ValidationError(f"row {x} of P[{a}] is empty (sums to 0, not 1)")
        n_out = int(nnz.max())
        idt = index_dtype(n)
        succ = np.repeat(np.arange(n, dtype=idt)[:, None, None], n_actions, axis=1)
        succ = np.repeat(succ, n_out, axis=2)
        prob = np.zeros((n, n_actions, n_out))
        for a, m in enumerate(mats):
            rows = np.repeat(np.arange(n), np.diff(m.indptr))
            pos = np.arange(m.nnz) - m.indptr[rows]
            succ[rows, a, pos] = m.indices
            prob[rows, a, pos] = m.data
        rew = cls._expected_rewards(R, mats, n, n_actions)
        return cls(succ, prob, rew, discount)

    @staticmethod
    def _matrix_list(P: Any, name: str) -> list[sp.csr_matrix]:
        if sp.issparse(P):
            raise ValidationError(f"{name} must be A matrices (a list or an (A, n, n) array)")
        if isinstance(P, np.ndarray):
            if P.ndim != 3:
                raise ValidationError(f"{name} must have shape (A, n, n); got {P.shape}")
            items = list(P)
        else:
            try:
                items = list(P)
            except TypeError as exc:
                raise ValidationError(f"{name} must be a sequence of A matrices") from exc
        if not items:
            raise ValidationError(f"{name} has no actions")
        out = []
        for a, m in enumerate(items):
            if sp.issparse(m):
                if m.dtype.kind not in "iuf":
                    raise ValidationError(f"{name}[{a}] must hold real numbers; got {m.dtype}")
            else:
                m = check_array(f"{name}[{a}]", m, finite=False)
            mat = sp.csr_matrix(m, dtype=np.float64)
            if mat.ndim != 2:
                raise ValidationError(f"{name}[{a}] is not a matrix")
            mat.sum_duplicates()
            mat.eliminate_zeros()
            mat.sort_indices()
            out.append(mat)
        return out

    @classmethod
    def _expected_rewards(
        cls, R: Any, mats: list[sp.csr_matrix], n: int, n_actions: int
    ) -> np.ndarray:
        matrices = sp.issparse(R) or (
            isinstance(R, (list, tuple))
            and len(R) > 0
            and (sp.issparse(R[0]) or np.ndim(R[0]) == 2)
        )
        if not matrices:  # a plain list of numbers is a vector, not A matrices
            arr = as_float_array("R", R, finite=False)
            if arr.shape == (n,):
                return np.repeat(arr[:, None], n_actions, axis=1)
            if arr.shape == (n, n_actions):
                return arr
            if arr.shape != (n_actions, n, n):
                raise ValidationError(
                    f"R must have shape {(n,)}, {(n, n_actions)} or {(n_actions, n, n)}; "
                    f"got {arr.shape}"
                )
        rmats = cls._matrix_list(R, "R")
        if len(rmats) != n_actions:
            raise ValidationError(f"R has {len(rmats)} matrices for {n_actions} actions")
        cols = []
        for a in range(n_actions):
            if rmats[a].shape != (n, n):
                raise ValidationError(f"R[{a}] has shape {rmats[a].shape}; expected {(n, n)}")
            cols.append(np.asarray(mats[a].multiply(rmats[a]).sum(axis=1)).ravel())
        return np.stack(cols, axis=1)

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
