"""The patrol's C kernels against numpy and plain-Python references, bit for bit.

:mod:`lpbounds._kernels.patrolsweeps` (the matrix-free walk, the model's decoder, successors
and partition key) and :mod:`lpbounds._kernels.patrolmc` (pi_s on the fly, its returns and
trajectories, the simulator of Table 1) replaced numba kernels with the same arithmetic.
The references here share no code with them: the model's arrays built by numpy
(``PatrolModel.mdp``), the loop-based model of ``tests/patrol/reference.py``, ``greedy_policy``
of the DP code, and the statistics, returns and simulation written out in Python floats in
the kernels' documented order. Random small patrols (1 to 4 stations, ``Gamma`` 1 to 5, the
empty loiter allowed or not), any chunk count, on one thread and on two; then every
argument check (a typed error naming the argument, never a wild read) and the promise that
the patrol runs without numba.
"""

from __future__ import annotations

import contextlib
import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from lpbounds import greedy_policy
from lpbounds._kernels import patrolmc, patrolsweeps, threads
from lpbounds.patrol import PatrolModel, PatrolParams, sweeps
from lpbounds.patrol import greedy_mc as gm
from lpbounds.patrol.model import decode_kernel, successor_kernel
from lpbounds.patrol.partitions import (
    alert_key_kernel,
    block_sizes,
    key_index_kernel,
    partition_index,
    state_partition_kernel,
)
from lpbounds.patrol.simulation import alert_sequence, simulate
from lpbounds.tolerances import GREEDY_TIE_RTOL

from .reference import RefPatrol
from .test_sweeps import per_state_q, values

SETTINGS = settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.filter_too_much]
)


@st.composite
def patrols(draw, max_states=3000):
    """A small patrol: any ring, 1 to 4 stations in any order, D 1..3, Gamma 1..5."""
    n_nodes = draw(st.integers(1, 6))
    m = draw(st.integers(1, min(4, n_nodes)))
    stations = tuple(draw(st.permutations(range(n_nodes)))[:m])
    gamma = draw(st.integers(1, 5))
    assume(2 * n_nodes * (gamma + 1) ** m <= max_states)
    return PatrolParams(
        N=n_nodes,
        stations=stations,
        D=draw(st.integers(1, 3)),
        Gamma=gamma,
        alpha=draw(st.sampled_from([1 / 60, 0.3, 1.5])),
        allow_empty_loiter=draw(st.booleans()),
    )


@contextlib.contextmanager
def on_threads(k):
    """Run the kernels on ``k`` threads (at most the CPUs there are)."""
    before = threads.get_threads()
    threads.set_threads(min(k, threads.default_threads()))
    try:
        yield
    finally:
        threads.set_threads(before)


def bits(a):
    a = np.ascontiguousarray(a)
    return a.view(np.uint8) if a.dtype == np.bool_ else a.view(f"u{a.itemsize}")


def same(a, b):
    return np.asarray(a).dtype == np.asarray(b).dtype and np.array_equal(bits(a), bits(b))


