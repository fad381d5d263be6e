r"""UBLP and LBLP (paper Theorems 3 and 4) built from the partitions alone.

For partition ``i`` with key ``(l, w, d, A, taubar)`` and action ``u``, every state of
``S_i`` has the same reward ``r_u(i)`` and the same allowed actions, and the partition
of its successor under outcome ``Y_l`` is determined by the key, with one exception
(Lemma 3): a *type-1* partition (``l`` a station, ``d = 0``, ``A_l = 1``, another alert
somewhere) under ``u = 0``. The own alert is reset, so the next maximum delay is
``min(tau~ + 1, Gamma)`` where ``tau~`` is the largest delay among the *other* alerts,
which ranges over ``1..taubar`` inside ``S_i``. The set ``T(i, 0)`` of successor tuples
therefore has one tuple per next maximum delay in ``2..min(taubar + 1, Gamma)``:
``min(taubar, Gamma - 1)`` tuples, not the paper's ``taubar`` when ``taubar = Gamma``
(the cap merges two of them; :func:`lemma3_cardinality` reports where).

Everything else follows the dynamics (:mod:`lpbounds.patrol.model`) key-wise:

* ``u != 0``: ``l' = (l + w u) mod N``, ``w' = w u``, ``d' = 0``, ``A' = A``,
  ``taubar' = min(taubar + 1, Gamma)`` (0 if no alert);
* ``u = 0``: ``l' = l``, ``w' = 1``, ``d' = d + 1``, ``A'_l = 0``; with the own alert reset
  and no other alert ``taubar' = 0``; with no own alert (a loiter state, or
  ``allow_empty_loiter``) ``taubar' = min(taubar + 1, Gamma)``; type 1: the rule above;
* outcome ``Y_k`` adds an alert at station ``k`` (``A'_k = 1``, ``taubar' >= 1``) unless
  ``u = 0`` at that very station (absorbed).

No state is enumerated: the rows are built from the ``M`` keys, vectorised, so
``M`` of about ``10^5 - 10^6`` (8 stations, ``|S| ~ 10^10 - 10^11``) takes seconds.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import cvxpy as cp
import numpy as np

from ..errors import ValidationError
from ..formulations.rows_lp import RowsLP
from ..rows import BellmanRows
from ..tolerances import BOUND_ORDER_ATOL, LP_COMPARE_RTOL, TINY
from .params import PatrolParams
from .partitions import decode_partition, partition_components, partition_index

__all__ = [
    "LBLP",
    "UBLP",
    "BoundsAnalysis",
    "Lemma3Cardinality",
    "PartitionKeys",
    "analyse_bounds",
    "lemma3_cardinality",
    "partition_keys",
    "patrol_rows",
]

Kind = Literal["upper", "lower", "all"]


@dataclass(frozen=True)
class PartitionKeys:
    """The keys of all ``M`` partitions and the per-partition facts the rows need."""

    l: np.ndarray
    w: np.ndarray
    d: np.ndarray
    A: np.ndarray  # (M, m) bool
    taubar: np.ndarray
    own_alert: np.ndarray  # A_l = 1 at a station
    type1: np.ndarray  # Section 4.2's type-1 partitions
    allowed: np.ndarray  # (M, 3)
    rewards: np.ndarray  # (M, 3) r_u(i) (0 where not allowed)

    @property
    def n_partitions(self) -> int:
        return int(self.l.size)


def partition_keys(params: PatrolParams) -> PartitionKeys:
    """Decode every partition index into its key and derive type, allowed actions, rewards."""
    l, w, d, A, tb = decode_partition(params, np.arange(params.n_partitions))
    pos = params.station_pos[l]
    at = pos >= 0
    own = np.zeros(l.size, dtype=bool)
    own[at] = A[np.flatnonzero(at), pos[at]]
    n_alerts = A.sum(axis=1)
    type1 = at & (d == 0) & own & (n_alerts >= 2)
    allowed = np.ones((l.size, 3), dtype=bool)
    allowed[:, 2] = at & (d < params.D) & ((d >= 1) | own | params.allow_empty_loiter)
    pen = -params.rho * np.minimum(tb, params.Gamma)
    inc = np.append(params.information_increments(), 0.0)
    rewards = np.column_stack([pen, pen, pen + inc[np.minimum(d, params.D)]])
    rewards[~allowed] = 0.0
    return PartitionKeys(l, w, d, A, tb, own, type1, allowed, rewards)


def _next_keys(
    params: PatrolParams, keys: PartitionKeys, action: int, rows: np.ndarray, next_tb: np.ndarray
) -> np.ndarray:
    """Successor partition tuples (len(rows), m+1) of partitions ``rows`` under ``action``.

    ``next_tb`` is the next maximum delay under no new alert (given per row).
    """
    m, n_nodes = params.m, params.N
    l, w, d, A = keys.l[rows], keys.w[rows], keys.d[rows], keys.A[rows].copy()
    if action in (0, 1):
        u = 1 if action == 0 else -1
        w2 = w * u
        l2 = (l + w2) % n_nodes
        d2 = np.zeros_like(d)
        absorbed = np.full(rows.size, -1)
    else:
        pos = params.station_pos[l]
        l2, w2, d2 = l, np.ones_like(w), d + 1
        A[np.arange(rows.size), pos] = False
        absorbed = pos
    out = np.empty((rows.size, m + 1), dtype=np.int64)
    out[:, 0] = partition_index(params, l2, w2, d2, A, next_tb, check=False)
    for k in range(m):
        A_k = A.copy()
        add = absorbed != k
        A_k[add, k] = True
        tb_k = np.where(add, np.maximum(next_tb, 1), next_tb)
        out[:, k + 1] = partition_index(params, l2, w2, d2, A_k, tb_k, check=False)
    return out


def _rows_of_action(
    params: PatrolParams, keys: PartitionKeys, action: int, kind: Kind
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(owner, targets, next_taubar) of the rows of one action."""
    g = params.Gamma
    rows = np.flatnonzero(keys.allowed[:, action])
    tb = keys.taubar[rows]
    capped = np.where(tb > 0, np.minimum(tb + 1, g), 0)
    if action in (0, 1):
        return rows, _next_keys(params, keys, action, rows, capped), capped
    own, type1 = keys.own_alert[rows], keys.type1[rows]
    # own alert reset: with no other alert the next max delay is 0; type 1 ranges (Lemma 3)
    next_tb = np.where(own & ~type1, 0, capped)
    if kind == "upper":
        next_tb = np.where(type1, min(2, g), next_tb)
    elif kind == "all":
        hi = np.minimum(tb + 1, g)
        lo = min(2, g)
        count = np.where(type1, hi - lo + 1, 1)
        start = np.repeat(np.cumsum(count) - count, count)
        offset = np.arange(int(count.sum())) - start
        rows = np.repeat(rows, count)
        next_tb = np.where(np.repeat(type1, count), lo + offset, np.repeat(next_tb, count))
    elif kind != "lower":
        raise ValidationError(f"kind must be 'upper', 'lower' or 'all'; got {kind!r}")
    return rows, _next_keys(params, keys, action, rows, next_tb), next_tb


