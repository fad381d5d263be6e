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
# # Theorem 1: the restricted LP does not depend on its cost
#
# A discounted MDP in the paper's notation: states $x$, actions $u$, random outcomes
# $Y_l$ with probabilities $p_l$ ($l = 0, \dots, m$), next state $f(x, u, Y_l)$, reward
# $R_u(x)$ and discount $\lambda < 1$. Its optimal value function solves
#
# $$
# V^*(x) = \max_u \Big[ R_u(x) + \lambda \sum_{l=0}^m p_l\, V^*(f(x, u, Y_l)) \Big].
# $$
#
# Hard aggregation partitions the states into $S_1, \dots, S_M$ and asks for one value per
# partition, $V(x) = v(i)$ for $x \in S_i$, written $V = \Phi v$; $\bar f(x, u, Y_l)$ is the
# partition of $f(x, u, Y_l)$. With state weights $c(x) \ge 0$ and
# $\bar c(i) = \sum_{x \in S_i} c(x)$, the restricted LP (eq. 9) is
#
# $$
# \begin{array}{l}
# RLP := \min \sum_{i=1}^M \bar c(i)\, v(i) \quad \text{s.t.} \\
# \qquad v(i) \ge R_u(x) + \lambda \sum_{l=0}^m p_l\, v(\bar f(x, u, Y_l))
# \quad \forall x \in S_i,\ \forall u .
# \end{array}
# $$
#
# **Theorem 1.** The optimal $v^*$ is the same for every cost $c \ge 0$ (and the only
# optimum when every $\bar c(i) > 0$); by Lemma 1, $\Phi v^* \ge V^*$.
#
# This notebook solves RLP for several costs, some with zeros, on two solvers of
# different kinds (HiGHS: simplex; Clarabel: interior point), and compares every optimum
# with $v^*$ computed without any LP.

# %%
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import lpbounds as lb
from lpbounds.formulations import RLP
from lpbounds.formulations.nlp.problem import NLP

mdp = lb.garnet(60, 3, 4, 0.9, seed=3)  # 60 states, 3 actions, 4 outcomes per pair
part = lb.random_partition(60, 6, seed=4)  # M = 6 partitions
print(mdp)
print(part)

# %% [markdown]
# ## $v^*$ without a solver
#
# Why the cost does not matter (Fact 1 of `lpbounds.rows.system`): the operator
# $(Tv)(i) = \max_{x \in S_i,\, u} \big[ R_u(x) + \lambda \sum_l p_l\, v(\bar f(x,u,Y_l)) \big]$
# is monotone and a $\lambda$-contraction, so it has one fixed point $v^*$. A feasible $v$
# satisfies $v \ge Tv$, hence $v \ge T^k v \to v^*$: $v^*$ is feasible and below every
# feasible point, so $\bar c^T v \ge \bar c^T v^*$ for every $\bar c \ge 0$.
# `RLP.fixed_point()` computes it by iterating $T$; `solve_exact` gives $V^*$.

# %%
vstar = RLP(mdp, part).fixed_point()  # the least feasible point of RLP, no LP solved
exact = lb.solve_exact(mdp)  # V* by modified policy iteration, with its error bound
print("v* =", np.round(vstar, 4))
print(f"V*: error bound {exact.error_bound:.1e}")

# %% [markdown]
# ## The same optimum for every cost and solver

# %%
rng = np.random.default_rng(0)
with_zeros = rng.random(60)
with_zeros[rng.random(60) < 0.4] = 0.0  # c >= 0 may vanish on many states
costs = {"all ones": np.ones(60), "random": rng.random(60), "40% zeros": with_zeros}
tol = 1e-6 * np.abs(vstar).max()

rows = []
for name, c in costs.items():
    for solver in ("HIGHS", "CLARABEL"):
        res = RLP(mdp, part, cost=c).solve(solver)
        deviation = np.abs(res.values - vstar).max()
        assert deviation <= tol, (name, solver, deviation)
        rows.append(
            {
                "cost": name,
                "solver": solver,
                "status": str(res.status),
                "objective": f"{res.objective:.4f}",
                "max |v - v*|": f"{deviation:.1e}",
            }
        )
# the optimal point is one, the objectives c-bar'v* are as many as the costs
assert len({r["objective"] for r in rows}) == len(costs)
pd.DataFrame(rows)

# %% [markdown]
# The objectives differ (they are $\bar c^T v^*$ for different $\bar c$); the optimal point
# does not, up to the solvers' accuracy.
#
# ## An upper bound on $V^*$, and how good it is
#
# $\Phi v^* \ge V^*$ on every state. How tight it is depends on the partition, never on the
# cost. For the picture, the lower bound of Section 3.3 (the NLP of eq. 23-25, whose
# optimum $w^*$ satisfies $w^*(i) \le \min_{x \in S_i} V^*(x)$) brackets each partition
# from below.

