"""How numbers, lists and times read in anything a user reads: one small vocabulary.

Reports, tables, summaries, help texts and error messages format their numbers here, so
that none of them prints a Python repr (``[15]``, ``['ELP', 'RLP']``, ``{'a': 1}``,
``True``) or a float at ``repr``/``str`` precision (``0.790292``, ``1e-06``):

* :func:`fmt_number` -- a number in a few significant digits: ``1,234``, ``0.7903``,
  ``4.03e-13``; exactly 0 (also ``-0.0``) reads ``0``, and a real tiny value is never shown
  as 0 (it goes to scientific notation);
* :func:`fmt_sci` -- always scientific, a fixed number of digits (residuals, errors,
  tolerances): ``4.0e-13``;
* :func:`fmt_seconds` -- a duration: ``8.8 ms``, ``0.79 s``, ``12.3 s``, ``2 min 05 s``;
* :func:`fmt_list` -- ``ELP, RLP``, or a list of choices ``mpi, vi, pi or ipi``;
* :func:`fmt_tuple` -- a vector ``(2, 0)``; :func:`fmt_counts` -- ``continue: 138,
  reverse: 100``; :func:`fmt_bool` -- ``yes`` / ``no`` (or any two words);
* :func:`fmt_bracket` -- a certified bracket ``[lower, upper]`` rounded **outward** at the
  digits shown (the printed bracket contains the computed one, never less), with enough
  digits to show its width and each end: ``[51.01718811010, 51.01718811027]``,
  ``[-1.0, 100]``; a bracket around 0 reads ``0 ± 9e-306``, not
  ``[-8.922546173e-306, 8.922546173e-306]``;
* :func:`fmt_within` -- a bracket after its words: ``in [a, b]`` or ``= 0 ± m``;
* :func:`fmt_value` -- any of these by type (a report's table cell).

Exponents are written without padding or a plus sign's zeros: ``1.2e-5``, ``3e+7``.
Layer 0: imports only the standard library (``lpbounds COMMAND --help`` reads it).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from decimal import ROUND_CEILING, ROUND_FLOOR, Decimal
from typing import Any

__all__ = [
    "fmt_bool",
    "fmt_bracket",
    "fmt_counts",
    "fmt_list",
    "fmt_number",
    "fmt_sci",
    "fmt_seconds",
    "fmt_tuple",
    "fmt_value",
    "fmt_within",
]

#: Magnitudes shown in fixed notation by :func:`fmt_number`; outside, scientific.
_FIXED_RANGE = (1e-3, 1e6)
#: The most significant digits :func:`fmt_bracket` shows (a float has 15-17).
_MAX_DIGITS = 15


def _exponent(text: str) -> str:
    """``1.20e-05`` -> ``1.20e-5``, ``3e+07`` -> ``3e+7`` (no zero padding)."""
    mant, sep, exp = text.partition("e")
    if not sep:
        return text
    sign = exp[0] if exp[:1] in "+-" else ""
    digits = exp.lstrip("+-").lstrip("0") or "0"
    return f"{mant}e{sign}{digits}"


def _strip_zeros(mantissa: str) -> str:
    """``4.000`` -> ``4``, ``4.020`` -> ``4.02`` (a mantissa, no exponent)."""
    return mantissa.rstrip("0").rstrip(".") if "." in mantissa else mantissa


def _special(x: float) -> str | None:
    """The text of nan, +-inf and 0 (also ``-0.0``), or None for any other float."""
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x == 0:
        return "0"
    return None


def _is_bool(x: Any) -> bool:
    """A Python or numpy bool (``numpy.bool_``, named ``bool`` in numpy 2), without
    importing numpy."""
    t = type(x)
    return isinstance(x, bool) or (t.__module__ == "numpy" and t.__name__ in ("bool_", "bool"))


def _is_int(x: Any) -> bool:
    return not _is_bool(x) and hasattr(x, "__index__") and not isinstance(x, str)


def fmt_number(x: Any, digits: int = 4) -> str:
    """A number as a person writes it, in ``digits`` significant digits.

    Parameters
    ----------
    x : int or float (numpy scalars too), or None
        The number.
    digits : int
        Significant digits of a non-integer (default 4).

    Returns
    -------
    str
        ``"-"`` for None; a bool ``yes``/``no`` (not ``1``); an integer with thousands
        separators (``2,048,000``); exactly 0,
        also ``-0.0``, as ``"0"``; a magnitude in ``[1e-3, 1e6)`` in fixed notation
        without trailing zeros (``0.7903``, ``51.02``; integer digits are never rounded
        away: ``123,457``); others in scientific notation (``4.028e-13``, ``1.5e-304``):
        a tiny value is never shown as 0. ``nan``, ``inf``, ``-inf`` as such.
    """
    if x is None:
        return "-"
    if _is_bool(x):
        return fmt_bool(x)
    if _is_int(x):
        return f"{int(x):,}"
    v = float(x)
    special = _special(v)
    if special is not None:
        return special
    digits = max(1, int(digits))
    a = abs(v)
    if not _FIXED_RANGE[0] <= a < _FIXED_RANGE[1]:
        mant, _, exp = f"{v:.{digits - 1}e}".partition("e")
        return _exponent(f"{_strip_zeros(mant)}e{exp}")
    if a >= 10**digits:
        return f"{v:,.0f}"  # every integer digit: a count is not rounded to 4 digits
    text = f"{v:,.{digits}g}"
    return f"{v:,.0f}" if "e" in text else text  # 9999.7 rounds up to 10,000


def fmt_sci(x: Any, digits: int = 2) -> str:
    """A number in scientific notation with ``digits`` significant digits: ``4.0e-13``.

    For residuals, errors and tolerances, whose order of magnitude is the point; trailing
    zeros are kept (columns align). 0 (also ``-0.0``) reads ``0``; None ``"-"``; a bool
    ``yes``/``no``.
    """
    if x is None:
        return "-"
    if _is_bool(x):
        return fmt_bool(x)
    v = float(x)
    special = _special(v)
    if special is not None:
        return special
    return _exponent(f"{v:.{max(1, int(digits)) - 1}e}")


def fmt_seconds(seconds: Any) -> str:
    """A duration: ``0 s``, ``8.8 ms`` (below 10 ms), ``0.79 s``, ``12.3 s``, ``2 min 05 s``,
    ``1 h 02 min``; None or nan ``"-"``."""
    if seconds is None:
        return "-"
    s = float(seconds)
    if math.isnan(s):
        return "-"
    if math.isinf(s) or s < 0:
        return f"{fmt_number(s)} s"
    if s == 0:
        return "0 s"
    if s < 0.01:
        return f"{fmt_number(s * 1e3, 2)} ms"
    if s < 10:
        return f"{s:.2f} s"
    if s < 60:
        return f"{s:.1f} s"
    if s < 3600:
        m, r = divmod(round(s), 60)
        return f"{m} min {r:02d} s"
    h, r = divmod(round(s) // 60, 60)
    return f"{h} h {r:02d} min"


def _item(x: Any) -> str:
    if isinstance(x, str):
        return x
    if _is_bool(x):
        return fmt_bool(x)
    if _is_int(x) or isinstance(x, float) or type(x).__name__.startswith("float"):
        return fmt_number(x)
    return str(x)


def fmt_list(items: Iterable[Any], last: str | None = None) -> str:
    """Items joined by commas: ``ELP, RLP``; with ``last="or"`` a list of choices
    ``mpi, vi, pi or ipi`` (``last="and"``: ``a, b and c``). Numbers as :func:`fmt_number`,
    strings as they are (no quotes); ``"none"`` for no item."""
    texts = [_item(x) for x in items]
    if not texts:
        return "none"
    if last is None or len(texts) == 1:
        return ", ".join(texts)
    return f"{', '.join(texts[:-1])} {last} {texts[-1]}"


def fmt_tuple(items: Iterable[Any]) -> str:
    """A vector as a mathematician writes it: ``(2, 0)``."""
    return "(" + ", ".join(_item(x) for x in items) + ")"


def fmt_counts(counts: Mapping[Any, Any]) -> str:
    """``key: count`` pairs in their order: ``continue: 138, reverse: 100, loiter: 82``."""
    return ", ".join(f"{_item(k)}: {_item(v)}" for k, v in counts.items()) or "none"


def fmt_bool(flag: Any, true: str = "yes", false: str = "no") -> str:
    """``yes`` / ``no`` (or the two words given, e.g. ``true`` / ``false`` for a setting
    of a TOML file)."""
    return true if bool(flag) else false


def _decimal_text(d: Decimal, scientific: bool) -> str:
    if d == 0:
        return "0"
    return format(d, "e") if scientific else format(d, "f")


def _quantum_exp(x: float, digits: int) -> int:
    """The decimal exponent of the ``digits``-th significant digit of ``x`` (nonzero)."""
    return math.floor(math.log10(abs(x))) - (digits - 1)


def _outward(x: float, q_exp: int, rounding: str) -> str:
    """``x`` rounded at ``10**q_exp`` in the direction ``rounding``, as text (fixed notation
    in ``[1e-3, 1e6)``, scientific outside)."""
    if x == 0:
        return "0"
    q_exp = max(q_exp, _quantum_exp(x, _MAX_DIGITS))
    d = Decimal(x).quantize(Decimal(1).scaleb(q_exp), rounding=rounding)
    return _decimal_text(d, not _FIXED_RANGE[0] <= abs(x) < _FIXED_RANGE[1])


def fmt_bracket(lower: Any, upper: Any, digits: int = 2) -> str:
    """A bracket ``[lower, upper]`` rounded outward at the digits it shows.

    Parameters
    ----------
    lower, upper : float
        The bracket's ends (a certified bracket: the shown one must contain it).
    digits : int
        Significant digits (default 2) of the width the ends resolve, and of each end
        itself: an end is shown to the decimal place of the width's ``digits``-th digit or
        of its own, whichever is finer, at most 15 significant digits.

    Returns
    -------
    str
        ``[a, b]`` with ``a <= lower`` and ``b >= upper`` exactly (decimal rounding of the
        binary values toward -inf and +inf), so the bracket is never shown narrower than it
        is; each end in fixed notation when its magnitude is in ``[1e-3, 1e6)``, else
        scientific: ``[51.01718811010, 51.01718811027]``, ``[-1.0, 100]``, ``[0, 1.1e-300]``.
        A bracket around 0 whose ends are within a factor 10 of each other in magnitude
        reads ``0 ± m`` with ``m >= max(-lower, upper)`` (``0 ± 1.6e-304``, not
        ``[-1.5e-304, 1.5e-304]``). Equal ends are shown exactly (shortest repr digits); an
        infinite or nan end as such, the other to 6 digits, outward.
    """
    lo, hi = float(lower), float(upper)
    digits = max(1, int(digits))
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo >= hi:
        if lo == hi and math.isfinite(lo):
            text = _shortest(lo)
            return f"[{text}, {text}]"
        return f"[{_half(lo, ROUND_FLOOR)}, {_half(hi, ROUND_CEILING)}]"
    if lo < 0 < hi and max(-lo, hi) <= 10 * min(-lo, hi):
        m = max(-lo, hi)
        return f"0 ± {_outward(m, _quantum_exp(m, digits), ROUND_CEILING)}"
    width = hi - lo if math.isfinite(hi - lo) else max(abs(lo), abs(hi))
    q_exp = _quantum_exp(width, digits)
    ends = []
    for x, rounding in ((lo, ROUND_FLOOR), (hi, ROUND_CEILING)):
        own = _quantum_exp(x, digits) if x != 0 else q_exp
        ends.append(_outward(x, min(q_exp, own), rounding))
    return f"[{ends[0]}, {ends[1]}]"


def fmt_within(lower: Any, upper: Any, digits: int = 2) -> str:
    """:func:`fmt_bracket` after the words that go with it: ``in [a, b]``, or ``= 0 ± m``
    for a bracket around 0 (``c'w* in [2929.1389, 2929.1390]``, ``c'w* = 0 ± 1.6e-304``)."""
    text = fmt_bracket(lower, upper, digits)
    return f"in {text}" if text.startswith("[") else f"= {text}"


def _shortest(x: float) -> str:
    """``x`` exactly, in the shortest digits that read back as it (``1``, ``0.1``, ``2.5e-7``)."""
    if x == 0:
        return "0"
    text = repr(x)
    mant, sep, exp = text.partition("e")
    return _exponent(f"{_strip_zeros(mant)}{sep}{exp}")


def _half(x: float, rounding: str) -> str:
    """One end alone (the other infinite or nan): 6 significant digits, rounded outward."""
    special = _special(x)
    if special is not None:
        return special
    return _outward(x, _quantum_exp(x, 6), rounding)


def fmt_value(x: Any, digits: int = 4) -> str:
    """Any value of a report's cell by its type: None ``-``, a bool ``yes``/``no``, a number
    :func:`fmt_number`, a mapping :func:`fmt_counts`, a list or tuple :func:`fmt_list`,
    anything else ``str``."""
    if x is None:
        return "-"
    if _is_bool(x):
        return fmt_bool(x)
    if _is_int(x):
        return fmt_number(x)
    if isinstance(x, float) or type(x).__name__.startswith("float"):
        return fmt_number(x, digits)
    if isinstance(x, Mapping):
        return fmt_counts(x)
    if isinstance(x, (list, tuple)):
        return fmt_list(x)
    return str(x)
