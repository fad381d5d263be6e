"""Partitions of the state space into disjoint sets ``S_1..S_M`` (paper Section 3).

A :class:`Partition` maps each state to its partition index (0-based here; the paper
counts from 1). It provides the aggregation basis ``Phi`` of eq. (10),
``Phi(x, i) = 1`` if ``x`` is in ``S_i`` and 0 otherwise, and the lift ``Phi v``.
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ValidationError
from ..validation import as_array, as_float_array, check_array, check_int
from .mdp import index_dtype

if TYPE_CHECKING:  # scipy.sparse is imported where a matrix is built (0.1 s at start-up)
    import scipy.sparse as sp

__all__ = ["Partition", "with_sink_block"]


class Partition:
    """A partition of ``n`` states into ``M`` non-empty sets.

    Parameters
    ----------
    labels : array_like of int, shape (n,)
        ``labels[x] = i`` when state ``x`` belongs to ``S_i``. The labels must use
        every index ``0..M-1`` (no empty partition) and nothing else.
    n_partitions : int, optional
        ``M``; by default ``max(labels) + 1``. Given explicitly, it is checked.

    Raises
    ------
    ValidationError
        If a label is negative or not an integer (booleans, strings and fractional
        floats are refused), or an index in ``0..M-1`` is unused. Since every index is
        used, ``M <= n``: a larger label is refused before anything of size ``M`` is
        allocated.
    """

    def __init__(self, labels: Any, n_partitions: int | None = None) -> None:
        lab = check_array("labels", labels, integer=True)
        if lab.ndim != 1 or lab.size == 0:
            raise ValidationError(f"labels must be a non-empty 1-d array; got shape {lab.shape}")
        n = lab.size
        if (lab < 0).any():
            x = int(np.flatnonzero(lab < 0)[0])
            raise ValidationError(f"labels[{x}] = {int(lab[x])} is negative")
        if n_partitions is None:
            # every index 0..M-1 must be used, so M <= n: checked before bincount allocates M
            over = lab >= n
            if over.any():
                x = int(np.flatnonzero(over)[0])
                raise ValidationError(
                    f"labels[{x}] = {int(lab[x])} is out of range [0, {n}): labels must use "
                    f"every index 0..M-1, so M <= n_states = {n}"
                )
            m = int(lab.max()) + 1
        else:
            m = check_int("n_partitions", n_partitions, lo=1, hi=n)
        if (lab >= m).any():
            x = int(np.flatnonzero(lab >= m)[0])
            raise ValidationError(f"labels[{x}] = {int(lab[x])} is not below n_partitions = {m}")
        lab = lab.astype(index_dtype(max(m, n)))
        sizes = np.bincount(lab, minlength=m)
        if (sizes == 0).any():
            missing = np.flatnonzero(sizes == 0)
            raise ValidationError(
                f"partition index {int(missing[0])} has no state ({missing.size} of {m} indices "
                "unused): labels must use every index 0..M-1"
            )
        lab.flags.writeable = False
        sizes.flags.writeable = False
        self.labels = lab
        self.sizes = sizes

    @classmethod
    def from_keys(cls, keys: Any) -> Partition:
        """Partition states by equal rows of ``keys`` (shape (n,) or (n, k)).

        Partition indices follow the lexicographic order of the distinct keys.
        """
        k = as_array("keys", keys)
        if k.ndim not in (1, 2) or k.size == 0:
            raise ValidationError(f"keys must be a non-empty (n,) or (n, k) array; got {k.shape}")
        if k.ndim == 1:
            k = k[:, None]
        _, inverse = np.unique(k, axis=0, return_inverse=True)
        return cls(inverse.ravel())

    @classmethod
    def singletons(cls, n_states: int) -> Partition:
        """The finest partition: every state alone (RLP becomes the exact LP)."""
        return cls(np.arange(check_int("n_states", n_states, lo=1)))

    @property
    def n_states(self) -> int:
        """Number of states ``n``."""
        return int(self.labels.size)

    @property
    def n_partitions(self) -> int:
        """Number of partitions ``M``."""
        return int(self.sizes.size)

    @cached_property
    def _order(self) -> tuple[np.ndarray, np.ndarray]:
        order = np.argsort(self.labels, kind="stable")
        indptr = np.zeros(self.n_partitions + 1, dtype=np.int64)
        np.cumsum(self.sizes, out=indptr[1:])
        return order, indptr

    def members(self, i: int) -> np.ndarray:
        """The states of ``S_i``, in increasing order."""
        i = check_int("i", i)
        if not 0 <= i < self.n_partitions:
            raise ValidationError(f"partition index {i} is out of range [0, {self.n_partitions})")
        order, indptr = self._order
        return order[indptr[i] : indptr[i + 1]]

    @cached_property
    def basis(self) -> sp.csr_matrix:
        """The basis ``Phi`` of eq. (10), a sparse (n, M) 0/1 matrix."""
        import scipy.sparse as sp

        n = self.n_states
        return sp.csr_matrix(
            (np.ones(n), self.labels, np.arange(n + 1)), shape=(n, self.n_partitions)
        )

    def lift(self, v: Any) -> np.ndarray:
        """``Phi v``: the value of each state's partition, shape (n,) (or (n, k))."""
        arr = as_array("v", v)
        if arr.ndim == 0 or arr.shape[0] != self.n_partitions:
            raise ValidationError(
                f"a vector over partitions must have length {self.n_partitions}; got {arr.shape}"
            )
        return arr[self.labels]

    def aggregate(self, x: Any, how: str = "sum") -> np.ndarray:
        """Per-partition ``sum``, ``min``, ``max`` or ``mean`` of a per-state vector."""
        if how not in ("sum", "mean", "min", "max"):
            raise ValidationError(f"unknown aggregation {how!r}; use sum, mean, min or max")
        arr = as_float_array("x", x, finite=False)
        if arr.shape != (self.n_states,):
            raise ValidationError(
                f"a vector over states must have length {self.n_states}; got {arr.shape}"
            )
        if how in ("sum", "mean"):
            s = np.bincount(self.labels, weights=arr, minlength=self.n_partitions)
            return s / self.sizes if how == "mean" else s
        order, indptr = self._order
        if how == "min":
            return np.minimum.reduceat(arr[order], indptr[:-1])
        if how == "max":
            return np.maximum.reduceat(arr[order], indptr[:-1])
        raise ValidationError(f"unknown aggregation {how!r}; use sum, mean, min or max")

    def __repr__(self) -> str:
        return f"Partition(n_states={self.n_states}, n_partitions={self.n_partitions})"


def with_sink_block(labels: Any, sink: bool) -> Partition:
    """The partition of ``labels`` and, with ``sink``, one more state (a model's sink, its
    last state) in a block of its own, numbered after the others."""
    lab = check_array("labels", labels, integer=True)
    if sink:
        lab = np.append(lab, int(lab.max()) + 1 if lab.size else 0)
    return Partition(lab)
