"""Tests of the patrol Monte Carlo (lpbounds.patrol.simulation).

The reference here is a deliberately simple, loop-based implementation of
``patrol-spec.md`` (:class:`SpecModel`), written for these tests and shared with no
package code; the Monte Carlo's statistics are compared with expectations computed
exactly from the Markov chain of the simulated policy.
"""

from __future__ import annotations

import itertools
import math
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

from lpbounds import FiniteMDP, solve_exact
from lpbounds.errors import ValidationError
from lpbounds.patrol.simulation import (
    alert_sequence,
    alert_statistics,
    pooled_statistics,
    simulate,
    spec_step,
)


def info(d: float, p=0.01, a=0.5, b=0.45, c=0.5, g=0.45, mu1=1.0, mu2=1.0) -> float:
    """Mutual information I(d) of Appendix A, in nats, written out term by term."""
    ptr = a + b * (1 - math.exp(-mu1 * d))
    pftr = c + g * (1 - math.exp(-mu2 * d))
    z1 = p * ptr + (1 - p) * (1 - pftr)
    z2 = p * (1 - ptr) + (1 - p) * pftr
    terms = [
        (p * ptr, ptr / z1),
        (p * (1 - ptr), (1 - ptr) / z2),
        ((1 - p) * (1 - pftr), (1 - pftr) / z1),
        ((1 - p) * pftr, pftr / z2),
    ]
    return sum(w * math.log(r) for w, r in terms if w > 0)


class SpecModel:
    """The patrol MDP of patrol-spec.md, built with plain Python loops (test reference)."""

    def __init__(
        self,
        N=6,
        stations=(0, 3),
        D=2,
        Gamma=4,
        rho=0.005,
        discount=0.9,
        alpha=0.2,
        allow_empty_loiter=False,
    ):
        self.params = SimpleNamespace(
            N=N,
            stations=tuple(stations),
            D=D,
            Gamma=Gamma,
            rho=rho,
            discount=discount,
            alpha=alpha,
            allow_empty_loiter=allow_empty_loiter,
        )
        m = len(stations)
        states = []
        for l in range(N):
            for w in (1, -1):
                for tau in itertools.product(range(Gamma + 1), repeat=m):
                    states.append((l, w, 0, *tau))
        for j, l in enumerate(stations):
            for d in range(1, D + 1):
                for tau in itertools.product(range(Gamma + 1), repeat=m):
                    if tau[j] == 0:
                        states.append((l, 1, d, *tau))
        self.states = states
        self.index = {s: i for i, s in enumerate(states)}
        self._mdp = None

    def f(self, s, a, y):
        l, w, d, *tau = s
        u = (1, -1, 0)[a]
        st = self.params.stations
        if u != 0:
            l2, w2, d2 = (l + w * u) % self.params.N, w * u, 0
        else:
            l2, w2, d2 = l, 1, d + 1
        new = []
        for j, tj in enumerate(tau):
            if u == 0 and st[j] == l:
                new.append(0)
            elif tj > 0:
                new.append(min(tj + 1, self.params.Gamma))
            elif y == j + 1:
                new.append(1)
            else:
                new.append(0)
        return (l2, w2, d2, *new)

    def allowed(self, s, a):
        l, _, d, *tau = s
        if a < 2:
            return True
        st = self.params.stations
        if l not in st or d >= self.params.D:
            return False
        return d > 0 or self.params.allow_empty_loiter or tau[st.index(l)] > 0

    def mdp(self):
        if self._mdp is None:
            p = self.params
            m = len(p.stations)
            n = len(self.states)
            succ = np.zeros((n, 3, m + 1), dtype=np.int64)
            rew = np.zeros((n, 3))
            allowed = np.zeros((n, 3), dtype=bool)
            for x, s in enumerate(self.states):
                for a in range(3):
                    if not self.allowed(s, a):
                        continue
                    allowed[x, a] = True
                    for y in range(m + 1):
                        succ[x, a, y] = self.index[self.f(s, a, y)]
                    gain = info(s[2] + 1) - info(s[2]) if a == 2 else 0.0
                    rew[x, a] = gain - p.rho * min(max(s[3:]), p.Gamma)
            p0 = math.exp(-p.alpha)
            probs = np.array([p0] + [(1 - p0) / m] * m)
            self._mdp = FiniteMDP(succ, probs, rew, p.discount, allowed=allowed)
        return self._mdp

    def state_components(self):
        return np.array(self.states, dtype=np.int64)

    def encode(self, l, w, d, tau):
        tau = np.atleast_2d(tau)
        ls, ws, ds = (np.broadcast_to(v, (tau.shape[0],)) for v in (l, w, d))
        return np.array(
            [
                self.index[(int(a), int(b), int(c), *map(int, t))]
                for a, b, c, t in zip(ls, ws, ds, tau, strict=True)
            ]
        )

    def p0(self):
        return math.exp(-self.params.alpha)


