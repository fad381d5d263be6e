"""Layer 1, the kernels: every compiled loop of lpbounds, in C, built when lpbounds is
installed (nothing is compiled at run time; no JIT).

Four C files, each including ``buffers.h`` (the arrays through the buffer protocol, the
no-FMA rule), imported in one place (:mod:`~lpbounds._kernels.extensions`):

- ``rowsweeps.c``: exact DP's row sweeps and the successor check (:mod:`.native`);
- ``rowkernels.c``: Q-values, the game operator, row hashes, the post-decision form and the
  aggregation of rows (:mod:`.ckernels`); :mod:`.dispatch` names these two for the library;
- ``patrolsweeps.c`` and ``patrolmc.c`` (with ``patrol.h``): the patrol's matrix-free
  sweeps, encoding, partition key, greedy Monte Carlo and simulator, called by
  :mod:`lpbounds.patrol`.

Their numpy twins (:mod:`.twins`, the same arithmetic) are the tests' reference, and they
all run on one thread pool and count (:mod:`.threads`).
"""
