r"""The one-command reproduction of the paper's patrol results (Sections 4-6).

:func:`reproduce` runs every step on one patrol instance and writes, into ``out``:

1. ``|S|`` and ``M`` (eq. 27, 28, and counted), the exact ``V*`` and ``pi*`` with their
   residual and error bound;
2. UBLP and LBLP (Theorems 4 and 3) solved with cvxpy and cross-checked with their
   fixed points; the general RLP and NLP of the full MDP and their distance to UBLP and
   LBLP; Lemma 3's ``|T(i, u)|`` against the paper's formula;
3. Claims 1-2 (monotonicity of ``V*``) on every ordered pair ``x1 = x2 + e_j``, and the
   partition-level Claim 2 on every pair of partitions one delay apart;
4. the sandwich ``w*(i) <= V*(x) <= v*(i)``, the greedy policy ``pi_s`` w.r.t.
   ``V_low = Phi w*``, ``V_sub`` by policy evaluation, and
   ``V_low <= V_sub <= V* <= V_up`` with margins;
5. the Monte Carlo of Section 6 (:mod:`lpbounds.patrol.simulation`) beside Table 1;
6. Figures 2-7 (:mod:`lpbounds.patrol.figures`);
7. ``report.md`` (:mod:`lpbounds.patrol.report`);
8. ``summary.json`` and ``values.npz``.

Tolerances
----------
Every comparison of two computed value vectors allows the sum of their certified
errors: an exact-DP result is within ``error_bound = residual / (1 - lambda)`` of the
true fixed point (:func:`lpbounds.solve_exact`), so ``a <= b`` is reported as violated
only when ``a - b > err(a) + err(b)``. LP solutions are compared with their fixed points
and the difference is reported; the sandwich uses the fixed points (certified), and
the LP values' distance to them is reported beside it. Nothing is clipped or hidden:
a violated inequality is counted and listed.
"""

from __future__ import annotations

import json
import os
import platform
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..dp import evaluate_policy, exact_rows, greedy_policy, solve_exact, solve_game
from ..errors import ValidationError
from ..formulations.base import resolve_solver
from ..instances import load_instance
from ..rows import BellmanRows
from . import figures as figs
from .bounds import LBLP, UBLP, lemma3_cardinality, patrol_rows
from .instance import params_from_instance
from .model import PatrolModel
from .params import PatrolParams
from .simulation import alert_sequence, pooled_statistics, simulate

__all__ = [
    "DEFAULT_MODEL",
    "DEFAULT_OUT",
    "DEFAULT_SEEDS",
    "PAPER_TABLE1",
    "Reproduction",
    "Tracker",
    "claim_pairs",
    "general_bound_residuals",
    "reproduce",
]

DEFAULT_MODEL = "models/patrol-paper.toml"
DEFAULT_OUT = "out/reproduce"
DEFAULT_SEEDS: tuple[int, ...] = (1, 2, 3, 4, 5)
#: Paper, Table 1.
PAPER_TABLE1 = {
    "pi_star": {"mean_loiters": 4.7, "mean_delay": 5.6, "worst_delay": 15},
    "pi_s": {"mean_loiters": 4.7, "mean_delay": 5.6, "worst_delay": 18},
}
#: Options per cvxpy solver for UBLP/LBLP. HiGHS's interior point method with crossover
#: (a vertex solution, as simplex gives), on one thread, is 5-7x faster than its default
#: (dual simplex, parallel) on these MDP LPs: UBLP of the paper's instance took 2.3 s
#: against 17 s (5.6 s for IPM on the default threads) on a shared, loaded 2-core machine.
SOLVER_OPTIONS: dict[str, dict[str, Any]] = {
    "HIGHS": {"highs_options": {"solver": "ipm", "threads": 1}}
}
#: Paper, Section 5: the example's counts.
PAPER_COUNTS = {"n_states": 2_048_000, "n_partitions": 8_900}


