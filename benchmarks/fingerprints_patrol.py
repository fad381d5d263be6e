"""Fingerprints of the patrol's compiled kernels, to show a port left every number bit-identical.

The companion of ``benchmarks/fingerprints.py`` (V*, policies and the reproduction) for what
that script does not reach: the matrix-free path (:mod:`lpbounds.patrol.matrix_free`: V*,
its policy, the partition labels, the greedy pass and its statistics, V_sub and its
statistics), the greedy policy acted out on the fly (:mod:`lpbounds.patrol.greedy_mc`: the
actions at every state, the Monte Carlo returns, Table 1's trajectories) and
:func:`lpbounds.patrol.simulation.simulate`'s trajectories, plus the model's decoder,
successors and partition of every state. One line per item: a SHA-256 prefix of the exact
bytes (floats as their bytes, statistics as ``repr`` of each float). Run it on the old
tree and the new one and ``diff`` the outputs::

    python benchmarks/fingerprints_patrol.py --m5 > before.txt   # old tree
    python benchmarks/fingerprints_patrol.py --m5 > after.txt    # new tree

``--m5`` adds the 5-station instance (``models/patrol-m5-paper.toml``, 33,095,680 states:
matrix-free V*, V_sub and the passes, about 2 minutes and 1.5 GB on two cores). The 6- and
8-station models are never run here.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from typing import Any

import numpy as np
from fingerprints import digest

SEEDS = (1, 2)
#: Monte Carlo size per start (the returns are hashed exactly, so a few hundred paths do)
PATHS = 300


def digest_obj(obj: Any) -> str:
    """Of a dict of numbers: every float by its ``repr`` (all its digits)."""

    def norm(o: Any) -> Any:
        if isinstance(o, dict):
            return {str(k): norm(v) for k, v in o.items() if k not in ("seconds",)}
        if isinstance(o, (list, tuple)):
            return [norm(v) for v in o]
        if isinstance(o, (float, np.floating)):
            return repr(float(o))
        if isinstance(o, (np.integer, np.bool_)):
            return int(o)
        return o

    return hashlib.sha256(json.dumps(norm(obj), sort_keys=True).encode()).hexdigest()[:16]


def out(name: str, what: str, h: str) -> None:
    print(f"{name:16s} {what:34s} {h}", flush=True)


def _params(name: str) -> Any:
    from lpbounds.model.instances import load_instance
    from lpbounds.patrol.instance import params_from_instance

    return params_from_instance(load_instance(name))


def matrix_free(name: str) -> None:
    """V*, labels, the greedy pass, V_sub and the statistics of the matrix-free path."""
    from lpbounds.patrol.greedy_mc import partition_bounds
    from lpbounds.patrol.matrix_free import MatrixFreePatrol, evaluate_policy, solve_vstar

    params = _params(name)
    mf = MatrixFreePatrol(params)
    out(name, "reward_absmax", digest_obj(mf.reward_absmax))
    sol = solve_vstar(mf)
    out(name, "mf V* + policy", digest(sol.values, sol.policy))
    out(name, "mf V* run", digest_obj([sol.iterations, sol.sweeps, sol.residual]))
    out(name, "mf labels", digest(mf.labels()))
    b = partition_bounds(params)
    out(name, "bounds w*, v*", digest(b.lower, b.upper))
    err_v = float(sol.error_bound)
    pi_s, g = mf.greedy_gap(sol.values, sol.policy, b.lower, b.upper, 2 * err_v)
    out(name, "mf greedy pi_s", digest(pi_s))
    out(name, "mf greedy stats", digest_obj(g))
    ev = evaluate_policy(mf, pi_s)
    out(name, "mf V_sub", digest(ev.values))
    out(name, "mf V_sub run", digest_obj([ev.sweeps, ev.residual, ev.error_bound]))
    out(name, "mf vsub stats", digest_obj(mf.vsub_stats(sol.values, ev.values, b.lower)))
    out(
        name,
        "mf vsub stats (V* as V_sub)",
        digest_obj(mf.vsub_stats(sol.values, sol.values, b.upper)),
    )
    v0 = np.zeros(mf.n_vars)
    o = mf.new_vector()
    arg = mf.new_arg()
    lohi = mf.sweep_max(sol.values * 0.5, o, arg)
    out(name, "mf sweep_max(V*/2)", digest(o, arg) + " " + digest_obj(lohi))
    lohi = mf.sweep_policy(pi_s, v0, o)
    out(name, "mf sweep_policy(pi_s, 0)", digest(o) + " " + digest_obj(lohi))
    bad = np.array(pi_s)
    x = int(np.flatnonzero(bad != 2)[-1])
    bad[x] = 2
    try:
        mf.check_policy(bad)
        msg = "accepted"
    except Exception as exc:  # a forbidden loiter somewhere, or accepted if allowed there
        msg = f"{type(exc).__name__}: {exc}"
    out(name, "mf check_policy(planted)", digest_obj(msg))
    greedy(name, params, b.lower, b.upper, model=None)


def greedy(name: str, params: Any, lower: np.ndarray, upper: np.ndarray, model: Any) -> None:
    """The greedy policy on the fly: actions, Monte Carlo returns and Table 1 trajectories."""
    from lpbounds.patrol import greedy_mc as gm
    from lpbounds.patrol.simulation import alert_sequence

    if model is not None:  # every state
        xs = np.arange(params.n_states, dtype=np.int64)
        out(name, "greedy_actions(all)", digest(gm.greedy_actions(params, lower, xs)))
    rng = np.random.default_rng(5)
    xs = rng.integers(0, params.n_states, size=20_000, dtype=np.int64)
    out(name, "greedy_actions(20,000)", digest(gm.greedy_actions(params, lower, xs)))
    for cv in (True, False):
        est = gm.greedy_value_mc(params, lower, upper, paths=PATHS, seed=7, control_variate=cv)
        out(
            name,
            f"greedy_value_mc cv={cv}",
            digest(est.starts, est.mean, est.std, est.half_width, est.ci_low, est.ci_high),
        )
    # the raw returns of one start (the kernel the estimate is made of)
    y = alert_sequence(PATHS * 50, float(params.alert_probabilities()[0]), params.m, 11)
    y = y.reshape(PATHS, 50)
    returns = np.empty(PATHS)
    kernel = gm._Kernel.of(params)
    run = getattr(gm, "_returns_kernel", None)
    if run is not None:  # an older tree's numba kernel (the port's "before")
        run(3, y, lower, kernel.args(), True, returns)
    else:  # C
        gm._returns(3, y, lower, kernel, True, returns)
    out(name, "greedy returns (raw)", digest(returns))
    t1 = gm.greedy_table1(params, lower, steps=3000, seeds=SEEDS)
    out(name, "greedy_table1", digest_obj(t1.summary()))
    seq = alert_sequence(4000, float(params.alert_probabilities()[0]), params.m, 3)
    r = gm.greedy_simulate(params, lower, seq, seed=3)
    out(name, "greedy_simulate", _sim_digest(r))


def _sim_digest(r: Any) -> str:
    arrays = [
        r.station, r.arrival, r.start, r.delay, r.delay_capped, r.delay_visit, r.loiters,
        r.complete, r.merged, r.merged_delay_sum,
    ]  # fmt: skip
    counts = [
        r.n_steps, r.n_arrivals, r.n_merged, r.n_absorbed, r.n_unserviced, r.n_loiter_steps,
        r.n_empty_loiter_steps, r.mismatches, r.first_mismatch, r.final_state,
    ]  # fmt: skip
    return digest(*arrays, np.array(counts, dtype=np.int64))


def array_model(name: str) -> None:
    """The model's decoder, successors, partitions and simulate's trajectories."""
    from lpbounds.dp import greedy_policy, solve_exact
    from lpbounds.patrol.greedy_mc import partition_bounds
    from lpbounds.patrol.model import PatrolModel
    from lpbounds.patrol.simulation import alert_sequence, simulate

    params = _params(name)
    pm = PatrolModel(params)
    xs = np.arange(pm.n_states, dtype=np.int64)
    out(name, "decode(all)", digest(*pm.decode(xs)))
    mdp = pm.mdp()
    out(name, "mdp successors", digest(mdp.successors))
    out(name, "state_partition(all)", digest(pm.state_partition(xs)))
    for a in range(3):
        y = np.arange(pm.n_states) % (params.m + 1)
        ok = mdp.allowed[:, a]
        out(name, f"step(action {a})", digest(pm.step(xs[ok], a, y[ok])))
    sol = solve_exact(mdp)
    b = partition_bounds(params)
    pi_s = np.asarray(greedy_policy(mdp, pm.partition().lift(b.lower)), dtype=np.int64)
    comps = pm.state_components()
    p0 = float(params.alert_probabilities()[0])
    for s in SEEDS:
        seq = alert_sequence(5000, p0, params.m, s)
        for key, pol in (("pi*", sol.policy), ("pi_s", pi_s)):
            r = simulate(pm, np.asarray(pol, dtype=np.int64), seq, seed=s, components=comps)
            out(name, f"simulate {key} seed {s}", _sim_digest(r))
    r = simulate(pm, np.asarray(sol.policy, np.int64), alert_sequence(300, p0, params.m, 9))
    out(name, "simulate (own comps)", _sim_digest(r))
    greedy(name, params, b.lower, b.upper, model=pm)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--m5", action="store_true", help="also the 5-station instance")
    args = ap.parse_args(argv)
    for name in ("patrol-small", "patrol-paper"):
        array_model(name)
        matrix_free(name)
    if args.m5:
        matrix_free("patrol-m5-paper")
    return 0


if __name__ == "__main__":
    sys.exit(main())
