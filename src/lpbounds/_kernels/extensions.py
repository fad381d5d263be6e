"""The C extensions of lpbounds' kernels, imported in one place.

Four C files are compiled when lpbounds is installed (``setup.py``), each including
``buffers.h`` first: ``rowsweeps.c`` (the row sweeps of exact DP and the successor check;
:mod:`lpbounds._kernels.native` runs them), ``rowkernels.c`` (Q-values, the game
operator, row hashes, the post-decision form, the aggregation of rows;
:mod:`lpbounds._kernels.ckernels`), ``patrolsweeps.c`` (the patrol's matrix-free sweeps
and passes, its decoder, successors and partition key; :mod:`lpbounds.patrol.sweeps`,
``.model``, ``.partitions``) and ``patrolmc.c`` (the greedy policy on the fly, its Monte
Carlo returns, the simulator; :mod:`lpbounds.patrol.greedy_mc`, ``.simulation``).

Every module that calls C imports its extension from here, so a tree whose extensions
were not compiled (a checkout used without ``pip install``) fails in one way, with one
message saying how to build them. Loading the four shared libraries takes well under a
millisecond; nothing is compiled at run time.
"""

from __future__ import annotations

try:
    from . import patrolmc, patrolsweeps, rowkernels, rowsweeps
except ImportError as exc:  # pragma: no cover - a source tree without the build
    raise ImportError(
        "lpbounds' C kernels (lpbounds._kernels.rowsweeps, rowkernels, patrolsweeps, "
        "patrolmc) are not built: install lpbounds with pip (`pip install .`, or "
        "`pip install -e .` in a checkout), which compiles them; a source build needs a C "
        "compiler (README, 'Installation')"
    ) from exc

__all__ = ["patrolmc", "patrolsweeps", "rowkernels", "rowsweeps"]
