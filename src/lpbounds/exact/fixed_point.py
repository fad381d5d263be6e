r"""Exact fixed points: the least fixed point of Bellman rows and the value of the NLP's game.

**Least fixed point** (:func:`least_fixed_point`; ``V*`` and the optima of ELP, RLP, SLP,
IB, UBLP, LBLP: Fact 1 of :mod:`lpbounds.rows`). Policy iteration in rational arithmetic:
a policy ``pi`` (one row per variable) is evaluated exactly, ``v = A_pi^{-1} b_pi``
(:meth:`~lpbounds.exact.system.ExactRows.solve_policy`); every row's slack at ``v`` is
computed exactly (``q_r(v) - v(i) = -slack_r``), and every variable with a row of negative
slack switches to its most improving row (ties: the lowest row). When no row improves,
``v >= q_r(v)`` for every row with equality on ``pi``'s rows: ``v = T v`` exactly, the
unique fixed point (``T`` contracts: ``lambda max_r sum_l p_rl < 1`` is checked when the
rows are built). *Termination:* if ``pi'`` switches some variables to strictly improving
rows, ``T_pi' v >= v`` with a strict entry, so ``v_pi' = lim T_pi'^k v >= v`` and
``v_pi' != v``; the values increase strictly in the partial order, no policy repeats, and
there are finitely many. Started from the floating-point solve's policy, one evaluation
and one check usually suffice (the float policy is already optimal).

**The game** (:func:`game_fixed_point`; the disjunctive NLP's optimum, Fact 2):
``(Gw)(i) = max_u min_{r in (i, u)} q_r(w)``. Strategy iteration on the minimiser's side
(Hoffman and Karp's scheme with the players' roles as in :meth:`NLP.solve
<lpbounds.formulations.nlp.problem.NLP.solve>`'s ``"strategy-iteration"``): fix one term
``tau(d)`` per disjunction ``d = (i, u)``; the rows ``tau`` form a Bellman system whose
least fixed point ``v_tau`` is computed exactly as above; then every disjunction whose
smallest term at ``v_tau`` is *strictly* smaller than ``q_tau(d)(v_tau)`` switches to it.
*Correctness:* when nothing switches, ``q_tau(d)(v) = min_{r in d} q_r(v)`` for every
``d`` and ``v = T_tau v``, so ``v = G v``, the unique fixed point of the contraction ``G``.
*Termination:* after a switch ``T_tau' v_tau <= T_tau v_tau = v_tau``, so ``v_tau`` is
feasible for ``tau'`` and ``v_tau' <= v_tau`` (its least feasible point). If
``v_tau' = v_tau``, every disjunction already holds its smallest term at ``v_tau'`` (the
switch chose them there), so the next check switches nothing and the method stops;
otherwise the values decrease strictly. So no strategy repeats, and there are finitely
many.

Both verify their answer with the certificate checker's own test
(:func:`lpbounds.exact.check.check_fixed_point`) before returning it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ConsistencyError, ConvergenceError, ValidationError
from . import check
from .rationals import RationalVector, nearest_float, rational
from .system import ExactProgress, ExactRows, ProgressCallback

__all__ = [
    "ExactFixedPoint",
    "game_fixed_point",
    "greedy_start",
    "least_fixed_point",
    "occupation_measure",
]

#: Improvement steps after which exact policy iteration gives up (never reached in the
#: measurements: from the float solve's policy it stops after 1-3 evaluations).
MAX_EXACT_ITER = 10_000


@dataclass(repr=False)
class ExactFixedPoint:
    """An exact fixed point, verified.

    Attributes
    ----------
    values : RationalVector
        The fixed point, exactly (``values[i]`` is a :class:`~fractions.Fraction`).
    policy : ndarray of int
        Per variable, a row attaining ``T v`` (for the game: the minimising row of a
        maximising action).
    strategy : ndarray of int or None
        The game only: the term (row) of every disjunction at the fixed point.
    iterations : int
        Exact evaluations (for the game: of every strategy's inner iteration).
    seconds : float
    history : list of float
        The exact residual ``max (T v - v)`` after each evaluation, as floats.
    rows : ExactRows
        The row system.
    game : bool
    """

    values: RationalVector
    policy: np.ndarray
    iterations: int
    seconds: float
    rows: ExactRows
    game: bool = False
    strategy: np.ndarray | None = None
    history: list[float] = field(default_factory=list)

    def __repr__(self) -> str:
        kind = "game value" if self.game else "least fixed point"
        return (
            f"ExactFixedPoint({kind}, n={len(self.values)}, iterations={self.iterations}, "
            f"{self.seconds:.3f} s)"
        )

    def entry(self, ident: str) -> dict[str, Any]:
        """This fixed point as a certificate entry (``fixed_points`` of the file format)."""
        return {**self.rows.spec, "id": ident, "game": self.game, "x": self.values.to_json()}


def _by_owner(rows: ExactRows) -> list[list[int]]:
    """The rows of every variable; a ValidationError if one owns none."""
    out: list[list[int]] = [[] for _ in range(rows.n_vars)]
    for r, o in enumerate(rows.owners()):
        if o < 0:
            raise ConsistencyError(f"row {r} is not a Bellman row (no owner)")
        out[int(o)].append(r)
    empty = [i for i, rs in enumerate(out) if not rs]
    if empty:
        raise ValidationError(f"variable {empty[0]} owns no row: it has no fixed point")
    return out


def _start(rows: ExactRows, owned: list[list[int]], start: Any) -> list[int]:
    """A starting policy: ``start`` checked (a row per variable), or the rows of largest
    reward (greedy at ``v = 0``)."""
    if start is None:
        return [max(rs, key=lambda r: (rows.rows[r][1], -r)) for rs in owned]
    sel = [int(r) for r in np.asarray(start).ravel()]
    if len(sel) != rows.n_vars:
        raise ValidationError(
            f"start must have one row per variable ({rows.n_vars}); got {len(sel)}"
        )
    owner = rows.owners()
    for i, r in enumerate(sel):
        if not (0 <= r < rows.n_rows and owner[r] == i):
            raise ValidationError(f"start[{i}] = {r} is not a row of variable {i}")
    return sel


def greedy_start(rows: ExactRows, approx: Any) -> np.ndarray:
    """A policy greedy w.r.t. an approximate (float) fixed point: per variable its row of
    least float slack at ``approx`` (the float solve's answer gives the optimal policy but
    for ties, so that one exact evaluation usually settles it)."""
    s = rows.float_slacks(np.asarray(approx, dtype=np.float64))
    owned = _by_owner(rows)
    return np.array([min(rs, key=lambda r: (s[r], r)) for rs in owned], dtype=np.int64)


def least_fixed_point(
    rows: ExactRows,
    start: Any = None,
    *,
    callback: ProgressCallback | None = None,
    size_limit: int | None = None,
    what: str = "a row system",
    verify: bool = True,
    _t0: float | None = None,
    _it0: int = 0,
) -> ExactFixedPoint:
    """The least fixed point of Bellman rows, ``v = T v``, in rational arithmetic.

    Parameters
    ----------
    rows : ExactRows
        Bellman rows (each owned by a variable; every variable owns one).
    start : array_like of int, optional
        A starting policy (a row per variable): the float solve's, for speed (default:
        the rows of largest reward).
    callback : callable(ExactProgress), optional
        Progress: after every component solved and every improvement check.
    size_limit : int, optional
        Refuse a policy whose largest strongly connected component (one dense solve) has
        more variables (default :data:`~lpbounds.tolerances.EXACT_MAX_VARIABLES`), before
        that evaluation starts.
    what : str
        The system's name in the size error.
    verify : bool
        Check the answer with :func:`lpbounds.exact.check.check_fixed_point` (rows built
        from ``rows.spec``; off only for a subset of those rows, the game's inner step).

    Returns
    -------
    ExactFixedPoint

    Raises
    ------
    SizeLimitError
        Before an evaluation whose largest component is above ``size_limit`` (in practice
        the first: the float policy is the exact one).
    ConvergenceError
        After :data:`MAX_EXACT_ITER` improvements (never seen).
    """
    t0 = time.perf_counter() if _t0 is None else _t0
    owned = _by_owner(rows)
    sel = _start(rows, owned, start)
    form = rows.form()
    history: list[float] = []
    for it in range(_it0 + 1, _it0 + MAX_EXACT_ITER + 1):

        def step(done: int, total: int, it: int = it) -> None:
            if callback is not None:
                callback(ExactProgress("evaluate", it - 1, done, total, time.perf_counter() - t0))

        v = rows.solve_policy(sel, progress=step, size_limit=size_limit, what=what)
        s = rows.slacks(v)
        switched, worst = _improve(owned, form, s)
        res = 0.0 if worst is None else nearest_float(-worst[0], worst[1] * v.denominator)
        history.append(res)
        if callback is not None:
            callback(
                ExactProgress(
                    "improve", it, len(switched), rows.n_vars, time.perf_counter() - t0, res
                )
            )
        if not switched:
            if verify:
                check.check_fixed_point(
                    "exact fixed point", {**rows.spec, "x": v.entry()}, check.load_model(rows.model)
                )
            return ExactFixedPoint(
                v,
                np.array(sel, dtype=np.int64),
                it - _it0,
                time.perf_counter() - t0,
                rows,
                history=history,
            )
        for i, r in switched:
            sel[i] = r
    raise ConvergenceError(f"exact policy iteration did not stop in {MAX_EXACT_ITER} steps")


def _improve(
    owned: list[list[int]], form: list[Any], s: list[int]
) -> tuple[list[tuple[int, int]], tuple[int, int] | None]:
    """Per variable, its most improving row (least ``slack = s_r / d_r < 0``; ties: the
    lowest row); and the largest improvement ``(s, d)`` over all of them."""
    switched: list[tuple[int, int]] = []
    worst: tuple[int, int] | None = None
    for i, rs in enumerate(owned):
        best = None
        for r in rs:
            if s[r] < 0 and (best is None or s[r] * form[best][3] < s[best] * form[r][3]):
                best = r
        if best is None:
            continue
        switched.append((i, best))
        d = form[best][3]
        if worst is None or s[best] * worst[1] < worst[0] * d:
            worst = (s[best], d)
    return switched, worst


def occupation_measure(
    rows: ExactRows, policy: Any, cost: Any, *, size_limit: int | None = None
) -> RationalVector:
    """The dual of the Bellman-row LP ``min c'x s.t. A x >= b`` at a policy: the solution
    of ``A_pi' y_pi = c`` on the policy's rows, 0 on every other row.

    For Bellman rows ``A_pi = I - lambda P_pi`` and ``y_pi = (I - lambda P_pi)^{-T} c``,
    the policy's discounted occupation measure of ``c``: ``>= 0`` for ``c >= 0``
    (``(I - lambda P_pi)^{-1} = sum_k (lambda P_pi)^k >= 0``). With ``x`` the least fixed
    point and ``pi`` its policy, ``y'(A x - b) = 0`` (the policy's rows are tight), so
    ``c'x = y'A x = b'y``: the pair proves ``x`` optimal.
    """
    sel = [int(r) for r in np.asarray(policy).ravel()]
    c = [rational(t) for t in cost]
    z = rows.solve_policy(sel, transpose=True, rhs=c, size_limit=size_limit, what="the dual")
    num = [0] * rows.n_rows
    for i, r in enumerate(sel):
        num[r] = z.numerators[i]
    return RationalVector(num, z.denominator)


def game_fixed_point(
    rows: ExactRows,
    approx: Any = None,
    *,
    callback: ProgressCallback | None = None,
    size_limit: int | None = None,
    what: str = "the disjunctive NLP's partitions",
) -> ExactFixedPoint:
    """The fixed point of ``(Gw)(i) = max_u min_{r in (i,u)} q_r(w)`` in rational arithmetic.

    Parameters
    ----------
    rows : ExactRows
        The NLP's terms (``{"rows": "NLP"}``): rows with groups ``(owner, action)``.
    approx : array_like, optional
        An approximate fixed point (a float solve's): the starting strategies are greedy
        at it.
    callback, size_limit, what
        As in :func:`least_fixed_point`.

    Returns
    -------
    ExactFixedPoint
        ``game=True``; ``strategy`` the term of every disjunction (in the order of first
        appearance of the disjunctions in ``rows``).
    """
    t0 = time.perf_counter()
    _by_owner(rows)
    groups: dict[Any, list[int]] = {}
    for r, row in enumerate(rows.rows):
        groups.setdefault(row[3], []).append(r)
    keys = list(groups)
    form = rows.form()
    s_float = None if approx is None else rows.float_slacks(np.asarray(approx, dtype=np.float64))
    # the minimiser's term per disjunction: the largest slack (smallest q) at approx
    tau = [
        max(groups[g], key=lambda r: (s_float[r], -r)) if s_float is not None else groups[g][0]
        for g in keys
    ]
    inner = None if s_float is None else greedy_start(rows.subset(tau), approx)
    iterations, history = 0, []
    while True:
        sub = rows.subset(tau)
        fp = least_fixed_point(
            sub,
            inner,
            callback=callback,
            size_limit=size_limit,
            what=what,
            verify=False,
            _t0=t0,
            _it0=iterations,
        )
        iterations += fp.iterations
        history += fp.history
        s = rows.slacks(fp.values)
        changed = 0
        for k, g in enumerate(keys):
            cur = tau[k]
            for r in groups[g]:  # a strictly smaller term: a strictly larger slack / d
                if s[r] * form[cur][3] > s[cur] * form[r][3]:
                    cur = r
            if cur != tau[k]:
                tau[k], changed = cur, changed + 1
        if callback is not None:
            callback(
                ExactProgress("switch", iterations, changed, len(keys), time.perf_counter() - t0)
            )
        if not changed:
            v = fp.values
            check.check_fixed_point(
                "exact game value",
                {**rows.spec, "game": True, "x": v.entry()},
                check.load_model(rows.model),
            )
            policy = np.array([tau[int(r)] for r in fp.policy], dtype=np.int64)
            return ExactFixedPoint(
                v,
                policy,
                iterations,
                time.perf_counter() - t0,
                rows,
                game=True,
                strategy=np.array(tau, dtype=np.int64),
                history=history,
            )
        inner = fp.policy  # the same disjunctions, new terms: keep the maximiser's choice
