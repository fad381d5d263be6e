r"""Monotone cuts and box resolution for the NLP (eq. 25): a cutting-plane method that scales.

Notation: the NLP's feasible set is ``F = {w : w(i) >= min_{k in d} f_k(w)}`` for every
disjunction ``d = (i, u)``, with terms ``f_k(w) = rho_k + a_k'w`` and ``a_k = lambda P_k
>= 0`` (``P_k``: the term's successor distribution, duplicates summed). ``F`` is closed
under componentwise ``min`` and has a least element ``w*`` (Fact 2 of :mod:`lpbounds.rows.system`).

**Monotone cut.** Let ``l <= w*``. For every ``w in F`` with ``w >= l`` and every ``d``,
with ``amin = min_{k in d} a_k`` elementwise (any ``0 <= amin <= a_k`` will do)::

    w(i) >= min_k f_k(w) = min_k [f_k(l) + a_k'(w - l)] >= min_k f_k(l) + amin'(w - l),

because ``w - l >= 0`` and ``a_k >= amin``. In particular the cut holds at ``w*``.

**Resolution on a box.** Let also ``h >= w*``. If the term ``k*`` smallest at ``l``
satisfies ``f_k(l) - f_k*(l) >= (a_k* - a_k)^+ '(h - l)`` for every other ``k in d``, then
for every ``w in [l, h]``::

    f_k(w) - f_k*(w) = f_k(l) - f_k*(l) - (a_k* - a_k)'(w - l)
                     >= f_k(l) - f_k*(l) - (a_k* - a_k)^+ '(h - l) >= 0,

so ``min_k f_k = f_k*`` on the box, and ``w*`` (in the box) satisfies the single row
``w(i) >= f_k*(w)``. Such a row stays valid at ``w*`` for ever (it is a statement about
``w*`` alone), so a resolved disjunction is replaced by its row in every later round.

**The master is a Bellman row system.** Its rows are: the single-term disjunctions, the
resolved rows, one monotone cut per other multi-term disjunction and ``w(i) >= l(i)``.
Each has nonnegative coefficients summing to at most ``lambda`` (a cut's ``amin`` sums
to ``lambda sum_j min_k P_k(j) <= lambda``), so with a *sink* variable ``s`` (row ``s >=
0 + lambda s``, least value 0) that takes the missing mass, every row is an ordinary
Bellman row ``w(i) >= r + lambda sum_j p_j w(j)`` with ``sum_j p_j = 1``. Its least
element ``l'`` (Fact 1) is found by modified policy iteration warm-started at ``l`` to a
residual of ``1e-13 max|R| / (1 - lambda)`` (:func:`lpbounds.dp.solve_exact`) or, as a
check, by the master LP ``min c'w`` over the same rows and ``l <= w <= hi`` (any LP
solver; the point is the least element for ``c > 0``). ``w*`` satisfies every master
row, so ``l <= l' <= w*``; the next ``l`` is the lower side of
:func:`lpbounds.certification.certificate.certify` (operator ``"max"``) of the master rows at the
computed point, so the rounding of the solve cannot push ``l`` above ``w*``. Floating
point: ``amin`` is shrunk by ``4 eps`` relative (so it stays ``<= a_k`` whatever the
rounding of duplicate sums) and the cut's right-hand side and the resolution test carry
a margin of a few ``eps`` times the magnitudes involved.

**The upper side** ``h``: the minimiser's strategy at ``l`` (per disjunction its
smallest term) is evaluated (modified policy iteration from the last round's value);
the NLP's certificate (operator ``"maxmin"``) at that value gives a certified ``h >= w*``;
``h`` is the elementwise minimum over the rounds.

**Why it is finite in practice.** Monotone cuts alone lift ``l`` like value iteration
(rate ``lambda``: the cut is a constant when the terms share no successor, as in
garnets). But once ``l`` and ``h`` are close the test resolves almost every
disjunction, and a master whose multi-term disjunctions are all resolved is the row
system of one strategy: its least element is ``w*`` exactly when that strategy is
optimal. Measured: the bracket closes in a few dozen rounds whatever ``M``
(docs/nlp.md).

Everything is vectorised over the disjunctions: sparse ``P`` (terms x M), per-disjunction
minima by ``reduceat`` on the sorted rows; no dense ``M x M`` object.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp

from ...certification.certificate import certify
from ...dp import solve_exact
from ...errors import SolverError, ValidationError
from ...rows import BellmanRows
from ...status import Status
from ...tolerances import NLP_EXACT_RTOL
from .cuts import LPData, NLPMaster, highs_solve
from .results import NLPIteration
from .stop import StopReason

if TYPE_CHECKING:
    from .problem import NLP

__all__ = ["MASTER_BACKENDS", "MonotoneMaster", "MonotoneOutput", "MonotoneRound", "monotone_cuts"]

_EPS = float(np.finfo(np.float64).eps)
_TINY = float(np.finfo(np.float64).tiny)
#: How the monotone master is solved: its row system by policy iteration, or its LP.
MASTER_BACKENDS: tuple[str, ...] = ("rows", "highspy", "cvxpy")


class MonotoneMaster(NLPMaster):
    r"""The monotone master LP ``min c'w`` over one round's rows (a cvxpy model).

    Groups: ``"single"`` (single-term disjunctions), ``"resolved"`` (the resolved
    disjunctions' rows), ``"cuts"`` (monotone cuts ``w(i) - amin'w >= rho``),
    ``"box_lower"`` (``w >= l``), ``"box_upper"`` (``w <= hi``, the NLP's box: it contains
    the least element). Its optimum is ``c'`` of the least element of the round's row
    system.
    """

    name = "NLP-monotone-master"

    def __init__(self, data: LPData, n_single: int, n_resolved: int) -> None:
        self.n_resolved = int(n_resolved)
        super().__init__(data, n_single)

    @property
    def n_cuts(self) -> int:
        """Monotone cuts in this master (group ``"cuts"``)."""
        return int(self.data.A.shape[0] - self.n_single - self.n_resolved)

    def _groups(self, n_rows: int, m: int) -> list[tuple[str, int]]:
        n_res = getattr(self, "n_resolved", 0)
        return [
            ("single", self.n_single),
            ("resolved", n_res),
            ("cuts", n_rows - self.n_single - n_res),
            ("box_lower", m),
            ("box_upper", m),
        ]


@dataclass
class MonotoneRound:
    """One round's master (kept when ``record`` is given: the tests check it at ``w*``)."""

    lower: np.ndarray  # l at the start of the round (certified <= w*)
    upper: np.ndarray  # h (certified >= w*)
    rows: BellmanRows  # the master's row system (variable M is the sink)
    lp: LPData  # the same master as an LP over w (M variables)
    n_single: int
    n_resolved: int
    point: np.ndarray  # the master's computed least element (M,)
    new_lower: np.ndarray  # the certified l of the next round


