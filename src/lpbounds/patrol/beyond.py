r"""Beyond the paper's size: exact ``V*`` at 5 and 6 stations and what the bounds are worth.

The paper computes ``V*`` only at 4 stations (2,048,000 states). With the matrix-free
sweeps (:mod:`lpbounds.patrol.matrix_free`) ``V*`` is computed, and certified, at 5
stations (``models/patrol-m5-paper.toml``, 33,095,680 states) and 6 stations
(``models/patrol-m6-paper.toml``, 534,773,760 states), with the paper's other parameters.
At each size :func:`study` measures, over every state ``x`` of partition ``i``:

* ``v*(i) - V*(x)``, ``V*(x) - w*(i)`` and ``v*(i) - w*(i)`` (max and mean), with ``v*``
  and ``w*`` the UBLP and LBLP optima (:func:`lpbounds.patrol.greedy_mc.partition_bounds`:
  their fixed points, certified): which side owns the gap;
* the fraction of states where ``pi_s``, greedy w.r.t. the lifted ``w*``, is optimal (its
  action is among ``V*``'s maximisers within :data:`~lpbounds.tolerances.GREEDY_TIE_RTOL`),
  and ``max(V* - V_sub)`` with ``V_sub`` its value (matrix-free policy evaluation);
* the sandwich checks ``V* <= v*``, ``w* <= V*`` and ``w* <= V_sub <= V*`` as verdicts
  (:class:`~lpbounds.status.Verdict`) from certified intervals, as
  :func:`lpbounds.certification.checks.compare_at_least` decides them.

The statistics are reduced inside compiled passes (no state-sized temporaries): at 6
stations a float64 vector over the states is 4.3 GB, and the whole study keeps at most
three of them (``V*`` and the two of the evaluation of ``pi_s``), the partition labels
(int32) only during the greedy pass, and two int8 policies.

Each size's result is a small JSON file (:func:`save_result`, :func:`load_result`), so a
long 6-station run is made once and the report (:func:`report_section`) is built from
the files.
"""

from __future__ import annotations

import json
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..certification.checks import compare_at_least
from ..status import Status, Verdict
from ..tolerances import GREEDY_TIE_RTOL, error_bound
from .matrix_free import MatrixFreePatrol, check_finite, evaluate_policy, solve_vstar
from .params import PatrolParams

__all__ = [
    "BEYOND_MODELS",
    "Check",
    "SizeResult",
    "certified_check",
    "load_result",
    "save_result",
    "study",
    "study_from_arrays",
]

#: The model files of the study beyond the paper, by number of stations.
BEYOND_MODELS: dict[int, str] = {5: "patrol-m5-paper", 6: "patrol-m6-paper"}


# ---------------------------------------------------------------------- results
@dataclass
class Check:
    """The verdict of ``a >= b`` at every state from certified intervals.

    With the intervals ``a +- err_a`` and ``b +- err_b`` of uniform width, the verdict over
    all states is the one at the state where ``a - b`` is smallest (``state``), which
    :func:`lpbounds.certification.checks.compare_at_least` decides: *holds* proves
    ``a >= b - accuracy`` at every state, *violated* proves ``a < b`` somewhere,
    *inconclusive* is neither. The bounds' claims (``V* <= v*``, ``w* <= V*``,
    ``w* <= V_sub``) are checked with accuracy 0 (holds = proven); ``V_sub <= V*`` with
    ``2 (err_a + err_b)``: ``V_sub = V*`` exactly where ``pi_s`` is optimal, so there
    *holds* says no violation beyond what the certified errors allow.

    Attributes
    ----------
    claim : str
    verdict : Verdict
        ``holds``, ``violated`` or ``inconclusive`` (a ``str`` enum: it compares equal to,
        prints and serialises as its value; a string given is converted).
    margin : float
        ``min(a - b) - err_a - err_b``: positive proves the claim everywhere.
    min_difference : float
        ``min(a - b)`` over the states.
    state : int
        Where it is attained.
    errors : float
        ``err_a + err_b``.
    accuracy : float
        The accuracy of the verdict.
    """

    claim: str
    verdict: Verdict
    margin: float
    min_difference: float
    state: int
    errors: float
    accuracy: float = 0.0

    def __post_init__(self) -> None:
        self.verdict = Verdict(self.verdict)


