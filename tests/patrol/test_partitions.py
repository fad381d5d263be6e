"""Partition keys and indices (Section 4.2): round trips, eq. 28, realisability checks."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from lpbounds.errors import ValidationError
from lpbounds.patrol.params import PatrolParams
from lpbounds.patrol.partitions import decode_partition, partition_components, partition_index

PARAMS = [
    PatrolParams(),
    PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4),
    PatrolParams(N=3, stations=(1,), D=1, Gamma=2),
    PatrolParams(N=7, stations=(6, 2, 4), D=3, Gamma=5),
    PatrolParams(N=24, stations=tuple(range(0, 24, 3)), D=5, Gamma=12),
]


def _all_keys_by_loops(p: PatrolParams) -> set[tuple[int, ...]]:
    """Every realisable key (l, w, d, A..., taubar), listed by loops from Section 4.2."""
    keys = set()
    for l in range(p.N):
        for w in (1, -1):
            for A in itertools.product((0, 1), repeat=p.m):
                for tb in range(1, p.Gamma + 1) if any(A) else [0]:
                    keys.add((l, w, 0, *A, tb))
    for k, s in enumerate(p.stations):
        for d in range(1, p.D + 1):
            for A in itertools.product((0, 1), repeat=p.m):
                if A[k] == 0:
                    for tb in range(1, p.Gamma + 1) if any(A) else [0]:
                        keys.add((s, 1, d, *A, tb))
    return keys


@pytest.mark.parametrize("p", PARAMS[:4], ids=lambda p: f"N{p.N}m{p.m}")
def test_components_are_exactly_the_realisable_keys(p):
    pc = partition_components(p)
    assert pc.shape == (p.n_partitions, 4 + p.m)
    got = {tuple(int(v) for v in row) for row in pc}
    assert len(got) == pc.shape[0], "distinct keys"
    assert got == _all_keys_by_loops(p)


@pytest.mark.parametrize("p", PARAMS, ids=lambda p: f"N{p.N}m{p.m}")
def test_index_decode_round_trip(p):
    idx = np.arange(p.n_partitions)
    l, w, d, A, tb = decode_partition(p, idx)
    assert np.array_equal(partition_index(p, l, w, d, A, tb), idx)


def test_paper_order_starts_with_travel_keys():
    p = PatrolParams()
    pc = partition_components(p)
    assert pc[0].tolist() == [0, 1, 0, 0, 0, 0, 0, 0]
    assert pc[1].tolist() == [0, 1, 0, 0, 0, 0, 1, 1]  # A = 0001, taubar = 1
    assert (pc[:, 2] == 0).sum() == 2 * 15 * (1 + 15 * 15)


@pytest.mark.parametrize(
    "key, why",
    [
        ((1, 1, 1, (0, 0), 0), "not a station"),
        ((0, -1, 1, (0, 0), 0), "w = -1"),
        ((0, 1, 1, (1, 0), 2), "own station"),
        ((0, 1, 0, (0, 0), 3), "taubar = 0 with an alert"),
        ((0, 1, 0, (1, 0), 5), "taubar outside"),
        ((0, 1, 3, (0, 0), 0), "d outside"),
    ],
)
def test_unrealisable_keys_raise(key, why):
    p = PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4)
    l, w, d, A, tb = key
    with pytest.raises(ValidationError, match=why):
        partition_index(p, [l], [w], [d], [A], [tb])
