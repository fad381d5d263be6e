"""Layer 5, dp: exact dynamic programming (paper Sections 2 and 3.3) -- value, policy and
modified policy iteration, policy evaluation, greedy policies, the Porteus bounds and the
disjunctive NLP's game, on a :class:`~lpbounds.model.mdp.FiniteMDP` or a
:class:`~lpbounds.rows.BellmanRows` system, each answer with a certified error bound.

A table of contents; the modules, in the order data flows through them:

* :mod:`~lpbounds.dp.operators` -- the operator a model is swept as (its rows, their
  post-decision form: the fast path), the contraction modulus, the shared argument checks;
* :mod:`~lpbounds.dp.threads` -- how many threads a solve's sweeps run on;
* :mod:`~lpbounds.dp.porteus` -- the Porteus shift of the loops and the Porteus bounds;
* :mod:`~lpbounds.dp.loop` -- **the one MPI loop** (:func:`mpi_loop`: VI, MPI, the game's VI);
* :mod:`~lpbounds.dp.evaluation` -- policy evaluation and its loop (:func:`evaluation_loop`);
* :mod:`~lpbounds.dp.policy_iteration` -- policy iteration and inexact policy iteration
  (with :mod:`~lpbounds.dp.krylov`, its GMRES);
* :mod:`~lpbounds.dp.solve` -- :func:`solve_exact`, its stopping rule and error bound;
* :mod:`~lpbounds.dp.game` -- :func:`solve_game`;
* :mod:`~lpbounds.dp.rational` -- ``arithmetic="rational"``: the bridge to
  :mod:`lpbounds.exact`;
* :mod:`~lpbounds.dp.greedy` -- greedy policies and the Bellman residual;
* :mod:`~lpbounds.dp.results` -- :class:`DPResult`, :class:`PolicyEvaluation` and where
  the loops stop.
"""

from __future__ import annotations

from .evaluation import evaluate_policy, evaluation_loop
from .game import solve_game
from .greedy import bellman_residual, greedy_policy
from .loop import AUTO_EVAL_SWEEPS, AUTO_SETTLED, EvalPlan, check_eval_sweeps, mpi_loop
from .operators import exact_rows, modulus, post_decision_rows
from .porteus import PorteusBounds, PorteusShift, porteus_bounds
from .results import DPResult, LoopResult, PolicyEvaluation, PolicyLoop
from .solve import solve_exact
from .threads import SERIAL_SWEEP_READS, ThreadChoice, threads_for

__all__ = [
    "AUTO_EVAL_SWEEPS",
    "AUTO_SETTLED",
    "SERIAL_SWEEP_READS",
    "DPResult",
    "EvalPlan",
    "LoopResult",
    "PolicyEvaluation",
    "PolicyLoop",
    "PorteusBounds",
    "PorteusShift",
    "ThreadChoice",
    "bellman_residual",
    "check_eval_sweeps",
    "evaluate_policy",
    "evaluation_loop",
    "exact_rows",
    "greedy_policy",
    "modulus",
    "mpi_loop",
    "porteus_bounds",
    "post_decision_rows",
    "solve_exact",
    "solve_game",
    "threads_for",
]
