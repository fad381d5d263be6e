"""Independent references for the ported cases: plain numpy, no lpbounds code.

``brute_force`` solves a small model by enumerating every deterministic policy (one
linear solve each) and taking the state-wise maximum (Puterman, Thm 6.2.10: V* is the
maximum of V_pi over deterministic stationary policies). ``porteus_bracket`` gives the
interval that any vector ``V`` certifies for V* (Porteus 1975): with ``a = TV - V``,
``TV + lam/(1-lam) min(a) <= V* <= TV + lam/(1-lam) max(a)``.
"""

from __future__ import annotations

import itertools

import numpy as np

import lpbounds as lb


def dense(P) -> np.ndarray:
    """(A, n, n) float array from matrices (dense or sparse)."""
    return np.stack([np.asarray(m.toarray() if hasattr(m, "toarray") else m, float) for m in P])


def brute_force(P, R, discount, allowed=None):
    """``(V*, optimal action sets)`` of ``P`` (A, n, n) and ``R`` (n, A) by enumeration."""
    P = dense(P)
    R = np.asarray(R, float)
    A, n, _ = P.shape
    allowed = np.ones((n, A), bool) if allowed is None else np.asarray(allowed)
    choices = [np.flatnonzero(allowed[x]) for x in range(n)]
    assert np.prod([len(c) for c in choices]) <= 20_000, "too many policies to enumerate"
    best = np.full(n, -np.inf)
    for pol in itertools.product(*choices):
        p_pi = P[list(pol), np.arange(n), :]
        r_pi = R[np.arange(n), list(pol)]
        v = np.linalg.solve(np.eye(n) - discount * p_pi, r_pi)
        best = np.maximum(best, v)
    q = R + discount * np.einsum("axy,y->xa", P, best)
    q[~allowed] = -np.inf
    tol = 1e-9 * max(1.0, np.abs(best).max())
    optimal = [set(np.flatnonzero(q[x] >= q[x].max() - tol)) for x in range(n)]
    return best, optimal


def porteus_bracket(P, R, discount, v):
    """The bracket on V* certified by the vector ``v`` (for an iterate published upstream)."""
    P = dense(P)
    q = np.asarray(R, float) + discount * np.einsum("axy,y->xa", P, np.asarray(v, float))
    tv = q.max(axis=1)
    a = tv - v
    k = discount / (1.0 - discount)
    return tv + k * a.min(), tv + k * a.max()


def exact(mdp: lb.FiniteMDP):
    """lpbounds' V* and policy (policy iteration, exact evaluation)."""
    res = lb.solve_exact(mdp, "pi")
    assert res.error_bound < 1e-9 * max(1.0, float(np.abs(res.values).max()))
    return res.values, res.policy


def assert_policy_optimal(policy, optimal_sets):
    for x, (u, ok) in enumerate(zip(policy, optimal_sets, strict=True)):
        assert int(u) in ok, f"state {x}: action {u} is not optimal ({sorted(ok)})"
