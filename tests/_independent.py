"""Independent references for the certificate tests: numpy and scipy only, no lpbounds.

Nothing here imports lpbounds: a model is given as plain arrays, as the paper writes it,

* ``P``: shape (A, n, n), ``P[a][x]`` the distribution of the successor of ``x`` under ``a``
  (dense; built from successor arrays by :func:`dense_transitions`);
* ``R``: shape (n, A), the rewards (entries at disallowed pairs are never read);
* ``allowed``: shape (n, A), bool;
* ``discount``: ``lambda`` in [0, 1).

What it computes: ``V*`` by Howard's policy iteration with dense ``numpy.linalg.solve``
(:func:`policy_iteration`), ``V_pi`` (:func:`policy_value`), the aggregated operators of the
paper's RLP (max over the states of a partition, eq. 9) and NLP (max over the actions of the
min over the states, eq. 25), their least fixed points by the same dense policy iteration
over rows, and, with :func:`scipy.optimize.linprog` (HiGHS), the LP optimum itself. Each
reference comes with its own error bound: the Bellman residual of the returned vector,
computed here, plus a rounding allowance, over ``1 - lambda``.

The ``assert_*`` helpers state each certificate's promise *both ways* (see the functions):
the bracket contains the exact optimum, AND it is no wider than the point's own residual
implies (so a bracket replaced by ``[-inf, inf]``, or an error bound inflated tenfold, fails);
an OPTIMAL result is within its requested accuracy, an INACCURATE one really is not.
They read the fields of lpbounds' results by name (duck typing), never its code.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.optimize as so

EPS = float(np.finfo(np.float64).eps)
TINY = float(np.finfo(np.float64).tiny)

#: Statuses that keep a point and its (valid) bracket; every LP of these tests is feasible
#: and bounded, so INFEASIBLE / UNBOUNDED / SOLVER_ERROR are never acceptable.
POINT_STATUSES = frozenset({"optimal", "inaccurate", "time_limit", "iteration_limit", "limit"})

#: Relative slack on products of floats in the comparisons below (a few ulps on quantities
#: that are each a handful of floating-point operations from the compared number).
REL = 1e-9


# ---------------------------------------------------------------------- models as arrays
def dense_transitions(successors: Any, probabilities: Any) -> np.ndarray:
    """``P`` (A, n, n) from successor indices (n, A, L) and probabilities ((L,) or (n, A, L))."""
    succ = np.asarray(successors, dtype=np.int64)
    n, n_act, n_out = succ.shape
    p = np.broadcast_to(np.asarray(probabilities, dtype=np.float64), succ.shape)
    big = np.zeros((n_act, n, n))
    x = np.repeat(np.arange(n), n_act * n_out).reshape(n, n_act, n_out)
    a = np.repeat(np.tile(np.arange(n_act), n), n_out).reshape(n, n_act, n_out)
    np.add.at(big, (a.ravel(), x.ravel(), succ.ravel()), p.ravel())
    return big


def q_values(P: np.ndarray, R: np.ndarray, allowed: np.ndarray, discount: float, v: Any):
    """``Q(x, a) = R(x, a) + lambda (P[a] v)(x)``, ``-inf`` at disallowed pairs."""
    v = np.asarray(v, dtype=np.float64)
    q = np.asarray(R, dtype=np.float64) + discount * np.einsum("axy,y->xa", P, v)
    return np.where(allowed, q, -np.inf)


def bellman(P, R, allowed, discount, v) -> np.ndarray:
    """``(T v)(x) = max_a Q(x, a)``."""
    return q_values(P, R, allowed, discount, v).max(axis=1)


def successor_bellman(successors, probabilities, R, allowed, discount, v) -> np.ndarray:
    """``T v`` from successor arrays (n, A, L) directly, for models too large for dense
    ``P``: ``max_a R(x, a) + lambda sum_l p_l v(succ(x, a, l))``."""
    succ = np.asarray(successors, dtype=np.int64)
    p = np.broadcast_to(np.asarray(probabilities, dtype=np.float64), succ.shape)
    v = np.asarray(v, dtype=np.float64)
    q = np.asarray(R, dtype=np.float64) + discount * (p * v[succ]).sum(axis=2)
    return np.where(allowed, q, -np.inf).max(axis=1)


def policy_operator(successors, probabilities, R, policy, discount, v) -> np.ndarray:
    """``T_pi v = R_pi + lambda P_pi v`` from successor arrays."""
    succ = np.asarray(successors, dtype=np.int64)
    p = np.broadcast_to(np.asarray(probabilities, dtype=np.float64), succ.shape)
    idx = np.arange(succ.shape[0])
    pol = np.asarray(policy, dtype=np.int64)
    v = np.asarray(v, dtype=np.float64)
    return np.asarray(R, dtype=np.float64)[idx, pol] + discount * (
        p[idx, pol] * v[succ[idx, pol]]
    ).sum(axis=1)


def rounding_slack(R: Any, v: Any, n_terms: int = 1) -> float:
    """A generous bound on the rounding of one Bellman sweep and its residual (absolute):
    ``8 (n_terms + 4) eps (max|R| + 2 max|v|)`` plus the smallest normal number."""
    r_abs = float(np.abs(np.asarray(R, dtype=np.float64)[np.isfinite(R)]).max(initial=0.0))
    v_abs = float(np.abs(np.asarray(v, dtype=np.float64)).max(initial=0.0))
    return 8.0 * (n_terms + 4) * EPS * (r_abs + 2.0 * v_abs + 1.0) + 4 * TINY


@dataclass(frozen=True)
class Reference:
    """A reference vector, its own error bound (``||values - exact||_inf <= error``) and, for
    policy iteration, the policy (row per owner, or action per state)."""

    values: np.ndarray
    error: float
    policy: np.ndarray | None = None


def policy_value(P, R, policy, discount) -> Reference:
    """``V_pi`` by a dense solve of ``(I - lambda P_pi) V = R_pi``, with its error bound."""
    n = P.shape[1]
    pol = np.asarray(policy, dtype=np.int64)
    idx = np.arange(n)
    p_pi = P[pol, idx]
    r_pi = np.asarray(R, dtype=np.float64)[idx, pol]
    v = np.linalg.solve(np.eye(n) - discount * p_pi, r_pi)
    res = float(np.abs(r_pi + discount * p_pi @ v - v).max(initial=0.0))
    return Reference(v, (res + rounding_slack(r_pi, v, n)) / (1.0 - discount), pol)


def policy_iteration(P, R, allowed, discount, max_iter: int = 1000) -> Reference:
    """``V*`` by Howard's policy iteration (a policy changes only for a strict gain)."""
    rows = _mdp_rows(P, R, allowed)
    ref = _rows_policy_iteration(*rows, discount, P.shape[1], max_iter)
    owner_actions = rows[3]
    return Reference(ref.values, ref.error, owner_actions[ref.policy])


