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
# # Theorem 2: lifting does not improve the restricted LP
#
# RLP (eq. 9) bounds $V^*$ from above by $\Phi v^*$, one value per partition $S_i$. A
# natural hope is to tighten it with more variables, a *lifted* LP whose projection is
# smaller. Section 3.2 of the paper tries two liftings and shows that neither helps.
#
# **Iterated Bellman inequalities** (eq. 20-22): $L$ copies $v_1, \dots, v_L$ of the
# partition values, each constrained by the Bellman rows of the previous one, cyclically,
#
# $$
# \begin{array}{l}
# IB := \min \sum_{j=1}^L \bar c^T v_j \quad \text{s.t.} \\
# \qquad v_{j+1}(i) \ge R_u(x) + \lambda \sum_l p_l\, v_j(\bar f(x,u,Y_l)) \ (j < L), \\
# \qquad v_1(i) \ge R_u(x) + \lambda \sum_l p_l\, v_L(\bar f(x,u,Y_l)),
# \end{array}
# $$
#
# for every $x \in S_i$, $i$ and $u$. For $L = 1$ this is RLP.
#
# **Theorem 2.** Every feasible $(v_1, \dots, v_L)$ has $v_j \ge v^*$ for every block $j$,
# where $v^*$ is RLP's optimum: IB's least feasible point is $(v^*, \dots, v^*)$, so its
# bound is RLP's, whatever $L$ and the cost.
#
# **Surplus lifting** (eq. 18, LLP): add one variable $z_u(x) \ge 0$ per (state, action),
# the surplus of its Bellman inequality, and price it with $d \ge 0$:
#
# $$
# \begin{array}{l}
# LLP := \min \bar c^T v + d^T z \quad \text{s.t.} \\
# \qquad z_u(x) = v(i) - R_u(x) - \lambda \sum_l p_l\, v(\bar f(x,u,Y_l)),\quad z \ge 0 .
# \end{array}
# $$
#
# The projection of its feasible set onto $v$ is RLP's, so its optimal $v$ is never
# below $v^*$ either; a positive $d$ can only push it *up*.

# %%
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import lpbounds as lb
from lpbounds.formulations import RLP
from lpbounds.formulations.ib import IB, LLP

mdp = lb.garnet(60, 3, 4, 0.9, seed=5)
part = lb.random_partition(60, 6, seed=6)
vstar = RLP(mdp, part).fixed_point()  # RLP's optimum, without a solver
tol = 1e-6 * np.abs(vstar).max()
print(mdp)
print("v* =", np.round(vstar, 4))

# %% [markdown]
# ## IB for $L = 1, \dots, 5$
#
# For each $L$, a random cost $c \ge 0$; the table shows the smallest and the largest
# difference between any block $v_j$ of IB's optimum and $v^*$.

# %%
rng = np.random.default_rng(5)
rows = []
for L in range(1, 6):
    res = IB(mdp, part, L, cost=rng.random(mdp.n_states)).solve("HIGHS")
    blocks = res.extra["blocks"]  # shape (L, M): one row per block v_j
    assert (blocks >= vstar - tol).all(), L  # Theorem 2
    assert np.abs(blocks - vstar).max() <= tol, L  # the words below: every block is v*
    rows.append(
        {
            "L": L,
            "variables": blocks.size,
            "min_j min_i (v_j - v*)": f"{(blocks - vstar).min():.1e}",
            "max_j max_i |v_j - v*|": f"{np.abs(blocks - vstar).max():.1e}",
        }
    )
pd.DataFrame(rows).set_index("L")

# %% [markdown]
# Every block is $v^*$ up to the solver's accuracy: $5 \times 6 = 30$ variables give the
# bound that 6 gave.
#
# ## LLP with surplus costs $d \ge 0$
#
# LLP's objective is $\bar c^T v + d^T z$ with $z = A v - R$ ($A$ the rows of RLP), so it
# equals $g^T v - d^T R$ with the effective cost $g = \bar c + A^T d$. While $g \ge 0$ the
# optimum is $v^*$ again (Theorem 1). A surplus cost on the pairs of one partition only
# (here $S_0$) enters $g$ with a negative sign in every partition its rows lead to; once
# it is large enough, the optimal $v$ moves, but only upwards: the bound gets *worse*,
# never better.

# %%
scales = [0.1, 1.0, 10.0, 100.0]
lifted = {}
for s in scales:
    d = np.zeros((mdp.n_states, mdp.n_actions))
    d[part.labels == 0] = s  # price the surplus of the rows of S_0 only
    llp = LLP(mdp, part, d)
    v = llp.solve("HIGHS").values
    assert (v >= vstar - tol).all(), s  # never below RLP's v*
    # the effective cost g = c-bar + A^T d (A: RLP's row of each pair, as LLP builds it)
    a_rows, _ = llp.rows.constraint_matrix()
    x, u = llp.pairs[:, 0], llp.pairs[:, 1]
    g = (
        np.bincount(part.labels, minlength=part.n_partitions)
        + a_rows[llp.rows.pair_row[x, u]].T @ d[x, u]
    )
    if (g >= 0).all():  # the words above: while g >= 0 the optimum is v* again
        assert np.abs(v - vstar).max() <= tol, s
    lifted[s] = v
    low, high = (v - vstar).min(), (v - vstar).max()
    print(f"d = {s:>5g} on S_0: min g {g.min():8.2f}; v - v* between {low:9.2g} and {high:9.2g}")
# "once it is large enough, the optimal v moves, but only upwards"
assert np.abs(lifted[scales[0]] - vstar).max() <= tol
assert (lifted[scales[-1]] - vstar).max() > 100 * tol

# %% [markdown]
# In the figure a bar of height 0 (LLP's $v$ is $v^*$, up to the solver's accuracy) would
# not show; it is drawn as a marker on the zero line, and its legend entry says so.

# %%
fig, ax = plt.subplots(figsize=(8, 3.4))
width = 0.2
i = np.arange(part.n_partitions)
for k, s in enumerate(scales):
    diff = lifted[s] - vstar
    at = i + (k - 1.5) * width
    color = f"C{k}"
    if np.abs(diff).max() <= tol:  # height 0: a marker on the line, said in the legend
        label = f"d = {s:g} on $S_0$: 0 (= $v^*$)"
        ax.plot(at, np.zeros_like(at), "D", color=color, ms=5, clip_on=False, label=label)
    else:
        ax.bar(at, diff, width, color=color, label=f"d = {s:g} on $S_0$")
ax.axhline(0.0, color="k", lw=0.8)
ax.set(
    xlabel="partition i",
    ylabel=r"$v_{LLP}(i) - v^*(i)$",
    title=r"LLP's optimal $v$ minus RLP's $v^*$: never negative",
)
ax.legend(fontsize=8)
ax.grid(alpha=0.3, axis="y")
# every legend entry shows: bars at least 2% of the axes tall, or markers on the zero line
top = ax.get_ylim()[1]
for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
    if hasattr(handle, "patches"):  # a bar series
        assert min(p.get_height() for p in handle.patches) >= 0.02 * top, label
    else:
        assert handle.get_marker() == "D" and not handle.get_clip_on(), label
