"""lpbounds against its peers on the paper's problem (the 2,048,000-state patrol MDP).

Peers: mdpsolver (C++/OpenMP, nested-list input) and pymdptoolbox (scipy.sparse input),
installed from the package index (``pip install -e .[bench]``). Every measurement runs in
a fresh process (so its peak RSS is that task's own), tools alternate within each
repetition, and the table reports medians and the ratio lpbounds/peer (< 1: lpbounds
faster). Every exact solve is checked afterwards: its Bellman residual, measured by
lpbounds on the returned vector, against the target 1e-10 max|R|/(1-discount).

Writes the ``peers`` section of docs/benchmarks.md.

    python benchmarks/bench_peers.py [--repeat 3] [--quick]

``--dp`` runs the exact-DP comparison instead (section ``peers-dp``): lpbounds'
default solve, its inexact policy iteration, a 30-line scipy MPI loop, QuantEcon's
DiscreteDP (state-action form, MPI) and mdpsolver on the patrol MDP, a random MDP of the
paper's shape (2,048,000 x 3 x 5) and a mid-size one, alternating within each repetition.
Every answer's Bellman residual is measured by lpbounds after the clock stops.

    python benchmarks/bench_peers.py --dp [--repeat 3] [--models patrol garnet-paper ...]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from _common import machine, run_isolated, today, write_section

ROOT = Path(__file__).resolve().parents[1]

PRELUDE = """
import json, time, numpy as np
import lpbounds as lb
from lpbounds.patrol import PatrolModel, PatrolParams
PARAMS = {params}
lb.solve_exact(PatrolModel(PatrolParams(N=6, stations=(0, 3), Gamma=4)).mdp())  # JIT warm-up
def build():
    t = time.perf_counter()
    mdp = PatrolModel(PatrolParams(**PARAMS)).mdp()
    return mdp, time.perf_counter() - t
def target(mdp):
    return 1e-10 * mdp.reward_absmax / (1 - mdp.discount)
def mdpsolver_model(mdp):
    # mdpsolver takes nested lists (sparse form: probabilities and columns per pair); it
    # has no action masks, so disallowed pairs get reward -1e4. Returns the model and the
    # seconds spent converting and loading.
    import mdpsolver
    P, R = mdp.to_matrices(disallowed_reward=-1e4)
    del P
    t = time.perf_counter()
    probs = np.broadcast_to(mdp.probabilities, mdp.successors.shape).tolist()
    cols = mdp.successors.tolist()
    rew = R.tolist()
    tc = time.perf_counter() - t
    t = time.perf_counter()
    m = mdpsolver.model()
    m.mdp(discount=mdp.discount, rewards=rew, tranMatProbs=probs, tranMatColumns=cols)
    return m, tc, time.perf_counter() - t
def pymdp_patched():
    # pymdptoolbox's input check densifies each transition matrix (n x n float64:
    # 30 TiB here) and ValueIteration._boundIter loops over the n columns in Python;
    # both are replaced by no-ops (max_iter is then the stated limit)
    import mdptoolbox.mdp as tm, mdptoolbox.util as tu
    tu.check = lambda P, R: None
    tm._util.check = tu.check
    def _bound(self, epsilon):
        self.max_iter = 100000
    tm.ValueIteration._boundIter = _bound
    return tm
"""

# ---------------------------------------------------------------------- tasks
BUILD_LB = """
mdp, tb = build()
print(json.dumps({"seconds": tb, "n": mdp.n_states, "pairs": mdp.n_pairs}))
"""

BUILD_MS = """
mdp, tb = build()
m, tc, tl = mdpsolver_model(mdp)
print(json.dumps({"seconds": tb + tc + tl, "build": tb, "convert": tc, "load": tl}))
"""

BUILD_PT = """
mdp, tb = build()
t = time.perf_counter()
P, R = mdp.to_matrices(disallowed_reward=-1e4)
tc = time.perf_counter() - t
print(json.dumps({"seconds": tb + tc, "build": tb, "convert": tc}))
"""

SOLVE_LB = """
mdp, tb = build()
t = time.perf_counter()
r = lb.solve_exact(mdp, "{method}")
ts = time.perf_counter() - t
res = lb.bellman_residual(mdp, r.values)
np.save("{tmp}/vstar.npy", r.values); np.save("{tmp}/pistar.npy", r.policy)
print(json.dumps({{"seconds": ts, "e2e": tb + ts, "residual": res, "tol": target(mdp),
                  "iterations": r.iterations, "sweeps": r.sweeps}}))
"""

SOLVE_MS = """
mdp, tb = build()
m, tc, tl = mdpsolver_model(mdp)
tin = tc + tl
t = time.perf_counter()
m.solve(algorithm="{method}", tolerance=target(mdp), parallel=True, verbose=False)
v = np.array(m.getValueVector())
ts = time.perf_counter() - t
res = lb.bellman_residual(mdp, v)
vstar = np.load("{tmp}/vstar.npy")
print(json.dumps({{"seconds": ts, "e2e": tb + tin + ts, "input": tin, "residual": res,
                  "tol": target(mdp), "max_diff_vs_lpbounds": float(np.abs(v - vstar).max())}}))
"""

SOLVE_PT = """
tm = pymdp_patched()
mdp, tb = build()
t = time.perf_counter()
P, R = mdp.to_matrices(disallowed_reward=-1e4)
tin = time.perf_counter() - t
tol = target(mdp)
# its stopping rule (span of V_k - V_k-1 below epsilon (1 - lambda) / lambda) does not
# bound the residual ||T V - V||: with epsilon = tol / 100 it stopped at 76 iterations
# with residual 3e-7. So it runs a fixed number of iterations K, the smallest with
# lambda^K ||T 0 - 0|| <= tol (plain VI from 0: ||T V_K - V_K|| <= lambda^K ||T 0||)
import math
res0 = lb.bellman_residual(mdp, np.zeros(mdp.n_states))
k_iter = math.ceil(math.log(tol / res0) / math.log(mdp.discount))
t = time.perf_counter()
vi = tm.ValueIteration(P, R, mdp.discount, epsilon=1e-300, max_iter=k_iter)
vi.max_iter = k_iter  # (the patched _boundIter set it to 100,000)
vi.run()
v = np.array(vi.V)
ts = time.perf_counter() - t
res = lb.bellman_residual(mdp, v)
vstar = np.load("{tmp}/vstar.npy")
print(json.dumps({{"seconds": ts, "e2e": tb + tin + ts, "input": tin, "residual": res,
                  "tol": tol, "iterations": vi.iter,
                  "max_diff_vs_lpbounds": float(np.abs(v - vstar).max())}}))
