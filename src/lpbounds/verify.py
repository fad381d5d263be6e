r"""Empirical verification of the paper's LP results, solver by solver, against exact values.

Every function returns *records*: dicts with the keys

``check``
    The paper's name of the result: "Lemma 1", "Theorem 1", "Lemma 2", "Theorem 2",
    "Remark 2".
``instance``, ``solver``
    The model and the LP solver ("exact" for solver-free checks, "all" for
    comparisons across solvers).
``max_deviation``, ``tolerance``, ``pass``
    The measured quantity (absolute, in value units), the absolute tolerance it was
    compared with, and ``max_deviation <= tolerance`` (for "Remark 2", where a
    *difference* is to be shown, ``pass`` is ``max_deviation > tolerance``).
``detail``
    What was measured, in one line.

The references are exact: ``V*`` and RLP's ``v*`` are fixed points computed by
:func:`lpbounds.dp.solve_exact` to a residual ``1e-10 * max|R| / (1 - lambda)``, never
an LP solution. LP tolerances are ``LP_COMPARE_RTOL * max(1, max|reference|)``
(:mod:`lpbounds.tolerances`), far above the DP error and above the accuracy of interior
point solvers (Clarabel stops near 1e-8 relative).

What each check measures (``c`` are ``n_costs`` random non-negative costs: the first
strictly positive, the others with zeros):

* **Lemma 1** - ELP's optimum is ``V*``: for ``c > 0`` the LP point equals ``V*``; where
  ``c`` has zeros the minimiser is not unique, so the check is that the point
  dominates ``V*`` and equals it wherever ``c(x) > 0`` (``c'V = c'V*`` with ``V >= V*``
  forces that). Solver "exact": ``Phi v* >= V*`` (RLP's bound).
* **Theorem 1** - RLP's optimum is ``v*`` for every cost (same measure as Lemma 1, on
  partitions), across solvers ("all": largest difference between two solvers'
  optima), and every feasible point found dominates ``v*`` (the LP optima for every
  cost, and, solver "exact", the value-iteration iterates ``T^k u`` from the feasible
  constant ``u = max R / (1 - lambda)``, all of which are feasible).
* **Lemma 2** - with each solver's own optimal duals ``mu-bar`` (they differ between
  solvers; the detail reports by how much), ``SLP(mu-bar)`` solved by that solver has
  the optimum ``v*``, and the reduced MDP of step 2 of Theorem 1's proof has the value
  ``v*`` (exact DP).
* **Theorem 2** - IB for ``L = 1..5``: every block of the LP optimum equals ``v*``
  (``>= v*`` is the theorem, equality is Lemma 1 for IB); solver "exact": the fixed
  point of IB's cyclic rows is ``(v*, ..., v*)``. LLP (surplus lifting) with random
  ``d >= 0``: the optimal ``v`` dominates ``v*``.
* **Remark 2** - :func:`~lpbounds.formulations.alp.find_cost_dependent_alp` finds a small
  MDP and soft-aggregation basis on which the optimum for ``c2`` is worse than the
  optimum for ``c1`` under ``c1`` (so the optimal sets differ); each solver re-solves it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .dp import solve_exact
from .errors import LPBoundsError, ValidationError
from .formulations import (
    ELP,
    IB,
    LLP,
    RLP,
    SLP,
    find_cost_dependent_alp,
    installed_lp_solvers,
    resolve_solver,
)
from .formulations.alp import ALP
from .formulations.base import LPResult
from .generators import garnet, random_partition
from .instances import load_instance, models_dir
from .mdp import FiniteMDP
from .partition import Partition
from .rows import BellmanRows
from .tolerances import LP_COMPARE_RTOL

__all__ = [
    "RELIABLE_LP_SOLVERS",
    "VerifyInstance",
    "default_solvers",
    "model_instances",
    "random_instances",
    "run_verification",
    "summarize",
    "verify_instance",
    "verify_remark2",
]

Record = dict[str, Any]
Progress = Callable[[str], None]

#: Solvers whose LP optima are accurate to ``LP_COMPARE_RTOL`` out of the box: the
#: default set of :func:`run_verification` (those installed). First-order methods (SCS,
#: OSQP, PDLP) stop near 1e-4 relative and are checked only when named.
RELIABLE_LP_SOLVERS: tuple[str, ...] = (
    "HIGHS",
    "CLARABEL",
    "SCIPY",
    "GLPK",
    "ECOS",
    "CVXOPT",
    "MOSEK",
    "GUROBI",
    "COPT",
    "XPRESS",
    "CPLEX",
)

#: Number of IB blocks checked for Theorem 2.
IB_BLOCKS: tuple[int, ...] = (1, 2, 3, 4, 5)


def default_solvers() -> list[str]:
    """The installed solvers of :data:`RELIABLE_LP_SOLVERS` (HiGHS, Clarabel, SciPy here)."""
    have = set(installed_lp_solvers())
    return [s for s in RELIABLE_LP_SOLVERS if s in have]


@dataclass
class VerifyInstance:
    """A model to verify on: a name, an MDP and a partition."""

    name: str
    mdp: FiniteMDP
    partition: Partition


def random_instances(n: int, seed: int = 0) -> list[VerifyInstance]:
    """``n`` seeded random MDPs (8-60 states, 1-3 actions) with random partitions."""
    if n < 0:
        raise ValidationError(f"the number of random instances must be >= 0; got {n}")
    out = []
    for k in range(n):
        rng = np.random.default_rng([seed, k])
        n_states = int(rng.integers(8, 61))
        n_actions = int(rng.integers(1, 4))
        mdp = garnet(
            n_states,
            n_actions,
            int(rng.integers(1, 5)),
            float(rng.uniform(0.5, 0.95)),
            seed=int(rng.integers(2**31)),
            shared_probabilities=bool(rng.random() < 0.3),
            reward_range=(-1.0, 1.0),
            allowed_fraction=float(rng.choice([1.0, 0.7])),
        )
        m = int(rng.integers(1, max(2, n_states // 3) + 1))
        part = random_partition(n_states, m, seed=int(rng.integers(2**31)))
        out.append(VerifyInstance(f"random-{seed}-{k}", mdp, part))
    return out


def model_instances(
    names: Iterable[str] | None = None, max_states: int = 10_000
) -> tuple[list[VerifyInstance], list[str]]:
    """Instances from ``models/`` (all with a ``[partition]`` table by default).

    Returns the instances and the names skipped for having more than ``max_states``
    states, or a size not known without building the model (ELP is solved by every
    solver, so only small models are verified by default).
    A model named explicitly is never skipped.
    """
    explicit = names is not None
    if names is None:
        names = [str(p) for p in sorted(models_dir().glob("*.toml"))]
    out: list[VerifyInstance] = []
    skipped: list[str] = []
    for name in names:
        inst = load_instance(name)
        if not inst.has_partition:
            if explicit:
                raise ValidationError(f"instance {inst.name!r} has no [partition]: cannot verify")
            continue
        if not explicit:
            size = _estimated_states(inst)
            if size is None or size > max_states:
                skipped.append(inst.name)
                continue
        mdp = inst.mdp()
        out.append(VerifyInstance(inst.name, mdp, inst.partition()))
    return out, skipped


def _estimated_states(inst: Any) -> int | None:
    """The number of states of an instance without building it (None if unknown)."""
    size = inst.config["model"].get("n_states")
    if isinstance(size, int):
        return size
    if inst.kind == "patrol":
        try:
            from .patrol.instance import model_for, params_from_instance

            return int(model_for(params_from_instance(inst)).n_states)
        except Exception:  # the patrol package is optional here: unknown size
            return None
    return None


def _record(
    check: str,
    instance: str,
    solver: str,
    deviation: float,
    tolerance: float,
    detail: str,
    *,
    larger_passes: bool = False,
) -> Record:
    dev = float(deviation)
    ok = dev > tolerance if larger_passes else dev <= tolerance
    return {
        "check": check,
        "instance": instance,
        "solver": solver,
        "max_deviation": dev,
        "tolerance": float(tolerance),
        "pass": bool(ok and np.isfinite(dev)),
        "detail": detail,
    }


def _random_costs(n: int, k: int, rng: np.random.Generator) -> list[np.ndarray]:
    """``k`` costs: strictly positive first, then with about 40% zeros (never all zero)."""
    costs = [rng.uniform(0.1, 1.0, n)]
    for _ in range(k - 1):
        c = rng.uniform(0.0, 1.0, n)
        c[rng.random(n) < 0.4] = 0.0
        if not c.any():
            c[rng.integers(n)] = 1.0
        costs.append(c)
    return costs


def _cost_deviation(v: np.ndarray, ref: np.ndarray, weight: np.ndarray) -> float:
    """``max( max_{weight > 0} |v - ref|, max (ref - v)^+ )``: equality where the cost is
    positive (forced by ``c'v = c'ref`` and ``v >= ref``), domination everywhere."""
    pos = weight > 0
    eq = float(np.abs(v[pos] - ref[pos]).max(initial=0.0))
    dom = float(np.maximum(ref - v, 0.0).max(initial=0.0))
    return max(eq, dom)


def _solve(form: Any, solver: str) -> tuple[LPResult | None, str]:
    try:
        return form.solve(solver), ""
    except LPBoundsError as exc:
        return None, f"solve failed: {exc}"


def verify_instance(
    inst: VerifyInstance,
    solvers: Sequence[str],
    *,
    n_costs: int = 3,
    seed: int = 0,
    rtol: float = LP_COMPARE_RTOL,
    progress: Progress | None = None,
) -> list[Record]:
    """Lemma 1, Theorem 1, Lemma 2 and Theorem 2 on one instance, for each solver.

    Parameters
    ----------
    inst : VerifyInstance
    solvers : sequence of str
        Installed cvxpy LP solvers (checked with :func:`resolve_solver`).
    n_costs : int
        Number of random costs per LP (>= 1; the first is strictly positive).
    seed : int
        Seed of the costs and of LLP's ``d``.
    rtol : float
        Relative tolerance of every LP comparison (see the module docstring).
    progress : callable(str), optional
        Called before each solver's checks.
    """
    if n_costs < 1:
        raise ValidationError(f"n_costs must be >= 1; got {n_costs}")
    names = [resolve_solver(s) for s in solvers]
    mdp, part, name = inst.mdp, inst.partition, inst.name
    rng = np.random.default_rng([seed, mdp.n_states, part.n_partitions])
    exact = solve_exact(mdp)
    vstar_full = exact.values
    rlp_rows = BellmanRows.aggregate(mdp, part, reduce="max")
    rfp = solve_exact(rlp_rows)
    vstar = rfp.values
    tol_v = rtol * max(1.0, float(np.abs(vstar_full).max()))
    tol_p = rtol * max(1.0, float(np.abs(vstar).max()))
    costs = _random_costs(mdp.n_states, n_costs, rng)
    # LLP's surplus costs: one dense, one with about half zeros
    d_list = [rng.uniform(0.0, 1.0, (mdp.n_states, mdp.n_actions)) for _ in range(2)]
    d_list[1][rng.random(d_list[1].shape) < 0.5] = 0.0
    records: list[Record] = []

    # ---------------------------------------------------------------- exact checks
    lift = part.lift(vstar)
    # exact checks compare two DP results: their error bounds plus round-off
    dp_err = exact.error_bound + rfp.error_bound + 1e-12 * max(1.0, float(np.abs(lift).max()))
    fp_err = rfp.error_bound + 1e-12 * max(1.0, float(np.abs(vstar).max()))
    records.append(
        _record(
            "Lemma 1",
            name,
            "exact",
            float(np.maximum(vstar_full - lift, 0.0).max()),
            dp_err,
            f"Phi v* >= V* (RLP's bound); min(Phi v* - V*) = {(lift - vstar_full).min():.3g}",
        )
    )
    upper = np.full(part.n_partitions, float(rlp_rows.reward.max()) / (1.0 - mdp.discount))
    worst, u = 0.0, upper
    for _ in range(50):
        u, _ = rlp_rows.apply_max(u)
        worst = max(worst, float(np.maximum(vstar - u, 0.0).max()))
    records.append(
        _record(
            "Theorem 1",
            name,
            "exact",
            worst,
            fp_err,
            "every feasible point found dominates v*: 50 iterates T^k(max R/(1-lambda))",
        )
    )
    ib_dev = 0.0
    for L in IB_BLOCKS:
        ib = IB(mdp, part, L)
        fp = solve_exact(ib.rows).values.reshape(L, -1)
        ib_dev = max(ib_dev, float(np.abs(fp - vstar).max()))
    records.append(
        _record(
            "Theorem 2",
            name,
            "exact",
            ib_dev,
            2 * fp_err,
            f"fixed point of IB's cyclic rows = (v*, ..., v*), L = {IB_BLOCKS[0]}..{IB_BLOCKS[-1]}",
        )
    )

    # ---------------------------------------------------------------- per solver
    first_opt: dict[str, np.ndarray] = {}
    mus: dict[str, np.ndarray] = {}
    for solver in names:
        if progress is not None:
            progress(f"{name}: {solver}")
        # Lemma 1: ELP = V*
        devs, fail = [], ""
        for c in costs:
            res, msg = _solve(ELP(mdp, c), solver)
            if res is None:
                devs.append(np.inf)
                fail = msg
                continue
            devs.append(_cost_deviation(res.values, vstar_full, c))
        records.append(
            _record(
                "Lemma 1",
                name,
                solver,
                max(devs),
                tol_v,
                fail or f"ELP = V* for {len(costs)} costs ({len(costs) - 1} with zeros)",
            )
        )
        # Theorem 1: RLP = v* for every cost; optima dominate v*
        devs, doms, fail = [], [], ""
        for k, c in enumerate(costs):
            res, msg = _solve(RLP(mdp, part, c), solver)
            if res is None:
                devs.append(np.inf)
                doms.append(np.inf)
                fail = msg
                continue
            cbar = np.bincount(part.labels, weights=c, minlength=part.n_partitions)
            devs.append(_cost_deviation(res.values, vstar, cbar))
            doms.append(float(np.maximum(vstar - res.values, 0.0).max()))
            if k == 0:
                first_opt[solver] = res.values
                assert res.mu is not None
                mus[solver] = res.mu
        records.append(
            _record(
                "Theorem 1",
                name,
                solver,
                max(devs),
                tol_p,
                fail or f"RLP optimum = v* for {len(costs)} costs ({len(costs) - 1} with zeros)",
            )
        )
        records.append(
            _record(
                "Theorem 1",
                name,
                solver,
                max(doms),
                tol_p,
                fail or f"every feasible point found dominates v*: {len(costs)} LP optima",
            )
        )
        # Lemma 2: SLP(mu-bar) = RLP with this solver's duals; reduced MDP value = v*
        if solver in mus:
            mu = mus[solver]
            ref_solver = names[0]
            mu_diff = float(np.abs(mu - mus[ref_solver]).max()) if ref_solver in mus else 0.0
            n_pos = int((mu > 0).sum())
            try:
                slp = SLP(mdp, part, mu)
                res, msg = _solve(slp, solver)
                dev = np.inf if res is None else float(np.abs(res.values - vstar).max())
                detail = msg or (
                    f"SLP(mu-bar) optimum = v*; mu-bar > 0 on {n_pos} pairs, "
                    f"max|mu-bar - mu-bar({ref_solver})| = {mu_diff:.3g}"
                )
                red = solve_exact(slp.reduced_mdp())
                red_dev = float(np.abs(red.values - vstar).max())
                red_detail = (
                    f"value of the reduced MDP (step 2) = v*: {int(slp.rows.n_rows)} (i, u) rows"
                )
            except LPBoundsError as exc:
                dev, red_dev = np.inf, np.inf
                detail = red_detail = f"SLP failed: {exc}"
            records.append(_record("Lemma 2", name, solver, dev, tol_p, detail))
            records.append(_record("Lemma 2", name, solver, red_dev, tol_p, red_detail))
        # Theorem 2: IB blocks and LLP never beat v*
        devs, fail = [], ""
        for L in IB_BLOCKS:
            res, msg = _solve(IB(mdp, part, L), solver)
            if res is None:
                devs.append(np.inf)
                fail = msg
                continue
            devs.append(float(np.abs(res.extra["blocks"] - vstar).max()))
        records.append(
            _record(
                "Theorem 2",
                name,
                solver,
                max(devs),
                tol_p,
                fail
                or f"IB L={IB_BLOCKS[0]}..{IB_BLOCKS[-1]}: every block = v* (>= v* is the theorem)",
            )
        )
        doms, fail, excess = [], "", 0.0
        for d in d_list:
            res, msg = _solve(LLP(mdp, part, d), solver)
            if res is None:
                doms.append(np.inf)
                fail = msg
                continue
            doms.append(float(np.maximum(vstar - res.values, 0.0).max()))
            excess = max(excess, float((res.values - vstar).max()))
        records.append(
            _record(
                "Theorem 2",
                name,
                solver,
                max(doms),
                tol_p,
                fail
                or f"LLP with {len(d_list)} random d >= 0: v >= v* (max(v - v*) = {excess:.3g})",
            )
        )
    if len(first_opt) > 1:
        vals = list(first_opt.values())
        spread = max(float(np.abs(a - b).max()) for a in vals for b in vals)
        records.append(
            _record(
                "Theorem 1",
                name,
                "all",
                spread,
                2 * tol_p,
                f"RLP optima agree across {', '.join(first_opt)}",
            )
        )
    return records


def verify_remark2(
    solvers: Sequence[str], *, seed: int = 0, rtol: float = LP_COMPARE_RTOL
) -> list[Record]:
    """Remark 2: an ALP (soft aggregation) whose optimum depends on the cost, per solver."""
    names = [resolve_solver(s) for s in solvers]
    ex = find_cost_dependent_alp(seed, rtol=rtol)
    inst = f"soft-agg garnet seed {ex.seed} (n=6, K=2)"
    out = []
    for solver in names:
        r1, m1 = _solve(ALP(ex.mdp, ex.basis, ex.cost1), solver)
        r2, m2 = _solve(ALP(ex.mdp, ex.basis, ex.cost2), solver)
        if r1 is None or r2 is None:
            out.append(_record("Remark 2", inst, solver, np.nan, np.nan, m1 or m2))
            continue
        assert r1.state_values is not None and r2.state_values is not None
        excess = float(ex.cost1 @ r2.state_values - ex.cost1 @ r1.state_values)
        tol = rtol * max(1.0, abs(r1.objective))
        out.append(
            _record(
                "Remark 2",
                inst,
                solver,
                excess,
                tol,
                "ALP optimum depends on c: c1'Phi r(c2) - c1'Phi r(c1) > tol; "
                f"max|Phi r(c1) - Phi r(c2)| = "
                f"{float(np.abs(r1.state_values - r2.state_values).max()):.3g}",
                larger_passes=True,
            )
        )
    return out


def run_verification(
    models: Iterable[str] | None = None,
    *,
    solvers: Sequence[str] | None = None,
    n_random: int = 5,
    seed: int = 0,
    n_costs: int = 3,
    rtol: float = LP_COMPARE_RTOL,
    max_states: int = 10_000,
    include_models: bool = True,
    progress: Progress | None = None,
) -> tuple[list[Record], list[str]]:
    """Every check on the models and ``n_random`` random instances, for each solver.

    Parameters
    ----------
    models : iterable of str, optional
        Model names or paths; default all of ``models/`` with a partition and at most
        ``max_states`` states.
    solvers : sequence of str, optional
        Default :func:`default_solvers`.
    include_models : bool
        False: random instances (and Remark 2) only.

    Returns
    -------
    (records, skipped)
        ``skipped``: default models left out for their size.
    """
    solver_names = [resolve_solver(s) for s in (solvers or default_solvers())]
    insts: list[VerifyInstance] = []
    skipped: list[str] = []
    if include_models:
        insts, skipped = model_instances(models, max_states)
    insts += random_instances(n_random, seed)
    records: list[Record] = []
    for inst in insts:
        records += verify_instance(
            inst, solver_names, n_costs=n_costs, seed=seed, rtol=rtol, progress=progress
        )
    if progress is not None:
        progress("Remark 2")
    records += verify_remark2(solver_names, seed=seed, rtol=rtol)
    return records, skipped


def summarize(records: Sequence[Record]) -> list[Record]:
    """One row per (check, solver): records, passed, worst ``max_deviation / tolerance``.

    Each row has ``check``, ``solver``, ``records``, ``passed``, ``max_deviation`` and
    ``tolerance`` of the record with the largest ratio (for "Remark 2": the smallest,
    since there the deviation must exceed the tolerance).
    """
    groups: dict[tuple[str, str], list[Record]] = {}
    for r in records:
        groups.setdefault((r["check"], r["solver"]), []).append(r)
    order = ["Lemma 1", "Theorem 1", "Lemma 2", "Theorem 2", "Remark 2"]
    out = []
    for (check, solver), recs in sorted(
        groups.items(),
        key=lambda kv: (order.index(kv[0][0]) if kv[0][0] in order else 99, kv[0][1]),
    ):

        def ratio(r: Record) -> float:
            tol = r["tolerance"]
            return r["max_deviation"] / tol if tol and np.isfinite(tol) else np.inf

        pick = min(recs, key=ratio) if check == "Remark 2" else max(recs, key=ratio)
        out.append(
            {
                "check": check,
                "solver": solver,
                "records": len(recs),
                "passed": sum(bool(r["pass"]) for r in recs),
                "max_deviation": pick["max_deviation"],
                "tolerance": pick["tolerance"],
            }
        )
    return out


def write_json(records: list[Record], path: str | Path) -> None:
    """Write the records as a JSON list."""
    import json

    Path(path).write_text(json.dumps(records, indent=2))