def patrol_rows(params: PatrolParams, kind: Kind = "upper") -> BellmanRows:
    r"""The partition-level Bellman rows of UBLP (``"upper"``) or LBLP (``"lower"``).

    One row per partition ``i`` and allowed action ``u``:
    ``w(i) >= r_u(i) + lambda sum_l p_l w(k_l)`` with the unique tuple ``k`` of
    ``T(i, u)``, or, for a type-1 partition under ``u = 0``, the tuple whose next maximum
    delay is ``min(2, Gamma)`` (``"upper"``, Theorem 4) or ``min(taubar + 1, Gamma)``
    (``"lower"``, Theorem 3). ``"all"`` keeps every tuple of ``T(i, u)``: these are
    exactly the distinct aggregated rows of RLP (eq. 9), and, grouped by action, the
    disjunctive terms of NLP (eq. 25), so ``solve_exact`` / ``solve_game`` on them give
    RLP's and NLP's optima without enumerating states.

    Parameters
    ----------
    params : PatrolParams
    kind : {"upper", "lower", "all"}

    Returns
    -------
    BellmanRows
        Over the ``M`` partitions (``n_vars = params.n_partitions``); no ``pair_row``.
    """
    if kind not in ("upper", "lower", "all"):
        raise ValidationError(f"kind must be 'upper', 'lower' or 'all'; got {kind!r}")
    keys = partition_keys(params)
    owners, targets, actions, rewards = [], [], [], []
    for action in range(3):
        rows, tg, _ = _rows_of_action(params, keys, action, kind)
        owners.append(rows)
        targets.append(tg)
        actions.append(np.full(rows.size, action, dtype=np.int32))
        rewards.append(keys.rewards[rows, action])
    return BellmanRows.from_arrays(
        np.concatenate(owners),
        np.concatenate(actions),
        np.concatenate(rewards),
        np.concatenate(targets),
        params.alert_probabilities(),
        params.discount,
        params.n_partitions,
    )


