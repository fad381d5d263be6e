r"""Exact LP optima with the primal and dual that prove them.

Every LP here is ``min c'x  s.t.  A x >= b`` built *in exact arithmetic* from the stored
model (the checker's builders, :func:`lpbounds.exact.check.lp_of`): the paper's LP of the
model, not the floating-point matrix handed to a solver (whose entries are
``fl(lambda p)``, whose aggregated probabilities were summed in floating point). An
:class:`ExactLP` is returned only after :func:`lpbounds.exact.check.check_lp` has verified
``A x >= b``, ``y >= 0``, ``A'y = c`` and ``c'x = b'y`` in Python integers and Fractions.

Routes:

* **Bellman-row LPs** (ELP, RLP, SLP, UBLP, LBLP: :func:`bellman_lp`): ``x`` is the rows'
  exact least fixed point (Fact 1; :func:`~lpbounds.exact.fixed_point.least_fixed_point`,
  started from the policy greedy at the solver's point) and ``y`` the occupation measure
  ``(I - lambda P_pi)^{-T} c`` of its policy on the policy's rows
  (:func:`~lpbounds.exact.fixed_point.occupation_measure`).
* **IB** (:func:`ib_lp`): ``x = (v*, ..., v*)`` from RLP's fixed point and the policy's rows
  in every block; ``y`` the occupation measure of the cyclic policy (the block-wise
  ``y_RLP`` when every block has the same cost: ``y_j = c + lambda P' y_{j+1}`` is then
  solved by ``y_j = y``).
* **General LPs** (ALP: :func:`simplex_lp`): an exact simplex method (Bland's rule) on
  ``min c'x s.t. A x >= b`` with free ``x``, started at the solver's point: if it is
  feasible it is moved to a vertex without raising the objective (a *crash* along null
  directions of the tight rows), else a phase 1 (``min t s.t. A x + t 1 >= b, t >= 0``)
  finds a feasible point first; then primal simplex pivots until the basis's duals are
  ``>= 0``. Each pivot solves two ``K x K`` systems exactly (:func:`solve_rational`): meant
  for LPs of a few hundred variables (ALP's ``K`` basis functions).
* **LLP** (:func:`llp_lp`): eliminating ``z = A v - R`` leaves ``min g'v s.t. A v >= R``
  over RLP's per-pair rows with ``g = c-bar + A'd``; its optimum (RLP's ``v*`` when
  ``g >= 0``, else the simplex from ``v*``'s vertex) gives LLP's ``(v, z)`` and its duals
  ``y_lower = (mu - d)^+``, ``y_upper = (d - mu)^+``, ``y_nonneg = mu`` from the reduced
  LP's duals ``mu``.

**What an exact answer trusts.** The model's stored doubles, taken as the exact rationals
they are; the checker (:mod:`lpbounds.exact.check`, Python's ints and Fractions) that
verified it; LP weak duality. python-flint only *computed* it (a wrong solve would fail
the check), and nothing is taken from the solver: its point only chose where the exact
computation starts.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from ..errors import ConsistencyError, ValidationError
from . import check
from .fixed_point import (
    ExactFixedPoint,
    game_fixed_point,
    greedy_start,
    least_fixed_point,
    occupation_measure,
)
from .rationals import RationalVector, fraction_text, rational, solve_rational
from .system import ExactRows, ProgressCallback, check_size

__all__ = [
    "TRUST",
    "ExactLP",
    "bellman_lp",
    "certify_optimum",
    "game_optimum",
    "ib_lp",
    "llp_lp",
    "simplex_lp",
]

#: What every exact answer rests on (docs/exact.md, "Trust").
TRUST = (
    "the model's stored doubles as exact rationals; the exact answer verified by "
    "lpbounds.exact.check in Python integers and Fractions (primal and dual feasibility, "
    "equal objectives); python-flint only computed it; nothing from the solver"
)


@dataclass(repr=False)
class ExactLP:
    """The exact optimum of an LP of the model, with the primal and dual that prove it.

    Attributes
    ----------
    formulation : str
    objective : Fraction
        ``c'x = b'y``.
    x : RationalVector
        The exact optimal point (every variable of the LP).
    y : RationalVector or None
        The exact duals, one per row of the exact LP (the checker's row order); ``None``
        for the disjunctive NLP (not an LP: its proof is the game's fixed point).
    values : RationalVector
        The value variables, as ``LPResult.values`` (ELP: ``V``; RLP, SLP, UBLP, LBLP, LLP:
        ``v``; IB: ``v_1``; ALP: ``r``).
    spec : dict
        The LP as the certificate describes it (``{"formulation": ..., "cost": ...}``).
    model : dict
        The certificate's model data.
    method : str
        How it was computed (see the module docstring).
    seconds : float
    unique : bool
        Whether the duals also prove the optimum unique (see :mod:`lpbounds.exact.check`).
    trust : str
        What the answer rests on (:data:`TRUST`).
    fixed_point : ExactFixedPoint or None
        The rows' exact fixed point (Bellman-row LPs).
    float_values : ndarray or None
        The solver's ``values`` (set by :meth:`judge`).
    error : Fraction or None
        ``max |float_values - values|``: how far the solver really was.
    objective_error : Fraction or None
        ``|float objective - objective|``.
    bracket_target : RationalVector or None
        The exact quantity the float result's certified bracket is about (the LP's
        optimum; for ALP, ``V*``; for LLP, RLP's ``v*``).
    inside_bracket : bool or None
        Whether ``lower_values <= bracket_target <= upper_values`` held, exactly.
    """

    formulation: str
    objective: Fraction
    x: RationalVector
    y: RationalVector | None
    values: RationalVector
    spec: dict[str, Any]
    model: dict[str, Any]
    method: str
    seconds: float
    unique: bool
    trust: str = TRUST
    fixed_point: ExactFixedPoint | None = None
    float_values: np.ndarray | None = None
    error: Fraction | None = None
    objective_error: Fraction | None = None
    bracket_target: RationalVector | None = None
    inside_bracket: bool | None = None

    def __repr__(self) -> str:
        err = "" if self.error is None else f", solver's error {float(self.error):.3e}"
        return (
            f"ExactLP({self.formulation}, objective ~ {float(self.objective):.17g}, "
            f"{len(self.x)} variables, {self.method}{err})"
        )

    def entry(self, ident: str) -> dict[str, Any]:
        """This optimum as a certificate entry (``lps`` of the file format; for the NLP a
        ``fixed_points`` entry)."""
        if self.y is None:
            assert self.fixed_point is not None
            return self.fixed_point.entry(ident)
        return {
            "id": ident,
            "lp": self.spec,
            "x": self.x.to_json(),
            "y": self.y.to_json(),
            "objective": fraction_text(self.objective),
            "unique": self.unique,
        }

    def judge(
        self,
        float_values: Any,
        lower: Any = None,
        upper: Any = None,
        float_objective: float | None = None,
        target: RationalVector | None = None,
    ) -> ExactLP:
        """Record a float answer's exact error and whether its bracket held (in place).

        Parameters
        ----------
        float_values : array_like
            The float result's ``values``.
        lower, upper : array_like, optional
            Its certified bracket (``None``: no bracket).
        float_objective : float, optional
        target : RationalVector, optional
            What the bracket is about (default :attr:`values`).

        Returns
        -------
        ExactLP
            ``self``.
        """
        fv = np.asarray(float_values, dtype=np.float64)
        self.float_values = fv
        if np.all(np.isfinite(fv)):
            self.error = self.values.max_abs_error(fv)
        if float_objective is not None and np.isfinite(float_objective):
            self.objective_error = abs(Fraction(float(float_objective)) - self.objective)
        self.bracket_target = self.values if target is None else target
        if lower is not None and upper is not None:
            self.inside_bracket = self.bracket_target.within(lower, upper)
        return self


def certify_optimum(
    formulation: str,
    rows: ExactRows,
    x: RationalVector,
    y: RationalVector,
    method: str,
    t0: float,
    fixed_point: ExactFixedPoint | None = None,
    unique: bool = False,
    values: RationalVector | None = None,
) -> ExactLP:
    """The ExactLP of a primal ``x`` and dual ``y`` of the LP ``rows`` (built from an LP
    spec), after the checker's verification (:func:`lpbounds.exact.check.check_lp`).

    ``values``: the value variables (default ``x``); ``t0``: when the computation started
    (``time.perf_counter()``).

    Raises
    ------
    ConsistencyError
        When ``(x, y)`` does not prove optimality: a defect of whoever computed them.
    """
    values = x if values is None else values
    objective = x.dot(rows.cost)
    entry = {
        "lp": rows.spec,
        "x": x.entry(),
        "y": y.entry(),
        "objective": objective,
        "unique": unique,
    }
    try:
        check.check_lp(formulation, entry, check.load_model(rows.model))
    except check.CheckError as exc:
        raise ConsistencyError(f"the exact {formulation} optimum fails its check: {exc}") from exc
    return ExactLP(
        formulation,
        objective,
        x,
        y,
        values,
        rows.spec,
        rows.model,
        method,
        time.perf_counter() - t0,
        unique,
        fixed_point=fixed_point,
    )


def _positive_on(y: RationalVector, policy: np.ndarray) -> bool:
    """Whether the duals are positive on every policy row (then the optimum is unique)."""
    return all(y.numerators[int(r)] > 0 for r in policy)


def bellman_lp(
    model: dict[str, Any],
    spec: dict[str, Any],
    *,
    approx: Any = None,
    fixed_point: ExactFixedPoint | None = None,
    callback: ProgressCallback | None = None,
    size_limit: int | None = None,
    what: str = "a Bellman-row LP",
) -> ExactLP:
    """The exact optimum of a Bellman-row LP (ELP, RLP, SLP, ROWS) and its proof.

    Parameters
    ----------
    model : dict
        The certificate's model data (:func:`lpbounds.exact.files.mdp_data`, ...).
    spec : dict
        The LP: ``{"formulation": "RLP", "cost": [...]}`` (and ``"mu"`` for SLP).
    approx : array_like, optional
        An approximate optimum (the solver's ``x``): the start is its greedy policy.
    fixed_point : ExactFixedPoint, optional
        The rows' exact least fixed point, when already known (the optimum for every
        cost, Fact 1): only the dual is then computed for ``spec``'s cost.
    callback, size_limit, what
        As in :func:`~lpbounds.exact.fixed_point.least_fixed_point`.
    """
    t0 = time.perf_counter()
    rows = ExactRows.build(model, spec)
    fp = fixed_point
    if fp is None or fp.rows.n_rows != rows.n_rows or len(fp.values) != rows.n_vars:
        spec_rows = {k: v for k, v in spec.items() if k not in ("formulation", "cost")}
        fp_rows = ExactRows(
            rows.rows,
            rows.n_vars,
            model,
            {**spec_rows, "rows": spec["formulation"]},
            _form=rows.form(),
        )
        fp = least_fixed_point(
            fp_rows, _start_of(rows, approx), callback=callback, size_limit=size_limit, what=what
        )
    y = occupation_measure(rows, fp.policy, rows.cost, size_limit=size_limit)
    return certify_optimum(
        spec["formulation"],
        rows,
        fp.values,
        y,
        "fixed point and occupation measure",
        t0,
        fp,
        _positive_on(y, fp.policy),
    )


def _start_of(rows: ExactRows, approx: Any) -> np.ndarray | None:
    """The greedy policy at a finite approximate point, else ``None`` (the default start)."""
    if approx is None:
        return None
    a = np.asarray(approx, dtype=np.float64)
    if a.shape != (rows.n_vars,) or not np.all(np.isfinite(a)):
        return None
    return greedy_start(rows, a)


def ib_lp(
    model: dict[str, Any],
    L: int,
    cost: list[Any],
    *,
    rlp: ExactFixedPoint | None = None,
    approx: Any = None,
    callback: ProgressCallback | None = None,
    size_limit: int | None = None,
) -> ExactLP:
    """The exact optimum of IB with ``L`` blocks (``cost``: every block's, stacked).

    ``x = (v*, ..., v*)`` with ``v*`` RLP's exact fixed point (``rlp``, computed if not
    given): every block satisfies the cyclic rows with the same slacks as ``v*`` RLP's
    rows, so the policy's rows are tight in every block. ``y``: the cyclic policy's
    occupation measure (block-wise RLP's when the blocks' costs are equal, else solved).
    """
    t0 = time.perf_counter()
    spec = {"formulation": "IB", "L": int(L), "cost": [_text(c) for c in cost]}
    rows = ExactRows.build(model, spec)
    if rlp is None:
        base = ExactRows.build(model, {"rows": "RLP"})
        start = None if approx is None else _start_of(base, np.asarray(approx)[: base.n_vars])
        rlp = least_fixed_point(
            base, start, callback=callback, size_limit=size_limit, what="RLP's partitions"
        )
    m, k = rlp.rows.n_vars, rlp.rows.n_rows
    if rows.n_vars != L * m or rows.n_rows != L * k:
        raise ConsistencyError("IB's rows are not L copies of RLP's")
    v = rlp.values
    x = RationalVector(list(v.numerators) * L, v.denominator)
    policy = np.concatenate([rlp.policy + j * k for j in range(L)])
    c = [rational(t) for t in cost]
    if all(c[j * m + i] == c[i] for j in range(L) for i in range(m)):
        y1 = occupation_measure(rlp.rows, rlp.policy, c[:m], size_limit=size_limit)
        y = RationalVector(list(y1.numerators) * L, y1.denominator)
    else:
        y = occupation_measure(rows, policy, c, size_limit=size_limit)
    return certify_optimum(
        "IB",
        rows,
        x,
        y,
        "RLP's fixed point in every block",
        t0,
        rlp,
        _positive_on(y, policy),
        values=x.take(range(m)),
    )


def _text(c: Any) -> str:
    """A cost entry for the spec: a certificate's number as given, a double's hex, or a
    Fraction's ``"p/q"``."""
    if isinstance(c, str):
        return c
    if isinstance(c, Fraction):
        return fraction_text(c)
    return float(c).hex()


# ---------------------------------------------------------------------- the simplex method
def _row_dot(coefs: dict[int, Fraction], x: list[Fraction]) -> Fraction:
    return sum((a * x[j] for j, a in coefs.items()), Fraction(0))


def _rank_rows(rows: list[Any], index: list[int], n: int) -> list[int]:
    """A maximal linearly independent subset of the rows ``index`` (in order)."""
    kept: list[int] = []
    basis: list[list[Fraction]] = []  # echelon rows with their pivot columns
    pivots: list[int] = []
    for r in index:
        v = [rows[r][0].get(j, Fraction(0)) for j in range(n)]
        for b, p in zip(basis, pivots, strict=True):
            if v[p]:
                f = v[p] / b[p]
                v = [a - f * t for a, t in zip(v, b, strict=True)]
        lead = next((j for j, a in enumerate(v) if a), None)
        if lead is not None:
            basis.append(v)
            pivots.append(lead)
            kept.append(r)
            if len(kept) == n:
                break
    return kept


def _null_direction(rows: list[Any], basis: list[int], n: int) -> list[Fraction]:
    """A nonzero ``d`` with ``a_r'd = 0`` for the (independent) rows ``basis``, ``|basis| < n``."""
    mat = [[rows[r][0].get(j, Fraction(0)) for j in range(n)] for r in basis]
    piv: list[int] = []
    for i in range(len(mat)):  # reduced row echelon form
        p = next(j for j in range(n) if mat[i][j])
        mat[i] = [a / mat[i][p] for a in mat[i]]
        for k in range(len(mat)):
            if k != i and mat[k][p]:
                f = mat[k][p]
                mat[k] = [a - f * t for a, t in zip(mat[k], mat[i], strict=True)]
        piv.append(p)
    free = next(j for j in range(n) if j not in piv)
    d = [Fraction(0)] * n
    d[free] = Fraction(1)
    for i, p in enumerate(piv):
        d[p] = -mat[i][free]
    return d


def _ratio(
    rows: list[Any], x: list[Fraction], d: list[Fraction], skip: set[int]
) -> tuple[Fraction, int] | None:
    """The largest step along ``d`` keeping every row satisfied, and the row that blocks
    it (the lowest index among ties); ``None`` if no row blocks."""
    best: tuple[Fraction, int] | None = None
    for r, (coefs, rhs, *_) in enumerate(rows):
        if r in skip:
            continue
        ad = _row_dot(coefs, d)
        if ad < 0:
            t = (_row_dot(coefs, x) - rhs) / -ad
            if best is None or t < best[0]:
                best = (t, r)
    return best


def _simplex(
    rows: list[Any], cost: list[Fraction], x: list[Fraction]
) -> tuple[list[Fraction], list[Fraction]]:
    """``min c'x s.t. A x >= b`` (``x`` free) from the feasible point ``x``: crash to a
    vertex, then primal simplex with Bland's rule; returns ``(x, y)``."""
    n = len(cost)
    tight = [r for r, (coefs, rhs, *_) in enumerate(rows) if _row_dot(coefs, x) == rhs]
    basis = _rank_rows(rows, tight, n)
    while len(basis) < n:  # crash: move along a null direction of the tight rows
        d = _null_direction(rows, basis, n)
        cd = sum((c * t for c, t in zip(cost, d, strict=True)), Fraction(0))
        if cd > 0:
            d = [-t for t in d]
        step = _ratio(rows, x, d, set(basis))
        if step is None and cd == 0:
            d = [-t for t in d]
            step = _ratio(rows, x, d, set(basis))
        if step is None:
            raise ValidationError("the LP is unbounded below (or has no vertex)")
        x = [a + step[0] * t for a, t in zip(x, d, strict=True)]
        basis.append(step[1])
    while True:
        a_b = [[rows[r][0].get(j, Fraction(0)) for j in range(n)] for r in basis]
        y_b = solve_rational([list(col) for col in zip(*a_b, strict=True)], cost)
        if y_b is None:
            raise ConsistencyError("a singular simplex basis")
        neg = [k for k in range(n) if y_b[k] < 0]
        if not neg:
            y = [Fraction(0)] * len(rows)
            for r, t in zip(basis, y_b, strict=True):
                y[r] = t
            return x, y
        k = min(neg, key=lambda k: basis[k])  # Bland: the lowest row leaves
        e = [Fraction(int(i == k)) for i in range(n)]
        move = solve_rational(a_b, e)
        assert move is not None
        step = _ratio(rows, x, move, set(basis))
        if step is None:
            raise ValidationError("the LP is unbounded below")
        x = [a + step[0] * t for a, t in zip(x, move, strict=True)]
        basis[k] = step[1]


def _feasible_start(rows: list[Any], cost: list[Fraction], x0: list[Fraction]) -> list[Fraction]:
    """``x0`` if it satisfies every row, else a feasible point from phase 1: ``min t s.t.
    A x + t >= b, t >= 0`` started at ``(x0, max violation)``."""
    viol = max((rhs - _row_dot(coefs, x0) for coefs, rhs, *_ in rows), default=Fraction(0))
    if viol <= 0:
        return x0
    n = len(cost)
    aux = [({**coefs, n: Fraction(1)}, rhs, -1, None) for coefs, rhs, *_ in rows]
    aux.append(({n: Fraction(1)}, Fraction(0), -1, None))
    xa, _ = _simplex(aux, [Fraction(0)] * n + [Fraction(1)], [*x0, viol])
    if xa[n] > 0:
        raise ValidationError(f"the LP is infeasible (phase 1 ends at t = {float(xa[n]):.3e})")
    return xa[:n]


def simplex_lp(
    model: dict[str, Any],
    spec: dict[str, Any],
    *,
    approx: Any = None,
    size_limit: int | None = None,
    what: str = "a general LP",
) -> ExactLP:
    """The exact optimum of any LP of the checker (ALP; LLP's reduced LP) by the exact
    simplex method started at ``approx`` (the solver's point; default 0)."""
    t0 = time.perf_counter()
    rows = ExactRows.build(model, spec)
    check_size(rows.n_vars, size_limit, what)
    n = rows.n_vars
    a = np.zeros(n) if approx is None else np.asarray(approx, dtype=np.float64)
    x0 = [Fraction(float(t)) if np.isfinite(t) else Fraction(0) for t in a]
    x, y = _simplex(rows.rows, rows.cost, _feasible_start(rows.rows, rows.cost, x0))
    xv, yv = RationalVector.from_fractions(x), RationalVector.from_fractions(y)
    return certify_optimum(
        spec["formulation"], rows, xv, yv, "exact simplex from the solver's point", t0
    )


def llp_lp(
    model: dict[str, Any],
    cost: list[Any],
    d: list[Any],
    *,
    rlp: ExactFixedPoint | None = None,
    approx: Any = None,
    callback: ProgressCallback | None = None,
    size_limit: int | None = None,
) -> ExactLP:
    """The exact optimum of LLP (eq. 18 with surplus lifting): ``cost`` is ``c-bar`` (one
    per partition), ``d`` the surplus costs of the allowed pairs (row-major)."""
    t0 = time.perf_counter()
    base = ExactRows.build(model, {"rows": "RLP"})
    m, k = base.n_vars, base.n_rows
    if rlp is None:
        start = None if approx is None else _start_of(base, np.asarray(approx)[:m])
        rlp = least_fixed_point(
            base, start, callback=callback, size_limit=size_limit, what="LLP's partitions"
        )
    cbar, dd = [rational(t) for t in cost], [rational(t) for t in d]
    g = list(cbar)  # g = c-bar + A'd over the per-pair rows
    for (coefs, *_), dk in zip(base.rows, dd, strict=True):
        for j, a in coefs.items():
            g[j] += a * dk
    if all(t >= 0 for t in g):
        v, mu = rlp.values, occupation_measure(base, rlp.policy, g, size_limit=size_limit)
        method = "RLP's fixed point (g >= 0) and its occupation measure"
    else:
        reduced = ExactRows(base.rows, m, model, {"formulation": "LLP-reduced"}, g, base.form())
        xs, ys = _simplex(reduced.rows, g, list(rlp.values))
        v, mu = RationalVector.from_fractions(xs), RationalVector.from_fractions(ys)
        method = "exact simplex from RLP's fixed point (g has negative entries)"
    vf, muf = v.fractions(), mu.fractions()
    z = [_row_dot(coefs, vf) - rhs for coefs, rhs, *_ in base.rows]
    x = RationalVector.from_fractions([*vf, *z])
    y = RationalVector.from_fractions(
        [max(t - u, Fraction(0)) for t, u in zip(muf, dd, strict=True)]
        + [max(u - t, Fraction(0)) for t, u in zip(muf, dd, strict=True)]
        + muf
    )
    spec = {"formulation": "LLP", "cost": [_text(c) for c in cost], "d": [_text(t) for t in d]}
    rows = ExactRows.build(model, spec)
    if rows.n_rows != 3 * k:
        raise ConsistencyError("LLP's rows are not three groups of the pairs")
    return certify_optimum("LLP", rows, x, y, method, t0, rlp, values=x.take(range(m)))


def game_optimum(
    model: dict[str, Any],
    cost: list[Any],
    *,
    approx: Any = None,
    callback: ProgressCallback | None = None,
    size_limit: int | None = None,
) -> ExactLP:
    """The disjunctive NLP's exact optimum ``w*`` (Fact 2: the same for every cost
    ``c >= 0``) by exact strategy iteration (:func:`lpbounds.exact.game_fixed_point`),
    verified as a fixed point of ``G``; ``objective = c'w*``; no duals (``y=None``)."""
    t0 = time.perf_counter()
    rows = ExactRows.build(model, {"rows": "NLP"})
    fp = game_fixed_point(rows, approx, callback=callback, size_limit=size_limit)
    objective = fp.values.dot([rational(t) for t in cost])
    return ExactLP(
        "NLP",
        objective,
        fp.values,
        None,
        fp.values,
        {"rows": "NLP"},
        model,
        "exact strategy iteration",
        time.perf_counter() - t0,
        False,
        fixed_point=fp,
    )
