"""Which kernels run an operation, and on how many threads.

Every Bellman-row kernel is C, built when lpbounds is installed: the row sweeps of exact
DP and the successor check (:mod:`lpbounds._kernels.native` over ``rowsweeps.c``) and the
others, Q-values, the game operator, row hashes, the post-decision form and the
aggregation of rows (:mod:`lpbounds._kernels.ckernels` over ``rowkernels.c``). Nothing
compiles at run time, and a C call has no first-call cost, so every model runs on them,
whatever its size: the twins were the path of small models only to spare them numba's
compile, and they are slower at every size (measured on two cores, the game operator of
a 3,000-state garnet's NLP rows takes 0.05 ms in C and 0.25 ms through the twins, its
aggregation 1.1 ms and 8.1 ms; ``docs/benchmarks.md``, "Kernels"). The numpy twins
(:mod:`lpbounds._kernels.twins`) are the reference the tests compare the C kernels with;
a test runs the library on them by replacing :func:`kernels` and :func:`row_sweeps`, the
one place that names the modules.

The thread count of the C kernels is :mod:`lpbounds._kernels.threads`' (one pool);
:func:`nchunks` is the work split of the patrol's matrix-free sweeps
(:mod:`lpbounds.patrol.sweeps`), which are numba's until they move to C too.
"""

from __future__ import annotations

from types import ModuleType

from .threads import get_threads, set_threads

__all__ = ["get_threads", "kernels", "nchunks", "row_sweeps", "set_threads"]


def kernels() -> ModuleType:
    """The Bellman-row kernels: Q-values, the game operator, row hashes, the post-decision
    form and the aggregation of rows (:mod:`lpbounds._kernels.ckernels`, C)."""
    from . import ckernels

    return ckernels


def row_sweeps() -> ModuleType:
    """The improvement and evaluation sweeps of a row system, its policy gather and the
    successor check (:mod:`lpbounds._kernels.native`, C)."""
    from . import native

    return native


def nchunks() -> int:
    """Work chunks of the patrol's numba sweeps: a few per thread, for load balance."""
    return max(1, 8 * get_threads())
