"""``lpbounds models``: the packaged and named instance files, with their sizes and sources.

Every model a MODEL argument can name: the files of ``./models`` (when it exists; they
are found first) and those shipped in the package (``lpbounds/models``). For each: its
name, kind, states, actions, (state, action) pairs, discount, number of partition sets,
source, what it needs beyond lpbounds (``gymnasium``) and its path. Sizes are read from
the parameters where the kind allows it (the patrol files by eq. 27-28, the garnets,
the shelf's models), so listing never enumerates a large model. A Gymnasium model's sizes
are Gymnasium's: they are read from it when the model is named (``lpbounds models
frozenlake``) and Gymnasium is installed, and shown as ``-`` in the full listing, which
imports no optional package (whether one is installed is found with
:func:`importlib.util.find_spec`). ``--json`` prints the same list for machines.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ._common import console, print_table

__all__ = ["ModelEntry", "catalogue", "register", "run"]

#: Sources of the kinds whose files have no ``[about] source``.
KIND_SOURCES: dict[str, str] = {
    "garnet": "a seeded random MDP (Garnet style, lpbounds.garnet)",
    "patrol": "Park et al., the perimeter patrol problem (Sections 5-6, Appendix A)",
    "explicit": "written out in the file",
}

#: Models with at most this many successor entries (states x actions x outcomes) are
#: built when their sizes cannot be read from their parameters.
BUILD_LIMIT = 10_000_000


@dataclass
class ModelEntry:
    """One model of the listing (None: not known without building it)."""

    name: str
    kind: str
    path: str
    n_states: int | None = None
    n_actions: int | None = None
    #: outcomes per pair (``L`` of ``successors (n, A, L)``)
    n_outcomes: int | None = None
    n_pairs: int | None = None
    discount: float | None = None
    n_partitions: int | None = None
    title: str = ""
    source: str = ""
    needs: list[str] = field(default_factory=list)
    #: False when something it needs is not installed here (its sizes may then be None)
    installed: bool = True
    #: why the file could not be read, if it could not
    error: str = ""


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``models`` command to ``sub``."""
    p = sub.add_parser(
        "models",
        help="list the packaged and named models with their sizes and sources",
        description=(
            "List every model a MODEL argument can name (./models first, then the "
            "packaged ones) with its states, actions, outcomes per pair, (state, action) "
            "pairs, discount, partition sets, what it needs, kind, source and file. Sizes "
            "come from the parameters; no large model is built."
        ),
    )
    p.add_argument(
        "names",
        metavar="MODEL",
        nargs="*",
        help="list only these (names or instance files; default: all)",
    )
    p.add_argument("--json", action="store_true", help="print the list as JSON instead")
    p.set_defaults(func=run)


def _model_files() -> list[Path]:
    """The instance files in name-resolution order, one per name."""
    from ..model.instances import models_dir, packaged_models_dir

    seen: set[str] = set()
    files = []
    for folder in dict.fromkeys((models_dir(), packaged_models_dir())):
        for path in sorted(folder.glob("*.toml")):
            if path.stem not in seen and path.is_file():
                seen.add(path.stem)
                files.append(path)
    return sorted(files, key=lambda p: p.stem)


def _shown_path(path: Path) -> str:
    """The path relative to the working directory when it is inside it."""
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def _patrol_sizes(entry: ModelEntry, table: Any) -> None:
    """Eq. 27-28 and the allowed actions of lpbounds.patrol.model, from the parameters."""
    from ..patrol.params import PatrolParams

    p = PatrolParams.from_table({k: v for k, v in table.items() if k != "kind"})
    r, m = p.Gamma + 1, p.m
    # "continue" and "reverse" everywhere; "loiter" at a station (travel states: when
    # its alert is on, or always with allow_empty_loiter) and in loiter states with d < D
    at_station = 2 * m * (r**m if p.allow_empty_loiter else p.Gamma * r ** (m - 1))
    entry.n_states, entry.n_actions, entry.discount = p.n_states, 3, p.discount
    entry.n_outcomes = m + 1  # no alert, or a new alert at one of the m stations
    entry.n_pairs = 2 * p.n_states + at_station + m * (p.D - 1) * r ** (m - 1)
    entry.n_partitions = p.n_partitions


