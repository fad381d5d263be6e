r"""Systems of Bellman rows: the one structure every formulation in lpbounds is made of.

A *Bellman row* ``r`` constrains one variable, its *owner* ``i``:

.. math:: v(i) \;\ge\; \rho_r + \lambda \sum_{l} p_{r,l}\, v(k_{r,l}).

* The exact LP (eq. 8) has one row per allowed (state, action): owner ``x``,
  reward ``R_u(x)``, targets ``f(x, u, Y_l)``.
* The restricted LP (eq. 9) has the same rows with every state replaced by its
  partition: owner ``i`` with ``x`` in ``S_i``, targets ``f-bar(x, u, Y_l)``. Rows that
  become identical are merged (:meth:`BellmanRows.aggregate`).
* UBLP/LBLP (eq. 26, 29) are row systems on the partitions; the disjunctive NLP (eq. 25)
  groups the rows of each (partition, action) into one disjunction.

**Fact 1 (least feasible point).** For any row system in which every owner has at
least one row, the set ``F = {v : v(i) >= q_r(v) for every row r of i}`` has a least
element, the unique fixed point ``v*`` of ``(Tv)(i) = max_{r of i} q_r(v)``, and
``v* = argmin c'v`` over ``F`` for *every* ``c >= 0`` (``c > 0`` makes it the unique
minimiser).

*Proof.* The rows are the Bellman inequalities of an MDP whose states are the owners
and whose actions at ``i`` are the rows of ``i`` (each row's outcome probabilities are
non-negative and sum to 1). ``T`` is that MDP's Bellman operator: monotone and a
``lambda``-contraction in the max norm, so it has one fixed point ``v*``. If ``v`` is in
``F`` then ``v >= Tv``, hence ``v >= T^k v -> v*`` by monotonicity; ``v*`` itself is in
``F``. So ``v*`` is the least element, and ``c'v >= c'v*`` for ``c >= 0``. For exact
rows this is Lemma 1 (ELP's optimum is ``V*``) with the remark that every feasible
point dominates ``V*``; with the RLP's rows it is Theorem 1: RLP's optimum does not
depend on the cost. []

**Fact 2 (disjunctive rows).** Group the rows of owner ``i`` by action ``u``. The set
``G = {w : w(i) >= min_{r in (i, u)} q_r(w) for every (i, u)}`` has the least element
``w*``, the fixed point of ``(Gw)(i) = max_u min_{r in (i,u)} q_r(w)``: the value of a
zero-sum stochastic game (the controller picks ``u``, an adversary the row).

*Proof.* ``G`` is monotone (max and min of monotone maps) and a ``lambda``-contraction
(max and min are 1-Lipschitz in the max norm), so it has one fixed point ``w*``, in
``G``. If ``w`` is in ``G`` then ``w >= Gw >= ... -> w*``. (Every owner needs at least
one group ``(i, u)``: an owner with none is unconstrained and ``w*(i) = -inf``.) []

So the NLP (eq. 24-25) has the same optimum for every cost ``c >= 0`` and one solve
gives the bound for every partition; the paper's one-LP-per-partition is not needed.

**Action sets (why** ``aggregate(reduce="min")`` **drops some (i, u)).** The NLP's bound
``w*(i) <= min_{x in S_i} V*(x)`` holds because ``wbar(i) = min_{S_i} V*`` lies in
``G``: for a group ``(i, u)`` take ``x0 = argmin_{S_i} V*``; *if u is allowed at x0*,
``wbar(i) = V*(x0) >= R_u(x0) + lambda sum_l p_l V*(f(x0, u, Y_l)) >= q_{(x0,u)}(wbar)
>= min_{x in S_i} q_{(x,u)}(wbar)`` (``V* >= Phi wbar`` and monotonicity), so the
disjunction holds at ``wbar``; then ``w* <= wbar`` by Fact 2. If ``u`` is *not*
allowed at ``x0`` nothing bounds ``V*(x0)`` through ``u``: the state's term is
``R_u(x0) = -inf`` (a forbidden action is infinitely bad), so the min over ``S_i`` is
``-inf`` and the disjunction ``w(i) >= -inf`` says nothing. Keeping the terms of the
states that do allow ``u`` instead can put ``wbar`` outside ``G`` and ``w*`` *above*
``min_{S_i} V*`` (two states, state 0 allowing action 0 only: ``V* = [0, 10]``, the
kept term of state 1 under action 1 gave ``w* = 10``). Since ``x0`` is not known in
advance, a group ``(i, u)`` is kept only when ``u`` is allowed at *every* state of
``S_i``; with that rule ``wbar`` is in ``G`` and the bound holds. A partition whose
states share no allowed action keeps no group and its bound is ``-inf``;
:meth:`BellmanRows.aggregate` refuses it with a :class:`~lpbounds.errors.ValidationError`
naming the partition (refine the partition so that its states share an action). The
patrol partitions satisfy the rule by construction (the allowed actions are a function
of the partition key, :mod:`lpbounds.patrol.bounds`). The max-rows of RLP (eq. 9) need
no such rule: a disallowed pair simply has no row, and every row that exists is implied
at ``Phi v`` by a Bellman inequality of an allowed pair (Theorem 1).
The kernels that apply ``T`` and ``G`` are C (:mod:`lpbounds._kernels.native`,
:mod:`lpbounds._kernels.ckernels`, named by :mod:`lpbounds._kernels.dispatch`); their numpy
twins (:mod:`lpbounds._kernels.twins`, the same numbers) are the tests' reference.

**The sweep protocol.** The exact-DP loops of :mod:`lpbounds.dp` (MPI, value iteration,
iterative policy evaluation) run on any :class:`SweepOperator`: :class:`BellmanRows`,
:class:`PostDecisionRows` and the matrix-free patrol operator
(:class:`lpbounds.patrol.matrix_free.MatrixFreePatrol`) implement it. A sweep writes
``T v`` (or ``T_pi v``) into ``out`` and returns the extremes of ``out - v``; the work
chunks of the patrol's matrix-free kernels are the operator's choice unless ``nchunks`` is
given (the C sweeps of :class:`BellmanRows` and :class:`PostDecisionRows` take one range per
thread and ignore it; neither changes a number: every state's value is computed alone and
the extremes are exact),
and ``work`` is the operator's scratch array from :meth:`SweepOperator.new_work`, made once
per solve and passed to each of its sweeps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal, Protocol, runtime_checkable

import numpy as np

from .._kernels import dispatch as _backend
from ..errors import ValidationError
from ..model.mdp import FiniteMDP, index_dtype
from ..model.partition import Partition
from ..stochastic import RowSums, check_rows, row_sums
from ..validation import (
    as_float_array,
    check_array,
    check_discount,
    check_indices,
    check_int,
    check_value_scale,
    check_vector,
)

if TYPE_CHECKING:  # scipy.sparse is imported where a matrix is built (0.1 s at start-up)
    import scipy.sparse as sp

__all__ = ["BellmanRows", "PackedSweeps", "PolicySweeps", "PostDecisionRows", "SweepOperator"]

Reduce = Literal["max", "min"]


@runtime_checkable
class SweepOperator(Protocol):
    """What the exact-DP loops of :mod:`lpbounds.dp` need of an operator: fused sweeps.

    A Bellman operator ``T`` over ``n_vars`` states with a choice per state (a row, an
    action) and its fixed-policy operators ``T_pi``. Implemented by :class:`BellmanRows`
    (choices are rows), :class:`PostDecisionRows` and
    :class:`lpbounds.patrol.matrix_free.MatrixFreePatrol` (choices are actions, int8).

    Attributes
    ----------
    n_vars : int
        States (the length of every value vector).
    discount : float
        ``lambda``.
    compiled : bool
        True when the sweeps run compiled, multithreaded kernels (C), whose thread count
        :func:`lpbounds.dp.threads_for` sets; False for an operator whose sweeps have no
        threads.
    sweep_reads : int
        Values one sweep reads: sweeps below :data:`lpbounds.dp.SERIAL_SWEEP_READS` run
        on one thread (:func:`lpbounds.dp.threads_for`).
    """

    @property
    def n_vars(self) -> int: ...

    @property
    def discount(self) -> float: ...

    @property
    def compiled(self) -> bool: ...

    @property
    def sweep_reads(self) -> int: ...

    def row_sums(self) -> RowSums:
        """Certified bounds on the rows' probability sums (the contraction modulus)."""
        ...

    def new_vector(self) -> np.ndarray:
        """An uninitialised float64 vector over the states."""
        ...

    def new_arg(self) -> np.ndarray:
        """A zeroed array for the choice of every state (what :meth:`sweep_max` writes)."""
        ...

    def new_work(self) -> np.ndarray | None:
        """The scratch array the sweeps of one solve share (``None``: they need none)."""
        ...

    def sweep_max(
        self,
        v: np.ndarray,
        out: np.ndarray,
        arg: np.ndarray,
        *,
        work: np.ndarray | None = None,
        nchunks: int | None = None,
    ) -> tuple[float, float]:
        """``out = T v``, the first maximising choice in ``arg``; the min and max of
        ``out - v``."""
        ...

    def sweep_policy(
        self,
        sel: np.ndarray,
        v: np.ndarray,
        out: np.ndarray,
        *,
        work: np.ndarray | None = None,
        nchunks: int | None = None,
    ) -> tuple[float, float]:
        """``out = T_pi v`` for the choices ``sel``; the min and max of ``out - v``."""
        ...

    def evaluator(self, work: np.ndarray | None = None) -> PolicySweeps:
        """MPI's evaluation sweeps: one policy at a time (:class:`PolicySweeps`)."""
        ...


