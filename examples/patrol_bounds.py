"""Perimeter patrol: the partition bounds UBLP / LBLP against V* on a small instance.

Builds the patrol MDP of ``models/patrol-small.toml`` (paper Section 4, with the
instance's smaller ring), solves it exactly, computes the upper bound ``v*`` (UBLP,
Theorem 4) and the lower bound ``w*`` (LBLP, Theorem 3) from the partitions alone, and
checks the sandwich ``w*(i) <= V*(x) <= v*(i)`` for every state ``x`` of partition
``i``. Saves ``patrol_bounds.png`` (partitions sorted by ``min V*``), the small
counterpart of the paper's Figure 5; ``lpbounds reproduce`` draws the full-size one.

Run: ``python examples/patrol_bounds.py --out .``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import lpbounds as lb
from lpbounds.patrol import PatrolModel
from lpbounds.patrol.bounds import LBLP, UBLP
from lpbounds.patrol.instance import params_from_instance
from lpbounds.tolerances import LP_COMPARE_RTOL


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", nargs="?", default="patrol-small")
    ap.add_argument("--out", default="out/examples", help="folder for the PNG (created)")
    args = ap.parse_args(argv)

    params = params_from_instance(args.model)
    model = PatrolModel(params)
    mdp, part = model.mdp(), model.partition()
    vstar = lb.solve_exact(mdp).values
    up_lp, low_lp = UBLP(params), LBLP(params)
    up, low = up_lp.solve("HIGHS"), low_lp.solve("HIGHS")
    up_fp, low_fp = up_lp.fixed_point(), low_lp.fixed_point()
    tol = LP_COMPARE_RTOL * max(1.0, np.abs(vstar).max())

    print(f"{args.model}: |S| = {mdp.n_states}, M = {part.n_partitions}")
    print(f"UBLP (HiGHS) vs its fixed point: {np.abs(up.values - up_fp).max():.1e}")
    print(f"LBLP (HiGHS) vs its fixed point: {np.abs(low.values - low_fp).max():.1e}")
    lab = part.labels
    lower_margin = float((vstar - low_fp[lab]).min())
    upper_margin = float((up_fp[lab] - vstar).min())
    print(f"min (V* - w*) = {lower_margin:.3e}, min (v* - V*) = {upper_margin:.3e}")
    gap = up_fp - low_fp
    print(f"policy-free gap v* - w* per partition: mean {gap.mean():.3e}, max {gap.max():.3e}")

    minv, maxv = part.aggregate(vstar, "min"), part.aggregate(vstar, "max")
    order = np.argsort(minv, kind="stable")
    k = np.arange(part.n_partitions)
    fig, ax = plt.subplots(figsize=(9, 4.2))
    ax.fill_between(k, minv[order], maxv[order], color="0.8", label="V* range in the partition")
    ax.plot(k, up_fp[order], "r-", lw=1, label="v* (UBLP, upper bound)")
    ax.plot(k, low_fp[order], "b-", lw=1, label="w* (LBLP, lower bound)")
    ax.set(
        xlabel="partition (sorted by min V*)",
        ylabel="value",
        title=f"{args.model}: bounds vs V* ({mdp.n_states} states, {part.n_partitions} partitions)",
    )
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out = Path(args.out) / "patrol_bounds.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(f"wrote {out}")
    ok = lower_margin >= -tol and upper_margin >= -tol
    ok &= np.abs(up.values - up_fp).max() <= tol and np.abs(low.values - low_fp).max() <= tol
    print("w* <= V* <= v* on every state" if ok else "CHECK FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