# ---------------------------------------------------------------------- progress
class Tracker:
    """Progress reporting for the steps (no-op by default; the CLI passes rich's).

    ``with tracker.step("name", total) as advance:`` times the step into
    :attr:`seconds` and gives a callable ``advance(n=1, status="")``.
    """

    def __init__(self, progress: Any = None) -> None:
        self.progress = progress
        self.seconds: dict[str, float] = {}
        self.peak_rss_mb: dict[str, float] = {}
        self.cpu_seconds: dict[str, float] = {}

    @contextmanager
    def step(self, name: str, description: str, total: float | None = None) -> Iterator[Any]:
        t0 = time.perf_counter()
        c0 = _cpu_seconds()
        task = None
        if self.progress is not None:
            task = self.progress.add_task(description, total=total, status="")

        def advance(n: float = 1, status: str = "", completed: float | None = None) -> None:
            if task is not None:
                if completed is not None:
                    self.progress.update(task, completed=completed, status=status)
                else:
                    self.progress.update(task, advance=n, status=status)

        try:
            yield advance
        finally:
            dt = time.perf_counter() - t0
            self.seconds[name] = self.seconds.get(name, 0.0) + dt
            self.peak_rss_mb[name] = _peak_rss_mb()
            self.cpu_seconds[name] = self.cpu_seconds.get(name, 0.0) + _cpu_seconds() - c0
            if task is not None:
                done = total if total is not None else 1
                self.progress.update(task, total=done, completed=done, status=f"{dt:.2f} s")


def _cpu_seconds() -> float:
    """CPU time (user + system) of the process, all threads: the work done, which a
    loaded machine does not inflate the way it inflates wall time."""
    t = os.times()
    return t.user + t.system


def _peak_rss_mb() -> float:
    """The process's peak resident memory so far, in MB (nan where unavailable)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - Windows
        return float("nan")
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kb / 1024.0 if platform.system() != "Darwin" else kb / 2**20


@dataclass
class Reproduction:
    """What :func:`reproduce` returns: the summary (as written to ``summary.json``), the
    output files, and the large arrays (as written to ``values.npz``)."""

    summary: dict[str, Any]
    out: Path
    files: dict[str, Path] = field(default_factory=dict)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)


# ---------------------------------------------------------------------- checks
def claim_pairs(
    model: PatrolModel, comps: np.ndarray
) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Every ordered pair ``x1 = x2 + e_j`` (one station's delay one larger), per station.

    Yields ``(j, x1, x2)`` for each station index ``j``; pairs exist where
    ``tau_j(x2) < Gamma`` and ``j`` is not the station of a loiter state (whose own delay
    is always 0). One station at a time keeps the memory at ``O(|S|)``.
    """
    p = model.params
    tau = comps[:, 3:]
    stations = np.asarray(p.stations)
    for j in range(p.m):  # m is small (stations); the states are vectorised
        own = (comps[:, 2] > 0) & (comps[:, 0] == stations[j])
        ok = np.flatnonzero((tau[:, j] < p.Gamma) & ~own)
        t2 = tau[ok].astype(np.int64)
        t2[:, j] += 1
        x1 = np.asarray(model.encode(comps[ok, 0], comps[ok, 1], comps[ok, 2], t2), np.int64)
        yield j, x1, ok.astype(np.int64)