# ---------------------------------------------------------------------- row systems
# A row system is (owner (K,), reward (K,), dist (K, M), tag (K,)): row k says
# v(owner_k) >= reward_k + lambda dist_k @ v. The least feasible point is the fixed point of
# (T v)(i) = max over the rows of i (Fact 1 of the paper's LPs).
def _mdp_rows(P, R, allowed):
    xs, us = np.nonzero(allowed)
    return xs, np.asarray(R, dtype=np.float64)[xs, us], P[us, xs], us


def aggregated_rows(P, R, allowed, labels):
    """RLP's rows (eq. 9): one per allowed ``(x, u)``, owned by ``label(x)``, its successor
    distribution summed over each partition."""
    lab = np.asarray(labels, dtype=np.int64)
    m = int(lab.max()) + 1
    xs, us = np.nonzero(allowed)
    onehot = np.zeros((P.shape[1], m))
    onehot[np.arange(P.shape[1]), lab] = 1.0
    dist = P[us, xs] @ onehot
    return lab[xs], np.asarray(R, dtype=np.float64)[xs, us], dist, us


def rows_operator(owner, reward, dist, discount, m, v):
    """``(T v)(i) = max_{rows k of i} reward_k + lambda dist_k @ v`` (``-inf`` without rows)."""
    q = reward + discount * dist @ np.asarray(v, dtype=np.float64)
    out = np.full(m, -np.inf)
    np.maximum.at(out, owner, q)
    return out


