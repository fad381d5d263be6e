"""Instance files (``models/*.toml``): named, reproducible models for the CLI and studies.

A file has a ``[model]`` table whose ``kind`` picks a builder, and optionally a
``[partition]`` table::

    [model]
    kind = "garnet"          # a seeded random MDP (lpbounds.model.generators.garnet)
    n_states = 500
    n_actions = 3
    branching = 5
    discount = 0.9
    seed = 1

    [partition]
    kind = "random"          # lpbounds.model.generators.random_partition (of the model:
    n_partitions = 50        # a sink, if it has one, in a set of its own)
    seed = 2

Builders are registered in :data:`MODEL_KINDS` and :data:`PARTITION_KINDS` (kind ->
``"module:function"``); unknown kinds and keys raise an error that names them. The MDP
and the partition are built lazily, so an instance too large for exact DP can still be
loaded for its partition-level bounds.
"""

from __future__ import annotations

import importlib
import math
import os
import stat
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from ..errors import ValidationError
from ..validation import check_bool, check_int, check_real
from .mdp import FiniteMDP
from .partition import Partition
from .shelf import (
    SHELF_KINDS,
    admission_queue,
    cliff_walking,
    forest,
    frozen_lake,
    gridworld,
    gymnasium_model,
    inventory,
    savings,
    taxi,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "MODEL_KINDS",
    "PARTITION_KINDS",
    "Instance",
    "admission_queue",
    "cliff_walking",
    "forest",
    "frozen_lake",
    "gridworld",
    "gymnasium_model",
    "inventory",
    "load_instance",
    "model_toml",
    "models_dir",
    "packaged_models_dir",
    "resolve_instance_path",
    "savings",
    "taxi",
]

#: kind -> "module:function(config: dict) -> FiniteMDP"
MODEL_KINDS: dict[str, str] = {
    "garnet": "lpbounds.model.instances:_build_garnet",
    "patrol": "lpbounds.patrol.instance:build_mdp",
    "explicit": "lpbounds.model.instances:_build_explicit",
    # the shelf of known models (lpbounds.model.shelf: forest, gridworld, ...)
    **{kind: "lpbounds.model.shelf:build_model" for kind in SHELF_KINDS},
}
#: kind -> "module:function(config: dict, instance: Instance) -> Partition"
PARTITION_KINDS: dict[str, str] = {
    "random": "lpbounds.model.instances:_build_random_partition",
    "patrol": "lpbounds.patrol.instance:build_partition",
    "labels": "lpbounds.model.instances:_build_labels_partition",
    "blocks": "lpbounds.model.shelf:build_blocks",  # consecutive states (the shelf's files)
    "grid": "lpbounds.model.shelf:build_grid",  # tiles of a grid of states
}


def models_dir() -> Path:
    """The ``models/`` folder: ``./models`` if it exists, else the one shipped in the package.

    The instance files are package data (``lpbounds/models/*.toml``, read through
    :mod:`importlib.resources`), so a non-editable install finds them from any directory;
    the repository's top-level ``models`` is a link to the same folder.
    """
    here = Path.cwd() / "models"
    if here.is_dir():
        return here
    return packaged_models_dir()


def packaged_models_dir() -> Path:
    """The folder of the instance files shipped inside the installed package."""
    return Path(str(resources.files("lpbounds") / "models"))


