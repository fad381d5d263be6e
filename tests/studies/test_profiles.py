"""lpbounds.studies.profiles and the study's per-solver summary, against hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from lpbounds.errors import ValidationError
from lpbounds.studies.profiles import (
    coinciding_profiles,
    new_figure,
    performance_profile,
    performance_ratios,
    plot_performance_profile,
    profile_value,
    shifted_geometric_mean,
)
from lpbounds.studies.report import profile_tables, solver_summary
from tests._figures import assert_legend_visible

INF = math.inf

#: A made-up table: 4 problems x 3 solvers (inf = failed). Worked by hand:
#: p1: best 1 -> A 1, B 2, C inf
#: p2: best 2 -> A 2, B 1, C 4
#: p3: nobody solved it -> inf for all
#: p4: best 1 -> A 3, B 1, C 1.5
TABLE = pd.DataFrame(
    {"A": [1.0, 4.0, INF, 3.0], "B": [2.0, 2.0, INF, 1.0], "C": [INF, 8.0, np.nan, 1.5]},
    index=["p1", "p2", "p3", "p4"],
)


def test_ratios_by_hand():
    r = performance_ratios(TABLE)
    expected = {
        "A": [1.0, 2.0, INF, 3.0],
        "B": [2.0, 1.0, INF, 1.0],
        "C": [INF, 4.0, INF, 1.5],
    }
    for col, vals in expected.items():
        assert r[col].tolist() == vals, (col, r[col].tolist())


@pytest.mark.parametrize(
    ("tau", "a", "b", "c"),
    [
        # rho_s(tau) = #{p: r_ps <= tau} / 4, counted by hand from the ratios above
        (1.0, 1 / 4, 2 / 4, 0.0),
        (1.5, 1 / 4, 2 / 4, 1 / 4),
        (2.0, 2 / 4, 3 / 4, 1 / 4),
        (3.0, 3 / 4, 3 / 4, 1 / 4),
        (4.0, 3 / 4, 3 / 4, 2 / 4),
        (1e9, 3 / 4, 3 / 4, 2 / 4),  # the plateau: the fraction each solved; p3 never
    ],
)
def test_profile_by_hand(tau, a, b, c):
    got = profile_value(performance_ratios(TABLE), tau)
    assert got.tolist() == [a, b, c]


def test_profile_breakpoints():
    prof = performance_profile(TABLE)
    assert prof.index.tolist() == [1.0, 1.5, 2.0, 3.0, 4.0]
    assert prof.loc[3.0].tolist() == [0.75, 0.75, 0.25]


def test_profile_png(tmp_path):
    path = plot_performance_profile(TABLE, tmp_path / "p.png", title="t", measure="time")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_coinciding_profiles_are_found():
    table = TABLE.assign(D=TABLE["A"], E=TABLE["B"])  # D: A's measures, E: B's
    assert coinciding_profiles(performance_profile(table)) == {"A": ["D"], "B": ["E"]}
    assert coinciding_profiles(performance_profile(TABLE)) == {}


def test_every_profile_shows_where_curves_coincide(tmp_path, monkeypatch):
    """SCIPY (HiGHS inside) drawn over HIGHS:simplex's identical curve hid it; now each
    curve of a coinciding group shows (pixels of every legend colour outside the legend)
    and its legend entry says which curve it shares."""
    from lpbounds.studies import profiles

    made = []

    def keep(size):
        made.append(new_figure(size))
        return made[-1]

    monkeypatch.setattr(profiles, "new_figure", keep)
    table = TABLE.assign(HIGHS=TABLE["A"], SCIPY=TABLE["A"], OTHER=TABLE["C"])
    plot_performance_profile(table, tmp_path / "p.png", title="t", measure="error")
    fig = made[0]
    texts = [t.get_text().replace("\n", " ") for t in fig.axes[0].get_legend().get_texts()]
    assert texts[0] == "A (same curve as HIGHS, SCIPY)" and texts[3] == "HIGHS (same curve as A)"
    assert texts[2] == "C (same curve as OTHER)" and texts[4] == "SCIPY (same curve as A)"
    assert_legend_visible(fig)


def test_the_pixel_check_sees_a_curve_drawn_over(tmp_path, monkeypatch):
    """The control: with every curve drawn alike (as before), A's colour is covered."""
    from lpbounds.studies import profiles

    made = []
    monkeypatch.setattr(
        profiles, "new_figure", lambda size: made.append(new_figure(size)) or made[-1]
    )
    monkeypatch.setattr(profiles, "coinciding_profiles", lambda prof: {})
    table = TABLE[["A"]].assign(HIGHS=TABLE["A"])
    plot_performance_profile(table, tmp_path / "p.png", title="t", measure="error")
    with pytest.raises(AssertionError, match="not visible"):
        assert_legend_visible(made[0])


