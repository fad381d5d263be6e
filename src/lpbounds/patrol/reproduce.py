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
8. ``summary.json``, ``values.npz`` and ``manifest.json``.

Each step is a function returning a typed dataclass (:mod:`lpbounds.patrol.summary`);
:func:`reproduce` runs them in order inside an
:class:`~lpbounds.outputs.AtomicDirectory`, so ``out`` is either the previous complete
output or the new complete one, never a mixture.

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
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._defaults import DEFAULT_MODEL, DEFAULT_OUT, DEFAULT_SEEDS
from ..dp import evaluate_policy, exact_rows, greedy_policy, solve_exact, solve_game
from ..errors import ConsistencyError, ValidationError
from ..formulations.base import resolve_solver
from ..model.instances import load_instance
from ..outputs import MANIFEST, AtomicDirectory, run_metadata
from ..rows import BellmanRows
from . import figures as figs
from .bounds import LBLP, UBLP, Kind, Lemma3Cardinality, lemma3_cardinality, patrol_rows
from .instance import params_from_instance
from .model import PatrolModel
from .params import PatrolParams
from .report import write_report
from .simulation import alert_sequence, pooled_statistics, simulate
from .summary import (
    ClaimsSummary,
    Counts,
    Inequality,
    Lemma3Summary,
    LPSummary,
    MonteCarloSummary,
    PolicyStatistics,
    PolicySummary,
    SandwichSummary,
    Summary,
    TheoremsSummary,
    VStarSummary,
    jsonable,
    to_dict,
)

__all__ = [
    "DEFAULT_MODEL",
    "DEFAULT_OUT",
    "DEFAULT_SEEDS",
    "PAPER_TABLE1",
    "STEP_HOOKS",
    "Reproduction",
    "Tracker",
    "build_model",
    "check_claims",
    "check_general",
    "check_lemma3",
    "check_sandwich",
    "checkpoint",
    "claim_pairs",
    "draw_figures",
    "general_bound_residuals",
    "inequality",
    "lemma3_summary",
    "policy_chain",
    "reproduce",
    "run_monte_carlo",
    "solve_bounds",
    "solve_vstar",
    "write_outputs",
]

#: Paper, Table 1.
PAPER_TABLE1 = {
    "pi_star": {"mean_loiters": 4.7, "mean_delay": 5.6, "worst_delay": 15},
    "pi_s": {"mean_loiters": 4.7, "mean_delay": 5.6, "worst_delay": 18},
}
#: Options per cvxpy solver for UBLP/LBLP: HiGHS's interior point method with crossover
#: (a vertex solution, as simplex gives). No ``threads`` option: HiGHS (1.16) refuses a
#: thread count that differs from the one its scheduler started with in the process, so
#: ``threads: 1`` made every reproduction after any other HiGHS solve fail; and it bought
#: nothing. Measured side by side in one run (highspy 1.16, one fresh process per
#: configuration, 2 cores shared at load ~4.5), LP solve wall / CPU seconds on
#: patrol-paper: UBLP ipm + threads 1: 3.36 / 2.97, ipm on the default threads:
#: 3.01 / 3.13, HiGHS's default (simplex): 7.47 / 5.08; LBLP 2.54 / 2.52, 2.55 / 2.51,
#: 4.67 / 3.95. patrol-small: about 0.01 s in every configuration. IPM is what is fast.
SOLVER_OPTIONS: dict[str, dict[str, Any]] = {"HIGHS": {"highs_options": {"solver": "ipm"}}}
#: The names :func:`reproduce` writes: an existing ``out`` holding anything else is
#: refused rather than replaced.
OUTPUT_FILES: tuple[str, ...] = (
    "summary.json",
    "values.npz",
    "report.md",
    "manifest.json",
    "fig*.png",
    "beyond.json",
)
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
        checkpoint(name)
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


#: Callables run, in order, with each step's name (``build``, ``vstar``, ... ``write``,
#: ``commit``) as the step starts; empty by default, so a run calls nothing. A caller that
#: needs to act at a chosen point of a run appends a hook (tests/cli/test_interrupt.py sends
#: the process SIGINT from one, as Ctrl-C would at that step) and removes it afterwards;
#: an exception a hook raises ends the run as one raised by the step itself would.
STEP_HOOKS: list[Callable[[str], None]] = []


