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
# # The NLP lower bound: a cutting-plane bracket, round by round
#
# RLP bounds $V^*$ from above. For a bound from below, Section 3.3 of the paper takes the
# *minimum* over each partition instead of the maximum: the disjunctive program (eq. 23-25)
#
# $$
# \begin{array}{l}
# NLP := \min \bar c^T w \quad \text{s.t.} \\
# \qquad w(i) \ge \min_{x \in S_i}
# \Big\{ R_u(x) + \lambda \sum_{l=0}^m p_l\, w(\bar f(x,u,Y_l)) \Big\}
# \quad \forall u,\ i = 1, \dots, M .
# \end{array}
# $$
#
# Each constraint is a disjunction (one of the states of $S_i$ must satisfy it), so the
# feasible set is not convex. Still, $\bar w(i) = \min_{x \in S_i} V^*(x)$ is feasible, and
# the feasible set has a least element $w^*$ (Fact 2 of `lpbounds.rows.system`: the fixed point of
# $(Gw)(i) = \max_u \min_{x \in S_i} [\dots]$, the value of a zero-sum game). Hence
#
# $$
# w^*(i) \le \min_{x \in S_i} V^*(x) \quad \text{for every partition } i .
# $$
#
# lpbounds computes $w^*$ exactly (strategy iteration) and by cutting planes, whose
# every round gives a certified bracket $[\text{lower}, \text{upper}]$ on $\bar c^T w^*$.

# %%
import math

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import lpbounds as lb
from lpbounds.formulations.nlp.problem import NLP

mdp = lb.garnet(40, 3, 3, 0.9, seed=3)
part = lb.random_partition(40, 5, seed=4)
exact = NLP(mdp, part).solve("strategy-iteration")
cw = exact.objective
print(
    f"{mdp.n_states} states, {part.n_partitions} partitions, "
    f"{NLP(mdp, part).n_disjunctions} disjunctions; exact c'w* = {cw:.8f}"
)
exact

# %% [markdown]
# ## The bound itself
#
# Against $V^*$ from exact dynamic programming: $w^*(i) \le \min_{S_i} V^*$ on every
# partition.

# %%
V = lb.solve_exact(mdp).values
pd.DataFrame(
    {
        "w*(i)": exact.values,
        "min V* on S_i": part.aggregate(V, "min"),
        "max V* on S_i": part.aggregate(V, "max"),
    }
).round(4)

# %%
margin = (part.aggregate(V, "min") - exact.values).min()
assert margin >= -1e-9
print(f"min over partitions of (min V* - w*) = {margin:.4f} (a lower bound: >= 0)")

# %% [markdown]
# ## Cutting planes: the bracket closing
#
# Two cut families: the default *monotone* cuts with box resolution (a certified lower
# point lifted round by round) and Balas' *lift-and-project* cuts (every master LP a valid
# lower bound). At every round the bracket must contain $\bar c^T w^*$. Here the
# lift-and-project bracket is the narrower one after 25 rounds (where it is stopped); the
# monotone cuts close theirs to the relative gap asked for, $10^{-9}$, in more rounds.

# %%
runs = {
    "monotone": NLP(mdp, part).solve(
        "cutting-planes", cuts="monotone", max_iter=200, gap_rtol=1e-9
    ),
    "lift-and-project": NLP(mdp, part).solve(
        "cutting-planes", cuts="lift-and-project", max_iter=25, gap_rtol=1e-9
    ),
}
slack = 1e-7 * max(1.0, abs(cw))
for family, run in runs.items():
    for e in run.log:
        assert e.lower <= cw + slack, (family, e.iteration)
        assert not math.isfinite(e.upper) or e.upper >= cw - slack, (family, e.iteration)
    last = run.log[-1]
    print(
        f"{family:>16}: {len(run.log)} rounds, final bracket [{last.lower:.8f}, "
        f"{last.upper:.8f}], gap {last.gap:.1e}"
    )
mono, lap = runs["monotone"].log, runs["lift-and-project"].log
at = len(lap) - 1  # the last round of lift-and-project, the same round of monotone
print(
    f"round {lap[at].iteration}: gap {lap[at].gap:.1e} (lift-and-project), "
    f"{mono[at].gap:.1e} (monotone)"
)
# the words above: narrower after 25 rounds; monotone closes to 1e-9 relative in more
assert lap[at].iteration == mono[at].iteration == 25 and lap[at].gap < mono[at].gap
assert mono[-1].gap <= 1e-9 * max(1.0, abs(cw)) and len(mono) > len(lap)

# %%
fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 3.6))
for (family, run), color in zip(runs.items(), ("tab:blue", "tab:green"), strict=True):
    k = [e.iteration for e in run.log]
    ax.plot(k, [e.lower for e in run.log], ".-", color=color, label=f"{family}: lower")
    upper = [e.upper if math.isfinite(e.upper) else np.nan for e in run.log]
    ax.plot(k, upper, "x:", color=color, label=f"{family}: upper")
    bx.semilogy(
        k, [max(e.gap, 1e-16) / max(1.0, abs(cw)) for e in run.log], ".-", color=color, label=family
    )
ax.axhline(cw, color="k", ls="--", lw=1, label=r"$\bar c^T w^*$ (strategy iteration)")
ax.set(xlabel="round", ylabel=r"bound on $\bar c^T w^*$", title="the bracket")
bx.set(xlabel="round", ylabel="relative gap", title="its width")
for a in (ax, bx):
    a.legend(fontsize=7)
    a.grid(alpha=0.3)
fig.tight_layout()
