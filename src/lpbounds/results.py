"""The result base shared by every result lpbounds returns: :class:`Result`.

:class:`~lpbounds.formulations.results.LPResult`,
:class:`~lpbounds.formulations.nlp.results.NLPResult` and :class:`~lpbounds.dp.DPResult`
are dataclasses that subclass :class:`Result`, a plain mixin with no fields (so the
subclasses' field order, hence their constructors, are their own). It gives them, in one
place, the one predicate :attr:`Result.ok`, a one-line ``repr``, a :meth:`Result.summary`,
an HTML table for Jupyter (:meth:`Result._repr_html_`) and a :meth:`Result.to_pandas`
table, all built from the attributes every result has:

``status`` : :class:`lpbounds.status.Status`
    What lpbounds knows about the returned point (decided from its certificate).
``values`` : ndarray
    The returned point, one entry per variable of the problem (state, partition, weight).
``lower_values``, ``upper_values`` : ndarray or None
    The certified bracket (``None`` on an LP without a certificate).
``error_bound`` : float
    A certified bound on ``max |values - exact|`` (``inf`` without a certificate).
``iterations`` : int or None
    The method's own count (solver iterations, rounds, improvement sweeps).

and, where the result has one, ``objective`` (a float). A subclass contributes its own
facts through three public hooks: :meth:`Result.label` (the one-word kind, e.g. the
formulation or the method), :meth:`Result.summary_items` (labelled lines of the summary
and rows of the HTML table) and :meth:`Result.table_columns` (extra columns of
:meth:`Result.to_pandas`, e.g. the policy of a DP result).

:func:`outward_bracket` is the bracket ``values -+ error_bound`` rounded outward, for
results that carry only a point and its error bound (DP results, policy evaluations).
"""

from __future__ import annotations

import html
from typing import TYPE_CHECKING, Any

import numpy as np

from .status import Status
from .text import fmt_sci

if TYPE_CHECKING:  # annotations only
    import pandas as pd

__all__ = ["Result", "outward_bracket"]


