"""Instance files of ``kind = "patrol"`` (``models/patrol-*.toml``).

::

    [model]
    kind = "patrol"
    N = 15                      # perimeter nodes
    stations = [0, 3, 7, 11]    # alert stations (Omega)
    D = 5                       # maximum dwell
    Gamma = 15                  # delay cap
    rho = 0.005
    discount = 0.9
    alpha = 0.016666666666666666
    # p_threat, a, b, c, g, mu1, mu2 (Appendix A), allow_empty_loiter = false

    [partition]
    kind = "patrol"             # the partition of Section 4.2 (no other key)

Missing keys take the paper's values; a misspelt key is an error naming it.
:func:`params_from_instance` gives the parameters of an instance without building its
MDP, so the partition-level bounds run on instances far too large to enumerate.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from typing import Any

from ..errors import ValidationError
from ..model.instances import Instance, check_keys
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from .model import PatrolModel
from .params import PatrolParams

__all__ = ["build_mdp", "build_partition", "model_for", "params_from_instance"]


@lru_cache(maxsize=2)
def model_for(params: PatrolParams) -> PatrolModel:
    """The (cached) :class:`PatrolModel` of ``params``: MDP and partition built once."""
    return PatrolModel(params)


def build_mdp(table: Mapping[str, Any]) -> FiniteMDP:
    """``MODEL_KINDS["patrol"]``: the full MDP of a ``[model]`` table."""
    return model_for(PatrolParams.from_table(table)).mdp()


def build_partition(table: Mapping[str, Any], instance: Instance) -> Partition:
    """``PARTITION_KINDS["patrol"]``: the partition of Section 4.2."""
    check_keys(table, {}, "partition")
    return model_for(params_from_instance(instance)).partition()


def params_from_instance(instance: Instance | str | Any) -> PatrolParams:
    """The :class:`PatrolParams` of a patrol instance (an Instance, a path or a name).

    Does not build the MDP.
    """
    if not isinstance(instance, Instance):
        from ..model.instances import load_instance

        instance = load_instance(instance)
    if instance.kind != "patrol":
        raise ValidationError(
            f"instance {instance.name!r} is of kind {instance.kind!r}, not 'patrol'"
        )
    return PatrolParams.from_table(instance.config["model"])
