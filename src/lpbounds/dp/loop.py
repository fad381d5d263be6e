"""The one MPI loop: value iteration, modified policy iteration and the game's value
iteration, on any :class:`~lpbounds.rows.SweepOperator`.

The loop
--------
VI, MPI and the game's VI are one loop, :func:`mpi_loop` (iterative policy evaluation is
its sibling :func:`~lpbounds.dp.evaluation_loop`, :mod:`lpbounds.dp.evaluation`); both
run on any :class:`~lpbounds.rows.SweepOperator` (the rows, their post-decision form, the
matrix-free patrol operator of :mod:`lpbounds.patrol.matrix_free`), so every path gives
the same numbers for the same operator. They keep two value vectors: the starting vector,
which they overwrite, and one from :meth:`~lpbounds.rows.SweepOperator.new_vector`; the
result ``u + c`` is formed in place (534 M states at 6 patrol stations: 4.3 GB a vector).
The loop stops at the first improvement sweep whose residual ``||T V - V||_inf`` is at
most ``tol`` (the certificate: "Stopping rule and error bound" in :mod:`lpbounds.dp.solve`).

Value iteration and MPI use the Porteus/MacQueen extrapolation: after a sweep
``V' = T V`` with ``r = V' - V``, the constant ``lambda / (1 - lambda) * (min r + max r) / 2``
is added to ``V'``. A constant shift does not change greedy policies and
``T(V + c) = T V + lambda c``, so the shift only removes the slowest (constant) error
mode; the residual of the shifted vector is at most ``lambda * span(r) / 2``. Its offset
algebra is :class:`~lpbounds.dp.PorteusShift` (:mod:`lpbounds.dp.porteus`).

Evaluation sweeps of MPI
------------------------
MPI converges for any number ``m_n >= 0`` of evaluation sweeps after improvement ``n``
(Puterman, *Markov Decision Processes*, Thm. 6.5.5), and the stopping test is always an
improvement sweep, so ``m_n`` changes the speed, never the certificate. With
``eval_sweeps=<int>`` every ``m_n`` is that number (textbook MPI). The default
``eval_sweeps="auto"`` does not spend evaluation sweeps on a policy that is about to be
replaced: ``m_n = AUTO_EVAL_SWEEPS`` once at most :data:`AUTO_SETTLED` of the states
changed their action in improvement ``n`` (the first improvement counts as a change of
every state), else ``m_n = 0``, a value-iteration step, which does everything an
evaluation sweep does and improves the policy too. The rule (:class:`EvalPlan`) reads only
the policies, so the iterates and the sweep count do not depend on timing, and a model
gives the same numbers on its plain rows and its post-decision form.

Measured (2 cores, quiet machine, best of 3, the same answers within the certificates):
the garnet 2,048,000 x 3 x 5 at discount 0.9 took 11 improvement and 25 evaluation
sweeps against fixed MPI's 9 and 40 (1.7 against 2.4 s); the patrol MDP, where an
evaluation sweep costs nearly an improvement sweep (both are dominated by the
expectations at every post-decision state), 27 and 35 against 16 and 75 (0.67 against
1.00 s; value iteration: 58 sweeps, 0.70 s).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, Literal

import numpy as np

from ..errors import ValidationError
from ..rows import BellmanRows, SweepOperator
from ..validation import check_int, is_int
from .operators import Callback
from .porteus import PorteusShift
from .results import LoopResult
from .threads import ThreadChoice, serial_if_small

__all__ = ["AUTO_EVAL_SWEEPS", "AUTO_SETTLED", "EvalPlan", "check_eval_sweeps", "mpi_loop"]


#: ``eval_sweeps="auto"``: evaluation sweeps after an improvement once the policy settled.
AUTO_EVAL_SWEEPS: int = 5
#: ``eval_sweeps="auto"``: the policy has settled when at most this fraction of the states
#: changed their action in the last improvement (1 % and 0.1 % gave sweep times within
#: 6 % of each other on the garnets and the patrol of docs/benchmarks.md, "Peers").
AUTO_SETTLED: float = 0.01


def check_eval_sweeps(eval_sweeps: Any) -> int | Literal["auto"]:
    """``eval_sweeps`` checked: ``"auto"`` or a non-negative integer.

    Raises
    ------
    ValidationError
        For anything else (a bool, a negative or non-integer number, another string).
    """
    if isinstance(eval_sweeps, str) and eval_sweeps == "auto":
        return "auto"
    if not is_int(eval_sweeps):
        raise ValidationError(
            f"eval_sweeps must be a non-negative integer or 'auto'; got {eval_sweeps!r}"
        )
    return check_int("eval_sweeps", eval_sweeps, lo=0)


class EvalPlan:
    """MPI's evaluation sweeps after each improvement: a fixed number, or the ``"auto"``
    rule of the module docstring ("Evaluation sweeps of MPI").

    Parameters
    ----------
    eval_sweeps : int or "auto"
        As checked by :func:`check_eval_sweeps`.
    """

    def __init__(self, eval_sweeps: int | str) -> None:
        self.fixed = None if eval_sweeps == "auto" else int(eval_sweeps)
        self.prev: np.ndarray | None = None  # the choices of the previous improvement

    @property
    def ever(self) -> bool:
        """False when no evaluation sweep will ever run (value iteration)."""
        return self.fixed != 0

    def count(self, arg: np.ndarray) -> int:
        """Evaluation sweeps after the improvement that chose ``arg`` (rows or actions:
        one to one on the states' allowed actions, so both count the same changes)."""
        if self.fixed is not None:
            return self.fixed
        if self.prev is None:
            self.prev = arg.copy()
            return 0
        changed = 0
        step = 1 << 22  # in blocks: no temporary of the states' size (534 M at 6 stations)
        for b in range(0, arg.size, step):
            changed += int(np.count_nonzero(arg[b : b + step] != self.prev[b : b + step]))
        self.prev[:] = arg
        return AUTO_EVAL_SWEEPS if changed <= AUTO_SETTLED * arg.size else 0


def _improvement(
    ops: SweepOperator, game: bool, work: np.ndarray | None
) -> Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[float, float]]:
    """The improvement sweep ``(u, out, arg) -> (lo, hi)``: ``T``, or the game's ``G``."""
    if game:  # the game operator exists on row systems only
        if not isinstance(ops, BellmanRows):
            raise ValidationError(f"the game operator needs BellmanRows; got {type(ops).__name__}")
        return ops.sweep_maxmin
    return functools.partial(ops.sweep_max, work=work)