"""

# The plain scipy MPI loop of both peer comparisons (the patrol peers and --dp): 5
# evaluation sweeps per improvement, Porteus shift. Reads ``rt`` (the rewards stacked by
# action), ``big`` (the (A n) x n CSR: one product gives every Q-value), ``lam``, ``tol``,
# ``n`` and ``A``; leaves ``v``, ``its`` (improvement steps) and ``sweeps``.
SCIPY_MPI_LOOP = """
v = np.zeros(n)
its = sweeps = 0
while True:
    q = (rt + lam * (big @ v)).reshape(A, n)
    pol = q.argmax(axis=0)
    tv = q[pol, np.arange(n)]
    d = tv - v
    sweeps += 1
    if max(-d.min(), d.max()) <= tol:
        break
    its += 1
    v = tv + lam / (1 - lam) * 0.5 * (d.min() + d.max())
    p_pi = big[pol * n + np.arange(n)]
    r_pi = rt[pol * n + np.arange(n)]
    for _ in range(5):
        nv = r_pi + lam * (p_pi @ v)
        d = nv - v
        v = nv + lam / (1 - lam) * 0.5 * (d.min() + d.max())
        sweeps += 1
"""

SOLVE_NP = (
    """
# the plain vectorised numpy/scipy MPI of the issue: the algorithm of lpbounds'
# solve_exact(eval_sweeps=5) (5 evaluation sweeps per improvement, Porteus shift; the
# default "auto" skips them while the policy changes), on scipy.sparse matrices
import scipy.sparse as sp
mdp, tb = build()
t = time.perf_counter()
P, R = mdp.to_matrices(disallowed_reward=-1e4)
tin = time.perf_counter() - t
tol, lam, n = target(mdp), mdp.discount, mdp.n_states
t = time.perf_counter()
big = sp.vstack(P).tocsr()  # (A n) x n: one product gives every Q-value
rt = R.T.ravel()
A = len(P)
"""
    + SCIPY_MPI_LOOP
    + """ts = time.perf_counter() - t
res = lb.bellman_residual(mdp, v)
print(json.dumps({"seconds": ts, "e2e": tb + tin + ts, "input": tin, "residual": res,
                  "tol": tol, "iterations": its, "sweeps": sweeps}))
"""
)

PT_UNPATCHED = """
import mdptoolbox.mdp as tm
mdp, tb = build()
P, R = mdp.to_matrices(disallowed_reward=-1e4)
try:
    tm.ValueIteration(P, R, mdp.discount, epsilon=1e-9)
    out = "no error"
except BaseException as exc:  # the failure is the measurement
    out = f"{{type(exc).__name__}}: {{str(exc)[:200]}}"
print(json.dumps({{"seconds": 0.0, "error": out}}))
"""

EVAL_LB = """
mdp, tb = build()
pol = np.load("{tmp}/pistar.npy")
t = time.perf_counter()
ev = lb.evaluate_policy(mdp, pol)
ts = time.perf_counter() - t
print(json.dumps({{"seconds": ts, "residual": ev.residual, "tol": target(mdp),
                  "sweeps": ev.sweeps}}))
"""

EVAL_PT = """
tm = pymdp_patched()
mdp, tb = build()
pol = np.load("{tmp}/pistar.npy")
P, R = mdp.to_matrices(disallowed_reward=-1e4)
tol = target(mdp)
t = time.perf_counter()
pi = tm.PolicyIteration(P, R, mdp.discount, policy0=pol, eval_type=1)
# stops when max|V_k - V_k-1| < (1 - lambda) / lambda * epsilon = tol
pi._evalPolicyIterative(epsilon=tol * mdp.discount / (1 - mdp.discount), max_iter=100000)
ts = time.perf_counter() - t
v = np.asarray(pi.V)
rows = lb.dp.exact_rows(mdp)
sel = rows.pair_row[np.arange(mdp.n_states), pol]
res = float(np.abs(rows.evaluate_rows(sel, v) - v).max())
print(json.dumps({{"seconds": ts, "residual": res, "tol": tol}}))
"""

EVAL_SCIPY = """
# pymdptoolbox's iterative evaluation without its dense P_pi: V <- R_pi + lambda P_pi V
# with P_pi in scipy.sparse, until max|V_k - V_k-1| < tol
mdp, tb = build()
pol = np.load("{tmp}/pistar.npy")
P, R = mdp.to_matrices(disallowed_reward=-1e4)
tol = target(mdp)
t = time.perf_counter()
n = mdp.n_states
import scipy.sparse as sp
rows_of = [np.flatnonzero(pol == a) for a in range(len(P))]
p_pi = sp.vstack([P[a][r] for a, r in enumerate(rows_of)]).tocsr()
perm = np.concatenate(rows_of)
inv = np.empty(n, dtype=np.int64); inv[perm] = np.arange(n)
p_pi = p_pi[inv]
r_pi = R[np.arange(n), pol]
v = np.zeros(n)
sweeps = 0
while True:
    nv = r_pi + mdp.discount * (p_pi @ v)
    sweeps += 1
    if np.abs(nv - v).max() < tol:
        v = nv
        break
    v = nv
ts = time.perf_counter() - t
rows = lb.dp.exact_rows(mdp)
sel = rows.pair_row[np.arange(n), pol]
res = float(np.abs(rows.evaluate_rows(sel, v) - v).max())
print(json.dumps({{"seconds": ts, "residual": res, "tol": tol, "sweeps": sweeps}}))
"""

LP_CVXPY = """
from lpbounds.patrol.bounds import {kind}
t = time.perf_counter()
res = {kind}(PatrolParams(**PARAMS)).solve(solver="HIGHS")
ts = time.perf_counter() - t
print(json.dumps({{"seconds": ts, "objective": float(res.objective),
                  "solve": res.solve_seconds}}))
"""

LP_HIGHSPY = """
import highspy, scipy.sparse as sp
from lpbounds.patrol.bounds import patrol_rows
t = time.perf_counter()
rows = patrol_rows(PatrolParams(**PARAMS), "{which}")
a, b = rows.constraint_matrix()
a = sp.csc_matrix(a)
h = highspy.Highs()
h.setOptionValue("output_flag", False)
lp = highspy.HighsLp()
lp.num_col_, lp.num_row_ = a.shape[1], a.shape[0]
lp.col_cost_ = np.ones(a.shape[1])
lp.col_lower_ = np.full(a.shape[1], -highspy.kHighsInf)
lp.col_upper_ = np.full(a.shape[1], highspy.kHighsInf)
lp.row_lower_ = np.asarray(b, dtype=float)
lp.row_upper_ = np.full(a.shape[0], highspy.kHighsInf)
lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
lp.a_matrix_.start_ = a.indptr
lp.a_matrix_.index_ = a.indices
lp.a_matrix_.value_ = a.data
h.passModel(lp)
h.run()
x = np.array(h.getSolution().col_value)
ts = time.perf_counter() - t
print(json.dumps({{"seconds": ts, "objective": float(x.sum()),
                  "status": h.modelStatusToString(h.getModelStatus())}}))
"""

RLP_LB = """
mdp, tb = build()
part = PatrolModel(PatrolParams(**PARAMS)).partition()
lb.BellmanRows.aggregate(lb.garnet(50, 3, 3, 0.9, shared_probabilities=True),
                         lb.random_partition(50, 5, 0))  # JIT warm-up