def certified_check(
    claim: str,
    min_diff: float,
    state: int,
    a_at: float,
    err_a: float,
    b_at: float,
    err_b: float,
    accuracy: float = 0.0,
) -> Check:
    """:class:`Check` of ``a >= b`` from its smallest difference ``a_at - b_at`` at ``state``."""
    cmp = compare_at_least(a_at - err_a, a_at + err_a, b_at - err_b, b_at + err_b, accuracy)
    return Check(
        claim=claim,
        verdict=cmp.verdict,
        margin=float(min_diff - err_a - err_b),
        min_difference=float(min_diff),
        state=int(state),
        errors=float(err_a + err_b),
        accuracy=float(accuracy),
    )


@dataclass
class SizeResult:
    """One size of the study (one row of the report's tables); JSON-serialisable.

    ``gaps`` holds max and mean over states of ``v* - V*`` (``upper_*``), ``V* - w*``
    (``lower_*``) and ``v* - w*`` (``gap_*``) and the shares ``upper_share =
    mean(v* - V*) / mean(v* - w*)``, ``lower_share`` likewise; ``policy`` the greedy
    policy's statistics; ``checks`` the certified verdicts; ``seconds`` per stage.
    """

    instance: str
    m: int
    stations: list[int]
    n_states: int
    n_partitions: int
    source: str
    vstar: dict[str, Any]
    bounds: dict[str, Any]
    gaps: dict[str, float]
    policy: dict[str, Any]
    checks: dict[str, Check]
    seconds: dict[str, float] = field(default_factory=dict)
    peak_rss_mb: float = float("nan")
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def all_hold(self) -> bool:
        """Every certified check holds."""
        return all(c.verdict is Verdict.HOLDS for c in self.checks.values())


