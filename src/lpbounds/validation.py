"""Checks of user input, shared by every public entry point of lpbounds.

Every check raises :class:`~lpbounds.errors.ValidationError` whose message names the
argument and, for arrays, the first offending entry (``"successors[2, 1, 0] =
4294967297 is out of range [0, 10)"``). The rules, applied everywhere:

* booleans and strings are never numbers; complex numbers are never real numbers;
  a float is never taken where an integer is needed (``n_states = 10.7`` is refused,
  not truncated);
* the dtype *kind* of an array is checked before any cast (a string, object, complex
  or boolean array never reaches ``np.asarray(..., dtype=float)``);
* integer ranges are checked before a cast to a narrower dtype (an int64 ``2**32 + 1``
  must not wrap to a valid int32 index) and before anything is allocated from them;
* algorithm arguments (initial vectors, values, tolerances) must be finite.

The checks run once, where data enters the package; nothing here runs per iteration.
Arrays are inspected in place: a check never copies an array that is already of an
accepted dtype (model builders hand over arrays of hundreds of megabytes).
"""

from __future__ import annotations

import numbers
import os
import sys
from collections.abc import Iterable
from typing import Any

import numpy as np

from .errors import ValidationError

__all__ = [
    "MAX_VALUE_SCALE",
    "as_array",
    "as_float_array",
    "check_allocation",
    "check_array",
    "check_bool",
    "check_choice",
    "check_discount",
    "check_indices",
    "check_int",
    "check_real",
    "check_seed",
    "check_value_scale",
    "check_vector",
    "entry",
    "first_index",
    "is_int",
    "physical_memory",
]

#: Largest accepted scale of a value function, ``max|R| / (1 - discount)`` (the largest
#: possible ``|V*|``). Exact DP, the LPs and their certificates form sums and differences
#: of values, residuals ``T V - V`` (up to twice the scale) and error bounds ``residual /
#: (1 - discount)``; float64 overflows at 1.8e308, so a scale near it would turn into
#: ``inf`` and then into a meaningless "converged" result. 1e300 leaves a factor 1e8 of
#: headroom for those intermediate quantities. Models above it are refused (rescale the
#: rewards: every bound scales linearly with them).
MAX_VALUE_SCALE: float = 1e300

NUMERIC_KINDS = frozenset("iuf")


# ---------------------------------------------------------------------- helpers
def describe_value(x: Any) -> str:
    """``repr`` of a value with its type, shortened."""
    text = repr(x)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(x).__name__})"


def first_index(mask: np.ndarray) -> tuple[int, ...]:
    """Index of the first True entry of ``mask`` (as a tuple of ints)."""
    flat = int(np.flatnonzero(mask.ravel())[0]) if mask.ndim else 0
    return tuple(int(i) for i in np.unravel_index(flat, mask.shape))


def entry(name: str, index: tuple[int, ...]) -> str:
    """``"name[i, j]"`` (or ``name`` itself for a scalar)."""
    return f"{name}[{', '.join(str(i) for i in index)}]" if index else name


def _is_real(x: Any) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_))


def is_int(x: Any) -> bool:
    """True for an integer (Python or NumPy), False for booleans and everything else."""
    return isinstance(x, numbers.Integral) and not isinstance(x, (bool, np.bool_))


# ---------------------------------------------------------------------- scalars
def check_real(
    name: str,
    x: Any,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    finite: bool = True,
) -> float:
    """``x`` as a float, refusing booleans, strings, complex numbers and NaN.

    Parameters
    ----------
    name : str
        The argument's name, used in the message.
    x : object
        A Python or NumPy real number (an int is accepted; a 0-d array is not).
    lo, hi : float, optional
        Bounds of the accepted interval, closed unless ``lo_open`` / ``hi_open``.
    finite : bool
        Refuse ``inf`` too (NaN is always refused).

    Returns
    -------
    float
    """
    if not _is_real(x):
        raise ValidationError(f"{name} must be a real number; got {describe_value(x)}")
    try:
        v = float(x)
    except OverflowError:  # a Python int beyond float64
        raise ValidationError(f"{name} = {describe_value(x)} is beyond float64") from None
    if np.isnan(v) or (finite and not np.isfinite(v)):
        raise ValidationError(f"{name} must be a finite number; got {v}")
    below = lo is not None and (v <= lo if lo_open else v < lo)
    above = hi is not None and (v >= hi if hi_open else v > hi)
    if below or above:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        lo_s = "-inf" if lo is None else f"{lo:g}"
        hi_s = "inf" if hi is None else f"{hi:g}"
        raise ValidationError(f"{name} must lie in {left}{lo_s}, {hi_s}{right}; got {v!r}")
    return v


