"""Theorem 2: lifting with iterated Bellman inequalities (IB, eq. 20-22) does not help.

For L = 1..5, solve IB and check that every block ``v_j`` of the optimum is ``>= v*``
(RLP's optimum) - in fact equal to it, since ``(v*, ..., v*)`` is IB's least feasible
point. Then the general lifted LP (LLP, eq. 18) with random surplus costs ``d >= 0``:
its ``v`` is never below ``v*`` either.

Run: ``python examples/theorem2_no_lifting.py``
"""

from __future__ import annotations

import argparse

import numpy as np

import lpbounds as lb
from lpbounds.formulations import RLP
from lpbounds.formulations.ib import IB, LLP
from lpbounds.tolerances import LP_COMPARE_RTOL


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=120)
    ap.add_argument("--partitions", type=int, default=12)
    ap.add_argument("--max-L", type=int, default=5)
    ap.add_argument("--solver", default="HIGHS")
    ap.add_argument("--seed", type=int, default=5)
    args = ap.parse_args(argv)

    mdp = lb.garnet(args.states, 3, 4, 0.9, seed=args.seed)
    part = lb.random_partition(args.states, args.partitions, seed=args.seed + 1)
    vstar = RLP(mdp, part).fixed_point()
    tol = LP_COMPARE_RTOL * max(1.0, np.abs(vstar).max())
    rng = np.random.default_rng(args.seed)
    ok = True

    print(f"{'L':>2} {'variables':>9} {'min_j min(v_j - v*)':>20} {'max_j max|v_j - v*|':>20}")
    for L in range(1, args.max_L + 1):
        cost = rng.random(mdp.n_states)  # any c >= 0
        res = IB(mdp, part, L, cost=cost).solve(args.solver)
        blocks = res.extra["blocks"]  # (L, M)
        below = float((blocks - vstar).min())
        dev = float(np.abs(blocks - vstar).max())
        ok &= below >= -tol
        print(f"{L:>2} {blocks.size:>9} {below:>20.2e} {dev:>20.2e}")

    print("\nLLP (eq. 18) with random surplus costs d >= 0:")
    for k in range(3):
        d = rng.random((mdp.n_states, mdp.n_actions)) * 10.0**-k
        res = LLP(mdp, part, d).solve(args.solver)
        below = float((res.values - vstar).min())
        ok &= below >= -tol
        print(f"  d scale 1e{-k}: min(v - v*) = {below:.2e}")

    print(f"\ntolerance {tol:.1e}:", "no lifting beats RLP (Theorem 2)" if ok else "CHECK FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
