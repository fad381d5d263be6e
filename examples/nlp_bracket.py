"""The disjunctive lower-bound program (NLP, eq. 25): the cutting-plane bracket, round by round.

Every master LP of Balas' cutting-plane method gives a valid lower bound on ``c'w*``;
every feasible point found gives an upper bound. The script prints the bracket at each
round next to the exact optimum (strategy iteration, a finite exact method) and checks
that the bracket always contains it. It also checks the bound itself:
``w*(i) <= min_{x in S_i} V*(x)``. Saves ``nlp_bracket.png`` in ``--out``.

How far the bracket closes depends on the instance: where the method stalls, the
result says so (``converged``, ``stop_reason``); see docs/nlp.md for measured runs.

Run: ``python examples/nlp_bracket.py --out .``
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import lpbounds as lb
from lpbounds.formulations.nlp import NLP


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=40)
    ap.add_argument("--partitions", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=40)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--out", default=".", help="folder for the PNG")
    args = ap.parse_args(argv)

    mdp = lb.garnet(args.states, 3, 3, 0.9, seed=args.seed)
    part = lb.random_partition(args.states, args.partitions, seed=args.seed + 1)
    exact = NLP(mdp, part).solve("strategy-iteration")
    cw = exact.objective
    cp = NLP(mdp, part).solve("cutting-planes", max_iter=args.rounds)
    scale = max(1.0, abs(cw))
    tol = 1e-7 * scale  # the bracket's own numerical slack (cut safety margins are 1e-9)

    print(
        f"NLP on {mdp.n_states} states, {part.n_partitions} partitions, "
        f"{NLP(mdp, part).n_disjunctions} disjunctions; exact c'w* = {cw:.8f}"
    )
    print(f"{'round':>5} {'lower':>14} {'upper':>14} {'gap':>10} {'cuts':>5}")
    ok = True
    for e in cp.log:
        inside = (e.lower <= cw + tol) and (not math.isfinite(e.upper) or e.upper >= cw - tol)
        ok &= inside
        print(
            f"{e.iteration:>5} {e.lower:>14.8f} {e.upper:>14.8f} {e.gap:>10.2e} "
            f"{e.cuts_added:>5}{'' if inside else '  <- does not contain c*w*'}"
        )
    print(cp.summary())

    vstar = lb.solve_exact(mdp).values
    minv = part.aggregate(vstar, "min")
    margin = float((minv - exact.values).min())
    ok &= margin >= -tol
    print(f"min over partitions of (min_S_i V* - w*) = {margin:.3e} (a lower bound: >= 0)")

    rounds = [e.iteration for e in cp.log]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(rounds, [e.lower for e in cp.log], "b.-", label="master LP (lower bound)")
    upper = [e.upper if math.isfinite(e.upper) else np.nan for e in cp.log]
    ax.plot(rounds, upper, "r.-", label="best feasible point (upper bound)")
    ax.axhline(cw, color="k", ls="--", lw=1, label="c'w* (strategy iteration)")
    ax.set(xlabel="round", ylabel="bound on c'w*", title="NLP cutting planes: the bracket")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out = Path(args.out) / "nlp_bracket.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(f"wrote {out}")
    print("the bracket contains c'w* at every round" if ok else "CHECK FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
