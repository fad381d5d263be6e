"""lpbounds.plot: what each plot draws, checked against an independent computation, seen in
the rendered image (every legend entry's colour outside the legend), and its input errors.

``V*``, RLP's ``v*`` and NLP's ``w*`` come from dense policy and strategy iteration
(``tests/_independent.py``), not from the package; the plots are given the package's
results and must draw their certified ends, on the right side of those references.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import lpbounds as lb
from lpbounds import plot
from lpbounds.errors import ValidationError
from lpbounds.formulations import RLP
from lpbounds.formulations.nlp.problem import NLP
from tests import _independent as ind
from tests._figures import assert_legend_visible

N_STATES, N_PARTS = 60, 6


@pytest.fixture(scope="module")
def case():
    """A garnet, a partition, the package's results and the independent references."""
    mdp = lb.garnet(N_STATES, 3, 3, 0.9, seed=7)
    part = lb.random_partition(N_STATES, N_PARTS, seed=3)
    dense = ind.dense_transitions(mdp.successors, mdp.probabilities)
    args = (dense, mdp.rewards, mdp.allowed, mdp.discount)
    labels = np.asarray(part.labels)
    return {
        "mdp": mdp,
        "part": part,
        "labels": labels,
        "vstar": ind.policy_iteration(*args),
        "v_rlp": ind.rlp_optimum(*args, labels),
        "w_nlp": ind.nlp_optimum(*args, labels),
        "dp": lb.solve_exact(mdp),
        "dp_vi": lb.solve_exact(mdp, "vi"),
        "rlp": RLP(mdp, part).solve(),
        "nlp": NLP(mdp, part).solve("cutting-planes"),
    }


def _axes() -> Axes:
    """Axes of a figure on an Agg canvas (no pyplot, no backend)."""
    fig = Figure(figsize=(8.0, 4.4), dpi=100)
    FigureCanvasAgg(fig)
    return fig.add_subplot()


def _line(ax: Axes, prefix: str):
    (line,) = [ln for ln in ax.get_lines() if str(ln.get_label()).startswith(prefix)]
    return line


def _y(line) -> np.ndarray:
    return np.asarray(line.get_ydata(), dtype=np.float64)


def _bracket_ends(ax: Axes, prefix: str) -> np.ndarray:
    """The y of both ends of every bar of the error bar container labelled ``prefix...``."""
    (box,) = [c for c in ax.containers if str(c.get_label()).startswith(prefix)]
    bars = box.lines[2][0]  # (data line, caps, bar collections)
    return np.concatenate([np.asarray(seg)[:, 1] for seg in bars.get_segments()])


def _segments(line) -> np.ndarray:
    """(k, 2) of a NaN-separated line of horizontal two-point segments."""
    y = _y(line)
    return y[np.isfinite(y)].reshape(-1, 2)


