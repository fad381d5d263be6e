"""The argument checks of functions that take model objects (an MDP, a partition of it).

They live in the model layer, beside the classes they check, so that the shared
:mod:`lpbounds.validation` never imports a layer above it.
"""

from __future__ import annotations

from typing import Any

from ..errors import ValidationError
from ..validation import NUMERIC_KINDS, check_array, describe_value
from .mdp import FiniteMDP
from .partition import Partition

__all__ = ["check_formulation_inputs", "check_model", "check_partition"]


def check_model(mdp: Any, name: str = "mdp") -> Any:
    """``mdp`` if it is a :class:`~lpbounds.model.mdp.FiniteMDP`."""
    if not isinstance(mdp, FiniteMDP):
        raise ValidationError(f"{name} must be a FiniteMDP; got {describe_value(mdp)}")
    return mdp


def check_partition(partition: Any, mdp: Any = None, name: str = "partition") -> Any:
    """``partition`` if it is a :class:`~lpbounds.model.partition.Partition`.

    Of ``mdp``'s states when ``mdp`` is given.
    """
    if not isinstance(partition, Partition):
        raise ValidationError(f"{name} must be a Partition; got {describe_value(partition)}")
    if mdp is not None and partition.n_states != mdp.n_states:
        raise ValidationError(
            f"the partition has {partition.n_states} states but the MDP has {mdp.n_states}"
        )
    return partition


_NO_PARTITION = object()


def check_formulation_inputs(mdp: Any, partition: Any = _NO_PARTITION, **arrays: Any) -> None:
    """The shared argument checks of a formulation's constructor.

    ``mdp`` must be a FiniteMDP, ``partition`` (when the formulation takes one) a
    Partition of its states, and each keyword array that is not None (costs, weights,
    a basis) must hold real numbers (dtype checked before the formulation casts it;
    shapes, signs and finiteness are the formulation's own checks). A scipy.sparse
    matrix is checked by its dtype.
    """
    check_model(mdp)
    if partition is not _NO_PARTITION:
        check_partition(partition, mdp)
    for key, value in arrays.items():
        if value is None:
            continue
        if hasattr(value, "tocsr") and hasattr(value, "dtype"):  # scipy.sparse
            if value.dtype.kind not in NUMERIC_KINDS:
                raise ValidationError(f"{key} must hold real numbers; got dtype {value.dtype}")
            continue
        check_array(key, value, finite=False)