def _rows_policy_iteration(owner, reward, dist, tag, discount, m, max_iter=1000) -> Reference:
    """Least fixed point of a row system by policy iteration: one row per owner, a dense
    solve, the best row at the solution (kept on ties within 1e-13 relative)."""
    del tag
    q0 = np.where(np.isfinite(reward), reward, -np.inf)
    sel = np.full(m, -1, dtype=np.int64)
    best = np.full(m, -np.inf)
    for k in range(owner.size):  # the first row of largest reward per owner
        if q0[k] > best[owner[k]]:
            best[owner[k]], sel[owner[k]] = q0[k], k
    if (sel < 0).any():
        raise ValueError("an owner without rows: the least fixed point is -inf there")
    for _ in range(max_iter):
        v = np.linalg.solve(np.eye(m) - discount * dist[sel], reward[sel])
        q = reward + discount * dist @ v
        tv = np.full(m, -np.inf)
        np.maximum.at(tv, owner, q)
        cur = q[sel]
        tie = 1e-13 * max(1.0, float(np.abs(v).max(initial=0.0)))
        better = tv > cur + tie
        if not better.any():
            break
        for i in np.flatnonzero(better):
            ks = np.flatnonzero(owner == i)
            sel[i] = ks[int(np.argmax(q[ks]))]
    else:
        raise AssertionError("reference policy iteration did not converge")
    res = float(np.abs(tv - v).max(initial=0.0))
    return Reference(v, (res + rounding_slack(reward, v, m)) / (1.0 - discount), sel)


def rlp_optimum(P, R, allowed, discount, labels) -> Reference:
    """RLP's exact optimum ``v*`` (eq. 9's least feasible point) by dense policy iteration."""
    owner, reward, dist, tag = aggregated_rows(P, R, allowed, labels)
    return _rows_policy_iteration(owner, reward, dist, tag, discount, int(np.max(labels)) + 1)


def rlp_operator(P, R, allowed, discount, labels, v) -> np.ndarray:
    """RLP's operator on partitions: ``max_{x in S_i, u} R_u(x) + lambda sum_y P_u(x, y)
    v(label(y))``."""
    lab = np.asarray(labels, dtype=np.int64)
    q = q_values(P, R, allowed, discount, np.asarray(v, dtype=np.float64)[lab]).max(axis=1)
    out = np.full(int(lab.max()) + 1, -np.inf)
    np.maximum.at(out, lab, q)
    return out


def ib_operator(P, R, allowed, discount, labels, x, n_blocks) -> np.ndarray:
    """IB's cyclic operator (eq. 20-22): block ``j`` is RLP's operator at block ``j - 1``
    (block 1 at block ``L``), for the stacked blocks ``x``."""
    blocks = np.asarray(x, dtype=np.float64).reshape(n_blocks, -1)
    return np.concatenate(
        [rlp_operator(P, R, allowed, discount, labels, blocks[(j - 1) % n_blocks])
         for j in range(n_blocks)]
    )  # fmt: skip


def nlp_operator(P, R, allowed, discount, labels, w) -> np.ndarray:
    """NLP's max-min operator (eq. 25): ``max_u min_{x in S_i} [R_u(x) + lambda sum_y
    P_u(x, y) w(label(y))]``, an action counting only where allowed at every state of S_i."""
    lab = np.asarray(labels, dtype=np.int64)
    m = int(lab.max()) + 1
    q = np.asarray(R, dtype=np.float64) + discount * np.einsum(
        "axy,y->xa", P, np.asarray(w, dtype=np.float64)[lab]
    )
    q = np.where(allowed, q, -np.inf)  # a forbidden action makes the min -inf
    mins = np.full((m, q.shape[1]), np.inf)
    for a in range(q.shape[1]):
        np.minimum.at(mins[:, a], lab, q[:, a])
    return mins.max(axis=1)


def fixed_point(op, v0, discount, rtol: float = 1e-14, max_iter: int = 1_000_000) -> Reference:
    """Value iteration of a ``lambda``-contraction ``op`` until its residual is within
    ``rtol (1 - lambda)`` of ``max(1, max|v|)`` or at the rounding floor (64 ulps of it: a
    sweep cannot do better in floating point), with the error bound ``(residual + slack) /
    (1 - lambda)`` of the vector returned."""
    v = np.asarray(v0, dtype=np.float64)
    for _ in range(max_iter):
        nv = op(v)
        res = float(np.abs(nv - v).max(initial=0.0))
        scale = max(1.0, float(np.abs(nv).max(initial=0.0)))
        if res <= max(rtol * (1.0 - discount), 64 * EPS) * scale:
            v = nv
            break
        v = nv
    else:
        raise AssertionError("reference value iteration did not converge")
    res = float(np.abs(op(v) - v).max(initial=0.0))
    return Reference(v, (res + rounding_slack(0.0, v, v.size)) / (1.0 - discount))


