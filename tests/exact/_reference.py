"""Exact references written here, independent of lpbounds: Python's Fractions only.

* :func:`gauss` -- Gauss-Jordan elimination in Fractions (``None`` when singular), from
  ``tests/_exact.py``, the references every folder shares;
* :func:`vstar` -- ``V*`` of a stored model by enumerating its deterministic policies;
* :func:`lp_optimum` -- the optimum of ``min c'x s.t. A x >= b`` (``x`` free) by
  enumerating every basis (every set of ``N`` rows), for tiny LPs;
* the paper's LPs built from the model's arrays (:func:`elp`, :func:`rlp`, :func:`ib`,
  :func:`slp`, :func:`llp`, :func:`alp`, :func:`rows_lp`): the coefficients written out
  from the equations (not with lpbounds' builders, nor its certificate checker's);
* :func:`game_value` -- the disjunctive NLP's ``w*`` as the entrywise minimum over the
  minimiser's strategies of each strategy's ``V*`` (each by policy enumeration).
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np

from tests._exact import gauss

F = Fraction


def _dist(mdp, x: int, u: int, labels=None) -> dict[int, Fraction]:
    """The exact successor distribution of ``(x, u)`` (over partitions with ``labels``)."""
    p = mdp.probabilities if mdp.shared_probabilities else mdp.probabilities[x, u]
    out: dict[int, Fraction] = {}
    for t, q in zip(mdp.successors[x, u], p, strict=True):
        k = int(t) if labels is None else int(labels[int(t)])
        out[k] = out.get(k, F(0)) + F(float(q))
    return out


def pairs(mdp) -> list[tuple[int, int]]:
    """The allowed pairs in row-major order."""
    return [(int(x), int(u)) for x, u in zip(*np.nonzero(mdp.allowed), strict=True)]


def vstar(mdp) -> list[Fraction]:
    """``V*`` of the stored model: the entrywise max of ``V_pi`` over every policy."""
    n, lam = mdp.n_states, F(float(mdp.discount))
    choices = [np.flatnonzero(mdp.allowed[x]).tolist() for x in range(n)]
    best: list[Fraction] | None = None
    for pol in itertools.product(*choices):
        a = [[F(int(i == j)) for j in range(n)] for i in range(n)]
        b = []
        for x, u in enumerate(pol):
            for t, q in _dist(mdp, x, u).items():
                a[x][t] -= lam * q
            b.append(F(float(mdp.rewards[x, u])))
        v = gauss(a, b)
        assert v is not None
        best = v if best is None else [max(s, t) for s, t in zip(best, v, strict=True)]
    assert best is not None
    return best


# ---------------------------------------------------------------------- LPs, tiny
def lp_optimum(rows: list[tuple[list[Fraction], Fraction]], cost: list[Fraction]):
    """``(objective, x)`` of ``min c'x s.t. a_r'x >= b_r`` by enumerating every basis.

    A bounded feasible LP whose rows have full column rank attains its optimum at a vertex.
    """
    n = len(cost)
    best = None
    for basis in itertools.combinations(range(len(rows)), n):
        x = gauss([rows[r][0] for r in basis], [rows[r][1] for r in basis])
        if x is None:
            continue
        if all(sum((a * t for a, t in zip(ar, x, strict=True)), F(0)) >= br for ar, br in rows):
            obj = sum((c * t for c, t in zip(cost, x, strict=True)), F(0))
            if best is None or obj < best[0]:
                best = (obj, x)
    assert best is not None, "no feasible vertex"
    return best


def _bellman(n_vars: int, owner: int, dist: dict[int, Fraction], lam: Fraction, shift: int = 0):
    """Coefficients of ``v(owner) - lambda sum_t p_t v(t + shift)`` (a dense row)."""
    a = [F(0)] * n_vars
    a[owner] += 1
    for t, q in dist.items():
        a[t + shift] -= lam * q
    return a


def elp(mdp):
    """Eq. 8: one row per allowed pair."""
    lam, n = F(float(mdp.discount)), mdp.n_states
    return [
        (_bellman(n, x, _dist(mdp, x, u), lam), F(float(mdp.rewards[x, u]))) for x, u in pairs(mdp)
    ]


def rlp(mdp, labels, m):
    """Eq. 9: one row per allowed pair, over the partitions."""
    lam = F(float(mdp.discount))
    return [
        (_bellman(m, int(labels[x]), _dist(mdp, x, u, labels), lam), F(float(mdp.rewards[x, u])))
        for x, u in pairs(mdp)
    ]


def ib(mdp, labels, m, L):
    """Eq. 20-22: block ``j``'s rows bound ``v_j`` by ``v_{j-1}`` (cyclically)."""
    lam, out = F(float(mdp.discount)), []
    for j in range(L):
        src = (j - 1) % L
        for x, u in pairs(mdp):
            a = [F(0)] * (L * m)
            a[j * m + int(labels[x])] += 1
            for t, q in _dist(mdp, x, u, labels).items():
                a[src * m + t] -= lam * q
            out.append((a, F(float(mdp.rewards[x, u]))))
    return out