# ---------------------------------------------------------------------- bounds
def test_bounds_draws_vstar_its_minimum_and_certified_bounds(case):
    """Dots are V* grouped by partition; each partition's min line is the least V* of its
    states; the lower line sits under every dot of its partition, the upper line over."""
    ax = _axes()
    out = plot.bounds(case["part"], case["dp"], case["nlp"], case["rlp"], ax=ax)
    assert out is ax
    vstar, lab = case["vstar"], case["labels"]
    dots = _line(ax, "V*(x)")
    x, y = np.asarray(dots.get_xdata()), _y(dots)
    assert x.tolist() == list(range(N_STATES))
    # every state once, its V* (the DP's values agree with dense PI to its error bound)
    assert np.sort(y) == pytest.approx(np.sort(vstar.values), abs=1e-8)
    # grouped: states of one partition are contiguous, by V* inside, partitions by min V*
    which = np.array([lab[np.argmin(np.abs(vstar.values - v))] for v in y])
    assert (np.diff(which) != 0).sum() == N_PARTS - 1
    mins = np.array([vstar.values[lab == i].min() for i in range(N_PARTS)])
    levels = _segments(_line(ax, "min V*"))
    assert (levels[:, 0] == levels[:, 1]).all()
    assert levels[:, 0] == pytest.approx(mins[which[np.r_[0, np.flatnonzero(np.diff(which)) + 1]]])
    assert (np.diff(levels[:, 0]) >= 0).all(), "ordered by min V*"
    # lower: the NLP's certified lower end, under w* and so under every V* of the partition
    low = _y(_line(ax, "lower bound"))[::2]  # two vertices per state
    up = _y(_line(ax, "upper bound"))[::2]
    low, up = low[np.isfinite(low)], up[np.isfinite(up)]
    assert low == pytest.approx(case["nlp"].lower_values[which], abs=0)
    assert up == pytest.approx(case["rlp"].upper_values[which], abs=0)
    assert (low <= case["w_nlp"].values[which] + case["w_nlp"].error).all()
    assert (up >= case["v_rlp"].values[which] - case["v_rlp"].error).all()
    assert (low <= y + vstar.error).all() and (y <= up + vstar.error).all()
    # the legend says where each bound comes from, and each entry shows in the image
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(t.startswith("lower bound (NLP, certified") for t in labels), labels
    assert any(t.startswith("upper bound (RLP, certified") for t in labels), labels
    assert not any(t.startswith("outside") for t in labels), labels
    assert_legend_visible(ax.figure, expect=("V*(x)", "lower bound", "upper bound", "min V*"))


def test_bounds_circles_states_outside_a_bound(case):
    """A lower bound raised above some V* is a claim the picture refutes: those states are
    circled, counted in the legend, and the circles show."""
    vstar, lab = case["vstar"].values, case["labels"]
    mins = np.array([vstar[lab == i].min() for i in range(N_PARTS)])
    wrong = mins.copy()
    wrong[0] += 0.5 * (vstar[lab == 0].max() - mins[0]) + 1e-6  # above the partition's least
    want = int((vstar[lab == 0] < wrong[0]).sum())
    ax = plot.bounds(case["labels"], vstar, wrong, ax=_axes())
    circled = _line(ax, "outside the bounds")
    assert circled.get_label() == f"outside the bounds ({want} states)"
    assert np.sort(_y(circled)) == pytest.approx(np.sort(vstar[(lab == 0) & (vstar < wrong[0])]))
    assert_legend_visible(ax.figure, expect=("outside the bounds",))


def test_bounds_per_partition_layout_and_style(case):
    """``layout="partitions"``: partition k of the given order at x = k + 1 with all its
    states; a style update changes one element, ``None`` leaves one out."""
    order = np.arange(N_PARTS)[::-1]
    ax = plot.bounds(
        case["part"],
        case["vstar"].values,
        case["w_nlp"].values,
        case["v_rlp"].values,
        partitions=order,
        layout="partitions",
        ax=_axes(),
        min_line=None,
        upper_line={"color": "black", "label": "v*"},
    )
    dots = _line(ax, "V*(x)")
    x = np.asarray(dots.get_xdata()).astype(int)
    lab = case["labels"]
    assert np.bincount(x, minlength=N_PARTS + 1)[1:].tolist() == np.bincount(lab)[order].tolist()
    up = _line(ax, "v*")
    assert up.get_color() == "black"
    assert _y(up) == pytest.approx(case["v_rlp"].values[order], abs=0)
    assert not [ln for ln in ax.get_lines() if str(ln.get_label()).startswith("min V*")]
    assert [t.get_text() for t in ax.get_xticklabels()] == [str(i) for i in order]
    assert_legend_visible(ax.figure, expect=("V*(x)", "lower bound", "v*"))


def test_min_line_above_crowded_dots_and_the_check_sees_it_hidden():
    """Many states sharing their partition's least V* (the crowding of the paper's Figure
    4): the min line drawn above the dots shows; drawn below them (matplotlib's default
    order), it does not, and the visibility check fails."""
    labels = np.repeat(np.arange(4), 100)
    values = -np.repeat([1.0, 2.0, 3.0, 4.0], 100)  # every state at its partition's least
    ax = plot.bounds(labels, values, order="index", ax=_axes())
    counts = assert_legend_visible(ax.figure, expect=("min V*",))
    assert counts["min V* over the partition"] > 500
    hidden = plot.bounds(labels, values, order="index", ax=_axes(), min_line={"zorder": 1})
    with pytest.raises(AssertionError, match=r"min V\* over the partition"):
        assert_legend_visible(hidden.figure)


