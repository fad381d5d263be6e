"""Keep third-party solvers off stdout and stderr; route what they print to ``logging``.

HiGHS (highspy 1.16) prints its banner ("Running HiGHS 1.16.0 ... Copyright ...") from C++
on the process's standard output the first time a ``highspy.Highs`` object is constructed,
before any option (``output_flag``, ``log_to_console``) can be set, and neither an option
nor an environment variable turns it off. cvxpy's HiGHS interface constructs two such
objects per solve, so every process that solves with HiGHS printed it once, whatever
``verbose`` said. It is printed once per process only, so :func:`silence_highs_banner`
constructs one ``Highs`` with the C-level standard output captured (:func:`captured_fds`)
and sends the text to the ``lpbounds`` logger at DEBUG; afterwards the options do the
rest (cvxpy passes ``log_to_console=verbose``, :func:`quiet_highs` sets
``output_flag=False``).

:func:`solver_output` is the one call solver wrappers make around a solve: nothing when
the caller asked for the solver's own log (``verbose=True``, or the command line's
``--verbose`` through :func:`show_solver_output`), the banner silenced otherwise.

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
import threading
from collections.abc import Iterator
from typing import Any

__all__ = [
    "captured_fds",
    "logger",
    "quiet_highs",
    "show_solver_output",
    "silence_highs_banner",
    "solver_output",
]

#: The package's logger; the library adds only a NullHandler (the application configures).
logger = logging.getLogger("lpbounds")
logger.addHandler(logging.NullHandler())

_lock = threading.Lock()
_banner_done = False
_show = False


def show_solver_output(show: bool = True) -> None:
    """Let solvers print their own banners and logs (the command line's ``--verbose``)."""
    global _show
    _show = bool(show)


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


def silence_highs_banner() -> None:
    """Print HiGHS' once-per-process banner into the log instead of stdout (idempotent;
    nothing when highspy is not installed or after :func:`show_solver_output`).

    :mod:`lpbounds.formulations.base` calls it at import (3 ms; cvxpy has imported highspy
    already), so no HiGHS solve of a model built with lpbounds prints the banner, even a
    user's own ``lp.problem.solve(solver="HIGHS")``.
    """
    global _banner_done
    if _banner_done or _show:
        return
    with _lock:
        if _banner_done:
            return
        try:
            import highspy
        except ImportError:
            _banner_done = True
            return
        with captured_fds((1,)):
            highspy.Highs()
        _banner_done = True


@contextlib.contextmanager
def solver_output(verbose: bool = False) -> Iterator[bool]:
    """Wrap a solver call: the solver prints nothing it was not asked for.

    ``with solver_output(verbose) as verbose: problem.solve(..., verbose=verbose)``. The
    value is ``verbose`` or the command line's ``--verbose`` (:func:`show_solver_output`):
    then the solver prints its banner and log as it likes; otherwise HiGHS' banner is
    silenced first (the solvers' own logs are off through their options, which cvxpy sets
    from ``verbose``).
    """
    show = bool(verbose or _show)
    if not show:
        silence_highs_banner()
    yield show


def quiet_highs() -> Any:
    """A ``highspy.Highs`` with ``output_flag`` off, its banner in the log rather than on
    stdout (unless :func:`show_solver_output`); a caller that wants HiGHS' log turns
    ``output_flag`` back on."""
    import highspy

    if not _show:
        silence_highs_banner()
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    return h
