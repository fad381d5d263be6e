"""Entry point of the ``lpbounds`` console script.

Each subcommand lives in its own module ``lpbounds.cli.<name>`` with a function
``register(subparsers)`` that adds its parser and sets ``func(args) -> int``.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from ..errors import LPBoundsError

#: Subcommand modules, in the order ``lpbounds --help`` lists them.
COMMANDS: tuple[str, ...] = ("solve", "verify", "bounds", "reproduce", "compare")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered subcommand."""
    from .. import __version__

    parser = argparse.ArgumentParser(
        prog="lpbounds",
        description="Bound discounted MDPs with linear programs (Park et al.).",
    )
    parser.add_argument("--version", action="version", version=f"lpbounds {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"lpbounds.cli.{name}")
        except ModuleNotFoundError as exc:  # a subcommand not written yet
            if exc.name != f"lpbounds.cli.{name}":
                raise
            continue
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (errors print one clear line)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except LPBoundsError as exc:
        print(f"lpbounds {args.command}: error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
