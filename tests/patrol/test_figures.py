"""Figure data selections (checked against plain loops over the states) and PNG output.

Every figure is also looked at as an image: each legend entry must show in the rendered
pixels outside the legend (:func:`tests._figures.assert_legend_visible`), so an element drawn
under another one, clipped or off the axes fails, whatever the artist tree holds.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lpbounds.patrol import figures as figs
from lpbounds.patrol.model import PatrolModel
from lpbounds.patrol.params import PatrolParams

from .._figures import assert_legend_visible

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def model():
    return PatrolModel(PatrolParams(N=7, stations=(0, 2, 5), D=2, Gamma=4))


def _is_png(p: Path) -> bool:
    data = Path(p).read_bytes()
    return data[:8] == PNG_MAGIC and len(data) > 5_000


def test_ordered_states_are_chains_of_the_partial_order(model):
    """Figure 3 shows, per station, a chain: all stations alerted, d = 0, w = +1, the UAV at
    the station, each state's delays componentwise >= the previous one's, from (2, 1, 1)
    to (Gamma, Gamma, Gamma), m states per maximum delay."""
    comps = model.state_components()
    st = model.params.stations
    m, gamma = len(st), model.params.Gamma
    sel = figs.select_ordered_states(comps, st)
    assert sorted(sel) == sorted(st)
    for s, idx in sel.items():
        c = comps[idx]
        assert (c[:, 0] == s).all() and (c[:, 1] == 1).all() and (c[:, 2] == 0).all()
        tau = c[:, 3:]
        assert (tau >= 1).all()
        assert tau[0].tolist() == [2] + [1] * (m - 1) and tau[-1].tolist() == [gamma] * m
        steps = np.diff(tau, axis=0)
        assert ((steps >= 0).all(axis=1) & (steps.sum(axis=1) == 1)).all()  # one step up
        assert len(idx) == m * (gamma - 1)
        assert np.bincount(tau.max(axis=1))[2:].tolist() == [m] * (gamma - 1)


def test_min_value_partition_selection(model):
    comps = model.state_components()
    st = model.params.stations
    idx, taubar, a = figs.select_min_value_partitions(comps, st)
    assert a.tolist() == [1, 0, 1]
    want = {
        x
        for x, c in enumerate(comps)
        if c[0] == st[0]
        and c[1] == 1
        and c[2] == 0
        and c[3] > 0
        and c[4] == 0
        and c[5] > 0
        and max(c[3:]) >= 2
    }
    assert set(idx.tolist()) == want
    assert (np.diff(taubar) >= 0).all() and taubar.min() == 2 and taubar.max() == 4


def test_bounds_partitions_selection(model):
    pc = model.partition_components()
    parts = figs.select_bounds_partitions(pc, model.params.N)
    n = model.params.N
    assert parts.shape == (2 * n,) and (parts >= 0).all() and np.unique(parts).size == 2 * n
    for k, i in enumerate(parts):
        l, w, d, *a, tb = pc[i].tolist()
        assert (l, w, d, tb) == (k % n, 1 if k < n else -1, 0, 2) and all(a)


def test_every_plot_writes_a_png(model, tmp_path, monkeypatch):
    """Each figure is written as a PNG, and each shows every legend entry it names."""
    seen = {}
    save = figs.save_figure

    def check_then_save(fig, path):
        seen[Path(path).name] = assert_legend_visible(fig)
        return save(fig, path)

    monkeypatch.setattr(figs, "save_figure", check_then_save)
    p = model.params
    comps = model.state_components()
    pc = model.partition_components()
    labels = np.asarray(model.partition().labels)
    rng = np.random.default_rng(0)
    v = -rng.random(model.n_states)
    up = rng.random(pc.shape[0])
    lo = -rng.random(pc.shape[0])
    out = [
        figs.plot_information(p, tmp_path / "f2.png"),
        figs.plot_ordered_states(comps, p.stations, v, tmp_path / "f3.png"),
        figs.plot_min_value_partitions(comps, p.stations, v, tmp_path / "f4.png"),
        figs.plot_bounds(pc, labels, v, up, lo, p.N, tmp_path / "f5.png"),
        figs.plot_vsub(pc, labels, v, v - 0.01, p.N, tmp_path / "f6.png"),
        figs.plot_histograms(
            {"a": rng.integers(0, 9, 50), "b": rng.integers(0, 12, 40)},
            {"a": rng.integers(1, 3, 50), "b": rng.integers(0, 3, 40)},
            tmp_path / "f7.png",
        ),
    ]
    for f in out:
        assert _is_png(f), f
    assert sorted(seen) == [f"f{k}.png" for k in range(2, 8)]
    # the random values fall outside the random bounds: Figure 5 circles them, and says so
    assert any(label.startswith("outside the bounds") for label in seen["f5.png"])


def test_figure7_legend_names_the_policies_as_the_report_does(tmp_path, monkeypatch):
    """The Monte Carlo's keys (pi_star, pi_s) read pi* and pi_s in Figure 7's legends, as in
    report.md, and every entry shows in the image."""
    seen = {}
    monkeypatch.setattr(figs, "save_figure", lambda fig, path: seen.setdefault("fig", fig))
    rng = np.random.default_rng(1)
    figs.plot_histograms(
        {"pi_star": rng.integers(0, 9, 60), "pi_s": rng.integers(0, 12, 50)},
        {"pi_star": rng.integers(1, 4, 60), "pi_s": rng.integers(0, 4, 50)},
        tmp_path / "f7.png",
    )
    fig = seen["fig"]
    texts = [t.get_text() for ax in fig.axes for t in ax.get_legend().get_texts()]
    assert texts == [r"$\pi^*$ (n = 60)", r"$\pi_s$ (n = 50)", r"$\pi^*$", r"$\pi_s$"]
    assert not any("pi_star" in t or "pi_s" == t for t in texts)
    assert_legend_visible(fig, expect=(r"$\pi^*$", r"$\pi_s$"))


# ---------------------------------------------------------------------- what each figure claims
@pytest.fixture(scope="module")
def small():
    """patrol-small with V* (exact DP), the UBLP/LBLP fixed points and V_sub computed here."""
    import lpbounds as lb
    from lpbounds.patrol.bounds import patrol_rows
    from lpbounds.patrol.instance import params_from_instance

    params = params_from_instance(lb.load_instance("models/patrol-small.toml"))
    pm = PatrolModel(params)
    mdp = pm.mdp()
    vs = lb.solve_exact(mdp, "pi")
    up = lb.solve_exact(patrol_rows(params, "upper"), "pi")
    low = lb.solve_exact(patrol_rows(params, "lower"), "pi")
    labels = np.asarray(pm.partition().labels)
    # V_sub: the policy greedy w.r.t. Phi w*, evaluated by a dense linear solve
    succ = np.asarray(mdp.successors)
    probs = np.broadcast_to(np.asarray(mdp.probabilities_full()), succ.shape)
    phi_low = low.values[labels]
    q = np.asarray(mdp.rewards) + mdp.discount * (probs * phi_low[succ]).sum(axis=2)
    pol = np.where(np.asarray(mdp.allowed), q, -np.inf).argmax(axis=1)
    n = mdp.n_states
    pmat = np.zeros((n, n))
    rows = np.arange(n)
    np.add.at(
        pmat, (np.repeat(rows, succ.shape[2]), succ[rows, pol].ravel()), probs[rows, pol].ravel()
    )
    vsub = np.linalg.solve(np.eye(n) - mdp.discount * pmat, np.asarray(mdp.rewards)[rows, pol])
    tol = 4 * max(vs.error_bound, up.error_bound, low.error_bound) + 1e-12
    return {
        "params": params, "pm": pm, "comps": pm.state_components(),
        "pcomps": pm.partition_components(), "labels": labels, "vstar": vs.values,
        "upper": up.values, "lower": low.values, "vsub": vsub, "tol": tol,
    }  # fmt: skip


@pytest.fixture
def captured(monkeypatch):
    """The figures the plot functions draw (their axes' lines), instead of PNG files."""
    figures = []

    def keep(fig, path):
        figures.append(fig)
        return Path(path)

    monkeypatch.setattr(figs, "save_figure", keep)
    return figures


def _lines(fig, prefix):
    return [
        ln for ax in fig.axes for ln in ax.get_lines() if str(ln.get_label()).startswith(prefix)
    ]


def test_figure3_plots_non_increasing_values_along_each_chain(small, captured):
    st = small["params"].stations
    figs.plot_ordered_states(small["comps"], st, small["vstar"], "f3.png")
    lines = _lines(captured[0], "UAV at station")
    assert len(lines) == len(st)
    m, gamma = len(st), small["params"].Gamma
    for ln in lines:
        y = np.asarray(ln.get_ydata())
        assert y.size == m * (gamma - 1)
        assert (np.diff(y) <= small["tol"]).all(), np.diff(y).max()
        assert y[0] - y[-1] > 100 * small["tol"]  # it does decrease, not only stay flat
    title = captured[0].axes[0].get_title()
    assert "all stations alerted" in title and "d = 0" in title and "w = +1" in title
    assert_legend_visible(captured[0], expect=("UAV at station",))


def _min_levels(line):
    """The heights of a ``min V*`` line: one segment per partition, NaN between them."""
    y = np.asarray(line.get_ydata(), dtype=np.float64)
    seg = y[np.isfinite(y)].reshape(-1, 2)
    assert (seg[:, 0] == seg[:, 1]).all(), "each segment is horizontal"
    return seg[:, 0]


def test_figure4_min_over_each_partition_is_non_increasing(small, captured):
    st = small["params"].stations
    figs.plot_min_value_partitions(small["comps"], st, small["vstar"], "f4.png")
    fig = captured[0]
    (line,) = _lines(fig, "min V*")
    levels = _min_levels(line)
    assert levels.size == small["params"].Gamma - 1
    assert (np.diff(levels) <= small["tol"]).all()
    # each green level is the least V* of the states plotted in its partition
    idx, taubar, _ = figs.select_min_value_partitions(small["comps"], st)
    want = [small["vstar"][idx[taubar == t]].min() for t in np.unique(taubar)]
    assert np.allclose(levels, want, rtol=0, atol=1e-15)
    (dots,) = _lines(fig, "V*(x)")
    assert line.get_zorder() > dots.get_zorder(), "the line the caption names is on top"
    assert_legend_visible(fig, expect=("V*(x)", "min V* over the partition"))


def test_figure5_bounds_sandwich_every_plotted_state(small, captured):
    p = small["params"]
    figs.plot_bounds(
        small["pcomps"], small["labels"], small["vstar"], small["upper"], small["lower"],
        p.N, "f5.png",
    )  # fmt: skip
    (dots,) = _lines(captured[0], "V*(x)")
    (up,) = _lines(captured[0], "V_up")
    (low,) = _lines(captured[0], "V_low")
    x, y = np.asarray(dots.get_xdata()).astype(int), np.asarray(dots.get_ydata())
    assert x.size > 0
    up_y, low_y = np.asarray(up.get_ydata()), np.asarray(low.get_ydata())
    assert (low_y[x - 1] <= y + small["tol"]).all() and (y <= up_y[x - 1] + small["tol"]).all()
    # the true V* lies inside its bounds: nothing is circled, and every entry shows
    counts = assert_legend_visible(captured[0], expect=("V*(x)", "V_up", "V_low"))
    assert not any(label.startswith("outside") for label in counts)


def test_figure6_vsub_never_exceeds_vstar(small, captured):
    p = small["params"]
    figs.plot_vsub(small["pcomps"], small["labels"], small["vstar"], small["vsub"], p.N, "f6.png")
    (vs,) = _lines(captured[0], "V*")
    (sub,) = _lines(captured[0], "V_sub")
    assert np.asarray(vs.get_ydata()).size > 0
    assert (np.asarray(sub.get_ydata()) <= np.asarray(vs.get_ydata()) + small["tol"]).all()
    assert_legend_visible(captured[0], expect=("V*", "V_sub"))


def test_figure3_says_so_when_values_increase(small, captured):
    """A V* that rises along a chain is circled and the title no longer claims monotonicity."""
    st = small["params"].stations
    bumped = small["vstar"].copy()
    idx = figs.select_ordered_states(small["comps"], st)[st[0]]
    bumped[idx[3]] = bumped[idx[2]] + 1e-3
    figs.plot_ordered_states(small["comps"], st, bumped, "f3.png")
    title = captured[0].axes[0].get_title()
    assert "non-increasing" not in title and "1 increase(s)" in title
    assert _lines(captured[0], "increase")
    assert_legend_visible(captured[0], expect=("increase",))