@dataclass(frozen=True)
class Lemma3Cardinality:
    """``|T(i, u)|`` from the construction beside Lemma 3's formula.

    Attributes
    ----------
    construction : ndarray (M, 3) of int
        Number of distinct successor tuples of each (partition, action); 0 where the
        action is not allowed.
    paper : ndarray (M, 3) of int
        Lemma 3: ``taubar(i)`` for type-1 partitions under ``u = 0``, else 1 (0 where not
        allowed).
    type1 : ndarray (M,) of bool
    taubar : ndarray (M,) of int
    """

    construction: np.ndarray
    paper: np.ndarray
    type1: np.ndarray
    taubar: np.ndarray

    @property
    def differs(self) -> np.ndarray:
        """Mask (M, 3) of the pairs where the construction and Lemma 3 disagree."""
        return self.construction != self.paper

    @property
    def n_differ(self) -> int:
        return int(self.differs.sum())

    def summary(self) -> dict[str, Any]:
        """Counts for reports: pairs compared, pairs that differ, and why."""
        diff = self.differs
        rows = np.flatnonzero(diff.any(axis=1))
        return {
            "pairs": int((self.paper > 0).sum()),
            "type1_partitions": int(self.type1.sum()),
            "pairs_differing": int(diff.sum()),
            "differing_taubar_values": sorted({int(t) for t in self.taubar[rows]}),
            "differing_all_type1_loiter": bool(diff[:, :2].sum() == 0 and self.type1[rows].all()),
        }


def lemma3_cardinality(params: PatrolParams) -> Lemma3Cardinality:
    """``|T(i, u)|`` per (partition, action) from the construction, and Lemma 3's formula.

    The construction counts the distinct successor tuples built by
    :func:`patrol_rows` with ``kind="all"``; it differs from the formula exactly where
    the cap at Gamma merges next maximum delays (type-1 partitions with
    ``taubar = Gamma`` under ``u = 0``: ``Gamma - 1`` tuples, not ``Gamma``).
    """
    keys = partition_keys(params)
    m_parts = keys.n_partitions
    construction = np.zeros((m_parts, 3), dtype=np.int64)
    for action in range(3):
        rows, tg, _ = _rows_of_action(params, keys, action, "all")
        # count distinct tuples per owner
        uniq = np.unique(np.column_stack([rows, tg]), axis=0)
        construction[:, action] = np.bincount(uniq[:, 0], minlength=m_parts)
    paper = np.where(keys.allowed, 1, 0)
    paper[:, 2] = np.where(keys.type1 & keys.allowed[:, 2], keys.taubar, paper[:, 2])
    return Lemma3Cardinality(construction, paper, keys.type1.copy(), keys.taubar.copy())


class _PatrolLP(RowsLP):
    kind: Kind = "upper"
    #: the paper writes UBLP and LBLP in ``w`` (eq. 26, 29)
    variable_name = "w"

    def __init__(self, params: PatrolParams | None = None, cost: Any = None) -> None:
        self.params = PatrolParams() if params is None else params
        super().__init__(patrol_rows(self.params, self.kind), cost, self.name)

    def partition_components(self) -> np.ndarray:
        """The key of each variable (partition): columns l, w, d, A_1..A_m, taubar."""
        from .partitions import partition_components

        return partition_components(self.params)

    @property
    def w(self) -> cp.Variable:
        """The cvxpy variable ``w`` (one entry per partition)."""
        return self.variables["w"]


