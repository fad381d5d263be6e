"""Lemma 2: the surrogate LP with RLP's optimal duals equals RLP, via a reduced MDP.

Solve RLP with two solvers: their dual variables ``mu-bar`` (the paper's
``mu_u^i(x)``) generally differ, but for each of them ``SLP(mu-bar)`` (eq. 12) has the
same optimum ``v*`` as RLP, and that ``v*`` is the exact value of the reduced MDP on the
partitions built from ``mu-bar`` (step 2 of Theorem 1's proof), computed here by exact
dynamic programming without any LP.

Run: ``python examples/lemma2_surrogate.py``
"""

from __future__ import annotations

import argparse

import numpy as np

import lpbounds as lb
from lpbounds.formulations import RLP
from lpbounds.formulations.slp import SLP
from lpbounds.tolerances import LP_COMPARE_RTOL


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=150)
    ap.add_argument("--partitions", type=int, default=15)
    ap.add_argument("--solvers", nargs="+", default=["HIGHS", "CLARABEL"])
    ap.add_argument("--seed", type=int, default=2)
    args = ap.parse_args(argv)

    mdp = lb.garnet(args.states, 3, 4, 0.9, seed=args.seed)
    part = lb.random_partition(args.states, args.partitions, seed=args.seed + 1)
    vstar = RLP(mdp, part).fixed_point()
    tol = LP_COMPARE_RTOL * max(1.0, np.abs(vstar).max())
    ok = True
    mus = {}
    for solver in args.solvers:
        rlp = RLP(mdp, part).solve(solver)
        mus[solver] = rlp.mu
        slp = SLP.from_rlp(rlp).solve(solver)
        reduced = SLP.from_rlp(rlp).reduced_mdp()
        v_red = lb.solve_exact(reduced).values
        d_slp = float(np.abs(slp.values - vstar).max())
        d_red = float(np.abs(v_red - vstar).max())
        ok &= d_slp <= tol and d_red <= tol
        print(
            f"{solver:<9} RLP {rlp.objective:.6f}  SLP(mu-bar) {slp.objective:.6f}  "
            f"max|v_SLP - v*| {d_slp:.1e}  reduced MDP ({reduced.n_states} states, "
            f"{int(reduced.allowed.sum())} actions): max|V_red - v*| {d_red:.1e}"
        )
    if len(mus) > 1:
        a, b = list(mus.values())[:2]
        print(f"the duals of the first two solvers differ by up to {np.abs(a - b).max():.2e}")
    uniform = SLP(mdp, part, mu="uniform").fixed_point()
    print(f"uniform mu (hard aggregation): max|v - v*| = {np.abs(uniform - vstar).max():.3e}")
    print(f"tolerance {tol:.1e}:", "Lemma 2 holds" if ok else "CHECK FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