@pytest.fixture(scope="module")
def spec():
    return SpecModel()


def test_spec_step_matches_loop_reference_on_every_pair(spec):
    comps = spec.state_components()
    m = len(spec.params.stations)
    for a in range(3):
        for y in range(m + 1):
            got = spec_step(comps, a, y, spec.params.stations, spec.params.N, spec.params.Gamma)
            want = np.array([spec.f(s, a, y) for s in spec.states])
            np.testing.assert_array_equal(got, want, err_msg=f"action {a}, outcome {y}")


def test_spec_step_matches_patrol_model_step_on_random_states():
    # plain imports: a missing or renamed lpbounds module is a failure, never a skip
    from lpbounds.patrol.model import PatrolModel
    from lpbounds.patrol.params import PatrolParams

    params = PatrolParams(N=9, stations=(0, 4, 6), D=3, Gamma=5)
    model = PatrolModel(params)
    rng = np.random.default_rng(0)
    x = rng.integers(0, model.n_states, size=4000)
    comps = model.state_components()[x]
    m = len(params.stations)
    for a in range(3):
        ok = model.mdp().allowed[x, a]
        for y in range(m + 1):
            nxt = model.step(x[ok], a, y)
            want = spec_step(comps[ok], a, y, params.stations, params.N, params.Gamma)
            np.testing.assert_array_equal(
                model.state_components()[nxt], want, err_msg=f"action {a}, outcome {y}"
            )


def test_alert_sequence_rate_and_uniform_stations():
    p0, m, n = math.exp(-1 / 60), 4, 600_000
    y = alert_sequence(n, p0, m, seed=3)
    k = int((y > 0).sum())
    sd = math.sqrt(n * p0 * (1 - p0))
    assert abs(k - n * (1 - p0)) < 5 * sd, f"{k} alerts vs {n * (1 - p0):.0f} +- 5 sd ({sd:.1f})"
    counts = np.bincount(y[y > 0], minlength=m + 1)[1:]
    assert np.all(np.abs(counts - k / m) < 5 * math.sqrt(k / m)), counts
    np.testing.assert_array_equal(y, alert_sequence(n, p0, m, seed=3))
    with pytest.raises(ValidationError):
        alert_sequence(0, p0, m, seed=1)


def _policy(model, rule):
    comps = model.state_components()
    pol = np.array([rule(tuple(c)) for c in comps], dtype=np.int64)
    return pol


def test_hand_traced_trajectory():
    # ring of 6 nodes, stations 0 and 3, D = 2, Gamma = 4; the UAV always goes on,
    # and loiters whenever allowed (own alert, or dwell below D)
    model = SpecModel(N=6, stations=(0, 3), D=2, Gamma=4)

    def rule(s):
        return 2 if model.allowed(s, 2) else 0

    pol = _policy(model, rule)
    # step 0: alert at station 3 (outcome 2); UAV at 0 (no alert) -> moves to 1, 2, 3
    # step 3: UAV at node 3, loiters (delay 3 - 0 = 3), step 4: loiter (d = 1),
    # step 5: d = D -> leaves; meanwhile an alert at station 3 arrives on step 4 (absorbed)
    # and one at station 0 on step 1 (pending from then), merged with one on step 2.
    y = np.array([2, 1, 1, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0])
    r = simulate(model, pol, y, policy_name="hand")
    assert r.mismatches == 0
    # the UAV leaves node 3 on step 5 (d = D) and reaches node 0 on step 8 (4, 5, 0):
    # station 0's alert (arrival 1) has delay 7, above Gamma = 4, so capped delay 4
    np.testing.assert_array_equal(r.station, [1, 0])
    np.testing.assert_array_equal(r.arrival, [0, 1])
    np.testing.assert_array_equal(r.start, [3, 8])
    np.testing.assert_array_equal(r.delay, [3, 7])
    np.testing.assert_array_equal(r.delay_capped, [3, 4])
    np.testing.assert_array_equal(r.delay_visit, [3, 7])
    np.testing.assert_array_equal(r.loiters, [2, 2])
    np.testing.assert_array_equal(r.complete, [True, True])
    np.testing.assert_array_equal(r.merged, [0, 1])
    np.testing.assert_array_equal(r.merged_delay_sum, [0, 8 - 2])
    assert (r.n_arrivals, r.n_merged, r.n_absorbed, r.n_unserviced) == (4, 1, 1, 0)
    assert r.n_loiter_steps == 4
    s = alert_statistics(r)
    assert s["mean_delay"] == 5.0 and s["worst_delay"] == 7 and s["worst_delay_capped"] == 4
    # all arrivals: delays 3, 7, 6 (merged) and 0 (absorbed)
    assert s["mean_delay_all_arrivals"] == pytest.approx((3 + 7 + 6 + 0) / 4)


