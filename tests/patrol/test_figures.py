"""Figure data selections (checked against plain loops over the states) and PNG output."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lpbounds.patrol import figures as figs
from lpbounds.patrol.model import PatrolModel
from lpbounds.patrol.params import PatrolParams

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def model():
    return PatrolModel(PatrolParams(N=7, stations=(0, 2, 5), D=2, Gamma=4))


def _is_png(p: Path) -> bool:
    data = Path(p).read_bytes()
    return data[:8] == PNG_MAGIC and len(data) > 5_000


def test_ordered_states_selection(model):
    comps = model.state_components()
    st = model.params.stations
    sel = figs.select_ordered_states(comps, st)
    assert sorted(sel) == sorted(st)
    for s, idx in sel.items():
        want = {
            x
            for x, c in enumerate(comps)
            if c[0] == s and c[1] == 1 and c[2] == 0 and min(c[3:]) >= 1 and max(c[3:]) >= 2
        }
        assert set(idx.tolist()) == want
        # never a state after one that it is dominated by (the order is a linear extension)
        tau = comps[idx, 3:]
        for k in range(len(idx)):
            later = tau[k + 1 :]
            assert not ((later <= tau[k]).all(axis=1) & (later != tau[k]).any(axis=1)).any()
        assert (np.diff(tau.max(axis=1)) >= 0).all()


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


def test_every_plot_writes_a_png(model, tmp_path):
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
