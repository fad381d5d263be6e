"""A deliberately simple, loop-based implementation of the patrol specification.

Written from ``shared/patrol-spec.md`` independently of :mod:`lpbounds.patrol`: states
are tuples ``(l, w, d, tau_1, ..., tau_m)`` listed by nested loops, transitions live in
dicts, the information gain is computed term by term with ``math.log``. Only for small
instances (a few thousand states): the tests compare the vectorised model with it.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import cached_property

CONTINUE, REVERSE, LOITER = 0, 1, 2
U_OF_ACTION = {CONTINUE: 1, REVERSE: -1, LOITER: 0}


def information(d, p, a, b, c, g, mu1, mu2):
    """Mutual information I(X; Z) after d loiters (Appendix A), natural log, 0 log 0 = 0."""
    ptr = a + b * (1 - math.exp(-mu1 * d))
    pftr = c + g * (1 - math.exp(-mu2 * d))
    joint = {
        ("T", "Z1"): p * ptr,
        ("T", "Z2"): p * (1 - ptr),
        ("FT", "Z1"): (1 - p) * (1 - pftr),
        ("FT", "Z2"): (1 - p) * pftr,
    }
    px = {"T": p, "FT": 1 - p}
    pz = {
        "Z1": joint[("T", "Z1")] + joint[("FT", "Z1")],
        "Z2": joint[("T", "Z2")] + joint[("FT", "Z2")],
    }
    total = 0.0
    for (x, z), pj in joint.items():
        if pj > 0:
            total += pj * math.log(pj / (px[x] * pz[z]))
    return total


@dataclass
class RefPatrol:
    """The patrol MDP by enumeration. Parameters as in the specification."""

    N: int
    stations: tuple
    D: int
    Gamma: int
    rho: float = 0.005
    discount: float = 0.9
    alpha: float = 1 / 60
    p_threat: float = 0.01
    a: float = 0.5
    b: float = 0.45
    c: float = 0.5
    g: float = 0.45
    mu1: float = 1.0
    mu2: float = 1.0
    allow_empty_loiter: bool = False

    @cached_property
    def states(self):
        """Every state, by nested loops: travel states, then loiter states."""
        m = len(self.stations)
        states = []
        for l in range(self.N):
            for w in (1, -1):
                for tau in itertools.product(range(self.Gamma + 1), repeat=m):
                    states.append((l, w, 0, *tau))
        for k, s in enumerate(self.stations):
            for d in range(1, self.D + 1):
                for tau in itertools.product(range(self.Gamma + 1), repeat=m):
                    if tau[k] == 0:
                        states.append((s, 1, d, *tau))
        return states

    @cached_property
    def index(self):
        return {x: i for i, x in enumerate(self.states)}

    @property
    def m(self):
        return len(self.stations)

    def probabilities(self):
        p0 = math.exp(-self.alpha)
        return [p0] + [(1 - p0) / self.m] * self.m

    def info(self, d):
        return information(d, self.p_threat, self.a, self.b, self.c, self.g, self.mu1, self.mu2)

    def allowed(self, x):
        l, _w, d, *tau = x
        acts = [CONTINUE, REVERSE]
        if l in self.stations and d < self.D:
            k = self.stations.index(l)
            if d >= 1 or tau[k] > 0 or self.allow_empty_loiter:
                acts.append(LOITER)
        return acts

    def reward(self, x, action):
        _l, _w, d, *tau = x
        r = -self.rho * min(max(tau), self.Gamma)
        if action == LOITER:
            r += self.info(d + 1) - self.info(d)
        return r

    def step(self, x, action, outcome):
        """f(x, u, Y_outcome); outcome 0 = no alert, k = alert at the k-th station."""
        l, w, d, *tau = x
        u = U_OF_ACTION[action]
        if u != 0:
            l2, w2, d2 = (l + w * u) % self.N, w * u, 0
        else:
            l2, w2, d2 = l, 1, d + 1
        tau2 = []
        for j, s in enumerate(self.stations):
            if u == 0 and s == l:
                t = 0
            elif tau[j] > 0:
                t = min(tau[j] + 1, self.Gamma)
            elif outcome == j + 1:
                t = 1
            else:
                t = 0
            tau2.append(t)
        return (l2, w2, d2, *tau2)

    def transitions(self):
        """dict (state index, action) -> list of (next state index, probability)."""
        probs = self.probabilities()
        out = {}
        for i, x in enumerate(self.states):
            for act in self.allowed(x):
                out[(i, act)] = [
                    (self.index[self.step(x, act, y)], probs[y]) for y in range(self.m + 1)
                ]
        return out

    def partition_key(self, x):
        l, w, d, *tau = x
        return (l, w, d, *[int(t > 0) for t in tau], max(tau))

    def value_iteration(self, tol=1e-12, max_iter=10_000):
        """V* by plain value iteration (dicts), stopped at sup-norm change <= tol."""
        trans = self.transitions()
        v = [0.0] * len(self.states)
        for _ in range(max_iter):
            new = []
            for i, x in enumerate(self.states):
                best = -math.inf
                for act in self.allowed(x):
                    q = self.reward(x, act) + self.discount * sum(
                        p * v[j] for j, p in trans[(i, act)]
                    )
                    best = max(best, q)
                new.append(best)
            delta = max(abs(a - b) for a, b in zip(new, v, strict=True))
            v = new
            if delta <= tol:
                break
        return v