def outward_bracket(values: Any, error_bound: float) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)`` with ``lower <= x <= upper`` entrywise for every real vector ``x``
    with ``||values - x||_inf <= error_bound``.

    Parameters
    ----------
    values : array_like of float
        The point.
    error_bound : float
        A certified bound on ``||values - x||_inf`` for the exact ``x`` to be bracketed.

    Returns
    -------
    lower, upper : ndarray
        ``nextafter(values - error_bound, -inf)`` and ``nextafter(values + error_bound,
        +inf)``: two new arrays of the shape of ``values``.

    Notes
    -----
    Why the bracket contains ``x``: in exact arithmetic ``values(i) - error_bound <= x(i)
    <= values(i) + error_bound``. The computed ``values(i) - error_bound`` is the float
    nearest the exact difference ``d`` (IEEE round to nearest), so ``d`` lies between that
    float and its neighbour on the side of ``d``, and one ``nextafter`` toward ``-inf``
    gives a float ``<= d <= x(i)``; the same toward ``+inf`` for the upper end. The width
    is therefore ``2 error_bound`` plus at most about two ulps of ``values(i) +-
    error_bound`` on each side. An overflow gives ``-inf`` / ``inf`` (still valid), an
    ``error_bound`` of ``inf`` the vacuous bracket.
    """
    v = np.asarray(values, dtype=np.float64)
    e = float(error_bound)
    return np.nextafter(v - e, -np.inf), np.nextafter(v + e, np.inf)


def _fmt(x: Any, spec: str = ".3e") -> str:
    """A number for display (``None`` as "none"); an ``.Ne`` spec as
    :func:`~lpbounds.text.fmt_sci` writes it (``4.337e-1``, not ``4.337e-01``)."""
    if x is None:
        return "none"
    try:
        if spec.endswith("e"):
            return fmt_sci(float(x), int(spec[1:-1]) + 1)
        return format(float(x), spec)
    except (TypeError, ValueError):
        return str(x)


class Result:
    """Mixin base of lpbounds' results (no fields of its own; see the module docstring).

    Subclasses are dataclasses declared with ``repr=False`` (a dataclass's generated
    ``__repr__`` would print every array) that have the attributes ``status``, ``values``,
    ``lower_values``, ``upper_values``, ``error_bound`` and ``iterations``, and where they
    have one, ``objective``.
    """

    # the attributes every result has (dataclass fields or properties of the subclasses)
    status: Status
    values: np.ndarray
    error_bound: float

    # ------------------------------------------------------------------ the predicate
    @property
    def ok(self) -> bool:
        """True when ``status is Status.OPTIMAL``: a point certified within the requested
        accuracy (the one predicate; every other status keeps a valid but wider bracket,
        or has no point)."""
        return self.status is Status.OPTIMAL

    # ------------------------------------------------------------------ hooks
    def label(self) -> str:
        """The kind of result in a word or two (the formulation, the method); hook.

        Returns
        -------
        str
            ``""`` here; subclasses return e.g. ``"RLP"`` or ``"mpi"``.
        """
        return ""

    def summary_items(self) -> list[tuple[str, str]]:
        """The subclass's own facts for :meth:`summary` and :meth:`_repr_html_`; hook.

        Returns
        -------
        list of (str, str)
            ``(label, text)`` pairs, one line of the summary (``label: text``) and one row
            of the HTML table each, after the common ones. Empty here.
        """
        return []

    def table_columns(self) -> dict[str, np.ndarray]:
        """Extra columns of :meth:`to_pandas`, one entry per entry of ``values``; hook.

        Returns
        -------
        dict of str to ndarray
            Column name to an array of ``len(values)`` entries (e.g. ``{"policy": ...}``
            for a DP result). Empty here.
        """
        return {}

    # ------------------------------------------------------------------ common facts
    def _size(self) -> int:
        v = getattr(self, "values", None)
        return 0 if v is None else int(np.size(v))

    def _objective(self) -> float | None:
        obj = getattr(self, "objective", None)
        return None if obj is None else float(obj)

    def _bracket(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        return getattr(self, "lower_values", None), getattr(self, "upper_values", None)

    def _width(self) -> float | None:
        """``max(upper_values - lower_values)`` (None without a bracket)."""
        lo, hi = self._bracket()
        if lo is None or hi is None:
            return None
        d = np.asarray(hi, dtype=np.float64) - np.asarray(lo, dtype=np.float64)
        return float(d.max()) if d.size else 0.0

    def _status_text(self) -> str:
        st = self.status
        if self.ok:
            return f"{st!s} (certified within the requested accuracy)"
        if getattr(st, "has_point", False):
            return f"{st!s} (NOT converged: a valid certified bracket, wider than asked)"
        return f"{st!s} (NOT converged: no point)"

    def _title(self) -> str:
        lab = self.label()
        return f"{type(self).__name__}[{lab}]" if lab else type(self).__name__

    def _common_items(self) -> list[tuple[str, str]]:
        items = [("status", self._status_text()), ("values", f"{self._size()} entries")]
        obj = self._objective()
        if obj is not None:
            items.append(("objective", _fmt(obj, ".10g")))
        items.append(("certified error", f"max|values - exact| <= {_fmt(self.error_bound)}"))
        items.append(("bracket width", f"max(upper - lower) = {_fmt(self._width())}"))
        items.append(("iterations", str(getattr(self, "iterations", None))))
        return items

    # ------------------------------------------------------------------ displays
    def __repr__(self) -> str:
        """One line, no arrays: type, kind, status, size, objective, certified error."""
        parts = [self.label()] if self.label() else []
        parts += [f"status={self.status!s}", f"values={self._size()}"]
        obj = self._objective()
        if obj is not None:
            parts.append(f"objective={_fmt(obj, '.10g')}")
        parts.append(f"error_bound={_fmt(self.error_bound)}")
        return f"{type(self).__name__}({', '.join(parts)})"

    def summary(self) -> str:
        """A few lines of plain text: the title, the common facts, the subclass's own.

        Returns
        -------
        str
            ``Title: status ...`` then one ``label: text`` line per fact
            (:meth:`summary_items` contributes the subclass's).
        """
        items = self._common_items() + self.summary_items()
        return "\n".join([self._title(), *(f"  {k}: {v}" for k, v in items)])

    def _repr_html_(self) -> str:
        """The facts of :meth:`summary` as a small HTML table (for Jupyter), escaped."""
        items = self._common_items() + self.summary_items()
        rows = "".join(
            f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
            f"<td style='text-align:left'>{html.escape(v)}</td></tr>"
            for k, v in items
        )
        return f"<table><caption>{html.escape(self._title())}</caption>{rows}</table>"

    def to_pandas(self) -> pd.DataFrame:
        """One row per entry of ``values``: ``value``, ``lower``, ``upper`` and the
        subclass's :meth:`table_columns`.

        ``lower``/``upper`` are the certified bracket where it has the shape of ``values``,
        NaN otherwise (no certificate; ALP, whose bracket is per state while its values
        are weights).

        Returns
        -------
        pandas.DataFrame
            Indexed by ``entry`` (0, 1, ...).
        """
        import pandas as pd  # 0.3 s to import: only where it is used

        v = np.asarray(self.values, dtype=np.float64).reshape(-1)
        cols: dict[str, np.ndarray] = {"value": v}
        nan = np.full(v.size, np.nan)
        for name, b in zip(("lower", "upper"), self._bracket(), strict=True):
            same = b is not None and np.shape(b) == np.shape(self.values)
            cols[name] = np.asarray(b, dtype=np.float64).reshape(-1) if same else nan
        cols.update({k: np.asarray(c).reshape(-1) for k, c in self.table_columns().items()})
        return pd.DataFrame(cols, index=pd.RangeIndex(v.size, name="entry"))
