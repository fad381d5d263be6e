"""Exceptions raised by lpbounds.

Every error the package raises on purpose derives from :class:`LPBoundsError`, so a
script can catch them all at once; each also derives from the built-in exception a
Python user would expect (``ValueError`` for bad input, ``RuntimeError`` for a failed
solve, ``ImportError`` for a missing solver).
"""

from __future__ import annotations


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