def surrogate_mdp(P, R, allowed, labels, mu):
    """The reduced MDP of SLP(mu) (Theorem 1's proof, step 2) over the partitions: for each
    ``(i, u)`` with ``sum_{x in S_i} mu_u(x) > 0``, weights ``h = mu_u(x) / sum``, reward
    ``sum h R_u(x)`` and transitions ``sum h P_u(x, .)`` summed over each partition.
    Returns ``(P_red (A, M, M), R_red (M, A), allowed_red (M, A))``."""
    lab = np.asarray(labels, dtype=np.int64)
    m, n_act = int(lab.max()) + 1, np.asarray(R).shape[1]
    w = np.where(allowed, np.asarray(mu, dtype=np.float64), 0.0)
    onehot = np.zeros((P.shape[1], m))
    onehot[np.arange(P.shape[1]), lab] = 1.0
    p_red = np.zeros((n_act, m, m))
    r_red = np.zeros((m, n_act))
    used = np.zeros((m, n_act), dtype=bool)
    for i in range(m):
        xs = np.flatnonzero(lab == i)
        for u in range(n_act):
            tot = w[xs, u].sum()
            if tot > 0:
                h = w[xs, u] / tot
                used[i, u] = True
                r_red[i, u] = h @ np.asarray(R, dtype=np.float64)[xs, u]
                p_red[u, i] = h @ (P[u, xs] @ onehot)
    return p_red, r_red, used


def rows_lp_optimum(owner, reward, dist, discount, m, cost) -> so.OptimizeResult:
    """``min c'v s.t. v(owner_k) >= reward_k + lambda dist_k @ v`` by scipy's HiGHS."""
    a = np.zeros((owner.size, m))
    a[np.arange(owner.size), owner] = 1.0
    a -= discount * dist
    res = so.linprog(cost, A_ub=-a, b_ub=-reward, bounds=(None, None), method="highs")
    assert res.status == 0, res.message
    return res


# ---------------------------------------------------------------------- the promises
def _status(res: Any) -> str:
    s = res.status
    return str(getattr(s, "value", s))


def reward_floor(R, allowed, labels=None) -> float:
    """A lower bound on ``max|reward|`` over an LP's rows after duplicates are merged: the
    best row of each owner (a state, or the partition ``labels[x]``) is never dropped, so
    ``max_i |max_{rows of i} reward|``."""
    r = np.where(allowed, np.asarray(R, dtype=np.float64), -np.inf).max(axis=1)
    if labels is None:
        return float(np.abs(r).max(initial=0.0))
    lab = np.asarray(labels, dtype=np.int64)
    best = np.full(int(lab.max()) + 1, -np.inf)
    np.maximum.at(best, lab, r)
    return float(np.abs(best).max(initial=0.0))


def bracket_limits(point, t_point, discount, reward_absmax, n_terms):
    """The widest bracket a certificate may honestly report from ``point``: with
    ``d+ = max(T v - v)^+`` and ``d- = max(v - T v)^+`` recomputed here,
    ``[v - (d- + m) / (1 - lambda), v + (d+ + m) / (1 - lambda)]`` (``m`` a generous
    rounding allowance, :func:`rounding_slack`). Returns ``(floor, ceil, d+, d-)``."""
    v = np.asarray(point, dtype=np.float64)
    tv = np.asarray(t_point, dtype=np.float64)
    diff = tv - v
    d_up = float(max(0.0, diff.max(initial=0.0)))
    d_down = float(max(0.0, -diff.min(initial=0.0)))
    m = rounding_slack(reward_absmax, np.r_[v, tv], n_terms)
    k = (1.0 + REL) / (1.0 - discount)
    return v - (d_down + m) * k, v + (d_up + m) * k, d_up, d_down


