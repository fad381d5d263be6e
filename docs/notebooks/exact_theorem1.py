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
# # Theorem 1, proved exactly on one instance
#
# **Theorem 1** of the paper: the restricted LP (eq. 9),
#
# $$
# \begin{array}{l}
# RLP := \min \sum_{i=1}^M \bar c(i)\, v(i) \quad \text{s.t.} \\
# \qquad v(i) \ge R_u(x) + \lambda \sum_{l} p_l\, v(\bar f(x, u, Y_l))
# \quad \forall x \in S_i,\ \forall u ,
# \end{array}
# $$
#
# has the same optimum $v^*$ for every cost $c \ge 0$. The float notebook
# ([Theorem 1: RLP and its cost](theorem1_cost_independence.md)) shows it *within certified
# widths*. Here it is shown **exactly**: every number a model stores is a double, and every
# double is a dyadic rational ($0.9 = 8106479329266893 / 2^{53}$), so the stored model has
# one exact $v^*$, and lpbounds computes it in rational arithmetic, proves it optimal for
# each cost with an exact primal and dual, and writes the proof into a file that Python's
# standard library checks alone (docs: [Exact arithmetic](../exact.md)).

# %%
import json
import subprocess
import sys
import tempfile
from fractions import Fraction
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import lpbounds as lb
from lpbounds.exact import check as checker
from lpbounds.formulations import RLP
from lpbounds.studies.exact_claims import ExactInstance, write_certificates

mdp = lb.garnet(8, 2, 3, 0.9, seed=5)  # 8 states, 2 actions, 3 outcomes per pair
part = lb.random_partition(8, 3, seed=2)  # M = 3 partitions
print(mdp)
print(part)
assert Fraction(mdp.discount) == Fraction(8106479329266893, 2**53)  # the stored 0.9

# %% [markdown]
# ## RLP's exact optimum for three costs
#
# Three state costs: all ones, random positive weights, and one with zeros on every other
# state. Each RLP is solved by two solvers of different kinds (HiGHS, a simplex method;
# Clarabel, an interior-point method) with `arithmetic="rational"`: the solver's answer is
# kept, and beside it the LP's exact optimum (`result.exact`), here the exact least fixed
# point of RLP's rows with its policy's occupation measure as the dual, both verified in
# rationals before the result is returned.

# %%
rng = np.random.default_rng(0)
costs = {
    "ones": np.ones(8),
    "random": rng.uniform(0.1, 2.0, 8),
    "zeros": np.where(np.arange(8) % 2 == 0, 1.0, 0.0),
}
solvers = ("HIGHS", "CLARABEL")
results = {
    (name, s): RLP(mdp, part, c).solve(s, arithmetic="rational")
    for name, c in costs.items()
    for s in solvers
}
exact = {key: list(r.exact.values) for key, r in results.items()}
vstar = exact["ones", "HIGHS"]
for i, t in enumerate(vstar):
    print(f"v*({i}) = {t.numerator} / {t.denominator}")
    print(f"       ~ {float(t):.17g}")

# %% [markdown]
# Theorem 1, exactly: the optimum is the same $v^*$, equal as rational numbers, for every
# cost and both solvers' runs (the exact optimum does not depend on which solver ran: its
# answer only chooses where the exact computation starts).

# %%
assert all(values == vstar for values in exact.values())
bits = max(t.denominator.bit_length() for t in vstar)
print(f"one optimum for {len(exact)} (cost, solver) pairs; denominators of {bits} bits")
assert bits > 53  # far more than a double carries

# %% [markdown]
# ## How far each float solver really was
#
# No double equals $v^*(i)$: its denominator is not a power of two. So every float answer
# is off by something, and now that something is known exactly: the exact error
# $\max_i |v_{\text{solver}}(i) - v^*(i)|$, computed in rationals. Each solver's
# certified bracket (`lower_values`, `upper_values`) contained $v^*$ exactly.

# %%
assert all(t.denominator & (t.denominator - 1) != 0 for t in vstar)  # not dyadic
rows = []
for (name, s), r in results.items():
    e = r.exact
    err = max(abs(Fraction(float(v)) - t) for v, t in zip(r.values, vstar, strict=True))
    assert err == e.error and err > 0  # the package's exact error, recomputed here
    assert e.inside_bracket
    assert all(
        Fraction(float(lo)) <= t <= Fraction(float(hi))
        for lo, hi, t in zip(r.lower_values, r.upper_values, vstar, strict=True)
    )
    rows.append((name, s, float(err), float(np.max(r.upper_values - r.lower_values))))
    print(f"{name:7s} {s:9s} exact error {float(err):.3e}   bracket width {rows[-1][3]:.3e}")

