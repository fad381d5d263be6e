"""Exact references in rational arithmetic (``fractions.Fraction``); no lpbounds code.

Every float64 is a dyadic rational, so a model *as stored* has one exact optimum: ``V*``
of the MDP, RLP's least feasible point ``v*`` (eq. 9), the disjunctive NLP's ``w*``
(eq. 25). This module computes them exactly from the plain arrays (successors,
probabilities, rewards, allowed, discount, partition labels), so a certified bracket can
be compared with the exact value *without any tolerance*: ``Fraction(lower) <= exact <=
Fraction(upper)``.

The three optima are fixed points of one kind of operator over variables ``i``:

``F(v)(i) = max_{g in groups(i)} min_{r in g} [R_r + lambda sum_t p_{r,t} v(t)]``

* the MDP: variable = state, a group per allowed action, holding the single row ``(x, u)``;
* RLP: variable = partition, a group per allowed ``(x, u)`` with ``x in S_i`` (one row,
  its successors read through the partition labels);
* NLP: variable = partition, a group per action ``u`` allowed at every state of ``S_i``,
  holding the rows ``(x, u)`` of every ``x in S_i`` (the minimiser picks one).

:func:`fixed_point` finds it by Hoffman-Karp strategy iteration (the maximiser's group per
variable, the minimiser's best reply by exact policy iteration), and then *checks* the
result: ``F(w) == w`` in exact arithmetic. ``F`` is a contraction whenever ``lambda`` times
the largest row sum is below 1, so an exact solution of ``F(w) = w`` is the optimum,
whatever way it was found; the search is only a means to it.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

Row = tuple[Fraction, dict[int, Fraction]]  # (reward, {target: probability})


def fr(x: Any) -> Fraction:
    """The exact rational value of a float (``Fraction(float)`` is exact)."""
    return Fraction(float(x))


@dataclass(frozen=True)
class Groups:
    """The operator ``F`` above: ``groups[i]`` is a list of groups, each a list of rows."""

    groups: list[list[list[Row]]]
    discount: Fraction

    @property
    def n(self) -> int:
        return len(self.groups)

    def q(self, row: Row, v: list[Fraction]) -> Fraction:
        reward, dist = row
        return reward + self.discount * sum((p * v[t] for t, p in dist.items()), Fraction(0))

    def apply(self, v: list[Fraction]) -> list[Fraction]:
        """``F(v)`` exactly."""
        return [max(min(self.q(r, v) for r in g) for g in gs) for gs in self.groups]

    def kappa(self) -> Fraction:
        """``lambda`` times the largest exact row sum: the contraction modulus."""
        sums = [sum(d.values(), Fraction(0)) for gs in self.groups for g in gs for _, d in g]
        return self.discount * max(sums)


def _rows_of(succ, probs, rewards, allowed, labels):
    """Row ``(x, u)`` of every allowed pair, successors read through ``labels``."""
    succ = np.asarray(succ, dtype=np.int64)
    p = np.broadcast_to(np.asarray(probs, dtype=np.float64), succ.shape)
    n, n_act, n_out = succ.shape
    out: dict[tuple[int, int], Row] = {}
    for x in range(n):
        for u in range(n_act):
            if not allowed[x, u]:
                continue
            dist: dict[int, Fraction] = {}
            for ll in range(n_out):
                t = int(labels[int(succ[x, u, ll])])
                dist[t] = dist.get(t, Fraction(0)) + fr(p[x, u, ll])
            out[(x, u)] = (fr(rewards[x, u]), dist)
    return out


def mdp_groups(succ, probs, rewards, allowed, discount) -> Groups:
    """The MDP's Bellman operator: ``max_u`` of the single row ``(x, u)``."""
    n, n_act = np.asarray(allowed).shape
    rows = _rows_of(succ, probs, rewards, np.asarray(allowed), np.arange(n))
    gs = [[[rows[(x, u)]] for u in range(n_act) if (x, u) in rows] for x in range(n)]
    return Groups(gs, fr(discount))


def rlp_groups(succ, probs, rewards, allowed, discount, labels) -> Groups:
    """RLP's operator (eq. 9): ``max_{x in S_i, u}`` of row ``(x, u)`` over partitions."""
    lab = np.asarray(labels, dtype=np.int64)
    n_act = np.asarray(allowed).shape[1]
    rows = _rows_of(succ, probs, rewards, np.asarray(allowed), lab)
    gs = [
        [[rows[(x, u)]] for x in np.flatnonzero(lab == i) for u in range(n_act) if (x, u) in rows]
        for i in range(int(lab.max()) + 1)
    ]
    return Groups(gs, fr(discount))


def nlp_groups(succ, probs, rewards, allowed, discount, labels) -> Groups:
    """The NLP's operator (eq. 25): ``max_u min_{x in S_i}`` of row ``(x, u)``, an action
    counting only where it is allowed at every state of ``S_i``."""
    lab = np.asarray(labels, dtype=np.int64)
    allowed = np.asarray(allowed)
    rows = _rows_of(succ, probs, rewards, allowed, lab)
    gs = []
    for i in range(int(lab.max()) + 1):
        xs = np.flatnonzero(lab == i)
        gs.append(
            [
                [rows[(int(x), u)] for x in xs]
                for u in range(allowed.shape[1])
                if allowed[xs, u].all()
            ]
        )
    return Groups(gs, fr(discount))