@serial_if_small
def mpi_loop(
    ops: SweepOperator,
    v: np.ndarray,
    tol: float,
    max_iter: int,
    eval_sweeps: int | Literal["auto"] = "auto",
    extrapolate: bool = True,
    callback: Callback | None = None,
    *,
    game: bool = False,
) -> LoopResult:
    """VI / MPI (and the game's VI) with the Porteus shift carried as a scalar offset.

    The iterate is ``v = u + c`` with ``u`` an array and ``c`` a scalar: since
    ``T(u + c) = T u + lambda c`` (and likewise for a fixed policy and for the game
    operator), a sweep computes ``T u`` and the extremes of ``T u - u`` in one pass, the
    residual extremes of ``v`` are those less ``(1 - lambda) c``, and the shift only
    updates ``c``. ``u + c`` is formed once, at the end, in place
    (:class:`~lpbounds.dp.PorteusShift`: rows that are not stochastic to rounding fold the
    offset into ``u`` after every sweep). The sweeps run on the thread count
    :class:`~lpbounds.dp.ThreadChoice` picks (no number changes).

    Parameters
    ----------
    ops : SweepOperator
    v : ndarray
        The starting vector, **overwritten** (the loop's first value vector; its second
        comes from ``ops.new_vector()``): pass a copy to keep it.
    tol : float
        Stop at the first improvement sweep whose residual is ``<= tol``.
    max_iter : int
        Limit on improvement steps (``max_iter + 1`` improvement sweeps at most).
    eval_sweeps : int or "auto"
        Evaluation sweeps after each improvement (:class:`EvalPlan`); 0 is value iteration.
    extrapolate : bool
        The Porteus/MacQueen shift.
    callback : callable(iteration, residual), optional
        Called after each improvement sweep.
    game : bool
        Improve with the game operator ``G`` (``ops`` must be :class:`BellmanRows`).

    Returns
    -------
    LoopResult
        ``values`` is ``v`` or the other vector, ``arg`` from ``ops.new_arg()``.
    """
    shift = PorteusShift(ops.discount, ops.row_sums(), tol)
    plan = EvalPlan(check_eval_sweeps(eval_sweeps))
    work = ops.new_work()  # reused by every sweep of this solve
    improve = _improvement(ops, game, work)
    evaluator = ops.evaluator(work) if plan.ever else None
    u, buf, arg = v, ops.new_vector(), ops.new_arg()
    run = LoopResult(u, arg, np.inf, max_iter, 0, False)
    c = 0.0
    threads = ThreadChoice(ops)
    try:
        for it in range(max_iter + 1):
            lo, hi = threads.timed("max", improve, u, buf, arg)
            run.sweeps += 1
            run.residual, c_next = shift.step(c, lo, hi, extrapolate)
            run.history.append(run.residual)
            if callback is not None:
                callback(it, run.residual)
            if run.residual <= tol:
                run.iterations, run.converged = it, True
                break
            if it == max_iter:
                break
            u, buf = buf, u
            c = shift.settle(u, c_next)
            m = plan.count(arg)
            if m == 0:
                continue
            assert evaluator is not None  # plan.ever
            evaluator.set_policy(arg)
            for _ in range(m):
                lo, hi = threads.timed("policy", evaluator.sweep, u, buf)
                run.sweeps += 1
                _, c_next = shift.step(c, lo, hi, extrapolate)
                u, buf = buf, u
                c = shift.settle(u, c_next)
    finally:
        threads.restore()
    del buf, evaluator
    u += c  # u + c, in place: the same numbers as a new vector, one vector less
    run.values = u
    return run