@dataclass(frozen=True, eq=False)
class BellmanRows:
    r"""A system of Bellman rows ``v(owner_r) >= reward_r + discount * sum_l p_{r,l} v(k_{r,l})``.

    Rows are sorted by (owner, action); ``indptr`` gives each owner's slice, so every
    owner ``i`` has rows ``indptr[i]:indptr[i+1]`` (at least one).

    Attributes
    ----------
    n_vars : int
        Number of variables (states for exact rows, partitions for aggregated ones).
    indptr : ndarray (n_vars + 1,)
    owner, action : ndarray (R,)
    reward : ndarray (R,)
    targets : ndarray (R, L)
    probs : ndarray (R, L)
        Possibly a read-only broadcast view when every row shares one distribution.
    discount : float
    pair_row : ndarray (n_states, A) or None
        For rows built from an MDP, the row each allowed (state, action) pair became
        (-1 for disallowed pairs): the map used to report duals as the paper's ``mu``.
    pair_tight : ndarray (n_states, A) or None
        False for a pair whose row was merged into one with a strictly larger
        reward (``reduce="max"``) or smaller reward (``reduce="min"``), i.e. a pair whose
        own inequality is implied by (or, for ``min``, implies) the kept row.
    """

    n_vars: int
    indptr: np.ndarray
    owner: np.ndarray
    action: np.ndarray
    reward: np.ndarray
    targets: np.ndarray
    probs: np.ndarray
    discount: float
    pair_row: np.ndarray | None = None
    pair_tight: np.ndarray | None = None

    # ------------------------------------------------------------------ builders
    @classmethod
    def from_arrays(
        cls,
        owner: Any,
        action: Any,
        reward: Any,
        targets: Any,
        probs: Any,
        discount: float,
        n_vars: int,
    ) -> BellmanRows:
        """Build a row system from arrays (sorted here by owner, then action).

        Raises
        ------
        ValidationError
            If shapes disagree, an index is out of range, a row's probabilities are
            negative or do not sum to one, or some owner has no row.
        """
        n_vars = check_int("n_vars", n_vars, lo=1)
        owner = check_array("owner", owner, integer=True, ndim=1)
        n_rows = owner.shape[0]
        targets = check_array("targets", targets, integer=True)
        if targets.ndim != 2 or targets.shape[0] != n_rows:
            raise ValidationError(f"targets must have shape ({n_rows}, L); got {targets.shape}")
        probs = as_float_array("probs", probs)
        if probs.ndim == 1:
            probs = np.broadcast_to(probs, targets.shape)
        if probs.shape != targets.shape:
            raise ValidationError(f"probs must have shape {targets.shape}; got {probs.shape}")
        reward = as_float_array("reward", reward)
        action = check_array("action", action, integer=True)
        if reward.shape != (n_rows,) or action.shape != (n_rows,):
            raise ValidationError("owner, action and reward must have the same length")
        lam = check_discount(discount)  # FiniteMDP's rule (lpbounds.validation)
        check_indices("owner", owner, n_vars)
        check_indices("targets", targets, n_vars)
        check_indices("action", action, np.iinfo(np.int32).max)
        if not np.all(np.isfinite(probs)):
            raise ValidationError("probs must be finite")
        check_rows("probs", probs, lam)  # the rule FiniteMDP applies (lpbounds.stochastic)
        if (probs < 0).any():
            probs = np.clip(probs, 0.0, None)
        check_value_scale(float(np.abs(reward).max(initial=0.0)), lam, "reward")
        order = np.lexsort((action, owner))
        idt = index_dtype(n_vars)
        return cls._finish(
            n_vars,
            owner[order].astype(idt),
            action[order].astype(np.int32),
            reward[order],
            targets[order].astype(idt),
            probs if probs.strides[0] == 0 else probs[order],
            lam,
        )

    @classmethod
    def _finish(
        cls,
        n_vars: int,
        owner: np.ndarray,
        action: np.ndarray,
        reward: np.ndarray,
        targets: np.ndarray,
        probs: np.ndarray,
        discount: float,
        pair_row: np.ndarray | None = None,
        pair_tight: np.ndarray | None = None,
    ) -> BellmanRows:
        counts = np.bincount(owner, minlength=n_vars)
        if (counts == 0).any():
            i = int(np.flatnonzero(counts == 0)[0])
            raise ValidationError(
                f"variable {i} owns no Bellman row ({int((counts == 0).sum())} such): "
                "it would be unbounded below"
            )
        indptr = np.zeros(n_vars + 1, dtype=np.int64)
        np.cumsum(counts, out=indptr[1:])
        return cls(
            n_vars=int(n_vars),
            indptr=indptr,
            owner=owner,
            action=action,
            reward=reward,
            targets=targets,
            probs=probs,
            discount=float(discount),
            pair_row=pair_row,
            pair_tight=pair_tight,
        )

    @classmethod
    def from_mdp(cls, mdp: FiniteMDP) -> BellmanRows:
        """The exact rows (eq. 5): one per allowed (state, action), owner = the state.

        When every action is allowed everywhere the arrays are views of the MDP's.
        """
        n, n_actions, n_out = mdp.successors.shape
        probs_full = mdp.probabilities_full()
        pair_row = np.full((n, n_actions), -1, dtype=np.int64)
        if mdp.allowed.all():
            owner = np.repeat(np.arange(n, dtype=index_dtype(n)), n_actions)
            action = np.tile(np.arange(n_actions, dtype=np.int32), n)
            reward = mdp.rewards.reshape(-1)
            targets = mdp.successors.reshape(-1, n_out)
            if mdp.shared_probabilities:
                probs = np.broadcast_to(mdp.probabilities, (n * n_actions, n_out))
            else:
                probs = probs_full.reshape(-1, n_out)
            pair_row[:] = np.arange(n * n_actions).reshape(n, n_actions)
        else:
            xs, us = np.nonzero(mdp.allowed)
            owner = xs.astype(index_dtype(n))
            action = us.astype(np.int32)
            reward = mdp.rewards[xs, us]
            targets = mdp.successors[xs, us]
            if mdp.shared_probabilities:
                probs = np.broadcast_to(mdp.probabilities, (xs.size, n_out))
            else:
                probs = probs_full[xs, us]
            pair_row[xs, us] = np.arange(xs.size)
        tight = mdp.allowed.copy()
        return cls._finish(n, owner, action, reward, targets, probs, mdp.discount, pair_row, tight)

    @classmethod
    def aggregate(cls, mdp: FiniteMDP, partition: Partition, reduce: Reduce = "max") -> BellmanRows:
        """The aggregated rows of the restricted LP (eq. 9): ``f-bar`` in place of ``f``.

        Row of pair ``(x, u)``: owner ``i`` (the partition of ``x``), reward ``R_u(x)``,
        targets ``f-bar(x, u, Y_l)``. Each row's outcomes are merged by target and
        sorted; rows of the same owner and action with the same successor
        distribution are merged into one, keeping the largest reward
        (``reduce="max"``: the other rows are implied, as in RLP) or the smallest
        (``reduce="min"``: the disjunctive NLP's terms, eq. 25).

        With ``reduce="min"`` the rows of ``(i, u)`` are dropped altogether when ``u``
        is not allowed at every state of ``S_i`` (such a state contributes a term
        ``-inf`` to the disjunction's min: see "Action sets" in the module docstring);
        their pairs get ``pair_row = -1``.

        Parameters
        ----------
        mdp : FiniteMDP
        partition : Partition
            Must have ``mdp.n_states`` states.
        reduce : {"max", "min"}

        Returns
        -------
        BellmanRows
            With ``pair_row``/``pair_tight`` mapping every pair to its merged row.

        Raises
        ------
        ValidationError
            With ``reduce="min"``, if the states of some partition share no allowed
            action (the NLP's bound on it would be ``-inf``); the message names the
            partition and its states' action sets.
        """
        if partition.n_states != mdp.n_states:
            raise ValidationError(
                f"the partition has {partition.n_states} states but the MDP has {mdp.n_states}"
            )
        if reduce not in ("max", "min"):
            raise ValidationError(f"reduce must be 'max' or 'min'; got {reduce!r}")
        exact = cls.from_mdp(mdp)
        m = partition.n_partitions
        idt = index_dtype(m)
        n_rows, n_out = exact.targets.shape
        labels = partition.labels.astype(idt)
        owner = np.empty(n_rows, dtype=idt)
        targets = np.empty((n_rows, n_out), dtype=idt)
        probs = np.empty((n_rows, n_out), dtype=np.float64)
        oa = np.empty(n_rows, dtype=np.int64)
        key = np.empty(n_rows, dtype=np.uint64)
        agg = _backend.kernels()
        agg.canonical_rows(
            labels, exact.owner, exact.action, exact.targets, exact.probs, mdp.n_actions,
            owner, targets, probs, oa, key,
        )  # fmt: skip
        order, offsets = agg.bucket_order(oa, m * mdp.n_actions)
        agg.sort_buckets(order, offsets, key)
        new = np.empty(n_rows, dtype=bool)
        if agg.mark_groups(order, oa, key, targets, probs.view(np.int64), new):
            # a 64-bit hash collision between different rows: group exactly instead
            group, _ = _group_rows(owner, exact.action, targets, probs)
            order = np.lexsort((group, exact.action, owner))
            new = np.r_[True, np.diff(group[order]) != 0]
        # groups are contiguous in `order` and sorted by (owner, action)
        starts = np.append(np.flatnonzero(new), n_rows)
        n_groups = starts.size - 1
        group = np.empty(n_rows, dtype=np.int64)
        reward_merged = np.empty(n_groups)
        g_owner = np.empty(n_groups, dtype=idt)
        g_action = np.empty(n_groups, dtype=np.int32)
        g_t = np.empty((n_groups, n_out), dtype=idt)
        g_p = np.empty((n_groups, n_out))
        agg.merge_groups(
            order, starts, exact.reward, reduce == "max", owner, exact.action, targets, probs,
            group, reward_merged, g_owner, g_action, g_t, g_p,
        )  # fmt: skip
        del targets, probs, owner, key, oa, order
        if reduce == "min" and not mdp.allowed.all():
            keep = _common_actions(mdp, partition)[g_owner, g_action]
            if not keep.all():
                renumber = np.cumsum(keep) - 1
                renumber[~keep] = -1
                group = renumber[group]
                g_owner, g_action, reward_merged = (
                    g_owner[keep],
                    g_action[keep],
                    reward_merged[keep],
                )
                g_t, g_p = g_t[keep], g_p[keep]
            _check_every_partition_kept(mdp, partition, g_owner)
        assert exact.pair_row is not None  # exact rows of an MDP carry the pair map
        pair_row = np.full(exact.pair_row.shape, -1, dtype=np.int64)
        allowed = exact.pair_row >= 0
        pair_row[allowed] = group[exact.pair_row[allowed]]
        tight = np.zeros(pair_row.shape, dtype=bool)
        kept = pair_row >= 0
        tight[kept] = exact.reward[exact.pair_row[kept]] == reward_merged[pair_row[kept]]
        return cls._finish(
            m, g_owner, g_action, reward_merged, g_t, g_p, mdp.discount, pair_row, tight
        )

    # ------------------------------------------------------------------ properties
    @property
    def n_rows(self) -> int:
        """Number of rows ``R``."""
        return int(self.owner.shape[0])

    @property
    def n_outcomes(self) -> int:
        """Outcomes per row ``L`` (padded with probability 0)."""
        return int(self.targets.shape[1])

    @property
    def reads(self) -> int:
        """Values a sweep reads, ``R * L``."""
        return self.n_rows * self.n_outcomes

    @property
    def compiled(self) -> bool:
        """True: the sweeps are C (:mod:`lpbounds._kernels.dispatch`), at every size."""
        return True

    @property
    def sweep_reads(self) -> int:
        """Values a sweep reads (:class:`SweepOperator`): :attr:`reads`."""
        return self.reads

    def kernels(self) -> Any:
        """The kernel module of Q-values and the game operator.

        Returns
        -------
        module
            :func:`lpbounds._kernels.dispatch.kernels` (C).
        """
        return _backend.kernels()

    def sweeps(self) -> Any:
        """The sweep module: :func:`lpbounds._kernels.dispatch.row_sweeps` (the C row
        sweeps)."""
        return _backend.row_sweeps()

    def __repr__(self) -> str:
        return (
            f"BellmanRows(n_vars={self.n_vars}, n_rows={self.n_rows}, "
            f"n_outcomes={self.n_outcomes}, discount={self.discount})"
        )

    # ------------------------------------------------------------------ operators
    def row_sums(self) -> RowSums:
        """Certified bounds on the exact sums of the rows' probabilities
        (:class:`lpbounds.stochastic.RowSums`): the contraction modulus of every operator
        of these rows is ``row_sums().modulus(discount)``."""
        return row_sums(self.probs)

    def as_vector(self, v: Any, name: str = "v") -> np.ndarray:
        """``v`` as a float64 vector of length ``n_vars``.

        The dtype and length are checked before the cast; finiteness is the caller's check,
        done once at its boundary.

        Parameters
        ----------
        v : array_like
            The vector.
        name : str
            Its name in error messages.

        Returns
        -------
        numpy.ndarray
            float64, shape ``(n_vars,)``.

        Raises
        ------
        ValidationError
            On a wrong dtype or length.
        """
        return check_vector(name, v, self.n_vars, finite=False)

    def q_values(self, v: Any) -> np.ndarray:
        """``q_r(v) = reward_r + discount * sum_l probs_{r,l} v(targets_{r,l})`` per row."""
        out = np.empty(self.n_rows)
        self.kernels().q_values(
            self.reward, self.targets, self.probs, self.discount, self.as_vector(v), out
        )
        return out

    def apply_max(self, v: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(Tv)(i) = max_{r of i} q_r(v)`` and the first maximising row of each owner."""
        out = np.empty(self.n_vars)
        arg = np.empty(self.n_vars, dtype=np.int64)
        self.sweep_max(self.as_vector(v), out, arg)
        return out, arg

    def apply_maxmin(self, v: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(Gv)(i) = max_u min_{r in (i, u)} q_r(v)`` and the minimising row of the best ``u``."""
        out = np.empty(self.n_vars)
        arg = np.empty(self.n_vars, dtype=np.int64)
        self.kernels().bellman_maxmin(
            self.indptr,
            self.action,
            self.reward,
            self.targets,
            self.probs,
            self.discount,
            self.as_vector(v),
            out,
            arg,
        )
        return out, arg

    # ------------------------------------------------------------------ sweep protocol
    # fused sweeps of the DP loops (SweepOperator): write into ``out`` and return the
    # extremes of ``out - v`` (no validation: the hot path; the callers check once)
    def new_vector(self) -> np.ndarray:
        """An uninitialised float64 vector over the owners."""
        return np.empty(self.n_vars)

    def new_arg(self) -> np.ndarray:
        """A zeroed array for the chosen row of every owner (int64)."""
        return np.zeros(self.n_vars, dtype=np.int64)

    def new_work(self) -> None:
        """No scratch array: the row sweeps read the values in place."""
        return None

    def sweep_max(
        self,
        v: np.ndarray,
        out: np.ndarray,
        arg: np.ndarray,
        *,
        work: np.ndarray | None = None,
        nchunks: int | None = None,
    ) -> tuple[float, float]:
        """``out = T v``, the first maximising row of each owner in ``arg``; returns the
        min and max of ``out - v`` (``work`` and ``nchunks`` are unused: the row sweeps
        split the owners one range per thread)."""
        lo, hi = self.sweeps().bellman_max_stats(
            self.indptr, self.reward, self.targets, self.probs, self.discount, v, out, arg
        )
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
        """``out[i] = q_{sel[i]}(v)``; returns the min and max of ``out - v``. ``reward``
        replaces the rows' rewards (:meth:`zero_rewards`: ``discount * P_pi v``);
        ``work`` and ``nchunks`` are unused, as in :meth:`sweep_max`."""
        rew = self.reward if reward is None else reward
        lo, hi = self.sweeps().policy_sweep_stats(
            sel, rew, self.targets, self.probs, self.discount, v, out
        )
        return float(lo), float(hi)

    def evaluator(self, work: np.ndarray | None = None) -> PolicySweeps:
        """Evaluation sweeps of one policy at a time, on its rows packed (:class:`PackedSweeps`)."""
        return PackedSweeps(self)

    def zero_rewards(self) -> np.ndarray:
        """Zeros in the layout of the rewards: ``sweep_policy(..., reward=zeros)`` computes
        ``discount * P_pi v`` (the product of inexact policy iteration, :mod:`lpbounds.dp`)."""
        return np.zeros(self.n_rows)

    def self_loops(self, sel: np.ndarray) -> np.ndarray:
        """``P_pi(i, i)``: the probability that row ``sel[i]`` stays at its owner ``i``."""
        stay = self.targets[sel] == np.arange(self.n_vars)[:, None]
        return (np.asarray(self.probs)[sel] * stay).sum(axis=1)

    def sweep_maxmin(self, v: np.ndarray, out: np.ndarray, arg: np.ndarray) -> tuple[float, float]:
        """``out = G v`` (the game operator of :meth:`apply_maxmin`), the minimising row of
        the best action in ``arg``; returns the min and max of ``out - v``."""
        self.kernels().bellman_maxmin(
            self.indptr,
            self.action,
            self.reward,
            self.targets,
            self.probs,
            self.discount,
            v,
            out,
            arg,
        )
        d = out - v
        return float(d.min()), float(d.max())

    def evaluate_rows(self, rows: np.ndarray, v: Any) -> np.ndarray:
        """One policy-evaluation sweep: ``out[i] = q_{rows[i]}(v)``."""
        out = np.empty(self.n_vars)
        self.sweep_policy(np.ascontiguousarray(rows, dtype=np.int64), self.as_vector(v), out)
        return out

    def violation(self, v: Any) -> float:
        """``max_r (q_r(v) - v(owner_r))_+``: how far ``v`` is from satisfying every row."""
        vv = self.as_vector(v)
        return float(max(0.0, (self.q_values(vv) - vv[self.owner]).max()))

    # ------------------------------------------------------------------ LP data
    def constraint_matrix(self) -> tuple[sp.csr_matrix, np.ndarray]:
        """``(A, b)`` with the rows as ``A v >= b``: ``A = E - discount * P``, ``b = reward``.

        ``E[r, owner_r] = 1`` and ``P[r, k] = sum of probs_{r,l}`` with ``targets_{r,l} = k``;
        zero-probability padding is dropped.
        """
        import scipy.sparse as sp

        n_rows, n_out = self.targets.shape
        probs = np.asarray(self.probs)
        keep = probs != 0.0
        rows = np.concatenate(
            [np.arange(n_rows), np.broadcast_to(np.arange(n_rows)[:, None], (n_rows, n_out))[keep]]
        )
        cols = np.concatenate([self.owner, self.targets[keep]])
        data = np.concatenate([np.ones(n_rows), -self.discount * probs[keep]])
        a = sp.csr_matrix((data, (rows, cols)), shape=(n_rows, self.n_vars))
        a.sum_duplicates()
        return a, np.array(self.reward)

    def transition_matrix(self, rows: np.ndarray) -> sp.csr_matrix:
        """The (n_vars, n_vars) transition matrix of the policy choosing ``rows[i]`` at ``i``."""
        import scipy.sparse as sp

        rows = np.asarray(rows, dtype=np.int64)
        probs = np.asarray(self.probs)[rows]
        cols = self.targets[rows]
        r_idx = np.broadcast_to(np.arange(self.n_vars)[:, None], cols.shape)
        keep = probs != 0.0
        m = sp.csr_matrix(
            (probs[keep], (r_idx[keep], cols[keep])), shape=(self.n_vars, self.n_vars)
        )
        m.sum_duplicates()
        return m

    def pair_values(self, row_values: Any) -> np.ndarray:
        """Spread per-row numbers (e.g. LP duals) over the (state, action) pairs.

        A merged row's value is split equally among its tight pairs; non-tight and
        disallowed pairs get 0. For LP duals this gives the paper's ``mu_u^i(x)``: an
        optimal dual of the unmerged LP (any split of a merged row's dual among
        identical rows is optimal, and dominated rows have zero dual).
        """
        if self.pair_row is None or self.pair_tight is None:
            raise ValidationError("these rows were not built from an MDP: no pair map")
        vals = np.asarray(row_values, dtype=np.float64)
        if vals.shape != (self.n_rows,):
            raise ValidationError(f"expected {self.n_rows} row values; got {vals.shape}")
        tight_rows = self.pair_row[self.pair_tight]
        counts = np.bincount(tight_rows, minlength=self.n_rows)
        out = np.zeros(self.pair_row.shape)
        share = np.divide(vals, counts, out=np.zeros_like(vals), where=counts > 0)
        out[self.pair_tight] = share[tight_rows]
        return out


class PolicySweeps:
    """Evaluation sweeps of the policy last set: ``set_policy(arg)`` with the ``arg`` of an
    improvement sweep, then ``sweep(v, out)`` writes ``T_pi v`` and returns the extremes
    of ``T_pi v - v`` (what MPI runs between improvements).

    Parameters
    ----------
    ops : SweepOperator
        Swept in place by :meth:`SweepOperator.sweep_policy`.
    work : ndarray, optional
        The operator's scratch array (:meth:`SweepOperator.new_work`).
    nchunks : int, optional
        Work chunks of the compiled kernels (default: the operator's choice per sweep).
    """

    def __init__(
        self, ops: SweepOperator, work: np.ndarray | None = None, nchunks: int | None = None
    ) -> None:
        self.ops = ops
        self.work = work
        self.nchunks = nchunks
        self.arg: np.ndarray | None = None

    def set_policy(self, arg: np.ndarray) -> None:
        """Sweep the choices ``arg`` from now on (read at every sweep: not copied)."""
        self.arg = arg

    def sweep(self, v: np.ndarray, out: np.ndarray) -> tuple[float, float]:
        """``out = T_pi v``; returns the min and max of ``out - v``."""
        assert self.arg is not None
        return self.ops.sweep_policy(self.arg, v, out, work=self.work, nchunks=self.nchunks)


class PackedSweeps(PolicySweeps):
    """Evaluation sweeps on the policy's rows gathered into contiguous arrays.

    A row system's rows of owner ``i`` sit together, so ``T_pi`` read in place hops over
    the rows of the other actions and streams about ``A`` times the data it uses. One
    gather per policy (the rows ``arg[i]`` into slot ``i``: rewards, targets, and the
    probabilities unless one distribution is shared) makes every later sweep stream only
    its own rows. Each row is then computed by the same kernel with the same arithmetic,
    so the numbers are identical to the in-place sweep's. Measured on the 2,048,000 x 3 x 5
    garnet (docs/benchmarks.md, "Peers"): a sweep 26 ms against 34 ms on two threads (52
    against 71 on one), the gather 9 ms; MPI does five sweeps per gather.
    """

    def __init__(self, ops: BellmanRows, nchunks: int | None = None) -> None:
        super().__init__(ops, nchunks=nchunks)
        self.rows = ops
        n, n_out = ops.n_vars, ops.n_outcomes
        probs = np.asarray(ops.probs)
        self.shared = probs.ndim == 2 and probs.strides[0] == 0
        self.reward = np.empty(n)
        self.targets = np.empty((n, n_out), dtype=ops.targets.dtype)
        self.probs = probs[:n] if self.shared else np.empty((n, n_out))
        # gather_rows writes no probabilities when they are shared; it is still typed with
        # a writable array (the broadcast view is read-only)
        self._probs_out = np.empty((0, n_out)) if self.shared else self.probs

    def set_policy(self, arg: np.ndarray) -> None:
        """Gather the rows ``arg`` (one per owner) into the packed arrays."""
        rows = self.rows
        rows.sweeps().gather_rows(
            arg, rows.reward, rows.targets, rows.probs, self.reward, self.targets,
            self._probs_out, not self.shared,
        )  # fmt: skip

    def sweep(self, v: np.ndarray, out: np.ndarray) -> tuple[float, float]:
        """``out = T_pi v`` on the packed rows; returns the min and max of ``out - v``."""
        rows = self.rows
        lo, hi = rows.sweeps().policy_sweep_stats(
            None, self.reward, self.targets, self.probs, rows.discount, v, out
        )
        return float(lo), float(hi)


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
        w = self.new_work() if work is None else work
        kern = self.kernels()
        kern.ps_expect(self.outcomes, self.probs, v, w)
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
        w = self.new_work() if work is None else work
        kern = self.kernels()
        kern.ps_expect(self.outcomes, self.probs, v, w)
        if self.reward_codes is not None:
            table = self.reward_table if reward is None else reward
            lo, hi = kern.ps_policy_stats_coded(
                self.first, self.reward_codes, table, sel, w, self.discount, v, out
            )
        else:
            rew = self.reward if reward is None else reward
            lo, hi = kern.ps_policy_stats(self.first, rew, sel, w, self.discount, v, out)
        return float(lo), float(hi)

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


def _common_actions(mdp: FiniteMDP, partition: Partition) -> np.ndarray:
    """``(M, A)`` bool: action ``u`` is allowed at every state of ``S_i``."""
    labels = partition.labels
    m = partition.n_partitions
    sizes = np.bincount(labels, minlength=m)
    count = np.empty((m, mdp.n_actions), dtype=np.int64)
    for u in range(mdp.n_actions):
        count[:, u] = np.bincount(labels[mdp.allowed[:, u]], minlength=m)
    return count == sizes[:, None]


def _check_every_partition_kept(mdp: FiniteMDP, partition: Partition, owner: np.ndarray) -> None:
    """A ValidationError naming the first partition left without a row by the action-set rule."""
    counts = np.bincount(owner, minlength=partition.n_partitions)
    empty = np.flatnonzero(counts == 0)
    if empty.size == 0:
        return
    i = int(empty[0])
    states = np.flatnonzero(partition.labels == i)
    shown = ", ".join(
        f"{int(x)}: {np.flatnonzero(mdp.allowed[x]).tolist()}" for x in states[:6]
    ) + (", ..." if states.size > 6 else "")
    raise ValidationError(
        f"partition {i} has no action allowed at all of its {states.size} states (allowed "
        f"actions by state: {shown}); {empty.size} partition(s) like this. The disjunctive "
        f"NLP (eq. 25) keeps (i, u) only when u is allowed at every state of S_i, so it puts "
        f"no constraint on w({i}) and its lower bound on min over S_{i} of V* is -inf. "
        "Refine the partition so that the states of each part share an allowed action."
    )


def _group_rows(
    owner: np.ndarray, action: np.ndarray, targets: np.ndarray, probs: np.ndarray
) -> tuple[np.ndarray, int]:
    """Group id of each row by equal (owner, action, targets, probs), exactly.

    A 64-bit hash sorts the rows; equal hashes are then checked entry by entry and, in
    the (astronomically rare) event of a collision, ``np.unique`` decides instead.
    """
    n_rows = owner.shape[0]
    if n_rows == 0:
        return np.zeros(0, dtype=np.int64), 0
    pbits = np.ascontiguousarray(probs).view(np.int64)
    h = np.empty(n_rows, dtype=np.uint64)
    _backend.kernels().hash_rows(owner, action, targets, pbits, h)
    order = np.argsort(h, kind="stable")
    hs = h[order]
    same = hs[1:] == hs[:-1]
    a, b = order[1:][same], order[:-1][same]
    exact = (
        np.array_equal(owner[a], owner[b])
        and np.array_equal(action[a], action[b])
        and np.array_equal(targets[a], targets[b])
        and np.array_equal(pbits[a], pbits[b])
    )
    if not exact:  # hash collision: fall back to an exact sort of the keys
        keys = np.column_stack([owner, action, targets, pbits]).astype(np.int64)
        _, inv = np.unique(keys, axis=0, return_inverse=True)
        inv = inv.ravel()
        return inv.astype(np.int64), int(inv.max()) + 1
    new = np.r_[True, ~same]
    gid_sorted = np.cumsum(new) - 1
    group = np.empty(n_rows, dtype=np.int64)
    group[order] = gid_sorted
    return group, int(gid_sorted[-1]) + 1
