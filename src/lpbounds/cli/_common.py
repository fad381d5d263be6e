"""Helpers shared by the subcommands: console, progress bars, ``--quiet``/``--verbose`` and
logging, instance argument, argument types that reject bad values at parse time, and output
checks made before any work."""

from __future__ import annotations

import argparse
import logging
import math
import os
import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from rich.console import Console, ConsoleDimensions

if TYPE_CHECKING:  # rich.progress is imported by progress(), not by --help
    from rich.progress import Progress, TaskID

from ..outputs import check_output_dir, check_output_file

__all__ = [
    "LazyProgress",
    "LogHandler",
    "add_model_argument",
    "add_verbosity_options",
    "check_output_dir",
    "check_output_file",
    "configure_output",
    "console",
    "err_console",
    "nonnegative_int",
    "positive_float",
    "positive_int",
    "print_table",
    "progress",
]


class _Console(Console):
    """A console that lays results out for 100 columns when its output is not a terminal
    (rich would assume 80) and COLUMNS does not say otherwise, decided at each print (the
    stream can change after import: a pipe, a file, pytest's capture), never at import."""

    @property
    def size(self) -> ConsoleDimensions:
        size = super().size
        if self._width is None and not self.is_terminal and "COLUMNS" not in os.environ:
            return ConsoleDimensions(100, size.height)
        return size

    @size.setter
    def size(self, new_size: tuple[int, int]) -> None:
        self._width, self._height = new_size

    def print_wide(self, renderable: Any, min_width: int) -> None:
        """Print laid out at least ``min_width`` columns wide (rich never exceeds the
        console's width on its own)."""
        saved = self._width
        self._width = max(self.width, min_width)
        try:
            self.print(renderable)
        finally:
            self._width = saved


#: Results on stdout: a terminal's own width, or 100 columns for a file or a pipe.
console = _Console()
err_console = Console(stderr=True)

#: Result tables are laid out at least this wide: on a narrower console (COLUMNS=80, which
#: GNU readline exports when a process initialises it) the terminal wraps the long lines
#: rather than rich cutting numbers and names out of the cells.
TABLE_MIN_WIDTH = 100


def print_table(table: Any) -> None:
    """Print a result table on :data:`console`, at least :data:`TABLE_MIN_WIDTH` wide."""
    console.print_wide(table, TABLE_MIN_WIDTH)


#: The consoles of the progress displays being drawn now (at most one in practice): the
#: log goes through the innermost, so that rich prints it above the live display.
_LIVE: list[Console] = []


class LogHandler(logging.Handler):
    """The ``lpbounds`` log on stderr, one line per record, never inside a progress display.

    While a :class:`LazyProgress` is drawing, a record is printed through the display's
    console, which puts it above the live lines and redraws them below (written to the
    terminal directly, the text would land inside the display, which rich then redraws
    under it, a copy per line it wrapped to). Otherwise it is written to the *current*
    ``sys.stderr`` (pytest's capture, a redirected stream), looked up at each record.
    """

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = self.format(record)
            if _LIVE:
                from rich.text import Text

                _LIVE[-1].print(Text(text))
            else:
                sys.stderr.write(text + "\n")
                sys.stderr.flush()
        except Exception:  # a broken stream must not end the command (logging's rule)
            self.handleError(record)


class LazyProgress:
    """A rich :class:`~rich.progress.Progress` that starts drawing at its first task, and
    only on a terminal, so a rejected command prints its one error line and nothing else
    (and a log file gets no progress frames). While it draws, the log goes through its
    console (:class:`LogHandler`): above the display, once."""

    def __init__(self, prog: Progress) -> None:
        self._prog = prog
        self._started = False

    def add_task(self, *args: Any, **kwargs: Any) -> TaskID:
        console_ = self._prog.console
        if not self._started and console_.is_terminal and not console_.quiet:
            self._prog.start()
            self._started = True
            _LIVE.append(console_)
        return self._prog.add_task(*args, **kwargs)

    def update(self, *args: Any, **kwargs: Any) -> None:
        self._prog.update(*args, **kwargs)

    def advance(self, *args: Any, **kwargs: Any) -> None:
        self._prog.advance(*args, **kwargs)

    def stop(self) -> None:
        if self._started:
            self._started = False
            if self._prog.console in _LIVE:
                _LIVE.remove(self._prog.console)
            self._prog.stop()