def check_discount(discount: Any, name: str = "discount") -> float:
    """The discount rule every model and row system shares: a real ``0 <= discount < 1``.

    (A discount of 1 has no discounted value; whether the rows' sums times the discount
    stay below 1 is :func:`lpbounds.stochastic.check_rows`'s check.)
    """
    return check_real(name, discount, lo=0.0, hi=1.0, hi_open=True)


def check_int(name: str, x: Any, *, lo: int | None = None, hi: int | None = None) -> int:
    """``x`` as an int, refusing booleans, strings and floats (even ``3.0``); ``lo <= x <= hi``."""
    if not is_int(x):
        raise ValidationError(f"{name} must be an integer; got {describe_value(x)}")
    v = int(x)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        lo_s = "-inf" if lo is None else str(lo)
        hi_s = "inf" if hi is None else str(hi)
        raise ValidationError(f"{name} must lie in [{lo_s}, {hi_s}]; got {v}")
    return v


def check_bool(name: str, x: Any) -> bool:
    """``x`` if it is a bool (Python or NumPy); 0/1, strings and None are refused."""
    if not isinstance(x, (bool, np.bool_)):
        raise ValidationError(f"{name} must be True or False; got {describe_value(x)}")
    return bool(x)


def check_seed(name: str, x: Any) -> Any:
    """A seed for :func:`numpy.random.default_rng`: None, an int >= 0 or a Generator."""
    if x is None or isinstance(x, (np.random.Generator, np.random.SeedSequence)):
        return x
    return check_int(name, x, lo=0)


def check_choice(name: str, x: Any, choices: Iterable[str]) -> str:
    """``x`` if it is one of the strings ``choices``."""
    options = tuple(choices)
    if not isinstance(x, str) or x not in options:
        raise ValidationError(f"{name} must be one of {list(options)}; got {describe_value(x)}")
    return x


# ---------------------------------------------------------------------- arrays
def as_array(name: str, x: Any) -> np.ndarray:
    """``np.asarray(x)`` without a cast (ragged nesting and None become ValidationError)."""
    if x is None:
        raise ValidationError(f"{name} must be an array; got None")
    if isinstance(x, (str, bytes)):
        raise ValidationError(f"{name} must be an array of numbers; got the string {x!r}")
    try:
        return np.asarray(x)
    except (ValueError, TypeError) as exc:
        raise ValidationError(f"{name} is not a rectangular array of numbers: {exc}") from exc


def _check_kind(name: str, arr: np.ndarray, integer: bool) -> np.ndarray:
    """Refuse strings, booleans, complex and non-numeric objects (by dtype, before a cast)."""
    kind = arr.dtype.kind
    if kind in NUMERIC_KINDS:
        return arr
    if kind == "O":
        for idx, item in np.ndenumerate(arr):
            if not (is_int(item) if integer else _is_real(item)):
                raise ValidationError(
                    f"{entry(name, idx)} = {describe_value(item)} is not "
                    f"{'an integer' if integer else 'a real number'}"
                )
            if integer and not -(2**63) <= int(item) < 2**63:
                raise ValidationError(
                    f"{entry(name, idx)} = {int(item)} is out of range (beyond 64-bit integers)"
                )
        try:
            return arr.astype(np.int64 if integer else np.float64)
        except OverflowError as exc:  # a Python int beyond float64
            raise ValidationError(f"{name} has an entry beyond float64: {exc}") from None
    what = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "bytes"}.get(
        kind, f"dtype {arr.dtype}"
    )
    idx = (0,) * arr.ndim
    first = f" ({entry(name, idx)} = {arr[idx].tolist()!r})" if arr.size else ""
    raise ValidationError(
        f"{name} must hold {'integers' if integer else 'real numbers'}; got {what}{first}"
    )


def check_finite(name: str, arr: np.ndarray, where: np.ndarray | None = None) -> None:
    """Refuse NaN or inf in ``arr`` (only where ``where`` is True, if given)."""
    bad = ~np.isfinite(arr)
    if where is not None:
        bad &= where
    if bad.any():
        idx = first_index(bad)
        raise ValidationError(
            f"{entry(name, idx)} = {arr[idx]} is not finite ({int(bad.sum())} such entries)"
        )


