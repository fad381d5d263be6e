r"""The exact rows of an MDP in post-decision form (:class:`PostDecisionRows`): the fast path
of exact DP on structured models such as the perimeter patrol."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .._kernels import dispatch as _backend
from ..model.mdp import FiniteMDP, index_dtype
from ..stochastic import RowSums, row_sums
from .sweep import PolicySweeps

__all__ = ["PostDecisionRows"]


@dataclass(frozen=True, eq=False)
class PostDecisionRows:
    r"""The exact rows of an MDP in post-decision form: a fast path for structured models.

    If the probabilities are shared and every allowed pair's outcome tuple is a function
    of its first outcome, ``f(x, u, Y_l) = g(y, l)`` with ``y = f(x, u, Y_0)`` (the
    *post-decision state*), then the exact Bellman operator factors as

    .. math:: (Tv)(x) = \max_{u \in U_x} R_u(x) + \lambda W(f(x, u, Y_0)),
              \qquad W(y) = \sum_l p_l\, v(g(y, l)),

    so a sweep reads ``L`` values per distinct ``y`` and one ``W`` per pair instead of
    ``L`` values per pair, and nothing is copied per row. The perimeter patrol MDP has
    this form (an alert changes the delays of the state the vehicle moved to, whatever
    the move). :meth:`detect` builds the form from a :class:`FiniteMDP` and checks it on
    every allowed pair (it returns ``None`` where it does not hold). The kernels use
    the arithmetic of the row kernels, so :func:`lpbounds.solve_exact` gives the same
    numbers, bit for bit, as on :meth:`BellmanRows.from_mdp`'s rows.

    Attributes
    ----------
    n_vars : int
        States.
    first : ndarray (n, A) int32
        Index into ``outcomes`` of each allowed pair's post-decision state (-1: disallowed).
    reward : ndarray (n, A)
        ``R_u(x)`` (the MDP's array, not copied).
    reward_codes, reward_table : ndarray or None
        ``reward == reward_table[reward_codes]`` exactly, when the rewards take few
        distinct values (the patrol model: a few dozen); the sweeps then read the codes.
    outcomes : ndarray (n_post, L)
        ``g(y, l)`` per distinct post-decision state ``y``.
    probs : ndarray (L,)
    allowed : ndarray (n, A) bool
    discount : float
    """

    n_vars: int
    first: np.ndarray
    reward: np.ndarray
    outcomes: np.ndarray
    probs: np.ndarray
    allowed: np.ndarray
    discount: float
    reward_codes: np.ndarray | None = None
    reward_table: np.ndarray | None = None

    #: Rewards with at most this many distinct values are stored as codes into a table
    #: (uint8 up to 256 values, else uint16): 1-2 bytes instead of 8 per pair and sweep.
    MAX_REWARD_CODES: ClassVar[int] = 65_536

    @classmethod
    def detect(cls, mdp: FiniteMDP) -> PostDecisionRows | None:
        """The post-decision form of ``mdp``, or ``None`` if it does not have one.

        Verified on every allowed pair: the form is returned only if each pair's full
        outcome tuple equals the tuple stored for its first outcome.
        """
        if not mdp.shared_probabilities:
            return None
        n, n_act, n_out = mdp.successors.shape
        if n_act > 127:
            return None
        succ, allowed = mdp.successors, mdp.allowed
        if not _sample_consistent(succ, allowed):
            return None
        kern = _backend.kernels()
        seen = np.zeros(n, dtype=np.bool_)
        kern.ps_mark(succ, allowed, seen)
        post = np.flatnonzero(seen)
        del seen
        idt = index_dtype(max(n, post.size))
        post_id = np.full(n, -1, dtype=idt)
        post_id[post] = np.arange(post.size, dtype=idt)
        outcomes = np.empty((post.size, n_out), dtype=succ.dtype)
        first = np.empty((n, n_act), dtype=idt)
        kern.ps_fill(succ, allowed, post_id, outcomes, first)
        del post_id, post
        if kern.ps_verify(succ, first, outcomes) != 0:
            return None
        codes, table = _reward_codes(kern, mdp.rewards, cls.MAX_REWARD_CODES)
        return cls(
            n_vars=int(n),
            first=first,
            reward=mdp.rewards,
            outcomes=outcomes,
            probs=np.ascontiguousarray(mdp.probabilities, dtype=np.float64),
            allowed=allowed,
            discount=float(mdp.discount),
            reward_codes=codes,
            reward_table=table,
        )

    @property
    def n_post(self) -> int:
        """Number of distinct post-decision states."""
        return int(self.outcomes.shape[0])

    @property
    def reads(self) -> int:
        """Pairs times outcomes, the reads of the plain rows' sweep."""
        return int(self.first.size * self.outcomes.shape[1])

    @property
    def compiled(self) -> bool:
        """True: the sweeps are C (:mod:`lpbounds._kernels.dispatch`), at every size."""
        return True

    @property
    def sweep_reads(self) -> int:
        """Values a sweep reads (:class:`SweepOperator`): ``L`` per post-decision state and
        one ``W`` per pair."""
        return self.n_post * int(self.outcomes.shape[1]) + int(self.first.size)

    def kernels(self) -> Any:
        """The post-decision kernel module.

        Returns
        -------
        module
            :func:`lpbounds._kernels.dispatch.kernels` (C).
        """
        return _backend.kernels()

    @property
    def reward_absmax(self) -> float:
        """``max |R_u(x)|`` over allowed pairs (disallowed rewards are stored as 0)."""
        return float(np.abs(self.reward).max(initial=0.0))

    def row_sums(self) -> RowSums:
        """Certified bounds on the exact sum of the shared distribution ``probs``."""
        return row_sums(self.probs)

    # ------------------------------------------------------------------ sweep protocol
    # intended parallel: the SweepOperator signatures (rows/sweep.py), repeated by each operator
    def new_vector(self) -> np.ndarray:
        """An uninitialised float64 vector over the states."""
        return np.empty(self.n_vars)

    def new_work(self) -> np.ndarray:
        """A buffer for ``W`` to pass to the sweeps: one per solve, reused by its sweeps (a
        fresh array every sweep costs page faults, 30% of the time at 33 M states)."""
        return np.empty(self.n_post)

    def new_arg(self) -> np.ndarray:
        """An array for the chosen action of every state (int8)."""
        return np.zeros(self.n_vars, dtype=np.int8)

    def evaluator(self, work: np.ndarray | None = None) -> PolicySweeps:
        """Evaluation sweeps of one policy at a time (in place: a sweep reads one ``W`` per
        state, nothing to pack)."""
        return PolicySweeps(self, work=work)

    def sweep_max(
        self,
        v: np.ndarray,
        out: np.ndarray,
        arg: np.ndarray,
        *,
        work: np.ndarray | None = None,
        nchunks: int | None = None,
    ) -> tuple[float, float]:
        """``out = T v``, the first maximising action in ``arg`` (int8); returns the min and
        max of ``out - v``. ``work``: a :meth:`new_work` buffer (else one is made);
        ``nchunks`` is unused (the C sweeps take one range of states per thread)."""
        kern, w = self._expect(v, work)
        if self.reward_codes is not None:
            lo, hi = kern.ps_max_stats_coded(
                self.first, self.reward_codes, self.reward_table, w, self.discount, v, out, arg
            )
        else:
            lo, hi = kern.ps_max_stats(self.first, self.reward, w, self.discount, v, out, arg)
        return float(lo), float(hi)

    def sweep_policy(
        self,
        sel: np.ndarray,
        v: np.ndarray,
        out: np.ndarray,
        *,
        work: np.ndarray | None = None,
        nchunks: int | None = None,
        reward: np.ndarray | None = None,
    ) -> tuple[float, float]:
        """One evaluation sweep of the actions ``sel``; returns the min and max of
        ``out - v``. ``reward`` replaces the stored rewards (the table when they are coded:
        see :meth:`zero_rewards`); ``work`` and ``nchunks`` as in :meth:`sweep_max`."""
        kern, w = self._expect(v, work)
        if self.reward_codes is not None:
            table = self.reward_table if reward is None else reward
            lo, hi = kern.ps_policy_stats_coded(
                self.first, self.reward_codes, table, sel, w, self.discount, v, out
            )
        else:
            rew = self.reward if reward is None else reward
            lo, hi = kern.ps_policy_stats(self.first, rew, sel, w, self.discount, v, out)
        return float(lo), float(hi)

    def _expect(self, v: np.ndarray, work: np.ndarray | None) -> tuple[Any, np.ndarray]:
        """The kernel module and ``W(y) = sum_l p_l v(g(y, l))`` at every post-decision
        state, written into ``work`` (a :meth:`new_work` buffer; else one is made)."""
        w = self.new_work() if work is None else work
        kern = self.kernels()
        kern.ps_expect(self.outcomes, self.probs, v, w)
        return kern, w

    def zero_rewards(self) -> np.ndarray:
        """Zeros in the layout :meth:`sweep_policy` reads (the code table when the rewards
        are coded): with them a sweep computes ``discount * P_pi v``."""
        if self.reward_table is not None:
            return np.zeros_like(self.reward_table)
        return np.zeros(self.reward.shape)

    def self_loops(self, act: np.ndarray) -> np.ndarray:
        """``P_pi(x, x)`` for the actions ``act``: the probability of staying at ``x``."""
        x = np.arange(self.n_vars)
        stay = self.outcomes[self.first[x, act]] == x[:, None]
        return (self.probs[None, :] * stay).sum(axis=1)

    def rows_of(self, act: np.ndarray) -> np.ndarray:
        """Row indices (those of :meth:`BellmanRows.from_mdp`) of the pairs ``(x, act[x])``."""
        counts = self.allowed.sum(axis=1)
        row_start = np.zeros(self.n_vars, dtype=np.int64)
        np.cumsum(counts[:-1], out=row_start[1:])
        out = np.empty(self.n_vars, dtype=np.int64)
        self.kernels().ps_rows(self.allowed, row_start, np.asarray(act), out)
        return out


def _sample_consistent(succ: np.ndarray, allowed: np.ndarray, size: int = 16_384) -> bool:
    """False if the pairs of an evenly spaced sample of states already contradict the
    post-decision form (two pairs with the same first outcome and different tuples).

    A cheap necessary test that rejects unstructured MDPs (a random MDP of 2 M states has
    ~600 such collisions in the sample) before the full pass; True proves nothing.
    """
    n = succ.shape[0]
    states = np.arange(0, n, max(1, n // size))
    xs, us = np.nonzero(allowed[states])
    tup = succ[states[xs], us]
    order = np.argsort(tup[:, 0], kind="stable")
    tup = tup[order]
    same = tup[1:, 0] == tup[:-1, 0]
    return bool(np.array_equal(tup[1:][same], tup[:-1][same]))


def _reward_codes(
    kern: Any, reward: np.ndarray, max_codes: int
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``(codes, table)`` with ``table[codes] == reward`` bit for bit, or ``(None, None)``;
    ``kern`` is the kernel module (:func:`lpbounds._kernels.dispatch.kernels`)."""
    if max_codes < 1 or reward.size == 0:
        return None, None
    rew = np.ascontiguousarray(reward, dtype=np.float64)
    codes = np.empty(rew.shape, dtype=np.uint16 if max_codes <= 65_536 else np.uint32)
    table = np.empty(max_codes)
    count = kern.reward_codes(rew, max_codes, codes, table)
    if count < 0:
        return None, None
    if count <= 256:
        codes = codes.astype(np.uint8)
    return codes, table[:count].copy()