t = time.perf_counter()
rows = lb.BellmanRows.aggregate(mdp, part)
ts = time.perf_counter() - t
print(json.dumps({"seconds": ts, "rows": rows.n_rows}))
"""

RLP_NUMPY = """
# the plain vectorised numpy way: key every pair by (owner, action, sorted targets and
# probabilities) and merge equal keys with np.unique(axis=0), keeping the max reward
mdp, tb = build()
part = PatrolModel(PatrolParams(**PARAMS)).partition()
t = time.perf_counter()
xs, us = np.nonzero(mdp.allowed)
lab = part.labels
tg = lab[mdp.successors[xs, us]]
pr = np.broadcast_to(mdp.probabilities, tg.shape)
rank = np.argsort(np.argsort(mdp.probabilities))  # ties in target: order by probability
order = np.argsort(tg.astype(np.int64) * 64 + rank[None, :], axis=1)
tg = np.take_along_axis(tg, order, axis=1)
pb = np.take_along_axis(pr, order, axis=1).view(np.int64)
keys = np.column_stack([lab[xs], us, tg, pb]).astype(np.int64)
uniq, inv = np.unique(keys, axis=0, return_inverse=True)
rew = np.full(uniq.shape[0], -np.inf)
np.maximum.at(rew, inv.ravel(), mdp.rewards[xs, us])
ts = time.perf_counter() - t
print(json.dumps({"seconds": ts, "rows": int(uniq.shape[0])}))
"""

CLI = """
import subprocess, resource, sys, time, json
t = time.perf_counter()
p = subprocess.run({argv!r}, capture_output=True, text=True, cwd={cwd!r})
ts = time.perf_counter() - t
peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
print(json.dumps({{"seconds": ts, "child_peak_mb": peak, "rc": p.returncode,
                  "tail": (p.stdout + p.stderr)[-300:]}}))
"""


# ---------------------------------------------------------------------- exact DP
# Each task is a fresh process. "seconds" is the solve alone (model in memory, in the
# tool's own format); "whole" is from the launch of the process to the answer (interpreter
# start-up, imports, model build, conversion, solve), taken by the parent's clock and the
# child's wall-clock stamp when the solve returns (the residual check comes after).
DP_MODELS = {
    "patrol": "the paper's patrol MDP (2,048,000 x 3 x 5, discount 0.9)",
    "garnet-paper": "random MDP of the paper's shape (garnet 2,048,000 x 3 x 5, discount 0.9)",
    "garnet-mid": "mid-size random MDP (garnet 256,000 x 3 x 5, discount 0.9)",
}
DP_BUILD = """
import time, json, numpy as np
KIND = {kind!r}
def build_arrays():
    # successors, probabilities, rewards, allowed, discount (garnets: the same draws as
    # lpbounds.garnet(n, 3, 5, 0.9, seed=2048, shared_probabilities=True), in plain numpy,
    # so a peer's process does not import lpbounds before its answer)
    if KIND == "patrol":
        from lpbounds.patrol import PatrolModel, PatrolParams
        m = PatrolModel(PatrolParams()).mdp()
        return m.successors, np.asarray(m.probabilities), m.rewards, m.allowed, m.discount
    n = 2_048_000 if KIND == "garnet-paper" else 256_000
    rng = np.random.default_rng(2048)
    succ = rng.integers(0, n, size=(n, 3, 5)).astype(np.int32)
    cuts = np.sort(rng.random((4,)))
    probs = np.diff(np.concatenate([[0.0], cuts, [1.0]]))
    rew = rng.uniform(0.0, 1.0, size=(n, 3))
    return succ, probs, rew, np.ones((n, 3), dtype=bool), 0.9
def target(rew, allowed, lam):
    return 1e-10 * float(np.abs(rew[allowed]).max()) / (1 - lam)
def stamp():
    return time.time()
"""
DP_CHECK = """
import lpbounds as lb
def check(v, out):
    if KIND == "patrol":
        from lpbounds.patrol import PatrolModel, PatrolParams
        mdp = PatrolModel(PatrolParams()).mdp()
    else:
        mdp = lb.garnet(2_048_000 if KIND == "garnet-paper" else 256_000, 3, 5, 0.9,
                        seed=2048, shared_probabilities=True)
        succ, probs, rew, allowed, lam = build_arrays()
        assert np.array_equal(succ, mdp.successors) and np.array_equal(rew, mdp.rewards)
        assert np.array_equal(probs, mdp.probabilities)
    out["residual"] = lb.bellman_residual(mdp, np.asarray(v, dtype=float))
    out["tol"] = 1e-10 * mdp.reward_absmax / (1 - mdp.discount)
    print(json.dumps(out))
"""
DP_TASKS = {
    "lpbounds": """
import lpbounds as lb
if KIND == "patrol":
    from lpbounds.patrol import PatrolModel, PatrolParams
    mdp = PatrolModel(PatrolParams()).mdp()
else:
    mdp = lb.garnet(2_048_000 if KIND == "garnet-paper" else 256_000, 3, 5, 0.9, seed=2048,
                    shared_probabilities=True)
t = time.perf_counter()
r = lb.solve_exact(mdp, {method!r}{extra})
ts = time.perf_counter() - t
t_end = stamp()
out = {{"seconds": ts, "end": t_end, "sweeps": r.sweeps, "iterations": r.iterations}}
""",
    "scipy": """
# the plain scipy MPI loop: 5 evaluation sweeps per improvement, Porteus shift; the
# stacked (A n) x n CSR gives every Q-value in one product; disallowed pairs get -1e4
import scipy.sparse as sp
succ, probs, rew, allowed, lam = build_arrays()
n, A, L = succ.shape
tol = target(rew, allowed, lam)
t0 = time.perf_counter()
rt = np.where(allowed, rew, -1e4).T.ravel()
cols = np.where(allowed[:, :, None], succ, np.arange(n)[:, None, None]).transpose(1, 0, 2)
pr = np.where(allowed[:, :, None], np.broadcast_to(probs, succ.shape), 1.0 / L)
big = sp.csr_matrix((pr.transpose(1, 0, 2).ravel(), cols.ravel(), np.arange(0, A * n * L + 1, L)),
                    shape=(A * n, n))
tin = time.perf_counter() - t0
t = time.perf_counter()
"""
    + SCIPY_MPI_LOOP
    + """ts = time.perf_counter() - t
t_end = stamp()
out = {"seconds": ts, "end": t_end, "input": tin, "iterations": its, "sweeps": sweeps}
""",
    "quantecon": """
# QuantEcon's DiscreteDP in state-action form (allowed pairs only), MPI with k = 5; its
# stopping rule (span(Tv - v) < eps (1 - beta) / beta, then the midrange shift) leaves a
# residual <= eps (1 - beta) / 2, so eps = 2 target / (1 - beta)
import scipy.sparse as sp
from quantecon.markov import DiscreteDP
succ, probs, rew, allowed, lam = build_arrays()
n, A, L = succ.shape
tol = target(rew, allowed, lam)
t0 = time.perf_counter()
x_idx, a_idx = np.nonzero(allowed)
q = sp.csr_matrix((np.broadcast_to(probs, (x_idx.size, L)).ravel(), succ[x_idx, a_idx].ravel(),
                   np.arange(0, x_idx.size * L + 1, L)), shape=(x_idx.size, n))
