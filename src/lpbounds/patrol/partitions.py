r"""The partitions of Section 4.2 and their indexing, shared by the state and partition levels.

States with the same ``(l, w, d, A_1..A_m, taubar)``, ``A_j = [tau_j > 0]`` and
``taubar = max_j tau_j``, form one partition. The realisable keys are

* travel (``d = 0``, ``w = +-1``, any node ``l``): ``A = 0`` with ``taubar = 0`` (one
  key), or ``A != 0`` with ``taubar`` in ``1..Gamma`` (``(2^m - 1) Gamma`` keys);
* loiter (``d = 1..D``, ``w = +1``, ``l`` a station, ``A_l = 0``): the same over the
  other ``m - 1`` stations (``1 + (2^(m-1) - 1) Gamma`` keys),

which gives eq. (28). Indices are assigned in the lexicographic order of
``(travel block: l, w = +1 before -1; then loiter block: station position, d)``, then
the alert pattern ``A`` read as a binary number with ``A_1`` the most significant bit,
then ``taubar``. :func:`partition_index` is the only map from keys to indices: the
state-level model (:mod:`lpbounds.patrol.model`) and the partition-level bounds
(:mod:`lpbounds.patrol.bounds`) both call it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._kernels.extensions import patrolsweeps as _c
from ..errors import ValidationError
from .params import PatrolParams

__all__ = [
    "alert_key_kernel",
    "block_sizes",
    "decode_partition",
    "key_index_kernel",
    "partition_components",
    "partition_index",
    "state_partition_kernel",
]


def block_sizes(params: PatrolParams) -> tuple[int, int]:
    """Number of keys per travel ``(l, w)`` and per loiter ``(station, d)`` block."""
    m, g = params.m, params.Gamma
    return 1 + (2**m - 1) * g, 1 + (2 ** (m - 1) - 1) * g


def _bits_weights(m: int) -> np.ndarray:
    return (1 << np.arange(m - 1, -1, -1)).astype(np.int64)


def partition_index(
    params: PatrolParams,
    l: Any,
    w: Any,
    d: Any,
    A: Any,
    taubar: Any,
    check: bool = True,
) -> np.ndarray:
    """Partition index (0-based) of the key ``(l, w, d, A_1..A_m, taubar)``, vectorised.

    Parameters
    ----------
    params : PatrolParams
    l, w, d, taubar : array_like of int, shape (k,)
    A : array_like of bool/int, shape (k, m)
    check : bool
        Validate that every key is realisable (raises ValidationError naming the first
        bad one). The model's internal calls pass False on keys they built themselves.

    Returns
    -------
    ndarray of int64, shape (k,)
    """
    l = np.asarray(l, dtype=np.int64).reshape(-1)
    w = np.asarray(w, dtype=np.int64).reshape(-1)
    d = np.asarray(d, dtype=np.int64).reshape(-1)
    tb = np.asarray(taubar, dtype=np.int64).reshape(-1)
    A = np.asarray(A).astype(bool).reshape(l.size, params.m)
    n_nodes, m, big_d, g = params.N, params.m, params.D, params.Gamma
    tb_size, lb_size = block_sizes(params)
    if check:
        _check_keys(params, l, w, d, A, tb)
    pos = params.station_pos[np.clip(l, 0, n_nodes - 1)]
    travel = d == 0
    acode = A.astype(np.int64) @ _bits_weights(m)
    within_t = np.where(acode == 0, 0, 1 + (acode - 1) * g + (tb - 1))
    idx_t = (2 * l + (w < 0)) * tb_size + within_t
    # loiter: drop the own station's bit (A_own = 0) from the code
    k = np.maximum(pos, 0)
    low = acode & ((1 << (m - 1 - k)) - 1)  # bits of stations after k
    high = acode >> (m - k)  # bits of stations before k
    acode_l = (high << (m - 1 - k)) | low
    within_l = np.where(acode_l == 0, 0, 1 + (acode_l - 1) * g + (tb - 1))
    idx_l = 2 * n_nodes * tb_size + (k * big_d + d - 1) * lb_size + within_l
    return np.where(travel, idx_t, idx_l)


def key_index_kernel(
    l: int, w: int, d: int, acode: int, tb: int, station_pos: np.ndarray, n_nodes: int,
    big_d: int, gamma: int, tb_size: int, lb_size: int, m: int,
) -> int:  # fmt: skip
    """:func:`partition_index` of one key, compiled (scalar; the C of the matrix-free
    sweeps and the greedy policy, ``patrol.h``): ``acode`` is the alert pattern ``A`` as a
    binary number (``A_1`` the most significant of ``m`` bits), ``tb`` the maximum delay;
    ``tb_size, lb_size`` are :func:`block_sizes`. A ValueError for ``l`` outside the nodes
    or a loiter key (``d >= 1``) away from a station."""
    return int(
        _c.key_index(
            int(l), int(w), int(d), int(acode), int(tb), _i8(station_pos), int(n_nodes),
            int(big_d), int(gamma), int(tb_size), int(lb_size), int(m),
        )
    )  # fmt: skip


def alert_key_kernel(tau: np.ndarray) -> tuple[int, int]:
    """``(acode, taubar)`` of one delay vector: the key's alert pattern and maximum delay."""
    acode, tb = _c.alert_key(np.ascontiguousarray(tau))
    return int(acode), int(tb)


