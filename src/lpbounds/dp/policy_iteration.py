"""Policy iteration (exact evaluations) and inexact policy iteration (GMRES evaluations):
``solve_exact(method="pi")`` and ``method="ipi"``.

Inexact policy iteration
------------------------
``method="ipi"`` alternates an improvement sweep (greedy policy ``pi``, Bellman residual
``res``) with a GMRES solve of ``(I - lambda P_pi) d = T u - u`` (:mod:`lpbounds.dp.krylov`,
self-loop preconditioned, products from the policy sweep with zero rewards) stopped at
``max(IPI_FORCING * res, tol / 2)`` in the max norm. The stopping rule and certificate
are those of :func:`~lpbounds.dp.solve_exact` (:mod:`lpbounds.dp.solve`): the residual of
the returned vector is measured by a full sweep, so the evaluation's accuracy only affects
speed. It is opt-in: measured against MPI with five evaluation sweeps per improvement
(sweep equivalents; improvement sweeps plus GMRES products, 2 cores; ``eval_sweeps="auto"``
needs fewer still on the large models) it lost on every large model and won only on small
slow-mixing ones:

* the ported peer test models (tests/model/interop): pymdptoolbox's forest with 1,000 states
  and discount 0.99, MPI 157 sweeps (44 ms), IPI 57 (26 ms); MDPSolver's test 1
  (discount 0.98): 31 against 11 sweeps, 0.56 against 0.44 ms;

* garnet 100,000 x 3 x 5, discount 0.9: MPI 55 sweeps, IPI 123 (a random MDP mixes
  fast; with the Porteus shift an evaluation sweep already contracts by ~0.45);
* the paper's patrol MDP: MPI 91 sweeps, IPI 165 (and 5x the time: each GMRES step
  also orthogonalises 2 M-entry vectors);
* a slow-mixing chain (3,000 states, discount 0.99): MPI 1,537, IPI 1,115 sweeps,
  about the same time; at 30,000 states and discount 0.999, MPI 13,057 sweeps (11 s),
  IPI 16,042 (32 s): PI's outer steps move the policy along the chain one stretch at a
  time, so GMRES's faster evaluations are spent on policies about to change.

So :func:`~lpbounds.dp.solve_exact` does not pick it by itself (a rule that pays only
below a millisecond is not worth a second default path); the measurements are rerun by
``benchmarks/bench_peers.py --dp``.
"""

from __future__ import annotations

import numpy as np

from ..rows import BellmanRows, PostDecisionRows
from ..tolerances import GREEDY_TIE_RTOL
from .evaluation import evaluate_row_policy
from .greedy import greedy_rows
from .operators import Callback, Model
from .results import LoopResult
from .threads import serial_if_small

__all__ = ["IPI_FORCING", "IPI_MAX_PRODUCTS", "IPI_RESTART", "inexact_pi", "policy_iteration"]


#: Inexact policy iteration: each evaluation stops when the max norm of its residual is at
#: most this fraction of the Bellman residual that started it (the forcing term), or at
#: half the requested tolerance once that is larger.
IPI_FORCING: float = 0.1
#: Krylov vectors per GMRES cycle (memory: that many vectors of the states' size).
IPI_RESTART: int = 20
#: Products (sweep equivalents) one evaluation may spend before the next improvement.
IPI_MAX_PRODUCTS: int = 200


@serial_if_small
def inexact_pi(
    ops: BellmanRows | PostDecisionRows,
    v: np.ndarray,
    tol: float,
    max_iter: int,
    callback: Callback | None,
) -> LoopResult:
    """Inexact policy iteration: improvement sweeps, GMRES evaluations of the greedy policy.

    At ``u`` the improvement sweep gives ``T u``, the greedy policy ``pi`` and the
    Bellman residual ``res = ||T u - u||``; the evaluation solves
    ``(I - lambda P_pi) d = T u - u`` (whose exact solution makes ``u + d = V_pi``) by
    GMRES until ``||T_pi(u + d) - (u + d)||_inf <= max(IPI_FORCING * res, tol / 2)``,
    right-preconditioned by ``1 / (1 - lambda P_pi(x, x))`` (self-loops). The product
    ``lambda P_pi z`` is the policy sweep with zero rewards. The returned residual is
    measured by a full improvement sweep on the returned vector, as for MPI. ``v`` is
    overwritten (the iterate).
    """
    from .krylov import gmres

    lam = ops.discount
    arg = ops.new_arg()
    work = ops.new_work()
    zero = ops.zero_rewards()
    u = v
    tu = ops.new_vector()
    prod = ops.new_vector()

    def apply(z: np.ndarray) -> np.ndarray:  # (I - lambda P_pi) z
        ops.sweep_policy(arg, z, prod, work=work, reward=zero)
        np.subtract(z, prod, out=prod)
        return prod

    run = LoopResult(u, arg, np.inf, max_iter, 0, False)
    for it in range(max_iter + 1):
        lo, hi = ops.sweep_max(u, tu, arg, work=work)
        run.sweeps += 1
        run.residual = res = max(-lo, hi)
        run.history.append(res)
        if callback is not None:
            callback(it, res)
        if res <= tol:
            run.iterations, run.converged = it, True
            break
        if it == max_iter:
            break
        dinv = 1.0 / (1.0 - lam * ops.self_loops(arg))
        target = max(IPI_FORCING * res, 0.5 * tol)
        d, k = gmres(apply, tu - u, target, IPI_RESTART, IPI_MAX_PRODUCTS, dinv)
        run.sweeps += k
        u += d
    return run


def policy_iteration(
    model: Model,
    rows: BellmanRows,
    v: np.ndarray,
    tol: float,
    max_iter: int,
    evaluation: str,
    callback: Callback | None,
) -> LoopResult:
    """Policy iteration: exact evaluations (:func:`evaluate_row_policy`), greedy improvements
    that keep a tied policy; the residual is measured by a max sweep at the end."""
    pol, _ = greedy_rows(rows, v, GREEDY_TIE_RTOL)
    sweeps = 0
    hist: list[float] = []
    for it in range(1, max_iter + 1):
        ev = evaluate_row_policy(rows, pol, evaluation, tol * (1 - rows.discount) * 0.1)
        v = ev.values
        sweeps += ev.sweeps
        new, tv = greedy_rows(rows, v, GREEDY_TIE_RTOL, prefer=pol)
        sweeps += 1
        res = float(np.abs(tv - v).max())
        hist.append(res)
        if callback is not None:
            callback(it, res)
        if np.array_equal(new, pol):
            tv, arg = rows.apply_max(v)
            res = float(np.abs(tv - v).max())
            return LoopResult(v, arg, res, it, sweeps, res <= tol, hist)
        pol = new
    tv, arg = rows.apply_max(v)
    return LoopResult(v, arg, float(np.abs(tv - v).max()), max_iter, sweeps, False, hist)
