"""Remarks 1-2: hard aggregation, soft aggregation, and why Theorem 1 is special.

* Soft aggregation (Remark 2): ALP (eq. 10) with a basis whose rows are positive and
  sum to one. Its optimum moves with the cost: sweep ``c_t = (1 - t) c_1 + t c_2`` and
  watch ``Phi r_t`` change (every one of them is still an upper bound on ``V*``).
* Hard aggregation, LP form: RLP with the 0/1 basis of a partition (each state in the
  feature it weighs most). The same sweep leaves its optimum flat (Theorem 1).
* Hard aggregation, Bertsekas' form (Remark 1): SLP with uniform ``mu``. Not a bound in
  general: the script counts the states where it falls below ``V*``.

Saves ``hard_vs_soft_aggregation.png`` (cost sweep, both LPs) in ``--out``.

Run: ``python examples/hard_vs_soft_aggregation.py --out .``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import lpbounds as lb
from lpbounds.formulations import RLP
from lpbounds.formulations.alp import ALP, find_cost_dependent_alp
from lpbounds.formulations.slp import SLP
from lpbounds.tolerances import LP_COMPARE_RTOL


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/examples", help="folder for the PNG (created)")
    ap.add_argument("--steps", type=int, default=21, help="costs in the sweep")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    ex = find_cost_dependent_alp(args.seed)  # a small instance where ALP depends on c
    mdp, basis = ex.mdp, ex.basis
    vstar = lb.solve_exact(mdp).values
    part = lb.Partition.from_keys(np.argmax(basis, axis=1))  # the hard version of the basis
    ts = np.linspace(0.0, 1.0, args.steps)
    soft, hard = [], []
    for t in ts:
        c = (1 - t) * ex.cost1 + t * ex.cost2
        soft.append(ALP(mdp, basis, c).solve("HIGHS").state_values)
        hard.append(RLP(mdp, part, c).solve("HIGHS").state_values)
    soft, hard = np.array(soft), np.array(hard)
    tol = LP_COMPARE_RTOL * max(1.0, np.abs(vstar).max())

    soft_spread = float((soft.max(axis=0) - soft.min(axis=0)).max())
    hard_spread = float((hard.max(axis=0) - hard.min(axis=0)).max())
    print(f"MDP: {mdp.n_states} states (seed {ex.seed}); soft basis with {basis.shape[1]} features")
    print(f"soft aggregation (ALP): optimum moves by up to {soft_spread:.4g} over the sweep")
    print(f"hard aggregation (RLP): optimum moves by up to {hard_spread:.1e} (Theorem 1)")
    print(
        f"both are upper bounds: min(ALP - V*) = {(soft - vstar).min():.2e}, "
        f"min(RLP - V*) = {(hard - vstar).min():.2e}"
    )

    # Remark 1 on a larger random instance: uniform mu is not a bound
    big = lb.garnet(300, 3, 4, 0.9, seed=7)
    bigpart = lb.random_partition(300, 30, seed=11)
    v_big = lb.solve_exact(big).values
    v_hard = bigpart.lift(SLP(big, bigpart, mu="uniform").fixed_point())
    below = int((v_hard < v_big - tol).sum())
    print(
        f"SLP(uniform mu) on 300 states / 30 partitions: below V* at {below} states "
        f"(by up to {float((v_big - v_hard).max()):.4g}): an approximation, not a bound"
    )

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for x in range(mdp.n_states):
        color = plt.cm.tab10(x % 10)
        ax1.plot(ts, soft[:, x], color=color, label=f"state {x}")
        ax1.axhline(vstar[x], color=color, ls=":", lw=1)
        ax2.plot(ts, hard[:, x], color=color)
        ax2.axhline(vstar[x], color=color, ls=":", lw=1)
    ax1.set(
        title="soft aggregation (ALP, Remark 2): depends on c",
        xlabel="t in c = (1 - t) c1 + t c2",
        ylabel="bound on V*(x)  (dotted: V*)",
    )
    ax2.set(
        title="hard aggregation (RLP, Theorem 1): independent of c",
        xlabel="t in c = (1 - t) c1 + t c2",
    )
    ax1.legend(fontsize=7)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    out = Path(args.out) / "hard_vs_soft_aggregation.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(f"wrote {out}")

    ok = soft_spread > tol and hard_spread <= tol
    ok &= (soft - vstar).min() >= -tol and (hard - vstar).min() >= -tol
    print("Remarks 1-2 illustrated" if ok else "CHECK FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