def check_array(
    name: str,
    x: Any,
    *,
    integer: bool = False,
    ndim: int | None = None,
    shape: tuple[int, ...] | None = None,
    finite: bool = True,
    nonempty: bool = False,
) -> np.ndarray:
    """``x`` as an array of numbers, checked but not cast (no copy of a numeric array).

    Parameters
    ----------
    name : str
    x : array_like
    integer : bool
        Integers wanted: float arrays are accepted only when every entry is a finite
        whole number (the caller casts after its range check); floats are refused.
    ndim, shape : optional
        Required number of dimensions / exact shape.
    finite : bool
        Refuse NaN and inf (float arrays).
    nonempty : bool
        Refuse arrays with no entry.

    Returns
    -------
    ndarray
        Of kind int, uint or float (an object array of numbers is converted).
    """
    arr = as_array(name, x)
    if ndim is not None and arr.ndim != ndim:
        raise ValidationError(f"{name} must be a {ndim}-d array; got shape {arr.shape}")
    if shape is not None and arr.shape != tuple(shape):
        raise ValidationError(f"{name} must have shape {tuple(shape)}; got {arr.shape}")
    if nonempty and arr.size == 0:
        raise ValidationError(f"{name} is empty (shape {arr.shape})")
    arr = _check_kind(name, arr, integer)
    if arr.dtype.kind == "f":
        if finite or integer:
            check_finite(name, arr)
        if integer:
            frac = arr != np.round(arr)
            if frac.any():
                idx = first_index(frac)
                raise ValidationError(
                    f"{name} must be integers; {entry(name, idx)} = {arr[idx]} is not"
                )
    return arr


def as_float_array(name: str, x: Any, **kwargs: Any) -> np.ndarray:
    """:func:`check_array`, then a float64 view (or copy when the dtype differs)."""
    return np.asarray(check_array(name, x, **kwargs), dtype=np.float64)


def check_vector(name: str, v: Any, n: int, *, finite: bool = True) -> np.ndarray:
    """A C-contiguous float64 vector of length ``n`` (finite unless ``finite=False``)."""
    arr = check_array(name, v, finite=finite)
    if arr.shape != (n,):
        raise ValidationError(f"{name}: expected a vector of length {n}; got shape {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def check_indices(
    name: str, arr: np.ndarray, n: int, where: np.ndarray | None = None
) -> tuple[int, int]:
    """Refuse entries of an integer-valued array outside ``[0, n)`` (where ``where``).

    Run on the array's own dtype, before any narrowing cast. Returns the counts of
    out-of-range entries ``(where True, where False)`` (the first is always 0).
    """
    bad = (arr < 0) | (arr >= n)
    if not bad.any():
        return 0, 0
    if where is not None:
        elsewhere = int((bad & ~where).sum())
        bad &= where
    else:
        elsewhere = 0
    if bad.any():
        idx = first_index(bad)
        raise ValidationError(
            f"{entry(name, idx)} = {int(arr[idx])} is out of range [0, {n}) "
            f"({int(bad.sum())} such entries)"
        )
    return 0, elsewhere


def check_value_scale(reward_absmax: float, discount: float, name: str = "rewards") -> None:
    """Refuse a model whose value scale ``max|R| / (1 - discount)`` exceeds
    :data:`MAX_VALUE_SCALE` (computed without overflow: ``max|R| > limit * (1 - lambda)``).
    """
    if reward_absmax > MAX_VALUE_SCALE * (1.0 - discount):
        raise ValidationError(
            f"{name}: max|R| = {reward_absmax:.3g} with discount {discount} gives values up "
            f"to max|R| / (1 - discount) = {reward_absmax:.3g} / {1.0 - discount:.3g}, above "
            f"{MAX_VALUE_SCALE:g}: float64 arithmetic on them would overflow; rescale the "
            f"{name} (bounds scale linearly with them)"
        )


# ---------------------------------------------------------------------- sizes
def physical_memory() -> int | None:
    """This machine's physical memory in bytes (``SC_PHYS_PAGES * SC_PAGE_SIZE``); None
    where the platform does not tell."""
    try:
        pages, size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None
    return int(pages) * int(size) if pages > 0 and size > 0 else None


def check_allocation(name: str, n_bytes: int, what: str) -> None:
    """Refuse, before anything is allocated, arrays of ``n_bytes`` in all that do not fit
    in this machine's memory (:func:`physical_memory`; without it, NumPy's limit of
    ``sys.maxsize`` bytes per array).

    Parameters
    ----------
    name : str
        The sizes the arrays follow from, as the message names them (``"[model] n_states
        = 10000000000 with n_actions = 3, branching = 4"``).
    n_bytes : int
        Bytes the arrays need (a Python int: no overflow).
    what : str
        The arrays (``"the successors, probabilities and rewards"``).
    """
    memory = physical_memory()
    limit = sys.maxsize if memory is None else min(memory, sys.maxsize)
    if n_bytes > limit:
        have = (
            f"this machine has {memory:,} bytes ({memory / 2**30:.3g} GiB) of memory"
            if memory is not None
            else f"NumPy allocates at most {limit:,} bytes"
        )
        raise ValidationError(
            f"{name}: {what} need {n_bytes:,} bytes ({n_bytes / 2**30:.3g} GiB) but {have}"
        )