fig, ax = plt.subplots(figsize=(7, 3.2))
labels = [f"{n}\n{s}" for n, s, *_ in rows]
ax.bar(np.arange(len(rows)) - 0.2, [r[2] for r in rows], 0.4, label="exact error")
ax.bar(np.arange(len(rows)) + 0.2, [r[3] for r in rows], 0.4, label="certified bracket width")
ax.set_yscale("log")
ax.set_xticks(np.arange(len(rows)), labels, fontsize=8)
ax.set_ylabel("value units")
ax.set_title("RLP: each float answer's exact error and its certified bracket")
ax.legend(fontsize=8)
fig.tight_layout()

# %% [markdown]
# The bars say the same as the asserts: every exact error is positive, and no larger than
# the width of the bracket that contains $v^*$ (the float answer lies in its own bracket).

# %%
for name, s, err, width in rows:
    assert 0 < err <= width, (name, s)

# %% [markdown]
# ## A certificate, checked by hand
#
# `ExactInstance.decide` decides the paper's claims on the instance and writes each as a
# certificate: the model (every double as a hex float), each LP's exact optimum `x` and
# dual `y`, the fixed point $v^*$, and the comparisons with their exact differences.

# %%
inst = ExactInstance("garnet-8", mdp, part, costs=list(costs.values()), ib_blocks=(1, 2))
(verdict,) = inst.decide(["Theorem 1"])
print(verdict)
assert verdict.verdict == lb.Verdict.HOLDS and verdict.difference == 0
folder = Path(tempfile.mkdtemp())
(path,) = write_certificates([verdict], folder)
cert = json.loads(path.read_text())
print(path.name, f"{path.stat().st_size:,} bytes:", [e["id"] for e in cert["lps"]])

# %% [markdown]
# By hand, with nothing but `json` and `fractions`: rebuild RLP's rows from the model data,
# then check what proves `x` optimal for the cost `c̄` of the first LP: every row holds at
# `x` (primal feasible), `y ≥ 0` and `A'y = c̄` (dual feasible), and `c̄'x = b'y` (equal
# objectives; by weak duality no feasible point does better).

# %%
model, lp = cert["model"], cert["lps"][0]
assert "allowed" not in model and "shared_probabilities" not in model  # every (x, u), as here


def vec(v):
    den = int(v["den"], 0)
    return [Fraction(int(n, 0), den) for n in v["num"]]


lam, label = Fraction(float.fromhex(model["discount"])), model["partition"]
M = max(label) + 1
A, b = [], []  # one row per (x, u): v(label x) - lam sum_l p_l v(label f) >= R_u(x)
for x in range(model["n_states"]):
    for u in range(model["n_actions"]):
        a = [Fraction(0)] * M
        a[label[x]] += 1
        for t, p in zip(model["successors"][x][u], model["probabilities"][x][u], strict=True):
            a[label[t]] -= lam * Fraction(float.fromhex(p))
        A.append(a)
        b.append(Fraction(float.fromhex(model["rewards"][x][u])))
cbar = [Fraction(float.fromhex(t)) for t in lp["lp"]["cost"]]
x, y = vec(lp["x"]), vec(lp["y"])
slacks = [
    sum(a_j * x_j for a_j, x_j in zip(a, x, strict=True)) - b_r for a, b_r in zip(A, b, strict=True)
]
assert min(slacks) >= 0  # primal feasible
assert min(y) >= 0 and all(
    sum(y[r] * A[r][j] for r in range(len(A))) == cbar[j] for j in range(M)
)  # dual feasible
obj = sum(c * t for c, t in zip(cbar, x, strict=True))
assert obj == sum(y_r * b_r for y_r, b_r in zip(y, b, strict=True)) == Fraction(lp["objective"])
assert x == vstar  # the optimum is v*, the same as above
print(
    f"{len(A)} rows hold at x (the smallest slack {float(min(slacks)):.3e}); A'y = c̄; "
    f"c̄'x = b'y = {float(obj):.15g}"
)

# %% [markdown]
# The checker does this for every LP of the file, checks the fixed point $v^* = T v^*$,
# and recomputes each comparison. It is one file of the standard library's Python: run it
# as a plain script in an isolated interpreter without site-packages (`-I -S`).

# %%
run = [sys.executable, "-I", "-S", checker.__file__, str(path)]
done = subprocess.run(run, capture_output=True, text=True, cwd="/")
print(done.stdout.strip())
assert done.returncode == 0 and ": OK: Theorem 1 holds" in done.stdout

# %% [markdown]
# Change one number of the proof, the first entry of the second LP's dual, and the checker
# refuses the file, naming the entry.

# %%
cert["lps"][1]["y"]["num"][0] = str(int(cert["lps"][1]["y"]["num"][0], 0) + 1)
bad = folder / "tampered.json"
bad.write_text(json.dumps(cert))
done = subprocess.run([*run[:-1], str(bad)], capture_output=True, text=True, cwd="/")
print(done.stdout.strip())
assert done.returncode == 1 and "lps[1] 'RLP c2'" in done.stdout