def resolve_instance_path(source: str | Path) -> Path:
    """The TOML file a MODEL argument names: an existing file first, then a packaged name.

    ``"garnet-small"``, ``"garnet-small.toml"`` and ``"models/garnet-small.toml"`` all name
    the packaged ``garnet-small.toml`` when no such file exists relative to the working
    directory (``./models`` is searched before the package's folder), so the README's
    commands work from any directory after ``pip install``.

    Raises
    ------
    ValidationError
        The path exists but is not a regular file (a directory, a FIFO, a device: found
        with ``stat``, never opened, as opening a FIFO would block), or names no file and
        no packaged model (the message lists the packaged names).
    """
    path = Path(source)
    kind = _file_kind(path)
    if kind == "regular file":
        return path
    if kind is not None:
        raise ValidationError(f"model: not a regular file: {str(source)!r} (a {kind})")
    bare = len(path.parts) == 1 or (len(path.parts) == 2 and path.parts[0] == "models")
    if bare and path.suffix in ("", ".toml"):
        stem = path.name[: -len(".toml")] if path.suffix == ".toml" else path.name
        for folder in dict.fromkeys((models_dir(), packaged_models_dir())):
            candidate = folder / f"{stem}.toml"
            if candidate.is_file():
                return candidate
    known = sorted(p.stem for p in packaged_models_dir().glob("*.toml"))
    raise ValidationError(
        f"no instance file {str(source)!r}, and no packaged model of that name; "
        f"packaged models: {', '.join(known)}"
    )


_FILE_KINDS = (
    (stat.S_ISREG, "regular file"),
    (stat.S_ISDIR, "directory"),
    (stat.S_ISFIFO, "FIFO"),
    (stat.S_ISCHR, "character device"),
    (stat.S_ISBLK, "block device"),
    (stat.S_ISSOCK, "socket"),
)