q.sum_duplicates()
ddp = DiscreteDP(rew[x_idx, a_idx], q, lam, x_idx, a_idx)
tin = time.perf_counter() - t0
t = time.perf_counter()
res = ddp.solve("modified_policy_iteration", v_init=np.zeros(n), epsilon=2 * tol / (1 - lam), k=5)
ts = time.perf_counter() - t
t_end = stamp()
v = res.v
out = {"seconds": ts, "end": t_end, "input": tin, "iterations": int(res.num_iter)}
""",
    "mdpsolver": """
# mdpsolver (C++/OpenMP): nested lists (sparse form); no masks: disallowed pairs get -1e4
import mdpsolver
succ, probs, rew, allowed, lam = build_arrays()
tol = target(rew, allowed, lam)
t0 = time.perf_counter()
m = mdpsolver.model()
m.mdp(discount=lam, rewards=np.where(allowed, rew, -1e4).tolist(),
      tranMatProbs=np.broadcast_to(probs, succ.shape).tolist(), tranMatColumns=succ.tolist())
tin = time.perf_counter() - t0
t = time.perf_counter()
m.solve(algorithm="mpi", tolerance=tol, parallel=True, verbose=False)
v = np.array(m.getValueVector())
ts = time.perf_counter() - t
t_end = stamp()
out = {"seconds": ts, "end": t_end, "input": tin}
""",
}

# the ported peer test models (tests/model/interop), in process: lpbounds' MPI and IPI, the
# error of each against policy iteration's V* (exact evaluation by LU) and its certificate
DP_PORTED = """
import json, time, numpy as np, scipy.sparse as sp
import lpbounds as lb
def forest(S, r1=4.0, r2=2.0, p=0.1):  # pymdptoolbox's example (tests/model/interop)
    P = np.zeros((2, S, S))
    P[0, np.arange(S - 1), np.arange(1, S)] = 1 - p
    P[0, S - 1, S - 1] = 1 - p
    P[0, :, 0] += p
    P[1, :, 0] = 1.0
    R = np.zeros((S, 2)); R[S - 1, 0] = r1; R[1:, 1] = 1.0; R[S - 1, 1] = r2
    return [sp.csr_matrix(P[0]), sp.csr_matrix(P[1])], R
TEST1 = ([[5, -1], [1, -2], [50, 0]], [[[0.9, 0.1, 0.0], [0.1, 0.9, 0.0]],
         [[0.4, 0.5, 0.1], [0.3, 0.5, 0.2]], [[0.2, 0.2, 0.6], [0.5, 0.5, 0.0]]])
models = {}
for S, lam in ((3, 0.9), (10, 0.96), (1000, 0.99)):
    P, R = forest(S)
    models[f"forest S={S}, discount {lam}"] = lb.FiniteMDP.from_matrices(P, R, lam)
models["mdpsolver test1, discount 0.98"] = lb.FiniteMDP.from_quantecon(*TEST1, 0.98)
out = []
lb.solve_exact(models["forest S=3, discount 0.9"], "ipi")
for name, mdp in models.items():
    ref = lb.solve_exact(mdp, "pi", tol=1e-13 * max(1.0, mdp.reward_absmax) / (1 - mdp.discount))
    row = {"model": name}
    for m in ("mpi", "ipi"):
        ts = []
        for _ in range(5):
            t = time.perf_counter(); r = lb.solve_exact(mdp, m); ts.append(time.perf_counter() - t)
        err = float(np.abs(r.values - ref.values).max())
        row[m] = {"ms": 1e3 * min(ts), "sweeps": r.sweeps, "err": err, "bound": r.error_bound,
                  "ok": err <= r.error_bound + ref.error_bound}
    out.append(row)
print(json.dumps({"rows": out}))
"""


#: The whole-process speed-up aimed at over the fastest peer, per model.
WHOLE_TARGET = {"patrol": 1.5, "garnet-paper": 1.5, "garnet-mid": 1.0}
#: lpbounds' solves stop at the peers' target residual (``target`` of DP_BUILD), so that every
#: tool is timed to the same accuracy; its own default (``dp_default_tol``: a residual of
#: 1e-11 max|R|, 100 times smaller at discount 0.9) is the row "lpbounds-default"
AT_TARGET = ", tol=1e-10 * mdp.reward_absmax / (1 - mdp.discount)"


#: lpbounds' whole process on the mid-size garnet, stage by stage (seconds)
STARTUP = """
import time, json, os, sys
t0 = time.perf_counter()
import numpy as np
t1 = time.perf_counter()
import lpbounds as lb
t2 = time.perf_counter()
from lpbounds._kernels import native  # the C row sweeps (the garnet's own check loads them)
t3 = time.perf_counter()
mdp = lb.garnet(256_000, 3, 5, 0.9, seed=2048, shared_probabilities=True)
t4 = time.perf_counter()
r = lb.solve_exact(mdp, tol=1e-10 * mdp.reward_absmax / (1 - mdp.discount))
t5 = time.perf_counter()
assert "numba" not in sys.modules, "the mid-size solve imported numba"
print(json.dumps({"numpy": t1 - t0, "import lpbounds": t2 - t1, "the C sweeps": t3 - t2,
                  "garnet": t4 - t3, "solve": t5 - t4, "load": os.getloadavg()[0]}))
"""


def dp_task(kind: str, tool: str, method: str = "mpi", extra: str = "") -> dict:
    """Run one exact-DP task in a fresh process; adds ``whole`` (launch to answer).
    ``extra``: more keyword arguments of lpbounds' ``solve_exact`` (source text)."""
    task = (
        DP_TASKS[tool].format(method=method, extra=extra) if tool == "lpbounds" else DP_TASKS[tool]
    )
    code = DP_BUILD.format(kind=kind) + DP_CHECK + task
    if tool == "lpbounds":
        code += "v = r.values\n"
    code += "check(v, out)\n"
    launch = time.time()
    label = f"{kind}/{tool}" + (f"-{method}{extra}" if tool == "lpbounds" else "")
    out = run(code, label, timeout=900)
    if "end" in out:
        out["whole"] = out["end"] - launch
    return out