def checkpoint(name: str) -> None:
    """Run every hook of :data:`STEP_HOOKS` with ``name``: step ``name`` starts now.

    Parameters
    ----------
    name : str
        The step (a key of the run's timings, or ``"commit"``).
    """
    for hook in tuple(STEP_HOOKS):
        hook(name)


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
    """What :func:`reproduce` returns: the summary as a dictionary (as written to
    ``summary.json``) and as typed objects (``result``), the output files, and the large
    arrays (as written to ``values.npz``)."""

    summary: dict[str, Any]
    out: Path
    result: Summary
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
    ``kappa``-contractions (``kappa = lambda max_r s_r``), so
    ``||v_up - v_RLP||_inf <= ||T-bar v_up - v_up|| / (1 - kappa)``
    and likewise for the NLP.
    """
    rows = exact_rows(mdp)
    n, n_act = mdp.allowed.shape
    kappa = rows.row_sums().modulus(mdp.discount)  # lambda, up to the rows' sums
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
        out[f"{name}_distance_bound"] = res / (1.0 - kappa)
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


def inequality(
    a: np.ndarray, b: np.ndarray, tol: float, comps: np.ndarray, stations: Sequence[int]
) -> Inequality:
    """The check ``a <= b`` over the states: its margin ``min(b - a)``, the number of
    states where ``a - b > tol`` (violations) and the state of the smallest margin.

    Parameters
    ----------
    a, b : ndarray (n_states,)
        The two sides (``V_low`` and ``V*``, ...).
    tol : float
        The sum of the two sides' certified errors: only a difference beyond it counts.
    comps : ndarray (n_states, 3 + m)
        The states' components (names the worst state).
    stations : sequence of int

    Returns
    -------
    Inequality
    """
    diff = b - a
    bad = np.flatnonzero(diff < -tol)
    return Inequality(
        margin=float(diff.min()),
        tolerance=float(tol),
        violations=int(bad.size),
        worst_state=_state_dict(comps, int(np.argmin(diff)), stations),
    )


def _state_dict(comps: np.ndarray, x: int, stations: Sequence[int]) -> dict[str, Any]:
    c = comps[x]
    return {
        "state": int(x),
        "l": int(c[0]),
        "w": int(c[1]),
        "d": int(c[2]),
        "tau": {int(s): int(t) for s, t in zip(stations, c[3:], strict=True)},
    }


def _load(model: Any) -> tuple[str, PatrolParams]:
    if isinstance(model, PatrolParams):
        return "custom", model
    inst = load_instance(model)
    if inst.kind != "patrol":
        raise ValidationError(f"reproduce needs a patrol instance; {inst.name!r} is {inst.kind!r}")
    return inst.name, params_from_instance(inst)


# ---------------------------------------------------------------------- step results
@dataclass
class BuiltModel:
    """Step 1's model: the MDP, the partition and the components of states/partitions."""

    pm: PatrolModel
    mdp: Any
    part: Any
    labels: np.ndarray
    comps: np.ndarray
    pcomps: np.ndarray


@dataclass
class VStar:
    """Step 1's exact solution."""

    summary: VStarSummary
    values: np.ndarray
    policy: np.ndarray
    error_bound: float


@dataclass
class Bounds:
    """Step 2's UBLP and LBLP: the LP solves' summaries and the certified fixed points."""

    summaries: dict[str, LPSummary]
    v_up: np.ndarray
    w_low: np.ndarray
    err_up: float
    err_low: float
    lp_values: dict[str, np.ndarray]
    #: the LP results' certified brackets on their exact optima (None: no certificate)
    lp_lower: dict[str, np.ndarray | None]
    lp_upper: dict[str, np.ndarray | None]


@dataclass
class General:
    """Step 2's Theorems 3-4 and, with ``general="aggregate"``, ``|T(i, u)|`` counted."""

    summary: TheoremsSummary
    counted: np.ndarray | None


@dataclass
class SandwichAndPolicy:
    """Step 4's sandwich, the greedy policy ``pi_s`` and its value ``V_sub``."""

    sandwich: SandwichSummary
    policy: PolicySummary
    pi_s: np.ndarray
    vsub: np.ndarray


@dataclass
class MonteCarlo:
    """Step 5's simulations and their pooled statistics."""

    summary: MonteCarloSummary
    runs: dict[str, list[Any]]


# ---------------------------------------------------------------------- the steps
def build_model(params: PatrolParams, tr: Tracker) -> tuple[BuiltModel, Counts]:
    """Step 1a: the MDP, the partition, and ``|S|``, ``M`` against eq. (27)-(28)."""
    with tr.step("build", "building the MDP and the partition") as adv:
        pm = PatrolModel(params)
        mdp = pm.mdp()
        part = pm.partition()
        built = BuiltModel(
            pm=pm,
            mdp=mdp,
            part=part,
            labels=np.asarray(part.labels, dtype=np.int64),
            comps=pm.state_components(),
            pcomps=pm.partition_components(),
        )
        adv(status=f"|S| = {mdp.n_states:,}  M = {part.n_partitions:,}")
    counts = Counts(
        n_states_eq27=int(params.n_states),
        n_partitions_eq28=int(params.n_partitions),
        n_states_counted=int(mdp.n_states),
        n_partitions_counted=int(part.n_partitions),
        n_state_action_pairs=int(mdp.allowed.sum()),
        paper=dict(PAPER_COUNTS),
    )
    return built, counts


