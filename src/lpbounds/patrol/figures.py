r"""Figures 2-7 of the paper (Sections 4-6) as PNG files.

Numbering follows the paper's LaTeX source (Figure 1 is the scenario sketch):

* Figure 2 (``fig:info``): information gain ``I(d)`` against the dwell ``d``;
* Figure 3 (``fig:MonoVal``): ``V*`` along chains of partially ordered states: every
  station has an alert (``A_j = 1``), ``d = 0``, ``w = +1``, the UAV at a station, the
  delays raised one station at a time from ``(2, 1, .., 1)`` to ``(Gamma, .., Gamma)``
  (:func:`ordered_delays`), so ``taubar = 2..Gamma``; dotted lines separate the partitions;
* Figure 4 (``fig:MonoValPart``): ``V*`` of every state and ``min V*`` (green) of the
  partitions ``A = 1 0 ... 0 1`` (first and last station alerted), ``d = 0``, ``w = +1``,
  ``l`` = the first station, ``taubar = 2..Gamma``;
* Figure 5 (``fig:BNDs_OPT``): ``V_up = Phi v*``, ``V_low = Phi w*`` and ``V*`` on the
  ``2N`` partitions of eq. (32)-(33) (``d = 0``, ``taubar = 2``, all ``A_j = 1``;
  clockwise ``l = 0..N-1``, then counter-clockwise);
* Figure 6 (``fig:BNDs_SUBOPT``): ``V_sub`` against ``V*`` on the clockwise states of (32);
* Figure 7 (``fig:perfcomp``): histograms of the service delay and of the loiters per
  serviced alert under ``pi*`` and ``pi_s``.

The ``select_*`` functions return the plotted data (so tests can check it against an
independent selection); the ``plot_*`` functions write one PNG each. Figures 4 and 5 are
drawn by :func:`lpbounds.plot.bounds`, the same plot for any model.

Figures are built with matplotlib's object API (:func:`subplots`: a
:class:`~matplotlib.figure.Figure` on an Agg canvas), never through pyplot, so importing
this module or drawing a figure leaves the session's backend as it was (a notebook keeps
its own); matplotlib itself is imported when a figure is drawn.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from .. import plot
from ..model.partition import Partition
from ..tolerances import FIGURE_MONOTONE_RTOL

__all__ = [
    "ordered_delays",
    "plot_bounds",
    "plot_histograms",
    "plot_information",
    "plot_min_value_partitions",
    "plot_ordered_states",
    "plot_vsub",
    "save_figure",
    "select_bounds_partitions",
    "select_min_value_partitions",
    "select_ordered_states",
    "subplots",
]

_DPI = 130


def subplots(nrows: int = 1, ncols: int = 1, **kwargs: Any) -> tuple[Any, Any]:
    """A new figure on an Agg canvas and its axes, as :func:`matplotlib.pyplot.subplots`
    returns them, without pyplot (no backend is selected or changed).

    Parameters
    ----------
    nrows, ncols : int
        The grid of axes.
    **kwargs
        ``figsize``, ``dpi`` and ``layout`` go to the figure; the rest (``sharex``,
        ``gridspec_kw``, ...) to :meth:`matplotlib.figure.Figure.subplots`.

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : matplotlib.axes.Axes or array of Axes
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(**{k: kwargs.pop(k) for k in ("figsize", "dpi", "layout") if k in kwargs})
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, **kwargs)