def gauss(a: list[list[Fraction]], b: list[Fraction]) -> list[Fraction] | None:
    """The solution of the square system ``a x = b``, or ``None`` if ``a`` is singular."""
    n = len(b)
    m = [[*row, b[i]] for i, row in enumerate(a)]
    for col in range(n):
        piv = next((r for r in range(col, n) if m[r][col] != 0), None)
        if piv is None:
            return None
        m[col], m[piv] = m[piv], m[col]
        p = m[col][col]
        m[col] = [x / p for x in m[col]]
        for r in range(n):
            if r != col and m[r][col] != 0:
                f = m[r][col]
                m[r] = [x - f * y for x, y in zip(m[r], m[col], strict=True)]
    return [m[i][n] for i in range(n)]


def evaluate(ops: Groups, chosen: list[Row]) -> list[Fraction]:
    """The value of one row per variable: ``(I - lambda P) v = R`` exactly."""
    n = ops.n
    a = [[Fraction(int(i == j)) for j in range(n)] for i in range(n)]
    for i, (_, dist) in enumerate(chosen):
        for t, p in dist.items():
            a[i][t] -= ops.discount * p
    v = gauss(a, [r for r, _ in chosen])
    assert v is not None, "a policy's (I - lambda P) is singular"
    return v


def _min_reply(ops: Groups, sigma: list[int]) -> list[Fraction]:
    """The minimiser's best reply to ``sigma`` by policy iteration (strict decreases)."""
    tau = [0] * ops.n
    while True:
        v = evaluate(ops, [ops.groups[i][sigma[i]][tau[i]] for i in range(ops.n)])
        changed = False
        for i in range(ops.n):
            qs = [ops.q(r, v) for r in ops.groups[i][sigma[i]]]
            best = min(range(len(qs)), key=qs.__getitem__)
            if qs[best] < qs[tau[i]]:
                tau[i], changed = best, True
        if not changed:
            return v


def fixed_point(ops: Groups) -> list[Fraction]:
    """The exact fixed point of ``F``, checked: ``F(w) == w`` exactly, and ``kappa < 1``."""
    assert ops.kappa() < 1, "not a contraction: no discounted value"
    assert all(ops.groups), "a variable without a group: its value is -inf"
    sigma = [0] * ops.n
    while True:
        w = _min_reply(ops, sigma)
        changed = False
        for i in range(ops.n):
            vals = [min(ops.q(r, w) for r in g) for g in ops.groups[i]]
            best = max(range(len(vals)), key=vals.__getitem__)
            if vals[best] > vals[sigma[i]]:
                sigma[i], changed = best, True
        if not changed:
            break
    assert ops.apply(w) == w, "the reference is not an exact fixed point"
    return w


def policy_value(succ, probs, rewards, discount, policy) -> list[Fraction]:
    """``V_pi`` of the stored model exactly (``policy``: an action per state)."""
    n = len(policy)
    allowed = np.zeros(np.asarray(rewards).shape, dtype=bool)
    allowed[np.arange(n), np.asarray(policy, dtype=np.int64)] = True
    return fixed_point(mdp_groups(succ, probs, rewards, allowed, discount))


def distance(point: Any, exact: list[Fraction]) -> Fraction:
    """``max_i |point_i - exact_i|`` exactly."""
    return max(abs(fr(p) - e) for p, e in zip(np.asarray(point).ravel(), exact, strict=True))


def assert_contains(lower: Any, upper: Any, exact: list[Fraction], what: str = "") -> None:
    """``lower <= exact <= upper`` entry by entry, compared exactly (no tolerance)."""
    lo = np.asarray(lower, dtype=np.float64).ravel()
    hi = np.asarray(upper, dtype=np.float64).ravel()
    assert lo.size == hi.size == len(exact), what
    for i, e in enumerate(exact):
        assert np.isfinite(lo[i]) and np.isfinite(hi[i]), f"{what}: bracket [{lo[i]}, {hi[i]}]"
        assert fr(lo[i]) <= e, f"{what}: lower[{i}] = {lo[i]!r} above the exact {float(e)!r}"
        assert e <= fr(hi[i]), f"{what}: upper[{i}] = {hi[i]!r} below the exact {float(e)!r}"


def width_limit(point: Any, exact: list[Fraction], kappa: Fraction, scale: float, n_out: int):
    """The widest bracket a certificate may honestly report from ``point``.

    The exact residual of ``point`` is at most ``(1 + kappa) ||point - exact||`` (``F`` is a
    ``kappa``-contraction with fixed point ``exact``), so a certificate's half-width is at
    most that plus a rounding allowance, over ``1 - kappa``. The allowance,
    ``64 (L + 3) eps scale`` with ``scale`` the largest magnitude involved (rewards, point,
    its image, 1), is many times any honest rounding margin; a bracket made infinite, or
    inflated by a factor, exceeds the limit.
    """
    eps = Fraction(float(np.finfo(np.float64).eps))
    allowance = 64 * (n_out + 3) * eps * fr(scale)
    half = ((1 + kappa) * distance(point, exact) + allowance) / (1 - kappa)
    return 2 * half


def assert_not_vacuous(lower: Any, upper: Any, limit: Fraction, what: str = "") -> None:
    """``max(upper - lower) <= limit``, compared exactly."""
    lo = np.asarray(lower, dtype=np.float64).ravel()
    hi = np.asarray(upper, dtype=np.float64).ravel()
    for i in range(lo.size):
        assert np.isfinite(lo[i]) and np.isfinite(hi[i]), f"{what}: bracket not finite"
        w = fr(hi[i]) - fr(lo[i])
        assert w <= limit, f"{what}: width {float(w):.3e} at {i} above {float(limit):.3e}"


def rounded(exact: list[Fraction]) -> np.ndarray:
    """The exact vector rounded to the nearest floats."""
    return np.array([float(e) for e in exact])
