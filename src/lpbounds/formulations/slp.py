r"""The surrogate LP of the restricted LP (paper eq. 12 / SLP1 in Appendix C).

.. math::

    \begin{array}{l}
    SLP(\mu) := \min \bar c^T v \quad\text{s.t.} \\
    \qquad \sum_{x \in S_i} \mu_u^i(x)\, v(i) \ge \sum_{x \in S_i} \mu_u^i(x)
    \Big[R_u(x) + \lambda \sum_{l=0}^m p_l\, v(\bar f(x, u, Y_l))\Big]
    \quad \forall u,\ i.
    \end{array}

Each surrogate row is a non-negative combination of RLP's rows of ``(i, u)``, so every
RLP-feasible ``v`` is SLP-feasible and ``SLP(mu) <= RLP`` (a relaxation). Dividing a row
with ``sum_x mu_u^i(x) > 0`` by that sum gives eq. SLPB: the Bellman row of the *reduced
MDP* of step 2 of Theorem 1's proof, with ``h_u^i(x) = mu_u^i(x) / sum_{x in S_i}
mu_u^i(x)`` and

.. math::

    \begin{array}{l}
    r_u(i) = \sum_{x \in S_i} h_u^i(x) R_u(x), \qquad
    \tilde P_u(i, j) = \sum_{x \in S_i} h_u^i(x) \sum_{y \in S_j} P_u(x, y), \\
    u \in U_i \iff \sum_{x \in S_i} \mu_u^i(x) > 0.
    \end{array}

So ``SLP(mu)`` is the exact LP of that reduced MDP; by Fact 1 of :mod:`lpbounds.rows.system`
its optimum, for every ``c >= 0``, is the reduced MDP's value
(:meth:`SLP.fixed_point`). Rows with zero total weight (``0 >= 0``) are dropped.

Lemma 2: for an optimal dual ``mu-bar`` of RLP, ``SLP(mu-bar) = RLP``, and the reduced
MDP's value is RLP's ``v*`` (:meth:`SLP.from_rlp`).

Action sets need no special rule here (unlike the disjunctive NLP, whose ``(i, u)`` is
kept only when ``u`` is allowed at every state of ``S_i``; see "Action sets" in
:mod:`lpbounds.rows.aggregation`): ``mu`` must vanish on disallowed pairs (checked), so each
surrogate row combines only RLP rows that exist, and ``u in U_i`` as soon as *some* state
of ``S_i`` allows ``u`` with positive weight. That keeps ``SLP(mu)`` a relaxation of RLP
for every ``mu`` and keeps Lemma 2 (RLP's pair duals are zero on disallowed pairs).

.. warning::
   For an arbitrary ``mu`` the SLP is only a relaxation of RLP: its optimum is
   *below* ``v*`` and is **not** an upper bound on ``V*`` in general. In particular
   ``mu="uniform"`` (``mu_u^i(x) = 1/|S_i|``, Remark 1) is Bertsekas' *hard
   aggregation*, an approximation that can lie below ``V*`` (shown in the tests).

The paper's step 1 ("for every ``i`` some ``u`` has ``sum_x mu-bar_u^i(x) > 0``") needs
``c-bar(i) > 0`` (or ``i`` reachable from a partition with positive cost): a partition of
zero cost that nothing leads to can get zero dual weight, and then ``SLP(mu-bar)`` has
no row for it. lpbounds raises :class:`~lpbounds.errors.ValidationError` naming the
partition in that case instead of building an unbounded LP.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..certification.certificate import Certificate
from ..errors import ValidationError
from ..model.checks import check_formulation_inputs, sink_block_note
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from ..rows import BellmanRows
from .base import LPResult, aggregated_cost
from .rows_lp import RowsLP

__all__ = ["SLP"]


def _check_mu(mu: Any, mdp: FiniteMDP, partition: Partition) -> np.ndarray:
    n, n_actions = mdp.n_states, mdp.n_actions
    if isinstance(mu, str):
        if mu != "uniform":
            raise ValidationError(
                f"mu must be an (n_states, n_actions) array or 'uniform'; got {mu!r}"
            )
        w = (1.0 / partition.sizes)[partition.labels]
        return np.where(mdp.allowed, w[:, None], 0.0)
    arr = np.asarray(mu, dtype=np.float64)
    if arr.shape != (n, n_actions):
        raise ValidationError(
            f"mu must have shape (n_states, n_actions) = {(n, n_actions)}; got {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        x, u = (int(t) for t in np.argwhere(~np.isfinite(arr))[0])
        raise ValidationError(f"mu[{x}, {u}] = {arr[x, u]} is not finite")
    if (arr < 0).any():
        x, u = (int(t) for t in np.argwhere(arr < 0)[0])
        raise ValidationError(f"mu[{x}, {u}] = {arr[x, u]} is negative; mu must be >= 0")
    bad = (arr > 0) & ~mdp.allowed
    if bad.any():
        x, u = (int(t) for t in np.argwhere(bad)[0])
        raise ValidationError(f"mu[{x}, {u}] > 0 but action {u} is not allowed in state {x}")
    return arr


class SLP(RowsLP):
    r"""The surrogate LP ``SLP(mu)`` of RLP (eq. 12): RLP's rows aggregated with weights ``mu``.

    ``SLP(mu) := min c-bar' v  s.t.  sum_{x in S_i} mu_u^i(x) v(i) >= sum_{x in S_i}
    mu_u^i(x) [R_u(x) + lambda sum_l p_l v(f-bar(x, u, Y_l))]  for all u, i``.

    It is the exact LP of the reduced MDP (:meth:`reduced_mdp`), so its optimum is that
    MDP's value for every ``c >= 0``. With RLP's optimal duals (:meth:`from_rlp`) this
    is RLP's ``v*`` (Lemma 2), an upper bound on ``V*``; for any other ``mu`` it is a
    relaxation of RLP (optimum ``<= v*``) and **not** a bound on ``V*`` in general
    (``mu="uniform"`` is hard aggregation, Remark 1).

    Parameters
    ----------
    mdp : FiniteMDP
    partition : Partition
    mu : array_like (n_states, n_actions) or "uniform"
        Non-negative weights ``mu_u^i(x)`` (``x`` in ``S_i``), zero on disallowed
        pairs. Every partition needs a positive weight on some pair.
    cost : array_like (n_states,), optional
        ``c(x) >= 0`` (default ones); the objective is ``c-bar' v``.

    Attributes
    ----------
    mu : ndarray (n_states, n_actions)
    weights : ndarray (n_states, n_actions)
        ``h_u^i(x)``: ``mu`` normalised over each ``(i, u)`` (0 where ``u`` not in ``U_i``).
    row_of_pair : ndarray (n_states, n_actions)
        The surrogate row of each pair (-1 where the weight is zero).
    problem : cvxpy.Problem
        ``min c-bar'v  s.t.  surrogate``.
    v : cvxpy.Variable (M,)
        The paper's ``v`` (``variables["v"]``).
    constraints : dict
        ``"surrogate"``: eq. 12, one row per ``(i, u)`` with positive weight, normalised
        (eq. SLPB: ``v(i) >= r_u(i) + lambda sum_j P-tilde_u(i, j) v(j)``), one sparse
        vector constraint; duals ``result.group_duals["surrogate"]``.

    Notes
    -----
    The result's ``mu`` maps each surrogate row's dual ``y_(i,u)`` back to pairs as
    ``y_(i,u) h_u^i(x)``: a dual of RLP with the same objective (the surrogate row is
    that combination of RLP's rows), hence an optimal RLP dual whenever
    ``SLP(mu) = RLP``.
    """

    name = "SLP"
    group_name = "surrogate"

    def __init__(self, mdp: FiniteMDP, partition: Partition, mu: Any, cost: Any = None) -> None:
        check_formulation_inputs(mdp, partition, cost=cost, mu=None if isinstance(mu, str) else mu)
        cbar = aggregated_cost(mdp, partition, cost, None)
        self.mdp = mdp
        self.partition = partition
        self.partition_note = sink_block_note(mdp, partition)
        self.mu = _check_mu(mu, mdp, partition)
        rows, weights, row_of_pair = _surrogate_rows(mdp, partition, self.mu)
        self.weights = weights
        self.row_of_pair = row_of_pair
        super().__init__(rows, cbar)

    @classmethod
    def from_rlp(cls, result: LPResult, cost: Any = None) -> SLP:
        """``SLP(mu-bar)`` with ``mu-bar`` = the pair duals ``result.mu`` of an RLP solve (Lemma 2).

        Parameters
        ----------
        result : LPResult
            The result of :meth:`RLP.solve <lpbounds.formulations.rlp.RLP.solve>`: its
            ``mu`` (shape (n_states, n_actions)) and its model (``extra["mdp"]``,
            ``extra["partition"]``).
        cost : array_like, optional
            The SLP's cost (default ones; the optimum does not depend on it).
        """
        mdp = result.extra.get("mdp")
        partition = result.extra.get("partition")
        if result.formulation != "RLP" or result.mu is None or mdp is None or partition is None:
            raise ValidationError(
                f"SLP.from_rlp needs the result of RLP(...).solve(); got a {result.formulation} "
                "result"
            )
        if not result.ok:
            raise ValidationError(f"the RLP result has status {result.status}: no optimal duals")
        return cls(mdp, partition, result.mu, cost)

    # ------------------------------------------------------------------ reduced MDP
    def reduced_mdp(self) -> FiniteMDP:
        r"""The reduced MDP of step 2 of Theorem 1's proof (eq. SLPB).

        States are the partitions, actions those of ``mdp`` with ``U_i = {u :
        sum_{x in S_i} mu_u^i(x) > 0}`` (``allowed``), rewards ``r_u(i)`` and outcomes
        the distinct successor partitions of ``P-tilde_u(i, .)`` (padded with
        probability 0).
        """
        rows = self.rows
        m, n_actions = self.partition.n_partitions, self.mdp.n_actions
        width = rows.n_outcomes
        succ = np.repeat(np.arange(m)[:, None, None], n_actions, axis=1)
        succ = np.repeat(succ, width, axis=2)
        probs = np.zeros((m, n_actions, width))
        probs[:, :, 0] = 1.0  # placeholder on disallowed pairs (never read)
        rewards = np.zeros((m, n_actions))
        allowed = np.zeros((m, n_actions), dtype=bool)
        o, a = rows.owner, rows.action
        succ[o, a] = rows.targets
        probs[o, a] = rows.probs
        rewards[o, a] = rows.reward
        allowed[o, a] = True
        return FiniteMDP(succ, probs, rewards, self.mdp.discount, allowed, self.mdp.action_names)

    @property
    def row_rounding(self) -> float:
        """``rho = (2 s (L + 1) + 8) eps``: the surrogate rows are computed in floating point,
        ``h = mu / sum mu`` and sums over a partition's states (``s`` the largest partition,
        ``L`` outcomes each) of ``h p`` and ``h R``; against the exact rows of eq. 12 (SLPB)
        every reward is within ``(2 s + 4) eps max|R|`` and every row's probabilities within
        ``(s L + s + 4) eps`` in sum, so ``|q_r(v) - q~_r(v)| <= rho (max|R| + max|v|)``
        (:meth:`RowsLP.row_rounding <lpbounds.formulations.RowsLP.row_rounding>`)."""
        eps = float(np.finfo(np.float64).eps)
        size = int(self.partition.sizes.max(initial=1))
        return (2.0 * size * (self.mdp.n_outcomes + 1) + 8.0) * eps

    def _certify(self, x: np.ndarray) -> Certificate:
        """The certificate of the computed rows, widened to the exact rows of eq. 12.

        With ``rho`` = :attr:`row_rounding` the two row systems' operators differ by at most
        ``rho (max|R| + max|v|)`` at any ``v``; so their fixed points ``v_f`` (computed
        rows) and ``v~`` (exact) satisfy ``D = ||v~ - v_f|| <= rho (max|R| + B + D) / (1 -
        kappa)`` with ``B`` bounding ``|v_f|`` (the computed bracket's ends), i.e. ``D <=
        rho (max|R| + B) / (1 - kappa - rho)``, added to both sides (rounded up)."""
        cert = super()._certify(x)
        if not np.isfinite(cert.error_bound):
            return cert
        eps = float(np.finfo(np.float64).eps)
        rho = self.row_rounding
        big = float(np.maximum(np.abs(cert.lower), np.abs(cert.upper)).max(initial=0.0))
        den = (1.0 - cert.modulus - rho) * (1.0 - 4.0 * eps)
        widen = rho * (cert.reward_absmax + big) / den * (1.0 + 8.0 * eps)
        return dataclasses.replace(
            cert,
            lower=np.nextafter(cert.lower - widen, -np.inf),
            upper=np.nextafter(cert.upper + widen, np.inf),
            error_bound=float(np.nextafter(cert.error_bound + widen, np.inf)),
            margin=cert.margin + widen * (1.0 - cert.modulus),
        )

    def exact_size(self) -> tuple[int, str]:
        """The partitions (:meth:`Formulation.exact_size`)."""
        return self.partition.n_partitions, "SLP's partitions"

    def exact_lp(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """``(model, lp)``: eq. 12 built by the checker from the MDP, the partition and
        ``mu`` (each double exact) in its unnormalised form: the same feasible set as the
        normalised rows (eq. SLPB) the float LP holds, without their rounding."""
        from ..exact.files import mdp_data
        from ..exact.rationals import RationalVector

        model = mdp_data(self.mdp, self.partition)
        mu = RationalVector.from_fractions(self.mu[self.mdp.allowed]).to_json()
        return model, {"formulation": "SLP", "cost": self.exact_cost(), "mu": mu}

    @property
    def v(self) -> cp.Variable:
        """The cvxpy variable ``v`` (one entry per partition)."""
        return self.variables["v"]

    def _interpret(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
        rp = self.row_of_pair
        mu = np.where(rp >= 0, y[np.maximum(rp, 0)] * self.weights, 0.0)
        return x, self.partition.lift(x), mu, {"row_duals": y}


def _surrogate_rows(
    mdp: FiniteMDP, partition: Partition, mu: np.ndarray
) -> tuple[BellmanRows, np.ndarray, np.ndarray]:
    """Normalised surrogate rows, one per ``(i, u)`` with positive weight, built with sparse ops."""
    n, n_actions, n_out = mdp.successors.shape
    m = partition.n_partitions
    labels = partition.labels.astype(np.int64)
    xs, us = np.nonzero(mu > 0)
    w = mu[xs, us]
    key = labels[xs] * n_actions + us  # (i, u) of each weighted pair
    denom = np.bincount(key, weights=w, minlength=m * n_actions)
    has = (denom > 0).reshape(m, n_actions)
    empty = ~has.any(axis=1)
    if empty.any():
        i = int(np.flatnonzero(empty)[0])
        raise ValidationError(
            f"mu gives partition {i} no positive weight on any of its (state, action) pairs "
            f"({int(empty.sum())} such partitions): SLP(mu) has no row for v({i}) and is "
            "unbounded below (with RLP duals this happens when c-bar(i) = 0 and nothing "
            "leads to partition i; use a positive cost)"
        )
    h = w / denom[key]
    weights = np.zeros((n, n_actions))
    weights[xs, us] = h
    reward = np.bincount(key, weights=h * mdp.rewards[xs, us], minlength=m * n_actions)
    # P-tilde: one COO entry per (weighted pair, outcome), summed by (i, u, target partition)
    p = mdp.probabilities_full()[xs, us] if not mdp.shared_probabilities else mdp.probabilities
    coo_w = (h[:, None] * np.broadcast_to(p, (xs.size, n_out))).ravel()
    coo_r = np.repeat(key, n_out)
    coo_c = labels[mdp.successors[xs, us]].ravel()
    keep = coo_w != 0.0
    ptil = sp.csr_matrix((coo_w[keep], (coo_r[keep], coo_c[keep])), shape=(m * n_actions, m))
    ptil.sum_duplicates()
    live = np.flatnonzero(has.ravel())
    ptil = ptil[live]
    nnz = np.diff(ptil.indptr)
    width = max(int(nnz.max(initial=1)), 1)
    n_rows = live.size
    owner = live // n_actions
    targets = np.repeat(owner[:, None], width, axis=1)
    probs = np.zeros((n_rows, width))
    row_idx = np.repeat(np.arange(n_rows), nnz)
    pos = np.arange(ptil.nnz) - ptil.indptr[row_idx]
    targets[row_idx, pos] = ptil.indices
    probs[row_idx, pos] = ptil.data
    # no renormalisation: a row summing to 1 + 9e-10 in the model keeps that sum here (the
    # stored model's SLP; its round-off is covered by SLP.row_rounding in the certificate)
    rows = BellmanRows.from_arrays(
        owner, live % n_actions, reward[live], targets, probs, mdp.discount, m
    )
    row_number = np.full(m * n_actions, -1, dtype=np.int64)
    row_number[live] = np.arange(n_rows)
    row_of_pair = np.where(
        mu > 0, row_number[labels[:, None] * n_actions + np.arange(n_actions)], -1
    )
    return rows, weights, row_of_pair
