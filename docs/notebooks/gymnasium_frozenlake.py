# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
#   lpbounds:
#     requires:
#     - gymnasium
# ---

# %% [markdown]
# # A Gymnasium model: FrozenLake, bounded two ways
#
# Gymnasium's toy-text environments carry their full model, `env.unwrapped.P[s][a] =
# [(p, s', r, terminated), ...]`. `FiniteMDP.from_gymnasium` reads it into an MDP (a
# terminated transition moves to one added absorbing sink with value 0); Gymnasium has no
# discount, so the MDP is given one, here $\lambda = 0.99$.
#
# Two ways to bound $V^*$, both certified from the returned point, not from a solver's
# status:
#
# * **exact DP** (`solve_exact`): a value $V$ with its Bellman residual $r = \|TV - V\|_\infty$
#   gives the bracket $V - \frac{r}{1 - \lambda} \le V^* \le V + \frac{r}{1 - \lambda}$, state by
#   state and very narrow;
# * **aggregation** (RLP on a partition of the map into $2 \times 2$ tiles, one value per
#   tile): $\Phi v^* \ge V^*$ from above (Lemma 1), and from below the value
#   $V_\pi \le V^*$ of the policy $\pi$ greedy with respect to $\Phi v^*$. Its bracket is
#   wide, but it needs only 17 LP variables and one policy evaluation.
#
# This notebook needs Gymnasium (`pip install "lpbounds[notebooks]"` installs it with what
# opens and runs the notebooks).

# %%
import gymnasium as gym
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import lpbounds as lb
from lpbounds import plot
from lpbounds.formulations import RLP

env = gym.make("FrozenLake-v1", map_name="8x8", is_slippery=True)
mdp = lb.FiniteMDP.from_gymnasium(env, 0.99)
n = mdp.n_user_states  # Gymnasium's 64 cells; the sink is state 64
print(mdp)
print("\n".join(row.tobytes().decode() for row in env.unwrapped.desc))

# %% [markdown]
# ## Exact DP and its certified bracket

# %%
exact = lb.solve_exact(mdp)
V = exact.values
width = exact.upper_values - exact.lower_values
assert (exact.lower_values <= V).all() and (V <= exact.upper_values).all()
print(f"V*(start) = {V[0]:.6f}; bracket width at most {width.max():.1e}")
exact

# %% [markdown]
# ## RLP on $2 \times 2$ tiles, and its greedy policy
#
# Tiles $0, \dots, 15$ row by row over the map; the sink is partition 16 on its own.

# %%
row, col = np.divmod(np.arange(n), 8)
part = lb.Partition(np.append((row // 2) * 4 + col // 2, 16))
rlp = RLP(mdp, part).solve("HIGHS")
upper = part.lift(rlp.upper_values)  # the certified upper end, rounded up
pi = lb.greedy_policy(mdp, part.lift(rlp.values))
policy = lb.evaluate_policy(mdp, pi)
lower = policy.lower_values  # V_pi certified from below: V_pi <= V*
# each bracket against the other's certified end: a violation would need a wrong bound
assert (upper >= exact.lower_values).all(), "RLP's upper bound below V*"
assert (lower <= exact.upper_values).all(), "a policy's value above V*"
print(rlp.summary())

# %%
brackets = pd.DataFrame(
    {
        "DP lower": exact.lower_values[:n],
        "DP upper": exact.upper_values[:n],
        "RLP-policy lower": lower[:n],
        "RLP upper": upper[:n],
    }
)
brackets["DP width"] = brackets["DP upper"] - brackets["DP lower"]
brackets["RLP width"] = brackets["RLP upper"] - brackets["RLP-policy lower"]
assert (brackets["RLP width"] >= brackets["DP width"] - 1e-12).all()
assert brackets["DP width"].max() < 1e-9  # the words below
assert rlp.values.size == 17  # 16 tiles and the sink: "17 LP variables"
brackets.index.name = "cell"
brackets.loc[[0, 9, 27, 54, 62]]

# %% [markdown]
# DP's bracket on $V^*$ is narrower than $10^{-9}$ in every cell; the tiles' bracket is
# the price of 17 values for 64 cells (printed below for the start cell). The figure shows every
# cell's $V^*$ against RLP's bound per tile (left) and the greedy policy's shortfall
# $V^* - V_\pi$ on the map (right).

# %%
fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4), width_ratios=(3, 2))
plot.bounds(part, exact, None, rlp, separators=None, ax=ax, legend={"loc": "upper left"})
ax.set(title="V* per cell and RLP's upper bound per tile", ylim=(-0.03, 1.35))
short = (V - policy.values)[:n].reshape(8, 8)
im = bx.imshow(short, cmap="magma_r")
for (r, c), ch in np.ndenumerate(env.unwrapped.desc):
    if ch in b"HG":
        bx.text(c, r, ch.decode(), ha="center", va="center", color="tab:blue")
bx.set(title=r"$V^* - V_\pi$ ($\pi$ greedy for $\Phi v^*$)", xticks=[], yticks=[])
fig.colorbar(im, ax=bx, shrink=0.8)
fig.tight_layout()
mismatch = int((pi[:n] != lb.greedy_policy(mdp, V)[:n]).sum())
print(
    f"start cell: DP bracket [{exact.lower_values[0]:.9f}, {exact.upper_values[0]:.9f}], "
    f"RLP bracket [{lower[0]:.3f}, {upper[0]:.3f}]"
)
print(f"pi differs from an optimal policy in {mismatch} of {n} cells")
