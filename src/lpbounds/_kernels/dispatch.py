"""Which kernels run an operation, and on how many threads.

Every Bellman-row kernel is C, built when lpbounds is installed: the row sweeps of exact
DP and the successor check (:mod:`lpbounds._kernels.native` over ``rowsweeps.c``) and the
others, Q-values, the game operator, row hashes, the post-decision form and the
aggregation of rows (:mod:`lpbounds._kernels.ckernels` over ``rowkernels.c``). Nothing
compiles at run time, and a C call has no first-call cost, so every model runs on them,
whatever its size: the numpy twins are slower at every size (measured on two cores, the
game operator of a 3,000-state garnet's NLP rows takes 0.05 ms in C and 0.25 ms through
the twins, its aggregation 1.1 ms and 8.1 ms; ``docs/benchmarks.md``, "Kernels"). The
twins (:mod:`lpbounds._kernels.twins`) are the reference the tests compare the C kernels
with; a test runs the library on them by replacing :func:`kernels` and
:func:`row_sweeps`, the one place that names the modules.

The thread count of the C kernels is :mod:`lpbounds._kernels.threads`' (one pool).
"""

from __future__ import annotations

from types import ModuleType

from .threads import get_threads, set_threads

__all__ = ["get_threads", "kernels", "row_sweeps", "set_threads"]


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
