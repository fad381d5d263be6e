r"""Dolan-Moré performance profiles and shifted geometric means: pure functions on a table.

The two summaries LP solver benchmarks publish (Dolan and Moré, *Benchmarking
optimization software with performance profiles*, Math. Program. 91, 2002; H. Mittelmann's
benchmarks of optimization software, which use shifted geometric means with a shift of
10 s).

A *measure table* has one row per problem and one column per solver, with a positive
cost (time, error, ...) where the solver solved the problem, and ``inf`` (or NaN) where it
did not. Then, for problem :math:`p` and solver :math:`s`,

.. math::

    r_{p,s} = \frac{t_{p,s}}{\min_{s'} t_{p,s'}}, \qquad
    \rho_s(\tau) = \frac{|\{p : r_{p,s} \le \tau\}|}{n_p},

with :math:`r_{p,s} = \infty` when :math:`s` failed on :math:`p` (and for every solver
when all of them failed: such a problem counts as unsolved for everyone).
:math:`\rho_s(1)` is the fraction of problems on which :math:`s` was (one of) the best;
:math:`\lim_{\tau \to \infty} \rho_s(\tau)` is the fraction it solved.

The shifted geometric mean of :math:`t_1, \dots, t_n` with shift :math:`\sigma` is
:math:`\left(\prod_i (t_i + \sigma)\right)^{1/n} - \sigma`: the shift keeps the many
small times from dominating the mean (a 0.01 s against 0.02 s solve is not "twice as
slow" in a study whose solves take minutes). Choose :math:`\sigma` near the time scale
below which differences do not matter: 10 s for Mittelmann's instances, which take
minutes; 0.01 s suits studies of sub-second solves.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ValidationError

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = [
    "coinciding_profiles",
    "new_figure",
    "performance_profile",
    "performance_ratios",
    "plot_performance_profile",
    "profile_value",
    "shifted_geometric_mean",
]


def shifted_geometric_mean(values: Iterable[float], shift: float = 10.0) -> float:
    r""":math:`\left(\prod_i (t_i + \sigma)\right)^{1/n} - \sigma`.

    Parameters
    ----------
    values : iterable of float
        Nonnegative finite values (charge a failure what the study decides, e.g. the
        time limit, before calling).
    shift : float
        :math:`\sigma \ge 0` (default 10, Mittelmann's shift in seconds); with
        ``shift = 0`` every value must be positive (the plain geometric mean).

    Returns
    -------
    float
        NaN for no values.

    Raises
    ------
    ValidationError
        A negative or non-finite value or shift, or a zero value with ``shift = 0``.
    """
    if isinstance(shift, bool) or not isinstance(shift, (int, float, np.integer, np.floating)):
        raise ValidationError(f"shift must be a number >= 0; got {shift!r}")
    if not (math.isfinite(shift) and shift >= 0):
        raise ValidationError(f"shift must be a finite number >= 0; got {shift!r}")
    t = np.asarray(list(values), dtype=np.float64)
    if t.size == 0:
        return float("nan")
    bad = np.flatnonzero(~np.isfinite(t) | (t < 0))
    if bad.size:
        raise ValidationError(
            f"values must be finite and >= 0; entry {int(bad[0])} is {t[bad[0]]!r}"
        )
    if shift == 0 and (t == 0).any():
        raise ValidationError(
            f"with shift 0 every value must be positive; entry {int(np.argmin(t))} is 0"
        )
    return float(np.exp(np.mean(np.log(t + shift))) - shift)


def _measures(table: pd.DataFrame) -> np.ndarray:
    """The table's values as floats, NaN read as ``inf`` (a failure), checked positive."""
    import pandas as pd

    if not isinstance(table, pd.DataFrame):
        raise ValidationError(
            f"table must be a pandas DataFrame (problems x solvers); got {type(table).__name__}"
        )
    if table.shape[1] == 0:
        raise ValidationError("table has no solver column")
    try:
        t = table.to_numpy(dtype=np.float64, na_value=np.inf)
    except (TypeError, ValueError) as exc:
        raise ValidationError(f"table must hold numbers: {exc}") from exc
    t = np.where(np.isnan(t), np.inf, t)
    bad = np.argwhere(t <= 0)
    if bad.size:
        i, j = (int(k) for k in bad[0])
        raise ValidationError(
            f"table entries must be > 0 (or inf for a failure); problem {table.index[i]!r}, "
            f"solver {table.columns[j]!r} has {t[i, j]!r}: floor measures at a positive "
            "resolution first"
        )
    return t


def performance_ratios(table: pd.DataFrame) -> pd.DataFrame:
    """:math:`r_{p,s} = t_{p,s} / \\min_{s'} t_{p,s'}`, ``inf`` for failures.

    Parameters
    ----------
    table : pandas.DataFrame
        Problems (rows) x solvers (columns): positive measures, ``inf`` or NaN for a
        failure.

    Returns
    -------
    pandas.DataFrame
        Same shape; a problem no solver solved has ``inf`` everywhere.
    """
    import pandas as pd

    t = _measures(table)
    best = t.min(axis=1, keepdims=True)
    with np.errstate(invalid="ignore"):
        r = np.where(np.isfinite(best), t / np.where(np.isfinite(best), best, 1.0), np.inf)
    return pd.DataFrame(r, index=table.index, columns=table.columns)


def profile_value(ratios: pd.DataFrame, tau: float) -> pd.Series:
    """:math:`\\rho_s(\\tau)` for every solver: the fraction of problems with ratio ``<= tau``."""
    r = ratios.to_numpy(dtype=np.float64)
    n = r.shape[0]
    frac = (r <= tau).sum(axis=0) / n if n else np.full(r.shape[1], np.nan)
    import pandas as pd

    return pd.Series(frac, index=ratios.columns, name=tau)


def performance_profile(table: pd.DataFrame, taus: Sequence[float] | None = None) -> pd.DataFrame:
    """Dolan-Moré profile :math:`\\rho_s(\\tau)` of a measure table.

    Parameters
    ----------
    table : pandas.DataFrame
        Problems x solvers, positive measures, ``inf``/NaN for failures.
    taus : sequence of float, optional
        Where to evaluate; default: every distinct finite ratio (the profile's
        breakpoints: it is a right-continuous step function, constant between them).

    Returns
    -------
    pandas.DataFrame
        Index ``tau`` (ascending), one column per solver, values in ``[0, 1]``.
    """
    import pandas as pd

    ratios = performance_ratios(table)
    if taus is None:
        r = ratios.to_numpy()
        taus = sorted(set(r[np.isfinite(r)].tolist()) | {1.0})
    rows = [profile_value(ratios, float(tau)) for tau in taus]
    out = pd.DataFrame(rows, index=pd.Index([float(t) for t in taus], name="tau"))
    out.columns = ratios.columns
    return out


def coinciding_profiles(prof: pd.DataFrame) -> dict[str, list[str]]:
    """Solvers whose profile curves are the same step function, by first member.

    Two columns of :func:`performance_profile` coincide when they are equal at every
    breakpoint (the profile is constant between breakpoints): drawn one over the other,
    only the last would show. Returns ``{first: [others, ...]}`` for each group of two or
    more, in the columns' order.
    """
    groups: dict[str, list[str]] = {}
    seen: dict[bytes, str] = {}
    for col in prof.columns:
        key = np.asarray(prof[col], dtype=np.float64).tobytes()
        if key in seen:
            groups.setdefault(seen[key], []).append(str(col))
        else:
            seen[key] = str(col)
    return groups


#: dash patterns of the second, third, ... of coinciding curves (the first is solid and
#: widest, each next one narrower and dashed over it: every colour shows along the curve)
_COINCIDE_DASHES = [(0, (4.0, 3.0)), (2, (2.0, 4.0)), (0, (1.0, 2.0))]


def _wrap(label: str, width: int = 48) -> str:
    """A legend label on lines of at most ``width`` characters (the legend sits beside the
    axes: one long label would squeeze them)."""
    import textwrap

    return "\n".join(textwrap.wrap(label, width)) or label


def plot_performance_profile(
    table: pd.DataFrame,
    path: str | Path,
    *,
    title: str,
    measure: str,
    labels: dict[str, str] | None = None,
) -> Path:
    """Save the step plot of :func:`performance_profile` (log2 ``tau`` axis) as a PNG.

    Each curve ends at the fraction of problems its solver solved; a solver that solved
    nothing lies on zero (drawn, not dropped). ``labels`` maps column names to legend
    text (for example with the backend). Curves that coincide
    (:func:`coinciding_profiles`: SCIPY is HiGHS inside, and often gives HIGHS's own
    curve) are drawn as stacked lines, the first widest and solid, the others narrower
    and dashed on top of it, so that each one shows; their legend entries say which
    curve they share.
    """
    prof = performance_profile(table)
    ratios = performance_ratios(table).to_numpy()
    finite = ratios[np.isfinite(ratios)]
    top = max(2.0, float(finite.max()) * 2.0 if finite.size else 2.0)
    taus = np.concatenate([prof.index.to_numpy(), [top]])
    fig = new_figure((9.5, 4.5))
    ax = fig.subplots()
    styles = ["-", "--", "-.", ":"]
    same = coinciding_profiles(prof)
    member = {o: (first, k + 1) for first, others in same.items() for k, o in enumerate(others)}
    name = {str(c): (labels or {}).get(str(c), str(c)) for c in prof.columns}
    for k, col in enumerate(prof.columns):
        col = str(col)
        y = np.concatenate([prof[col].to_numpy(), [prof[col].to_numpy()[-1]]])
        label, lw = name[col], 1.6
        ls: Any = styles[(k // 10) % 4]  # a name, or an (offset, dashes) pattern below
        if col in same:  # the first of coinciding curves: widest, under the others
            lw = 1.6 + 1.6 * len(same[col])
            label += f" (same curve as {', '.join(same[col])})"
        elif col in member:
            first, j = member[col]
            ls = _COINCIDE_DASHES[min(j, len(_COINCIDE_DASHES)) - 1]
            lw = max(1.2, 1.6 + 1.6 * (len(same[first]) - j))
            label += f" (same curve as {first})"
        ax.step(taus, y, where="post", label=_wrap(label), ls=ls, lw=lw)
    ax.set_xscale("log", base=2)
    ax.set(
        xlim=(1.0, top),
        ylim=(-0.02, 1.02),
        xlabel=f"tau: within this factor of the best {measure}",
        ylabel="fraction of problems",
    )
    ax.set_title(title, loc="left")  # from the axes' left edge: never cut off on the left
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False)
    fig.text(
        0.01,
        0.01,
        f"{table.shape[0]} problems; failures count as unsolved (ratio inf)",
        fontsize=7,
        color="0.35",
    )
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=100)
    return path


def new_figure(size: tuple[float, float]) -> Figure:
    """A matplotlib figure drawn by the Agg canvas, outside pyplot: no backend is selected
    and no pyplot state is touched, so a notebook's or a script's backend stays as it was
    (and the figure needs no ``plt.close``: it is freed with its last reference).

    Parameters
    ----------
    size : (float, float)
        Width and height in inches.

    Returns
    -------
    matplotlib.figure.Figure
        With a :class:`~matplotlib.backends.backend_agg.FigureCanvasAgg`; ``savefig``
        writes PNG files.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig
