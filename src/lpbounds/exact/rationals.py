r"""Exact rational numbers for lpbounds: the vector type, conversions and the one dense solver.

Every double is a dyadic rational (``x = m 2^e``), so the data of a stored model *is* a set
of rationals and :class:`fractions.Fraction` (``Fraction(x)``) represents it without
error. Exact answers are vectors whose entries share one large denominator (a policy's
values ``(I - lambda P_pi)^{-1} R_pi`` all divide ``det(I - lambda P_pi)`` scaled to
integers), so lpbounds keeps them as :class:`RationalVector`: integer numerators over
one common denominator. Comparing, subtracting and checking rows then needs integer
arithmetic only; a :class:`~fractions.Fraction` per entry, whose construction reduces
each entry by a gcd of numbers of tens of thousands of bits, is made only when an entry
is asked for (measured on a 400-state garnet: 1.4 s for the 400 gcds against 0.26 s for
every Bellman row of the model checked in integers).

The linear algebra is python-flint's (FLINT's ``fmpq_mat``/``fmpz_mat``: exact,
fraction-free or p-adic solvers): :func:`solve_rational` and the policy solves of
:mod:`lpbounds.exact.fixed_point`. python-flint is imported only when exact arithmetic is
asked for (:func:`flint_module`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence
from fractions import Fraction
from typing import Any, overload

import numpy as np

from ..errors import SolverNotInstalledError, ValidationError
from . import check

__all__ = [
    "RationalVector",
    "flint_module",
    "fraction_text",
    "integer_text",
    "nearest_float",
    "rational",
    "solve_rational",
]


def flint_module() -> Any:
    """python-flint, imported on first use (exact arithmetic only).

    Raises
    ------
    SolverNotInstalledError
        When python-flint is missing (it is a dependency of lpbounds; the message gives
        the install command).
    """
    try:
        import flint
    except ImportError as exc:  # pragma: no cover - a dependency; only a broken install
        raise SolverNotInstalledError(
            "exact arithmetic needs python-flint (a dependency of lpbounds): "
            "pip install python-flint"
        ) from exc
    return flint


def rational(x: Any) -> Fraction:
    """``x`` as an exact Fraction: a float's exact dyadic value, an int, a Fraction, or a
    certificate's number (a ``"p/q"`` string or a hex float, :func:`lpbounds.exact.check.rat`).

    Raises
    ------
    ValidationError
        For a NaN, an infinity or a value that is not a real number.
    """
    if isinstance(x, Fraction):
        return x
    if isinstance(x, str):
        try:
            return check.rat(x)
        except (check.CheckError, ValueError) as exc:
            raise ValidationError(f"{x!r} is not a number of a certificate: {exc}") from exc
    if isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_)):
        return Fraction(int(x))
    if isinstance(x, (float, np.floating)):
        if not math.isfinite(float(x)):
            raise ValidationError(f"{x!r} has no exact rational value (not finite)")
        return Fraction(float(x))
    raise ValidationError(f"expected a real number; got {type(x).__name__} {x!r}")


#: Integers with more decimal digits are written in hexadecimal (``0x...``): Python refuses
#: decimal conversions of ints beyond 4,300 digits by default (CVE-2020-10735), a limit the
#: library does not lift for its host; hex conversions are unlimited and exact.
DECIMAL_DIGITS_MAX = 4000


def integer_text(n: int) -> str:
    """``n`` as a decimal string, or as ``0x...`` hex when it is too long for decimal."""
    if n.bit_length() <= DECIMAL_DIGITS_MAX * 3:  # 3 bits < 1 decimal digit
        return str(n)
    return hex(n)


def fraction_text(x: Fraction) -> str:
    """``"p/q"`` (always with ``/q``; ``q > 0``, lowest terms; long integers in hex)."""
    return f"{integer_text(x.numerator)}/{integer_text(x.denominator)}"


def nearest_float(num: int, den: int) -> float:
    """``num / den`` rounded to the nearest double (Python's integer true division is
    correctly rounded, and never forms the quotient in full)."""
    return num / den


class RationalVector(Sequence[Fraction]):
    """An exact vector ``x_i = numerators[i] / denominator`` (``denominator > 0``).

    A :class:`~collections.abc.Sequence` of :class:`~fractions.Fraction`: ``v[i]`` is the
    exact entry (reduced when asked for, cached), ``list(v)`` all of them. The numerators
    and the common denominator are plain Python ints; the denominator need not be the
    least one.

    Parameters
    ----------
    numerators : sequence of int
    denominator : int
    """

    __slots__ = ("_fractions", "denominator", "numerators")

    def __init__(self, numerators: Iterable[int], denominator: int) -> None:
        den = int(denominator)
        if den <= 0:
            raise ValidationError(f"a RationalVector needs a positive denominator; got {den}")
        self.numerators: tuple[int, ...] = tuple(int(t) for t in numerators)
        self.denominator = den
        self._fractions: list[Fraction] | None = None

    # ------------------------------------------------------------------ builders
    @classmethod
    def from_fractions(cls, values: Iterable[Any]) -> RationalVector:
        """From exact numbers (Fractions, ints, floats taken exactly); the denominator is
        the least common one."""
        fr = [rational(t) for t in values]
        den = math.lcm(*(t.denominator for t in fr)) if fr else 1
        return cls([t.numerator * (den // t.denominator) for t in fr], den)

    @classmethod
    def from_fmpq(cls, values: Sequence[Any]) -> RationalVector:
        """From python-flint ``fmpq`` numbers (their least common denominator)."""
        flint = flint_module()
        den = flint.fmpz(1)
        for t in values:
            q = t.q
            if den % q:
                den = den // den.gcd(q) * q
        return cls([int(t.p * (den // t.q)) for t in values], int(den))

    @classmethod
    def zeros(cls, n: int) -> RationalVector:
        """``n`` zeros."""
        return cls([0] * n, 1)

    # ------------------------------------------------------------------ Sequence
    def __len__(self) -> int:
        return len(self.numerators)

    @overload
    def __getitem__(self, i: int) -> Fraction: ...

    @overload
    def __getitem__(self, i: slice) -> list[Fraction]: ...

    def __getitem__(self, i: int | slice) -> Fraction | list[Fraction]:
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        if self._fractions is not None:
            return self._fractions[i]
        return Fraction(self.numerators[i], self.denominator)

    def __iter__(self) -> Iterator[Fraction]:
        return iter(self.fractions())

    def __repr__(self) -> str:
        bits = self.denominator.bit_length()
        return f"RationalVector(n={len(self)}, denominator of {bits} bits)"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RationalVector):
            return NotImplemented
        if len(self) != len(other):
            return False
        d1, d2 = self.denominator, other.denominator
        return all(a * d2 == b * d1 for a, b in zip(self.numerators, other.numerators, strict=True))

    __hash__ = None  # type: ignore[assignment]  # mutable cache; equality is by value

    # ------------------------------------------------------------------ views
    def fractions(self) -> list[Fraction]:
        """Every entry as a reduced Fraction (computed once, then cached)."""
        if self._fractions is None:
            d = self.denominator
            self._fractions = [Fraction(n, d) for n in self.numerators]
        return self._fractions

    def to_floats(self) -> np.ndarray:
        """The nearest double of every entry (correctly rounded)."""
        d = self.denominator
        return np.array([nearest_float(n, d) for n in self.numerators], dtype=np.float64)

    def take(self, index: Sequence[int]) -> RationalVector:
        """The entries ``index`` (same denominator): a slice, or a lift ``v[labels]``."""
        num = self.numerators
        return RationalVector([num[int(i)] for i in index], self.denominator)

    def to_json(self) -> dict[str, Any]:
        """``{"den": "D", "num": ["N_1", ...]}``: the certificate format (decimal strings, or
        ``0x`` hex for integers of more than :data:`DECIMAL_DIGITS_MAX` digits)."""
        return {
            "den": integer_text(self.denominator),
            "num": [integer_text(t) for t in self.numerators],
        }

    def entry(self) -> dict[str, Any]:
        """The same as :meth:`to_json` with Python ints (no text): what the checker's
        functions read in memory."""
        return {"den": self.denominator, "num": list(self.numerators)}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> RationalVector:
        """The inverse of :meth:`to_json` (and of :meth:`entry`)."""
        return cls([_integer(t) for t in data["num"]], _integer(data["den"]))

    # ------------------------------------------------------------------ exact comparisons
    def max_abs_error(self, approx: Any) -> Fraction:
        """``max_i |approx_i - x_i|`` exactly, for an array of doubles ``approx``.

        Every double is ``m 2^-k``; over the common denominator ``2^K D`` the errors are
        integers, so the maximum is found by integer comparisons and reduced once.
        """
        a = np.asarray(approx, dtype=np.float64)
        if a.shape != (len(self),):
            raise ValidationError(f"expected {len(self)} doubles; got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValidationError("the approximation has a non-finite entry: no exact error")
        ratios = [float(t).as_integer_ratio() for t in a]
        big = max((q for _, q in ratios), default=1)  # powers of two: the largest is the lcm
        d = self.denominator
        worst = max(
            (
                abs(p * (big // q) * d - n * big)
                for (p, q), n in zip(ratios, self.numerators, strict=True)
            ),
            default=0,
        )
        return Fraction(worst, big * d)

    def within(self, lower: Any, upper: Any) -> bool:
        """``lower_i <= x_i <= upper_i`` for every ``i``, exactly (doubles ``lower``,
        ``upper``; ``-inf``/``inf`` allowed)."""
        lo = np.asarray(lower, dtype=np.float64)
        hi = np.asarray(upper, dtype=np.float64)
        if lo.shape != (len(self),) or hi.shape != (len(self),):
            raise ValidationError(f"expected brackets of {len(self)} entries")
        d = self.denominator
        for n, a, b in zip(self.numerators, lo, hi, strict=True):
            if np.isnan(a) or np.isnan(b):
                return False
            if np.isfinite(a):
                p, q = float(a).as_integer_ratio()
                if p * d > n * q:
                    return False
            elif a > 0:
                return False
            if np.isfinite(b):
                p, q = float(b).as_integer_ratio()
                if p * d < n * q:
                    return False
            elif b < 0:
                return False
        return True

    def dot(self, weights: Sequence[Fraction]) -> Fraction:
        """``sum_i w_i x_i`` exactly."""
        total = sum(
            (Fraction(w) * n for w, n in zip(weights, self.numerators, strict=True)), Fraction(0)
        )
        return total / self.denominator


def solve_rational(
    matrix: Sequence[Sequence[Fraction]], rhs: Sequence[Fraction]
) -> list[Fraction] | None:
    """The exact solution of the square system ``matrix x = rhs``; ``None`` if singular.

    python-flint's ``fmpq_mat.solve`` (fraction-free elimination or p-adic lifting, its
    choice). The one dense rational solver of lpbounds: the exact LP steps of
    :mod:`lpbounds.exact.lp` and the exact brackets of :mod:`lpbounds.studies.verify` use it.
    """
    flint = flint_module()
    n = len(rhs)
    if n == 0:
        return []
    if any(len(row) != n for row in matrix) or len(matrix) != n:
        raise ValidationError(f"solve_rational needs a square system; got {len(matrix)} rows")
    a = flint.fmpq_mat(n, n, [_fmpq(flint, t) for row in matrix for t in row])
    b = flint.fmpq_mat(n, 1, [_fmpq(flint, t) for t in rhs])
    try:
        x = a.solve(b)
    except ZeroDivisionError:
        return None
    return [Fraction(int(x[i, 0].p), int(x[i, 0].q)) for i in range(n)]


def _integer(s: Any) -> int:
    return s if isinstance(s, int) else int(s, 0)


def _fmpq(flint: Any, x: Any) -> Any:
    """A Fraction (or int, or float taken exactly) as python-flint's ``fmpq``."""
    f = rational(x)
    return flint.fmpq(f.numerator, f.denominator)