def test_bounds_draws_wide_certified_brackets():
    """A DP result whose bracket is wide against the plot is drawn with its bracket: the
    bracket's caps are at the result's lower and upper values."""

    class Loose:
        values = np.array([0.0, 1.0, 2.0, 3.0])
        lower_values = values - 0.25
        upper_values = values + 0.25

    ax = plot.bounds([0, 0, 1, 1], Loose(), ax=_axes(), order="index")
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(t.startswith("certified bracket on V*(x) (width ≤ 0.5)") for t in labels), labels
    ends = np.sort(_bracket_ends(ax, "certified bracket on V*"))
    assert ends == pytest.approx(np.sort(np.r_[Loose.lower_values, Loose.upper_values]))
    assert_legend_visible(ax.figure, expect=("certified bracket",))


# ---------------------------------------------------------------------- gap
def test_gap_is_a_certified_width_over_the_spread(case):
    ax = _axes()
    out = plot.gap(case["part"], case["nlp"], case["rlp"], values=case["vstar"].values, ax=ax)
    assert out is ax
    lab, vstar = case["labels"], case["vstar"].values
    width = case["rlp"].upper_values - case["nlp"].lower_values
    spread = np.array([np.ptp(vstar[lab == i]) for i in range(N_PARTS)])
    order = np.argsort(-width, kind="stable")
    g = _y(_line(ax, "gap"))
    assert (g >= width[order]).all() and g == pytest.approx(width[order], rel=1e-15)
    assert (np.diff(g) <= 0).all(), "widest gap first"
    s = _y(_line(ax, "spread"))
    assert s == pytest.approx(spread[order], abs=1e-8)
    assert (s <= g).all(), "valid bounds: no partition's spread exceeds its gap"
    # the true gap v* - w* (independent) is inside the drawn one
    true = case["v_rlp"].values - case["w_nlp"].values
    assert (true[order] <= g + case["v_rlp"].error + case["w_nlp"].error).all()
    assert_legend_visible(ax.figure, expect=("gap", "spread"))


# ---------------------------------------------------------------------- NLP bracket
def test_nlp_bracket_closes_on_the_exact_optimum(case):
    nlp, rlp = case["nlp"], case["rlp"]
    exact = float(nlp.cost @ case["w_nlp"].values)
    ax = _axes()
    out = plot.nlp_bracket(nlp, reference=rlp, exact=exact, ax=ax)
    assert out is ax
    low, up = _line(ax, "lower bound per round"), _line(ax, "upper bound per round")
    assert np.asarray(low.get_xdata()).tolist() == [float(e.iteration) for e in nlp.log]
    assert _y(low).tolist() == [e.lower for e in nlp.log]
    # each round's bracket holds c'w* (the exact value from strategy iteration)
    tol = float(np.abs(nlp.cost).sum()) * case["w_nlp"].error + 1e-9
    assert (_y(low) <= exact + tol).all() and (_y(up) >= exact - tol).all()
    assert nlp.lower_bound <= exact + tol and exact - tol <= nlp.upper_bound
    ends = _bracket_ends(ax, "certified bracket on c'w*")
    assert sorted(ends) == pytest.approx([nlp.lower_bound, nlp.upper_bound], abs=0)
    ref = _line(ax, "RLP: c'v*")
    assert _y(ref)[0] == rlp.objective_bracket[1] >= exact
    assert_legend_visible(ax.figure, expect=("lower bound", "upper bound", "certified", "RLP"))


