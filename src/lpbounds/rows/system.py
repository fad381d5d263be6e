r"""Systems of Bellman rows: the one structure every formulation in lpbounds is made of.

A *Bellman row* ``r`` constrains one variable, its *owner* ``i``:

.. math:: v(i) \;\ge\; \rho_r + \lambda \sum_{l} p_{r,l}\, v(k_{r,l}).

* The exact LP (eq. 8) has one row per allowed (state, action): owner ``x``,
  reward ``R_u(x)``, targets ``f(x, u, Y_l)``.
* The restricted LP (eq. 9) has the same rows with every state replaced by its
  partition: owner ``i`` with ``x`` in ``S_i``, targets ``f-bar(x, u, Y_l)``. Rows that
  become identical are merged (:meth:`BellmanRows.aggregate`, :mod:`lpbounds.rows.aggregation`).
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


The kernels that apply ``T`` and ``G`` are C (:mod:`lpbounds._kernels.native`,
:mod:`lpbounds._kernels.ckernels`, named by :mod:`lpbounds._kernels.dispatch`); their numpy
twins (:mod:`lpbounds._kernels.twins`, the same numbers) are the tests' reference.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

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
from .aggregation import merge_rows
from .sweep import PolicySweeps

if TYPE_CHECKING:  # scipy.sparse is imported where a matrix is built (0.1 s at start-up)
    import scipy.sparse as sp

__all__ = ["BellmanRows", "PackedSweeps", "Reduce"]

#: How :meth:`BellmanRows.aggregate` merges rows of one (owner, action) and distribution.
Reduce = Literal["max", "min"]


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
        ``-inf`` to the disjunction's min: see "Action sets" in :mod:`lpbounds.rows.aggregation`);
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
        g = merge_rows(exact, mdp, partition, reduce)
        return cls._finish(
            g.n_vars, g.owner, g.action, g.reward, g.targets, g.probs, mdp.discount,
            g.pair_row, g.pair_tight,
        )  # fmt: skip

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
        self._maxmin(self.as_vector(v), out, arg)
        return out, arg

    def _maxmin(self, v: np.ndarray, out: np.ndarray, arg: np.ndarray) -> None:
        """``out = G v`` and the minimising row of the best action in ``arg`` (the C kernel
        behind :meth:`apply_maxmin` and :meth:`sweep_maxmin`)."""
        self.kernels().bellman_maxmin(
            self.indptr, self.action, self.reward, self.targets, self.probs, self.discount,
            v, out, arg,
        )  # fmt: skip

    # ------------------------------------------------------------------ sweep protocol
    # intended parallel: the SweepOperator signatures (rows/sweep.py), repeated by each operator
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
        self._maxmin(v, out, arg)
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
