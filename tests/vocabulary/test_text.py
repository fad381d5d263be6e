"""The formatters of :mod:`lpbounds.text`: what a person reads, never a Python repr.

The brackets are checked against the computed ends exactly (the printed text parsed back
with :class:`fractions.Fraction`, which holds every float and every decimal exactly), the
numbers by parsing them back and comparing with the value they show.
"""

from __future__ import annotations

import math
import re
from fractions import Fraction

import numpy as np
import pytest

from lpbounds.text import (
    fmt_bool,
    fmt_bracket,
    fmt_counts,
    fmt_list,
    fmt_number,
    fmt_sci,
    fmt_seconds,
    fmt_tuple,
    fmt_value,
    fmt_within,
)

REPR = re.compile(r"\['|'\]|\{'|\bTrue\b|\bFalse\b|\bNone\b|np\.|array\(")


def _parse(text: str) -> Fraction:
    """A number as printed (thousands separators, scientific notation), exactly."""
    return Fraction(text.replace(",", ""))


# ---------------------------------------------------------------------- fmt_number
@pytest.mark.parametrize(
    ("x", "text"),
    [
        (0, "0"),
        (0.0, "0"),
        (-0.0, "0"),
        (np.float64(-0.0), "0"),
        (1e-304, "1e-304"),
        (-1.5e-304, "-1.5e-304"),
        (5e-324, "4.941e-324"),
        (float("nan"), "nan"),
        (float("inf"), "inf"),
        (-float("inf"), "-inf"),
        (None, "-"),
        (2_048_000, "2,048,000"),
        (np.int64(12_345_678), "12,345,678"),
        (np.int32(-7), "-7"),
        (0.790292, "0.7903"),
        (np.float32(0.5), "0.5"),
        (51.017188, "51.02"),
        (123_456.7, "123,457"),  # integer digits are not rounded away
        (9999.7, "10,000"),
        (1e6, "1e+6"),
        (0.001, "0.001"),
        (4.0283e-13, "4.028e-13"),
        (True, "yes"),
        (False, "no"),
        (np.bool_(True), "yes"),
        (np.bool_(False), "no"),
    ],
)
def test_fmt_number(x, text):
    assert fmt_number(x) == text


@pytest.mark.parametrize("digits", [1, 2, 4, 6])
def test_fmt_number_is_never_zero_for_a_nonzero_value_and_reads_back(digits):
    rng = np.random.default_rng(0)
    xs = np.concatenate([10.0 ** rng.uniform(-320, 300, 400), -(10.0 ** rng.uniform(-30, 30, 100))])
    for x in xs:
        text = fmt_number(float(x), digits)
        assert text not in ("0", "-0", "0.0"), x
        back = float(_parse(text))
        # the shown value is x rounded at its digits-th significant digit (integer digits
        # of a fixed-notation number are all shown: at least that precise)
        assert abs(back - x) <= 0.5 * 10 ** (math.floor(math.log10(abs(x))) - digits + 1) * (
            1 + 1e-12
        ), (x, text)


def test_fmt_number_digits():
    assert fmt_number(math.pi, 2) == "3.1"
    assert fmt_number(math.pi, 6) == "3.14159"
    assert fmt_number(1 / 3e9, 3) == "3.33e-10"


# ---------------------------------------------------------------------- fmt_sci
@pytest.mark.parametrize(
    ("x", "digits", "text"),
    [
        (4.03e-13, 2, "4.0e-13"),
        (1.2e-5, 2, "1.2e-5"),  # no zero padding of the exponent
        (3e7, 1, "3e+7"),
        (1.0, 3, "1.00e+0"),  # trailing zeros kept: columns align
        (0.0, 2, "0"),
        (-0.0, 2, "0"),
        (1e-304, 2, "1.0e-304"),
        (float("nan"), 2, "nan"),
        (-float("inf"), 2, "-inf"),
        (None, 2, "-"),
        (np.float32(2.5), 2, "2.5e+0"),
        (np.int64(1500), 2, "1.5e+3"),
        (True, 2, "yes"),
    ],
)
def test_fmt_sci(x, digits, text):
    assert fmt_sci(x, digits) == text


# ---------------------------------------------------------------------- fmt_seconds
@pytest.mark.parametrize(
    ("s", "text"),
    [
        (0, "0 s"),
        (0.0, "0 s"),
        (0.0042, "4.2 ms"),
        (0.790292, "0.79 s"),
        (12.34, "12.3 s"),
        (125, "2 min 05 s"),
        (3725, "1 h 02 min"),
        (None, "-"),
        (float("nan"), "-"),
        (float("inf"), "inf s"),
        (np.float64(1.5), "1.50 s"),
    ],
)
def test_fmt_seconds(s, text):
    assert fmt_seconds(s) == text


