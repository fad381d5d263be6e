"""Partition: validation, the basis Phi of eq. (10), lift and aggregation."""

from __future__ import annotations

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.errors import ValidationError


def test_basis_and_lift():
    part = lb.Partition([2, 0, 1, 0, 2])
    assert part.n_partitions == 3 and part.n_states == 5
    np.testing.assert_array_equal(part.sizes, [2, 1, 2])
    phi = part.basis.toarray()
    assert phi.shape == (5, 3)
    np.testing.assert_array_equal(phi.sum(axis=1), 1)
    v = np.array([10.0, 20.0, 30.0])
    np.testing.assert_array_equal(part.lift(v), phi @ v)
    np.testing.assert_array_equal(part.members(0), [1, 3])


def test_aggregate():
    part = lb.Partition([1, 0, 1, 0])
    x = np.array([5.0, -1.0, 2.0, 7.0])
    np.testing.assert_array_equal(part.aggregate(x, "min"), [-1.0, 2.0])
    np.testing.assert_array_equal(part.aggregate(x, "max"), [7.0, 5.0])
    np.testing.assert_array_equal(part.aggregate(x, "sum"), [6.0, 7.0])
    np.testing.assert_array_equal(part.aggregate(x, "mean"), [3.0, 3.5])
    with pytest.raises(ValidationError, match="unknown aggregation"):
        part.aggregate(x, "median")


def test_labels_that_skip_an_index():
    with pytest.raises(ValidationError, match="partition index 1 has no state"):
        lb.Partition([0, 2, 2])


def test_negative_and_too_large_labels():
    with pytest.raises(ValidationError, match=r"labels\[1\] = -1 is negative"):
        lb.Partition([0, -1])
    with pytest.raises(ValidationError, match="not below n_partitions"):
        lb.Partition([0, 1, 2], n_partitions=2)


def test_partition_must_match_the_mdp(small_mdp):
    with pytest.raises(ValidationError, match="the partition has 3 states"):
        lb.BellmanRows.aggregate(small_mdp, lb.Partition([0, 1, 1]))


def test_from_keys_and_singletons():
    part = lb.Partition.from_keys(np.array([[1, 2], [0, 5], [1, 2]]))
    np.testing.assert_array_equal(part.labels, [1, 0, 1])
    np.testing.assert_array_equal(lb.Partition.singletons(4).labels, np.arange(4))


def test_random_partition_uses_every_index():
    part = lb.random_partition(50, 50, seed=4)
    assert sorted(part.labels.tolist()) == list(range(50))
    with pytest.raises(ValidationError):
        lb.random_partition(5, 6)


def test_huge_label_is_refused_before_allocating():
    """Partition([0, 2**40]) used to ask bincount for 2**40 counters (8 TiB)."""
    with pytest.raises(ValidationError, match=r"labels\[1\] = 1099511627776 is out of range"):
        lb.Partition(np.array([0, 2**40]))
    with pytest.raises(ValidationError, match="n_partitions must lie in"):
        lb.Partition([0, 1], n_partitions=2**40)
    with pytest.raises(ValidationError, match="n_partitions must be an integer"):
        lb.random_partition(10, 3.7)