def _file_kind(path: Path) -> str | None:
    """What ``path`` is (``"regular file"``, ``"FIFO"``, ...) by ``stat``, which never opens
    it; None when nothing is there (or it cannot be looked at)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    return next((name for test, name in _FILE_KINDS if test(mode)), "special file")


def _resolve(spec: str) -> Callable[..., Any]:
    module, _, name = spec.partition(":")
    return getattr(importlib.import_module(module), name)


def check_keys(table: Mapping[str, Any], allowed: Mapping[str, Any], where: str) -> dict[str, Any]:
    """Merge ``table`` over the defaults ``allowed``; an unknown key raises ValidationError.

    A default of ``...`` marks a required key.
    """
    if not isinstance(table, Mapping):
        raise ValidationError(f"[{where}] must be a table; got {table!r}")
    unknown = sorted(set(table) - set(allowed) - {"kind"})
    if unknown:
        raise ValidationError(f"unknown key(s) {unknown} in [{where}]; allowed: {sorted(allowed)}")
    out = {k: table.get(k, v) for k, v in allowed.items()}
    missing = [k for k, v in out.items() if v is ...]
    if missing:
        raise ValidationError(f"missing key(s) {missing} in [{where}]")
    return out


@dataclass
class Instance:
    """A loaded instance: its name, configuration and lazily built MDP and partition."""

    name: str
    config: dict[str, Any]
    path: Path | None = None
    _mdp: FiniteMDP | None = field(default=None, repr=False)
    _partition: Partition | None = field(default=None, repr=False)

    @property
    def kind(self) -> str:
        """The ``[model] kind``."""
        return str(self.config["model"]["kind"])

    @property
    def has_partition(self) -> bool:
        """True when the file has a ``[partition]`` table or the kind defines one."""
        return "partition" in self.config

    def mdp(self) -> FiniteMDP:
        """The MDP (built on first use)."""
        if self._mdp is None:
            model = self.config["model"]
            self._mdp = _resolve(MODEL_KINDS[self.kind])(model)
        return self._mdp

    def partition(self) -> Partition:
        """The partition of the ``[partition]`` table (built on first use)."""
        if self._partition is None:
            table = self.config.get("partition")
            if table is None:
                raise ValidationError(f"instance {self.name!r} has no [partition] table")
            if not isinstance(table, Mapping):
                raise ValidationError(f"[partition] must be a table; got {table!r}")
            kind = table.get("kind")
            if not isinstance(kind, str) or kind not in PARTITION_KINDS:
                raise ValidationError(
                    f"unknown partition kind {kind!r}; known: {sorted(PARTITION_KINDS)}"
                )
            self._partition = _resolve(PARTITION_KINDS[kind])(table, self)
        return self._partition


def load_instance(source: str | Path | Mapping[str, Any], name: str | None = None) -> Instance:
    """Load an instance from a TOML file, a name in ``models/``, or a dict.

    Parameters
    ----------
    source : path, name or mapping
        ``"models/garnet-small.toml"``, ``"garnet-small"`` (resolved by
        :func:`resolve_instance_path`: a file first, then a packaged model), or the
        parsed tables.
    name : str, optional
        Display name (default: the file's stem).
    """
    path: Path | None = None
    if name is not None and not isinstance(name, str):
        raise ValidationError(f"name must be a string or None; got {name!r}")
    if isinstance(source, Mapping):
        config = dict(source)
    elif isinstance(source, (str, os.PathLike)):
        path = resolve_instance_path(source)
        config = _read_toml(path)
    else:
        raise ValidationError(
            f"source must be a path, a model name or a mapping; got {type(source).__name__}"
        )
    model = config.get("model")
    if not isinstance(model, Mapping) or "kind" not in model:
        raise ValidationError("an instance needs a [model] table with a 'kind'")
    if not isinstance(model["kind"], str) or model["kind"] not in MODEL_KINDS:
        raise ValidationError(f"unknown model kind {model['kind']!r}; known: {sorted(MODEL_KINDS)}")
    display = name or (path.stem if path is not None else str(model["kind"]))
    return Instance(name=display, config=config, path=path)


def _read_toml(path: Path) -> dict[str, Any]:
    """The parsed tables of an instance file (unreadable or invalid files: ValidationError)."""
    try:
        # O_NONBLOCK: a path replaced by a FIFO since it was resolved does not block the
        # open; fstat then refuses it (no effect on a regular file)
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise ValidationError(f"model: not a regular file: {str(path)!r}")
            return tomllib.load(fh)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValidationError(f"{path}: not valid TOML: {exc}") from exc
    except OSError as exc:
        raise ValidationError(f"{path}: cannot read the instance file: {exc}") from exc


# ---------------------------------------------------------------------- builders
_GARNET_KEYS = {
    "n_states": ...,
    "n_actions": ...,
    "branching": ...,
    "discount": 0.9,
    "seed": 0,
    "shared_probabilities": False,
    "reward_low": 0.0,
    "reward_high": 1.0,
    "allowed_fraction": 1.0,
}


def _build_garnet(table: Mapping[str, Any]) -> FiniteMDP:
    from .generators import check_garnet_rewards, check_garnet_size, garnet

    c = check_keys(table, _GARNET_KEYS, "model")
    # the file's values are checked, never coerced (a "0.9" string or 10.7 states is an error)
    n = check_int("[model] n_states", c["n_states"], lo=1)
    a = check_int("[model] n_actions", c["n_actions"], lo=1)
    branching = check_int("[model] branching", c["branching"], lo=1)
    discount = check_real("[model] discount", c["discount"], lo=0.0, hi=1.0, hi_open=True)
    seed = check_int("[model] seed", c["seed"], lo=0)
    shared = check_bool("[model] shared_probabilities", c["shared_probabilities"])
    low = check_real("[model] reward_low", c["reward_low"])
    high = check_real("[model] reward_high", c["reward_high"])
    allowed = check_real(
        "[model] allowed_fraction", c["allowed_fraction"], lo=0.0, hi=1.0, lo_open=True
    )
    if low > high:
        raise ValidationError(f"[model] reward_low = {low} is above reward_high = {high}")
    # named as the file names them, before garnet() allocates anything
    check_garnet_rewards("[model] reward_low, reward_high", low, high, discount)
    check_garnet_size(n, a, branching, shared, prefix="[model] ")
    return garnet(
        n,
        a,
        branching,
        discount,
        seed,
        shared_probabilities=shared,
        reward_range=(low, high),
        allowed_fraction=allowed,
    )


def _build_random_partition(table: Mapping[str, Any], instance: Instance) -> Partition:
    from .generators import random_partition

    c = check_keys(table, {"n_partitions": ..., "seed": 0}, "partition")
    n_partitions = check_int("[partition] n_partitions", c["n_partitions"], lo=1)
    seed = check_int("[partition] seed", c["seed"], lo=0)
    return random_partition(instance.mdp(), n_partitions, seed)


# ---------------------------------------------------------------------- explicit arrays
#: ``kind = "explicit"``: a small MDP written out in full, as :class:`FiniteMDP` takes it
#: (``successors[x][u][l]``, ``probabilities[l]`` or ``[x][u][l]``, ``rewards[x][u]``,
#: ``allowed[x][u]`` optional); shrunk counterexamples are written so
#: (:mod:`lpbounds.studies.shrink`). Validated by :class:`FiniteMDP`, which names the entry.
_EXPLICIT_KEYS = {
    "successors": ...,
    "probabilities": ...,
    "rewards": ...,
    "discount": ...,
    "allowed": None,
}


def _build_explicit(table: Mapping[str, Any]) -> FiniteMDP:
    c = check_keys(table, _EXPLICIT_KEYS, "model")
    discount = check_real("[model] discount", c["discount"], lo=0.0, hi=1.0, hi_open=True)
    try:
        return FiniteMDP(c["successors"], c["probabilities"], c["rewards"], discount, c["allowed"])
    except ValidationError as exc:
        raise ValidationError(f"[model] {exc}") from None


def _build_labels_partition(table: Mapping[str, Any], instance: Instance) -> Partition:
    """``kind = "labels"``: ``labels[x]``, the block of state ``x`` (0-based)."""
    c = check_keys(table, {"labels": ...}, "partition")
    n = instance.mdp().n_states
    try:
        part = Partition(c["labels"])
    except ValidationError as exc:
        raise ValidationError(f"[partition] {exc}") from None
    if part.n_states != n:
        raise ValidationError(
            f"[partition] labels has {part.n_states} entries; the model has {n} states"
        )
    return part


# ---------------------------------------------------------------------- writing
def _toml_value(a: Any) -> str:
    """A nested TOML array (floats written as Python's shortest round-trip repr)."""
    if a.ndim == 0:
        t = a.item()
        if isinstance(t, bool):
            return "true" if t else "false"
        if isinstance(t, int):
            return str(t)
        return repr(float(t)) if math.isfinite(t) else ("nan" if t != t else str(t))
    return "[" + ", ".join(_toml_value(t) for t in a) + "]"


def model_toml(mdp: FiniteMDP, partition: Partition, header: Sequence[str] = ()) -> str:
    """The instance as the text of an instance file (``kind = "explicit"``).

    Parameters
    ----------
    mdp, partition
        The instance (rewards as stored: the reward-maximising form).
    header : sequence of str
        Comment lines written first (each prefixed with ``# ``).

    Returns
    -------
    str
        ``[model]`` with ``successors[x][u][l]``, ``probabilities`` (``[l]`` or
        ``[x][u][l]``), ``rewards[x][u]`` (0 on disallowed pairs), ``discount`` and
        ``allowed[x][u]`` when some pair is disallowed; ``[partition]`` with ``labels``.
        Read back by :func:`load_instance`, it gives the same arrays bit for bit (the
        writer of :mod:`lpbounds.studies.shrink`'s counterexample files).
    """
    import numpy as np

    rewards = np.where(mdp.allowed, mdp.rewards, 0.0)
    lines = [f"# {h}" for h in header]
    lines += [
        "[model]",
        'kind = "explicit"',
        f"discount = {_toml_value(np.asarray(float(mdp.discount)))}",
        "# successors[x][u][l] = f(x, u, Y_l)",
        f"successors = {_toml_value(np.asarray(mdp.successors, dtype=np.int64))}",
        f"probabilities = {_toml_value(np.asarray(mdp.probabilities, dtype=np.float64))}",
        f"rewards = {_toml_value(rewards)}",
    ]
    if not mdp.allowed.all():
        lines.append(f"allowed = {_toml_value(np.asarray(mdp.allowed, dtype=bool))}")
    lines += [
        "",
        "[partition]",
        'kind = "labels"',
        f"labels = {_toml_value(np.asarray(partition.labels, dtype=np.int64))}",
    ]
    return "\n".join(lines) + "\n"