def main_dp(args: argparse.Namespace) -> None:
    """The exact-DP comparison (``--dp``): writes the ``peers-dp`` section."""
    load0 = os.getloadavg()
    t_start = time.time()
    R: dict[str, list[dict]] = {}
    tools = ["lpbounds", "scipy", "quantecon", "mdpsolver"]
    R["ported"] = [run(DP_PORTED, "ported")]
    for rep in range(args.repeat):
        for kind in args.models:
            print(f"repetition {rep + 1}/{args.repeat}: {kind}  load {os.getloadavg()}", flush=True)
            k = rep % 3  # the order rotates: no tool always runs first after another model
            for tool in [*tools[k:3], *tools[:k], tools[3]]:
                if tool == "mdpsolver" and (
                    rep > 0 or (kind == "garnet-paper" and not args.mdpsolver_paper)
                ):
                    continue  # once (minutes per run); not on the paper-shape garnet by default
                extra = AT_TARGET if tool == "lpbounds" else ""
                R.setdefault(f"{kind}/{tool}", []).append(dp_task(kind, tool, extra=extra))
            if rep == 0:
                R.setdefault(f"{kind}/lpbounds-default", []).append(dp_task(kind, "lpbounds"))
                R.setdefault(f"{kind}/lpbounds-ipi", []).append(
                    dp_task(kind, "lpbounds", "ipi", AT_TARGET)
                )
                R.setdefault(f"{kind}/lpbounds-mpi5", []).append(
                    dp_task(kind, "lpbounds", "mpi", ", eval_sweeps=5" + AT_TARGET)
                )
    if "garnet-mid" in args.models:
        R["startup"] = [run(STARTUP, "startup") for _ in range(args.repeat)]
    load1 = os.getloadavg()
    tmp = Path(os.environ.get("TMPDIR", "/tmp")) / "lpbounds-bench-peers"
    tmp.mkdir(parents=True, exist_ok=True)
    (tmp / "results-dp.json").write_text(json.dumps(R, indent=1))
    write_section("peers-dp", dp_body(R, args, load0, load1, time.time() - t_start))


def dp_body(R: dict, args: argparse.Namespace, load0, load1, wall: float) -> str:
    names = {
        "lpbounds": "lpbounds `solve_exact(tol=target)` (MPI, `eval_sweeps='auto'`)",
        "lpbounds-default": "lpbounds `solve_exact()` (its default tolerance, 1e-11 max abs R)",
        "lpbounds-mpi5": "lpbounds `solve_exact(eval_sweeps=5, tol=target)` (the old default)",
        "lpbounds-ipi": "lpbounds `solve_exact(method='ipi', tol=target)`",
        "scipy": "plain scipy MPI loop (30 lines)",
        "quantecon": "QuantEcon DiscreteDP MPI (k = 5)",
        "mdpsolver": "mdpsolver MPI",
    }
    lines, targets_ = [], []
    for kind in args.models:
        lines.append(f"| **{DP_MODELS[kind]}** | | | | | |")
        ours = R.get(f"{kind}/lpbounds", [])
        a, aw = med(ours), med(ours, "whole")
        best_in, best_whole = None, None
        for tool in (
            "lpbounds",
            "lpbounds-default",
            "lpbounds-mpi5",
            "lpbounds-ipi",
            "scipy",
            "quantecon",
            "mdpsolver",
        ):
            runs = R.get(f"{kind}/{tool}", [])
            if not runs:
                continue
            b, bw = med(runs), med(runs, "whole")
            err = next((r["error"] for r in runs if "error" in r), "")
            chk = [r for r in runs if "residual" in r]
            ok = all(r["residual"] <= r["tol"] for r in chk) if chk else False
            cert = (
                f"{max(r['residual'] for r in chk):.1e} "
                f"({'meets' if ok else '**MISSES**'} {chk[0]['tol']:.1e})"
                if chk
                else "failed: " + err.splitlines()[-1][:100]
                if err
                else "-"
            )
            ratio = "-" if a is None or b is None else f"{a / b:.2f}"
            ratio_w = "-" if aw is None or bw is None else f"{aw / bw:.2f}"
            spread = ", ".join(f"{r['seconds']:.2f}" for r in runs if "seconds" in r)
            cells = [names[tool], f"{fmt(b)} ({spread})", fmt(bw), ratio, ratio_w, cert]
            lines.append("| " + " | ".join(cells) + " |")
            if tool in ("scipy", "quantecon", "mdpsolver") and b is not None and ok:
                best_in = b if best_in is None else min(best_in, b)
                best_whole = bw if best_whole is None else min(best_whole, bw or np.inf)
        if a and best_in:
            targets_.append(
                f"| {kind} | {best_in / a:.2f}x (target 2x: "
                f"{'met' if best_in / a >= 2 else '**missed**'}) | "
                + (
                    f"{best_whole / aw:.2f}x (target {WHOLE_TARGET[kind]:g}x: "
                    f"{'met' if best_whole / aw >= WHOLE_TARGET[kind] else '**missed**'}) |"
                    if aw and best_whole
                    else "- |"
                )
            )
    ported = []
    for row in (R.get("ported") or [{}])[0].get("rows", []):
        cells = [row["model"]]
        for m in ("mpi", "ipi"):
            x = row[m]
            ok = "yes" if x["ok"] else "**NO**"
            cells.append(
                f"{x['ms']:.2f} ms, {x['sweeps']} sweeps, error {x['err']:.1e} <= "
                f"{x['bound']:.1e}: {ok}"
            )
        ported.append("| " + " | ".join(cells) + " |")
    return (
        f"""## Peers: exact DP against scipy, QuantEcon and mdpsolver

Machine: {machine()}. Date: {today()}. Versions: {versions()}, quantecon
{_version("quantecon")}. Load average (1, 5, 15 min) at start {load0[0]:.2f} {load0[1]:.2f}
{load0[2]:.2f}, at end {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} (2 cores: above 2 the
machine was shared with other jobs and every time is inflated, unevenly). Repetitions:
{args.repeat} (median, all runs in brackets; each task a fresh process; the tools alternate
within a repetition; lpbounds' IPI, its fixed five evaluation sweeps, its default
tolerance and mdpsolver once, mdpsolver with a 900 s limit); the
run took {wall / 60:.1f} min.

"solve s" is the solve alone, the model in memory in the tool's own format; "whole s" is
the whole process, from its launch to the answer: interpreter start-up, imports, model
build (garnets: the same numpy draws as `lpbounds.garnet`, so a peer does not import
lpbounds; the patrol: lpbounds' builder for every tool), conversion and solve. Every tool stops at
the same target residual, 1e-10 max|R| / (1 - discount): lpbounds is given it as `tol`
(its own default is 100 times smaller at discount 0.9: the row "default tolerance").
Ratios are lpbounds' solve at the target / the row's (below 1: lpbounds faster). Every
answer's Bellman residual is measured by lpbounds on the returned vector after the clock
stops, against the target. mdpsolver is not run on the paper-shape garnet
(its nested-list input of 6 M pairs takes ~4 GB; `--mdpsolver-paper` runs it).

| tool | solve s (runs) | whole s | ratio solve | ratio whole | residual (target) |
|---|---|---|---|---|---|
"""
        + "\n".join(lines)
        + """

Speed-up of lpbounds' solve over the fastest peer whose answer met the target (the
targets: >= 2x in process on every model; as a whole process >= 1.5x on the patrol and the
paper-shape garnet, >= 1x on the mid-size garnet):

| model | in process | whole process |
|---|---|---|
"""
        + "\n".join(targets_)
        + """

lpbounds' MPI and IPI on the ported peer test models (tests/model/interop; in process, best of
5; error against policy iteration's V* to 1e-13, within each answer's certificate):

| model | MPI | IPI |
|---|---|---|
"""
        + "\n".join(ported)
        + "\n"
        + startup_text(R.get("startup", []))
    )