def save_result(res: SizeResult, path: str | Path) -> Path:
    """Write ``res`` as JSON (atomically: a temporary file renamed into place)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(asdict(res), indent=2) + "\n")
    tmp.replace(path)
    return path


def load_result(path: str | Path, params: PatrolParams | None = None) -> SizeResult | None:
    """The result saved at ``path``, or ``None`` if there is none or it was made for other
    parameters than ``params``."""
    path = Path(path)
    if not path.is_file():
        return None
    data = json.loads(path.read_text())
    if params is not None and data.get("params") != params.to_table():
        return None
    data["checks"] = {k: Check(**v) for k, v in data["checks"].items()}
    return SizeResult(**data)


# ---------------------------------------------------------------------- the passes
def _peak_rss_mb() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def greedy_pass(
    mf: MatrixFreePatrol,
    vstar: np.ndarray,
    pistar: np.ndarray,
    w_low: np.ndarray,
    v_up: np.ndarray,
    loss_tol: float,
) -> tuple[np.ndarray, dict[str, Any]]:
    """``pi_s`` (int8) greedy w.r.t. the lifted ``w_low`` and the gap and policy statistics
    (:meth:`MatrixFreePatrol.greedy_gap`, ties within :data:`GREEDY_TIE_RTOL`).

    ``loss_tol``: a one-step loss ``max_u Q*(x, u) - Q*(x, pi_s(x))`` above it counts as
    certainly suboptimal (``2 error_bound(V*)``, as the 4-station report counts).
    """
    return mf.greedy_gap(vstar, pistar, w_low, v_up, loss_tol, GREEDY_TIE_RTOL)


def vsub_pass(
    mf: MatrixFreePatrol, vstar: np.ndarray, vsub: np.ndarray, w_low: np.ndarray
) -> dict[str, Any]:
    """Max, mean and min of ``V* - V_sub`` and the smallest ``V_sub - w*`` (with states):
    :meth:`MatrixFreePatrol.vsub_stats`."""
    return mf.vsub_stats(vstar, vsub, w_low)


@contextmanager
def _stage(tr: Any, seconds: dict[str, float], name: str, description: str) -> Any:
    """Time a stage into ``seconds``; show it on the tracker (a reproduce ``Tracker``)."""
    t0 = time.perf_counter()
    if tr is None:
        yield lambda *a, **k: None
    else:
        with tr.step(name, description) as adv:
            yield adv
    seconds[name] = time.perf_counter() - t0


# ---------------------------------------------------------------------- one size
def _vstar_summary(sol: Any, vstar: np.ndarray) -> dict[str, Any]:
    return {
        "method": sol.method,
        "iterations": int(sol.iterations),
        "sweeps": int(sol.sweeps),
        "residual": float(sol.residual),
        "error_bound": float(sol.error_bound),
        "tol": float(sol.tol),
        "status": sol.status,
        "seconds": float(sol.seconds),
        "min": float(vstar.min()),
        "max": float(vstar.max()),
        "mean": float(vstar.mean()),
    }


def _checks(
    mf: MatrixFreePatrol,
    g: dict[str, Any],
    s: dict[str, Any],
    vstar: np.ndarray,
    err_v: float,
    vsub: np.ndarray,
    err_sub: float,
    bounds: Any,
) -> dict[str, Check]:
    """The four certified sandwich checks, each decided at its tightest state."""
    up, low = bounds.upper, bounds.lower
    e_up, e_low = float(bounds.upper_error), float(bounds.lower_error)

    def part(x: int) -> int:
        return int(mf.model.state_partition([x])[0])

    xu, xl, xs, xw = g["upper_argmin"], g["lower_argmin"], s["argmin"], s["low_argmin"]
    return {
        "vstar_le_upper": certified_check(
            "V*(x) <= v*(i)", g["upper_min"], xu, up[part(xu)], e_up, vstar[xu], err_v
        ),
        "lower_le_vstar": certified_check(
            "w*(i) <= V*(x)", g["lower_min"], xl, vstar[xl], err_v, low[part(xl)], e_low
        ),
        "vsub_le_vstar": certified_check(
            "V_sub(x) <= V*(x)",
            s["min"],
            xs,
            vstar[xs],
            err_v,
            vsub[xs],
            err_sub,
            accuracy=2 * (err_v + err_sub),
        ),
        "lower_le_vsub": certified_check(
            "w*(i) <= V_sub(x)", s["low_min"], xw, vsub[xw], err_sub, low[part(xw)], e_low
        ),
    }


def _policy_summary(
    g: dict[str, Any], s: dict[str, Any], ev: Any, n: int, loss_tol: float
) -> dict[str, Any]:
    return {
        "optimal_fraction": g["optimal"] / n,
        "optimal_states": g["optimal"],
        "tie_rtol": GREEDY_TIE_RTOL,
        "differs_fraction": g["differs"] / n,
        "suboptimal_fraction": g["suboptimal"] / n,
        "suboptimal_tolerance": loss_tol,
        "max_one_step_loss": g["max_one_step_loss"],
        "max_vstar_minus_vsub": s["max"],
        "max_vstar_minus_vsub_state": s["argmax"],
        "mean_vstar_minus_vsub": s["mean"],
        "vsub_residual": float(ev.residual),
        "vsub_error_bound": float(ev.error_bound),
        "vsub_sweeps": int(ev.sweeps),
        "vsub_seconds": float(ev.seconds),
        "vsub_method": str(ev.method),
    }


def _gaps(g: dict[str, Any]) -> dict[str, float]:
    keys = (
        "upper_max",
        "upper_mean",
        "lower_max",
        "lower_mean",
        "gap_max",
        "gap_mean",
        "upper_share",
        "lower_share",
    )
    return {k: float(g[k]) for k in keys}


def _bounds_summary(bounds: Any, seconds: float) -> dict[str, Any]:
    gap = bounds.upper - bounds.lower
    return {
        "method": "UBLP / LBLP fixed points (their exact LP optima, certified)",
        "upper_error": float(bounds.upper_error),
        "lower_error": float(bounds.lower_error),
        "partition_gap_max": float(gap.max()),
        "partition_gap_mean": float(gap.mean()),
        "seconds": float(seconds),
    }


def study(
    params: PatrolParams,
    name: str,
    *,
    tr: Any = None,
    log: Any = None,
    checkpoint: str | Path | None = None,
) -> SizeResult:
    """The whole study at one size, matrix-free: ``V*``, the bounds, ``pi_s``, ``V_sub``.

    Parameters
    ----------
    params : PatrolParams
    name : str
        The instance's name (for the report).
    tr : Tracker, optional
        :class:`lpbounds.patrol.reproduce.Tracker` (progress bars and stage times).
    log : callable(str), optional
        Called with a line per improvement step and stage (a long run's log file).
    checkpoint : path, optional
        A folder where ``V*`` and ``pi*`` are saved once solved (``.npy``, with their
        summary) and from which a later call with the same parameters loads them instead
        of solving again (a long run that fails after ``V*`` resumes there).

    Returns
    -------
    SizeResult
    """
    from .greedy_mc import partition_bounds

    say = log if log is not None else (lambda _s: None)
    seconds: dict[str, float] = {}
    tag = f"beyond_m{params.m}"
    mf = MatrixFreePatrol(params)
    n = mf.n_vars
    with _stage(tr, seconds, f"{tag}_bounds", f"{params.m} stations: UBLP and LBLP"):
        bounds = partition_bounds(params)
    say(f"bounds: {bounds.seconds:.1f} s, errors {bounds.upper_error:.1e} {bounds.lower_error:.1e}")

    def progress(it: int, r: float, adv: Any) -> None:
        adv(status=f"iteration {it}  residual {r:.1e}")
        say(f"V* iteration {it}: residual {r:.3e} ({time.perf_counter() - t0:.0f} s)")

    t0 = time.perf_counter()
    saved = _load_vstar(checkpoint, params)
    if saved is not None:
        vstar, pistar, vs = saved
        seconds[f"{tag}_vstar"] = vs["seconds"]
        vs = _recertify(mf, vstar, vs)
        say(f"V* loaded from {checkpoint} and certified again from the vector (one sweep)")
    else:
        with _stage(tr, seconds, f"{tag}_vstar", f"{params.m} stations: V* ({n:,} states)") as adv:
            sol = solve_vstar(mf, callback=lambda it, r: progress(it, r, adv))
        vs = _vstar_summary(sol, sol.values)
        vstar, pistar = sol.values, sol.policy
        del sol
        _save_vstar(checkpoint, params, vstar, pistar, vs)
    err_v = float(vs["error_bound"])
    say(
        f"V*: {vs['iterations']} iterations, {vs['sweeps']} sweeps, {vs['seconds']:.0f} s, "
        f"residual {vs['residual']:.3e}, error bound {err_v:.3e}"
    )

    def evaluate(pi_s: np.ndarray) -> Any:
        def every_tenth(k: int, r: float) -> None:
            if k % 10 == 0:
                say(f"V_sub sweep {k}: residual {r:.3e} ({time.perf_counter() - t1:.0f} s)")

        t1 = time.perf_counter()
        return evaluate_policy(mf, pi_s, callback=every_tenth)

    g, s, ev, checks = _measure(mf, vstar, err_v, pistar, bounds, evaluate, tr, seconds, tag, say)
    return SizeResult(
        instance=name,
        m=params.m,
        stations=list(params.stations),
        n_states=n,
        n_partitions=int(params.n_partitions),
        source="matrix-free (lpbounds.patrol.matrix_free)",
        vstar=vs,
        bounds=_bounds_summary(bounds, seconds[f"{tag}_bounds"]),
        gaps=_gaps(g),
        policy=_policy_summary(g, s, ev, n, 2 * err_v),
        checks=checks,
        seconds=seconds,
        peak_rss_mb=_peak_rss_mb(),
        params=params.to_table(),
    )


def _save_vstar(
    folder: str | Path | None,
    params: PatrolParams,
    vstar: np.ndarray,
    pistar: np.ndarray,
    summary: dict[str, Any],
) -> None:
    if folder is None:
        return
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    np.save(folder / "vstar.npy", vstar)
    np.save(folder / "pistar.npy", pistar)
    meta = {"params": params.to_table(), "vstar": summary}
    (folder / "vstar.json").write_text(json.dumps(meta, indent=2) + "\n")  # written last


def _recertify(mf: MatrixFreePatrol, vstar: np.ndarray, vs: dict[str, Any]) -> dict[str, Any]:
    """A ``V*`` read from disk is a claim until certified again: one Bellman sweep of the
    vector gives its residual and error bound (``(residual + slack) / (1 - lambda)``), which
    replace the saved ones; the status is OPTIMAL only if the residual is within the saved
    tolerance, else INACCURATE (a file edited or truncated since it was written)."""
    out = mf.new_vector()
    arg = np.empty(mf.n_vars, dtype=np.int8)
    lo, hi = mf.sweep_max(vstar, out, arg)
    del out, arg
    res = max(-lo, hi)
    vmax = check_finite("the saved V*", vstar, res)
    ok = res <= float(vs["tol"])
    return {
        **vs,
        "residual": res,
        "error_bound": error_bound(res, vmax, mf.modulus()),
        "status": str(Status.OPTIMAL if ok else Status.INACCURATE),
    }


def _load_vstar(
    folder: str | Path | None, params: PatrolParams
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]] | None:
    if folder is None or not (Path(folder) / "vstar.json").is_file():
        return None
    folder = Path(folder)
    meta = json.loads((folder / "vstar.json").read_text())
    if meta["params"] != params.to_table():
        return None
    vstar = np.load(folder / "vstar.npy")
    pistar = np.load(folder / "pistar.npy")
    if vstar.shape != (params.n_states,) or pistar.shape != (params.n_states,):
        return None
    return vstar, pistar, meta["vstar"]


def _measure(
    mf: MatrixFreePatrol,
    vstar: np.ndarray,
    err_v: float,
    pistar: np.ndarray,
    bounds: Any,
    evaluate: Any,
    tr: Any,
    seconds: dict[str, float],
    tag: str,
    say: Any,
) -> tuple[dict[str, Any], dict[str, Any], Any, dict[str, Check]]:
    """The greedy pass, the evaluation of ``pi_s`` and the checks (shared by both entries)."""
    m = mf.params.m
    with _stage(tr, seconds, f"{tag}_greedy", f"{m} stations: pi_s and the gaps"):
        pi_s, g = greedy_pass(mf, vstar, pistar, bounds.lower, bounds.upper, 2 * err_v)
    say(
        f"greedy pass: optimal fraction {g['optimal'] / mf.n_vars:.6f}, gap mean "
        f"{g['gap_mean']:.4e}, upper share {g['upper_share']:.3f}"
    )
    with _stage(tr, seconds, f"{tag}_vsub", f"{m} stations: V_sub (evaluation of pi_s)"):
        ev = evaluate(pi_s)
    del pi_s
    say(f"V_sub: {ev.sweeps} sweeps, {ev.seconds:.0f} s, residual {ev.residual:.3e}")
    with _stage(tr, seconds, f"{tag}_checks", f"{m} stations: V* - V_sub and the checks"):
        s = vsub_pass(mf, vstar, ev.values, bounds.lower)
        checks = _checks(mf, g, s, vstar, err_v, ev.values, float(ev.error_bound), bounds)
    say(
        "checks: "
        + ", ".join(f"{c.claim} {c.verdict} (margin {c.margin:.3e})" for c in checks.values())
    )
    return g, s, ev, checks


def study_from_arrays(
    params: PatrolParams,
    name: str,
    *,
    vstar: np.ndarray,
    vstar_summary: dict[str, Any],
    pistar: np.ndarray,
    bounds: Any,
    pi_s: np.ndarray,
    vsub: Any,
    tr: Any = None,
) -> SizeResult:
    """The study's numbers from an array-path run (the 4-station ``lpbounds reproduce``).

    Nothing is solved again: ``V*`` (``vstar_summary`` holds its ``error_bound``), the
    bounds (:class:`~lpbounds.patrol.greedy_mc.PartitionBounds`) and ``V_sub`` (a
    :class:`lpbounds.dp.PolicyEvaluation`) are the run's; the greedy pass recomputes
    ``pi_s`` and must find the run's (a :class:`~lpbounds.errors.ConsistencyError`
    otherwise), then measures what :func:`study` measures.
    """
    from ..errors import ConsistencyError

    seconds: dict[str, float] = {}
    tag = f"beyond_m{params.m}"
    mf = MatrixFreePatrol(params)
    err_v = float(vstar_summary["error_bound"])

    def evaluate(policy: np.ndarray) -> Any:
        if not np.array_equal(policy, np.asarray(pi_s, dtype=np.int8)):
            raise ConsistencyError(
                f"the greedy pass's pi_s differs from the run's on "
                f"{int((policy != pi_s).sum())} states"
            )
        return vsub

    vs = np.ascontiguousarray(vstar, dtype=np.float64)
    g, s, ev, checks = _measure(
        mf, vs, err_v, pistar, bounds, evaluate, tr, seconds, tag, lambda _s: None
    )
    return SizeResult(
        instance=name,
        m=params.m,
        stations=list(params.stations),
        n_states=mf.n_vars,
        n_partitions=int(params.n_partitions),
        source="array path (the lpbounds reproduce run)",
        vstar=dict(vstar_summary),
        bounds=_bounds_summary(bounds, float(getattr(bounds, "seconds", float("nan")))),
        gaps=_gaps(g),
        policy=_policy_summary(g, s, ev, mf.n_vars, 2 * err_v),
        checks=checks,
        seconds=seconds,
        peak_rss_mb=_peak_rss_mb(),
        params=params.to_table(),
    )


# ---------------------------------------------------------------------- reproduce --beyond
#: Where ``lpbounds reproduce --beyond`` keeps the 5- and 6-station results (and the
#: 6-station V* checkpoint) between runs.
DEFAULT_CACHE = "out/beyond"
#: The Monte Carlo sizes of the beyond section (:mod:`lpbounds.patrol.greedy_mc`).
MC_MODELS: tuple[str, ...] = ("patrol-m6-paper", "patrol-m8")


def _load_params(name: str) -> PatrolParams:
    from ..model.instances import load_instance
    from .instance import params_from_instance

    return params_from_instance(load_instance(name))


def run_sizes(
    sizes: tuple[int, ...] = (5, 6),
    cache: str | Path = DEFAULT_CACHE,
    tr: Any = None,
    log: Any = None,
) -> list[SizeResult]:
    """The study at each size: the result saved in ``cache`` for the same parameters, else
    computed (with a V* checkpoint in ``cache``) and saved there."""
    out = []
    for m in sizes:
        name = BEYOND_MODELS[m]
        params = _load_params(name)
        path = Path(cache) / f"{name}.json"
        res = load_result(path, params)
        if res is None:
            res = study(params, name, tr=tr, log=log, checkpoint=Path(cache) / f"{name}-vstar")
            save_result(res, path)
        out.append(res)
    return out


def from_reproduction(
    params: PatrolParams, name: str, vs: Any, bounds: Any, sp: Any, tr: Any = None
) -> SizeResult:
    """The 4-station row from :func:`lpbounds.patrol.reproduce.reproduce`'s step results
    (``VStar``, ``Bounds``, ``SandwichAndPolicy``): nothing is solved again."""
    from ..dp import PolicyEvaluation
    from .greedy_mc import PartitionBounds

    pol = sp.policy
    ev = PolicyEvaluation(
        values=np.ascontiguousarray(sp.vsub, dtype=np.float64),
        residual=pol.vsub_residual,
        error_bound=pol.vsub_error_bound,
        method=pol.vsub_method,
        sweeps=pol.vsub_sweeps,
        seconds=float("nan"),
    )
    keys = ("method", "iterations", "sweeps", "residual", "error_bound", "tol", "seconds")
    vstar_summary = {k: getattr(vs.summary, k) for k in (*keys, "min", "max", "mean")}
    vstar_summary["status"] = "optimal"  # reproduce's solve_exact raises otherwise
    pb = PartitionBounds(
        lower=bounds.w_low,
        upper=bounds.v_up,
        lower_error=float(bounds.err_low),
        upper_error=float(bounds.err_up),
        seconds=float("nan"),
    )
    return study_from_arrays(
        params,
        name,
        vstar=vs.values,
        vstar_summary=vstar_summary,
        pistar=np.asarray(vs.policy, dtype=np.int8),
        bounds=pb,
        pi_s=np.asarray(sp.pi_s, dtype=np.int8),
        vsub=ev,
        tr=tr,
    )


def monte_carlo(models: tuple[str, ...] = MC_MODELS, tr: Any = None) -> list[dict[str, Any]]:
    """:func:`~lpbounds.patrol.greedy_mc.greedy_value_mc` (default starts, paths and
    horizon) and :func:`~lpbounds.patrol.greedy_mc.greedy_table1` at each model."""
    from .greedy_mc import greedy_table1, greedy_value_mc, partition_bounds

    out = []
    for name in models:
        params = _load_params(name)
        seconds: dict[str, float] = {}
        with _stage(tr, seconds, f"beyond_mc_m{params.m}", f"{name}: pi_s by Monte Carlo"):
            pb = partition_bounds(params)
            est = greedy_value_mc(params, pb.lower, pb.upper, upper_error=pb.upper_error)
            t1 = greedy_table1(params, pb.lower)
        st = t1.statistics
        out.append(
            {
                "instance": name,
                "m": params.m,
                "n_states": int(params.n_states),
                "n_partitions": int(params.n_partitions),
                "starts": est.n_starts,
                "paths": est.paths,
                "horizon": est.horizon,
                "level": est.level,
                "truncation": est.truncation,
                "mean_half_width": float(np.mean(est.half_width)),
                "max_half_width": float(np.max(est.half_width)),
                "gap_bound_max": float(np.max(est.gap_bound)),
                # an interval wholly above v* + err contradicts V_pis <= V* <= v*: the
                # estimate (not the bound) is wrong there
                "above_upper": int(np.sum(est.ci_low > est.upper + est.upper_error)),
                "gap_bound_mean": float(np.mean(est.gap_bound)),
                "upper_minus_lower_mean": float(np.mean(est.upper - est.lower)),
                "per_start": est.rows(),
                "table1": {
                    k: getattr(st, k)
                    for k in (
                        "mean_loiters",
                        "mean_delay",
                        "worst_delay",
                        "mean_delay_plus_one",
                        "worst_delay_plus_one",
                        "n_serviced",
                    )
                },
                "table1_seeds": t1.seeds,
                "table1_steps": t1.steps,
                "visited_states": t1.visited_states,
                "seconds": seconds,
            }
        )
    return out


def plot_gap_shares(rows: list[SizeResult], path: str | Path) -> Path:
    """The figure of the beyond section: the mean gaps ``v* - V*``, ``V* - w*`` and
    ``v* - w*`` over states (left, log-log) and each side's share of the gap (right),
    against the number of states."""
    from matplotlib.ticker import NullLocator

    from .figures import save_figure, subplots

    n = [r.n_states for r in rows]
    ticks = [f"{r.n_states:.2g}\nm = {r.m}" for r in rows]
    fig, (ax1, ax2) = subplots(1, 2, figsize=(10, 4))
    for key, label, mk in (
        ("upper_mean", "mean v* - V* (UBLP side)", "v"),
        ("lower_mean", "mean V* - w* (LBLP side)", "^"),
        ("gap_mean", "mean v* - w*", "o"),
    ):
        ax1.loglog(n, [r.gaps[key] for r in rows], marker=mk, label=label)
    ax1.set_ylabel("mean over states")
    for key, label, mk in (
        ("upper_share", "share of v* - V*", "v"),
        ("lower_share", "share of V* - w*", "^"),
    ):
        ax2.semilogx(n, [r.gaps[key] for r in rows], marker=mk, label=label)
    ax2.set_ylim(0.0, 1.0)
    ax2.set_ylabel("fraction of mean(v* - w*)")
    for ax in (ax1, ax2):
        ax.set_xticks(n, ticks)
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xlabel("|S| (states)")
        ax.legend(fontsize=8)
    sizes = ", ".join(str(r.m) for r in rows)
    fig.suptitle(f"Who owns the gap between the bounds: {sizes} stations")
    fig.tight_layout()
    return save_figure(fig, path)


def _gap_rows(rows: list[SizeResult]) -> list[list[Any]]:
    out = []
    for r in rows:
        g, p, v = r.gaps, r.policy, r.vstar
        out.append(
            [
                r.m,
                r.n_states,
                r.n_partitions,
                f"{v['residual']:.1e} / {v['error_bound']:.1e}",
                g["upper_max"],
                g["upper_mean"],
                g["lower_max"],
                g["lower_mean"],
                g["gap_max"],
                g["gap_mean"],
                f"{g['upper_share']:.2f} / {g['lower_share']:.2f}",
                f"{100 * p['optimal_fraction']:.3f} %",
                p["max_vstar_minus_vsub"],
            ]
        )
    return out


def _ms(ms: list[int]) -> str:
    return ", ".join(str(m) for m in ms) if ms else "none"


def tighter_side(rows: list[SizeResult]) -> str:
    """One sentence on which bound is the tighter one (by mean and by max) at each size."""
    low_mean = [r.m for r in rows if r.gaps["lower_mean"] < r.gaps["upper_mean"]]
    low_max = [r.m for r in rows if r.gaps["lower_max"] < r.gaps["upper_max"]]
    sizes = [r.m for r in rows]
    if low_mean == sizes:
        head = "The lower bound w* is the tighter one at every size, on average over states"
    elif not low_mean:
        head = "The upper bound v* is the tighter one at every size, on average over states"
    else:
        head = f"The lower bound w* is the tighter one on average at m = {_ms(low_mean)} only"
    shares = ", ".join(f"{r.gaps['lower_share']:.2f} at m = {r.m}" for r in rows)
    return (
        f"{head} (V* - w* owns {shares} of the mean gap v* - w*); by the largest distance "
        f"over states it is the tighter one at m = {_ms(low_max)} (of {_ms(sizes)})."
    )


def report_section(
    rows: list[SizeResult], mc: list[dict[str, Any]], figure: Path | None, out: Path
) -> list[str]:
    """The markdown of the report's "Beyond the paper" section."""
    from .report import markdown_table

    exact = [r.m for r in rows if r.m > 4]
    lines = [
        f"## Beyond the paper: exact V* at {_ms(exact)} stations"
        + (", pi_s by Monte Carlo at " + _ms([e["m"] for e in mc]) if mc else "")
        + "\n",
        "The paper computes V* at 4 stations only. Here the same instance with 5 and 6 "
        "stations spread around the ring (`models/patrol-m5-paper.toml`, "
        "`models/patrol-m6-paper.toml`) is solved exactly by matrix-free sweeps "
        "(`lpbounds.patrol.matrix_free`: successors, rewards and partitions computed from "
        "the state index; the same MPI and certificate as the array path, bit for bit on "
        "the paper's instance). v* and w* are the UBLP and LBLP optima (certified fixed "
        "points), lifted to states; pi_s is greedy w.r.t. the lifted w*; V_sub its value. "
        "Means and maxima are over all states; a share is mean(v* - V*) or mean(V* - w*) "
        "over mean(v* - w*).\n",
        markdown_table(
            [
                "m",
                "states",
                "partitions",
                "V* residual / error bound",
                "max v*-V*",
                "mean v*-V*",
                "max V*-w*",
                "mean V*-w*",
                "max v*-w*",
                "mean v*-w*",
                "share v* / w*",
                "pi_s optimal",
                "max V*-V_sub",
            ],
            _gap_rows(rows),
        )
        + "\n",
        f"**What the gap shares say.** {tighter_side(rows)}\n",
        "Certified checks at every state (verdicts of "
        "`lpbounds.certification.checks.compare_at_least` at the tightest state, from V*'s, the "
        "bounds' and V_sub's certified error bounds; margin = smallest difference less the "
        "errors):\n",
        markdown_table(
            ["m", *[c.claim for c in rows[0].checks.values()]],
            [[r.m, *[f"{c.verdict} ({c.margin:.2e})" for c in r.checks.values()]] for r in rows],
        )
        + "\n",
    ]
    if figure is not None:
        rel = Path(figure).relative_to(out) if Path(figure).is_absolute() else figure
        lines.append(f"![gap shares against the number of states]({Path(rel).name})\n")
    if mc:
        lines += _mc_lines(mc)
    return lines