def chunk_bounds(n, nchunks, radix):
    """The kernels' chunks: ``ceil(n / nchunks)`` rounded up to whole rows."""
    size = -(-n // nchunks)
    size = -(-size // radix) * radix
    return [(min(n, c * size), min(n, (c + 1) * size)) for c in range(nchunks)]


# ---------------------------------------------------------------------- the walk
@SETTINGS
@given(
    params=patrols(), k=st.sampled_from([1, 2]), nchunks=st.integers(1, 40), seed=st.integers(0, 99)
)
def test_sweeps_and_passes_equal_the_model_arrays(params, k, nchunks, seed):
    """max_sweep, policy_sweep, the labels, decode and successor passes, the reward scale and
    the policy check against the decode-per-state arrays of the model (numpy)."""
    pm = PatrolModel(params)
    mdp, geo, n = pm.mdp(), sweeps.geometry(params), pm.n_states
    v = values(n, seed)
    q = per_state_q(mdp, v)
    with on_threads(k):
        out, arg = np.full(n, np.nan), np.full(n, 9, dtype=np.int8)
        lo, hi = sweeps.max_sweep(*geo, mdp.discount, v, out, arg, nchunks)
        want = q.max(axis=1)
        assert same(out, want) and np.array_equal(arg, q.argmax(axis=1))
        assert (lo, hi) == ((want - v).min(), (want - v).max())
        rng = np.random.default_rng(seed)
        act = rng.integers(0, 2, size=n).astype(np.int8)
        act[mdp.allowed[:, 2] & (rng.random(n) < 0.5)] = 2
        lo, hi = sweeps.policy_sweep(*geo, mdp.discount, act, v, out, nchunks)
        want = q[np.arange(n), act]
        assert same(out, want) and (lo, hi) == ((want - v).min(), (want - v).max())
        labels = np.empty(n, dtype=np.int64)
        sweeps.labels_pass(*geo[:4], labels, nchunks)
        assert np.array_equal(labels, pm.partition().labels)
        comps = np.empty((n, 3 + params.m), dtype=np.int64)
        sweeps.decode_range(*geo[:4], 0, comps, nchunks)
        assert np.array_equal(comps, pm.state_components(np.int64))
        for a in range(3):
            got = np.empty((n, params.m + 1), dtype=np.int64)
            sweeps.successor_range(*geo[:4], a, got, nchunks)
            want_s = np.where(mdp.allowed[:, a, None], mdp.successors[:, a, :], -1)
            assert np.array_equal(got, want_s)
        absmax = sweeps.reward_absmax_pass(*geo[:4], *geo[5:], nchunks)
        assert absmax == np.abs(mdp.rewards[mdp.allowed]).max()
        forbidden = np.flatnonzero(~mdp.allowed[:, 2])
        act[:] = 0
        act[forbidden[::3]] = 2
        first = int(forbidden[0]) if forbidden.size else -1
        assert sweeps.check_policy_pass(*geo[:4], act, nchunks) == first


def greedy_reference(q_v, q_w, allowed, v, labels, w_low, v_up, pistar, loss_tol, chunks):
    """pi_s and the per-chunk statistics of the greedy pass, in Python floats, state by state
    in index order within each chunk (the documented order of the C pass)."""
    n = v.size
    pi = np.empty(n, dtype=np.int8)
    f = np.empty((len(chunks), 9))
    st_ = np.zeros((len(chunks), 5), dtype=np.int64)
    for c, (lo, hi) in enumerate(chunks):
        up_sum = low_sum = gap_sum = 0.0
        up_max = low_max = gap_max = loss_max = -math.inf
        up_min = low_min = math.inf
        for x in range(lo, hi):
            n_act = 3 if allowed[x, 2] else 2
            qv = [float(q) for q in q_v[x, :n_act]]
            qw = [float(q) for q in q_w[x, :n_act]]
            best_v, best_w = max(qv), max(qw)
            thr = best_w - GREEDY_TIE_RTOL * max(1.0, abs(best_w))
            a_s = next(a for a in range(n_act) if qw[a] >= thr)
            pi[x] = a_s
            st_[c, 2] += qv[a_s] >= best_v - GREEDY_TIE_RTOL * max(1.0, abs(best_v))
            loss = best_v - qv[a_s]
            loss_max = max(loss_max, loss)
            st_[c, 4] += loss > loss_tol
            st_[c, 3] += a_s != pistar[x]
            kx = labels[x]
            up, low = float(v_up[kx] - v[x]), float(v[x] - w_low[kx])
            up_sum += up
            up_max = max(up_max, up)
            if up < up_min:
                up_min, st_[c, 0] = up, x
            low_sum += low
            low_max = max(low_max, low)
            if low < low_min:
                low_min, st_[c, 1] = low, x
            gap = float(v_up[kx] - w_low[kx])
            gap_sum += gap
            gap_max = max(gap_max, gap)
        f[c] = [up_sum, up_max, up_min, low_sum, low_max, low_min, gap_sum, gap_max, loss_max]
    return pi, f, st_


def vsub_reference(vstar, vsub, labels, w_low, chunks):
    """The V_sub pass's per-chunk statistics in Python floats, in index order."""
    f = np.empty((len(chunks), 4))
    st_ = np.zeros((len(chunks), 3), dtype=np.int64)
    for c, (lo, hi) in enumerate(chunks):
        s, mx, mn, low_min = 0.0, -math.inf, math.inf, math.inf
        for x in range(lo, hi):
            d = float(vstar[x] - vsub[x])
            s += d
            if d > mx:
                mx, st_[c, 0] = d, x
            if d < mn:
                mn, st_[c, 1] = d, x
            low = float(vsub[x] - w_low[labels[x]])
            if low < low_min:
                low_min, st_[c, 2] = low, x
        f[c] = [s, mx, mn, low_min]
    return f, st_


@SETTINGS
@given(
    params=patrols(), k=st.sampled_from([1, 2]), nchunks=st.integers(1, 40), seed=st.integers(0, 99)
)
def test_greedy_and_vsub_passes_equal_python_per_chunk(params, k, nchunks, seed):
    """The greedy pass: pi_s is greedy_policy's of the lifted w_low, and every per-chunk
    statistic is the Python reference's, bit for bit; the same for the V_sub pass."""
    pm = PatrolModel(params)
    mdp, geo, n = pm.mdp(), sweeps.geometry(params), pm.n_states
    labels = pm.partition().labels
    rng = np.random.default_rng(seed)
    v = values(n, seed)
    w_low = rng.normal(size=pm.n_partitions) - 2.0
    w_low[rng.random(w_low.size) < 0.3] = -2.0  # ties among the lifted Q-values
    v_up = w_low + 4.0 + rng.random(pm.n_partitions)
    pistar = per_state_q(mdp, v).argmax(axis=1).astype(np.int8)
    chunks = chunk_bounds(n, nchunks, params.Gamma + 1)
    want = greedy_reference(
        per_state_q(mdp, v), per_state_q(mdp, w_low[labels]), mdp.allowed, v, labels, w_low,
        v_up, pistar, 1e-9, chunks,
    )  # fmt: skip
    assert np.array_equal(want[0], greedy_policy(mdp, w_low[labels]))
    with on_threads(k):
        pi_s = np.full(n, 7, dtype=np.int8)
        f, st_ = np.full((nchunks, 9), np.nan), np.full((nchunks, 5), -9, dtype=np.int64)
        args = (v, labels.astype(np.int32), w_low, v_up, pistar, GREEDY_TIE_RTOL, 1e-9)
        sweeps.greedy_pass(*geo, mdp.discount, *args, pi_s, f, st_, nchunks)
        assert same(pi_s, want[0]) and same(f, want[1]) and same(st_, want[2])
        vsub = v - rng.random(n)
        f, st_ = np.full((nchunks, 4), np.nan), np.full((nchunks, 3), -9, dtype=np.int64)
        sweeps.vsub_pass(*geo[:4], v, vsub, w_low, f, st_, nchunks)
        want_f, want_st = vsub_reference(v, vsub, labels, w_low, chunks)
        assert same(f, want_f) and same(st_, want_st)


# ---------------------------------------------------------------------- the model
@SETTINGS
@given(params=patrols(max_states=1500), k=st.sampled_from([1, 2]))
def test_decoder_successors_and_keys_equal_the_loop_reference(params, k):
    """decode_kernel and successor_kernel against the loop-based model of the specification
    (its states listed by nested loops, its step written from the text); the partition of
    every state, by key and by state, against partition_index (numpy)."""
    p = params
    pm = PatrolModel(p)
    ref = RefPatrol(N=p.N, stations=p.stations, D=p.D, Gamma=p.Gamma,
                    allow_empty_loiter=p.allow_empty_loiter)  # fmt: skip
    n = pm.n_states
    assert len(ref.states) == n
    with on_threads(k):
        xs = np.arange(n, dtype=np.int64)
        l, w, d = (np.empty(n, dtype=np.int64) for _ in range(3))
        tau = np.empty((n, p.m), dtype=np.int16)
        decode_kernel(xs, pm.n_travel, pm.radix, p.m, p.D, pm.stations, l, w, d, tau)
        comps = np.column_stack([l, w, d, tau]).tolist()
        assert [tuple(c) for c in comps] == ref.states
        allowed = pm.allowed(l, d, tau)
        for a in range(3):
            sel = np.flatnonzero(allowed[:, a])
            out = np.empty((sel.size, p.m + 1), dtype=np.int64)
            successor_kernel(
                l[sel], w[sel], d[sel], np.ascontiguousarray(tau[sel]), a, p.N, p.D, p.Gamma,
                pm.radix, pm.n_travel, pm.station_pos, pm.w_travel, pm.w_loiter, out,
            )  # fmt: skip
            for i, x in enumerate(sel):
                want = [ref.index[ref.step(ref.states[x], a, y)] for y in range(p.m + 1)]
                assert out[i].tolist() == want
    tb_size, lb_size = block_sizes(p)
    want = partition_index(p, l, w, d, tau > 0, tau.max(axis=1), check=False)
    sp = p.station_pos
    for x in range(n):
        acode, tb = alert_key_kernel(tau[x])
        assert (acode, tb) == (int((tau[x] > 0) @ (1 << np.arange(p.m - 1, -1, -1))), tau[x].max())
        args = (sp, p.N, p.D, p.Gamma, tb_size, lb_size)
        assert key_index_kernel(l[x], w[x], d[x], acode, tb, *args, p.m) == want[x]
        assert state_partition_kernel(l[x], w[x], d[x], tau[x], *args) == want[x]


# ---------------------------------------------------------------------- pi_s on the fly
def walk_returns(mdp, pi_s, w, x0, y, cv):
    """The discounted return of each path of y (paths, H) from x0 walked on the model's
    arrays under pi_s, in Python floats in the kernel's order: g += disc r; with cv,
    g -= disc lambda (w(x') - sum_l p_l w(f(x, u, Y_l))); disc *= lambda."""
    lam, probs = mdp.discount, [float(p) for p in mdp.probabilities]
    succ, rewards = mdp.successors, mdp.rewards
    out, trails = [], []
    for path in y:
        x, g, disc, trail = x0, 0.0, 1.0, [x0]
        for yt in path:
            a = pi_s[x]
            nxt = succ[x, a]
            g += disc * float(rewards[x, a])
            if cv:
                ev = 0.0
                for o, p in enumerate(probs):
                    ev += p * float(w[nxt[o]])
                g -= disc * lam * (float(w[nxt[yt]]) - ev)
            disc *= lam
            x = int(nxt[yt])
            trail.append(x)
        out.append(g)
        trails.append(trail)
    return np.array(out), trails


@SETTINGS
@given(params=patrols(max_states=2000), k=st.sampled_from([1, 2]), seed=st.integers(0, 99),
       cv=st.booleans())  # fmt: skip
def test_greedy_actions_returns_and_trajectories_equal_a_walk_on_the_arrays(params, k, seed, cv):
    """pi_s at every state is greedy_policy's; each path's return and each trajectory are
    those of a walk on the model's arrays under it, bit for bit."""
    pm = PatrolModel(params)
    mdp = pm.mdp()
    b = gm.partition_bounds(params)
    w = b.lower[pm.partition().labels]
    pi_s = greedy_policy(mdp, w)
    rng = np.random.default_rng(seed)
    x0 = int(rng.integers(0, pm.n_states))
    y = alert_sequence(7 * 30, float(mdp.probabilities[0]), params.m, seed).reshape(7, 30)
    want, trails = walk_returns(mdp, pi_s, w, x0, y, cv)
    with on_threads(k):
        assert same(
            gm.greedy_actions(params, b.lower, np.arange(pm.n_states)), pi_s.astype(np.int8)
        )
        got = np.full(7, np.nan)
        gm._returns(x0, y, b.lower, gm._Kernel.of(params), cv, got)
        assert same(got, want)
    states, actions = np.empty(31, dtype=np.int64), np.empty(30, dtype=np.int64)
    patrolmc.greedy_trajectory(x0, y[0], b.lower, gm._Kernel.of(params).args(), states, actions)
    assert states.tolist() == trails[0] and np.array_equal(actions, pi_s[states[:-1]])


# ---------------------------------------------------------------------- the simulator
def simulate_reference(comps, succ, pol, x0, stations, n_nodes, gamma, y, check):
    """Table 1's bookkeeping in plain Python (lpbounds.patrol.simulation's conventions):
    records of the serviced alerts, the counts, the unserviced alerts, the final state."""
    m = len(stations)
    rec, run = [], None
    pend, arr, visit = [False] * m, [0] * m, [-1] * m
    mcount, msum = [0] * m, [0] * m
    arrivals = merged = absorbed = loiter = mismatch = empty = 0
    first = -1
    x = x0
    for t, yt in enumerate(y):
        l, w, d = (int(c) for c in comps[x, :3])
        a = int(pol[x])
        jl = max((j for j in range(m) if stations[j] == l), default=-1)
        if jl >= 0 and pend[jl] and visit[jl] < 0:
            visit[jl] = t
        if a == 2:
            loiter += 1
            if d == 0 and jl >= 0 and pend[jl]:
                rec.append(
                    [jl, arr[jl], t, visit[jl], 0, False, mcount[jl], mcount[jl] * t - msum[jl]]
                )
                run = rec[-1]
                pend[jl], mcount[jl], msum[jl] = False, 0, 0
            if run is not None:
                run[4] += 1
            else:
                empty += 1
        else:
            if run is not None:
                run[5] = True
            run = None
        if yt > 0:
            j = yt - 1
            arrivals += 1
            if a == 2 and jl == j:
                absorbed += 1
            elif pend[j]:
                merged += 1
                mcount[j] += 1
                msum[j] += t
            else:
                pend[j], arr[j], visit[j] = True, t, -1
        xn = int(succ[x, a, yt])
        if check:
            u = (1, -1, 0)[a]
            nxt = [(l + w * u) % n_nodes, w * u, 0] if u else [l, 1, d + 1]
            for j in range(m):
                tj = int(comps[x, 3 + j])
                v = (
                    0
                    if (u == 0 and j == jl)
                    else min(tj + 1, gamma)
                    if tj > 0
                    else int(yt == j + 1)
                )
                ok = pend[j] == (v > 0) and (not pend[j] or v == min(t + 1 - arr[j], gamma))
                nxt.append(v if ok else -1)
            if [int(c) for c in comps[xn]] != nxt:
                mismatch += 1
                first = t if first < 0 else first
        x = xn
    counts = [arrivals, merged, absorbed, loiter, mismatch, first, empty, 0]
    return rec, counts, sum(pend), x


@SETTINGS
@given(params=patrols(max_states=2000), seed=st.integers(0, 99), check=st.booleans(),
       wide=st.booleans(), broken=st.booleans())  # fmt: skip
def test_simulator_equals_the_python_bookkeeping(params, seed, check, wide, broken):
    """simulate's records and counts against the bookkeeping written out in Python, on a
    random allowed policy; ``broken``: a successor table with planted wrong entries, whose
    mismatches both must count alike."""
    pm = PatrolModel(params)
    mdp = pm.mdp()
    n = pm.n_states
    rng = np.random.default_rng(seed)
    pol = rng.integers(0, 2, size=n)
    pol[mdp.allowed[:, 2] & (rng.random(n) < 0.7)] = 2
    succ = np.array(mdp.successors, dtype=np.int64 if wide else np.int32)
    if broken:
        bad = rng.integers(0, n, size=(max(1, n // 20), 3))
        succ[bad[:, 0], bad[:, 1] % 3, 0] = bad[:, 2]
    comps = pm.state_components(np.int64 if wide else np.int32)
    y = alert_sequence(600, 0.5, params.m, seed)
    x0 = int(rng.integers(0, n))
    stations = [int(s) for s in params.stations]
    rec, counts, unserviced, final = simulate_reference(
        comps, succ, pol, x0, stations, params.N, params.Gamma, y, check
    )
    model = type("M", (), {"params": params, "mdp": lambda self: _with_successors(mdp, succ)})()
    r = simulate(model, pol, y, start=x0, check=check, components=comps)
    cols = list(zip(*rec, strict=True)) if rec else [()] * 8
    assert r.station.tolist() == list(cols[0]) and r.arrival.tolist() == list(cols[1])
    assert r.start.tolist() == list(cols[2]) and (r.delay_visit + r.arrival).tolist() == list(
        cols[3]
    )
    assert r.loiters.tolist() == list(cols[4]) and r.complete.tolist() == list(cols[5])
    assert r.merged.tolist() == list(cols[6]) and r.merged_delay_sum.tolist() == list(cols[7])
    got = [r.n_arrivals, r.n_merged, r.n_absorbed, r.n_loiter_steps, r.mismatches,
           r.first_mismatch, r.n_empty_loiter_steps, 0]  # fmt: skip
    assert got == counts and r.n_unserviced == unserviced and r.final_state == final


def _with_successors(mdp, succ):
    """The model's MDP with another successor table (the same allowed pairs)."""
    from lpbounds import FiniteMDP

    return FiniteMDP(succ, mdp.probabilities, mdp.rewards, mdp.discount, allowed=mdp.allowed)


# ---------------------------------------------------------------------- argument checks
@pytest.fixture(scope="module")
def small():
    params = PatrolParams(N=5, stations=(0, 2), D=2, Gamma=3)
    pm = PatrolModel(params)
    return params, pm, sweeps.geometry(params), pm.n_states


def test_walk_refuses_a_geometry_that_is_not_its_definition(small):
    """Every kernel checks the geometry exactly: a tampered plane, weight, size or station
    is a ValueError naming it (the walk would otherwise read outside the vectors)."""
    _, _, geo, n = small
    v, out, arg = np.zeros(n), np.empty(n), np.empty(n, dtype=np.int8)

    def sweep(g):
        return patrolsweeps.max_sweep(*g, 0.9, v, out, arg, 4, 0, 4)

    sweep(geo)
    cases = [(1, (3, 9), 10**9, r"planes\[3, 9\] \(x0\)"),
             (1, (2, 6), -5, r"planes\[2, 6\] \(b0\)"),
             (3, (2, 0), 7, r"weights\[m\]\[0\]"), (3, (0, 1), 2, r"weights\[0, 1\]"),
             (0, (8,), n + 1, r"geo\[8\]"), (0, (3,), 40, r"geo\[4\]"),
             (2, (1,), 1, r"station_pos\[1\]")]  # fmt: skip
    for which, index, value, message in cases:
        g = [a.copy() for a in geo]
        g[which][index] = value
        with pytest.raises(ValueError, match=message):
            sweep(g)
    with pytest.raises(ValueError, match="planes: shape"):
        sweep([geo[0], geo[1][:-1], *geo[2:]])


def test_walk_refuses_arrays_of_the_wrong_kind_size_or_content(small):
    params, pm, geo, n = small
    v, out, arg = np.zeros(n), np.empty(n), np.empty(n, dtype=np.int8)
    with pytest.raises(TypeError, match=r"^v: expected a 1-dimensional float64"):
        patrolsweeps.max_sweep(*geo, 0.9, v.astype(np.float32), out, arg, 4, 0, 4)
    with pytest.raises(TypeError, match=r"^arg: expected a 1-dimensional integer"):
        patrolsweeps.max_sweep(*geo, 0.9, v, out, arg.astype(np.int64), 4, 0, 4)
    with pytest.raises(TypeError, match=r"^out: not C-contiguous"):
        patrolsweeps.max_sweep(*geo, 0.9, v, np.empty(2 * n)[::2], arg, 4, 0, 4)
    with pytest.raises(TypeError, match=r"^out: expected a writable"):
        ro = np.empty(n)
        ro.flags.writeable = False
        patrolsweeps.max_sweep(*geo, 0.9, v, ro, arg, 4, 0, 4)
    with pytest.raises(ValueError, match=r"^v: length"):
        patrolsweeps.max_sweep(*geo, 0.9, v[:-1], out, arg, 4, 0, 4)
    with pytest.raises(ValueError, match="range"):
        patrolsweeps.max_sweep(*geo, 0.9, v, out, arg, 4, 2, 5)
    with pytest.raises(ValueError, match="nchunks"):
        patrolsweeps.max_sweep(*geo, 0.9, v, out, arg, 0, 0, 0)
    with pytest.raises(ValueError, match=r"^pent: length"):
        patrolsweeps.max_sweep(*geo[:6], geo[6][:-1], 0.9, v, out, arg, 4, 0, 4)
    act = np.zeros(n, dtype=np.int8)
    forbidden = int(np.flatnonzero(~pm.mdp().allowed[:, 2])[4])
    for x, a in ((17, 3), (23, -1), (forbidden, 2)):
        bad = act.copy()
        bad[x] = a
        with pytest.raises(ValueError, match=rf"^act\[{x}\] = {a} is not an allowed action"):
            sweeps.policy_sweep(*geo, 0.9, bad, v, out, 4)
    labels = pm.partition().labels.astype(np.int32)
    w = np.zeros(pm.n_partitions)
    f, st_ = np.empty((4, 9)), np.empty((4, 5), dtype=np.int64)
    pi = np.empty(n, dtype=np.int8)
    for value in (-1, pm.n_partitions):
        bad = labels.copy()
        bad[11] = value
        with pytest.raises(ValueError, match=rf"^labels\[11\] = {value} is not a partition"):
            sweeps.greedy_pass(*geo, 0.9, v, bad, w, w, act, 1e-12, 0.0, pi, f, st_, 4)
    with pytest.raises(ValueError, match=r"^fstats: shape"):
        sweeps.greedy_pass(*geo, 0.9, v, labels, w, w, act, 1e-12, 0.0, pi, f[:3], st_, 4)
    with pytest.raises(ValueError, match=r"^w_low: length"):
        sweeps.vsub_pass(*geo[:4], v, v, w[:-1], np.empty((4, 4)), np.empty((4, 3), np.int64), 4)
    with pytest.raises(ValueError, match="start0"):
        sweeps.decode_range(*geo[:4], 3, np.empty((n, 3 + params.m), dtype=np.int64), 2)
    with pytest.raises(ValueError, match="action = 3"):
        sweeps.successor_range(*geo[:4], 3, np.empty((n, params.m + 1), dtype=np.int64), 2)


def test_model_kernels_refuse_what_is_not_a_state(small):
    params, pm, _, n = small
    x = np.array([0, n], dtype=np.int64)
    l, w, d = (np.empty(2, dtype=np.int64) for _ in range(3))
    tau = np.empty((2, params.m), dtype=np.int16)
    with pytest.raises(ValueError, match=rf"^x\[1\] = {n} is not a state"):
        decode_kernel(x, pm.n_travel, pm.radix, params.m, params.D, pm.stations, l, w, d, tau)
    with pytest.raises(TypeError, match=r"^tau: expected a 2-dimensional integer"):
        decode_kernel(x[:1], pm.n_travel, pm.radix, params.m, params.D, pm.stations, l[:1], w[:1],
                      d[:1], tau[:1].astype(np.int64))  # fmt: skip
    args = (pm.radix, pm.n_travel, pm.station_pos, pm.w_travel, pm.w_loiter)
    out = np.empty((1, params.m + 1), dtype=np.int64)
    one = np.array([1]), np.array([1]), np.array([0])
    with pytest.raises(ValueError, match="loiter needs a station"):
        successor_kernel(*one, tau[:1], 2, params.N, params.D, params.Gamma, *args, out)
    with pytest.raises(ValueError, match="l is not a node"):
        successor_kernel(np.array([5]), *one[1:], tau[:1], 0, params.N, params.D, params.Gamma,
                         *args, out)  # fmt: skip
    sp = params.station_pos
    with pytest.raises(ValueError, match="needs a station"):
        key_index_kernel(1, 1, 1, 0, 0, sp, params.N, params.D, params.Gamma, 1, 1, params.m)
    with pytest.raises(ValueError, match="0 <= l < N"):
        state_partition_kernel(9, 1, 0, tau[0], sp, params.N, params.D, params.Gamma, 1, 1)


def test_monte_carlo_kernels_refuse_bad_tables_states_and_outcomes(small):
    params, _, _, n = small
    k = gm._Kernel.of(params)
    lower = np.zeros(params.n_partitions)
    y = np.zeros((3, 5), dtype=np.int64)
    out = np.empty(3)
    patrolmc.greedy_returns(0, y, lower, k.args(), True, out, 0, 3)
    with pytest.raises(ValueError, match=r"^x0 = -1 is not a state"):
        patrolmc.greedy_returns(-1, y, lower, k.args(), True, out, 0, 3)
    bad = y.copy()
    bad[2, 4] = params.m + 1
    with pytest.raises(ValueError, match=r"outcomes \(flat\) \[14\] = 3 is not an outcome"):
        patrolmc.greedy_returns(0, bad, lower, k.args(), True, out, 0, 3)
    with pytest.raises(ValueError, match=r"^lower: length"):
        patrolmc.greedy_returns(0, y, lower[:-1], k.args(), True, out, 0, 3)
    with pytest.raises(TypeError, match=r"^mt: expected the tuple"):
        patrolmc.greedy_returns(0, y, lower, k.args()[:9], True, out, 0, 3)
    for field, index, value, message in (
        ("cfg", 4, k.cfg[4] + 1, r"mt cfg\[4\]"),
        ("w_loiter", (1, 0), 3, r"mt w_loiter\[1, 0\]"),
        ("station_pos", 1, 1, r"station_pos\[1\]"),
    ):
        arr = getattr(k, field).copy()
        arr[index] = value
        args = list(k.args())
        args[["cfg", "station_pos", "stations", "w_travel", "w_loiter"].index(field)] = arr
        with pytest.raises(ValueError, match=message):
            patrolmc.greedy_returns(0, y, lower, tuple(args), True, out, 0, 3)
    with pytest.raises(ValueError, match=r"^xs\[1\]"):
        patrolmc.greedy_actions(np.array([0, n]), lower, k.args(), np.empty(2, np.int8), 0, 2)


def test_simulator_checks_every_index_it_reads(small):
    params, pm, _, n = small
    mdp = pm.mdp()
    succ = np.array(mdp.successors, dtype=np.int64)
    comps = pm.state_components(np.int64)
    pol = np.zeros(n, dtype=np.int64)
    st_ = np.asarray(params.stations, dtype=np.int64)
    y = np.zeros(50, dtype=np.int64)

    def run(pol=pol, succ=succ, comps=comps, y=y, x0=0):
        cap = y.size + 1
        rec = [np.zeros(cap, np.int64) for _ in range(5)] + [np.zeros(cap, np.bool_)]
        rec += [np.zeros(cap, np.int64), np.zeros(cap, np.int64)]
        return patrolmc.simulate(x0, pol, succ, comps, st_, params.N, params.Gamma, y, True,
                                 *rec, np.zeros(8, np.int64))  # fmt: skip

    run()
    bad = succ.copy()
    bad[0, 0, 0] = n
    with pytest.raises(ValueError, match=rf"step 0: successors\[0, 0, 0\] = {n} is not a state"):
        run(succ=bad)
    bad = pol.copy()
    bad[0] = 3
    with pytest.raises(ValueError, match=r"step 0: policy\[0\] = 3 is not an action"):
        run(pol=bad)
    with pytest.raises(ValueError, match=r"outcomes\[2\] = 3 is not an outcome"):
        run(y=np.array([0, 1, 3], dtype=np.int64))
    with pytest.raises(ValueError, match=r"^comps: shape"):
        run(comps=comps[:, :-1].copy())
    with pytest.raises(ValueError, match="start"):
        run(x0=n)


# ---------------------------------------------------------------------- no numba
def test_the_patrol_runs_without_numba():
    """Every module of lpbounds.patrol imports, and a matrix-free solve, its passes, the
    greedy Monte Carlo and Table 1 run, without numba in the process."""
    code = """
import pkgutil, sys, importlib
import lpbounds.patrol
for mod in pkgutil.iter_modules(lpbounds.patrol.__path__):
    importlib.import_module("lpbounds.patrol." + mod.name)
from lpbounds.patrol import PatrolParams
from lpbounds.patrol.matrix_free import MatrixFreePatrol, solve_vstar, evaluate_policy
from lpbounds.patrol.greedy_mc import partition_bounds, greedy_value_mc, greedy_table1
p = PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4)
mf = MatrixFreePatrol(p)
r = solve_vstar(mf)
b = partition_bounds(p)
pi_s, g = mf.greedy_gap(r.values, r.policy, b.lower, b.upper, 1e-9)
evaluate_policy(mf, pi_s)
greedy_value_mc(p, b.lower, b.upper, paths=20, horizon=30)
greedy_table1(p, b.lower, steps=300, seeds=(1,))
assert "numba" not in sys.modules, sorted(m for m in sys.modules if "numba" in m)[:5]
print("ok")
"""
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert res.returncode == 0 and res.stdout.strip() == "ok", res.stderr[-2000:]