# ---------------------------------------------------------------------- lists and mappings
def test_lists_read_as_words_not_reprs():
    assert fmt_list(["ELP", "RLP"]) == "ELP, RLP"
    assert fmt_list([15]) == "15"
    assert fmt_list([15, 16], "or") == "15 or 16"
    assert fmt_list(["mpi", "vi", "pi", "ipi"], "or") == "mpi, vi, pi or ipi"
    assert fmt_list([], "and") == "none"
    assert fmt_list((np.int64(3), 0.5, True)) == "3, 0.5, yes"
    assert fmt_tuple([np.int64(2), 0]) == "(2, 0)"
    assert fmt_counts({"continue": 138, "reverse": np.int64(1000)}) == (
        "continue: 138, reverse: 1,000"
    )
    assert fmt_counts({}) == "none"
    assert fmt_bool(np.bool_(True), "true", "false") == "true"


@pytest.mark.parametrize(
    ("x", "text"),
    [
        (None, "-"),
        (True, "yes"),
        (np.bool_(False), "no"),
        (3, "3"),
        (0.790292, "0.7903"),
        ({"a": 1, "b": 2}, "a: 1, b: 2"),
        (["ELP", "RLP"], "ELP, RLP"),
        (("x", 1), "x, 1"),
        ("text", "text"),
    ],
)
def test_fmt_value(x, text):
    assert fmt_value(x) == text
    assert not REPR.search(fmt_value(x))


# ---------------------------------------------------------------------- brackets
def _ends(text: str) -> tuple[Fraction, Fraction]:
    """The printed bracket's ends, exactly: ``[a, b]`` or ``0 ± m``."""
    if text.startswith("0 ± "):
        m = _parse(text[4:])
        return -m, m
    assert text[0] == "[" and text[-1] == "]", text
    a, b = text[1:-1].split(", ")
    return _parse(a), _parse(b)


def _pairs() -> list[tuple[float, float]]:
    rng = np.random.default_rng(1)
    out = []
    for _ in range(400):
        centre = float(rng.choice([-1, 1]) * 10.0 ** rng.uniform(-300, 300))
        width = abs(centre) * float(10.0 ** rng.uniform(-15.5, 1))
        out.append((centre - width / 2, centre + width / 2))
    for _ in range(100):  # around zero, asymmetric and symmetric
        a, b = 10.0 ** rng.uniform(-320, 10, 2)
        out.append((-float(a), float(b)))
    out += [(-1.5e-304, 1.5e-304), (0.0, 1e-300), (-1.0, 100.0), (-1e-10, 5.0)]
    out += [(2929.13898101012, 2929.13898101096), (-3.0, -2.5), (1e300, 1.7e308)]
    out += [(-1.7e308, 1.7e308), (-5e-324, 5e-324), (np.nextafter(1.0, 0.0), 1.0)]
    return [(lo, hi) for lo, hi in out if lo < hi]


@pytest.mark.parametrize("digits", [1, 2, 3])
def test_a_printed_bracket_contains_the_computed_one_and_shows_its_width(digits):
    for lo, hi in _pairs():
        text = fmt_bracket(lo, hi, digits)
        a, b = _ends(text)
        assert a <= Fraction(lo) and b >= Fraction(hi), (lo, hi, text)
        true = Fraction(hi) - Fraction(lo)
        if text.startswith("0 ± "):
            m = max(-Fraction(lo), Fraction(hi))
            assert lo < 0 < hi and b <= m * (1 + Fraction(10) ** (1 - digits)), (lo, hi, text)
        else:
            # each end moved by at most one unit of the width's digits-th digit (or of
            # 15 significant digits of the ends, the most a float resolves)
            mag = max(abs(Fraction(lo)), abs(Fraction(hi)))
            unit = max(true * Fraction(10) ** (1 - digits), mag * Fraction(10) ** -14)
            assert b - a <= true + 2 * unit, (lo, hi, text)


def test_a_bracket_around_zero_reads_as_zero_plus_minus():
    assert fmt_bracket(-1.5e-304, 1.5e-304) == "0 ± 1.6e-304"  # 1.5e-304 is above 1.5e-304
    assert fmt_bracket(-0.3, 0.5) == "0 ± 0.50"
    assert fmt_within(-1.5e-304, 1.5e-304) == "= 0 ± 1.6e-304"


def test_a_bracket_shows_each_end_to_its_own_digits():
    assert fmt_bracket(-1.0, 100.0) == "[-1.0, 100]"  # not [-10, 100]
    assert fmt_bracket(-1e-10, 5.0) == "[-1.1e-10, 5.0]"
    assert fmt_bracket(0.0, 1e-300) == "[0, 1.1e-300]"
    assert fmt_bracket(51.01718811011, 51.01718811026) == "[51.01718811010, 51.01718811027]"
    assert fmt_within(0.1, 0.3) == "in [0.10, 0.30]"


def test_degenerate_brackets():
    assert fmt_bracket(1.0, 1.0) == "[1, 1]"
    assert fmt_bracket(0.1, 0.1) == "[0.1, 0.1]"  # exactly: the shortest repr digits
    assert fmt_bracket(-0.0, 0.0) == "[0, 0]"
    assert fmt_bracket(-float("inf"), 3.2) == "[-inf, 3.20001]"
    assert fmt_bracket(float("nan"), 1.0) == "[nan, 1.00000]"
    assert fmt_bracket(np.float64(2.0), np.float32(2.0)) == "[2, 2]"
