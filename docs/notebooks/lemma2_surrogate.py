# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Lemma 2: the surrogate LP with RLP's duals, and the reduced MDP
#
# RLP (eq. 9) has one constraint per (state, action) pair. The surrogate LP (eq. 12)
# replaces the constraints of each (partition, action) by one weighted sum, with weights
# $\mu_u^i(x) \ge 0$:
#
# $$
# \begin{array}{l}
# SLP(\mu) := \min \bar c^T v \quad \text{s.t.} \\
# \qquad \sum_{x \in S_i} \mu_u^i(x)\, v(i) \ge \sum_{x \in S_i} \mu_u^i(x)
# \Big[R_u(x) + \lambda \sum_{l=0}^m p_l\, v(\bar f(x, u, Y_l))\Big] \quad \forall u,\ i .
# \end{array}
# $$
#
# For an arbitrary $\mu$ it is a relaxation of RLP, $SLP(\mu) \le RLP$, and *not* a bound
# on $V^*$.
#
# **Lemma 2.** With $\bar\mu$, an optimal dual solution of RLP, $SLP(\bar\mu) = RLP$, and
# both have the optimum $v^*$.
#
# Normalising the weights of each $(i, u)$ turns $SLP(\bar\mu)$ into the exact LP of a
# smaller MDP on the partitions (step 2 of Theorem 1's proof): its states are the
# partitions, its actions the pairs $(i, u)$ with positive weight, and its value is $v^*$.
# So RLP's bound is the exact value of an MDP, computable by dynamic programming alone.

# %%
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import lpbounds as lb
from lpbounds.formulations import RLP
from lpbounds.formulations.slp import SLP

mdp = lb.garnet(60, 3, 4, 0.9, seed=2)
part = lb.random_partition(60, 6, seed=3)
vstar = RLP(mdp, part).fixed_point()
tol = 1e-6 * np.abs(vstar).max()
print(mdp)
print("v* =", np.round(vstar, 4))

# %% [markdown]
# ## Two solvers, two different $\bar\mu$, one $v^*$
#
# A simplex method (HiGHS) returns a vertex of the dual polytope: at most one positive
# dual per partition. An interior-point method (Clarabel) stops at a point near the
# optimal face where every dual is positive, tiny or not: its $\bar\mu$ differs from
# HiGHS's only at its own accuracy (below), yet none of its entries is zero, so its reduced
# MDP keeps more actions. Each reduced MDP has the value $v^*$, computed here by exact
# dynamic programming, without any LP.

# %%
rows, duals = [], {}
for solver in ("HIGHS", "CLARABEL"):
    rlp = RLP(mdp, part).solve(solver)
    duals[solver] = rlp.mu  # mu-bar per (state, action): RLP's optimal duals
    slp = SLP.from_rlp(rlp)
    reduced = slp.reduced_mdp()
    v_slp = slp.solve(solver).values
    v_reduced = lb.solve_exact(reduced).values
    assert np.abs(v_slp - vstar).max() <= tol and np.abs(v_reduced - vstar).max() <= tol
    rows.append(
        {
            "solver": solver,
            "positive duals": f"{int((rlp.mu > 1e-9).sum())} of {int(mdp.allowed.sum())}",
            "reduced MDP": f"{reduced.n_states} states, {int(reduced.allowed.sum())} actions",
            "max |v_SLP - v*|": f"{np.abs(v_slp - vstar).max():.1e}",
            "max |V_reduced - v*|": f"{np.abs(v_reduced - vstar).max():.1e}",
        }
    )
pd.DataFrame(rows).set_index("solver")

# %%
gap = np.abs(duals["HIGHS"] - duals["CLARABEL"]).max()
positive = {solver: int((mu > 1e-9).sum()) for solver, mu in duals.items()}
print(f"the two solvers' mu-bar differ by up to {gap:.3g}, yet give the same v*")
print(f"positive duals: {positive}")
# the words above: a vertex has at most M positive duals; the interior point has more,
# and differs from the vertex only at the interior-point method's accuracy
assert positive["HIGHS"] <= part.n_partitions < positive["CLARABEL"]
assert gap < 1e-4

# %% [markdown]
# ## Uniform weights: hard aggregation, not a bound
#
# $\mu$ uniform over each partition is Bertsekas' hard aggregation (Remark 1): the value
# of the MDP whose transitions from $S_i$ average those of its states. It is an
# approximation with no guarantee on either side, not a bound: here it falls below $V^*$
# on every state, by about as much on average as $\Phi v^*$ (RLP) lies above it.

# %%
V = lb.solve_exact(mdp).values
hard = part.lift(SLP(mdp, part, mu="uniform").fixed_point())
upper = part.lift(vstar)
assert (upper >= V - 1e-9).all()
below, above = (V - hard).mean(), (upper - V).mean()
print(f"uniform mu below V* at {int((hard < V - 1e-9).sum())} of {mdp.n_states} states")
print(f"on average: uniform mu {below:.2f} below V*, RLP {above:.2f} above")
assert (hard < V - 1e-9).all()  # "below V* on every state"
assert abs(below - above) < 0.1 * above  # "by about as much on average"

order = np.argsort(V)
fig, ax = plt.subplots(figsize=(8, 3.4))
ax.plot(upper[order] - V[order], "r.", label=r"$\Phi v^* - V^*$ (RLP = SLP($\bar\mu$))")
ax.plot(hard[order] - V[order], "g.", label=r"$\Phi v_{uniform} - V^*$ (hard aggregation)")
ax.axhline(0.0, color="k", lw=0.8)
ax.set(xlabel=r"state (sorted by $V^*$)", ylabel="difference from $V^*$")
ax.legend(fontsize=8)
ax.grid(alpha=0.3)