def assert_bracket(
    res: Any,
    *,
    point: Any,
    t_point: Any,
    discount: float,
    reward_absmax: float,
    n_terms: int,
    lower: Any = None,
    upper: Any = None,
    optimum: Any = None,
    optimum_err: float = 0.0,
    judged: str = "both",
    reward_floor: float | None = None,
    accuracy: float | None = None,
    check_error_bound: bool = True,
    what: str = "",
) -> str:
    """The certified bracket of ``res`` (an LP or NLP result) held to its promise both ways.

    ``point`` is the point the certificate is taken at (the full LP point: all IB blocks,
    ALP's ``Phi r``), ``t_point`` the operator of its row system applied to it, computed
    independently; ``lower``/``upper`` default to ``res.lower_values``/``res.upper_values``
    and cover the first ``len(lower)`` entries of the point (IB reports block ``v_1``).

    * the status keeps a point (never INFEASIBLE/UNBOUNDED on these LPs);
    * the bracket is finite and contains ``optimum`` (up to its own error ``optimum_err``);
    * it is no wider than the point's residual implies (:func:`bracket_limits`), so an
      inflated or infinite bracket fails, whatever the status;
    * OPTIMAL: each judged side (``"both"``; ``"upper"`` where only feasibility is judged:
      ALP, LLP, a cost with zeros) is within ``accuracy * max|R| / (1 - lambda)`` plus the
      rounding allowance, and so is ``error_bound`` where both sides are judged;
    * INACCURATE: the recomputed residual really exceeds ``accuracy * max|R|`` (an honest
      status, not a pessimistic one). The LP's rows may merge duplicate rows (keeping the
      best reward), so its ``max|R|`` lies between ``reward_floor`` (:func:`reward_floor`;
      default ``reward_absmax``) and ``reward_absmax``: the OPTIMAL limits use the larger,
      the INACCURATE check the smaller.

    Returns the status (as a string) for the caller's own expectations.
    """
    status = _status(res)
    assert status in POINT_STATUSES, f"{what}: status {status} on a feasible bounded LP"
    lo = np.asarray(res.lower_values if lower is None else lower, dtype=np.float64)
    hi = np.asarray(res.upper_values if upper is None else upper, dtype=np.float64)
    v = np.asarray(point, dtype=np.float64)
    k = lo.size
    assert np.isfinite(lo).all() and np.isfinite(hi).all(), f"{what}: a bracket end is not finite"
    assert (lo <= hi).all(), f"{what}: lower above upper"
    floor, ceil, d_up, d_down = bracket_limits(v, t_point, discount, reward_absmax, n_terms)
    assert (hi <= ceil[:k]).all(), (
        f"{what}: upper_values exceed point + residual / (1 - lambda) by "
        f"{float((hi - ceil[:k]).max()):.3e} (d+ = {d_up:.3e})"
    )
    assert (lo >= floor[:k]).all(), (
        f"{what}: lower_values below point - residual / (1 - lambda) by "
        f"{float((floor[:k] - lo).max()):.3e} (d- = {d_down:.3e})"
    )
    if optimum is not None:
        opt = np.asarray(optimum, dtype=np.float64)[:k]
        assert (lo <= opt + optimum_err).all(), f"{what}: lower_values above the exact optimum"
        assert (hi >= opt - optimum_err).all(), f"{what}: upper_values below the exact optimum"
    acc = float(res.accuracy if accuracy is None else accuracy)
    tol = acc * (reward_absmax if reward_floor is None else reward_floor)
    allow = acc * reward_absmax / (1.0 - discount) * (1.0 + REL) + (
        rounding_slack(reward_absmax, np.r_[v, t_point], n_terms) / (1.0 - discount)
    )
    if status == "optimal":
        assert float((hi - v[:k]).max(initial=0.0)) <= allow, (
            f"{what}: OPTIMAL but upper_values - point = {float((hi - v[:k]).max()):.3e} > "
            f"the requested {allow:.3e}"
        )
        if judged == "both":
            assert float((v[:k] - lo).max(initial=0.0)) <= allow, (
                f"{what}: OPTIMAL but point - lower_values = {float((v[:k] - lo).max()):.3e} "
                f"> the requested {allow:.3e}"
            )
            if check_error_bound:
                assert 0.0 <= res.error_bound <= allow, (
                    f"{what}: OPTIMAL with error_bound {res.error_bound:.3e} > {allow:.3e}"
                )
    elif status == "inaccurate":
        side = max(d_up, d_down) if judged == "both" else d_up
        if judged == "both" or d_up > tol:  # an upper-judged point may fail on its own rule
            slack = rounding_slack(reward_absmax, np.r_[v, t_point], n_terms)
            assert side + slack >= tol, (
                f"{what}: INACCURATE but the recomputed residual {side:.3e} is within the "
                f"requested {tol:.3e}"
            )
    if check_error_bound and judged == "both":
        assert np.isfinite(res.error_bound), f"{what}: error_bound not finite"
        worst = max(float((ceil - v).max(initial=0.0)), float((v - floor).max(initial=0.0)))
        assert res.error_bound <= worst, (
            f"{what}: error_bound {res.error_bound:.3e} above what the residual implies "
            f"({worst:.3e})"
        )
        if optimum is not None:
            true = float(np.abs(v[:k] - np.asarray(optimum)[:k]).max(initial=0.0))
            assert true <= res.error_bound + optimum_err, (
                f"{what}: true error {true:.3e} > error_bound {res.error_bound:.3e}"
            )
    return status