def test_pass_through_visit_and_censoring():
    # the UAV never loiters at station 0: it passes it, and the alert there is never
    # serviced (counted as unserviced); station 3's service at the end is censored
    model = SpecModel(N=6, stations=(0, 3), D=2, Gamma=4)

    def rule(s):
        return 2 if (s[0] == 3 and model.allowed(s, 2)) else 0

    pol = _policy(model, rule)
    y = np.array([1, 2, 0, 0, 0])  # alert at station 0 on step 0, station 3 on step 1
    r = simulate(model, pol, y)
    assert r.mismatches == 0
    np.testing.assert_array_equal(r.start, [3])
    np.testing.assert_array_equal(r.delay, [2])
    np.testing.assert_array_equal(r.complete, [False])
    assert r.n_unserviced == 1
    s = alert_statistics(r)
    assert s["n_censored_loiters"] == 1 and math.isnan(s["mean_loiters"])


def test_invalid_policy_rejected(spec):
    pol = np.full(spec.mdp().n_states, 2)
    with pytest.raises(ValidationError, match="not an allowed action"):
        simulate(spec, pol, np.zeros(5, dtype=np.int64))
    with pytest.raises(ValidationError):
        simulate(spec, np.zeros(3, dtype=np.int64), np.zeros(5, dtype=np.int64))
    ok = np.zeros(spec.mdp().n_states, dtype=np.int64)
    with pytest.raises(ValidationError, match="state components"):
        simulate(spec, ok, np.zeros(5, dtype=np.int64), components=np.zeros((3, 5), int))
    with pytest.raises(ValidationError, match="outcomes"):
        simulate(spec, ok, np.array([0, 9]))


def _exact_expectations(model, policy, start, n_steps):
    """E[sum over steps of g(x_t)] for the Markov chain of ``policy`` from ``start``."""
    mdp = model.mdp()
    n = mdp.n_states
    comps = model.state_components()
    probs = mdp.probabilities
    succ = mdp.successors[np.arange(n), policy]  # (n, L)
    rows = np.repeat(np.arange(n), succ.shape[1])
    P = sp.csr_matrix((np.tile(probs, n), (rows, succ.ravel())), shape=(n, n))
    st = np.array(model.params.stations)
    at = comps[:, 0][:, None] == st[None, :]
    tau_l = np.where(at.any(axis=1), comps[:, 3:][np.arange(n), at.argmax(axis=1)], 0)
    loiter = policy == 2
    starts = loiter & (comps[:, 2] == 0) & (tau_l > 0)
    g = {
        "loiter": loiter.astype(float),
        "starts": starts.astype(float),
        "capped_delay": np.where(starts, tau_l, 0).astype(float),
    }
    acc = dict.fromkeys(g, 0.0)
    mu = np.zeros(n)
    mu[start] = 1.0
    PT = P.T.tocsr()
    for _ in range(n_steps):
        for k, v in g.items():
            acc[k] += float(mu @ v)
        mu = PT @ mu
    return acc


def _patrol_model(**kw):
    from lpbounds.patrol.model import PatrolModel
    from lpbounds.patrol.params import PatrolParams

    model = PatrolModel(PatrolParams(**kw))
    model.p0 = lambda: float(model.params.alert_probabilities()[0])
    return model


@pytest.mark.parametrize("factory", [SpecModel, _patrol_model], ids=["spec", "PatrolModel"])
def test_monte_carlo_matches_markov_chain_expectations(factory):
    """Loiter steps, service starts and the sum of (capped) service delays over a horizon:
    the mean over independent runs is within 4.5 standard errors of the exact expectation
    (computed by propagating the state distribution of pi*'s Markov chain)."""
    model = factory(N=6, stations=(0, 3), D=2, Gamma=4, alpha=0.25)
    pi = solve_exact(model.mdp()).policy
    start = int(model.encode(0, 1, 0, np.zeros((1, 2), dtype=np.int64))[0])
    n_steps, n_runs = 300, 400
    exact = _exact_expectations(model, pi, start, n_steps)
    sims = [
        simulate(model, pi, alert_sequence(n_steps, model.p0(), 2, seed=s), seed=s)
        for s in range(n_runs)
    ]
    assert all(r.mismatches == 0 for r in sims)
    obs = {
        "loiter": np.array([r.n_loiter_steps for r in sims], float),
        "starts": np.array([r.n_serviced for r in sims], float),
        "capped_delay": np.array([r.delay_capped.sum() for r in sims], float),
    }
    assert exact["starts"] > 20, "the test needs services to happen"
    for k, v in obs.items():
        se = v.std(ddof=1) / math.sqrt(n_runs)
        assert abs(v.mean() - exact[k]) <= 4.5 * se + 1e-9, (
            f"{k}: Monte Carlo mean {v.mean():.3f} vs exact {exact[k]:.3f} "
            f"(tolerance 4.5 standard errors = {4.5 * se:.3f})"
        )
    pooled = pooled_statistics(sims)
    assert pooled["n_serviced"] == int(obs["starts"].sum())
    assert len(pooled["per_seed"]["mean_delay"]) == n_runs