def _partition_pairs(model: PatrolModel, pcomps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(i, j)`` of partitions with the same ``(l, w, d, A)`` and
    ``taubar(i) = taubar(j) + 1``, ``taubar(j) >= 1``: ``S_i >= S_j`` in the paper's order."""
    m = model.params.m
    tb = pcomps[:, -1]
    lo = np.flatnonzero((tb >= 1) & (tb < model.params.Gamma))
    hi = model.partition_index(
        pcomps[lo, 0], pcomps[lo, 1], pcomps[lo, 2], pcomps[lo, 3 : 3 + m], tb[lo] + 1
    )
    return np.asarray(hi, dtype=np.int64), lo.astype(np.int64)


def general_bound_residuals(
    mdp: Any, labels: np.ndarray, n_partitions: int, v_up: np.ndarray, w_low: np.ndarray
) -> dict[str, float]:
    """How far ``v_up`` and ``w_low`` are from being the general RLP's and NLP's exact
    optima, from one sweep over the full MDP's rows (no aggregation needed).

    ``T-bar v (i) = max_{x in S_i, u} q(x, u; Phi v)`` is the operator whose fixed point is
    the RLP optimum (eq. 9, Fact 1) and ``G-bar w (i) = max_u min_{x in S_i} q(x, u; Phi w)``
    the one of the NLP (eq. 25, Fact 2), with
    ``q(x, u; V) = R_u(x) + lambda sum_l p_l V(f(x, u, Y_l))``. Both are
    ``lambda``-contractions, so ``||v_up - v_RLP||_inf <= ||T-bar v_up - v_up|| / (1 - lambda)``
    and likewise for the NLP.
    """
    rows = exact_rows(mdp)
    n, n_act = mdp.allowed.shape
    lam = mdp.discount
    out: dict[str, float] = {}
    order = np.argsort(labels, kind="stable")
    sizes = np.bincount(labels, minlength=n_partitions)
    starts = np.r_[0, np.cumsum(sizes)[:-1]]
    for name, vec, game in (("rlp", v_up, False), ("nlp", w_low, True)):
        q = rows.q_values(vec[labels])
        qa = np.full((n, n_act), -np.inf)
        qa[rows.owner, rows.action] = q
        if not game:
            per_state = qa.max(axis=1)
            tv = np.maximum.reduceat(per_state[order], starts)
        else:
            qmin = np.where(mdp.allowed, qa, np.inf)
            mins = np.minimum.reduceat(qmin[order], starts, axis=0)
            mins[np.isinf(mins)] = -np.inf  # action not allowed in the partition
            tv = mins.max(axis=1)
        res = float(np.abs(tv - vec).max())
        out[f"{name}_residual"] = res
        out[f"{name}_distance_bound"] = res / (1.0 - lam)
    return out


def _reward_spread(mdp: Any, labels: np.ndarray, n_partitions: int) -> float:
    """``max_(i, u) (max_{x in S_i} R_u(x) - min_{x in S_i} R_u(x))`` over allowed pairs."""
    r = np.asarray(mdp.rewards, dtype=np.float64)
    allowed = np.asarray(mdp.allowed)
    hi = np.full((n_partitions, r.shape[1]), -np.inf)
    lo = np.full((n_partitions, r.shape[1]), np.inf)
    for a in range(r.shape[1]):  # 3 actions
        ok = allowed[:, a]
        np.maximum.at(hi[:, a], labels[ok], r[ok, a])
        np.minimum.at(lo[:, a], labels[ok], r[ok, a])
    has = np.isfinite(hi)
    return float((hi[has] - lo[has]).max(initial=0.0))


def _err_le(a: np.ndarray, b: np.ndarray, tol: float) -> dict[str, Any]:
    """Margin of ``a <= b``: ``min(b - a)``, violations beyond ``tol``, where."""
    diff = b - a
    bad = np.flatnonzero(diff < -tol)
    return {
        "margin": float(diff.min()),
        "tolerance": float(tol),
        "violations": int(bad.size),
        "worst_index": int(np.argmin(diff)),
    }


def _state_dict(comps: np.ndarray, x: int, stations: Sequence[int]) -> dict[str, Any]:
    c = comps[x]
    return {
        "state": int(x),
        "l": int(c[0]),
        "w": int(c[1]),
        "d": int(c[2]),
        "tau": {int(s): int(t) for s, t in zip(stations, c[3:], strict=True)},
    }


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None if np.isnan(obj) else ("inf" if obj > 0 else "-inf")
    return obj


def _machine() -> dict[str, Any]:
    import os

    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
    }


def _load(model: Any) -> tuple[str, PatrolParams]:
    if isinstance(model, PatrolParams):
        return "custom", model
    inst = load_instance(model)
    if inst.kind != "patrol":
        raise ValidationError(f"reproduce needs a patrol instance; {inst.name!r} is {inst.kind!r}")
    return inst.name, params_from_instance(inst)


