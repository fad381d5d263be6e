"""Entry point of the ``lpbounds`` console script.

Each subcommand lives in its own module ``lpbounds.cli.<name>`` with a function
``register(subparsers)`` that adds its parser and sets ``func(args) -> int``.

A user error never shows a traceback: :func:`main` turns it into one line on stderr and
an exit status (:data:`EXIT_CODES`, also in ``lpbounds --help``).
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
from collections.abc import Sequence
from typing import Any

from ..errors import LPBoundsError, OutputError, SolverNotInstalledError, ValidationError
from ..outputs import committed_outputs
from ._common import add_verbosity_options, configure_output

#: Subcommand modules, in the order ``lpbounds --help`` lists them.
COMMANDS: tuple[str, ...] = (
    "solve",
    "verify",
    "bounds",
    "reproduce",
    "compare",
    "export",
    "score",
    "models",
)

EXIT_OK = 0
#: A computation failed: a solver error, no convergence, two results that disagree.
EXIT_FAILED = 1
#: A usage or input error: bad arguments, an invalid or unreadable model, an output that
#: cannot be written (checked before any computation) or is locked by another run.
EXIT_USAGE = 2
#: Interrupted (Ctrl-C) before the output folder was renamed into place: outputs are as
#: they were before the run. A Ctrl-C after that rename ends a completed run (0).
EXIT_INTERRUPTED = 130

EXIT_CODES: dict[int, str] = {
    EXIT_OK: "success (also a Ctrl-C once the output folder is in place: it is complete)",
    EXIT_FAILED: "a computation failed (solver error, no convergence, inconsistent results)",
    EXIT_USAGE: "usage or input error: bad arguments, invalid or unreadable model file, "
    "output not writable or locked (checked before any computation)",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C) before the output folder was in place; earlier "
    "outputs are left as they were",
}

EPILOG = "exit status:\n" + "\n".join(f"  {code:<4} {text}" for code, text in EXIT_CODES.items())


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered subcommand."""
    from .._defaults import VERSION as __version__

    parser = argparse.ArgumentParser(
        prog="lpbounds",
        description="Bound discounted MDPs with linear programs (Park et al.).",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
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
    for subparser in sub.choices.values():
        add_verbosity_options(subparser)
    return parser


def exit_status(exc: BaseException) -> int:
    """The exit status of an exception that ends a command (see :data:`EXIT_CODES`)."""
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_INTERRUPTED
    if isinstance(exc, ValidationError | SolverNotInstalledError | OutputError | OSError):
        return EXIT_USAGE
    return EXIT_FAILED


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and not isinstance(exc, LPBoundsError) and exc.strerror:
        where = f": {exc.filename!r}" if exc.filename else ""
        return f"{exc.strerror}{where}"
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def interrupted(command: str, mark: int = 0) -> int:
    """Report a Ctrl-C; its exit status. After the command committed its output folder
    (:func:`lpbounds.outputs.committed_outputs` grew past ``mark``) the run is complete:
    0, with a note naming the folder; before, 130 (the outputs are as they were)."""
    done = committed_outputs()[mark:]
    if done:
        print(f"{command}: interrupted after {str(done[-1])!r} was complete", file=sys.stderr)
        return EXIT_OK
    print(f"{command}: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (errors print one clear line)."""
    command = "lpbounds"
    mark = len(committed_outputs())
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        args.argv = list(sys.argv[1:] if argv is None else argv)  # recorded in metadata
        if not getattr(args, "func", None):
            parser.print_help()
            return EXIT_USAGE
        command = f"lpbounds {args.command}"
        with configure_output(quiet=args.quiet, verbose=args.verbose):
            return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return interrupted(command, mark)
    except (LPBoundsError, OSError) as exc:
        print(f"{command}: error: {_one_line(exc)}", file=sys.stderr)
        return exit_status(exc)


def _reraise_swallowed_interrupt(unraisable: Any) -> None:
    """``sys.unraisablehook`` of the command: a Ctrl-C that landed in code Python cannot
    raise from (a weakref callback or ``__del__``, e.g. matplotlib's transforms) would be
    printed as "Exception ignored in ..." with a traceback and then lost; it is delivered
    again instead, so the command stops as on any Ctrl-C (130, one line). Not from inside
    the hook (a KeyboardInterrupt there is unraisable again): a timer thread interrupts
    the main thread a millisecond later, once the hook has returned."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        import _thread
        import threading

        threading.Timer(0.001, _thread.interrupt_main).start()
        return
    sys.__unraisablehook__(unraisable)


def entry() -> None:
    """The console script: :func:`main`, then exit with its status.

    A Ctrl-C that arrives once :func:`main` has returned (its output is complete by then)
    must not kill the interpreter by signal during shutdown (exit status -2, and possibly a
    traceback): SIGINT is ignored from the moment :func:`main` returns, and one arriving
    in between is still reported as an interruption (130, or 0 after a commit). One that
    lands in a weakref callback or ``__del__`` is delivered again
    (:func:`_reraise_swallowed_interrupt`).
    """
    sys.unraisablehook = _reraise_swallowed_interrupt  # the command's own process only
    try:
        try:
            code = main()
        finally:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
    except KeyboardInterrupt:
        code = interrupted("lpbounds")
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    entry()