@pytest.mark.parametrize(
    ("values", "shift", "expected"),
    [
        ([0.0, 3.0, 15.0], 1.0, 3.0),  # (1 * 4 * 16)^(1/3) - 1 = 4 - 1
        ([1.0, 7.0, 31.0], 1.0, 7.0),  # (2 * 8 * 32)^(1/3) - 1 = 8 - 1
        ([1.0, 4.0, 2.0], 0.0, 2.0),  # plain geometric mean: 8^(1/3)
        ([1.0, 4.0, 3.0], 10.0, 2002 ** (1 / 3) - 10),  # 11 * 14 * 13 = 2002
        ([5.0], 10.0, 5.0),
    ],
)
def test_shifted_geometric_mean_by_hand(values, shift, expected):
    assert shifted_geometric_mean(values, shift) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(
    ("values", "shift", "needle"),
    [
        ([1.0, -1.0], 10.0, "entry 1"),
        ([1.0, INF], 10.0, "entry 1"),
        ([0.0, 1.0], 0.0, "positive"),
        ([1.0], -1.0, "shift"),
        ([1.0], True, "shift"),
    ],
)
def test_shifted_geometric_mean_bad_input(values, shift, needle):
    with pytest.raises(ValidationError, match=needle):
        shifted_geometric_mean(values, shift)


def test_ratios_bad_table():
    with pytest.raises(ValidationError, match=r"'p1'.*'A'"):
        performance_ratios(pd.DataFrame({"A": [0.0]}, index=["p1"]))
    with pytest.raises(ValidationError, match="DataFrame"):
        performance_ratios([[1.0]])  # type: ignore[arg-type]


def _frame() -> pd.DataFrame:
    """Two problems x three configurations, made up: A solves both in 1 s and 7 s; B solves
    p1 in 3 s and returns no point on p2; C returns a point at the time limit on p1."""
    rows = [
        ("p1", "A", "optimal", True, 1.0, 1e-9),
        ("p2", "A", "optimal", True, 7.0, 1e-12),
        ("p1", "B", "optimal", True, 3.0, 1e-10),
        ("p2", "B", "solver_error", False, 2.0, INF),
        ("p1", "C", "time_limit", False, 15.0, 1e-3),
        ("p2", "C", "inaccurate", False, 4.0, 1e-4),
    ]
    keys = ("instance", "config", "status", "accurate", "solve_seconds", "rel_error")
    frame = pd.DataFrame([dict(zip(keys, r, strict=True)) for r in rows])
    return frame.assign(formulation="RLP", backend=frame["config"], repeat=0)


def test_solver_summary_by_hand():
    s = solver_summary(_frame(), (1.0,), time_limit=15.0).set_index("config")
    # A: sqrt((1 + 1)(7 + 1)) - 1 = 3; B: p2 unsolved, charged the limit: sqrt(4 * 16) - 1 = 7
    # C: nothing solved: both charged 15 s -> 15
    assert s.loc["A", "sgm_1s"] == pytest.approx(3.0, rel=1e-12)
    assert s.loc["B", "sgm_1s"] == pytest.approx(7.0, rel=1e-12)
    assert s.loc["C", "sgm_1s"] == pytest.approx(15.0, rel=1e-12)
    assert s.loc["A", ["solved", "optimal", "failed"]].tolist() == [2, 2, 0]
    assert s.loc["B", ["solved", "optimal", "failed"]].tolist() == [1, 1, 1]
    assert s.loc["C", ["solved", "time_limit", "inaccurate"]].tolist() == [0, 1, 1]
    assert s.loc["C", "worst_rel_error"] == 1e-3


def test_profile_tables_count_failures_as_unsolved():
    time_t, acc_t = profile_tables(_frame())
    assert time_t.loc["p1 / RLP"].tolist() == [1.0, 3.0, INF]
    assert time_t.loc["p2 / RLP"].tolist() == [7.0, INF, INF]
    # accuracy compares every returned point, a time-limit stop included; no point: inf
    assert acc_t.loc["p1 / RLP"].tolist() == [1e-9, 1e-10, 1e-3]
    assert acc_t.loc["p2 / RLP"].tolist() == [1e-12, INF, 1e-4]
