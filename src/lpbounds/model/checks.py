"""The argument checks of functions that take model objects (an MDP, a partition of it).

They live in the model layer, beside the classes they check, so that the shared
:mod:`lpbounds.validation` never imports a layer above it.
"""

from __future__ import annotations

from typing import Any

from ..errors import PartitionWarning, ValidationError, warn
from ..validation import NUMERIC_KINDS, check_array, describe_value
from .mdp import FiniteMDP
from .partition import Partition

__all__ = [
    "check_formulation_inputs",
    "check_model",
    "check_partition",
    "sink_block",
    "sink_block_note",
]


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


def sink_block(mdp: FiniteMDP, partition: Partition) -> int | None:
    """The block of ``partition`` that holds ``mdp``'s sink together with live states, or
    None (no sink, or the sink alone in its block).

    The sink (``mdp.sink``: the last state, absorbing, reward 0, added by a converter for
    the transitions that end an episode) is worth 0 under every policy. In a block with
    live states it shares their variable ``v(i)``: the transitions into it are then worth
    ``v(i)`` instead of 0 (RLP's row of the sink gives ``v(i) >= 0``), so the aggregated
    bounds of that block, and of every block that reaches it, can be far looser
    (docs/interop.md gives the figures on FrozenLake and Taxi).
    """
    if not mdp.sink:
        return None
    block = int(partition.labels[mdp.n_states - 1])
    return block if int(partition.sizes[block]) > 1 else None


def sink_block_note(mdp: FiniteMDP, partition: Partition) -> str | None:
    """A :class:`~lpbounds.errors.PartitionWarning` when ``partition`` mixes ``mdp``'s sink
    with live states (:func:`sink_block`), at the caller's line; returns its text (for the
    result's summary), or None when the partition keeps the sink alone or there is none.

    The partition is valid and every bound computed from it holds: the warning says that
    they are weaker than they need to be, and how to keep the sink in a block of its own.
    """
    block = sink_block(mdp, partition)
    if block is None:
        return None
    others = int(partition.sizes[block]) - 1
    note = (
        f"block {block} holds the sink (state {mdp.n_states - 1}, worth 0) and {others} "
        f"live state{'s' if others > 1 else ''}: the bounds hold but can be far looser (a "
        "transition into the sink is valued at the block's variable, not 0); keep the sink "
        "alone: lpbounds.random_partition(mdp, M)"
    )
    warn(f"partition: {note}", PartitionWarning)
    return note