@dataclass
class MonotoneOutput:
    """What :func:`monotone_cuts` hands back to :meth:`NLP.solve`.

    ``stop_reason`` is one of :class:`StopReason`'s ``GAP_CLOSED``, ``MAX_ROUNDS``,
    ``TIME_LIMIT``, ``MASTER_STALLED``; ``master`` the last round's master as
    ``(LPData, n_single, n_resolved)``, which the NLP builds into a
    :class:`MonotoneMaster` on demand (:attr:`NLP.master`).
    """

    lower: float
    upper: float
    lower_values: np.ndarray
    upper_values: np.ndarray
    best_point: np.ndarray
    rounds: int
    cuts: int
    resolved: int
    stop_reason: StopReason
    log: list[NLPIteration]
    master: tuple[LPData, int, int] | None = None
    history: list[MonotoneRound] = field(default_factory=list)


class _Terms:
    """The NLP's terms as sparse data, built once (vectorised over the disjunctions)."""

    def __init__(self, nlp: NLP) -> None:
        rows = nlp.rows
        m, r = rows.n_vars, rows.n_rows
        lout = rows.targets.shape[1]
        probs = np.asarray(rows.probs, dtype=np.float64)
        self.m, self.lout, self.lam = m, lout, rows.discount
        # P (terms x M): duplicates summed by the csr conversion
        self.P = sp.csr_matrix(
            (probs.ravel(), (np.repeat(np.arange(r), lout), rows.targets.ravel())), shape=(r, m)
        )
        self.P.sum_duplicates()
        self.starts = nlp.disj_start
        self.d_of = nlp.disj_of_row
        self.owner = nlp.disj_owner
        self.multi = np.flatnonzero(nlp.disj_size >= 2)
        self.single_rows = nlp.single_rows
        self.single_rows_disj = np.flatnonzero(nlp.disj_size == 1)
        self.pmin = self._pmin(nlp)
        self.r_abs = float(np.abs(rows.reward).max(initial=0.0))
        # rows padded with a sink column (probability 0) for the master's row system
        self.targets = np.hstack([rows.targets, np.full((r, 1), m)]).astype(np.int64)
        self.probs = np.hstack([probs, np.zeros((r, 1))])
        self.reward = rows.reward

    def _pmin(self, nlp: NLP) -> sp.csr_matrix:
        """Per disjunction ``min_k P_k`` elementwise (0 off the common support), shrunk 4 eps."""
        coo = self.P.tocoo()
        d = self.d_of[coo.row]
        key = d.astype(np.int64) * self.m + coo.col
        order = np.argsort(key, kind="stable")
        key, val = key[order], coo.data[order]
        first = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
        count = np.diff(np.r_[first, key.size])
        vmin = np.minimum.reduceat(val, first) if first.size else val[:0]
        ukey = key[first]
        keep = count == nlp.disj_size[ukey // self.m]
        ukey, vmin = ukey[keep], vmin[keep] * (1.0 - 4 * _EPS)
        return sp.csr_matrix(
            (vmin, (ukey // self.m, ukey % self.m)), shape=(nlp.disj_size.size, self.m)
        )


def _smallest(q: np.ndarray, starts: np.ndarray, d_of: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per disjunction ``min_k q_k`` and the first row attaining it."""
    fmin = np.minimum.reduceat(q, starts[:-1])
    idx = np.flatnonzero(q <= fmin[d_of])
    _, first = np.unique(d_of[idx], return_index=True)
    return fmin, idx[first]


def _resolve(
    t: _Terms, q: np.ndarray, fmin: np.ndarray, kstar: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """Disjunctions (bool, D) whose smallest term at ``lo`` is smallest on all of ``[lo, hi]``."""
    ks = kstar[t.d_of]
    diff = (t.P[ks] - t.P).tocsr()
    diff.data = np.maximum(diff.data, 0.0)
    width = np.maximum(hi - lo, 0.0)
    push = t.lam * (diff @ width)
    mag = t.r_abs + float(np.abs(lo).max(initial=0.0)) + float(np.abs(hi).max(initial=0.0))
    margin = 8 * (2 * t.lout + 4) * _EPS * mag + 4 * _TINY
    slack = q - fmin[t.d_of] - push - margin
    slack[kstar] = np.inf
    ok = np.minimum.reduceat(slack, t.starts[:-1]) >= 0
    ok[t.single_rows_disj] = False
    return ok


def _master(
    t: _Terms, lo: np.ndarray, fmin: np.ndarray, res_rows: np.ndarray, cut_d: np.ndarray
) -> tuple[BellmanRows, np.ndarray, np.ndarray, np.ndarray, sp.csr_matrix]:
    """The master's row system (sink = variable M) and its cut data ``(owner, rho, pmin)``."""
    m, lout, lam = t.m, t.lout, t.lam
    pm = t.pmin[cut_d]
    mag = t.r_abs + float(np.abs(lo).max(initial=0.0))
    rho = fmin[cut_d] - lam * (pm @ lo)
    rho -= 8 * (2 * lout + 4) * _EPS * mag + 4 * _TINY
    nc = cut_d.size
    ct = np.full((nc, lout + 1), m, dtype=np.int64)
    cp_ = np.zeros((nc, lout + 1))
    pos = np.arange(pm.nnz) - np.repeat(pm.indptr[:-1], np.diff(pm.indptr))
    rr = np.repeat(np.arange(nc), np.diff(pm.indptr))
    ct[rr, pos] = pm.indices
    cp_[rr, pos] = pm.data
    cp_[:, lout] = np.maximum(1.0 - cp_[:, :lout].sum(axis=1), 0.0)
    orig = np.r_[t.single_rows, res_rows].astype(np.int64)
    lt = np.full((m + 1, lout + 1), m, dtype=np.int64)
    lp_ = np.zeros((m + 1, lout + 1))
    lp_[:, lout] = 1.0
    owner = np.r_[t.owner[t.d_of[orig]], t.owner[cut_d], np.arange(m + 1)]
    reward = np.r_[t.reward[orig], rho, lo, 0.0]
    targets = np.vstack([t.targets[orig], ct, lt])
    probs = np.vstack([t.probs[orig], cp_, lp_])
    action = np.zeros(owner.size, dtype=np.int64)
    rows = BellmanRows.from_arrays(owner, action, reward, targets, probs, lam, m + 1)
    return rows, orig, t.owner[cut_d], rho, pm


def _master_lp(
    nlp: NLP, orig: np.ndarray, cut_owner: np.ndarray, rho: np.ndarray, pm: sp.csr_matrix,
    lo: np.ndarray,
) -> LPData:  # fmt: skip
    """The same master as ``min c'w  s.t.  rows,  lo <= w <= box[1]``."""
    a, b = nlp.term_matrix
    m = nlp.rows.n_vars
    e = sp.csr_matrix(
        (np.ones(cut_owner.size), (np.arange(cut_owner.size), cut_owner)), (cut_owner.size, m)
    )
    cuts = e - nlp.rows.discount * pm
    big = sp.vstack([a[orig], cuts], format="csr")
    return LPData(
        c=np.asarray(nlp.cost, dtype=np.float64),
        A=big,
        row_lo=np.r_[b[orig], rho],
        row_hi=np.full(big.shape[0], np.inf),
        col_lo=lo.copy(),
        col_hi=np.maximum(np.full(m, nlp.box[1]), lo),
    )


def _solve_master(
    backend: str, rows: BellmanRows, lp: LPData | None, lo: np.ndarray, tol: float, solver: str,
    options: dict[str, Any], n: tuple[int, int],
) -> np.ndarray:  # fmt: skip
    """The master's least element over ``w`` (M,), by its row system or its LP."""
    m = lo.size
    if backend == "rows":
        dp = solve_exact(
            rows, method="mpi", tol=tol, initial=np.r_[lo, 0.0], max_iter=10_000,
            raise_on_failure=False,
        )  # fmt: skip
        return np.asarray(dp.values[:m])
    assert lp is not None
    if backend == "cvxpy":
        res = MonotoneMaster(lp, *n).solve(solver, raise_on_failure=False, **options)
        if not res.ok:
            raise SolverError(f"NLP monotone master with {solver}: status {res.status}")
        return np.asarray(res.x[:m], dtype=np.float64)
    sol = highs_solve(lp)
    if sol.status is not Status.OPTIMAL:
        raise SolverError(f"NLP monotone master (highspy): status {sol.model_status or sol.status}")
    return sol.x[:m]


def _strategy_value(
    nlp: NLP, sel: np.ndarray, initial: np.ndarray | None, tol: float
) -> np.ndarray:
    """The value of the minimiser's strategy ``sel`` (an MDP over ``u``), warm-started.

    Modified policy iteration from the previous round's value: the strategy changes little
    from round to round, so a few sweeps replace the sparse LU of exact policy iteration
    (measured at M = 2,000: 0.45 s a round for the LU). Any point will do: the upper side
    ``h`` is the certificate's, whatever the residual.
    """
    res = solve_exact(
        nlp.strategy_rows(sel), method="mpi", tol=tol, initial=initial, max_iter=10_000,
        raise_on_failure=False,
    )  # fmt: skip
    return np.asarray(res.values)


def monotone_cuts(
    nlp: NLP,
    *,
    gap_rtol: float,
    max_rounds: int = 200,
    time_limit: float | None = None,
    resolve: bool = True,
    backend: str = "rows",
    solver: str = "HIGHS",
    on_round: Callable[[NLPIteration], None] | None = None,
    record: list[MonotoneRound] | None = None,
    **options: Any,
) -> MonotoneOutput:
    """Run the monotone-cut loop on ``nlp`` (see the module docstring).

    Parameters
    ----------
    nlp : NLP
    gap_rtol : float
        Stop when ``c'h - c'l <= gap_rtol * sum(c) * scale``.
    max_rounds : int
    time_limit : float, optional
    resolve : bool
        Resolve disjunctions on the box ``[l, h]`` (default); ``False``: monotone cuts only.
    backend : {"rows", "highspy", "cvxpy"}
        Solve each master as a row system (modified policy iteration, default), or as an LP with
        highspy or through cvxpy with ``solver``; the point is certified the same way.
    on_round : callable(NLPIteration), optional
    record : list, optional
        Receives a :class:`MonotoneRound` per round (for tests: every row at ``w*``).
    **options
        Passed to the cvxpy solver (``backend="cvxpy"``).

    Returns
    -------
    MonotoneOutput
    """
    if backend not in MASTER_BACKENDS:
        raise ValidationError(f"backend must be one of {MASTER_BACKENDS}; got {backend!r}")
    t0 = time.perf_counter()
    t = _Terms(nlp)
    m, c = t.m, nlp.cost
    gap_unit = gap_rtol * float(c.sum()) * nlp.scale
    tol = NLP_EXACT_RTOL * nlp.scale
    lo = nlp.certify(np.full(m, nlp.box[0])).lower
    hi = np.full(m, np.inf)
    best, best_ub = np.full(m, nlp.box[1]), np.inf
    res_row = np.full(nlp.n_disjunctions, -1, dtype=np.int64)
    v_prev = None
    log: list[NLPIteration] = []
    stop, n_cut, last = StopReason.MAX_ROUNDS, 0, None
    for rnd in range(1, max_rounds + 1):
        q = nlp.rows.q_values(lo)
        fmin, kstar = _smallest(q, t.starts, t.d_of)
        v = _strategy_value(nlp, kstar, v_prev, tol)
        v_prev = v
        cert = nlp.certify(v)
        hi = np.minimum(hi, cert.upper)
        ub = float(c @ cert.upper)
        if ub < best_ub:
            best, best_ub = v, ub
        if resolve:
            new = _resolve(t, q, fmin, kstar, lo, hi) & (res_row < 0)
            res_row[new] = kstar[new]
        cut_d = t.multi[res_row[t.multi] < 0]
        res_rows = res_row[res_row >= 0]
        rows, orig, cut_owner, rho, pm = _master(t, lo, fmin, res_rows, cut_d)
        need_lp = backend != "rows" or record is not None
        lp = _master_lp(nlp, orig, cut_owner, rho, pm, lo) if need_lp else None
        n = (t.single_rows.size, res_rows.size)
        x = _solve_master(backend, rows, lp, lo, tol, solver, options, n)
        low = certify(rows, np.r_[x, 0.0], operator="max").lower[:m]
        new_lo = np.maximum(lo, low)
        if record is not None:
            assert lp is not None
            record.append(MonotoneRound(lo, hi.copy(), rows, lp, *n, x, new_lo))
        last = (orig, cut_owner, rho, pm, lo, n)
        gain = float(c @ new_lo) - float(c @ lo)
        lo = new_lo
        lower, upper = float(c @ lo), float(c @ hi)
        n_cut = cut_d.size
        e = NLPIteration(
            rnd, lower, upper, upper - lower, int(cut_d.size), time.perf_counter() - t0,
            max_violation=float(np.maximum(fmin - x[t.owner], 0.0).max(initial=0.0)),
            master_objective=float(c @ x),
        )  # fmt: skip
        log.append(e)
        if on_round is not None:
            on_round(e)
        if upper - lower <= gap_unit:
            stop = StopReason.GAP_CLOSED
            break
        if not gain > 0 and not (resolve and new.any()):
            stop = StopReason.MASTER_STALLED
            break
        if time_limit is not None and time.perf_counter() - t0 > time_limit:
            stop = StopReason.TIME_LIMIT
            break
    master = None
    if last is not None:
        orig, cut_owner, rho, pm, lo_m, n = last
        master = (_master_lp(nlp, orig, cut_owner, rho, pm, lo_m), *n)
    return MonotoneOutput(
        lower=float(c @ lo),
        upper=float(c @ hi),
        lower_values=lo,
        upper_values=hi,
        best_point=best,
        rounds=len(log),
        cuts=n_cut,
        resolved=int((res_row >= 0).sum()),
        stop_reason=stop,
        log=log,
        master=master,
        history=record if record is not None else [],
    )
