"""How many threads the sweeps of one solve run on: one below
:data:`SERIAL_SWEEP_READS` (:func:`threads_for`), else the count :class:`ThreadChoice`
measures. The thread count changes no number (the kernels' pool and count:
:mod:`lpbounds._kernels.threads`)."""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from .._kernels import dispatch as _backend
from ..rows import SweepOperator

__all__ = ["SERIAL_SWEEP_READS", "ThreadChoice", "serial_if_small", "threads_for"]


#: Below this many value reads per sweep the sweeps run on one thread: a parallel region
#: costs a wake-up of the other threads (tens of microseconds on an idle machine,
#: milliseconds on a busy one), more than a small sweep itself. Measured on the patrol
#: model (16,320 states) on a loaded 2-core machine: 0.03 s on one thread, 1-4 s on two.
SERIAL_SWEEP_READS: int = 1_000_000


@contextmanager
def threads_for(ops: SweepOperator) -> Iterator[None]:
    """Run the enclosed sweeps of ``ops`` on one thread when they are small.

    Below :data:`SERIAL_SWEEP_READS` values read per sweep (``ops.sweep_reads``) the
    compiled kernels' thread count (:func:`lpbounds._kernels.dispatch.set_threads`) is set
    to 1 for the block and restored after. Only compiled sweeps have threads.
    """
    if not ops.compiled:
        yield
        return
    before = _backend.get_threads()
    serial = before > 1 and ops.sweep_reads < SERIAL_SWEEP_READS
    if serial:
        _backend.set_threads(1)
    try:
        yield
    finally:
        if serial:
            _backend.set_threads(before)


def serial_if_small(func: Callable[..., Any]) -> Callable[..., Any]:
    """Run ``func(ops, ...)`` with the thread count :func:`threads_for` picks for ``ops``."""

    @functools.wraps(func)
    def wrapper(ops: Any, *args: Any, **kwargs: Any) -> Any:
        with threads_for(ops):
            return func(ops, *args, **kwargs)

    return wrapper


class ThreadChoice:
    """One thread or all of the compiled kernels' for the sweeps of one large solve, chosen
    by timing (the count of :func:`lpbounds._kernels.dispatch.set_threads`).

    Two threads halve a sweep on an idle 2-core machine, but when other jobs hold the
    cores, a parallel region waits for a descheduled thread and one thread is faster
    (measured: a random MDP of 2,048,000 x 3 x 5 took 10.6 s on one thread and 13.7-14.7 s
    on two with one core busy). Sweeps of one kind (improvement, evaluation) are timed
    against each other: sweep 0 of a kind pays first-touch page faults and is not timed;
    the first kind to get that far runs sweep 1 on one thread and sweeps 2 and 3 on all
    (:attr:`MANY_SAMPLES`), and keeps all threads if their mean is below :attr:`PREFER`
    times the one thread's. That choice holds for every kind (they stall alike when a core
    is taken; a one-thread sample of the garnet's improvement sweep costs 80 ms, of its
    evaluation sweep 30). Every :attr:`RECHECK` sweeps of a kind, the other count is timed
    again and taken for that kind if faster by :attr:`MARGIN` than the median of the
    chosen count's last three (the load changes). Sweeps below :data:`SERIAL_SWEEP_READS`
    always run on one thread (:func:`threads_for`). The thread count changes no number:
    every state's value is computed by the same arithmetic on whichever thread, and the
    residual extremes are exact minima and maxima.
    """

    MANY_SAMPLES: int = 2
    RECHECK: int = 32
    MARGIN: float = 0.9
    #: All threads are kept only when their mean sweep is this much faster than one
    #: thread's: on a loaded machine their times scatter (a descheduled thread stalls the
    #: region), and two lucky samples made the choice lose to one thread (patrol MPI, load
    #: 7: one thread 3.8-4.9 s, all 6.7-9.4 s, a plain lower-mean choice 5.4-5.6 s).
    PREFER: float = 0.85

    def __init__(self, ops: SweepOperator) -> None:
        self.many = 1
        if ops.compiled and ops.sweep_reads >= SERIAL_SWEEP_READS:
            self.many = _backend.get_threads()
        self.current = self.many
        self.count: dict[str, int] = {}  # sweeps of each kind so far
        self.times: dict[tuple[str, int], list[float]] = {}
        self.chosen: dict[str, int] = {}
        self.first: int | None = None  # the first choice made, adopted by every kind

    @property
    def n_calibrate(self) -> int:
        """Sweeps of the first kind before the first choice (sweep 0 untimed, one sample
        on one thread, :attr:`MANY_SAMPLES` on all)."""
        return 2 + self.MANY_SAMPLES

    def start(self, kind: str) -> int:
        """Set the kernels' thread count for the next sweep of ``kind``; returns it."""
        if self.many == 1:
            return 1
        i = self.count.get(kind, 0)
        if kind not in self.chosen and self.first is not None:
            self.chosen[kind] = self.first
        if kind not in self.chosen:
            want = 1 if i == 1 else self.many
        elif i > 0 and i % self.RECHECK == 0:
            want = 1 if self.chosen[kind] != 1 else self.many
        else:
            want = self.chosen[kind]
        self._set(want)
        return want

    def stop(self, kind: str, threads: int, seconds: float) -> None:
        """Record the time of the sweep of ``kind`` just run on ``threads``."""
        if self.many == 1:
            return
        i = self.count.get(kind, 0)
        self.count[kind] = i + 1
        if i == 0:
            return
        mine = self.times.setdefault((kind, threads), [])
        mine.append(seconds)
        chosen = self.chosen.get(kind)
        if chosen is None:
            if i == self.n_calibrate - 1:
                fast = self._mean(kind, self.many) < self.PREFER * self._mean(kind, 1)
                self.chosen[kind] = self.first = self.many if fast else 1
            return
        if threads != chosen:
            # against the median of the chosen count's last three sweeps: one slow sweep
            # flipped a 256,000-state garnet to one thread (2.1 ms sweeps, one of 5.1 ms)
            recent = float(np.median(self.times.get((kind, chosen), [np.inf])[-3:]))
            if seconds < self.MARGIN * recent:
                self.chosen[kind] = threads

    def timed(self, kind: str, sweep: Callable[..., tuple[float, float]], *args: Any) -> Any:
        """``sweep(*args)`` on the thread count :meth:`start` sets for ``kind``, timed into
        :meth:`stop`; returns what the sweep returns."""
        k = self.start(kind)
        t = time.perf_counter()
        out = sweep(*args)
        self.stop(kind, k, time.perf_counter() - t)
        return out

    def _mean(self, kind: str, threads: int) -> float:
        return float(np.mean(self.times.get((kind, threads)) or [np.inf]))

    def _set(self, k: int) -> None:
        if k != self.current:
            _backend.set_threads(k)
            self.current = k

    def restore(self) -> None:
        """Back to the kernels' thread count at the start."""
        self._set(self.many)
