"""Deliberately simple references for the formulation tests (no BellmanRows, no kernels)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

import lpbounds as lb


def _q_partition(mdp: lb.FiniteMDP, labels: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R_u(x) + lam sum_l p_l v(label(f(x,u,Y_l)))`` per pair, -inf when disallowed."""
    p = mdp.probabilities_full()
    q = mdp.rewards + mdp.discount * (p * v[labels[mdp.successors]]).sum(axis=2)
    return np.where(mdp.allowed, q, -np.inf)


def rlp_reference(mdp: lb.FiniteMDP, part: lb.Partition, tol: float = 1e-13) -> np.ndarray:
    """RLP's least feasible point: v(i) = max_{x in S_i, u} q(x, u), iterated to ``tol``."""
    labels = np.asarray(part.labels, dtype=np.int64)
    m = part.n_partitions
    v = np.zeros(m)
    while True:
        q = _q_partition(mdp, labels, v).max(axis=1)
        nv = np.full(m, -np.inf)
        np.maximum.at(nv, labels, q)
        if np.abs(nv - v).max() < tol * max(1.0, np.abs(nv).max()):
            return nv
        v = nv


def hard_aggregation_reference(mdp: lb.FiniteMDP, part: lb.Partition) -> np.ndarray:
    """Remark 1: w(i) = max_u mean over the x in S_i allowing u of q(x, u), iterated."""
    labels = np.asarray(part.labels, dtype=np.int64)
    m, n_act = part.n_partitions, mdp.n_actions
    w = np.zeros(m)
    while True:
        q = _q_partition(mdp, labels, w)
        nw = np.full(m, -np.inf)
        for u in range(n_act):  # small loop over actions only
            ok = mdp.allowed[:, u]
            s = np.bincount(labels[ok], weights=q[ok, u], minlength=m)
            k = np.bincount(labels[ok], minlength=m)
            mean = np.where(k > 0, s / np.maximum(k, 1), -np.inf)
            nw = np.maximum(nw, mean)
        if np.abs(nw - w).max() < 1e-13 * max(1.0, np.abs(nw).max()):
            return nw
        w = nw


def transition_rows(mdp: lb.FiniteMDP) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """P (n_pairs x n) over allowed pairs in row-major (x, u) order, the rewards and the pairs."""
    pairs = np.argwhere(mdp.allowed)
    n_out = mdp.n_outcomes
    p = mdp.probabilities_full()[pairs[:, 0], pairs[:, 1]]
    cols = mdp.successors[pairs[:, 0], pairs[:, 1]]
    rows = np.repeat(np.arange(len(pairs)), n_out)
    mat = sp.csr_matrix((p.ravel(), (rows, cols.ravel())), shape=(len(pairs), mdp.n_states))
    return mat, mdp.rewards[pairs[:, 0], pairs[:, 1]], pairs