@contextmanager
def progress(transient: bool = True) -> Iterator[LazyProgress]:
    """A rich progress display on stderr, drawn from the first task on and only when stderr
    is a terminal."""
    from rich.progress import (
        BarColumn,
        Progress,
        SpinnerColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    lazy = LazyProgress(
        Progress(
            SpinnerColumn(),
            TextColumn("[progress.description]{task.description}"),
            BarColumn(),
            TextColumn("{task.fields[status]}"),
            TimeElapsedColumn(),
            console=err_console,
            transient=transient,
        )
    )
    try:
        yield lazy
    finally:
        lazy.stop()


def add_verbosity_options(parser: argparse.ArgumentParser) -> None:
    """``--quiet`` and ``--verbose`` (each subcommand gets them from :mod:`.main`)."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="print nothing but errors: no table, no progress, no notes",
    )
    group.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        help="also print diagnostics (the lpbounds log at DEBUG, on stderr) and the "
        "solvers' own banners and logs (where the solvers print them)",
    )


@contextmanager
def configure_output(quiet: bool = False, verbose: bool = False) -> Iterator[None]:
    """For the duration of one command: the ``lpbounds`` logger on stderr (WARNING by
    default, ERROR with ``quiet``, DEBUG with ``verbose``), quiet consoles with ``quiet``,
    and the solvers' own output with ``verbose``. Everything is restored afterwards, so
    :func:`lpbounds.cli.main.main` called in-process leaves no logging state behind.

    Only the ``lpbounds`` logger is configured, never the root logger.
    """
    from ..formulations.quiet import show_solver_output

    log = logging.getLogger("lpbounds")
    saved = (log.level, log.propagate, console.quiet, err_console.quiet)
    handler = LogHandler()  # stderr at each record, above a live progress display
    handler.setFormatter(logging.Formatter("lpbounds: %(levelname)s: %(message)s"))
    log.addHandler(handler)
    log.setLevel(logging.DEBUG if verbose else logging.ERROR if quiet else logging.WARNING)
    log.propagate = False  # no second copy through a root handler the host may have
    console.quiet = err_console.quiet = quiet
    show_solver_output(verbose)
    try:
        with warnings.catch_warnings():
            _log_lpbounds_warnings(log)
            if verbose:
                from ..outputs import metadata_lines, run_metadata

                for line in metadata_lines(run_metadata()):
                    log.debug(line)
            yield
    finally:
        log.removeHandler(handler)
        log.setLevel(saved[0])
        log.propagate = saved[1]
        console.quiet, err_console.quiet = saved[2], saved[3]
        show_solver_output(False)


def _log_lpbounds_warnings(log: logging.Logger) -> None:
    """Inside a ``warnings.catch_warnings()``: lpbounds' own warnings
    (:class:`~lpbounds.errors.LPBoundsWarning`) go to ``log`` at WARNING, each text once per
    command (a warning of every instance verified would repeat it), with one label and no
    source line of the console script; other warnings are shown as Python shows them."""
    from ..errors import LPBoundsWarning

    seen: set[str] = set()
    shown = warnings.showwarning

    def show(
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        file: Any = None,
        line: str | None = None,
    ) -> None:
        if not issubclass(category, LPBoundsWarning):
            shown(message, category, filename, lineno, file, line)
        elif str(message) not in seen:
            seen.add(str(message))
            log.warning("%s", message)

    warnings.showwarning = show
    warnings.simplefilter("always", LPBoundsWarning)  # once per text: counted here


def add_model_argument(parser: argparse.ArgumentParser, default: str | None = None) -> None:
    """The positional MODEL argument (a TOML path or a packaged model's name)."""
    kwargs: dict[str, Any] = {"nargs": "?", "default": default} if default is not None else {}
    parser.add_argument(
        "model",
        metavar="MODEL",
        help="instance file (models/*.toml) or the name of a packaged model"
        + (f" (default: {default})" if default else ""),
        **kwargs,
    )


def _int(text: str) -> int:
    try:
        return int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None


def positive_int(text: str) -> int:
    """An argparse type: an integer >= 1."""
    value = _int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1; got {value}")
    return value


def nonnegative_int(text: str) -> int:
    """An argparse type: an integer >= 0 (seeds, counts)."""
    value = _int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0; got {value}")
    return value


def positive_float(text: str) -> float:
    """An argparse type: a finite number > 0 (tolerances, limits)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0; got {text}")
    return value