class UBLP(_PatrolLP):
    r"""UBLP, eq. (29), Theorem 4: the RLP of the patrol problem collapsed to an exact LP.

    .. math:: \min \bar c^T w \quad\text{s.t.}\quad w(i) \ge r_u(i)
              + \lambda \sum_{l=0}^{m} p_l\, w(k_l), \quad \forall u,\ i = 1..M,

    "where the tuple ``k in T(i, u)`` if ``|T(i, u)| = 1``, else ``k = k*``, where
    ``k*`` is the tuple of partition indices such that ``taubar(k*_l) = 2``."

    Theorem 4 states that RLP (eq. 9) reduces to this LP, so that ``Phi v*`` is an
    upper bound on ``V*``: ``V*(x) <= v*(i)`` for every ``x`` in ``S_i``. The reduction
    relies on Claim 2 (monotonicity of ``V*``); see the project's report for where it
    holds. Built from the partitions alone (:func:`patrol_rows` with ``"upper"``); the
    optimum does not depend on the cost ``c >= 0`` (Fact 1 of :mod:`lpbounds.rows.system`) and
    :meth:`fixed_point` computes it without a solver.

    As a cvxpy model: :attr:`problem` is ``min c-bar'w  s.t.  bellman``, with the variable
    ``w`` (``variables["w"]``, the paper's symbol) and the group ``"bellman"`` (the rows of
    eq. 29, one sparse vector constraint; duals ``result.group_duals["bellman"]``).
    """

    name = "UBLP"
    kind: Kind = "upper"


class LBLP(_PatrolLP):
    r"""LBLP, eq. (26), Theorem 3: the disjunctive NLP of the patrol problem as an exact LP.

    .. math:: \min \bar c^T w \quad\text{s.t.}\quad w(i) \ge r_u(i)
              + \lambda \sum_{l=0}^{m} p_l\, w(k_l), \quad \forall u,\ i = 1..M,

    "where the tuple ``k in T(i, u)`` if ``|T(i, u)| = 1``, else ``k = k*``, where
    ``k*`` is the tuple of partition indices such that ``taubar(k*_l) = taubar(i) + 1``"
    (capped at Gamma here).

    Theorem 3 states that NLP (eq. 25) reduces to this LP and that its optimum is a
    lower bound: ``w*(i) <= min_{x in S_i} V*(x)``. The reduction relies on Claims 1-2
    (monotonicity), which the default model (no loitering at an empty station) can
    violate; see the project's report for what is measured. Built from the partitions
    alone (:func:`patrol_rows` with ``"lower"``); cost-independent optimum (Fact 1),
    :meth:`fixed_point` computes it without a solver.

    Action sets: the NLP keeps a disjunction ``(i, u)`` only when ``u`` is allowed at
    every state of ``S_i`` ("Action sets" in :mod:`lpbounds.rows.aggregation`). The patrol model
    forbids loitering at an empty station, but whether loitering is allowed depends only
    on ``(l, d, A_l)``, which the partition key fixes; so every state of ``S_i`` has the
    same actions, the rule drops nothing, and LBLP's rows (one per allowed (partition,
    action)) are those of the masked NLP. Checked state by state against the full MDP
    and against ``NLP`` on ``models/patrol-small.toml`` in the tests.

    As a cvxpy model: :attr:`problem` is ``min c-bar'w  s.t.  bellman``, with the variable
    ``w`` (``variables["w"]``, the paper's symbol) and the group ``"bellman"`` (the rows of
    eq. 26, one sparse vector constraint; duals ``result.group_duals["bellman"]``).
    """

    name = "LBLP"
    kind: Kind = "lower"


# ---------------------------------------------------------------------- the bounds' analysis
#: Number of partitions with the largest gaps that :func:`analyse_bounds` lists.
WORST_GAPS = 10


@dataclass
class BoundsAnalysis:
    """UBLP and LBLP of a patrol instance, their gap and Lemma 3, as report data.

    Attributes
    ----------
    formulations : dict
        ``"UBLP"`` and ``"LBLP"`` -> ``{"n_rows", "fixed_point": {...}, "lp": {...}}`` (``lp``
        only when the LPs were solved): the fixed point's iterations, residual, error bound
        and seconds; the LP's solver, status, objective, seconds, primal residual, largest
        distance to the fixed point, whether it agrees within ``tolerance``
        (``LP_COMPARE_RTOL * max(1, max|v_fp|)``).
    lemma3 : dict
        :meth:`Lemma3Cardinality.summary`.
    gap : dict
        ``v*(i) - w*(i)`` over the partitions: min, mean, median, max, ``negative_count``
        (partitions where it is below ``-BOUND_ORDER_ATOL``), its max relative to the
        range of the values, and the ``WORST_GAPS`` largest (``worst``: partition, key,
        upper, lower, gap).
    seconds : dict
        Time of each step.
    """

    formulations: dict[str, dict[str, Any]]
    lemma3: dict[str, Any]
    gap: dict[str, Any]
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def negative_count(self) -> int:
        """Partitions whose lower bound exceeds the upper bound (0 unless a defect)."""
        return int(self.gap["negative_count"])

    @property
    def lp_disagreements(self) -> list[str]:
        """The formulations whose LP optimum differs from the fixed point."""
        return [k for k, e in self.formulations.items() if "lp" in e and not e["lp"]["agrees"]]