# ---------------------------------------------------------------------- the pipeline
def reproduce(
    model: Any = DEFAULT_MODEL,
    out: str | Path = DEFAULT_OUT,
    *,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    n_steps: int = 60_000,
    solver: str = "HIGHS",
    general: str = "residual",
    figures: bool = True,
    progress: Any = None,
    n_examples: int = 10,
) -> Reproduction:
    """Reproduce the paper's patrol results on one instance; write them into ``out``.

    Parameters
    ----------
    model : path, name or PatrolParams
        A ``kind = "patrol"`` instance (default ``models/patrol-paper.toml``).
    out : path
        Output folder (created): ``summary.json``, ``values.npz``, ``report.md``, PNGs.
    seeds : sequence of int
        Seeds of the Monte Carlo alert sequences (one run of each policy per seed).
    n_steps : int
        Steps (time units) per Monte Carlo run (paper: 60,000).
    solver : str
        cvxpy solver of UBLP and LBLP (``HIGHS`` or ``CLARABEL``, any LP solver cvxpy has).
    general : {"residual", "aggregate"}
        How the general RLP and NLP of the full MDP are compared with UBLP and LBLP:
        measure how far UBLP's and LBLP's optima are from being the fixed points of the
        RLP's and NLP's operators, built from the full MDP (``residual``, default: one
        sweep over the MDP's rows; a certified bound ``residual / (1 - lambda)`` on the
        difference), or build the aggregated rows and solve them exactly (``aggregate``:
        measured differences; on the paper's instance about 1 GB more memory and
        several times slower). Both report the residual bound.
    figures : bool
        Write the PNG figures.
    progress : rich.progress.Progress, optional
        Progress bars for every step.
    n_examples : int
        Violating states listed per check.

    Returns
    -------
    Reproduction
    """
    if general not in ("aggregate", "residual"):
        raise ValidationError(f"general must be 'aggregate' or 'residual'; got {general!r}")
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ValidationError("give at least one Monte Carlo seed")
    if n_steps < 1:
        raise ValidationError(f"n_steps must be >= 1; got {n_steps}")
    solver = resolve_solver(solver)
    t_start = time.perf_counter()
    outdir = Path(out)
    outdir.mkdir(parents=True, exist_ok=True)
    tr = Tracker(progress)
    name, params = _load(model)
    summary: dict[str, Any] = {
        "instance": name,
        "params": params.to_table(),
        "machine": _machine(),
        "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
    }
    files: dict[str, Path] = {}

    # ------------------------------------------------------------- 1. model and V*
    with tr.step("build", "building the MDP and the partition") as adv:
        pm = PatrolModel(params)
        mdp = pm.mdp()
        part = pm.partition()
        labels = np.asarray(part.labels, dtype=np.int64)
        comps = pm.state_components()
        pcomps = pm.partition_components()
        adv(status=f"|S| = {mdp.n_states:,}  M = {part.n_partitions:,}")
    summary["n_states"] = int(mdp.n_states)
    summary["n_partitions"] = int(part.n_partitions)
    summary["counts"] = {
        "n_states_eq27": int(params.n_states),
        "n_partitions_eq28": int(params.n_partitions),
        "n_states_counted": int(mdp.n_states),
        "n_partitions_counted": int(part.n_partitions),
        "n_state_action_pairs": int(mdp.allowed.sum()),
        "paper": PAPER_COUNTS,
    }

    with tr.step("vstar", "exact V* (modified policy iteration)") as adv:
        res = solve_exact(
            mdp, "mpi", callback=lambda it, r: adv(status=f"iteration {it}  residual {r:.1e}")
        )
    vstar, pi_star = res.values, np.asarray(res.policy, dtype=np.int64)
    err_v = res.error_bound
    summary["vstar"] = {
        "method": res.method,
        "iterations": res.iterations,
        "sweeps": res.sweeps,
        "residual": res.residual,
        "error_bound": res.error_bound,
        "tol": res.tol,
        "seconds": res.seconds,
        "min": float(vstar.min()),
        "max": float(vstar.max()),
        "mean": float(vstar.mean()),
        "policy_counts": {
            mdp.action_names[a]: int(c)
            for a, c in enumerate(np.bincount(pi_star, minlength=mdp.n_actions))
        },
    }

    # ------------------------------------------------------------- 2. UBLP, LBLP
    bounds: dict[str, Any] = {}
    fp: dict[str, Any] = {}
    solver_options = dict(SOLVER_OPTIONS.get(solver, {}))
    lp_vals: dict[str, np.ndarray] = {}
    with tr.step("bounds", f"UBLP and LBLP ({solver}) and their fixed points", 4) as adv:
        for key, cls, kind in (("ublp", UBLP, "upper"), ("lblp", LBLP, "lower")):
            lp = cls(params)
            lp_res = lp.solve(solver=solver, **solver_options)
            adv(status=f"{cls.name}: {lp_res.status}")
            # policy iteration: exact LU evaluations (8 on the paper), few kernel launches
            f = solve_exact(patrol_rows(params, kind), "pi")
            fp[key] = f
            adv(status=f"{cls.name} fixed point")
            lp_vals[key] = np.asarray(lp_res.values, dtype=np.float64)
            diff = float(np.abs(lp_vals[key] - f.values).max())
            bounds[key] = {
                "solver": lp_res.solver,
                "solver_options": solver_options,
                "status": str(lp_res.status),
                "n_rows": int(lp.rows.n_rows),
                "objective": float(lp_res.objective),
                "primal_residual": float(lp_res.primal_residual),
                "residual_tol": float(lp_res.residual_tol),
                "dual_residual": _f(lp_res.dual_residual),
                "gap": _f(lp_res.gap),
                "solve_seconds": _f(lp_res.solve_seconds),
                "compile_seconds": _f(lp_res.compile_seconds),
                "fixed_point_seconds": f.seconds,
                "fixed_point_residual": f.residual,
                "fixed_point_error_bound": f.error_bound,
                "lp_minus_fixed_point_max_abs": diff,
                "lp_values_min": float(np.min(lp_res.values)),
                "lp_values_max": float(np.max(lp_res.values)),
            }
    v_up, w_low = fp["ublp"].values, fp["lblp"].values
    err_up, err_low = fp["ublp"].error_bound, fp["lblp"].error_bound
    summary["bounds"] = bounds

    # general RLP / NLP of the full MDP (Theorems 3, 4)
    with tr.step("general", "general RLP and NLP of the full MDP (Theorems 3, 4)", 3) as adv:
        gres = general_bound_residuals(mdp, labels, part.n_partitions, v_up, w_low)
        adv(status="residuals")
        thm: dict[str, Any] = {"method": general, **gres}
        # r_u(i): the reward is the same for every state of a partition (Section 4.2);
        # then the max- and min-reduced aggregated rows (RLP, NLP) are the same rows
        spread = _reward_spread(mdp, labels, part.n_partitions)
        thm["reward_spread_within_partitions"] = spread
        if general == "aggregate":
            rlp_rows = BellmanRows.aggregate(mdp, part, reduce="max")
            rlp = solve_exact(rlp_rows, "pi")
            adv(status="RLP")
            nlp_rows = rlp_rows if spread == 0.0 else BellmanRows.aggregate(mdp, part, reduce="min")
            thm["nlp_rows_shared_with_rlp"] = nlp_rows is rlp_rows
            nlp = solve_game(nlp_rows)
            adv(status="NLP")
            thm["rlp_rows"] = int(rlp_rows.n_rows)
            thm["nlp_rows"] = int(nlp_rows.n_rows)
            thm["rlp_error_bound"] = rlp.error_bound
            thm["nlp_error_bound"] = nlp.error_bound
            thm["theorem4_max_abs_diff"] = float(np.abs(rlp.values - v_up).max())
            thm["theorem3_max_abs_diff"] = float(np.abs(nlp.values - w_low).max())
            thm["tolerance_theorem4"] = rlp.error_bound + err_up
            thm["tolerance_theorem3"] = nlp.error_bound + err_low
            # |T(i, u)| counted from the full MDP: distinct aggregated rows per (i, u)
            counted = np.zeros((part.n_partitions, 3), dtype=np.int64)
            np.add.at(counted, (rlp_rows.owner.astype(np.int64), rlp_rows.action), 1)
        else:
            thm["theorem4_max_abs_diff"] = gres["rlp_distance_bound"]
            thm["theorem3_max_abs_diff"] = gres["nlp_distance_bound"]
            thm["tolerance_theorem4"] = err_up
            thm["tolerance_theorem3"] = err_low
            counted = None
            adv(2)
    summary["theorems"] = thm
    summary["theorem3_max_abs_diff"] = thm["theorem3_max_abs_diff"]
    summary["theorem4_max_abs_diff"] = thm["theorem4_max_abs_diff"]

    with tr.step("lemma3", "Lemma 3: |T(i, u)|") as adv:
        card = lemma3_cardinality(params)
        lem = card.summary()
        differs = card.differs
        rows_d, acts_d = np.nonzero(differs)
        lem["examples"] = [
            {
                "partition": int(i),
                "action": mdp.action_names[int(a)],
                "taubar": int(card.taubar[i]),
                "construction": int(card.construction[i, a]),
                "paper": int(card.paper[i, a]),
            }
            for i, a in zip(rows_d[:n_examples], acts_d[:n_examples], strict=True)
        ]
        if counted is not None:
            lem["full_mdp_rows_equal_construction"] = bool(
                np.array_equal(counted, card.construction)
            )
            lem["full_mdp_rows_differ_pairs"] = int((counted != card.construction).sum())
        summary["lemma3"] = lem
        adv(status=f"{lem['pairs_differing']} pairs differ")

    # ------------------------------------------------------------- 3. Claims 1-2
    with tr.step("claims", "Claims 1-2: monotonicity on all ordered pairs", 2) as adv:
        tol_claim = 2.0 * err_v
        st_arr = np.asarray(params.stations)
        acc = dict.fromkeys(
            ("pairs", "violations", "new_alert", "new_alert_own", "same", "same_pairs"), 0
        )
        max_excess, max_same = -np.inf, -np.inf
        cand: list[tuple[float, int, int, int]] = []
        for j, x1, x2 in claim_pairs(pm, comps):
            excess = vstar[x1] - vstar[x2]  # Claim 2 says <= 0
            bad = excess > tol_claim
            new_alert = comps[x2, 3 + j] == 0
            at_own = (comps[x2, 0] == st_arr[j]) & (comps[x2, 2] == 0)
            acc["pairs"] += x1.size
            acc["violations"] += int(bad.sum())
            acc["new_alert"] += int((bad & new_alert).sum())
            acc["new_alert_own"] += int((bad & new_alert & at_own).sum())
            acc["same"] += int((bad & ~new_alert).sum())
            acc["same_pairs"] += int((~new_alert).sum())
            if x1.size:
                max_excess = max(max_excess, float(excess.max()))
            if (~new_alert).any():
                max_same = max(max_same, float(excess[~new_alert].max()))
            top = np.flatnonzero(bad)
            top = top[np.argsort(-excess[top])[:n_examples]]
            for k in top:
                cand.append((float(excess[k]), int(x1[k]), int(x2[k]), j))
            del x1, x2, excess, bad, new_alert, at_own
        cand.sort(reverse=True)
        claims = {
            "pairs": acc["pairs"],
            "tolerance": tol_claim,
            "violations": acc["violations"],
            "max_excess": max_excess,
            "violations_new_alert": acc["new_alert"],
            "violations_new_alert_own_station": acc["new_alert_own"],
            "violations_same_alert_status": acc["same"],
            "pairs_same_alert_status": acc["same_pairs"],
            "max_excess_same_alert_status": max_same if np.isfinite(max_same) else None,
            "examples": [
                {
                    "x1": _state_dict(comps, a1, params.stations),
                    "x2": _state_dict(comps, a2, params.stations),
                    "station": int(params.stations[j]),
                    "vstar_x1": float(vstar[a1]),
                    "vstar_x2": float(vstar[a2]),
                    "excess": ex,
                }
                for ex, a1, a2, j in cand[:n_examples]
            ],
        }
        adv(status=f"{claims['violations']} of {claims['pairs']:,} pairs violate")
        vmin_part = part.aggregate(vstar, "min")
        hi, lo = _partition_pairs(pm, pcomps)
        pexcess = vmin_part[hi] - vmin_part[lo]
        pbad = pexcess > tol_claim
        pw = np.flatnonzero(pbad)
        pw = pw[np.argsort(-pexcess[pw])][:n_examples]
        claims["partition_pairs"] = int(hi.size)
        claims["partition_violations"] = int(pbad.sum())
        claims["partition_max_excess"] = float(pexcess.max()) if hi.size else None
        claims["partition_examples"] = [
            {
                "higher": pcomps[hi[k]].tolist(),
                "lower": pcomps[lo[k]].tolist(),
                "excess": float(pexcess[k]),
            }
            for k in pw
        ]
        # the chain of Figure 4
        idx4, _, _ = figs.select_min_value_partitions(comps, params.stations)
        chain = np.unique(labels[idx4])
        ch_tb = pcomps[chain, -1]
        chain = chain[np.argsort(ch_tb)]
        steps = np.diff(vmin_part[chain])
        claims["figure4_chain"] = {
            "taubar": pcomps[chain, -1].tolist(),
            "min_vstar": vmin_part[chain].tolist(),
            "non_increasing": bool((steps <= tol_claim).all()),
        }
        adv(status=f"partitions: {claims['partition_violations']} violate")
    summary["claims"] = claims
    summary["claim2_violations"] = claims["violations"]

    # ------------------------------------------------------------- 4. sandwich, pi_s
    with tr.step("sandwich", "sandwich, greedy policy pi_s and V_sub", 3) as adv:
        v_low_s = w_low[labels]
        v_up_s = v_up[labels]
        lower = _err_le(v_low_s, vstar, err_low + err_v)
        upper = _err_le(vstar, v_up_s, err_up + err_v)
        lower["worst_state"] = _state_dict(comps, lower.pop("worst_index"), params.stations)
        upper["worst_state"] = _state_dict(comps, upper.pop("worst_index"), params.stations)
        gap = v_up - w_low
        sandwich = {
            "lower_margin": lower["margin"],
            "upper_margin": upper["margin"],
            "lower": lower,
            "upper": upper,
            "partition_gap_max": float(gap.max()),
            "partition_gap_mean": float(gap.mean()),
            "mean_vstar_minus_vlow": float((vstar - v_low_s).mean()),
            "mean_vup_minus_vstar": float((v_up_s - vstar).mean()),
            # the same margins with the LP solutions in place of the fixed points
            "lp_lower_margin": float((vmin_part - lp_vals["lblp"]).min()),
            "lp_upper_margin": float((lp_vals["ublp"] - part.aggregate(vstar, "max")).min()),
        }
        adv(status="sandwich")
        pi_s = np.asarray(greedy_policy(mdp, v_low_s), dtype=np.int64)
        adv(status="greedy policy")
        ev = evaluate_policy(mdp, pi_s, method="iterative")
        vsub = ev.values
        adv(status="V_sub")
        tol_sub = ev.error_bound + err_low
        chain_checks = {
            "vlow_le_vsub": _err_le(v_low_s, vsub, tol_sub),
            "vsub_le_vstar": _err_le(vsub, vstar, ev.error_bound + err_v),
            "vstar_le_vup": _err_le(vstar, v_up_s, err_up + err_v),
        }
        for c in chain_checks.values():
            c["worst_state"] = _state_dict(comps, c.pop("worst_index"), params.stations)
        q = exact_rows(mdp).q_values(vstar)
        rows_ex = exact_rows(mdp)
        assert rows_ex.pair_row is not None
        q_pis = q[rows_ex.pair_row[np.arange(mdp.n_states), pi_s]]
        loss = vstar - q_pis
        differs = pi_s != pi_star
        policy = {
            "differs_fraction": float(differs.mean()),
            "differs_states": int(differs.sum()),
            "suboptimal_fraction": float((loss > 2 * err_v).mean()),
            "suboptimal_tolerance": 2 * err_v,
            "max_one_step_loss": float(loss.max()),
            "max_vstar_minus_vsub": float((vstar - vsub).max()),
            "max_vstar_minus_vsub_state": _state_dict(
                comps, int(np.argmax(vstar - vsub)), params.stations
            ),
            "mean_vstar_minus_vsub": float((vstar - vsub).mean()),
            "vsub_residual": ev.residual,
            "vsub_error_bound": ev.error_bound,
            "vsub_sweeps": ev.sweeps,
            "vsub_method": ev.method,
            "chain": chain_checks,
            "pi_s_counts": {
                mdp.action_names[a]: int(c)
                for a, c in enumerate(np.bincount(pi_s, minlength=mdp.n_actions))
            },
        }
    summary["sandwich"] = sandwich
    summary["policy"] = policy

    # ------------------------------------------------------------- 5. Monte Carlo
    sims: dict[str, list[Any]] = {"pi_star": [], "pi_s": []}
    with tr.step(
        "monte_carlo", f"Monte Carlo: {len(seeds)} seeds x {n_steps:,} steps", 2 * len(seeds)
    ) as adv:
        p0 = float(params.alert_probabilities()[0])
        for s in seeds:
            y = alert_sequence(n_steps, p0, params.m, s)
            for key, pol in (("pi_star", pi_star), ("pi_s", pi_s)):
                r = simulate(pm, pol, y, policy_name=key, seed=s, components=comps)
                if r.mismatches:
                    raise AssertionError(
                        f"simulation of {key} (seed {s}): the model's successor disagrees "
                        f"with the spec's dynamics on {r.mismatches} steps "
                        f"(first at step {r.first_mismatch})"
                    )
                sims[key].append(r)
                adv(status=f"seed {s}, {key}")
    mc = {k: pooled_statistics(v) for k, v in sims.items()}
    mc["seeds"] = seeds
    mc["n_steps_per_seed"] = n_steps
    mc["conventions"] = _conventions(mc)
    summary["monte_carlo"] = mc
    summary["paper_table1"] = PAPER_TABLE1

    # ------------------------------------------------------------- 6. figures
    if figures:
        with tr.step("figures", "figures 2-7", 6) as adv:
            files["fig2"] = figs.plot_information(params, outdir / "fig2_information.png")
            adv()
            files["fig3"] = figs.plot_ordered_states(
                comps, params.stations, vstar, outdir / "fig3_ordered_states.png"
            )
            adv()
            files["fig4"] = figs.plot_min_value_partitions(
                comps, params.stations, vstar, outdir / "fig4_min_value_partitions.png"
            )
            adv()
            files["fig5"] = figs.plot_bounds(
                pcomps, labels, vstar, v_up, w_low, params.N, outdir / "fig5_bounds.png"
            )
            adv()
            files["fig6"] = figs.plot_vsub(
                pcomps, labels, vstar, vsub, params.N, outdir / "fig6_vsub.png"
            )
            adv()
            files["fig7"] = figs.plot_histograms(
                {k: np.concatenate([r.delay for r in v]) for k, v in sims.items()},
                {k: np.concatenate([r.loiters[r.complete] for r in v]) for k, v in sims.items()},
                outdir / "fig7_histograms.png",
            )
            adv()

    # ------------------------------------------------------------- 8. arrays
    arrays = {
        "vstar": vstar,
        "pi_star": pi_star.astype(np.int8),
        "state_components": comps.astype(np.int16),
        "lower": w_low,
        "upper": v_up,
        "partition_components": pcomps.astype(np.int16),
        "partition_of_state": labels.astype(np.int32),
        "vsub": vsub,
        "pi_s": pi_s.astype(np.int8),
    }
    with tr.step("write", "writing values.npz, summary.json, report.md") as adv:
        files["values"] = outdir / "values.npz"
        np.savez(files["values"], **arrays)
        summary["seconds"] = dict(tr.seconds)
        summary["peak_rss_mb"] = dict(tr.peak_rss_mb)
        summary["cpu_seconds"] = dict(tr.cpu_seconds)
        summary["seconds_total"] = time.perf_counter() - t_start
        files["summary"] = outdir / "summary.json"
        from .report import write_report

        files["report"] = write_report(summary, files, outdir / "report.md")
    summary["seconds"] = dict(tr.seconds)
    summary["peak_rss_mb"] = dict(tr.peak_rss_mb)
    summary["cpu_seconds"] = dict(tr.cpu_seconds)
    summary["seconds_total"] = time.perf_counter() - t_start
    files["summary"].write_text(json.dumps(_jsonable(summary), indent=2) + "\n")
    return Reproduction(summary=summary, out=outdir, files=files, arrays=arrays)


