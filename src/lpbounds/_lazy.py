"""Package tables of contents that import a name's module on first use (PEP 562).

A package ``__init__`` lists its public names and the submodule defining each, and gets
its module ``__getattr__`` and ``__dir__`` from :func:`attach`: ``import lpbounds.patrol``
then imports no submodule, ``from lpbounds.formulations import RLP`` imports
:mod:`lpbounds.formulations.rlp` (and what it needs) and nothing else, and the command
line loads only what a command uses. Type checkers read the same names from the
package's ``if TYPE_CHECKING:`` imports.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["attach"]


def attach(
    package: str, names: Mapping[str, str], submodules: Mapping[str, str] | None = None
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    names : mapping
        Public name -> the submodule that defines it, relative to the package
        (``"rlp"``, ``"nlp.problem"``); imported on first access, then cached in the
        package's namespace.
    submodules : mapping, optional
        Attribute -> submodule (relative) reachable as an attribute without importing it
        first.
    """
    table = dict(names)
    subs = dict(submodules or {})

    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is not None:
            value = getattr(importlib.import_module(f".{module}", package), name)
            setattr(sys.modules[package], name, value)
            return value
        if name in subs:
            return importlib.import_module(f".{subs[name]}", package)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(table) | set(subs))

    return __getattr__, __dir__