def startup_text(runs: list[dict]) -> str:
    """Where lpbounds' whole process goes on the mid-size garnet (medians of ``runs``)."""
    runs = [r for r in runs if "error" not in r]
    if not runs:
        return ""
    stages = [k for k in runs[0] if k not in ("load", "peak_rss_mb")]
    cells = " | ".join(f"{statistics.median(r[k] for r in runs):.3f}" for k in stages)
    return f"""
Where lpbounds' whole process goes on the mid-size garnet (`STARTUP` in this script, a fresh
process each, medians of {len(runs)}; seconds):

| {" | ".join(stages)} |
|{"---|" * len(stages)}
| {cells} |

The process imports no numba (the script asserts it): the row sweeps, their policy gather
and the model's successor check are C (`lpbounds._kernels.native`). What was cut: numba's
import (0.16-0.20 s) and its first call of a cached kernel (0.32-0.42 s: it initialises its
CPU target, its typing and lowering registries, and imports `scipy.linalg`, where it looks
for BLAS), which together cost about what the plain scipy script's whole run costs; and
earlier, `scipy.sparse` at start-up (0.08-0.14 s; it is imported where a matrix is built).
"""


def _version(pkg: str) -> str:
    import importlib.metadata as md

    try:
        return md.version(pkg)
    except md.PackageNotFoundError:
        return "(not installed)"


def run(code: str, label: str, timeout: float = 1800) -> dict:
    try:
        out = run_isolated(code, timeout=timeout)
    except Exception as exc:  # record the failure, keep benchmarking
        out = {"error": f"{type(exc).__name__}: {str(exc)[-400:]}"}
    print(f"  {label}: {json.dumps(out)[:300]}", flush=True)
    return out


def med(runs: list[dict], key: str = "seconds") -> float | None:
    vals = [r[key] for r in runs if key in r and "error" not in r]
    return statistics.median(vals) if vals else None


def peak(runs: list[dict]) -> float | None:
    vals = [r.get("child_peak_mb", r.get("peak_rss_mb")) for r in runs if "error" not in r]
    vals = [v for v in vals if v is not None]
    return max(vals) if vals else None


def fmt(x: float | None, d: int = 2) -> str:
    return "-" if x is None else f"{x:.{d}f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="small instance, 1 repetition")
    ap.add_argument("--skip", nargs="*", default=[], help="task names to skip")
    ap.add_argument(
        "--only",
        nargs="*",
        choices=["numpy", "pymdptoolbox"],
        help="rerun only these peers' exact solves and merge them into the last run's results",
    )
    ap.add_argument("--dp", action="store_true", help="the exact-DP comparison")
    ap.add_argument("--models", nargs="*", choices=list(DP_MODELS), default=list(DP_MODELS))
    ap.add_argument("--mdpsolver-paper", action="store_true", help="mdpsolver on garnet-paper")
    args = ap.parse_args()
    if args.dp:
        main_dp(args)
        return
    params = "{}" if not args.quick else "{'N': 10, 'stations': (0, 3, 6), 'Gamma': 8}"
    reps = 1 if args.quick else args.repeat
    tmp = Path(os.environ.get("TMPDIR", "/tmp")) / "lpbounds-bench-peers"
    tmp.mkdir(parents=True, exist_ok=True)
    pre = PRELUDE.format(params=params)
    load0 = os.getloadavg()
    t_start = time.time()
    R: dict[str, list[dict]] = {}

    def rec(key: str, code: str, timeout: float = 1800) -> None:
        R.setdefault(key, []).append(run(pre + code, key, timeout))

    if args.only is not None:  # "--only" alone: rewrite the section from the last results
        old = json.loads((tmp / "results.json").read_text())
        meta = old.pop("_meta", None) or _meta_from_doc(old)
        R.update(old)
        rerun = meta.get("rerun", [])
        if args.only:
            rerun = sorted(set(rerun) | set(args.only))
            meta["load_rerun"] = os.getloadavg()
        meta["rerun"] = rerun
        tasks = {
            "numpy": ("solve/numpy-mpi", SOLVE_NP),
            "pymdptoolbox": ("solve/pymdptoolbox-vi", SOLVE_PT.format(tmp=tmp)),
        }
        for name in args.only:
            R.pop(tasks[name][0], None)
        for _ in range(reps):
            for name in args.only:
                rec(*tasks[name])
        R["_meta"] = meta
        (tmp / "results.json").write_text(json.dumps(R, indent=1))
        R.pop("_meta")
        write_doc(
            R,
            [tuple(c) for c in meta["cli_rows"]],
            meta["load0"],
            meta["load1"],
            meta["reps"],
            meta["wall"],
            False,
            (
                [{"numpy": "plain numpy MPI", "pymdptoolbox": "pymdptoolbox VI"}[r] for r in rerun],
                meta.get("load_rerun", [float("nan")]),
            )
            if rerun
            else None,
        )
        return
    # the lpbounds solve writes V* and pi* for the others to compare with: first
    rec("solve/lpbounds-mpi", SOLVE_LB.format(method="mpi", tmp=tmp))
    for rep in range(reps):
        print(f"repetition {rep + 1}/{reps}", flush=True)
        rec("build/lpbounds", BUILD_LB)
        rec("build/pymdptoolbox", BUILD_PT)
        if "mdpsolver" not in args.skip:
            rec("build/mdpsolver", BUILD_MS)
        for m in ("mpi", "vi"):
            rec(f"solve/lpbounds-{m}", SOLVE_LB.format(method=m, tmp=tmp))
        if "mdpsolver" not in args.skip:
            for m in ("vi", "mpi"):
                rec(f"solve/mdpsolver-{m}", SOLVE_MS.format(method=m, tmp=tmp))
        rec("solve/pymdptoolbox-vi", SOLVE_PT.format(tmp=tmp))
        rec("eval/lpbounds", EVAL_LB.format(tmp=tmp))
        rec("eval/scipy", EVAL_SCIPY.format(tmp=tmp))
        for kind, which in (("UBLP", "upper"), ("LBLP", "lower")):
            rec(f"lp/{kind}-cvxpy", LP_CVXPY.format(kind=kind))
            rec(f"lp/{kind}-highspy", LP_HIGHSPY.format(which=which))
        rec("rlp/lpbounds", RLP_LB)
        rec("rlp/numpy", RLP_NUMPY)
    if "mdpsolver" not in args.skip and "mdpsolver-pi" not in args.skip:
        rec("solve/mdpsolver-pi", SOLVE_MS.format(method="pi", tmp=tmp), timeout=900)
    rec("solve/pymdptoolbox-unpatched", PT_UNPATCHED.format(), timeout=600)
    if not args.quick:  # its P_pi is a dense n x n array: 54 s even at 15,795 states
        rec("eval/pymdptoolbox", EVAL_PT.format(tmp=tmp), timeout=600)
    exe = shutil.which("lpbounds") or str(Path(sys.executable).with_name("lpbounds"))
    has_reproduce = (ROOT / "src/lpbounds/cli/reproduce.py").exists()
    cli_rows = []
    if has_reproduce and "reproduce" not in args.skip and not args.quick:
        argv = [exe, "reproduce", "--out", str(tmp / "reproduce"), "--no-figures"]
        for _ in range(min(reps, 2)):
            rec("cli/reproduce", CLI.format(argv=argv, cwd=str(ROOT)), timeout=900)
        argv_f = [exe, "reproduce", "--out", str(tmp / "reproduce-fig")]
        rec("cli/reproduce-figures", CLI.format(argv=argv_f, cwd=str(ROOT)), timeout=900)
        cli_rows += [("reproduce", "cli/reproduce", "`lpbounds reproduce --no-figures`", 20)]
        cli_rows += [("reproduce+figures", "cli/reproduce-figures", "`lpbounds reproduce`", 20)]
    m8 = ROOT / "models/patrol-m8.toml"
    if m8.exists() and "bounds" not in args.skip and not args.quick:
        argv = [exe, "bounds", str(m8)]
        for _ in range(min(reps, 2)):
            rec("cli/bounds-m8", CLI.format(argv=argv, cwd=str(ROOT)), timeout=900)
        cli_rows += [("bounds m8", "cli/bounds-m8", "`lpbounds bounds models/patrol-m8.toml`", 60)]
    load1 = os.getloadavg()
    wall = time.time() - t_start
    meta = {"cli_rows": cli_rows, "load0": load0, "load1": load1, "reps": reps, "wall": wall}
    (tmp / "results.json").write_text(json.dumps({**R, "_meta": meta}, indent=1))
    write_doc(R, cli_rows, load0, load1, reps, wall, args.quick)


