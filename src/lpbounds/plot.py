r"""Plots of bounds for any model: matplotlib axes in, axes out.

Four functions draw what lpbounds computes, for a garnet, a Gymnasium model or the patrol
alike:

* :func:`bounds`: ``V*(x)`` of every state as dots, grouped by partition, each partition's
  lower and upper bound as steps, and ``min V*`` over the partition drawn above the dots
  (the paper's Figures 4-5 for any model);
* :func:`gap`: the gap ``upper - lower`` per partition, optionally against the spread
  ``max V* - min V*`` inside it (the part of the gap no bound could close);
* :func:`nlp_bracket`: the NLP's bracket on ``c'w*`` round by round, its certified final
  bracket, and optionally the RLP's objective above it;
* :func:`dp_residuals`: the Bellman residual of exact DP per improvement sweep (log scale)
  against its stopping tolerance.

Each takes ``ax=None`` (a :class:`matplotlib.axes.Axes`; without one, a new figure from
:func:`matplotlib.pyplot.subplots`, on whatever backend the session uses) and returns the
axes it drew on. ``import lpbounds.plot`` imports no matplotlib at all (each function
imports what it needs when called) and never selects a backend.

Results are read the way their docstrings define them: a bound given as a result
(:class:`~lpbounds.formulations.results.LPResult`, :class:`~lpbounds.dp.DPResult`,
:class:`~lpbounds.formulations.nlp.results.NLPResult`) is drawn at its certified end,
``lower_values`` for a lower bound and ``upper_values`` for an upper bound, never at the
point a solver returned; its whole certified bracket ``[lower_values, upper_values]`` is
drawn as a bracket and named in the legend (or, when it is too narrow to see, its width is
written in the bound's legend entry). Arrays are drawn as given.

Style
-----
Every element a function draws has a name (``dots``, ``lower_line``, ``min_line``, ...,
listed in each docstring) and a default style; a keyword argument of that name updates it
with matplotlib keywords (``min_line={"color": "black"}``), ``None`` leaves the element
out, and ``legend=None`` draws no legend. An unknown name is a
:class:`~lpbounds.errors.ValidationError`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import ValidationError
from .model.partition import Partition
from .results import Result
from .tolerances import PLOT_BOUND_RTOL, PLOT_COST_MATCH_RTOL
from .validation import as_float_array, check_array, check_choice, describe_value

if TYPE_CHECKING:  # annotations only: matplotlib is imported when a function draws
    from matplotlib.axes import Axes

__all__ = ["BRACKET_DRAW_FRACTION", "bounds", "dp_residuals", "gap", "nlp_bracket"]

#: With ``brackets="auto"``, a certified bracket is drawn only when its widest entry is at
#: least this fraction of the plotted values' range (below it, its caps would merge into the
#: line they bracket); otherwise its width is written in the legend. A drawing choice, not a
#: tolerance: no number is judged by it.
BRACKET_DRAW_FRACTION: float = 1e-3

Style = dict[str, dict[str, Any] | None]


# ---------------------------------------------------------------------- shared helpers
def _num(x: float, digits: int = 2) -> str:
    """A number as people write it: ``2.1e-13``, ``0.052``, ``1.4e6`` (no ``e-05``)."""
    if not np.isfinite(x):
        return "inf" if x > 0 else ("-inf" if x < 0 else "nan")
    text = f"{x:.{digits}g}"
    if "e" in text:
        mant, exp = text.split("e")
        text = f"{mant}e{int(exp)}"
    return text


def _styles(defaults: Mapping[str, dict[str, Any]], given: Mapping[str, Any]) -> Style:
    """The defaults updated by the caller's ``**style`` (checked names, dicts or None)."""
    out: Style = {k: dict(v) for k, v in defaults.items()}
    for name, value in given.items():
        if name not in defaults:
            raise ValidationError(
                f"style: unknown element {name!r}; this plot draws {', '.join(defaults)}"
            )
        if value is None:
            out[name] = None
        elif isinstance(value, Mapping):
            base = out[name] or {}
            out[name] = {**base, **value}
        else:
            raise ValidationError(
                f"style {name}= must be a dict of matplotlib keywords or None; got "
                f"{describe_value(value)}"
            )
    return out


def _axes(ax: Any, figsize: tuple[float, float]) -> Axes:
    """``ax`` if it is an Axes, else (``ax is None``) the axes of a new pyplot figure."""
    from matplotlib.axes import Axes

    if ax is None:
        import matplotlib.pyplot as plt  # the session's backend, never switched

        _, new = plt.subplots(figsize=figsize)
        return new
    if not isinstance(ax, Axes):
        raise ValidationError(f"ax must be a matplotlib Axes or None; got {describe_value(ax)}")
    return ax


def _legend(ax: Axes, style: Style) -> None:
    kw = style.get("legend")
    if kw is not None and ax.get_legend_handles_labels()[0]:
        ax.legend(**kw)


def _is_result(x: Any) -> bool:
    """A result (lpbounds' or any object with a certified bracket), not an array."""
    return isinstance(x, Result) or (
        hasattr(x, "lower_values") and hasattr(x, "upper_values") and hasattr(x, "values")
    )


def _name(result: Any) -> str:
    """What produced a result, for the legend: the formulation, else "exact DP"."""
    name = getattr(result, "formulation", None)
    return str(name) if name else "exact DP"