def _garnet_sizes(entry: ModelEntry, inst: Any) -> None:
    table = inst.config["model"]
    n, a, branching = (table.get(k) for k in ("n_states", "n_actions", "branching"))
    entry.n_states, entry.n_actions, entry.n_outcomes = n, a, branching
    entry.discount = table.get("discount")
    if table.get("allowed_fraction", 1.0) == 1.0 and isinstance(n, int) and isinstance(a, int):
        entry.n_pairs = n * a
    elif isinstance(n, int) and isinstance(a, int) and isinstance(branching, int):
        if n * a * branching <= BUILD_LIMIT:
            entry.n_pairs = inst.mdp().n_pairs
    part = inst.config.get("partition")
    if isinstance(part, dict) and part.get("kind") == "random":
        entry.n_partitions = part.get("n_partitions")


def _built_sizes(entry: ModelEntry, inst: Any) -> None:
    mdp = inst.mdp()
    entry.n_states, entry.n_actions, entry.n_pairs = mdp.n_states, mdp.n_actions, mdp.n_pairs
    entry.n_outcomes = mdp.n_outcomes
    entry.discount = mdp.discount
    if inst.has_partition:
        entry.n_partitions = inst.partition().n_partitions


def installed(package: str) -> bool:
    """Whether ``package`` can be imported here (found, not imported)."""
    return importlib.util.find_spec(package) is not None


def _shelf_sizes(entry: ModelEntry, inst: Any, build: bool) -> None:
    from ..errors import SolverNotInstalledError
    from ..model.shelf import SHELF_KINDS, model_sizes, partition_size

    entry.needs = list(SHELF_KINDS[inst.kind].needs)
    entry.installed = all(installed(need) for need in entry.needs)
    sizes = model_sizes(inst.config["model"])
    entry.discount = sizes.discount
    if sizes.n_states is None:  # Gymnasium's: read from it for a model named (``build``)
        if build and entry.installed:
            try:
                _built_sizes(entry, inst)
            except SolverNotInstalledError:
                entry.installed = False
        return
    entry.n_states, entry.n_actions, entry.n_pairs = sizes.n_states, sizes.n_actions, sizes.n_pairs
    entry.n_outcomes = sizes.n_outcomes
    if inst.has_partition:
        entry.n_partitions = partition_size(inst.config["partition"], sizes)


def _entry(path: Path, build: bool = False) -> ModelEntry:
    """The listing of one instance file (an unreadable file is listed with the reason);
    ``build``: read the sizes that only building the model gives (a Gymnasium model's)."""
    from ..errors import LPBoundsError
    from ..model.instances import load_instance
    from ..model.shelf import SHELF_KINDS

    entry = ModelEntry(name=path.stem, kind="-", path=_shown_path(path))
    try:
        inst = load_instance(path)
        entry.kind = inst.kind
        about = inst.config.get("about")
        about = about if isinstance(about, dict) else {}
        entry.title = str(about.get("title", ""))
        entry.source = str(about.get("source", KIND_SOURCES.get(inst.kind, "")))
        if inst.kind == "patrol":
            _patrol_sizes(entry, inst.config["model"])
        elif inst.kind == "garnet":
            _garnet_sizes(entry, inst)
        elif inst.kind in SHELF_KINDS:
            _shelf_sizes(entry, inst, build)
        else:
            _built_sizes(entry, inst)
    except LPBoundsError as exc:
        entry.error = " ".join(str(exc).split())
    return entry


def catalogue(names: list[str] | None = None) -> list[ModelEntry]:
    """Every model a MODEL argument can name, sorted by name (see the module docstring);
    with ``names``, those models (names or files) in that order.

    Raises
    ------
    ValidationError
        A name that names no file and no packaged model (the message lists them).
    """
    from ..model.instances import resolve_instance_path

    if names:
        return [_entry(resolve_instance_path(name), build=True) for name in names]
    return [_entry(path) for path in _model_files()]


def _count(x: int | None) -> str:
    return "-" if x is None else f"{x:,}"


def _discount(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:g}"


def _new_table(title: str) -> Any:
    from rich import box
    from rich.table import Table
    from rich.text import Text

    return Table(
        title=Text(title, "bold"),
        title_justify="left",
        box=box.SIMPLE_HEAD,
        show_edge=False,
        padding=(0, 0, 0, 0),  # the box's column separators already space the columns
    )


def _sizes_table(entries: list[ModelEntry]) -> Any:
    """Name, sizes, discount and needs: one line per model, 100 columns at most."""
    from rich.text import Text

    table = _new_table("models")
    table.add_column("name", no_wrap=True)
    for col in ("states", "actions", "outcomes", "pairs", "discount", "sets"):
        table.add_column(col, justify="right", no_wrap=True)
    table.add_column("needs", no_wrap=True)
    for e in entries:
        needs = ", ".join(e.needs) or "-"
        table.add_row(
            Text(e.name),
            _count(e.n_states),
            _count(e.n_actions),
            _count(e.n_outcomes),
            _count(e.n_pairs),
            _discount(e.discount),
            _count(e.n_partitions),
            Text(needs if e.installed else f"{needs}*"),
        )
    return table


def _file_column(path: str, packaged: Path) -> str:
    """``packaged`` for a file of the package's folder, else the path as given."""
    return "packaged" if Path(path).resolve().parent == packaged.resolve() else path


def _sources_table(entries: list[ModelEntry]) -> Any:
    """Name, kind, source and file of each model (long sources fold)."""
    from rich.text import Text

    from ..model.instances import packaged_models_dir

    packaged = packaged_models_dir()
    table = _new_table("kinds, sources and files")
    table.add_column("name", no_wrap=True)
    table.add_column("kind", no_wrap=True)
    table.add_column("source", overflow="fold")
    table.add_column("file", no_wrap=True)
    for e in entries:
        source = e.source or "-"
        if e.error:
            source = f"{source} (cannot be read: {e.error})".lstrip("- ")
        table.add_row(
            Text(e.name), Text(e.kind), Text(source), Text(_file_column(e.path, packaged))
        )
    return table


#: The footnote of the sizes table.
SIZES_NOTE = (
    "each name is a MODEL of solve, compare, export and verify; outcomes = successors "
    "listed per (state, action) pair; pairs = allowed pairs; sets = "
    "sets of the file's [partition] (for RLP, SLP, IB, ALP); a Gymnasium model's states "
    "include the absorbing end state it adds (name the model to read its sizes from "
    "Gymnasium); - = not known without building the model"
)


def run(args: argparse.Namespace) -> int:
    """List the models (a table, or JSON with ``--json``)."""
    from rich.text import Text

    from ..model.instances import packaged_models_dir
    from ..model.shelf import GYMNASIUM_HINT  # the one optional need of the shelf

    entries = catalogue(args.names or None)
    if args.json:  # plain text: rich would wrap long strings at the console's width
        if not console.quiet:
            sys.stdout.write(json.dumps([asdict(e) for e in entries], indent=2) + "\n")
        return 0
    print_table(_sizes_table(entries))
    missing = sorted({n for e in entries if not e.installed for n in e.needs})
    if missing:
        note = f"; * not installed here: {', '.join(missing)} ({GYMNASIUM_HINT})"
    else:
        note = ""
    console.print(Text(SIZES_NOTE + note))
    print_table(_sources_table(entries))
    console.print(Text(f"packaged = in {packaged_models_dir()}"))
    return 0