def _meta_from_doc(R: dict) -> dict:
    """The run's metadata, read back from the peers section it wrote (older result files)."""
    import re

    from _common import DOCS

    text = DOCS.read_text()
    sec = text[text.index("<!-- peers:start -->") :]
    num = r"([0-9.]+)"
    m = re.search(rf"at start {num} {num} {num}, at end\s+{num} {num} {num}", sec)
    loads = [float(x) for x in m.groups()] if m else [float("nan")] * 6
    reps = re.search(r"Repetitions: (\d+)", sec)
    wall = re.search(r"took ([0-9.]+) min", sec)
    cli_rows = []
    if "cli/reproduce" in R:
        cli_rows += [("reproduce", "cli/reproduce", "`lpbounds reproduce --no-figures`", 20)]
    if "cli/reproduce-figures" in R:
        cli_rows += [("reproduce+figures", "cli/reproduce-figures", "`lpbounds reproduce`", 20)]
    if "cli/bounds-m8" in R:
        cli_rows += [("bounds m8", "cli/bounds-m8", "`lpbounds bounds models/patrol-m8.toml`", 60)]
    return {
        "cli_rows": cli_rows,
        "load0": loads[:3],
        "load1": loads[3:],
        "reps": int(reps.group(1)) if reps else 0,
        "wall": 60 * float(wall.group(1)) if wall else float("nan"),
    }


def versions() -> str:
    import importlib.metadata as md

    out = []
    for pkg in ("lpbounds", "mdpsolver", "pymdptoolbox", "cvxpy", "highspy", "scipy"):
        try:
            out.append(f"{pkg} {md.version(pkg)}")
        except md.PackageNotFoundError:
            out.append(f"{pkg} (not installed)")
    return ", ".join(out)