def assert_objective_bracket(bracket, cost, optimum, optimum_err, width_limit, what=""):
    """``lo <= c'v* <= hi`` (up to the reference's error) and ``hi - lo <= width_limit``."""
    lo, hi = bracket
    c = np.asarray(cost, dtype=np.float64)
    opt = float(c @ np.asarray(optimum, dtype=np.float64))
    slack = optimum_err * float(np.abs(c).sum())
    assert np.isfinite(lo) and np.isfinite(hi), f"{what}: objective bracket not finite"
    assert lo <= opt + slack and opt - slack <= hi, f"{what}: [{lo}, {hi}] misses c'v* = {opt}"
    assert hi - lo <= width_limit, f"{what}: objective bracket width {hi - lo:.3e} > {width_limit}"


def dp_bound_ceiling(residual: float, values: Any, discount: float) -> float:
    """The largest error bound an exact-DP result may honestly report for a vector whose
    Bellman residual (recomputed here) is ``residual``: ``(residual + 32 eps max(1, max|V|))
    / (1 - lambda)``, four times the package's documented rounding slack of 8 ulps (and
    ``1e-9`` relative for a contraction modulus a few ulps above ``lambda``), so only an
    inflated bound, not rounding, can exceed it."""
    vmax = float(np.abs(np.asarray(values, dtype=np.float64)).max(initial=0.0))
    return (residual + 32.0 * EPS * max(1.0, vmax)) / (1.0 - discount) * (1.0 + REL)


def assert_dp_certificate(
    res: Any,
    t_values: Any,
    discount: float,
    *,
    reference: Any = None,
    reference_err: float = 0.0,
    tol: float | None = None,
    what: str = "",
) -> None:
    """An exact-DP result (``values``, ``residual``, ``error_bound``, ``status``, ``tol``) held
    to its promise both ways, with ``t_values`` the operator at ``res.values`` computed here:

    * the reported residual is the true one (to rounding);
    * ``error_bound`` is no larger than the residual implies (:func:`dp_bound_ceiling`);
    * OPTIMAL: the residual is within ``tol`` and ``error_bound <= (tol + slack) / (1 -
      lambda)``;
    * the true error against ``reference`` (with its own error) is within ``error_bound``.
    """
    v = np.asarray(res.values, dtype=np.float64)
    tv = np.asarray(t_values, dtype=np.float64)
    true_res = float(np.abs(tv - v).max(initial=0.0))
    vmax = float(np.abs(v).max(initial=0.0))
    rnd = 32.0 * EPS * max(1.0, vmax, float(np.abs(tv).max(initial=0.0)))
    assert abs(true_res - res.residual) <= rnd, (
        f"{what}: reported residual {res.residual:.6e} is not the true {true_res:.6e}"
    )
    ceiling = dp_bound_ceiling(true_res, v, discount)
    assert np.isfinite(res.error_bound) and res.error_bound <= ceiling, (
        f"{what}: error_bound {res.error_bound:.6e} > (residual + rounding) / (1 - lambda) "
        f"= {ceiling:.6e}"
    )
    assert res.error_bound >= true_res / (1.0 + discount) * (1 - REL) or true_res == 0.0, (
        f"{what}: error_bound {res.error_bound:.3e} below what the residual alone proves"
    )
    status = _status(res) if hasattr(res, "status") else "optimal"
    t = getattr(res, "tol", None) if tol is None else tol
    if status == "optimal" and t is not None:
        assert true_res <= t + rnd, f"{what}: OPTIMAL with residual {true_res:.3e} > tol {t:.3e}"
        assert res.error_bound <= dp_bound_ceiling(t, v, discount), (
            f"{what}: OPTIMAL but error_bound {res.error_bound:.3e} > (tol + slack) / (1 - "
            f"lambda) = {dp_bound_ceiling(t, v, discount):.3e}"
        )
    if reference is not None:
        err = float(np.abs(v - np.asarray(reference, dtype=np.float64)).max(initial=0.0))
        assert err <= res.error_bound + reference_err, (
            f"{what}: |V - V*| = {err:.3e} > error_bound {res.error_bound:.3e} "
            f"(+ reference error {reference_err:.1e})"
        )


