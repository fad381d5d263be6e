r"""The aggregation of rows (:meth:`~lpbounds.rows.BellmanRows.aggregate`): the restricted
LP's rows (eq. 9) and the disjunctive NLP's terms (eq. 25) from an MDP and a partition.

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
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .._kernels import dispatch as _backend
from ..errors import ValidationError
from ..model.mdp import index_dtype

if TYPE_CHECKING:
    from ..model.mdp import FiniteMDP
    from ..model.partition import Partition
    from .system import BellmanRows, Reduce

__all__ = [
    "MergedRows",
    "check_every_partition_kept",
    "common_actions",
    "group_rows",
    "merge_rows",
]


class MergedRows(NamedTuple):
    """The arrays of an aggregated row system, in the order of ``BellmanRows._finish``'s
    first six arguments, and the map of every (state, action) pair to its merged row."""

    n_vars: int
    owner: np.ndarray
    action: np.ndarray
    reward: np.ndarray
    targets: np.ndarray
    probs: np.ndarray
    pair_row: np.ndarray
    pair_tight: np.ndarray


def merge_rows(
    exact: BellmanRows, mdp: FiniteMDP, partition: Partition, reduce: Reduce
) -> MergedRows:
    """The rows of :meth:`BellmanRows.aggregate` from the exact rows of ``mdp`` (checked
    arguments): each row's outcomes merged by partition and sorted (C kernels: canonical
    rows, a counting sort, bucket sorts by a 64-bit key, exact grouping on a collision),
    identical rows merged by ``reduce``, and with ``reduce="min"`` the groups ``(i, u)``
    of an action not allowed at every state of ``S_i`` dropped ("Action sets" above)."""
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
        group, _ = group_rows(owner, exact.action, targets, probs)
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
        keep = common_actions(mdp, partition)[g_owner, g_action]
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
        check_every_partition_kept(mdp, partition, g_owner)
    assert exact.pair_row is not None  # exact rows of an MDP carry the pair map
    pair_row = np.full(exact.pair_row.shape, -1, dtype=np.int64)
    allowed = exact.pair_row >= 0
    pair_row[allowed] = group[exact.pair_row[allowed]]
    tight = np.zeros(pair_row.shape, dtype=bool)
    kept = pair_row >= 0
    tight[kept] = exact.reward[exact.pair_row[kept]] == reward_merged[pair_row[kept]]
    return MergedRows(m, g_owner, g_action, reward_merged, g_t, g_p, pair_row, tight)


def common_actions(mdp: FiniteMDP, partition: Partition) -> np.ndarray:
    """``(M, A)`` bool: action ``u`` is allowed at every state of ``S_i``."""
    labels = partition.labels
    m = partition.n_partitions
    sizes = np.bincount(labels, minlength=m)
    count = np.empty((m, mdp.n_actions), dtype=np.int64)
    for u in range(mdp.n_actions):
        count[:, u] = np.bincount(labels[mdp.allowed[:, u]], minlength=m)
    return count == sizes[:, None]


def check_every_partition_kept(mdp: FiniteMDP, partition: Partition, owner: np.ndarray) -> None:
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


def group_rows(
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
