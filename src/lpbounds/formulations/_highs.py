r"""The highspy backend: ``min c'x s.t. A x >= b`` (x free) handed to HiGHS directly.

:func:`highs_lp` is the one builder of a :class:`highspy.HighsLp` from a formulation's
stored data ``(A, b, c)`` (``A`` CSR): rows ``b <= A x <= +inf``, columns free, the
matrix passed column-wise (HiGHS' own storage, so ``passModel`` copies it without a
transpose). :func:`quiet_highs` is :func:`lpbounds._quiet.quiet_highs` (a ``Highs``
with its output off), re-exported so a caller needs one import.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from .._quiet import quiet_highs

__all__ = ["highs_lp", "quiet_highs"]


def highs_lp(A: sp.spmatrix | sp.sparray, b: np.ndarray, c: np.ndarray) -> Any:
    """``min c'x  s.t.  A x >= b``, ``x`` free, as a ``highspy.HighsLp``.

    Parameters
    ----------
    A : scipy.sparse matrix (R, N)
        The rows (any sparse format; converted to CSC, indices sorted).
    b : ndarray (R,)
        Row lower bounds (``row_upper = +inf``).
    c : ndarray (N,)
        Column costs (``col_lower = -inf``, ``col_upper = +inf``).

    Returns
    -------
    highspy.HighsLp
        Ready for ``Highs.passModel``; its row duals are ``>= 0`` at an optimum in
        HiGHS' sign convention for a minimisation with ``>=`` rows.
    """
    import highspy

    a = sp.csc_matrix(A)
    if not a.has_sorted_indices:
        a = a.sorted_indices()
    n_rows, n_cols = a.shape
    bb = np.ascontiguousarray(b, dtype=np.float64)
    cc = np.ascontiguousarray(c, dtype=np.float64)
    if bb.shape != (n_rows,) or cc.shape != (n_cols,):
        raise ValueError(f"A is {a.shape}, b {bb.shape}, c {cc.shape}")
    inf = highspy.kHighsInf
    lp = highspy.HighsLp()
    lp.num_col_ = int(n_cols)
    lp.num_row_ = int(n_rows)
    lp.col_cost_ = cc
    lp.col_lower_ = np.full(n_cols, -inf)
    lp.col_upper_ = np.full(n_cols, inf)
    lp.row_lower_ = bb
    lp.row_upper_ = np.full(n_rows, inf)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.num_col_ = int(n_cols)
    lp.a_matrix_.num_row_ = int(n_rows)
    lp.a_matrix_.start_ = a.indptr.astype(np.int32, copy=False)
    lp.a_matrix_.index_ = a.indices.astype(np.int32, copy=False)
    lp.a_matrix_.value_ = np.ascontiguousarray(a.data, dtype=np.float64)
    return lp