def check_mdp_lp(
    res: Any,
    kind: str,
    P,
    R,
    allowed,
    discount: float,
    *,
    labels: Any = None,
    cost: Any = None,
    n_blocks: int = 1,
    optimum: Reference | None = None,
    what: str = "",
    row_terms: int = 0,
) -> str:
    """:func:`assert_bracket` for the LP of an MDP given as arrays, the operator and the
    exact optimum computed here. ``row_terms``: terms summed in floating point to make a
    row (added to the rounding allowance; SLP's surrogate rows sum ``|S_i| (L + 1)``).
    ``kind``:

    * ``"ELP"`` (eq. 8): per state, ``V*`` by policy iteration;
    * ``"RLP"`` (eq. 9; also UBLP, and ``res.values`` of LLP): per partition ``labels``,
      ``v*`` by policy iteration over the aggregated rows;
    * ``"IB"`` (eq. 20-22): the ``n_blocks`` stacked blocks ``res.x``, optimum ``v*`` each;
    * ``"LLP"``: RLP's rows at LLP's ``v`` (the bracket is on RLP's ``v*``), only the upper
      side judged;
    * ``"ALP"``: per state at ``Phi r`` (``res.state_values``), on ``V*``, upper side only.

    A side is judged for OPTIMAL only where the formulation promises it: both sides when
    every (partition) cost is positive, else the upper side (a cost of zero leaves the
    point free there). Returns the status.
    """
    R = np.asarray(R, dtype=np.float64)
    n = P.shape[1]
    c = np.ones(n) if cost is None else np.asarray(cost, dtype=np.float64)
    n_terms = int((P > 0).sum(axis=2).max(initial=1)) + int(row_terms)
    r_abs = float(np.abs(R[allowed]).max(initial=0.0))
    if kind in ("ELP", "ALP"):
        point = np.asarray(res.values if kind == "ELP" else res.state_values, dtype=np.float64)
        t_point = bellman(P, R, allowed, discount, point)
        opt = policy_iteration(P, R, allowed, discount) if optimum is None else optimum
        floor = reward_floor(R, allowed)
        positive = bool((c > 0).all())
    else:
        lab = np.asarray(labels, dtype=np.int64)
        opt = rlp_optimum(P, R, allowed, discount, lab) if optimum is None else optimum
        cbar = np.bincount(lab, weights=c, minlength=int(lab.max()) + 1)
        positive = bool((cbar > 0).all())
        floor = reward_floor(R, allowed, lab)
        if kind == "IB":
            point = np.asarray(res.x, dtype=np.float64)
            t_point = ib_operator(P, R, allowed, discount, lab, point, n_blocks)
            opt = Reference(np.tile(opt.values, n_blocks), opt.error)
        else:
            point = np.asarray(res.values, dtype=np.float64)
            t_point = rlp_operator(P, R, allowed, discount, lab, point)
    judged = "both" if positive and kind not in ("ALP", "LLP") else "upper"
    return assert_bracket(
        res, point=point, t_point=t_point, discount=discount, reward_absmax=r_abs,
        n_terms=n_terms, optimum=opt.values,
        optimum_err=opt.error, judged=judged, reward_floor=floor,
        check_error_bound=kind not in ("ALP", "LLP"), what=what or kind,
    )  # fmt: skip


def nlp_reward_floor(R, allowed, labels) -> float:
    """A lower bound on ``max|reward|`` over the NLP's merged min-rows: for each kept ``(i,
    u)`` (``u`` allowed at every state of ``S_i``) the smallest reward over ``S_i`` is kept."""
    lab = np.asarray(labels, dtype=np.int64)
    m = int(lab.max()) + 1
    r = np.where(allowed, np.asarray(R, dtype=np.float64), np.inf)
    worst = np.full((m, r.shape[1]), np.inf)
    for a in range(r.shape[1]):
        np.minimum.at(worst[:, a], lab, r[:, a])
    kept = np.isfinite(worst)
    return float(np.abs(worst[kept]).max(initial=0.0))