def analyse_bounds(
    params: PatrolParams,
    *,
    solver: str = "HIGHS",
    solve_lp: bool = True,
    step: Callable[[str], None] | None = None,
    advance: Callable[[], None] | None = None,
) -> BoundsAnalysis:
    """UBLP and LBLP of ``params`` (fixed points, optionally LPs), their gap and Lemma 3.

    Each formulation is solved as a solver-free fixed point (its exact LP optimum) and,
    with ``solve_lp``, as an LP with ``solver``, cross-checked against the fixed point;
    then Lemma 3's cardinalities and the policy-free gap ``v*(i) - w*(i)`` per partition.

    Parameters
    ----------
    params : PatrolParams
        The instance.
    solver : str
        cvxpy solver of the LPs.
    solve_lp : bool
        Solve the LPs too (the fixed points are always computed).
    step : callable(str), optional
        Called with a description as each step starts (progress display).
    advance : callable(), optional
        Called as each counted step ends: ``4 + (2 if solve_lp else 0)`` calls in all.

    Returns
    -------
    BoundsAnalysis
    """
    from ..dp import solve_exact

    say = step or (lambda _s: None)
    done = advance or (lambda: None)
    times: dict[str, float] = {}
    entries: dict[str, dict[str, Any]] = {}
    values: dict[str, np.ndarray] = {}
    for cls in (UBLP, LBLP):
        say(f"{cls.name}: building rows")
        t0 = time.perf_counter()
        lp = cls(params)
        times[f"{cls.name.lower()}_build"] = time.perf_counter() - t0
        say(f"{cls.name}: fixed point")
        t0 = time.perf_counter()
        fp = solve_exact(lp.rows)
        times[f"{cls.name.lower()}_fixed_point"] = time.perf_counter() - t0
        values[cls.name] = fp.values
        entry: dict[str, Any] = {
            "n_rows": lp.rows.n_rows,
            "fixed_point": {
                "iterations": fp.iterations,
                "residual": fp.residual,
                "error_bound": fp.error_bound,
                "seconds": fp.seconds,
            },
        }
        done()
        if solve_lp:
            say(f"{cls.name}: LP ({solver})")
            t0 = time.perf_counter()
            res = lp.solve(solver)
            times[f"{cls.name.lower()}_lp"] = time.perf_counter() - t0
            diff = float(np.abs(res.values - fp.values).max())
            scale = max(1.0, float(np.abs(fp.values).max()))
            entry["lp"] = {
                "solver": res.solver,
                "status": res.status,
                "objective": res.objective,
                "seconds": times[f"{cls.name.lower()}_lp"],
                "primal_residual": res.primal_residual,
                "max_abs_diff_fixed_point": diff,
                "agrees": diff <= LP_COMPARE_RTOL * scale,
                "tolerance": LP_COMPARE_RTOL * scale,
            }
            done()
        entries[cls.name] = entry
        del lp
    say("Lemma 3 cardinalities")
    t0 = time.perf_counter()
    lemma3 = lemma3_cardinality(params).summary()
    times["lemma3"] = time.perf_counter() - t0
    done()
    gap = values["UBLP"] - values["LBLP"]
    comps = partition_components(params)
    order = np.argsort(-gap)[:WORST_GAPS]
    names = ["l", "w", "d", *[f"A{j + 1}" for j in range(params.m)], "taubar"]
    gaps = {
        "min": float(gap.min()),
        "mean": float(gap.mean()),
        "median": float(np.median(gap)),
        "max": float(gap.max()),
        "negative_count": int((gap < -BOUND_ORDER_ATOL).sum()),
        "relative_to_value_range": float(
            gap.max() / max(TINY, values["UBLP"].max() - values["LBLP"].min())
        ),
        "worst": [
            {
                "partition": int(i),
                "key": dict(zip(names, comps[i].tolist(), strict=True)),
                "upper": float(values["UBLP"][i]),
                "lower": float(values["LBLP"][i]),
                "gap": float(gap[i]),
            }
            for i in order
        ],
    }
    done()
    return BoundsAnalysis(entries, lemma3, gaps, times)