def test_nlp_bracket_refuses_a_reference_for_another_cost(case):
    other = RLP(case["mdp"], case["part"], np.arange(1.0, N_STATES + 1.0)).solve()
    with pytest.raises(ValidationError, match="reference: its objective"):
        plot.nlp_bracket(case["nlp"], reference=other, ax=_axes())


# ---------------------------------------------------------------------- DP residuals
def test_dp_residuals_per_sweep(case):
    dp = case["dp_vi"]
    ax = _axes()
    out = plot.dp_residuals(dp, ax=ax)
    assert out is ax and ax.get_yscale() == "log"
    line = _line(ax, "residual per improvement sweep (vi)")
    assert _y(line).tolist() == list(dp.history)
    # value iteration contracts: each residual at most lambda times the previous one
    h = np.asarray(dp.history)
    assert (h[1:] <= case["mdp"].discount * h[:-1] * (1 + 1e-9) + 1e-15).all()
    assert _y(_line(ax, "stopping tolerance"))[0] == dp.tol
    final = _line(ax, "residual of the returned values")
    assert _y(final)[0] == dp.residual <= dp.tol
    # the certified error bound in the legend is residual / (1 - lambda) or wider
    assert dp.error_bound >= dp.residual / (1 - case["mdp"].discount)
    assert np.abs(dp.values - case["vstar"].values).max() <= dp.error_bound + case["vstar"].error
    assert_legend_visible(ax.figure, expect=("residual per", "stopping", "residual of"))


def test_dp_residuals_leaves_out_exact_zeros_and_says_so():
    class Done:
        def __init__(self):
            self.history = [1.0, 0.1, 0.0]
            self.method = "pi"
            self.tol, self.residual, self.error_bound = 1e-3, 0.0, 0.0

    ax = plot.dp_residuals(Done(), ax=_axes())
    line = _line(ax, "residual per improvement sweep (pi); 1 of exactly 0 not shown")
    assert _y(line).tolist() == [1.0, 0.1]
    assert_legend_visible(ax.figure)


def _legend_covers(ax: Axes) -> list[str]:
    """What the legend's box covers: the tolerance line, or a drawn point (display space)."""
    fig = ax.figure
    fig.canvas.draw()
    box = ax.get_legend().get_window_extent(fig.canvas.get_renderer()).padded(2)
    covered = []
    for line in ax.get_lines():
        label = str(line.get_label())
        if label.startswith("stopping tolerance"):
            y = ax.transData.transform((0.0, _y(line)[0]))[1]
            if box.y0 <= y <= box.y1:
                covered.append(label)
            continue
        path = line.get_transform().transform_path(line.get_path())  # display space
        if box.count_contains(path.vertices) or path.intersects_bbox(box, filled=False):
            covered.append(label)
    return covered


@pytest.mark.parametrize("method", ["vi", "mpi", "pi"])
@pytest.mark.parametrize("size", [(8.0, 4.4), (7.0, 4.0), (5.0, 3.0)])
def test_dp_residuals_legend_covers_no_line_nor_point(method, size):
    """MPI's legend used to sit on the tolerance line ("best" finds no free corner for its
    long labels); the legend now has a band of its own above everything drawn."""
    dp = lb.solve_exact(lb.garnet(40, 3, 3, 0.9, seed=1), method)
    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)
    ax = plot.dp_residuals(dp, ax=fig.add_subplot())
    assert not _legend_covers(ax), _legend_covers(ax)
    assert_legend_visible(fig, expect=("residual per", "stopping", "residual of"))


def test_dp_residuals_legend_check_sees_a_covered_line():
    """The check above fails where the legend is put back over the tolerance line."""
    dp = lb.solve_exact(lb.garnet(40, 3, 3, 0.9, seed=1), "mpi")
    ax = plot.dp_residuals(dp, ax=_axes(), legend={"loc": "lower left"})
    assert any(c.startswith("stopping tolerance") for c in _legend_covers(ax))