def solve_vstar(built: BuiltModel, tr: Tracker) -> VStar:
    """Step 1b: the exact ``V*`` and ``pi*`` by modified policy iteration."""
    mdp = built.mdp
    with tr.step("vstar", "exact V* (modified policy iteration)") as adv:
        res = solve_exact(
            mdp, "mpi", callback=lambda it, r: adv(status=f"iteration {it}  residual {r:.1e}")
        )
    vstar, pi_star = res.values, np.asarray(res.policy, dtype=np.int64)
    summary = VStarSummary(
        method=res.method,
        iterations=res.iterations,
        sweeps=res.sweeps,
        residual=res.residual,
        error_bound=res.error_bound,
        tol=res.tol,
        seconds=res.seconds,
        min=float(vstar.min()),
        max=float(vstar.max()),
        mean=float(vstar.mean()),
        policy_counts=_action_counts(mdp, pi_star),
    )
    return VStar(summary=summary, values=vstar, policy=pi_star, error_bound=res.error_bound)


def solve_bounds(params: PatrolParams, solver: str, tr: Tracker) -> Bounds:
    """Step 2a: UBLP and LBLP with the LP solver, and their fixed points (certified)."""
    summaries: dict[str, LPSummary] = {}
    fp: dict[str, Any] = {}
    lp_vals: dict[str, np.ndarray] = {}
    lp_lower: dict[str, np.ndarray | None] = {}
    lp_upper: dict[str, np.ndarray | None] = {}
    solver_options = dict(SOLVER_OPTIONS.get(solver, {}))
    with tr.step("bounds", f"UBLP and LBLP ({solver}) and their fixed points", 4) as adv:
        pairs: tuple[tuple[str, type[UBLP] | type[LBLP], Kind], ...] = (
            ("ublp", UBLP, "upper"),
            ("lblp", LBLP, "lower"),
        )
        for key, cls, kind in pairs:
            lp = cls(params)
            lp_res = lp.solve(solver=solver, **solver_options)
            adv(status=f"{cls.name}: {lp_res.status}")
            # policy iteration: exact LU evaluations (8 on the paper), few kernel launches
            f = solve_exact(patrol_rows(params, kind), "pi")
            fp[key] = f
            adv(status=f"{cls.name} fixed point")
            lp_vals[key] = np.asarray(lp_res.values, dtype=np.float64)
            lp_lower[key] = _array_or_none(lp_res.lower_values)
            lp_upper[key] = _array_or_none(lp_res.upper_values)
            summaries[key] = LPSummary(
                solver=lp_res.solver,
                solver_options=solver_options,
                status=lp_res.status,
                n_rows=int(lp.rows.n_rows),
                objective=float(lp_res.objective),
                primal_residual=float(lp_res.primal_residual),
                residual_tol=float(lp_res.residual_tol),
                dual_residual=_f(lp_res.dual_residual),
                gap=_f(lp_res.gap),
                solve_seconds=_f(lp_res.solve_seconds),
                compile_seconds=_f(lp_res.compile_seconds),
                fixed_point_seconds=f.seconds,
                fixed_point_residual=f.residual,
                fixed_point_error_bound=f.error_bound,
                lp_minus_fixed_point_max_abs=float(np.abs(lp_vals[key] - f.values).max()),
                lp_values_min=float(np.min(lp_res.values)),
                lp_values_max=float(np.max(lp_res.values)),
                certified_error_bound=float(lp_res.error_bound),
            )
    return Bounds(
        summaries=summaries,
        v_up=fp["ublp"].values,
        w_low=fp["lblp"].values,
        err_up=fp["ublp"].error_bound,
        err_low=fp["lblp"].error_bound,
        lp_values=lp_vals,
        lp_lower=lp_lower,
        lp_upper=lp_upper,
    )


def check_general(built: BuiltModel, bounds: Bounds, general: str, tr: Tracker) -> General:
    """Step 2b: Theorems 3-4, the general RLP / NLP of the full MDP against UBLP / LBLP."""
    mdp, part, labels = built.mdp, built.part, built.labels
    v_up, w_low = bounds.v_up, bounds.w_low
    with tr.step("general", "general RLP and NLP of the full MDP (Theorems 3, 4)", 3) as adv:
        gres: dict[str, Any] = general_bound_residuals(mdp, labels, part.n_partitions, v_up, w_low)
        adv(status="residuals")
        # r_u(i): the reward is the same for every state of a partition (Section 4.2);
        # then the max- and min-reduced aggregated rows (RLP, NLP) are the same rows
        spread = _reward_spread(mdp, labels, part.n_partitions)
        if general != "aggregate":
            adv(2)
            thm = TheoremsSummary(
                method=general,
                **gres,
                reward_spread_within_partitions=spread,
                theorem4_max_abs_diff=gres["rlp_distance_bound"],
                theorem3_max_abs_diff=gres["nlp_distance_bound"],
                tolerance_theorem4=bounds.err_up,
                tolerance_theorem3=bounds.err_low,
            )
            return General(summary=thm, counted=None)
        rlp_rows = BellmanRows.aggregate(mdp, part, reduce="max")
        rlp = solve_exact(rlp_rows, "pi")
        adv(status="RLP")
        nlp_rows = rlp_rows if spread == 0.0 else BellmanRows.aggregate(mdp, part, reduce="min")
        nlp = solve_game(nlp_rows)
        adv(status="NLP")
        thm = TheoremsSummary(
            method=general,
            **gres,
            reward_spread_within_partitions=spread,
            theorem4_max_abs_diff=float(np.abs(rlp.values - v_up).max()),
            theorem3_max_abs_diff=float(np.abs(nlp.values - w_low).max()),
            tolerance_theorem4=rlp.error_bound + bounds.err_up,
            tolerance_theorem3=nlp.error_bound + bounds.err_low,
            nlp_rows_shared_with_rlp=nlp_rows is rlp_rows,
            rlp_rows=int(rlp_rows.n_rows),
            nlp_rows=int(nlp_rows.n_rows),
            rlp_error_bound=rlp.error_bound,
            nlp_error_bound=nlp.error_bound,
        )
        # |T(i, u)| counted from the full MDP: distinct aggregated rows per (i, u)
        counted = np.zeros((part.n_partitions, 3), dtype=np.int64)
        np.add.at(counted, (rlp_rows.owner.astype(np.int64), rlp_rows.action), 1)
    return General(summary=thm, counted=counted)


