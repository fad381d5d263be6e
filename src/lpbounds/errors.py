"""Exceptions raised by lpbounds.

Every error the package raises on purpose derives from :class:`LPBoundsError`, so a
script can catch them all at once; each also derives from the built-in exception a
Python user would expect (``ValueError`` for bad input, ``RuntimeError`` for a failed
solve, ``ImportError`` for a missing solver).

Its warnings derive from :class:`LPBoundsWarning` (a ``UserWarning``): input that is valid
and gets a correct answer, but probably not the one meant. :func:`warn` issues them at the
user's line, the first frame outside lpbounds.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path


class LPBoundsError(Exception):
    """Base class of every error raised by lpbounds."""


class ValidationError(LPBoundsError, ValueError):
    """Input data that does not describe a valid model (names the offending entry)."""


class SolverError(LPBoundsError, RuntimeError):
    """A solve that did not return a trustworthy optimum (status, residual or dual check)."""


class SolverNotInstalledError(LPBoundsError, ImportError):
    """The requested solver is unknown to cvxpy or not installed on this machine."""


class ConvergenceError(LPBoundsError, RuntimeError):
    """An iterative method stopped at its iteration limit before reaching its tolerance."""


class OutputError(LPBoundsError, OSError):
    """An output that cannot be written: not writable, of the wrong kind, or locked."""


class ConsistencyError(LPBoundsError, RuntimeError):
    """Two computations of the same quantity disagree: a defect, not a user error."""


class SizeLimitError(ValidationError):
    """A computation refused up front because the model exceeds a size limit (the message
    names the size, the limit and the option that lifts it).

    Attributes
    ----------
    size, limit : int or None
        The size asked for and the limit, when the raiser gives them (so that a caller,
        the command line, can name its own option).
    """

    def __init__(self, message: str, *, size: int | None = None, limit: int | None = None):
        super().__init__(message)
        self.size, self.limit = size, limit


class LPBoundsWarning(UserWarning):
    """Base class of every warning lpbounds issues (``warnings.simplefilter("error",
    LPBoundsWarning)`` turns them all into errors)."""


class PartitionWarning(LPBoundsWarning):
    """A valid partition that weakens the bounds it is used for: a model's sink (its
    absorbing end state, worth 0) shares a block with live states (the message names the
    block; :func:`lpbounds.model.checks.sink_block_note`)."""


#: the package's folder: frames below it are lpbounds', not the user's
_PACKAGE = str(Path(__file__).resolve().parent)


def warn(message: str, category: type[Warning] = LPBoundsWarning) -> None:
    """``warnings.warn(message, category)`` attributed to the user's line: the first frame
    of the stack that is not in lpbounds (so the filters' "once per location" and the
    printed file and line are the caller's, however deep inside lpbounds it is raised)."""
    level, frame = 2, sys._getframe(1)
    while frame.f_back is not None and str(Path(frame.f_code.co_filename).resolve()).startswith(
        _PACKAGE
    ):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)