# ---------------------------------------------------------------------- axes out
@pytest.mark.parametrize("which", ["bounds", "gap", "nlp_bracket", "dp_residuals"])
def test_without_axes_each_plot_makes_a_figure(case, which):
    import matplotlib.pyplot as plt

    calls = {
        "bounds": lambda: plot.bounds(case["part"], case["dp"], case["nlp"], case["rlp"]),
        "gap": lambda: plot.gap(case["part"], case["nlp"], case["rlp"]),
        "nlp_bracket": lambda: plot.nlp_bracket(case["nlp"]),
        "dp_residuals": lambda: plot.dp_residuals(case["dp"]),
    }
    ax = calls[which]()
    try:
        assert isinstance(ax, Axes) and ax.figure.axes == [ax]
        assert_legend_visible(ax.figure)
    finally:
        plt.close(ax.figure)


def test_import_selects_no_backend():
    """``import lpbounds.plot`` (and the patrol's figures) imports no matplotlib, and
    drawing a patrol figure leaves the backend the session chose."""
    code = (
        "import sys, lpbounds, lpbounds.plot, lpbounds.patrol.figures as f\n"
        "assert lpbounds.plot is sys.modules['lpbounds.plot']\n"
        "assert 'matplotlib' not in sys.modules, 'imported matplotlib'\n"
        "import matplotlib\n"
        "matplotlib.use('svg')\n"
        "fig, ax = f.subplots()\n"
        "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
        "assert 'matplotlib.pyplot' not in sys.modules or not __import__("
        "'matplotlib.pyplot').get_fignums()\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr


# ---------------------------------------------------------------------- bad input
def _bad_calls(case):
    part, v = case["part"], case["vstar"].values
    m = N_PARTS
    return [
        (lambda: plot.bounds(part, v[:-1]), r"values must have length n_states = 60"),
        (lambda: plot.bounds(part, v, np.zeros(m + 1)), r"lower must have length"),
        (lambda: plot.bounds(part, v, None, np.zeros(7)), r"upper must have length"),
        (
            lambda: plot.bounds(part, v, np.r_[np.nan, np.zeros(m - 1)]),
            r"lower\[0\] = nan is not finite",
        ),
        (lambda: plot.bounds(part, v, states=[0, 60]), r"states\[1\] = 60 is out of range"),
        (lambda: plot.bounds(part, v, states=[3, 3]), r"states\[1\] = 3 is repeated"),
        (lambda: plot.bounds(part, v, partitions=[0, 0]), r"partitions\[1\] = 0 is repeated"),
        (lambda: plot.bounds(part, v, order="size"), r"order"),
        (lambda: plot.bounds(part, v, order="lower"), r"order = 'lower' needs the lower"),
        (lambda: plot.bounds(part, v, layout="grid"), r"layout"),
        (lambda: plot.bounds(part, v, brackets="yes"), r"brackets must be"),
        (lambda: plot.bounds(part, v, ax="axes"), r"ax must be a matplotlib Axes"),
        (lambda: plot.bounds(part, v, dot={}), r"style: unknown element 'dot'"),
        (lambda: plot.bounds(part, v, dots="red"), r"style dots= must be a dict"),
        (lambda: plot.bounds(None, v), r"partition must be a Partition"),
        (lambda: plot.gap(part, None, np.zeros(m)), r"lower is required"),
        (lambda: plot.gap(part, np.zeros(m), np.ones(m), order="min"), r"order = 'min' needs"),
        (lambda: plot.nlp_bracket(case["rlp"]), r"nlp_result must be an NLPResult"),
        (lambda: plot.dp_residuals(case["rlp"]), r"dp_result must be a DPResult"),
    ]


def test_bad_input_is_a_validation_error_naming_the_argument(case):
    for call, message in _bad_calls(case):
        with pytest.raises(ValidationError, match=message):
            call()


def test_a_result_without_a_certified_bracket_bounds_nothing(case):
    class Uncertified:
        formulation = "RLP"
        values = np.zeros(N_PARTS)
        lower_values = upper_values = None

    with pytest.raises(ValidationError, match=r"upper: the RLP result has no certified"):
        plot.bounds(case["part"], case["vstar"].values, None, Uncertified(), ax=_axes())