def _f(x: Any) -> float | None:
    return None if x is None else float(x)


def _conventions(mc: dict[str, Any]) -> dict[str, Any]:
    """Which delay convention comes closest to Table 1 (mean and worst delay)."""
    conv = {
        "true delay to first loiter (uncapped)": ("mean_delay", "worst_delay"),
        "capped delay min(tau, Gamma)": ("mean_delay_capped", "worst_delay_capped"),
        "delay to first visit of the station": ("mean_delay_visit", "worst_delay_visit"),
        "delay to end of first loiter": ("mean_delay_plus_one", "worst_delay_plus_one"),
    }
    rows = []
    for name, (mk, wk) in conv.items():
        err = 0.0
        vals = {}
        for pol in ("pi_star", "pi_s"):
            mean, worst = mc[pol][mk], mc[pol][wk]
            vals[pol] = {"mean_delay": mean, "worst_delay": worst}
            paper = PAPER_TABLE1[pol]
            err += abs(mean - paper["mean_delay"]) / paper["mean_delay"]
            err += abs(worst - paper["worst_delay"]) / paper["worst_delay"]
        rows.append({"convention": name, "values": vals, "relative_error_sum": err})
    best = min(rows, key=lambda r: r["relative_error_sum"])
    return {"table": rows, "closest": best["convention"]}
