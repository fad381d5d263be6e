"""Keep third-party solvers off stdout and stderr; route what they print to ``logging``.

This module holds the solver-independent parts: the package's :data:`logger`,
:func:`captured_fds` (the C-level standard output and error captured into the log) and
the command line's switch :func:`show_solver_output` (read back with
:func:`solver_output_shown`). It constructs no solver object. What is HiGHS' own (its
once-per-process banner, silenced lazily with :func:`captured_fds`, ``quiet_highs`` and
``solver_output``) lives in the one HiGHS layer, :mod:`lpbounds.formulations.highs`.

The library logs through ``logging.getLogger("lpbounds")`` and never configures logging;
the command line does (``--quiet`` / ``--verbose``).
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import sys
import tempfile
from collections.abc import Iterator

__all__ = [
    "captured_fds",
    "logger",
    "show_solver_output",
    "solver_output_shown",
]

#: The package's logger; the library adds only a NullHandler (the application configures).
logger = logging.getLogger("lpbounds")
logger.addHandler(logging.NullHandler())

_show = False


def show_solver_output(show: bool = True) -> None:
    """Let solvers print their own banners and logs (the command line's ``--verbose``)."""
    global _show
    _show = bool(show)


def solver_output_shown() -> bool:
    """Whether :func:`show_solver_output` let the solvers print (the command line's
    ``--verbose``); ``False`` by default."""
    return _show


def _flush_c_stdio() -> None:
    """Flush the C library's stdio buffers (a banner in a pipe's buffer would otherwise be
    written after the descriptors are restored)."""
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def captured_fds(fds: tuple[int, ...] = (1,), level: int = logging.DEBUG) -> Iterator[None]:
    """Redirect the file descriptors ``fds`` (1 = stdout, 2 = stderr) to a temporary file
    during the block, then log what was written there at ``level``.

    This catches what compiled code prints, which ``contextlib.redirect_stdout`` cannot.
    The descriptors are process-wide: another thread printing during the block is captured
    too (and logged), so keep the block short. Where a descriptor cannot be duplicated
    (no real stdout, e.g. under some embedders) the block runs uncaptured.
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    saved: list[tuple[int, int]] = []
    with tempfile.TemporaryFile(mode="w+b") as sink:
        try:
            for fd in fds:
                try:
                    saved.append((fd, os.dup(fd)))
                    os.dup2(sink.fileno(), fd)
                except OSError:
                    continue
            yield
        finally:
            _flush_c_stdio()
            for fd, copy in reversed(saved):
                os.dup2(copy, fd)
                os.close(copy)
            sink.seek(0)
            text = sink.read().decode("utf-8", "replace").strip()
            if text:
                logger.log(level, "solver output: %s", text)
