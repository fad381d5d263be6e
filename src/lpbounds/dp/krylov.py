"""Restarted GMRES for the policy-evaluation equations of inexact policy iteration.

:func:`gmres` solves ``A d = b`` approximately, ``A = I - lambda P_pi`` applied by a
callable (a Bellman sweep of the policy with zero rewards, :mod:`lpbounds.dp`), right
preconditioned by a diagonal. It is written here rather than taken from
:func:`scipy.sparse.linalg.gmres` for two measured reasons:

* its stopping test is the *max norm* of the true residual (what the Bellman certificate
  uses), checked at every restart, and the 2-norm estimate inside a cycle (an upper bound
  on the max norm) stops a cycle early;
* its inner products are :func:`numpy.einsum` loops, not BLAS: OpenBLAS runs ``ddot`` on
  all its threads, and on a busy 2-core machine (load 9-13) scipy's GMRES took 80 s where
  the same iteration with one BLAS thread took 3.5 s (30,000 states, 1,617 products).

Nothing here decides a bound: the caller measures the Bellman residual of the vector it
returns with a full sweep.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["gmres"]


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """``a . b`` on one thread (numpy's own loop, see the module docstring)."""
    return float(np.einsum("i,i->", a, b))


def gmres(
    apply: Callable[[np.ndarray], np.ndarray],
    b: np.ndarray,
    target: float,
    restart: int,
    max_products: int,
    dinv: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """Restarted GMRES(``restart``) from 0 until ``||b - A d||_inf <= target``.

    Parameters
    ----------
    apply : callable
        ``apply(z)`` returns ``A z`` (a new array or a buffer the caller owns; it is read
        before the next call).
    b : ndarray
    target : float
        Stop when the max norm of the residual is at most this.
    restart : int
        Krylov vectors per cycle (memory: ``restart + 1`` vectors of ``b``'s size).
    max_products : int
        Limit on calls of ``apply``: the result is then the best point reached so far.
    dinv : ndarray, optional
        Right preconditioner ``D^{-1}`` (elementwise): GMRES runs on ``A D^{-1}``.

    Returns
    -------
    d : ndarray
    products : int
        Calls of ``apply``.
    """
    n = b.shape[0]
    d = np.zeros(n)
    r = b.copy()
    products = 0
    basis = np.empty((restart + 1, n))
    while products < max_products and np.abs(r).max(initial=0.0) > target:
        beta = float(np.sqrt(_dot(r, r)))
        basis[0] = r / beta
        k, y = _cycle(apply, basis, beta, target, min(restart, max_products - products), dinv)
        products += k
        step = np.zeros(n)
        for i in range(y.shape[0]):
            step += y[i] * basis[i]
        if dinv is not None:
            step *= dinv
        d += step
        r = b - apply(d)  # the true residual (also guards the 2-norm recursion's rounding)
        products += 1
    return d, products


def _cycle(
    apply: Callable[[np.ndarray], np.ndarray],
    basis: np.ndarray,
    beta: float,
    target: float,
    steps: int,
    dinv: np.ndarray | None,
) -> tuple[int, np.ndarray]:
    """One Arnoldi cycle (modified Gram-Schmidt, Givens rotations) from ``basis[0]``.

    Returns the number of products and the coefficients of the correction in the basis.
    """
    h = np.zeros((steps + 1, steps))
    cs = np.zeros(steps)
    sn = np.zeros(steps)
    e = np.zeros(steps + 1)
    e[0] = beta
    k = 0
    for j in range(steps):
        z = basis[j] * dinv if dinv is not None else basis[j]
        w = np.array(apply(z), dtype=np.float64)
        k = j + 1
        for i in range(j + 1):
            h[i, j] = _dot(w, basis[i])
            w -= h[i, j] * basis[i]
        hn = float(np.sqrt(_dot(w, w)))
        h[j + 1, j] = hn
        for i in range(j):  # the earlier rotations on the new column
            top, bot = h[i, j], h[i + 1, j]
            h[i, j] = cs[i] * top + sn[i] * bot
            h[i + 1, j] = -sn[i] * top + cs[i] * bot
        denom = float(np.hypot(h[j, j], h[j + 1, j]))
        if denom == 0.0:  # A z = 0 cannot happen for I - lambda P (lambda < 1): stop safely
            k = j
            break
        cs[j], sn[j] = h[j, j] / denom, h[j + 1, j] / denom
        h[j, j], h[j + 1, j] = denom, 0.0
        e[j + 1] = -sn[j] * e[j]
        e[j] = cs[j] * e[j]
        if abs(e[j + 1]) <= target or j + 1 == steps:
            break
        if hn == 0.0:  # the exact solution is in the space (happy breakdown)
            break
        basis[j + 1] = w / hn
    if k == 0:
        return 0, np.zeros(0)
    y = np.linalg.solve(np.triu(h[:k, :k]), e[:k]) if k > 1 else e[:1] / h[0, 0]
    return k, y