def slp(mdp, labels, m, mu):
    """Eq. SLPB: the rows of (i, u) averaged with weights ``h = mu / sum mu``."""
    lam, out = F(float(mdp.discount)), []
    for i in range(m):
        for u in range(mdp.n_actions):
            xs = [x for x, uu in pairs(mdp) if uu == u and labels[x] == i and mu[x][u] != 0]
            tot = sum((F(mu[x][u]) for x in xs), F(0))
            if not xs:
                continue
            a, b = [F(0)] * m, F(0)
            for x in xs:
                h = F(mu[x][u]) / tot
                row = _bellman(m, i, _dist(mdp, x, u, labels), lam)
                a = [s + h * t for s, t in zip(a, row, strict=True)]
                b += h * F(float(mdp.rewards[x, u]))
            out.append((a, b))
    return out


def llp(mdp, labels, m, d):
    """Eq. 18 with surplus lifting: variables (v, z), ``A v - z = R`` as two rows, ``z >= 0``."""
    base = rlp(mdp, labels, m)
    k = len(base)
    out = []
    for sign in (1, -1):
        for j, (a, b) in enumerate(base):
            z = [F(0)] * k
            z[j] = F(-sign)
            out.append(([sign * t for t in a] + z, sign * b))
    for j in range(k):
        z = [F(0)] * k
        z[j] = F(1)
        out.append(([F(0)] * m + z, F(0)))
    cost_z = [F(float(d[x, u])) for x, u in pairs(mdp)]
    return out, cost_z


def alp(mdp, basis):
    """Eq. 10 with a general basis: ``(Phi r)(x) - lambda sum_l p_l (Phi r)(f) >= R``."""
    phi = [[F(float(t)) for t in row] for row in np.asarray(basis)]
    k = len(phi[0])
    out = []
    for a, b in elp(mdp):
        out.append(([sum((a[x] * phi[x][j] for x in range(len(a))), F(0)) for j in range(k)], b))
    return out, phi


def rows_lp(rows):
    """The LP of a BellmanRows system as stored."""
    lam, n, out = F(float(rows.discount)), rows.n_vars, []
    probs = np.asarray(rows.probs)
    for r in range(rows.n_rows):
        dist: dict[int, Fraction] = {}
        for t, q in zip(rows.targets[r], probs[r], strict=True):
            dist[int(t)] = dist.get(int(t), F(0)) + F(float(q))
        out.append((_bellman(n, int(rows.owner[r]), dist, lam), F(float(rows.reward[r]))))
    return out


# ---------------------------------------------------------------------- the game
def _least_fixed_point(rows, n):
    """The least fixed point of Bellman rows ``(a, b, owner)`` by policy enumeration."""
    mine = [[r for r in rows if r[2] == i] for i in range(n)]
    best = None
    for pol in itertools.product(*mine):
        v = gauss([r[0] for r in pol], [r[1] for r in pol])
        assert v is not None
        best = v if best is None else [max(s, t) for s, t in zip(best, v, strict=True)]
    return best


def game_value(mdp, labels, m):
    """``w*`` of the NLP (eq. 25): disjunctions (i, u) kept when u is allowed at every state
    of S_i; ``w* = min over minimiser strategies tau of V*_tau``, entrywise (attained)."""
    lam = F(float(mdp.discount))
    groups: dict[tuple[int, int], list] = {}
    for x, u in pairs(mdp):
        i = int(labels[x])
        if all(mdp.allowed[y, u] for y in range(mdp.n_states) if labels[y] == i):
            row = (_bellman(m, i, _dist(mdp, x, u, labels), lam), F(float(mdp.rewards[x, u])), i)
            groups.setdefault((i, u), []).append(row)
    best = None
    for tau in itertools.product(*groups.values()):
        v = _least_fixed_point(list(tau), m)
        best = v if best is None else [min(s, t) for s, t in zip(best, v, strict=True)]
    return best
