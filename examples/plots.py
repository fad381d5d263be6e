"""The four plots of ``lpbounds.plot`` on a garnet: bounds, gap, NLP bracket, DP residuals.

One random MDP (a garnet: 150 states, 3 actions, 3 successors, discount 0.9) and a random
partition into 10 sets; exact DP gives ``V*``, the NLP (cutting planes) the certified
lower bound ``w*``, the RLP the certified upper bound ``v*``. Before drawing, the script
checks what the pictures show, against the results' certified ends:

* ``w*(i) <= V*(x) <= v*(i)`` for every state ``x`` of every partition ``i`` (beyond
  ``V*``'s own certified bracket, Theorem 3's sandwich);
* the NLP's certified bracket contains ``c'w*`` from strategy iteration (an exact, finite
  method), and ``c'w* <= c'v*``;
* the last DP residual is below its stopping tolerance, and its error bound is at least
  ``residual / (1 - lambda)``.

The figures are drawn on matplotlib :class:`~matplotlib.figure.Figure` objects (no pyplot,
no backend selected) and written as ``plot_bounds.png``, ``plot_bounds_partitions.png``,
``plot_gap.png``, ``plot_nlp_bracket.png`` and ``plot_dp_residuals.png`` into ``--out``
(default: a new temporary directory; the path is printed). The images of docs/plots.md
are made by ``python examples/plots.py --out docs/img``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import lpbounds as lb
from lpbounds import plot
from lpbounds.formulations import RLP
from lpbounds.formulations.nlp.problem import NLP

DPI = 110


def _axes(width: float = 8.0, height: float = 4.2):
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.add_subplot()


def _checks(mdp, part, dp, lower, upper, exact) -> list[str]:
    """The claims the figures show, each checked on certified ends; the failures."""
    failed = []
    lab = np.asarray(part.labels)
    if not (lower.lower_values[lab] <= dp.lower_values).all():
        failed.append("w*(i) <= V*(x) for every x in S_i")
    if not (dp.upper_values <= upper.upper_values[lab]).all():
        failed.append("V*(x) <= v*(i) for every x in S_i")
    if not lower.lower_bound <= exact.objective <= lower.upper_bound:
        failed.append("the NLP's certified bracket contains c'w* (strategy iteration)")
    if not exact.objective <= float(lower.cost @ upper.values):
        failed.append("c'w* <= c'v*")
    vi = lb.solve_exact(mdp, "vi")
    if not (vi.history[-1] <= vi.tol and vi.error_bound >= vi.residual / (1 - mdp.discount)):
        failed.append("value iteration stops below its tolerance, error >= residual/(1-lambda)")
    return failed


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=150)
    ap.add_argument("--partitions", type=int, default=10)
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument("--out", default=None, help="folder for the PNGs (default: a temp dir)")
    args = ap.parse_args(argv)
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="lpbounds-plots-"))
    out.mkdir(parents=True, exist_ok=True)

    mdp = lb.garnet(args.states, 3, 3, 0.9, seed=args.seed)
    part = lb.random_partition(args.states, args.partitions, seed=args.seed + 1)
    dp = lb.solve_exact(mdp)
    lower = NLP(mdp, part).solve("cutting-planes")
    upper = RLP(mdp, part).solve()
    exact = NLP(mdp, part).solve("strategy-iteration")
    print(
        f"garnet: {mdp.n_states} states, {part.n_partitions} partitions; "
        f"c'w* = {exact.objective:.6f} in [{lower.lower_bound:.6f}, {lower.upper_bound:.6f}]"
    )
    failed = _checks(mdp, part, dp, lower, upper, exact)
    for claim in failed:
        print(f"CHECK FAILED: {claim}")

    figures = {}
    fig, ax = _axes(9.0, 4.4)
    plot.bounds(part, dp, lower, upper, ax=ax, legend={"fontsize": 8, "loc": "lower right"})
    ax.set_title("V* per state against the NLP's lower and the RLP's upper bound")
    figures["plot_bounds.png"] = fig
    fig, ax = _axes(9.0, 4.4)
    plot.bounds(part, dp, lower, upper, layout="partitions", ax=ax)
    ax.set_title('The same, one x per partition (layout="partitions")')
    figures["plot_bounds_partitions.png"] = fig
    fig, ax = _axes()
    plot.gap(part, lower, upper, values=dp, ax=ax)
    ax.set_title("Gap v* - w* per partition, against the spread of V* inside it")
    figures["plot_gap.png"] = fig
    fig, ax = _axes()
    plot.nlp_bracket(lower, reference=upper, exact=exact.objective, ax=ax)
    ax.set_title("The NLP's bracket on c'w*, round by round (cutting planes)")
    figures["plot_nlp_bracket.png"] = fig
    fig, ax = _axes(7.0, 4.0)
    plot.dp_residuals(lb.solve_exact(mdp, "vi"), ax=ax)
    ax.set_title("Value iteration: Bellman residual per sweep")
    figures["plot_dp_residuals.png"] = fig
    for name, fig in figures.items():
        fig.savefig(out / name)
    print(f"wrote {', '.join(figures)} in {out}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