def state_partition_kernel(
    l: int, w: int, d: int, tau: np.ndarray, station_pos: np.ndarray, n_nodes: int,
    big_d: int, gamma: int, tb_size: int, lb_size: int,
) -> int:  # fmt: skip
    """:func:`partition_index` of one state given by its components, compiled (scalar).

    ``tau`` is the state's delay vector (length m). The key index of the C kernels that
    act states out one at a time; tested equal to :func:`partition_index` on every state of
    small instances (tests/patrol/test_greedy_mc.py).
    """
    return int(
        _c.state_partition(
            int(l), int(w), int(d), np.ascontiguousarray(tau), _i8(station_pos), int(n_nodes),
            int(big_d), int(gamma), int(tb_size), int(lb_size),
        )
    )  # fmt: skip


def _i8(a: Any) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def _check_keys(
    params: PatrolParams,
    l: np.ndarray,
    w: np.ndarray,
    d: np.ndarray,
    A: np.ndarray,
    tb: np.ndarray,
) -> None:
    n = l.size
    if not (w.size == d.size == tb.size == n):
        raise ValidationError("l, w, d, taubar must have the same length (and A k rows)")
    pos = params.station_pos[np.clip(l, 0, params.N - 1)]
    own = np.zeros(n, dtype=bool)
    at = pos >= 0
    own[at] = A[np.flatnonzero(at), pos[at]]
    bad = {
        "l outside 0..N-1": (l < 0) | (l >= params.N),
        "w not +1 or -1": (w != 1) & (w != -1),
        "d outside 0..D": (d < 0) | (d > params.D),
        "taubar outside 0..Gamma": (tb < 0) | (tb > params.Gamma),
        "taubar = 0 with an alert, or > 0 without one": (tb == 0) == A.any(axis=1),
        "d >= 1 at a node that is not a station": (d >= 1) & ~at,
        "d >= 1 with w = -1 (loiter states have w = +1)": (d >= 1) & (w != 1),
        "d >= 1 with an alert at the own station": (d >= 1) & own,
    }
    for what, mask in bad.items():
        if mask.any():
            i = int(np.flatnonzero(mask)[0])
            raise ValidationError(
                f"partition key {i} (l={l[i]}, w={w[i]}, d={d[i]}, A={A[i].astype(int).tolist()}, "
                f"taubar={tb[i]}) is not realisable: {what}"
            )


def decode_partition(
    params: PatrolParams, index: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Inverse of :func:`partition_index`: ``(l, w, d, A (k, m) bool, taubar)``."""
    i = np.asarray(index, dtype=np.int64).reshape(-1)
    total = params.n_partitions
    if i.size and (i.min() < 0 or i.max() >= total):
        raise ValidationError(f"partition index outside [0, {total})")
    n_nodes, m, big_d, g = params.N, params.m, params.D, params.Gamma
    tb_size, lb_size = block_sizes(params)
    t_total = 2 * n_nodes * tb_size
    travel = i < t_total
    l = np.zeros(i.size, dtype=np.int64)
    w = np.ones(i.size, dtype=np.int64)
    d = np.zeros(i.size, dtype=np.int64)
    tb = np.zeros(i.size, dtype=np.int64)
    acode = np.zeros(i.size, dtype=np.int64)
    # travel block
    it = i[travel]
    lw, within = np.divmod(it, tb_size)
    l[travel] = lw // 2
    w[travel] = np.where(lw % 2 == 1, -1, 1)
    nz = within > 0
    acode_t = np.where(nz, (within - 1) // g + 1, 0)
    acode[travel] = acode_t
    tb[travel] = np.where(nz, (within - 1) % g + 1, 0)
    # loiter block
    il = i[~travel] - t_total
    kd, within = np.divmod(il, lb_size)
    k = kd // big_d
    d[~travel] = kd % big_d + 1
    l[~travel] = np.asarray(params.stations, dtype=np.int64)[k]
    nz = within > 0
    code_l = np.where(nz, (within - 1) // g + 1, 0)
    tb[~travel] = np.where(nz, (within - 1) % g + 1, 0)
    # re-insert a 0 bit at position k
    low = code_l & ((1 << (m - 1 - k)) - 1)
    high = code_l >> (m - 1 - k)
    acode[~travel] = (high << (m - k)) | low
    A = (acode[:, None] & _bits_weights(m)[None, :]) != 0
    return l, w, d, A, tb


def partition_components(params: PatrolParams, dtype: Any = np.int64) -> np.ndarray:
    """Every partition's key, an int array (M, 4 + m): columns l, w, d, A_1..A_m, taubar."""
    l, w, d, A, tb = decode_partition(params, np.arange(params.n_partitions))
    return np.column_stack([l, w, d, A.astype(np.int64), tb]).astype(dtype)