def _as_partition(partition: Any) -> Partition:
    if isinstance(partition, Partition):
        return partition
    if partition is None:
        raise ValidationError("partition must be a Partition or an array of labels; got None")
    return Partition(check_array("partition", partition, integer=True))


# ---------------------------------------------------------------------- reading the inputs
@dataclass
class _Series:
    """One input read: ``y`` per state or per partition, and its certified bracket."""

    y: np.ndarray
    per_state: bool
    bracket: tuple[np.ndarray, np.ndarray] | None = None
    source: str | None = None  # the result's name; None for an array

    def width(self) -> float:
        if self.bracket is None or self.bracket[0].size == 0:
            return 0.0
        return float(np.max(self.bracket[1] - self.bracket[0]))


def _read_values(values: Any, n: int) -> _Series:
    """``values`` (V* per state): an array of length n or a result whose ``values`` is."""
    if _is_result(values):
        v = as_float_array("values.values", values.values)
        if v.shape != (n,):
            raise ValidationError(
                f"values: the result's values have shape {v.shape}; V* per state needs "
                f"length n_states = {n}"
            )
        lo, hi = values.lower_values, values.upper_values
        bracket = None
        if lo is not None and hi is not None and np.shape(lo) == (n,) == np.shape(hi):
            bracket = (np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64))
        return _Series(v, True, bracket, _name(values))
    v = as_float_array("values", values)
    if v.shape != (n,):
        raise ValidationError(
            f"values must have length n_states = {n} (V* per state); got shape {v.shape}"
        )
    return _Series(v, True)


def _read_bound(name: str, bound: Any, part: Partition, side: str) -> _Series | None:
    """A lower (``side="lower"``) or upper bound: per partition (length M) or per state
    (length n; when n == M, read per partition); a result gives its certified end."""
    if bound is None:
        return None
    n, m = part.n_states, part.n_partitions
    if _is_result(bound):
        lo, hi = bound.lower_values, bound.upper_values
        if lo is None or hi is None:
            raise ValidationError(
                f"{name}: the {_name(bound)} result has no certified bracket (lower_values "
                "is None), so it bounds nothing: pass its values as an array to plot them"
            )
        lo = as_float_array(f"{name}.lower_values", lo, finite=False)
        hi = as_float_array(f"{name}.upper_values", hi, finite=False)
        y = lo if side == "lower" else hi
        bracket: tuple[np.ndarray, np.ndarray] | None = (lo, hi)
        source: str | None = _name(bound)
        what = f"{name}.{side}_values"
    else:
        y = as_float_array(name, bound)
        bracket, source, what = None, None, name
    if y.ndim != 1 or y.size not in (n, m):
        raise ValidationError(
            f"{what} must have length n_partitions = {m} (per partition) or n_states = {n} "
            f"(per state); got shape {y.shape}"
        )
    if np.isnan(y).any():
        k = int(np.flatnonzero(np.isnan(y))[0])
        raise ValidationError(f"{what}[{k}] is NaN: a bound must be a number")
    return _Series(y, y.size != m, bracket, source)


def _indices(name: str, x: Any, size: int) -> np.ndarray:
    """Distinct integer indices into ``range(size)``."""
    arr = check_array(name, x, integer=True, ndim=1).astype(np.int64)
    bad = (arr < 0) | (arr >= size)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValidationError(f"{name}[{k}] = {int(arr[k])} is out of range [0, {size})")
    uniq, first = np.unique(arr, return_index=True)
    if uniq.size != arr.size:
        dup = np.setdiff1d(np.arange(arr.size), first)[0]
        raise ValidationError(f"{name}[{int(dup)}] = {int(arr[dup])} is repeated")
    return arr


# ---------------------------------------------------------------------- the layout
@dataclass
class _Groups:
    """The plotted states grouped by partition, in plotting order."""

    parts: np.ndarray  # the partitions, in plotting order
    states: np.ndarray  # the plotted states, grouped by partition
    start: np.ndarray  # group k is states[start[k]:end[k]]
    end: np.ndarray
    x: np.ndarray  # x of each plotted state
    centre: np.ndarray  # x of each group's centre


def _select(
    part: Partition,
    v: np.ndarray,
    lower: _Series | None,
    upper: _Series | None,
    states: Any,
    partitions: Any,
    order: str,
) -> tuple[np.ndarray, np.ndarray]:
    """(partitions in plotting order, plotted states in their given order)."""
    n, m, lab = part.n_states, part.n_partitions, part.labels
    shown = np.arange(n) if states is None else _indices("states", states, n)
    if partitions is not None:
        parts = _indices("partitions", partitions, m)
        keep = np.zeros(m, dtype=bool)
        keep[parts] = True
        shown = shown[keep[lab[shown]]]
        have = np.zeros(m, dtype=bool)
        have[lab[shown]] = True
        if not have[parts].all():
            k = int(np.flatnonzero(~have[parts])[0])
            raise ValidationError(
                f"partitions[{k}] = {int(parts[k])} has no state among the plotted states"
            )
        return parts, shown
    if shown.size == 0:
        raise ValidationError("states is empty: nothing to plot")
    parts = np.unique(lab[shown])
    if order == "index":
        return parts, shown
    if order == "min":
        key = np.full(m, np.inf)
        np.minimum.at(key, lab[shown], v[shown])
    else:
        series = lower if order == "lower" else upper
        if series is None:
            raise ValidationError(f"order = {order!r} needs the {order} bound; it is None")
        key = _per_partition(series, part, "min" if order == "lower" else "max")
    return parts[np.argsort(key[parts], kind="stable")], shown


