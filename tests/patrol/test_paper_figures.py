"""The reproduction against the paper's published numbers (Park et al., Section 6, Table 1).

The paper's figures are for its instance only (``models/patrol-paper.toml``: N = 15,
stations 0, 3, 7, 11, D = 5, Gamma = 15; 2,048,000 states, 8,900 partitions), so they are
checked at that size:

* fast: ``|S|`` and ``M`` (Section 6); Figure 4 at the paper's size, drawn from the
  certified lower bound (its ``min V*`` line must show above 224 crowded dots); Table 1's
  row of ``pi_s`` (greedy w.r.t. the lower bound ``w*``, eq. 30), which needs the partition
  bounds only (a second), acted out on the fly on the reproduction's alert sequences (5
  seeds x 60,000 steps); the Section 6 text ("almost 90 %" of the serviced alerts get the
  full dwell of 5 loiters); and the saved
  paper-scale record of ``benchmarks/bench_greedy_mc.py`` against both;
* slow (``-m slow``; excluded by default, see pyproject's ``addopts``): the whole
  reproduction at the paper's size, with exact ``V*`` and ``pi*``, against both rows of
  Table 1 and the Section 6 statements on the bounds, its figures drawn and each legend
  entry seen in their pixels.

The same statements are checked on the small instance in ``test_reproduce.py``
(``test_section_6_statements_on_the_small_instance``), where Table 1's numbers themselves
do not apply (D = 2 there).

Tolerances, and why:

* means (loiters, delay): the paper prints one decimal (+-0.05) and ran ONE 60,000-step
  window; ours pools 5 windows. A window's mean has the spread ``s`` of our per-window
  means (``std_mean_*``: 0.016 loiters, 0.023 delay), so the difference of the paper's one
  window and our pooled five has standard deviation ``s sqrt(1 + 1/5)``: tolerance
  ``0.05 + 3 s sqrt(1 + 1/5)`` (about 0.10 and 0.13).
* the paper's delay counts to the END of the first loiter: its worst delay of ``pi*`` is 15
  = Gamma, and of the conventions lpbounds reports (``Reproduction``'s ``conventions``) the
  ``+1`` one is the closest to its mean (checked below); so ``mean_delay_plus_one`` and
  ``worst_delay_plus_one`` are compared.
* worst delay: the largest of about a thousand delays in one window, a tail statistic with
  no central limit; the paper's own two policies differ by 3 on the SAME alert sequence
  (15 and 18) while their means agree to the printed digit, so +-3 is the spread the paper
  itself shows for it.
* "almost 90 %" (full dwell): read off a histogram: [0.85, 0.95].
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from lpbounds.patrol import figures as figs
from lpbounds.patrol.greedy_mc import greedy_table1, partition_bounds
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.model import PatrolModel
from lpbounds.patrol.reproduce import PAPER_TABLE1

from .._figures import assert_legend_visible

PAPER = "models/patrol-paper.toml"
ROOT = Path(__file__).resolve().parents[2]
GREEDY_RECORD = ROOT / "benchmarks" / "results" / "greedy_mc.json"

#: Table 1 (tab:perfcomp) of the paper, as printed: mean number of loiters, mean service
#: delay, worst service delay (5 seeds x 60,000 steps here; one 60,000-step window there).
TABLE1 = {
    "pi_star": {"mean_loiters": 4.7, "mean_delay": 5.6, "worst_delay": 15},
    "pi_s": {"mean_loiters": 4.7, "mean_delay": 5.6, "worst_delay": 18},
}
#: Section 6: |S| = 2,048,000 (eq. 27) and M = 8900 partitions (eq. 28).
PAPER_STATES, PAPER_PARTITIONS = 2_048_000, 8_900
#: the printed precision of Table 1's means
DIGIT = 0.05
#: the spread of a single window's maximum delay the paper itself shows (15 vs 18)
WORST_TOL = 3
#: Section 6: "maximum information was gained (5 loiters completed) on almost 90 % of the
#: serviced alerts", read off a histogram
FULL_DWELL = (0.85, 0.95)


def _mean_tol(std_per_window: float, n_windows: int) -> float:
    return DIGIT + 3.0 * std_per_window * math.sqrt(1.0 + 1.0 / n_windows)


def check_table1_row(stats, paper: dict, n_windows: int, what: str) -> None:
    """One row of Table 1 (``stats``: a PolicyStatistics or its dict) against the paper's."""
    get = stats.get if isinstance(stats, dict) else lambda k: getattr(stats, k)
    tol_l = _mean_tol(get("std_mean_loiters"), n_windows)
    tol_d = _mean_tol(get("std_mean_delay"), n_windows)
    assert abs(get("mean_loiters") - paper["mean_loiters"]) <= tol_l, (what, get("mean_loiters"))
    assert abs(get("mean_delay_plus_one") - paper["mean_delay"]) <= tol_d, (
        what,
        get("mean_delay_plus_one"),
    )
    assert abs(get("worst_delay_plus_one") - paper["worst_delay"]) <= WORST_TOL, (
        what,
        get("worst_delay_plus_one"),
    )
    # the +1 convention is the paper's: it is the closest of the conventions to its mean
    others = ("mean_delay", "mean_delay_capped", "mean_delay_visit")
    others = [k for k in others if get(k) is not None]
    gap = abs(get("mean_delay_plus_one") - paper["mean_delay"])
    assert all(gap < abs(get(k) - paper["mean_delay"]) for k in others), what
    assert get("mismatches") == 0, "every simulated step follows the specification"