def check_lemma3(
    params: PatrolParams, built: BuiltModel, general: General, n_examples: int, tr: Tracker
) -> Lemma3Summary:
    """Step 2c: Lemma 3's ``|T(i, u)|`` from the construction against the paper's formula."""
    with tr.step("lemma3", "Lemma 3: |T(i, u)|") as adv:
        card = lemma3_cardinality(params)
        lem = lemma3_summary(card, general.counted, built.mdp.action_names, n_examples)
        adv(status=f"{lem.pairs_differing} pairs differ")
    return lem


def lemma3_summary(
    card: Lemma3Cardinality,
    counted: np.ndarray | None,
    action_names: Sequence[str],
    n_examples: int,
) -> Lemma3Summary:
    """Lemma 3's check from the cardinalities it judges.

    Parameters
    ----------
    card : Lemma3Cardinality
        ``|T(i, u)|`` from the construction beside the paper's formula
        (:func:`lpbounds.patrol.bounds.lemma3_cardinality`).
    counted : ndarray (M, 3) of int, optional
        ``|T(i, u)|`` counted from the full MDP's aggregated rows (``general="aggregate"``);
        None: not compared.
    action_names : sequence of str
    n_examples : int
        Differing pairs listed.

    Returns
    -------
    Lemma3Summary
        The pairs where the construction and the formula differ (count, examples) and,
        with ``counted``, whether the full MDP's rows agree with the construction.
    """
    rows_d, acts_d = np.nonzero(card.differs)
    examples = [
        {
            "partition": int(i),
            "action": action_names[int(a)],
            "taubar": int(card.taubar[i]),
            "construction": int(card.construction[i, a]),
            "paper": int(card.paper[i, a]),
        }
        for i, a in zip(rows_d[:n_examples], acts_d[:n_examples], strict=True)
    ]
    lem = Lemma3Summary(**card.summary(), examples=examples)
    if counted is not None:
        lem.full_mdp_rows_equal_construction = bool(np.array_equal(counted, card.construction))
        lem.full_mdp_rows_differ_pairs = int((counted != card.construction).sum())
    return lem


def check_claims(
    params: PatrolParams, built: BuiltModel, vs: VStar, n_examples: int, tr: Tracker
) -> ClaimsSummary:
    """Step 3: Claims 1-2 on every ordered pair of states, then of partitions."""
    with tr.step("claims", "Claims 1-2: monotonicity on all ordered pairs", 2) as adv:
        state_level = _state_claims(params, built, vs, n_examples)
        adv(status=f"{state_level['violations']} of {state_level['pairs']:,} pairs violate")
        claims = ClaimsSummary(**state_level, **_partition_claims(params, built, vs, n_examples))
        adv(status=f"partitions: {claims.partition_violations} violate")
    return claims


