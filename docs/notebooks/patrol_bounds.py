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
# # Perimeter patrol: bounds from the partitions alone
#
# The paper's application (Sections 4-6; the model is specified in
# [the perimeter patrol model](../patrol-model.md)): an aerial vehicle patrols a ring of
# nodes, some of them alert stations; the state $x = (l, w, d, \tau_1, \dots, \tau_m)$
# holds its position, direction, dwell time and the age of each station's alert. States
# with the same position, direction, dwell, set of stations with an alert and largest
# age $\bar\tau$ form one partition (Section 4.2).
#
# The partition's structure gives, for each partition $i$ and action $u$, the partitions
# its successors fall in, except at *type-1* partitions under loitering, where the next
# $\bar\tau$ is not determined. Choosing the optimistic successor gives UBLP, the
# pessimistic one LBLP, two LPs over the partitions only (Theorems 3-4):
#
# $$
# w^*(i) \le \min_{x \in S_i} V^*(x) \le V^*(x) \le v^*(i) \quad
# \text{for every } x \in S_i .
# $$
#
# This notebook checks the sandwich on `patrol-small` (6 nodes, 2 stations: 320 states,
# 176 partitions), where $V^*$ is cheap to compute exactly, and repeats the Section 6
# experiment: the policy greedy with respect to $\Phi w^*$ and its value.

# %%
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import lpbounds as lb
from lpbounds import plot
from lpbounds.patrol import PatrolModel
from lpbounds.patrol.bounds import LBLP, UBLP
from lpbounds.patrol.instance import params_from_instance

params = params_from_instance("patrol-small")
model = PatrolModel(params)
mdp, part = model.mdp(), model.partition()
exact = lb.solve_exact(mdp)  # V* by modified policy iteration, with its certified error
V = exact.values
print(f"|S| = {mdp.n_states}, M = {part.n_partitions}, discount {mdp.discount}")
print(f"V*: certified error {exact.error_bound:.1e}")

# %% [markdown]
# ## UBLP and LBLP, solved and recomputed without a solver
#
# Each LP's optimum is also the fixed point of its rows (`fixed_point()`, by iteration,
# no LP): the two must agree.

# %%
up_lp, low_lp = UBLP(params), LBLP(params)
up, low = up_lp.solve("HIGHS"), low_lp.solve("HIGHS")
v_up, w_low = up_lp.fixed_point(), low_lp.fixed_point()
tol = 1e-9 * max(1.0, np.abs(V).max())
assert np.abs(up.values - v_up).max() <= tol and np.abs(low.values - w_low).max() <= tol
print(f"UBLP: HiGHS vs fixed point {np.abs(up.values - v_up).max():.1e}")
print(f"LBLP: HiGHS vs fixed point {np.abs(low.values - w_low).max():.1e}")
up

# %% [markdown]
# ## The sandwich, partition by partition

# %%
lo_V, hi_V = part.aggregate(V, "min"), part.aggregate(V, "max")
assert (w_low <= lo_V + tol).all()  # Theorem 3: a lower bound on min V* over S_i
assert (hi_V <= v_up + tol).all()  # Theorem 4: an upper bound on max V* over S_i
assert (low.upper_values <= lo_V + tol).all() and (up.lower_values >= hi_V - tol).all()
table = pd.DataFrame(
    {
        "w* (LBLP)": w_low,
        "min V* on S_i": lo_V,
        "max V* on S_i": hi_V,
        "v* (UBLP)": v_up,
        "states": np.bincount(part.labels, minlength=part.n_partitions),
    }
)
table["gap v* - w*"] = table["v* (UBLP)"] - table["w* (LBLP)"]
print(f"min over states of V* - w*: {(V - w_low[part.labels]).min():.2e} (>= 0)")
print(f"min over states of v* - V*: {(v_up[part.labels] - V).min():.2e} (>= 0)")
table.sort_values("gap v* - w*", ascending=False).head(8).round(5)

# %% [markdown]
# A partition's gap $v^*(i) - w^*(i)$ has two parts: the spread
# $\max_{S_i} V^* - \min_{S_i} V^*$ of the values inside it, which no bound constant on
# the partition could close, and what the two LPs lose beyond it.

# %%
spread = hi_V - lo_V
excess = table["gap v* - w*"].to_numpy() - spread
assert (excess >= -tol).all()  # valid bounds: the gap covers the spread
print(
    f"gap: max {table['gap v* - w*'].max():.2e}; beyond the spread: median "
    f"{np.median(excess):.1e}, max {excess.max():.1e}"
)
below, above = (lo_V - w_low).max(), (v_up - hi_V).max()
print(f"w* below min V* by at most {below:.1e}; v* above max V* by at most {above:.1e}")
assert below < 0.05 * above  # LBLP is far tighter than UBLP on this instance

# %% [markdown]
# The figure is the small counterpart of the paper's Figure 5: every state's $V^*$ as a
# dot, grouped by partition (sorted by $\min V^*$), both bounds as steps, and
# $\min V^*$ over each partition as the green line that $w^*$ must stay under. LBLP is so
# tight here that its orange steps lie under that green line; the gap is UBLP's.

# %%
widest = np.argsort(-table["gap v* - w*"].to_numpy(), kind="stable")[:12]
fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2), width_ratios=(3, 2))
plot.bounds(part, exact, low, up, separators=None, ax=ax)
ax.set_title(f"all {part.n_partitions} partitions")
plot.bounds(part, exact, low, up, partitions=widest, legend=None, ax=bx)
bx.set_title("the 12 widest gaps")
fig.tight_layout()

# %% [markdown]
# ## Section 6: the greedy policy of the lower bound
#
# $\pi_s$ is greedy with respect to $V_{low} = \Phi w^*$ on the full state space; its
# value $V_{sub}$ solves $(I - \lambda P_{\pi_s}) V = R_{\pi_s}$. The paper's chain is
# $V_{low} \le V_{sub} \le V^* \le V_{up} = \Phi v^*$.

# %%
pi_s = lb.greedy_policy(mdp, part.lift(w_low))
V_sub = lb.evaluate_policy(mdp, pi_s).values
V_low, V_up = part.lift(w_low), part.lift(v_up)
assert (V_low <= V_sub + tol).all() and (V_sub <= V + tol).all() and (V <= V_up + tol).all()
pi_star = lb.greedy_policy(mdp, V)
print(f"V_sub - V_low: min {(V_sub - V_low).min():.2e}; V* - V_sub: max {(V - V_sub).max():.2e}")
print(f"pi_s differs from pi* in {int((pi_s != pi_star).sum())} of {mdp.n_states} states")