def nlp_optimum(P, R, allowed, discount, labels, max_iter: int = 10_000) -> Reference:
    """``w*``, eq. 25's least feasible point, by strategy iteration: fix the minimiser's state
    ``x in S_i`` for every kept ``(i, u)``, solve that row system by policy iteration, switch
    each ``(i, u)`` to its smallest term there (only for a strict decrease), repeat. Every
    iterate is feasible for the fixed strategy and they decrease: finite."""
    lab = np.asarray(labels, dtype=np.int64)
    m = int(lab.max()) + 1
    n_act = np.asarray(R).shape[1]
    onehot = np.zeros((P.shape[1], m))
    onehot[np.arange(P.shape[1]), lab] = 1.0
    members = [np.flatnonzero(lab == i) for i in range(m)]
    pairs = [(i, u) for i in range(m) for u in range(n_act) if allowed[members[i], u].all()]
    if {i for i, _ in pairs} != set(range(m)):
        raise ValueError("a partition without a common action: w* is -inf there")
    dist = {(i, u): P[u, members[i]] @ onehot for i, u in pairs}  # one row per x in S_i
    rew = {(i, u): np.asarray(R, dtype=np.float64)[members[i], u] for i, u in pairs}
    choice = {k: int(np.argmin(rew[k])) for k in pairs}
    owner = np.array([i for i, _ in pairs])
    for _ in range(max_iter):
        reward = np.array([rew[k][choice[k]] for k in pairs])
        rows = np.array([dist[k][choice[k]] for k in pairs])
        ref = _rows_policy_iteration(owner, reward, rows, None, discount, m)
        tie = 1e-13 * max(1.0, float(np.abs(ref.values).max(initial=0.0)))
        changed = False
        for k in pairs:
            q = rew[k] + discount * dist[k] @ ref.values
            best = int(np.argmin(q))
            if q[best] < q[choice[k]] - tie:
                choice[k], changed = best, True
        if not changed:
            break
    else:
        raise AssertionError("reference strategy iteration did not converge")
    w = ref.values
    res = float(np.abs(nlp_operator(P, R, allowed, discount, lab, w) - w).max(initial=0.0))
    return Reference(w, (res + rounding_slack(R, w, m)) / (1.0 - discount))


def check_nlp(
    res: Any,
    P,
    R,
    allowed,
    discount: float,
    labels,
    *,
    optimum: Reference | None = None,
    what: str = "",
) -> str:
    """An NLP result's certified bracket on ``w*`` both ways (:func:`assert_bracket` with the
    max-min operator computed here; OPTIMAL means a residual within ``gap_rtol / 2`` of
    ``max|R|``, so both sides within ``gap_rtol / 2`` of the scale), and its bracket
    ``[lower_bound, upper_bound]`` on ``c'w*``: it contains ``c'w*``, is no wider than
    ``c'(upper_values - lower_values)`` allows and, OPTIMAL, than ``gap_rtol sum(c) scale``."""
    R = np.asarray(R, dtype=np.float64)
    lab = np.asarray(labels, dtype=np.int64)
    opt = nlp_optimum(P, R, allowed, discount, lab) if optimum is None else optimum
    point = np.asarray(res.values, dtype=np.float64)
    t_point = nlp_operator(P, R, allowed, discount, lab, point)
    r_abs = float(np.abs(R[allowed]).max(initial=0.0))
    n_terms = int((P > 0).sum(axis=2).max(initial=1))
    status = assert_bracket(
        res, point=point, t_point=t_point, discount=discount, reward_absmax=r_abs,
        reward_floor=nlp_reward_floor(R, allowed, lab), n_terms=n_terms,
        optimum=opt.values, optimum_err=opt.error, accuracy=res.gap_rtol / 2, what=what,
    )  # fmt: skip
    c = np.asarray(res.cost, dtype=np.float64)
    floor, ceil, _, _ = bracket_limits(point, t_point, discount, r_abs, n_terms)
    limit = float(c @ (ceil - floor))
    if status == "optimal":
        slack = rounding_slack(r_abs, np.r_[point, t_point], n_terms)
        limit = min(limit, float(c.sum()) * (res.gap_rtol * r_abs + 2 * slack) / (1 - discount))
    assert_objective_bracket(
        (res.lower_bound, res.upper_bound), c, opt.values, opt.error,
        limit * (1 + REL) + 1e-300, what=f"{what} c'w*",
    )  # fmt: skip
    assert res.gap == res.upper_bound - res.lower_bound
    return status