# %%
w = NLP(mdp, part).solve("strategy-iteration").values
upper = part.lift(vstar)
assert (upper >= exact.values - 1e-9).all()  # Lemma 1: an upper bound
assert (part.lift(w) <= exact.values + 1e-9).all()  # Section 3.3: a lower bound

order = np.lexsort((exact.values, part.labels))  # states by partition, then by V*
x = np.arange(mdp.n_states)
fig, ax = plt.subplots(figsize=(8, 3.6))
ax.plot(x, exact.values[order], "k.", label="$V^*(x)$")
ax.step(x, upper[order], "r-", where="mid", label=r"$\Phi v^*$ (RLP, any cost)")
ax.step(x, part.lift(w)[order], "b-", where="mid", label=r"$\Phi w^*$ (NLP)")
ax.set(xlabel="state (grouped by partition)", ylabel="value")
ax.legend(loc="center right", fontsize=8)
ax.grid(alpha=0.3)

# %% [markdown]
# With this random partition the bracket is wide: about 8, where $V^*$ varies by less
# than 1 inside any block (the printout below). Neither LP is off because the values in a
# block differ; each is the value of an MDP on the blocks. RLP's rows let every step take
# the best (state, action) of its block, the NLP's takes its action against the worst
# state of its block, and every block here holds rewards from below 0.25 to above 0.9.
# So per step RLP earns about the best reward of a block and the NLP about the worst, and
# over the horizon $1/(1 - \lambda) = 10$ that puts $v^*$ between 9.6 and 9.7 and $w^*$
# between 1.6 and 1.9, around a $V^*$ between 7.2 and 8.3.

# %%
lam = mdp.discount
spread = part.aggregate(exact.values, "max") - part.aggregate(exact.values, "min")
bracket = vstar - w  # v*(i) - w*(i), one per block
R = mdp.rewards
best_r = np.array([R[part.labels == i].max() for i in range(part.n_partitions)])
worst_r = np.array([R[part.labels == i].min(axis=0).max() for i in range(part.n_partitions)])
print(f"V* spread inside a block: at most {spread.max():.2f}")
print(f"bracket v* - w* per block: {bracket.min():.2f} to {bracket.max():.2f}")
print(f"V* between {exact.values.min():.2f} and {exact.values.max():.2f}")
print(pd.DataFrame({
    "best reward": best_r, "(1 - lambda) v*": (1 - lam) * vstar,
    "worst-case reward": worst_r, "(1 - lambda) w*": (1 - lam) * w,
}).round(3))  # fmt: skip
# the words above, checked: a spread below 1, a bracket of about 8, the ends near the
# best and worst rewards of the blocks
assert spread.max() < 1 and (np.abs(bracket - 8) < 0.5).all()
assert worst_r.max() < 0.25 and best_r.min() > 0.9
assert np.abs((1 - lam) * vstar - best_r).max() < 0.05  # RLP: about the best reward
assert np.abs((1 - lam) * w - worst_r).max() < 0.1  # NLP: about the worst
assert 9.6 <= vstar.min() and vstar.max() <= 9.7 and 1.6 <= w.min() and w.max() <= 1.9
assert 7.2 <= exact.values.min() and exact.values.max() <= 8.3

# %% [markdown]
# A partition that groups states of similar value (below, by the rank of $V^*$, which a
# real application would approximate from its structure) tightens both bounds, a little:
# grouping values does not group rewards, so the bracket stays wide. And $v^*$ is again
# independent of the cost.

# %%
ranked = lb.Partition(np.argsort(np.argsort(exact.values)) * 6 // mdp.n_states)
v_ranked = RLP(mdp, ranked).fixed_point()
w_ranked = NLP(mdp, ranked).solve("strategy-iteration").values
for c in costs.values():
    assert np.abs(RLP(mdp, ranked, cost=c).solve("HIGHS").values - v_ranked).max() <= tol
gaps = pd.DataFrame(
    {
        "max (Phi v* - V*)": [
            (upper - exact.values).max(), (ranked.lift(v_ranked) - exact.values).max(),
        ],
        "max (V* - Phi w*)": [
            (exact.values - part.lift(w)).max(), (exact.values - ranked.lift(w_ranked)).max(),
        ],
        "bracket v* - w*": [bracket.mean(), (v_ranked - w_ranked).mean()],
    },
    index=["random partition", "ranked partition"],
)  # fmt: skip
# "tightens both bounds": the upper and the lower one, each closer to V*
assert (gaps.loc["ranked partition"] < gaps.loc["random partition"]).all()
assert gaps.loc["ranked partition", "bracket v* - w*"] > 5  # "stays wide"
gaps.round(3)