def _per_partition(series: _Series, part: Partition, how: str) -> np.ndarray:
    """A series per partition: per-state entries reduced by ``how`` (min for a lower bound,
    max for an upper bound: the value that holds for every state of the partition)."""
    return part.aggregate(series.y, how) if series.per_state else series.y


def _group(
    part: Partition,
    v: np.ndarray,
    parts: np.ndarray,
    shown: np.ndarray,
    within: str,
    layout: str,
) -> _Groups:
    """Group ``shown`` by partition in the order ``parts``; x positions per ``layout``."""
    rank = np.full(part.n_partitions, -1, dtype=np.int64)
    rank[parts] = np.arange(parts.size)
    r = rank[part.labels[shown]]
    keys = (np.arange(shown.size), r) if within == "given" else (v[shown], r)
    states = shown[np.lexsort(keys)]
    sizes = np.bincount(rank[part.labels[states]], minlength=parts.size)
    end = np.cumsum(sizes)
    start = end - sizes
    if layout == "states":
        x = np.arange(states.size, dtype=np.float64)
        centre = (start + end - 1) / 2.0
    else:
        centre = np.arange(1, parts.size + 1, dtype=np.float64)
        x = np.repeat(centre, sizes)
    return _Groups(parts, states, start, end, x, centre)


# ---------------------------------------------------------------------- drawing pieces
def _bound_line(
    g: _Groups, series: _Series, part: Partition, how: str, layout: str
) -> tuple[np.ndarray, np.ndarray]:
    """Vertices of a bound's steps: per state (``states`` layout) or per group."""
    if layout == "partitions":
        y = _per_partition(series, part, how)[g.parts]
        return g.centre, y
    y = series.y[g.states] if series.per_state else series.y[part.labels[g.states]]
    left, right = g.x - 0.5, g.x + 0.5
    left[g.start] += 0.1  # a gap between neighbouring partitions
    right[g.end - 1] -= 0.1
    xs = np.stack([left, right], axis=1).ravel()
    ys = np.repeat(y, 2)
    cut = 2 * g.end[:-1]  # a NaN after each group's last vertex breaks the line
    return np.insert(xs, cut, np.nan), np.insert(ys, cut, np.nan)