def write_doc(R, cli_rows, load0, load1, reps, wall, quick, load_numpy=None) -> None:
    def row(task, ours, peer, peer_name, note=""):
        a, b = med(R.get(ours, [])), med(R.get(peer, []))
        ratio = "-" if a is None or b is None else f"**{a / b:.2f}**"
        pa, pb = peak(R.get(ours, [])), peak(R.get(peer, []))
        err = next((r["error"] for r in R.get(peer, []) if "error" in r), None)
        if err and b is None:
            note = (note + "; " if note else "") + "failed: " + err.splitlines()[-1][:120]
        return (
            f"| {task} | {fmt(a)} | {fmt(pa, 0)} | {peer_name} | {fmt(b)} | {fmt(pb, 0)} | "
            f"{ratio} | {note} |"
        )

    def res(key):
        rs = [r for r in R.get(key, []) if "residual" in r]
        if not rs:
            return ""
        r = rs[0]
        ok = "meets" if r["residual"] <= r["tol"] else "MISSES"
        return f"residual {r['residual']:.1e} ({ok} {r['tol']:.1e})"

    def e2e(key):
        vals = [r["e2e"] for r in R.get(key, []) if "e2e" in r]
        return statistics.median(vals) if vals else None

    lines = []
    lines.append(
        row(
            "model build / input",
            "build/lpbounds",
            "build/mdpsolver",
            "mdpsolver",
            _split(R, "build/mdpsolver"),
        )
    )
    lines.append(
        row(
            "model build / input",
            "build/lpbounds",
            "build/pymdptoolbox",
            "pymdptoolbox",
            _split(R, "build/pymdptoolbox"),
        )
    )
    for ours in ("solve/lpbounds-mpi", "solve/lpbounds-vi"):
        m = ours.split("-")[-1]
        for peer, name in (
            ("solve/mdpsolver-vi", "mdpsolver VI"),
            ("solve/mdpsolver-mpi", "mdpsolver MPI"),
            ("solve/mdpsolver-pi", "mdpsolver PI"),
            ("solve/pymdptoolbox-vi", "pymdptoolbox VI (check patched out)"),
            ("solve/numpy-mpi", "plain numpy/scipy MPI (eval_sweeps=5)"),
        ):
            if ours.endswith("vi") and peer.endswith("pi"):
                continue
            lines.append(
                row(
                    f"exact V* ({m.upper()})",
                    ours,
                    peer,
                    name,
                    f"ours: {res(ours)}; peer: {res(peer)}",
                )
            )
    # end to end (build + input + solve)
    for ours in ("solve/lpbounds-mpi", "solve/lpbounds-vi"):
        for peer, name in (
            ("solve/mdpsolver-vi", "mdpsolver VI"),
            ("solve/mdpsolver-mpi", "mdpsolver MPI"),
            ("solve/pymdptoolbox-vi", "pymdptoolbox VI (patched)"),
            ("solve/numpy-mpi", "plain numpy/scipy MPI"),
        ):
            a, b = e2e(ours), e2e(peer)
            ratio = "-" if a is None or b is None else f"**{a / b:.2f}**"
            meth = ours.split("-")[-1].upper()
            lines.append(
                f"| end to end: build + input + V* ({meth}) | {fmt(a)} | | {name} | {fmt(b)} | | "
                f"{ratio} | |"
            )
    lines.append(
        row(
            "policy evaluation of pi*",
            "eval/lpbounds",
            "eval/pymdptoolbox",
            "pymdptoolbox _evalPolicyIterative",
            "dense n x n P_pi",
        )
    )
    lines.append(
        row(
            "policy evaluation of pi*",
            "eval/lpbounds",
            "eval/scipy",
            "same iteration, sparse P_pi (scipy)",
            f"ours: {res('eval/lpbounds')}; peer: {res('eval/scipy')}",
        )
    )
    for kind in ("UBLP", "LBLP"):
        lines.append(
            row(
                f"{kind} (cvxpy + HiGHS, incl. rows)",
                f"lp/{kind}-cvxpy",
                f"lp/{kind}-highspy",
                "highspy directly (same rows)",
                _obj(R, kind),
            )
        )
    lines.append(
        row(
            "general RLP rows (aggregate)",
            "rlp/lpbounds",
            "rlp/numpy",
            "plain numpy np.unique",
            _rows(R),
        )
    )
    unpatched = next((r for r in R.get("solve/pymdptoolbox-unpatched", [])), {})
    cli = []
    for _name, key, cmd, target in cli_rows:
        rs = [r for r in R.get(key, []) if "error" not in r]
        ok = all(r.get("rc") == 0 for r in rs)
        t = med(rs)
        pk = max((r.get("child_peak_mb", 0) for r in rs), default=None)
        tail = " ".join(rs[0].get("tail", "").split())[-120:] if rs else ""
        status = "n/a" if not rs else ("ok" if ok else "FAILED: " + tail)
        cli.append(f"| {cmd} | {fmt(t)} | {fmt(pk, 0)} | {target} | {status} |")
    body = (
        f"""## Peers: lpbounds vs mdpsolver and pymdptoolbox on the paper's patrol MDP

Machine: {machine()}. Date: {today()}. Versions: {versions()}.
Load average (1, 5, 15 min) at start {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, at end
{load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} (2 cores: above ~2 the machine was shared and all
times are inflated). Repetitions: {reps} (median; each measurement a fresh process; tools
alternate within a repetition); the whole run took {wall / 60:.1f} min.{
            ""
            if load_numpy is None
            else f" Rerun right after the main run (load {load_numpy[1][0]:.2f}): "
            + ", ".join(load_numpy[0])
            + "."
        }
{"QUICK RUN (small instance): not the paper's numbers." if quick else ""}

Model: the paper's instance (2,048,000 states, 3 actions, 5 outcomes, 4,653,056 allowed
pairs). Peers get the same MDP: mdpsolver as nested lists (sparse option: probabilities
and columns per (state, action)), pymdptoolbox as scipy.sparse matrices; neither has
action masks, so disallowed pairs are self-loops with reward -1e4. "peak MB" is the peak
RSS of the process doing the whole task (model build included). Ratio = lpbounds time /
peer time (below 1: lpbounds faster). Every exact solve is checked by lpbounds on the
returned vector against the target residual 1e-10 max|R|/(1-discount).

| task | lpbounds s | peak MB | peer | peer s | peak MB | ratio | notes |
|---|---|---|---|---|---|---|---|
"""
        + "\n".join(lines)
        + f"""

pymdptoolbox as shipped: `{unpatched.get("error", "not run")}`. Its `util.check` turns
each transition matrix into a dense n x n array (2,048,000^2 float64 = 30 TiB) and
`ValueIteration._boundIter` loops over the n columns in Python; the "patched" rows replace
both with no-ops (max_iter 100,000). pymdptoolbox's VI stops on the span of successive
differences, which does not bound the residual (with epsilon = tol/100 it stopped after 76
iterations at residual 3e-7); it therefore runs the fixed number of iterations K with
lambda^K ||T0 - 0|| <= tol, which does (checked in the table).

Commands of lpbounds itself (no peer does these; targets from the issues):

| command | seconds | peak MB (child) | target s | status |
|---|---|---|---|---|
"""
        + "\n".join(cli)
        + "\n"
        + targets(R, e2e)
    )
    write_section("peers", body)


def targets(R, e2e) -> str:
    """The issue's targets against this run's medians."""

    def t(key):
        return med(R.get(key, []))

    out = [
        "",
        "The project's performance targets against this run:",
        "",
        "| target | measured | met |",
        "|---|---|---|",
    ]

    def add(what, value, ok):
        out.append(f"| {what} | {value} | {'yes' if ok else '**no**'} |")

    for m in ("mpi", "vi"):
        v = t(f"solve/lpbounds-{m}")
        if v is not None:
            add(
                f"exact V* of the paper's instance <= 1.5 s ({m.upper()}, MDP given)",
                f"{v:.2f} s",
                v <= 1.5,
            )
    pk = peak(R.get("solve/lpbounds-mpi", []))
    if pk is not None:
        add("peak memory <= 1 GB (build + solve process)", f"{pk:.0f} MB", pk <= 1024)
    b = t("build/lpbounds")
    if b is not None:
        add("model build <= 1.5 s", f"{b:.2f} s", b <= 1.5)
    ours = min(x for x in (e2e("solve/lpbounds-mpi"), e2e("solve/lpbounds-vi")) if x)
    peers = [e2e(k) for k in ("solve/mdpsolver-vi", "solve/mdpsolver-mpi", "solve/mdpsolver-pi")]
    peers = [x for x in peers if x]
    if peers:
        r = min(peers) / ours
        add(
            ">= 3x faster than mdpsolver's fastest method end to end (incl. model input)",
            f"{r:.1f}x ({ours:.2f} s vs {min(peers):.2f} s)",
            r >= 3,
        )
    np_e2e = e2e("solve/numpy-mpi")
    if np_e2e:
        r = np_e2e / ours
        add(
            ">= 2x faster than the plain numpy MPI end to end",
            f"{r:.1f}x ({ours:.2f} s vs {np_e2e:.2f} s)",
            r >= 2,
        )
    for key, what, lim in (
        ("cli/reproduce", "full reproduction <= 20 s (no figures)", 20),
        ("cli/reproduce-figures", "full reproduction <= 20 s (figures)", 20),
        ("cli/bounds-m8", "bounds for 8 stations <= 60 s", 60),
    ):
        v = t(key)
        if v is not None:
            add(what, f"{v:.1f} s", v <= lim)
    return "\n".join(out) + "\n"


def _split(R, key) -> str:
    rs = [r for r in R.get(key, []) if "convert" in r]
    if not rs:
        return ""
    parts = [
        f"{k} {statistics.median(r[k] for r in rs):.2f} s"
        for k in ("build", "convert", "load")
        if k in rs[0]
    ]
    return "peer = lpbounds build + " + ", ".join(parts[1:]) if parts else ""


def _obj(R, kind) -> str:
    a = [r["objective"] for r in R.get(f"lp/{kind}-cvxpy", []) if "objective" in r]
    b = [r["objective"] for r in R.get(f"lp/{kind}-highspy", []) if "objective" in r]
    if a and b:
        return f"objectives {a[0]:.8g} vs {b[0]:.8g}"
    return ""


def _rows(R) -> str:
    a = [r["rows"] for r in R.get("rlp/lpbounds", []) if "rows" in r]
    b = [r["rows"] for r in R.get("rlp/numpy", []) if "rows" in r]
    return f"rows {a[0]} vs {b[0]}" if a and b else ""


if __name__ == "__main__":
    main()
