"""The perimeter alert patrol problem (paper Sections 4-6, Appendix A).

* :mod:`~lpbounds.patrol.params`: :class:`PatrolParams` (the paper's names and defaults);
* :mod:`~lpbounds.patrol.model`: :class:`PatrolModel`, the full MDP and its partition;
* :mod:`~lpbounds.patrol.partitions`: the partition keys and their indexing;
* :mod:`~lpbounds.patrol.bounds`: UBLP and LBLP (Theorems 3, 4) built from the partitions
  alone, for instances far too large to enumerate;
* :mod:`~lpbounds.patrol.instance`: the ``kind = "patrol"`` instance files.
"""

from __future__ import annotations

from .model import ACTION_NAMES, ACTION_U, PatrolModel
from .params import PatrolParams

__all__ = ["ACTION_NAMES", "ACTION_U", "PatrolModel", "PatrolParams"]
