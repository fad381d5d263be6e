"""The perimeter alert patrol problem (paper Sections 4-6, Appendix A).

* :mod:`~lpbounds.patrol.params`: :class:`PatrolParams` (the paper's names and defaults);
* :mod:`~lpbounds.patrol.model`: :class:`PatrolModel`, the full MDP and its partition;
* :mod:`~lpbounds.patrol.partitions`: the partition keys and their indexing;
* :mod:`~lpbounds.patrol.bounds`: UBLP and LBLP (Theorems 3, 4) built from the partitions
  alone, for instances far too large to enumerate;
* :mod:`~lpbounds.patrol.instance`: the ``kind = "patrol"`` instance files.

A table of contents: each name's module is imported on first use (PEP 562,
:mod:`lpbounds._lazy`), so a module of the package (``lpbounds.patrol.params`` for
``lpbounds models``) loads without the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import attach

if TYPE_CHECKING:  # what type checkers see; at run time see __getattr__
    from .model import ACTION_NAMES, ACTION_U, PatrolModel
    from .params import PatrolParams

#: public name -> the submodule that defines it (imported on first access)
_LAZY: dict[str, str] = {
    "ACTION_NAMES": "model",
    "ACTION_U": "model",
    "PatrolModel": "model",
    "PatrolParams": "params",
}

__all__ = ["ACTION_NAMES", "ACTION_U", "PatrolModel", "PatrolParams"]

__getattr__, __dir__ = attach(__name__, _LAZY)