def test_the_constants_are_the_papers():
    """lpbounds' own copy of Table 1 (the report prints it beside its numbers) is the paper's."""
    assert PAPER_TABLE1 == TABLE1
    params = params_from_instance(PAPER)
    assert (params.n_states, params.n_partitions) == (PAPER_STATES, PAPER_PARTITIONS)
    assert (params.N, tuple(params.stations), params.D, params.Gamma) == (15, (0, 3, 7, 11), 5, 15)
    assert (params.rho, params.discount, params.alpha) == (0.005, 0.9, pytest.approx(1 / 60))


@pytest.fixture(scope="module")
def paper_bounds():
    """The paper's parameters and its partition bounds w* (LBLP) and v* (UBLP), certified."""
    params = params_from_instance(PAPER)
    bounds = partition_bounds(params)
    # the bounds are certified fixed points, and not vacuous
    assert bounds.lower.shape == bounds.upper.shape == (PAPER_PARTITIONS,)
    assert 0 < bounds.lower_error < 1e-8 and 0 < bounds.upper_error < 1e-8
    assert (bounds.lower <= bounds.upper + bounds.lower_error + bounds.upper_error).all()
    return params, bounds


@pytest.fixture(scope="module")
def pi_s_table1(paper_bounds):
    """Table 1 of pi_s at the paper's size: w* of LBLP from the partitions (certified), pi_s
    greedy w.r.t. it, acted out on the reproduction's 5 alert sequences of 60,000 steps."""
    params, bounds = paper_bounds
    return greedy_table1(params, bounds.lower, steps=60_000, seeds=(1, 2, 3, 4, 5))


def _keep_figures(monkeypatch, save: bool = True) -> list:
    """The figures the patrol's plot functions draw (and, with ``save``, still write)."""
    kept = []
    write = figs.save_figure

    def keep(fig, path):
        kept.append((Path(path).name, fig))
        return write(fig, path) if save else Path(path)

    monkeypatch.setattr(figs, "save_figure", keep)
    return kept


def test_figure4_at_the_papers_size_shows_its_min_line(paper_bounds, monkeypatch):
    """Figure 4's 224 states (A = 1001, d = 0, w = +1, l = 0) at the paper's size, drawn
    from Phi w*: constant on each partition, so every dot sits on the partition's
    ``min`` line, the crowding under which the paper's figure lost that line. Drawn
    above the dots, the line shows in the image; pushed below them, it does not (the check
    sees what a reader sees)."""
    params, bounds = paper_bounds
    pm = PatrolModel(params)
    comps = pm.state_components()
    values = bounds.lower[np.asarray(pm.partition().labels)]
    kept = _keep_figures(monkeypatch, save=False)
    figs.plot_min_value_partitions(comps, params.stations, values, "fig4.png")
    ((_, fig),) = kept
    idx, _, _ = figs.select_min_value_partitions(comps, params.stations)
    assert idx.size == 224, "tau_1, tau_4 in 1..15 with max >= 2: 15 * 15 - 1"
    counts = assert_legend_visible(fig, expect=("V*(x)", "min V* over the partition"))
    assert counts["min V* over the partition"] > 1000
    (line,) = [ln for ln in fig.axes[0].get_lines() if ln.get_label().startswith("min V*")]
    line.set_zorder(1)  # under the dots (zorder 3), as matplotlib's default order drew it
    with pytest.raises(AssertionError, match="min V\\* over the partition"):
        assert_legend_visible(fig)


def test_table1_pi_s_at_the_papers_size(pi_s_table1):
    stats = pi_s_table1.statistics
    assert pi_s_table1.steps == 60_000 and len(pi_s_table1.seeds) == 5
    assert stats.n_serviced > 4000, "about 5,000 alerts in 300,000 steps at alpha = 1/60"
    check_table1_row(stats, TABLE1["pi_s"], 5, "pi_s")