def save_figure(fig: Any, path: str | Path) -> Path:
    """Write ``fig`` as a PNG at ``path`` (parents created) and close it.

    The one way every figure of the patrol (here and :mod:`lpbounds.patrol.beyond`) is
    written, at the same resolution.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or pathlib.Path
        Where to write it.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=_DPI)
    pyplot = sys.modules.get("matplotlib.pyplot")
    if pyplot is not None:  # a figure pyplot made is released; ours are not registered
        pyplot.close(fig)
    return p


# ---------------------------------------------------------------------- Figure 2
def plot_information(params: Any, path: str | Path) -> Path:
    """Figure 2: ``I(d)`` (nats) for ``0 <= d <= D + 1``, with the integer dwells marked."""
    d = np.linspace(0.0, params.D + 1, 200)
    di = np.arange(params.D + 1)
    fig, ax = subplots(figsize=(6.4, 4.0))
    ax.plot(d, params.information(d), color="tab:blue", label=r"$\mathcal{I}(d)$")
    ax.plot(
        di,
        params.information(di),
        "o",
        color="tab:orange",
        zorder=3,
        label=f"d = 0..D (D = {params.D})",
    )
    ax.set_xlabel("dwell time d (loiters)")
    ax.set_ylabel("information gain I(d) [nats]")
    ax.set_title("Figure 2: value of information gained vs dwell time")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    fig.tight_layout()
    return save_figure(fig, path)


# ---------------------------------------------------------------------- Figure 3
def ordered_delays(m: int, gamma: int) -> np.ndarray:
    """The delay vectors of Figure 3's chain, shape ``(m (Gamma - 1), m)``.

    From ``(2, 1, ..., 1)`` to ``(Gamma, ..., Gamma)``, raising one station's delay by one
    at a time in station order: ``(t, .., t, t-1, .., t-1)`` with ``k = 1..m`` leading
    ``t``'s, for ``t = 2..Gamma``. Each vector is componentwise above the previous one,
    so the states form a chain of the partial order and Claim 2 makes ``V*`` along them
    non-increasing. The ``m`` states of one ``t`` share the maximum delay ``taubar = t``,
    hence the partition.
    """
    rows = [[t] * k + [t - 1] * (m - k) for t in range(2, gamma + 1) for k in range(1, m + 1)]
    return np.array(rows, dtype=np.int64).reshape(-1, m)


def select_ordered_states(comps: np.ndarray, stations: Any) -> dict[int, np.ndarray]:
    """States of Figure 3: one chain per station node ``l``, in chain order.

    Every station alerted, ``d = 0``, ``w = +1``, the UAV at ``l``, and the delays of
    :func:`ordered_delays` (``Gamma`` = the largest delay in ``comps``). A delay vector
    the model does not hold is left out (what remains is still a chain).
    """
    tau = comps[:, 3:].astype(np.int64)
    m = tau.shape[1]
    gamma = int(tau.max(initial=0))
    chain = ordered_delays(m, gamma)
    out: dict[int, np.ndarray] = {}
    for s in stations:
        cand = np.flatnonzero((comps[:, 0] == s) & (comps[:, 1] == 1) & (comps[:, 2] == 0))
        where = {tuple(t): int(x) for x, t in zip(cand, tau[cand].tolist(), strict=True)}
        hits = [where.get(tuple(t)) for t in chain.tolist()]
        out[int(s)] = np.array([h for h in hits if h is not None], dtype=np.int64)
    return out


def plot_ordered_states(
    comps: np.ndarray, stations: Any, vstar: np.ndarray, path: str | Path
) -> Path:
    """Figure 3: ``V*`` along the chains of :func:`select_ordered_states`, one curve per
    UAV location, dotted lines where the maximum delay (the partition) changes."""
    sel = select_ordered_states(comps, stations)
    m = comps.shape[1] - 3
    fig, ax = subplots(figsize=(8.0, 4.6))
    markers = "osD^v<>px*"
    taubar = np.zeros(0, dtype=np.int64)
    # an increase beyond rounding would contradict Claim 2: marked, and the title says so
    slack = FIGURE_MONOTONE_RTOL * float(np.abs(vstar).max(initial=0.0))
    n_up = 0
    for k, (s, idx) in enumerate(sel.items()):
        y = vstar[idx]
        ax.plot(
            np.arange(idx.size),
            y,
            marker=markers[k % 10],
            ms=3.5,
            lw=1.0,
            label=f"UAV at station l = {s}",
        )
        up = np.flatnonzero(np.diff(y) > slack) + 1
        if up.size:
            ax.plot(up, y[up], "o", mfc="none", mec="red", ms=9, label=None if n_up else "increase")
        n_up += up.size
        if idx.size > taubar.size:
            taubar = comps[idx, 3:].max(axis=1)
    if taubar.size:
        levels, start = np.unique(taubar, return_index=True)
        for b in start[1:]:
            ax.axvline(b - 0.5, color="grey", ls=":", lw=0.8)
        centres = (start + np.r_[start[1:], taubar.size] - 1) / 2
        step = max(1, len(levels) // 14)
        top = ax.secondary_xaxis("top")
        top.set_xticks(centres[::step], [str(v) for v in levels[::step]])
        top.tick_params(length=0, labelsize=8)
        top.set_xlabel(r"maximum delay $\bar\tau$ (partition), dotted lines: boundaries")
        ax.set_xlim(-0.5, taubar.size - 0.5)
    if 0 < taubar.size <= 24:  # label each state by its delays where they fit
        longest = max(sel.values(), key=lambda i: i.size)
        ax.set_xticks(
            np.arange(taubar.size),
            [",".join(map(str, t)) for t in comps[longest, 3:].tolist()],
            rotation=90 if m > 3 else 0,
            fontsize=7,
        )
    ax.set_xlabel(
        "states in chain order: station delays raised one at a time, "
        f"({', '.join(['2'] + ['1'] * (m - 1))}) → (Γ, ..., Γ)"
    )
    ax.set_ylabel("V*")
    claim = (
        "V* is non-increasing along ordered states"
        if n_up == 0
        else f"V* along ordered states: {n_up} increase(s) (circled) contradict Claim 2"
    )
    ax.set_title(
        f"Figure 3: {claim}\n"
        "(all stations alerted, d = 0, w = +1; each state's delays ≥ the previous one's)",
        fontsize=10,
    )
    ax.grid(alpha=0.25, axis="y")
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return save_figure(fig, path)


# ---------------------------------------------------------------------- Figure 4
def select_min_value_partitions(
    comps: np.ndarray, stations: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """States of Figure 4: ``l`` = first station, ``d = 0``, ``w = +1``, alerts exactly at
    the first and last station (``A = 1 0 .. 0 1``), ``taubar >= 2``.

    Returns ``(states, taubar, A)`` with the states ordered by ``taubar``, then by the
    sum of the delays.
    """
    tau = comps[:, 3:].astype(np.int64)
    m = tau.shape[1]
    a = np.zeros(m, dtype=bool)
    a[0] = a[-1] = True
    alerted = tau > 0
    mask = (
        (comps[:, 0] == stations[0])
        & (comps[:, 1] == 1)
        & (comps[:, 2] == 0)
        & (alerted == a[None, :]).all(axis=1)
        & (tau.max(axis=1) >= 2)
    )
    idx = np.flatnonzero(mask)
    taubar = tau[idx].max(axis=1)
    order = np.lexsort((tau[idx, 0], tau[idx].sum(axis=1), taubar))
    return idx[order], taubar[order], a.astype(int)


def plot_min_value_partitions(
    comps: np.ndarray, stations: Any, vstar: np.ndarray, path: str | Path
) -> Path:
    """Figure 4: ``V*`` of every state (dots) and ``min V*`` per partition (green, drawn
    above the dots: :func:`lpbounds.plot.bounds`)."""
    idx, taubar, a = select_min_value_partitions(comps, stations)
    fig, ax = subplots(figsize=(8.0, 4.2))
    legend = {"loc": "lower left", "fontsize": 8}
    if idx.size:
        # the plotted states' partitions: for fixed l, w, d and A, the maximum delay
        levels, group = np.unique(taubar, return_inverse=True)
        plot.bounds(
            Partition(group),
            vstar[idx],
            order="index",
            within="given",
            ax=ax,
            legend=legend,
        )
        start = np.flatnonzero(np.r_[True, np.diff(group) != 0])
        ends = np.r_[start[1:], idx.size]
        top = ax.get_ylim()[1]
        for k, (s0, e0) in enumerate(zip(start, ends, strict=True)):
            ax.text((s0 + e0 - 1) / 2, top, str(levels[k]), ha="center", va="bottom", fontsize=7)
    else:
        ax.plot([], [], "o", ms=3.5, color="tab:blue", label="V*(x), x in the partition")
        ax.legend(**legend)
    code = "".join(str(v) for v in a)
    ax.set_xlabel(r"states grouped by partition, max delay $\bar\tau$ = 2..Γ (labels on top)")
    ax.set_ylabel("V*")
    ax.set_title(
        f"Figure 4: min V* over a partition is non-increasing in the maximum delay\n"
        f"(states with alerts A = {code}, d = 0, w = +1, l = {stations[0]})",
        fontsize=10,
        pad=14,
    )
    fig.tight_layout()
    return save_figure(fig, path)


# ---------------------------------------------------------------------- Figure 5
def select_bounds_partitions(pcomps: np.ndarray, N: int) -> np.ndarray:
    """The ``2N`` partitions of eq. (32)-(33): ``d = 0``, ``taubar = 2``, all ``A_j = 1``;
    first ``w = +1`` for ``l = 0..N-1``, then ``w = -1``. Returns partition indices."""
    d, taubar = pcomps[:, 2], pcomps[:, -1]
    a = pcomps[:, 3:-1]
    base = (d == 0) & (taubar == 2) & (a == 1).all(axis=1)
    out = []
    for w in (1, -1):
        for l in range(N):
            hit = np.flatnonzero(base & (pcomps[:, 1] == w) & (pcomps[:, 0] == l))
            out.append(int(hit[0]) if hit.size == 1 else -1)
    return np.array(out, dtype=np.int64)


def plot_bounds(
    pcomps: np.ndarray,
    labels: np.ndarray,
    vstar: np.ndarray,
    upper: np.ndarray,
    lower: np.ndarray,
    N: int,
    path: str | Path,
) -> Path:
    """Figure 5: ``V_up``, ``V_low`` and ``V*`` (every member state) on the 2N partitions
    (:func:`lpbounds.plot.bounds`, one x per partition)."""
    parts = select_bounds_partitions(pcomps, N)
    fig, ax = subplots(figsize=(9.0, 4.4))
    line = {"ms": 4, "lw": 1, "drawstyle": "default"}
    plot.bounds(
        labels,
        vstar,
        lower,
        upper,
        partitions=parts[parts >= 0],
        layout="partitions",
        within="given",
        ax=ax,
        dots={"alpha": 0.7},
        upper_line={**line, "marker": "v", "color": "tab:red", "label": "V_up = Φ v* (UBLP)"},
        lower_line={**line, "marker": "^", "color": "tab:green", "label": "V_low = Φ w* (LBLP)"},
        min_line=None,
        legend={"loc": "upper center", "bbox_to_anchor": (0.5, -0.16), "ncol": 3, "fontsize": 8},
    )
    k = np.arange(1, parts.size + 1)
    ax.axvline(N + 0.5, color="grey", ls=":", lw=0.8)
    ticks = k[:: max(1, N // 8)]
    ax.set_xticks(ticks, [str(t) for t in ticks])
    ax.set_xlabel(
        f"partition number (1..{N}: clockwise l = 0..{N - 1}; {N + 1}..{2 * N}: counter-clockwise)"
    )
    ax.set_ylabel("value")
    ax.set_title(
        "Figure 5: V_low ≤ V* ≤ V_up on every state of the partitions\n"
        r"(d = 0, $\bar\tau$ = 2, all stations alerted)",
        fontsize=10,
    )
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path)


# ---------------------------------------------------------------------- Figure 6
def plot_vsub(
    pcomps: np.ndarray,
    labels: np.ndarray,
    vstar: np.ndarray,
    vsub: np.ndarray,
    N: int,
    path: str | Path,
) -> Path:
    """Figure 6: ``V_sub`` and ``V*`` on the states of the clockwise partitions (32)."""
    parts = select_bounds_partitions(pcomps, N)[:N]
    pos = np.full(pcomps.shape[0], -1)
    pos[parts] = np.arange(parts.size)
    member = pos[labels]
    xs = np.flatnonzero(member >= 0)
    order = np.lexsort((vstar[xs], member[xs]))
    xs = xs[order]
    fig, (ax, ax2) = subplots(
        2, 1, figsize=(9.0, 5.6), sharex=True, gridspec_kw={"height_ratios": [2, 1]}
    )
    x = np.arange(xs.size)
    ax.plot(x, vstar[xs], "-", color="tab:blue", lw=1.2, label="V*")
    ax.plot(x, vsub[xs], "--", color="tab:orange", lw=1.2, label="V_sub (greedy w.r.t. V_low)")
    ax.set_ylabel("value")
    ax.legend(fontsize=8)
    ax.set_title(r"Figure 6: V_sub vs V* (clockwise, d = 0, $\bar\tau$ = 2, all alerted)")
    ax2.axhline(0.0, color="black", lw=0.6)
    ax2.plot(x, vstar[xs] - vsub[xs], ".", ms=3, color="tab:purple")
    ax2.set_ylabel("V* − V_sub")
    ax2.set_title(
        "V* − V_sub ≥ 0 up to the DP error bounds of both (V_sub is a policy's value)",
        fontsize=8,
    )
    ax2.set_xlabel("states, grouped by partition l = 0..N-1 (dotted)")
    bounds = np.flatnonzero(np.diff(member[xs])) + 0.5
    for a_ in (ax, ax2):
        for b in bounds:
            a_.axvline(b, color="grey", ls=":", lw=0.5)
        a_.grid(alpha=0.2)
    fig.tight_layout()
    return save_figure(fig, path)


# ---------------------------------------------------------------------- Figure 7
#: How a policy's key in the Monte Carlo's runs reads in a legend: the report's names
#: (``pi*`` and ``pi_s`` there, as mathtext here), not the keys of the code
POLICY_LABELS = {"pi_star": r"$\pi^*$", "pi_s": r"$\pi_s$"}


def plot_histograms(
    delays: dict[str, np.ndarray], loiters: dict[str, np.ndarray], path: str | Path
) -> Path:
    """Figure 7: histograms (fraction of serviced alerts) of the delay and the loiters."""
    fig, (ax, ax2) = subplots(2, 1, figsize=(8.0, 6.4))
    names = list(delays)
    colors = ["tab:blue", "tab:orange", "tab:green", "tab:red"]
    width = 0.8 / max(1, len(names))
    top = max((int(v.max()) for v in delays.values() if v.size), default=1)
    bins = np.arange(0, top + 1)
    for k, name in enumerate(names):
        v = delays[name]
        h = np.bincount(v, minlength=top + 1)[: top + 1] / max(1, v.size)
        ax.bar(
            bins + (k - (len(names) - 1) / 2) * width,
            h,
            width,
            color=colors[k % 4],
            label=f"{POLICY_LABELS.get(name, name)} (n = {v.size})",
        )
    ax.set_xlabel("service delay (time from alert to first loiter, uncapped)")
    ax.set_ylabel("fraction of serviced alerts")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    topl = max((int(v.max()) for v in loiters.values() if v.size), default=1)
    lb = np.arange(0, topl + 1)
    for k, name in enumerate(names):
        v = loiters[name]
        h = np.bincount(v, minlength=topl + 1)[: topl + 1] / max(1, v.size)
        ax2.bar(
            lb + (k - (len(names) - 1) / 2) * width,
            h,
            width,
            color=colors[k % 4],
            label=POLICY_LABELS.get(name, name),
        )
    ax2.set_xlabel("number of loiters per serviced alert")
    ax2.set_ylabel("fraction of serviced alerts")
    ax2.set_xticks(lb)
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3, axis="y")
    fig.suptitle("Figure 7: service delay and loiters, optimal vs sub-optimal policy")
    fig.tight_layout()
    return save_figure(fig, path)
