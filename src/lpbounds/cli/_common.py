"""Helpers shared by the subcommands: console, progress bars, instance argument."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

console = Console()
err_console = Console(stderr=True)


@contextmanager
def progress(transient: bool = True) -> Iterator[Progress]:
    """A rich progress display on stderr (quiet when stderr is not a terminal)."""
    with Progress(
        SpinnerColumn(),
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[status]}"),
        TimeElapsedColumn(),
        console=err_console,
        transient=transient,
    ) as prog:
        yield prog


def add_model_argument(parser: argparse.ArgumentParser, default: str | None = None) -> None:
    """The positional MODEL argument (a TOML path or a name in models/)."""
    kwargs = {"nargs": "?", "default": default} if default is not None else {}
    parser.add_argument(
        "model",
        metavar="MODEL",
        help="instance file (models/*.toml) or its name"
        + (f" (default: {default})" if default else ""),
        **kwargs,
    )