def _mc_lines(mc: list[dict[str, Any]]) -> list[str]:
    from .report import markdown_table

    rows = []
    for e in mc:
        t = e["table1"]
        rows.append(
            [
                e["m"],
                e["n_states"],
                f"{e['starts']} x {e['paths']:,}",
                e["horizon"],
                e["max_half_width"],
                e["gap_bound_max"],
                e["gap_bound_mean"],
                e.get("above_upper", 0),
                t["mean_loiters"],
                f"{t['mean_delay']:.2f} ({t['mean_delay_plus_one']:.2f})",
                f"{t['worst_delay']} ({t['worst_delay_plus_one']})",
            ]
        )
    e0 = mc[0]
    return [
        "**pi_s where no exact value exists** (`lpbounds.patrol.greedy_mc`): its discounted "
        "value by Monte Carlo from the documented start states (the m empty stations and "
        f"seeded random states), Student's t intervals at {100 * e0['level']:.0f} % per "
        "start plus the exact truncation bound, beside the certified v*: a statistical "
        "certificate V*(x) - V_pis(x) <= v*(i) + err - (V_hat(x) - half-width - trunc); "
        f"Table 1 of pi_s ({len(e0['table1_seeds'])} seeds x {e0['table1_steps']:,} steps, "
        "delays to the first loiter, in brackets to the end of it):\n",
        markdown_table(
            [
                "m",
                "states",
                "starts x paths",
                "horizon",
                "max CI half-width",
                "max certificate V* - V_pis",
                "mean certificate",
                "intervals above v*",
                "mean loiters",
                "mean delay",
                "worst delay",
            ],
            rows,
        )
        + "\n",
        *[
            f"**Inconsistent Monte Carlo at m = {e['m']}:** {e['above_upper']} of "
            f"{e['starts']} intervals lie wholly above the certified v* + err, which "
            "V_pis <= V* <= v* rules out: those estimates are wrong, not the bound.\n"
            for e in mc
            if e.get("above_upper", 0)
        ],
    ]


def write_beyond(
    folder: Path, rows: list[SizeResult], mc: list[dict[str, Any]], figures: bool = True
) -> tuple[list[str], dict[str, Path]]:
    """``beyond.json`` and the figure in ``folder``; returns the report lines and files."""
    files = {"beyond": Path(folder) / "beyond.json"}
    data = {
        "sizes": [asdict(r) for r in rows],
        "monte_carlo": mc,
        "tighter_side": tighter_side(rows),
    }
    files["beyond"].write_text(json.dumps(data, indent=2, default=float) + "\n")
    fig = None
    if figures:
        fig = plot_gap_shares(rows, Path(folder) / "fig8_beyond_gap_shares.png")
        files["fig8"] = fig
    return report_section(rows, mc, fig, Path(folder)), files