def _min_line(g: _Groups, v: np.ndarray, layout: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices of the ``min V*`` segments, one per group, NaN between them."""
    vmin = np.minimum.reduceat(v[g.states], g.start)
    if layout == "states":
        lo, hi = g.x[g.start] - 0.4, g.x[g.end - 1] + 0.4
    else:
        lo, hi = g.centre - 0.3, g.centre + 0.3
    nan = np.full(g.parts.size, np.nan)
    xs = np.stack([lo, hi, nan], axis=1).ravel()[:-1]
    ys = np.stack([vmin, vmin, nan], axis=1).ravel()[:-1]
    return xs, ys


def _bracket_at(
    g: _Groups, series: _Series, part: Partition, layout: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, lower end, upper end) of a series' certified bracket, where it is drawn."""
    assert series.bracket is not None
    lo, hi = series.bracket
    if series.per_state and layout == "states":
        return g.x, lo[g.states], hi[g.states]
    if series.per_state:  # one bracket per group, containing those of its states
        return g.centre, part.aggregate(lo, "min")[g.parts], part.aggregate(hi, "max")[g.parts]
    return g.centre, lo[g.parts], hi[g.parts]


def _draw_bracket(
    ax: Axes, x: np.ndarray, lo: np.ndarray, hi: np.ndarray, kw: dict[str, Any]
) -> None:
    """A certified bracket ``[lo, hi]`` at ``x``: a vertical bar with caps at both ends."""
    mid = lo + (hi - lo) / 2.0
    ax.errorbar(x, mid, yerr=np.vstack([mid - lo, hi - mid]), **kw)


def _outside(
    g: _Groups, values: _Series, lower: _Series | None, upper: _Series | None, part: Partition
) -> np.ndarray:
    """Plotted states whose V* lies outside a bound: beyond the certified brackets when
    both are certified, else beyond ``PLOT_BOUND_RTOL * max(1, max|V*|)``."""
    s = g.states
    v = values.y[s]
    vlo, vhi = (values.bracket[0][s], values.bracket[1][s]) if values.bracket else (v, v)
    bad = np.zeros(s.size, dtype=bool)
    slack = PLOT_BOUND_RTOL * max(1.0, float(np.abs(values.y).max(initial=0.0)))
    for series, sign in ((lower, 1.0), (upper, -1.0)):
        if series is None:
            continue
        y = series.y[s] if series.per_state else series.y[part.labels[s]]
        certified = series.bracket is not None and values.bracket is not None
        tol = 0.0 if certified else slack
        if sign > 0:
            bad |= vhi < y - tol
        else:
            bad |= vlo > y + tol
    return np.flatnonzero(bad)


# ---------------------------------------------------------------------- bounds
_BOUNDS_STYLE: dict[str, dict[str, Any]] = {
    "dots": {
        "marker": "o",
        "ls": "none",
        "ms": 3.5,
        "color": "tab:blue",
        "zorder": 3,
        "label": "V*(x), x in the partition",
    },
    "lower_line": {"color": "tab:orange", "lw": 1.5, "zorder": 2, "label": "lower bound"},
    "upper_line": {"color": "tab:red", "lw": 1.5, "zorder": 2, "label": "upper bound"},
    # above the dots (zorder 4 > 3): where many states share the least value, the dots
    # would otherwise hide the line the figure is about
    "min_line": {
        "color": "green",
        "lw": 2,
        "zorder": 4,
        "solid_capstyle": "butt",
        "label": "min V* over the partition",
    },
    "values_bracket": {"fmt": "none", "ecolor": "tab:cyan", "capsize": 2, "zorder": 2.5},
    "lower_bracket": {"fmt": "none", "ecolor": "tab:brown", "capsize": 4, "zorder": 5},
    "upper_bracket": {"fmt": "none", "ecolor": "tab:purple", "capsize": 4, "zorder": 5},
    "outside": {
        "marker": "o",
        "ls": "none",
        "ms": 9,
        "mfc": "none",
        "mec": "magenta",
        "zorder": 6,
    },
    "separators": {"color": "grey", "ls": ":", "lw": 0.7},
    "legend": {"fontsize": 8},
}


def bounds(
    partition: Any,
    values: Any,
    lower: Any = None,
    upper: Any = None,
    *,
    states: Any = None,
    partitions: Any = None,
    order: str = "min",
    within: str = "value",
    layout: str = "states",
    brackets: bool | str = "auto",
    ax: Any = None,
    **style: Any,
) -> Axes:
    r"""``V*`` of every state against the lower and upper bound of its partition.

    The paper's Figures 4-5 for any model: ``V*(x)`` of each state as a dot, the states
    grouped by partition; each partition's lower and upper bound as a step over its states;
    ``min V*`` over each partition as a green segment drawn above the dots (Theorem 3's
    lower bound ``w*(i) <= min_{x in S_i} V*(x)`` is judged against it). States whose
    ``V*`` lies outside a bound are circled (legend: "outside the bounds").

    Parameters
    ----------
    partition : Partition or array_like of int, shape (n,)
        The partition (or its labels, ``labels[x] = i`` for ``x`` in ``S_i``).
    values : array_like, shape (n,), or a result
        ``V*`` per state, or a result whose ``values`` are (a
        :class:`~lpbounds.dp.DPResult`; its certified bracket ``lower_values <= V* <=
        upper_values`` is drawn with ``values_bracket``).
    lower, upper : array_like or a result, optional
        The bounds, per partition (length ``M``) or per state (length ``n``; when ``n ==
        M`` a vector is read per partition). A result is drawn at its certified end:
        ``lower.lower_values`` (LBLP, NLP: ``<= min_{x in S_i} V*(x)``) and
        ``upper.upper_values`` (RLP, UBLP: ``partition.lift(upper_values) >= V*``), with
        its bracket ``[lower_values, upper_values]``.
    states : array_like of int, optional
        The states to plot (default all); their order is kept with ``within="given"``.
    partitions : array_like of int, optional
        The partitions to plot, in this order (default: those of the plotted states, in
        the order ``order``). Each must have a plotted state.
    order : {"min", "lower", "upper", "index"}
        Order of the partitions when ``partitions`` is not given: by ``min V*`` over the
        plotted states, by the lower bound, by the upper bound, or by index.
    within : {"value", "given"}
        Order of the states inside a partition: by ``V*``, or as given.
    layout : {"states", "partitions"}
        ``"states"``: each state at its own x (0, 1, ...), partitions side by side with
        dotted separators. ``"partitions"``: partition ``k`` of the plotting order at
        ``x = k + 1`` with all its states stacked there, the bounds as steps through
        the partitions (a per-state lower bound is reduced to its minimum over the
        partition's plotted states, an upper bound to its maximum).
    brackets : bool or "auto"
        Draw the certified brackets of the results given; ``"auto"`` draws those whose
        widest entry is at least :data:`BRACKET_DRAW_FRACTION` of the plotted range and
        writes the width of the others in the legend.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    **style : dict or None
        Per element (see the module docstring): ``dots``, ``lower_line``, ``upper_line``,
        ``min_line``, ``values_bracket``, ``lower_bracket``, ``upper_bracket``,
        ``outside``, ``separators``, ``legend``.

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    ValidationError
        An array of the wrong length (naming the argument), a result without a certified
        bracket given as a bound, a state or partition index out of range or repeated, an
        unknown option or style element.

    Examples
    --------
    >>> import lpbounds as lb
    >>> from lpbounds import plot
    >>> from lpbounds.formulations import RLP
    >>> from lpbounds.formulations.nlp.problem import NLP
    >>> mdp = lb.garnet(40, 3, 3, 0.9, seed=1)
    >>> part = lb.random_partition(40, 5, seed=2)
    >>> ax = plot.bounds(
    ...     part, lb.solve_exact(mdp), NLP(mdp, part).solve(), RLP(mdp, part).solve()
    ... )
    """
    st = _styles(_BOUNDS_STYLE, style)
    check_choice("order", order, ("min", "lower", "upper", "index"))
    check_choice("within", within, ("value", "given"))
    check_choice("layout", layout, ("states", "partitions"))
    if brackets not in (True, False, "auto"):
        raise ValidationError(f"brackets must be True, False or 'auto'; got {brackets!r}")
    part = _as_partition(partition)
    vals = _read_values(values, part.n_states)
    lo = _read_bound("lower", lower, part, "lower")
    up = _read_bound("upper", upper, part, "upper")
    parts, shown = _select(part, vals.y, lo, up, states, partitions, order)
    g = _group(part, vals.y, parts, shown, within, layout)
    ax = _axes(ax, (9.0, 4.4))
    span = _span(vals.y[g.states], *(s.y for s in (lo, up) if s is not None))

    def show(series: _Series) -> bool:
        if series.bracket is None or brackets is False:
            return False
        return brackets is True or series.width() >= BRACKET_DRAW_FRACTION * span

    _draw_values(ax, g, vals, part, layout, show(vals), st)
    for series, side, how in ((up, "upper", "max"), (lo, "lower", "min")):
        if series is not None:
            _draw_bound(ax, g, series, part, side, how, layout, show(series), st)
    if st["min_line"] is not None:
        ax.plot(*_min_line(g, vals.y, layout), **st["min_line"])
    bad = _outside(g, vals, lo, up, part)
    if bad.size and st["outside"] is not None:
        kw = {"label": f"outside the bounds ({bad.size} states)", **st["outside"]}
        ax.plot(g.x[bad], vals.y[g.states[bad]], **kw)
    _decorate(ax, g, layout, order if partitions is None else "given", st)
    _legend(ax, st)
    return ax


def _draw_values(
    ax: Axes, g: _Groups, vals: _Series, part: Partition, layout: str, bracket: bool, st: Style
) -> None:
    """The dots of ``V*`` and, if drawn, their certified bracket (else its width in the
    dots' legend entry)."""
    if st["dots"] is not None:
        kw = dict(st["dots"])
        if vals.bracket is not None and not bracket:
            kw["label"] = f"{kw.get('label', '')} (certified within ±{_num(vals.width() / 2)})"
        ax.plot(g.x, vals.y[g.states], **kw)
    if vals.bracket is not None and bracket and st["values_bracket"] is not None:
        label = f"certified bracket on V*(x) (width ≤ {_num(vals.width())})"
        _draw_bracket(
            ax, *_bracket_at(g, vals, part, layout), {"label": label, **st["values_bracket"]}
        )


def _span(*arrays: np.ndarray) -> float:
    """The range of the finite plotted values (a flat plot's: its magnitude, at least 1)."""
    finite = [a[np.isfinite(a)] for a in arrays if a.size]
    allv = np.concatenate(finite) if finite else np.zeros(1)
    if allv.size == 0:
        return 1.0
    span = float(allv.max() - allv.min())
    return span if span > 0 else max(1.0, float(np.abs(allv).max()))


def _draw_bound(
    ax: Axes,
    g: _Groups,
    series: _Series,
    part: Partition,
    side: str,
    how: str,
    layout: str,
    bracket: bool,
    st: Style,
) -> None:
    """One bound's steps and, if drawn, its certified bracket (labels name the source)."""
    line = st[f"{side}_line"]
    if line is not None:
        kw = dict(line)
        if series.source is not None:
            note = f"{series.source}, certified"
            if series.bracket is not None and not bracket:
                note += f"; bracket width ≤ {_num(series.width())}"
            kw["label"] = f"{kw.get('label', side + ' bound')} ({note})"
        if layout == "partitions":
            kw.setdefault("drawstyle", "steps-mid")
        ax.plot(*_bound_line(g, series, part, how, layout), **kw)
    box = st[f"{side}_bracket"]
    if bracket and box is not None:
        label = f"certified bracket on the {series.source} optimum (width ≤ {_num(series.width())})"
        _draw_bracket(ax, *_bracket_at(g, series, part, layout), {"label": label, **box})


def _decorate(ax: Axes, g: _Groups, layout: str, order: str, st: Style) -> None:
    """Axis labels, partition separators (``states``) or partition ticks (``partitions``)."""
    ordered = {
        "min": "ordered by min V*",
        "lower": "ordered by the lower bound",
        "upper": "ordered by the upper bound",
        "index": "ordered by index",
        "given": "in the order given",
    }[order]
    if layout == "states":
        if st["separators"] is not None:
            for s0 in g.start[1:]:
                ax.axvline(g.x[s0] - 0.5, **st["separators"])
        ax.set_xlabel(f"states, grouped by partition ({g.parts.size} partitions, {ordered})")
    else:
        step = max(1, g.parts.size // 12)
        ax.set_xticks(g.centre[::step], [str(int(p)) for p in g.parts[::step]])
        ax.set_xlabel(f"partition ({ordered})")
    ax.set_ylabel("value")


# ---------------------------------------------------------------------- gap
_GAP_STYLE: dict[str, dict[str, Any]] = {
    "gap_line": {
        "color": "tab:red",
        "lw": 1.2,
        "drawstyle": "steps-mid",
        "zorder": 2,
        "label": "gap: upper - lower",
    },
    "gap_fill": {"color": "tab:red", "alpha": 0.15, "lw": 0, "step": "mid", "zorder": 1},
    "spread": {
        "marker": "o",
        "ls": "none",
        "ms": 3,
        "color": "tab:blue",
        "zorder": 3,
        "label": "spread of V* in the partition: max - min",
    },
    "legend": {"fontsize": 8},
}


def gap(
    partition: Any,
    lower: Any,
    upper: Any,
    *,
    values: Any = None,
    order: str = "gap",
    ax: Any = None,
    **style: Any,
) -> Axes:
    r"""The gap ``upper - lower`` per partition, optionally against the spread of ``V*``.

    A partition's gap is the width of the interval its bounds give every one of its
    states; the spread ``max_{x in S_i} V*(x) - min_{x in S_i} V*(x)`` is the part of it
    that no bound constant on the partition could close (valid bounds make ``spread <=
    gap``). Bounds given as results are read at their certified ends (``lower.lower_values``,
    ``upper.upper_values``), and the gap is rounded up, so it is a certified width.

    Parameters
    ----------
    partition : Partition or array_like of int, shape (n,)
        The partition (or its labels).
    lower, upper : array_like or a result
        The bounds, per partition (length ``M``) or per state (length ``n``, reduced per
        partition by the minimum for ``lower`` and the maximum for ``upper``; when ``n ==
        M`` a vector is read per partition), as in :func:`bounds`.
    values : array_like, shape (n,), or a result, optional
        ``V*`` per state: its spread inside each partition is drawn as dots.
    order : {"gap", "index", "min"}
        Partitions from the widest gap to the narrowest, by index, or by ``min V*``
        (needs ``values``).
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    **style : dict or None
        Per element: ``gap_line``, ``gap_fill``, ``spread``, ``legend``.

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    ValidationError
        An array of the wrong length (naming the argument), a result without a certified
        bracket, ``order="min"`` without ``values``, an unknown option or style element.

    Examples
    --------
    >>> import lpbounds as lb
    >>> from lpbounds import plot
    >>> from lpbounds.formulations import RLP
    >>> from lpbounds.formulations.nlp.problem import NLP
    >>> mdp = lb.garnet(40, 3, 3, 0.9, seed=1)
    >>> part = lb.random_partition(40, 5, seed=2)
    >>> lower, upper = NLP(mdp, part).solve(), RLP(mdp, part).solve()
    >>> ax = plot.gap(part, lower, upper, values=lb.solve_exact(mdp))
    """
    st = _styles(_GAP_STYLE, style)
    check_choice("order", order, ("gap", "index", "min"))
    part = _as_partition(partition)
    lo = _read_bound("lower", lower, part, "lower")
    up = _read_bound("upper", upper, part, "upper")
    if lo is None or up is None:
        raise ValidationError(f"{'lower' if lo is None else 'upper'} is required; got None")
    widths = np.nextafter(_per_partition(up, part, "max") - _per_partition(lo, part, "min"), np.inf)
    spread = None
    if values is not None:
        v = _read_values(values, part.n_states).y
        vmin = part.aggregate(v, "min")
        spread = part.aggregate(v, "max") - vmin
    if order == "gap":
        idx = np.argsort(-widths, kind="stable")
    elif order == "index":
        idx = np.arange(part.n_partitions)
    else:
        if values is None:
            raise ValidationError("order = 'min' needs values (V* per state); it is None")
        idx = np.argsort(vmin, kind="stable")
    ax = _axes(ax, (8.0, 4.0))
    x = np.arange(1, idx.size + 1, dtype=np.float64)
    if st["gap_fill"] is not None:
        ax.fill_between(x, 0.0, widths[idx], **st["gap_fill"])
    if st["gap_line"] is not None:
        kw = dict(st["gap_line"])
        kw["label"] = f"{kw.get('label', 'gap')} (largest {_num(float(widths.max()))})"
        ax.plot(x, widths[idx], **kw)
    if spread is not None and st["spread"] is not None:
        ax.plot(x, spread[idx], **st["spread"])
    ordered = {"gap": "widest gap first", "index": "by index", "min": "ordered by min V*"}
    ax.set_xlabel(f"partition ({part.n_partitions}, {ordered[order]})")
    ax.set_ylabel("width")
    _legend(ax, st)
    return ax


# ---------------------------------------------------------------------- NLP bracket
_NLP_STYLE: dict[str, dict[str, Any]] = {
    "lower_line": {"color": "tab:green", "marker": ".", "lw": 1.2, "label": None},
    "upper_line": {"color": "tab:orange", "marker": ".", "lw": 1.2, "label": None},
    "bracket": {"fmt": "none", "ecolor": "black", "capsize": 5, "elinewidth": 1.5, "zorder": 5},
    "reference_line": {"color": "tab:red", "ls": "--", "lw": 1.2},
    "exact_line": {"color": "tab:blue", "ls": ":", "lw": 1.2},
    "legend": {"fontsize": 8},
}


def nlp_bracket(
    nlp_result: Any,
    *,
    reference: Any = None,
    exact: float | None = None,
    ax: Any = None,
    **style: Any,
) -> Axes:
    r"""The NLP's bracket on ``c'w*`` round by round, and its certified final bracket.

    Draws the method's own lower and upper bound on ``c'w*`` per round from
    ``nlp_result.log`` (for the cutting planes: the master LP's weak-duality bound, and
    the best strategy's exact value; the master's bound is not rounding-certified, see
    :class:`~lpbounds.formulations.nlp.results.NLPResult`), then, one step to the right of
    the last round, the certified bracket ``[lower_bound, upper_bound]`` computed from the
    returned point alone.

    Parameters
    ----------
    nlp_result : NLPResult
        From :meth:`NLP.solve <lpbounds.formulations.nlp.problem.NLP.solve>`.
    reference : LPResult or float, optional
        An upper bound to compare with, typically the RLP of the same model, partition and
        cost: drawn at its certified objective's upper end (``objective_bracket[1]``,
        ``>= c'v* >= c'w*``). Its cost is checked to be the NLP's (``nlp_result.cost @
        reference.values == reference.objective``).
    exact : float, optional
        ``c'w*`` if known (strategy iteration), drawn as a dotted line.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    **style : dict or None
        Per element: ``lower_line``, ``upper_line``, ``bracket``, ``reference_line``,
        ``exact_line``, ``legend``.

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    ValidationError
        ``nlp_result`` without a log or a certified bracket; a ``reference`` without a
        certified objective or for another cost; an unknown style element.

    Examples
    --------
    >>> import lpbounds as lb
    >>> from lpbounds import plot
    >>> from lpbounds.formulations import RLP
    >>> from lpbounds.formulations.nlp.problem import NLP
    >>> mdp = lb.garnet(40, 3, 3, 0.9, seed=1)
    >>> part = lb.random_partition(40, 5, seed=2)
    >>> res = NLP(mdp, part).solve("cutting-planes", max_iter=30)
    >>> ax = plot.nlp_bracket(res, reference=RLP(mdp, part).solve())
    """
    st = _styles(_NLP_STYLE, style)
    log = getattr(nlp_result, "log", None)
    lo_b, hi_b = getattr(nlp_result, "lower_bound", None), getattr(nlp_result, "upper_bound", None)
    if log is None or lo_b is None or hi_b is None:
        raise ValidationError(
            f"nlp_result must be an NLPResult (a log and a certified bracket); got "
            f"{describe_value(nlp_result)}"
        )
    ax = _axes(ax, (8.0, 4.2))
    method = str(getattr(nlp_result, "method", "NLP"))
    rounds = np.array([float(e.iteration) for e in log])
    for key, attr, text in (
        ("lower_line", "lower", f"lower bound per round ({method})"),
        ("upper_line", "upper", f"upper bound per round ({method})"),
    ):
        y = np.array([float(getattr(e, attr)) for e in log])
        ok = np.isfinite(y)
        line = st[key]
        if line is not None and ok.any():
            kw = dict(line)
            kw["label"] = kw.get("label") or text
            ax.plot(rounds[ok], y[ok], **kw)
    last = float(rounds.max()) + 1.0 if rounds.size else 1.0
    if st["bracket"] is not None:
        label = (
            f"certified bracket on c'w*: [{float(lo_b):.8g}, {float(hi_b):.8g}] "
            f"(width {_num(float(hi_b) - float(lo_b))})"
        )
        _draw_bracket(
            ax,
            np.array([last]),
            np.array([lo_b]),
            np.array([hi_b]),
            {"label": label, **st["bracket"]},
        )
    if reference is not None and st["reference_line"] is not None:
        value, text = _reference(reference, nlp_result)
        ax.axhline(value, **{"label": text, **st["reference_line"]})
    if exact is not None and st["exact_line"] is not None:
        ax.axhline(
            float(exact), **{"label": f"exact c'w* = {float(exact):.8g}", **st["exact_line"]}
        )
    ax.set_xlabel("round (the certified bracket one step after the last)")
    ax.set_ylabel("c'w (cost-weighted partition values)")
    _legend(ax, st)
    return ax


def _reference(reference: Any, nlp_result: Any) -> tuple[float, str]:
    """(height, legend text) of the reference upper bound of :func:`nlp_bracket`."""
    if isinstance(reference, (int, float, np.floating, np.integer)) and not isinstance(
        reference, bool
    ):
        return float(reference), f"reference: {float(reference):.8g}"
    bracket = getattr(reference, "objective_bracket", None)
    name = _name(reference)
    if bracket is None:
        raise ValidationError(
            f"reference: the {name} result has no certified objective bracket "
            "(objective_bracket is None), so it bounds nothing"
        )
    cost = np.asarray(getattr(nlp_result, "cost", []), dtype=np.float64)
    v = np.asarray(getattr(reference, "values", []), dtype=np.float64)
    obj = float(getattr(reference, "objective", np.nan))
    if v.shape != cost.shape:
        raise ValidationError(
            f"reference: its values have shape {v.shape}, the NLP's cost {cost.shape}: "
            "compare results of the same partition"
        )
    scale = float(np.abs(cost) @ np.abs(v)) + abs(obj)
    if not abs(float(cost @ v) - obj) <= PLOT_COST_MATCH_RTOL * max(1.0, scale):
        raise ValidationError(
            f"reference: its objective {obj:.8g} is not the NLP's cost times its values "
            f"({float(cost @ v):.8g}): it was solved for another cost, so the two do not compare"
        )
    hi = float(bracket[1])
    return hi, f"{name}: c'v* ≤ {hi:.8g} (certified upper end)"


# ---------------------------------------------------------------------- DP residuals
_DP_STYLE: dict[str, dict[str, Any]] = {
    "residual_line": {"color": "tab:blue", "marker": ".", "lw": 1.2, "label": None},
    "tolerance_line": {"color": "tab:red", "ls": "--", "lw": 1.2},
    "final": {"marker": "*", "ls": "none", "ms": 11, "color": "tab:green", "zorder": 5},
    "legend": {"fontsize": 8, "loc": "upper right"},
}


def _legend_headroom(ax: Axes, values: np.ndarray, style: Style) -> None:
    """A log y-axis whose top band holds the legend and no data.

    The legend's labels are long (a residual, a tolerance, an error bound), so on an axes
    of the usual width no corner is free of the residual line, the tolerance line and the
    final star ("best" put it over the tolerance line). The y-axis is extended upward by
    the legend's height (estimated from its entries and font size, in points, against the
    axes' height), so an upper legend covers nothing drawn.
    """
    kw = style.get("legend")
    n = len(ax.get_legend_handles_labels()[0])
    if kw is None or n == 0 or values.size == 0:
        return
    from matplotlib.font_manager import FontProperties

    size = FontProperties(size=kw.get("fontsize")).get_size_in_points()
    box = float(ax.bbox.height) / float(ax.figure.dpi) * 72.0  # axes height (pt)
    band = min(0.6, ((1.5 * n + 2.0) * size) / box + 0.03)  # legend + padding, a fraction
    lo, hi = np.log10(values.min()), np.log10(values.max())
    span = max(hi - lo, 1.0)
    bottom = lo - 0.05 * span
    top = bottom + (hi - bottom) / (1.0 - band)
    ax.set_ylim(10.0**bottom, 10.0**top)


def dp_residuals(dp_result: Any, *, ax: Any = None, **style: Any) -> Axes:
    r"""The Bellman residual ``||T V - V||_inf`` per improvement sweep, on a log scale.

    From ``dp_result.history`` (one residual per improvement sweep, the first at sweep
    0), with the stopping tolerance ``dp_result.tol`` as a dashed line and the residual
    measured on the returned values (``dp_result.residual``, which gives the certified
    ``error_bound``) as a star after the last sweep. Residuals of exactly 0 have no place
    on a log scale: they are left out and counted in the legend. The legend sits in a band
    at the top of the axes, above every point and line drawn (the y-axis is extended for
    it), so it never covers the tolerance line.

    Parameters
    ----------
    dp_result : DPResult
        From :func:`lpbounds.solve_exact` (any object with a ``history`` list).
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    **style : dict or None
        Per element: ``residual_line``, ``tolerance_line``, ``final``, ``legend``.

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    ValidationError
        ``dp_result`` without a ``history``; an unknown style element.

    Examples
    --------
    >>> import lpbounds as lb
    >>> from lpbounds import plot
    >>> ax = plot.dp_residuals(lb.solve_exact(lb.garnet(40, 3, 3, 0.9, seed=1), "vi"))
    """
    st = _styles(_DP_STYLE, style)
    history = getattr(dp_result, "history", None)
    if history is None:
        raise ValidationError(
            f"dp_result must be a DPResult (with a history of residuals); got "
            f"{describe_value(dp_result)}"
        )
    h = as_float_array("dp_result.history", list(history), finite=False)
    ax = _axes(ax, (7.0, 4.0))
    sweeps = np.arange(h.size, dtype=np.float64)
    pos = h > 0
    method = str(getattr(dp_result, "method", "DP"))
    if st["residual_line"] is not None and pos.any():
        kw = dict(st["residual_line"])
        text = f"residual per improvement sweep ({method})"
        if (~pos).any():
            text += f"; {int((~pos).sum())} of exactly 0 not shown"
        kw["label"] = kw.get("label") or text
        ax.plot(sweeps[pos], h[pos], **kw)
    tol = getattr(dp_result, "tol", None)
    if tol is not None and np.isfinite(tol) and tol > 0 and st["tolerance_line"] is not None:
        ax.axhline(
            float(tol),
            **{"label": f"stopping tolerance {_num(float(tol))}", **st["tolerance_line"]},
        )
    res = getattr(dp_result, "residual", None)
    if res is not None and float(res) > 0 and st["final"] is not None:
        text = f"residual of the returned values {_num(float(res))}"
        eb = getattr(dp_result, "error_bound", None)
        if eb is not None:
            text += f" (error bound {_num(float(eb))})"
        ax.plot([float(h.size)], [float(res)], **{"label": text, **st["final"]})
    ax.set_yscale("log")
    ax.set_xlabel("improvement sweep")
    ax.set_ylabel("||T V - V||_inf")
    drawn = [h[pos]]
    if tol is not None and np.isfinite(tol) and tol > 0 and st["tolerance_line"] is not None:
        drawn.append(np.array([float(tol)]))
    if res is not None and float(res) > 0 and st["final"] is not None:
        drawn.append(np.array([float(res)]))
    _legend_headroom(ax, np.concatenate(drawn), st)
    _legend(ax, st)
    return ax
