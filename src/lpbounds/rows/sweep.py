r"""The sweep protocol: what the exact-DP loops need of an operator (:class:`SweepOperator`)
and the evaluation sweeps of one policy (:class:`PolicySweeps`).

The exact-DP loops of :mod:`lpbounds.dp` (MPI, value iteration, iterative policy
evaluation) run on any :class:`SweepOperator`: :class:`~lpbounds.rows.BellmanRows`,
:class:`~lpbounds.rows.PostDecisionRows` and the matrix-free patrol operator
(:class:`lpbounds.patrol.matrix_free.MatrixFreePatrol`) implement it. A sweep writes
``T v`` (or ``T_pi v``) into ``out`` and returns the extremes of ``out - v``; the work
chunks of the patrol's matrix-free kernels are the operator's choice unless ``nchunks`` is
given (the C sweeps of :class:`~lpbounds.rows.BellmanRows` and
:class:`~lpbounds.rows.PostDecisionRows` take one range per thread and ignore it; neither
changes a number: every state's value is computed alone and the extremes are exact), and
``work`` is the operator's scratch array from :meth:`SweepOperator.new_work`, made once
per solve and passed to each of its sweeps.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from ..stochastic import RowSums

__all__ = ["PolicySweeps", "SweepOperator"]


@runtime_checkable
class SweepOperator(Protocol):
    """What the exact-DP loops of :mod:`lpbounds.dp` need of an operator: fused sweeps.

    A Bellman operator ``T`` over ``n_vars`` states with a choice per state (a row, an
    action) and its fixed-policy operators ``T_pi``. Implemented by
    :class:`~lpbounds.rows.BellmanRows` (choices are rows),
    :class:`~lpbounds.rows.PostDecisionRows` and
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