def _state_claims(
    params: PatrolParams, built: BuiltModel, vs: VStar, n_examples: int
) -> dict[str, Any]:
    """Claim 2 on every ``x1 = x2 + e_j``, split by whether ``x2`` has the alert at ``j``."""
    comps, vstar = built.comps, vs.values
    tol_claim = 2.0 * vs.error_bound
    st_arr = np.asarray(params.stations)
    acc = dict.fromkeys(
        ("pairs", "violations", "new_alert", "new_alert_own", "same", "same_pairs"), 0
    )
    max_excess, max_same = -np.inf, -np.inf
    cand: list[tuple[float, int, int, int]] = []
    for j, x1, x2 in claim_pairs(built.pm, comps):
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
    return {
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


def _partition_claims(
    params: PatrolParams, built: BuiltModel, vs: VStar, n_examples: int
) -> dict[str, Any]:
    """The partition-level Claim 2 (min of ``V*`` one delay apart) and Figure 4's chain."""
    pcomps, tol_claim = built.pcomps, 2.0 * vs.error_bound
    vmin_part = built.part.aggregate(vs.values, "min")
    hi, lo = _partition_pairs(built.pm, pcomps)
    pexcess = vmin_part[hi] - vmin_part[lo]
    pbad = pexcess > tol_claim
    pw = np.flatnonzero(pbad)
    pw = pw[np.argsort(-pexcess[pw])][:n_examples]
    # the chain of Figure 4
    idx4, _, _ = figs.select_min_value_partitions(built.comps, params.stations)
    chain = np.unique(built.labels[idx4])
    chain = chain[np.argsort(pcomps[chain, -1])]
    steps = np.diff(vmin_part[chain])
    return {
        "partition_pairs": int(hi.size),
        "partition_violations": int(pbad.sum()),
        "partition_max_excess": float(pexcess.max()) if hi.size else None,
        "partition_examples": [
            {
                "higher": pcomps[hi[k]].tolist(),
                "lower": pcomps[lo[k]].tolist(),
                "excess": float(pexcess[k]),
            }
            for k in pw
        ],
        "figure4_chain": {
            "taubar": pcomps[chain, -1].tolist(),
            "min_vstar": vmin_part[chain].tolist(),
            "non_increasing": bool((steps <= tol_claim).all()),
        },
    }


def check_sandwich(
    params: PatrolParams, built: BuiltModel, vs: VStar, bounds: Bounds, tr: Tracker
) -> SandwichAndPolicy:
    """Step 4: the sandwich ``w*(i) <= V*(x) <= v*(i)``, ``pi_s`` and ``V_sub``."""
    mdp, part, labels, comps = built.mdp, built.part, built.labels, built.comps
    vstar, err_v = vs.values, vs.error_bound
    st = params.stations
    with tr.step("sandwich", "sandwich, greedy policy pi_s and V_sub", 3) as adv:
        v_low_s = bounds.w_low[labels]
        v_up_s = bounds.v_up[labels]
        lower = inequality(v_low_s, vstar, bounds.err_low + err_v, comps, st)
        upper = inequality(vstar, v_up_s, bounds.err_up + err_v, comps, st)
        gap = bounds.v_up - bounds.w_low
        sandwich = SandwichSummary(
            lower_margin=lower.margin,
            upper_margin=upper.margin,
            lower=lower,
            upper=upper,
            partition_gap_max=float(gap.max()),
            partition_gap_mean=float(gap.mean()),
            mean_vstar_minus_vlow=float((vstar - v_low_s).mean()),
            mean_vup_minus_vstar=float((v_up_s - vstar).mean()),
            # the same margins with the LP solutions in place of the fixed points
            lp_lower_margin=float((part.aggregate(vstar, "min") - bounds.lp_values["lblp"]).min()),
            lp_upper_margin=float((bounds.lp_values["ublp"] - part.aggregate(vstar, "max")).min()),
            **_certified_margins(bounds, labels, vstar, err_v),
        )
        adv(status="sandwich")
        pi_s = np.asarray(greedy_policy(mdp, v_low_s), dtype=np.int64)
        adv(status="greedy policy")
        ev = evaluate_policy(mdp, pi_s, method="iterative")
        adv(status="V_sub")
        chain = policy_chain(
            v_low_s,
            ev.values,
            vstar,
            v_up_s,
            errors=(bounds.err_low, ev.error_bound, err_v, bounds.err_up),
            comps=comps,
            stations=st,
        )
        policy = _policy_summary(params, built, vs, pi_s, ev, chain)
    return SandwichAndPolicy(sandwich=sandwich, policy=policy, pi_s=pi_s, vsub=ev.values)


def policy_chain(
    v_low: np.ndarray,
    vsub: np.ndarray,
    vstar: np.ndarray,
    v_up: np.ndarray,
    *,
    errors: tuple[float, float, float, float],
    comps: np.ndarray,
    stations: Sequence[int],
) -> dict[str, Inequality]:
    """The chain ``V_low <= V_sub <= V* <= V_up`` over the states, link by link.

    Parameters
    ----------
    v_low, vsub, vstar, v_up : ndarray (n_states,)
        ``Phi w*``, the value of the greedy policy, ``V*`` and ``Phi v*``.
    errors : (float, float, float, float)
        The certified errors of the four vectors, in that order: each link allows the sum
        of its two sides' errors (:func:`inequality`).
    comps : ndarray (n_states, 3 + m)
    stations : sequence of int

    Returns
    -------
    dict of str to Inequality
        ``vlow_le_vsub``, ``vsub_le_vstar`` and ``vstar_le_vup``.
    """
    err_low, err_sub, err_v, err_up = errors
    return {
        "vlow_le_vsub": inequality(v_low, vsub, err_sub + err_low, comps, stations),
        "vsub_le_vstar": inequality(vsub, vstar, err_sub + err_v, comps, stations),
        "vstar_le_vup": inequality(vstar, v_up, err_up + err_v, comps, stations),
    }


def _policy_summary(
    params: PatrolParams,
    built: BuiltModel,
    vs: VStar,
    pi_s: np.ndarray,
    ev: Any,
    chain: dict[str, Inequality],
) -> PolicySummary:
    """How ``pi_s`` compares with ``pi*``: states that differ, one-step loss, ``V* - V_sub``."""
    mdp, vstar, err_v = built.mdp, vs.values, vs.error_bound
    rows_ex = exact_rows(mdp)
    if rows_ex.pair_row is None:
        raise ConsistencyError("the exact rows of the patrol MDP have no (state, action) index")
    q = rows_ex.q_values(vstar)
    loss = vstar - q[rows_ex.pair_row[np.arange(mdp.n_states), pi_s]]
    differs = pi_s != vs.policy
    vsub = ev.values
    return PolicySummary(
        differs_fraction=float(differs.mean()),
        differs_states=int(differs.sum()),
        suboptimal_fraction=float((loss > 2 * err_v).mean()),
        suboptimal_tolerance=2 * err_v,
        max_one_step_loss=float(loss.max()),
        max_vstar_minus_vsub=float((vstar - vsub).max()),
        max_vstar_minus_vsub_state=_state_dict(
            built.comps, int(np.argmax(vstar - vsub)), params.stations
        ),
        mean_vstar_minus_vsub=float((vstar - vsub).mean()),
        vsub_residual=ev.residual,
        vsub_error_bound=ev.error_bound,
        vsub_sweeps=ev.sweeps,
        vsub_method=ev.method,
        chain=chain,
        pi_s_counts=_action_counts(mdp, pi_s),
    )


def run_monte_carlo(
    params: PatrolParams,
    built: BuiltModel,
    policies: dict[str, np.ndarray],
    seeds: list[int],
    n_steps: int,
    tr: Tracker,
) -> MonteCarlo:
    """Step 5: Section 6's simulation of ``pi*`` and ``pi_s`` on common alert sequences."""
    runs: dict[str, list[Any]] = {key: [] for key in policies}
    with tr.step(
        "monte_carlo", f"Monte Carlo: {len(seeds)} seeds x {n_steps:,} steps", 2 * len(seeds)
    ) as adv:
        p0 = float(params.alert_probabilities()[0])
        for s in seeds:
            y = alert_sequence(n_steps, p0, params.m, s)
            for key, pol in policies.items():
                r = simulate(built.pm, pol, y, policy_name=key, seed=s, components=built.comps)
                if r.mismatches:
                    raise ConsistencyError(
                        f"simulation of {key} (seed {s}): the model's successor disagrees "
                        f"with the spec's dynamics on {r.mismatches} steps "
                        f"(first at step {r.first_mismatch})"
                    )
                runs[key].append(r)
                adv(status=f"seed {s}, {key}")
    pooled = {k: pooled_statistics(v) for k, v in runs.items()}
    summary = MonteCarloSummary(
        pi_star=PolicyStatistics(**pooled["pi_star"]),
        pi_s=PolicyStatistics(**pooled["pi_s"]),
        seeds=seeds,
        n_steps_per_seed=n_steps,
        conventions=_conventions(pooled),
    )
    return MonteCarlo(summary=summary, runs=runs)


def draw_figures(
    params: PatrolParams,
    built: BuiltModel,
    vs: VStar,
    bounds: Bounds,
    sp: SandwichAndPolicy,
    mc: MonteCarlo,
    folder: Path,
    tr: Tracker,
) -> dict[str, Path]:
    """Step 6: Figures 2-7 as PNG files in ``folder``."""
    comps, pcomps, labels, vstar = built.comps, built.pcomps, built.labels, vs.values
    files: dict[str, Path] = {}
    with tr.step("figures", "figures 2-7", 6) as adv:
        files["fig2"] = figs.plot_information(params, folder / "fig2_information.png")
        adv()
        files["fig3"] = figs.plot_ordered_states(
            comps, params.stations, vstar, folder / "fig3_ordered_states.png"
        )
        adv()
        files["fig4"] = figs.plot_min_value_partitions(
            comps, params.stations, vstar, folder / "fig4_min_value_partitions.png"
        )
        adv()
        files["fig5"] = figs.plot_bounds(
            pcomps, labels, vstar, bounds.v_up, bounds.w_low, params.N, folder / "fig5_bounds.png"
        )
        adv()
        files["fig6"] = figs.plot_vsub(
            pcomps, labels, vstar, sp.vsub, params.N, folder / "fig6_vsub.png"
        )
        adv()
        files["fig7"] = figs.plot_histograms(
            {k: np.concatenate([r.delay for r in v]) for k, v in mc.runs.items()},
            {k: np.concatenate([r.loiters[r.complete] for r in v]) for k, v in mc.runs.items()},
            folder / "fig7_histograms.png",
        )
        adv()
    return files


# ---------------------------------------------------------------------- the pipeline
def _check_arguments(
    general: str, seeds: Sequence[int], n_steps: int, n_examples: int
) -> list[int]:
    """The scalar arguments of :func:`reproduce`, checked before anything is built."""
    if general not in ("aggregate", "residual"):
        raise ValidationError(f"general must be 'aggregate' or 'residual'; got {general!r}")
    out = []
    for k, s in enumerate(seeds):
        if isinstance(s, bool) or not isinstance(s, int | np.integer) or s < 0:
            raise ValidationError(f"seeds[{k}] must be an integer >= 0; got {s!r}")
        out.append(int(s))
    if not out:
        raise ValidationError("give at least one Monte Carlo seed")
    for name, value in (("n_steps", n_steps), ("n_examples", n_examples)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise ValidationError(f"{name} must be an integer >= 1; got {value!r}")
    return out


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
    beyond: bool = False,
    beyond_cache: str | Path = "out/beyond",
    beyond_sizes: Sequence[int] = (5, 6),
) -> Reproduction:
    """Reproduce the paper's patrol results on one instance; write them into ``out``.

    Every argument and the model are checked, and ``out`` is checked for writability and
    locked, before any computation. The files are written into a temporary folder beside
    ``out`` and moved into place, with ``manifest.json``, only when all are complete
    (:class:`lpbounds.outputs.AtomicDirectory`): an error or Ctrl-C leaves a previous
    ``out`` as it was.

    Parameters
    ----------
    model : path, name or PatrolParams
        A ``kind = "patrol"`` instance (default ``models/patrol-paper.toml``).
    out : path
        Output folder: ``summary.json``, ``values.npz``, ``report.md``, PNGs,
        ``manifest.json``. An existing folder is replaced as a whole.
    seeds : sequence of int
        Seeds (``>= 0``) of the Monte Carlo alert sequences (one run of each policy per seed).
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
    beyond : bool
        Also run the study beyond the paper's size (:mod:`lpbounds.patrol.beyond`): exact
        ``V*`` at 5 and 6 stations (matrix-free; the 4-station numbers are this run's),
        the greedy policy by Monte Carlo at 6 and 8 stations, and a "Beyond the paper"
        section of the report with ``beyond.json`` and a figure. Long: the 6-station
        study needs about 14 GB and 10 minutes on 2 cores (``beyond_sizes``; measured in
        docs/reproduction.md).
    beyond_cache : path
        Where the 5- and 6-station results are kept between runs (reused when the
        parameters are the same; the 6-station V* is checkpointed there).
    beyond_sizes : sequence of int
        The numbers of stations (5, 6 or both) solved exactly by ``beyond``.

    Returns
    -------
    Reproduction

    Raises
    ------
    ValidationError
        A bad argument or model (nothing is created).
    OutputError
        ``out`` is not a writable folder, or another run holds its lock.
    SolverError, ConvergenceError, ConsistencyError
        A computation failed (``out`` is left as it was).
    """
    seeds = _check_arguments(general, seeds, n_steps, n_examples)
    sizes = tuple(beyond_sizes)
    if beyond and (not sizes or any(m not in (5, 6) for m in sizes)):
        raise ValidationError(f"beyond_sizes must be 5, 6 or both; got {list(sizes)}")
    solver = resolve_solver(solver)
    name, params = _load(model)
    t_start = time.perf_counter()
    tr = Tracker(progress)
    outdir = Path(out)
    target = AtomicDirectory(outdir, replaceable=OUTPUT_FILES)
    with target as tmp:
        # the large sizes first, so that their memory is free before the MDP is built
        bey_rows = _beyond_sizes(sizes, beyond_cache, tr) if beyond else []
        built, counts = build_model(params, tr)
        vs = solve_vstar(built, tr)
        bounds = solve_bounds(params, solver, tr)
        gen = check_general(built, bounds, general, tr)
        lemma3 = check_lemma3(params, built, gen, n_examples, tr)
        claims = check_claims(params, built, vs, n_examples, tr)
        sp = check_sandwich(params, built, vs, bounds, tr)
        mc = run_monte_carlo(
            params, built, {"pi_star": vs.policy, "pi_s": sp.pi_s}, seeds, n_steps, tr
        )
        files = draw_figures(params, built, vs, bounds, sp, mc, tmp, tr) if figures else {}
        summary = Summary(
            instance=name,
            params=params.to_table(),
            machine=run_metadata(),
            date=time.strftime("%Y-%m-%d %H:%M:%S %Z"),
            n_states=counts.n_states_counted,
            n_partitions=counts.n_partitions_counted,
            counts=counts,
            vstar=vs.summary,
            bounds=bounds.summaries,
            theorems=gen.summary,
            theorem3_max_abs_diff=gen.summary.theorem3_max_abs_diff,
            theorem4_max_abs_diff=gen.summary.theorem4_max_abs_diff,
            lemma3=lemma3,
            claims=claims,
            claim2_violations=claims.violations,
            sandwich=sp.sandwich,
            policy=sp.policy,
            monte_carlo=mc.summary,
            paper_table1=PAPER_TABLE1,
            **_timing(tr, t_start),
        )
        arrays = _arrays(built, vs, bounds, sp)
        bey_lines: list[str] = []
        if beyond:
            bey_lines, bey_files = _beyond_section(
                params, name, vs, bounds, sp, bey_rows, tmp, figures, tr
            )
            files.update(bey_files)
        files.update(write_outputs(summary, arrays, files, tmp, tr, t_start))
        if bey_lines:
            with open(files["report"], "a") as fh:
                fh.write("\n" + "\n".join(bey_lines))
        checkpoint("commit")
        target.commit({"instance": name})
    files = {k: outdir / Path(p).relative_to(tmp) for k, p in files.items()}
    files["manifest"] = outdir / MANIFEST
    return Reproduction(
        summary=to_dict(summary), out=outdir, files=files, arrays=arrays, result=summary
    )


def _beyond_sizes(sizes: tuple[int, ...], cache: str | Path, tr: Tracker) -> list[Any]:
    """``--beyond``: the 5- and 6-station studies (cached in ``cache``)."""
    from .beyond import run_sizes

    return run_sizes(sizes, cache, tr)


def _beyond_section(
    params: PatrolParams,
    name: str,
    vs: VStar,
    bounds: Bounds,
    sp: SandwichAndPolicy,
    rows: list[Any],
    folder: Path,
    figures: bool,
    tr: Tracker,
) -> tuple[list[str], dict[str, Path]]:
    """``--beyond``: this run's row, the Monte Carlo, ``beyond.json``, the figure, the text."""
    from .beyond import from_reproduction, monte_carlo, write_beyond

    here = from_reproduction(params, name, vs, bounds, sp, tr)
    mc = monte_carlo(tr=tr)
    return write_beyond(folder, [here, *rows], mc, figures)


def _arrays(
    built: BuiltModel, vs: VStar, bounds: Bounds, sp: SandwichAndPolicy
) -> dict[str, np.ndarray]:
    """The large arrays of ``values.npz``."""
    return {
        "vstar": vs.values,
        "pi_star": vs.policy.astype(np.int8),
        "state_components": built.comps.astype(np.int16),
        "lower": bounds.w_low,
        "upper": bounds.v_up,
        "partition_components": built.pcomps.astype(np.int16),
        "partition_of_state": built.labels.astype(np.int32),
        "vsub": sp.vsub,
        "pi_s": sp.pi_s.astype(np.int8),
    }


def _timing(tr: Tracker, t_start: float) -> dict[str, Any]:
    return {
        "seconds": dict(tr.seconds),
        "peak_rss_mb": dict(tr.peak_rss_mb),
        "cpu_seconds": dict(tr.cpu_seconds),
        "seconds_total": time.perf_counter() - t_start,
    }


def write_outputs(
    summary: Summary,
    arrays: dict[str, np.ndarray],
    figures: dict[str, Path],
    folder: Path,
    tr: Tracker,
    t_start: float,
) -> dict[str, Path]:
    """Step 7: ``values.npz``, ``report.md`` and ``summary.json`` (with the final times)
    in ``folder`` (the temporary folder :func:`reproduce` moves into place)."""
    files = {"values": folder / "values.npz", "summary": folder / "summary.json"}
    with tr.step("write", "writing values.npz, summary.json, report.md"):
        np.savez(files["values"], **arrays)  # type: ignore[arg-type]  # numpy's stub types **kwds as allow_pickle
        for key, value in _timing(tr, t_start).items():
            setattr(summary, key, value)
        files["report"] = write_report(summary, {**figures, **files}, folder / "report.md")
    for key, value in _timing(tr, t_start).items():
        setattr(summary, key, value)
    files["summary"].write_text(json.dumps(jsonable(summary), indent=2) + "\n")
    return files


def _certified_margins(
    bounds: Bounds, labels: np.ndarray, vstar: np.ndarray, err_v: float
) -> dict[str, float | None]:
    """The sandwich's margins from the LP results' certified brackets and ``V*``'s error
    bound: positive margins prove the sandwich for the exact quantities."""
    w_up, v_lo = bounds.lp_upper["lblp"], bounds.lp_lower["ublp"]
    return {
        "certified_lower_margin": None
        if w_up is None
        else float(((vstar - err_v) - w_up[labels]).min()),
        "certified_upper_margin": None
        if v_lo is None
        else float((v_lo[labels] - (vstar + err_v)).min()),
    }


def _array_or_none(x: Any) -> np.ndarray | None:
    return None if x is None else np.asarray(x, dtype=np.float64)


def _action_counts(mdp: Any, policy: np.ndarray) -> dict[str, int]:
    return {
        mdp.action_names[a]: int(c)
        for a, c in enumerate(np.bincount(policy, minlength=mdp.n_actions))
    }


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
    rows: list[dict[str, Any]] = []
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
    best = min(rows, key=lambda r: float(r["relative_error_sum"]))
    return {"table": rows, "closest": best["convention"]}