def test_section_6_full_dwell_and_fast_service(pi_s_table1):
    """'maximum information was gained (5 loiters completed) on almost 90 % of the serviced
    alerts'; 'roughly 90 % of the alerts were cleared within ten time steps'."""
    stats = pi_s_table1.statistics
    assert FULL_DWELL[0] <= stats.fraction_full_dwell <= FULL_DWELL[1], stats.fraction_full_dwell
    # measured 0.99 of the delays are <= 10 (0.55 if "cleared" means the end of the 5
    # loiters): the paper's "roughly 90 %" is at least met; it does not say which it counts
    assert stats.fraction_delay_le_10 >= FULL_DWELL[0], stats.fraction_delay_le_10


def test_saved_paper_scale_record_matches_the_paper_and_this_run(pi_s_table1):
    """benchmarks/results/greedy_mc.json (the paper-scale run of bench_greedy_mc.py, shown in
    docs/benchmarks.md and the README): its Table 1 row of pi_s against the paper's, and
    against this run within the Monte Carlo tolerance (same seeds: equal in practice)."""
    record = json.loads(GREEDY_RECORD.read_text())
    runs = [r for r in record["runs"] if r["model"] == "patrol-paper"]
    assert len(runs) == 1, [r["model"] for r in record["runs"]]
    run = runs[0]
    assert (run["n_states"], run["n_partitions"]) == (PAPER_STATES, PAPER_PARTITIONS)
    saved = run["table1"]
    assert saved["steps"] == 60_000 and len(saved["seeds"]) == 5
    check_table1_row(saved, TABLE1["pi_s"], 5, "saved pi_s")
    stats = pi_s_table1.statistics
    for key in ("mean_loiters", "mean_delay_plus_one"):
        std = stats.std_mean_loiters if key == "mean_loiters" else stats.std_mean_delay
        assert abs(saved[key] - getattr(stats, key)) <= 3 * std * math.sqrt(2 / 5), key
    assert abs(saved["worst_delay_plus_one"] - stats.worst_delay_plus_one) <= WORST_TOL


# ---------------------------------------------------------------------- the whole run
@pytest.mark.slow
def test_full_reproduction_against_table_1_and_section_6(tmp_path, monkeypatch):
    """``lpbounds reproduce`` at the paper's size (exact V*, both policies; about a minute
    and 1.5 GB on 2 cores): both rows of Table 1 and Section 6's statements; its figures
    written, every legend entry visible in each."""
    from lpbounds.patrol.reproduce import reproduce

    kept = _keep_figures(monkeypatch)
    rep = reproduce(PAPER, tmp_path / "out", figures=True, general="residual")
    names = [name for name, _ in kept]
    assert {f"fig{k}" for k in range(2, 8)} <= {name.split("_")[0] for name in names}, names
    for name, fig in kept:
        counts = assert_legend_visible(fig)
        assert not any(label.startswith("outside the bounds") for label in counts), name
    s = rep.summary
    assert (s["n_states"], s["n_partitions"]) == (PAPER_STATES, PAPER_PARTITIONS)
    mc = s["monte_carlo"]
    n_windows = len(mc["seeds"])
    assert mc["n_steps_per_seed"] == 60_000 and n_windows == 5
    for pol in ("pi_star", "pi_s"):
        check_table1_row(mc[pol], TABLE1[pol], n_windows, pol)
        assert FULL_DWELL[0] <= mc[pol]["fraction_full_dwell"] <= FULL_DWELL[1], pol
    # "hardly any difference in terms of either metric between the optimal and the
    # sub-optimal policies": the two rows agree within the printed digit
    for key in ("mean_loiters", "mean_delay_plus_one"):
        assert abs(mc["pi_star"][key] - mc["pi_s"][key]) <= 2 * DIGIT, key
    # V_low <= V_sub <= V* <= V_up, proved with the certificates (0 violations)
    chain = s["policy"]["chain"]
    assert all(chain[k]["violations"] == 0 for k in chain), chain
    sw = s["sandwich"]
    assert sw["certified_lower_margin"] > 0 and sw["certified_upper_margin"] > 0
    # "the lower bound appears to be tighter than the upper bound" (Figure 5): on average
    z = rep.arrays
    lab = z["partition_of_state"].astype(np.int64)
    vstar = z["vstar"]
    assert (vstar - z["lower"][lab]).mean() < (z["upper"][lab] - vstar).mean()
    # and on Figure 5's own states (every station alerted, taubar = 2, d = 0): the same
    comps = z["partition_components"]  # (l, w, d, A_1..A_m, taubar)
    fig5 = (comps[:, 2] == 0) & (comps[:, 3:-1] == 1).all(axis=1) & (comps[:, -1] == 2)
    assert fig5.sum() == 30, "Figure 5 shows 30 partitions (15 clockwise, 15 counter)"
    states = fig5[lab]
    assert (vstar - z["lower"][lab])[states].mean() < (z["upper"][lab] - vstar)[states].mean()
