r"""The greedy policy ``pi_s`` beyond exact DP: acted out on the fly, valued by Monte Carlo.

At 8 stations (``models/patrol-m8.toml``: 4.2e10 states) no successor array, no value
vector over states and no exact ``V*`` exist; the partition bounds do (``M = 207,928``,
:func:`partition_bounds`, seconds). This module acts out ``pi_s``, the policy greedy
with respect to the lower bound ``w*`` lifted to states (``V_low(x) = w*(i(x))``, paper
eq. 30), one state at a time:

* the successors of a state come from the model's own dynamics and its decoder
  (the formulas of ``lpbounds.patrol.model.successor_kernel`` and ``decode_kernel``) and
  their partitions from the key index of :mod:`lpbounds.patrol.partitions`
  (``key_index_kernel``), all in C (:mod:`lpbounds._kernels.patrolmc`, built at install;
  the paths of a start run one range per thread);
* ``Q(x, u) = R_u(x) + lambda sum_l p_l w*(i(f(x, u, Y_l)))`` is summed in outcome
  order exactly as :func:`lpbounds.dp.greedy_policy` sums it, and the action is chosen
  with its tie rule (every action within
  ``GREEDY_TIE_RTOL * max(1, |max Q|)`` of the best is tied; the lowest index wins), so
  on an instance small enough for the MDP the two policies are equal state by state.

Value by Monte Carlo (:func:`greedy_value_mc`)
----------------------------------------------
From each start state ``x``, ``paths`` independent trajectories of ``horizon`` steps,
with the alert stream of :func:`lpbounds.patrol.simulation.alert_sequence`, give the
truncated discounted returns ``G_H = sum_{t<H} lambda^t R(x_t, pi_s(x_t))``. The
estimate ``V_hat(x)`` is their mean; the interval is Student's t at the given level
(95 % by default), ``V_hat +- (t_{n-1} s / sqrt(n) + trunc)``, where the truncation error
is bounded exactly: ``|V_pis(x) - E G_H| <= trunc = lambda^H max|R| / (1 - lambda)``.
Beside it, the certified upper bound ``v*(i(x))`` (UBLP, plus its certified error) gives
the statistical certificate, at that level for each start separately:

    ``V*(x) - V_pis(x) <= v*(i(x)) + err(v*) - V_hat(x) + half-width + trunc``.

The intervals hold for each start at the stated level, not simultaneously (for that,
pass ``level = 1 - 0.05 / n_starts``, Bonferroni). The certificate takes ``V* <= v*``
from Theorem 4 (UBLP = RLP, whose optimum bounds ``V*`` from above); lpbounds checks that
with certificates wherever ``V*`` is computable (4 stations in ``lpbounds reproduce``,
5 and 6 with ``--beyond``), but at 8 stations it is the theorem's claim, not a checked
fact (the theorem rests on Claim 2, which fails on a few pairs at 4 stations).

Control variate (default on). Each path's return has subtracted

    ``C = sum_{t<H} lambda^(t+1) (w(x_(t+1)) - sum_l p_l w(f(x_t, u_t, Y_l)))``,

``w = w*`` lifted. Given the path up to ``t``, each term has mean 0 (the sum is the
expectation of ``w(x_(t+1))``; the greedy step computes it anyway), so ``E[G_H - C] =
E[G_H]``: the same estimand, the same truncation bound, and the paths stay independent,
so the t interval applies unchanged. ``G_H - C`` telescopes to ``w(x_0)`` plus the
discounted one-step errors ``R + lambda E w(x') - w(x)`` along the path (minus the end
term ``lambda^H w(x_H)``), whose spread is that of ``w``'s Bellman residual, not of the
alert stream: much smaller when ``w*`` is close to ``V_pis``.

Table 1 (:func:`greedy_table1`)
-------------------------------
Long trajectories of ``pi_s`` with the alert sequences of the 4-station run (same seeds,
steps and start state), counted by :func:`lpbounds.patrol.simulation.simulate` itself:
the visited states form a small MDP (one row per visited state, the taken transitions
filled in), on which ``simulate`` applies every counting convention of the paper's
Table 1 and checks each step against the specification's dynamics
(``mismatches`` must be 0); :func:`~lpbounds.patrol.simulation.pooled_statistics` pools
the seeds.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from .._defaults import DEFAULT_SEEDS
from .._kernels.extensions import patrolmc as _c
from .._kernels.threads import run_ranges, split_ranges
from ..dp import solve_exact
from ..errors import ConsistencyError, ValidationError
from ..model.mdp import FiniteMDP
from ..tolerances import GREEDY_TIE_RTOL, MC_TRUNCATION_TARGET
from ..validation import check_bool, check_int, check_real, check_vector
from .bounds import patrol_rows
from .model import ACTION_NAMES, PatrolModel
from .params import PatrolParams
from .partitions import block_sizes
from .simulation import SimulationResult, alert_sequence, pooled_statistics, simulate
from .summary import PolicyStatistics

__all__ = [
    "GreedyTable1",
    "GreedyValueEstimate",
    "PartitionBounds",
    "default_horizon",
    "default_starts",
    "greedy_actions",
    "greedy_simulate",
    "greedy_table1",
    "greedy_value_mc",
    "partition_bounds",
    "reward_absmax",
    "table1_markdown",
    "truncation_bound",
]

#: Default truncation error: the horizon is the smallest with ``trunc <= TRUNCATION_TARGET``
#: (:data:`lpbounds.tolerances.MC_TRUNCATION_TARGET`, where its reason is).
TRUNCATION_TARGET = MC_TRUNCATION_TARGET


# ---------------------------------------------------------------------- bounds
@dataclass(frozen=True)
class PartitionBounds:
    """LBLP's ``w*`` and UBLP's ``v*`` over the partitions, with certified errors.

    Attributes
    ----------
    lower, upper : ndarray (M,)
        The fixed points of the LBLP and UBLP rows (:func:`patrol_rows`).
    lower_error, upper_error : float
        Their certified distance to the exact optima (``residual / (1 - lambda)``).
    seconds : float
    """

    lower: np.ndarray
    upper: np.ndarray
    lower_error: float
    upper_error: float
    seconds: float


def partition_bounds(params: PatrolParams) -> PartitionBounds:
    """``w*`` and ``v*`` from the partitions alone (as ``lpbounds bounds`` computes them)."""
    _params(params)
    t0 = time.perf_counter()
    low = solve_exact(patrol_rows(params, "lower"))
    up = solve_exact(patrol_rows(params, "upper"))
    return PartitionBounds(
        lower=low.values,
        upper=up.values,
        lower_error=float(low.error_bound),
        upper_error=float(up.error_bound),
        seconds=time.perf_counter() - t0,
    )


# ---------------------------------------------------------------------- compiled steps
@dataclass(frozen=True)
class _Kernel:
    """The model's constants in the form the compiled kernels take (C,
    :mod:`lpbounds._kernels.patrolmc`: a greedy step decodes the state, forms each
    allowed action's successors and their partitions, and sums ``p_l w*(i(x'))`` in outcome
    order; it checks these tables exactly against their definition at every call)."""

    cfg: np.ndarray  # n_nodes, big_d, gamma, radix, n_travel, tb_size, lb_size, allow_empty
    station_pos: np.ndarray
    stations: np.ndarray
    w_travel: np.ndarray
    w_loiter: np.ndarray
    probs: np.ndarray
    inc: np.ndarray
    rho: float
    discount: float

    @classmethod
    def of(cls, params: PatrolParams) -> _Kernel:
        pm = PatrolModel(params)
        tb_size, lb_size = block_sizes(params)
        cfg = [params.N, params.D, params.Gamma, pm.radix, pm.n_travel, tb_size, lb_size]
        cfg.append(int(params.allow_empty_loiter))
        return cls(
            cfg=np.array(cfg, dtype=np.int64),
            station_pos=np.ascontiguousarray(pm.station_pos, dtype=np.int64),
            stations=pm.stations,
            w_travel=pm.w_travel,
            w_loiter=pm.w_loiter,
            probs=np.ascontiguousarray(params.alert_probabilities(), dtype=np.float64),
            inc=np.ascontiguousarray(params.information_increments(), dtype=np.float64),
            rho=float(params.rho),
            discount=float(params.discount),
        )

    def args(self) -> tuple[Any, ...]:
        """The tuple ``mt`` the kernels take (with the greedy tie tolerance)."""
        return (
            self.cfg,
            self.station_pos,
            self.stations,
            self.w_travel,
            self.w_loiter,
            self.probs,
            self.inc,
            self.rho,
            self.discount,
            GREEDY_TIE_RTOL,
        )


def _returns(
    x0: int, outcomes: np.ndarray, lower: np.ndarray, kernel: _Kernel, cv: bool, out: np.ndarray
) -> None:
    """``out[p]``: the discounted return of path ``p`` from ``x0`` under ``outcomes[p]``,
    minus (``cv``) the control variate ``sum_t lambda^(t+1) (w(x_(t+1)) - E_t w(x_(t+1)))``
    (C, one range of paths per thread; each path its own work arrays)."""
    args = (int(x0), outcomes, lower, kernel.args(), bool(cv), out)
    run_ranges(_c.greedy_returns, args, split_ranges(outcomes.shape[0]))


# ---------------------------------------------------------------------- inputs
def _params(params: Any) -> PatrolParams:
    """Refuse anything but :class:`PatrolParams` (a typed error, not an AttributeError)."""
    if not isinstance(params, PatrolParams):
        raise ValidationError(f"params must be a PatrolParams; got {type(params).__name__}")
    return params


def _lower(params: PatrolParams, lower: Any, name: str = "lower") -> np.ndarray:
    """A partition value vector (length M, finite), as the kernels read it."""
    _params(params)
    return check_vector(name, lower, params.n_partitions)


def _states(params: PatrolParams, x: Any, name: str) -> np.ndarray:
    """State indices (int64, in ``[0, |S|)``), refused with the offending entry named."""
    arr = np.asarray(x)
    if arr.ndim != 1 or arr.size == 0 or not np.issubdtype(arr.dtype, np.integer):
        raise ValidationError(
            f"{name} must be a non-empty 1-d array of state indices; got {arr.dtype} {arr.shape}"
        )
    n = params.n_states
    bad = np.flatnonzero((arr < 0) | (arr >= n))
    if bad.size:
        raise ValidationError(f"{name}[{bad[0]}] = {arr[bad[0]]} is not a state index in [0, {n})")
    return np.ascontiguousarray(arr, dtype=np.int64)


def reward_absmax(params: PatrolParams) -> float:
    """``max |R_u(x)|`` over every state and action (an exact bound, from the parameters).

    ``R`` is ``-rho min(taubar, Gamma)``, plus ``I(d+1) - I(d)`` for a loiter at dwell
    ``d``: affine in ``taubar``, so the extremes are at ``taubar = 0`` or ``Gamma``.
    """
    pen = _params(params).rho * params.Gamma
    inc = np.abs(params.information_increments())
    shifted = np.abs(params.information_increments() - pen)
    return float(max(pen, inc.max(initial=0.0), shifted.max(initial=0.0)))


def truncation_bound(params: PatrolParams, horizon: int) -> float:
    """``lambda^H max|R| / (1 - lambda)``: how far a return cut at ``H`` steps can be from
    the infinite-horizon one, on every path."""
    _params(params)
    horizon = check_int("horizon", horizon, lo=1)
    lam = params.discount
    return float(lam**horizon * reward_absmax(params) / (1.0 - lam))


def default_horizon(params: PatrolParams, target: float = TRUNCATION_TARGET) -> int:
    """The smallest horizon whose :func:`truncation_bound` is at most ``target``."""
    _params(params)
    target = check_real("target", target, lo=0.0, lo_open=True)
    lam, rmax = params.discount, reward_absmax(params)
    if lam == 0.0 or rmax == 0.0:
        return 1
    h = max(1, math.ceil(math.log(target * (1.0 - lam) / rmax) / math.log(lam)))
    while truncation_bound(params, h) > target:  # rounding of the logarithms
        h += 1
    return h


def default_starts(params: PatrolParams, *, n_random: int = 12, seed: int = 0) -> np.ndarray:
    """The documented start states of :func:`greedy_value_mc`.

    First the ``m`` states "at station ``k``, heading clockwise, not loitering, no alert"
    (``l = stations[k], w = +1, d = 0, tau = 0``), then ``n_random`` state indices drawn
    uniformly from ``[0, |S|)`` (``numpy.random.default_rng(seed)``; duplicates kept).
    """
    _params(params)
    n_random = check_int("n_random", n_random, lo=0)
    seed = check_int("seed", seed, lo=0)
    pm = PatrolModel(params)
    st = np.asarray(params.stations, dtype=np.int64)
    zero = pm.encode(st, np.ones_like(st), np.zeros_like(st), np.zeros((st.size, params.m)))
    rng = np.random.default_rng(seed)
    rand = rng.integers(0, params.n_states, size=n_random, dtype=np.int64)
    return np.concatenate([zero, rand]).astype(np.int64)


# ---------------------------------------------------------------------- the policy
def greedy_actions(params: PatrolParams, lower: Any, states: Any) -> np.ndarray:
    """``pi_s`` at the given states, computed on the fly (no MDP arrays).

    Parameters
    ----------
    params : PatrolParams
    lower : array (M,)
        The partition values the policy is greedy for (``w*`` of LBLP).
    states : array of int
        State indices (the model's encoding, :class:`~lpbounds.patrol.model.PatrolModel`).

    Returns
    -------
    ndarray of int8
        Action index per state (0 continue, 1 reverse, 2 loiter), chosen with the tie
        rule of :func:`lpbounds.dp.greedy_policy`.
    """
    v = _lower(params, lower)
    xs = _states(params, states, "states")
    out = np.empty(xs.size, dtype=np.int8)
    k = _Kernel.of(params)
    run_ranges(_c.greedy_actions, (xs, v, k.args(), out), split_ranges(xs.size))
    return out


# ---------------------------------------------------------------------- value by Monte Carlo
@dataclass(frozen=True)
class GreedyValueEstimate:
    """Monte Carlo value of ``pi_s`` from a set of start states, beside the bounds.

    The arrays have one entry per start state.

    Attributes
    ----------
    starts : ndarray of int64
        Start state indices; ``partitions`` their partition indices.
    start_labels : tuple of str
        ``"station k empty"`` (``l = stations[k-1], w = +1, d = 0, tau = 0``), ``"random"``
        (:func:`default_starts`) or ``"given"``.
    mean : ndarray
        ``V_hat(x)``: the mean truncated discounted return over ``paths`` paths.
    std : ndarray
        Sample standard deviation of the returns (``ddof = 1``).
    half_width : ndarray
        Student's t half-width at ``level``: ``t_{paths-1} std / sqrt(paths)``.
    truncation : float
        ``lambda^horizon max|R| / (1 - lambda)``, added to every interval.
    ci_low, ci_high : ndarray
        ``mean -+ (half_width + truncation)``: the interval on ``V_pis(x)``.
    upper : ndarray
        ``v*(i(x))`` (UBLP, lifted); ``upper_error`` its certified error.
    lower : ndarray
        ``w*(i(x))`` (LBLP, lifted): ``pi_s``'s own lower bound, for comparison.
    paths, horizon, level, seed : int, int, float, int
    interval : str
        ``"student-t"``.
    control_variate : bool
        Whether the returns had the control variate subtracted (``std`` is then the
        standard deviation of the corrected returns).
    seconds : float
        Wall time of the simulation (the C kernels, one range of paths per thread).
    """

    starts: np.ndarray
    start_labels: tuple[str, ...]
    partitions: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    half_width: np.ndarray
    truncation: float
    ci_low: np.ndarray
    ci_high: np.ndarray
    upper: np.ndarray
    upper_error: float
    lower: np.ndarray
    paths: int
    horizon: int
    level: float
    seed: int
    interval: str
    control_variate: bool
    seconds: float

    @property
    def n_starts(self) -> int:
        return int(self.starts.size)

    @property
    def gap_bound(self) -> np.ndarray:
        """``v*(i(x)) + upper_error - ci_low``: at ``level``, ``V*(x) - V_pis(x)`` is at
        most this (the statistical certificate)."""
        return self.upper + self.upper_error - self.ci_low

    def rows(self) -> list[dict[str, Any]]:
        """One dict per start, for tables and JSON."""
        keys = ("mean", "std", "half_width", "ci_low", "ci_high", "upper", "lower", "gap_bound")
        out = []
        for i in range(self.n_starts):
            row: dict[str, Any] = {
                "start": self.start_labels[i],
                "state": int(self.starts[i]),
                "partition": int(self.partitions[i]),
            }
            row.update({k: float(getattr(self, k)[i]) for k in keys})
            out.append(row)
        return out

    def summary(self) -> dict[str, Any]:
        """Plain numbers for JSON: the settings, the extremes and :meth:`rows`.

        ``contradicts_upper`` counts starts whose interval lies wholly above
        ``v* + err(v*)`` (impossible if ``V_pis <= V* <= v*``: a failed interval or a
        wrong bound), ``below_lower`` those wholly below ``w*`` (``w* <= V_pis`` holds
        when the lifted ``w*`` is a subsolution, as the paper's chain states; a count,
        not an error).
        """
        return {
            "n_starts": self.n_starts,
            "paths": self.paths,
            "horizon": self.horizon,
            "level": self.level,
            "interval": self.interval,
            "truncation": self.truncation,
            "upper_error": self.upper_error,
            "seed": self.seed,
            "seconds": self.seconds,
            "max_half_width": float(self.half_width.max()),
            "gap_bound_min": float(self.gap_bound.min()),
            "gap_bound_max": float(self.gap_bound.max()),
            "bound_gap_max": float((self.upper - self.lower).max()),
            "contradicts_upper": int((self.ci_low > self.upper + self.upper_error).sum()),
            "below_lower": int((self.ci_high < self.lower).sum()),
            "rows": self.rows(),
        }

    def markdown(self) -> str:
        """The per-start table (Markdown): ``w*``, ``V_hat +- half-width``, ``v*``, the
        bound gap and the statistical certificate."""
        from .report import markdown_table

        header = ["start", "state", "w*(x)", f"V_pis(x): mean +- {self.level:.0%} t half-width",
                  "v*(x)", "v* - w*", "V* - V_pis <="]  # fmt: skip
        rows = [
            [str(r["start"]), f"{r['state']:,}", f"{r['lower']:.5f}",
             f"{r['mean']:.5f} +- {r['half_width']:.5f}", f"{r['upper']:.5f}",
             f"{r['upper'] - r['lower']:.5f}", f"{r['gap_bound']:.5f}"]
            for r in self.rows()
        ]  # fmt: skip
        return markdown_table(header, rows, align="lrrrrrr")


def _start_states(
    params: PatrolParams, starts: Any, seed: int
) -> tuple[np.ndarray, tuple[str, ...]]:
    """The start states of :func:`greedy_value_mc` and their labels."""
    if starts is not None and not (
        isinstance(starts, (int, np.integer)) and not isinstance(starts, bool)
    ):
        xs = _states(params, starts, "starts")
        return xs, ("given",) * xs.size
    n = 12 + params.m if starts is None else check_int("starts", starts, lo=params.m)
    xs = default_starts(params, n_random=n - params.m, seed=seed)
    labels = [f"station {k + 1} empty" for k in range(params.m)] + ["random"] * (n - params.m)
    return xs, tuple(labels)


def greedy_value_mc(
    params: PatrolParams,
    lower: Any,
    upper: Any,
    *,
    starts: Any = None,
    paths: int = 4_000,
    horizon: int | None = None,
    level: float = 0.95,
    upper_error: float = 0.0,
    seed: int = 0,
    control_variate: bool = True,
) -> GreedyValueEstimate:
    """Estimate ``V_pis`` by Monte Carlo and bound ``V* - V_pis`` with ``v*``.

    Parameters
    ----------
    params : PatrolParams
    lower, upper : array (M,)
        ``w*`` (LBLP: ``pi_s`` is greedy for it) and ``v*`` (UBLP) over the partitions,
        as :func:`partition_bounds` returns them.
    starts : None, int or array of int
        Start states: ``None`` for :func:`default_starts` (the ``m`` empty stations and
        12 seeded random states), an int ``n >= m`` for the ``m`` stations and
        ``n - m`` random states, or explicit state indices.
    paths : int
        Independent paths per start (>= 2). The t interval needs enough paths to see
        the rare events (alerts are rare at ``alpha = 1/60``, and the corrected returns
        are nearly constant between them): on the 320-state instance, 95 % intervals
        covered the exact value at 92.5 % of 80 starts with 1,500 paths and 96 % with
        4,000 (the default).
    horizon : int, optional
        Steps per path; default :func:`default_horizon` (truncation error <= 1e-6).
    level : float
        Confidence level of each start's Student's t interval (default 95 %).
    upper_error : float
        Certified error of ``upper`` (``PartitionBounds.upper_error``), added to the
        certificate.
    seed : int
        Seeds the random starts and, with the start's position, each start's alert
        stream (:func:`~lpbounds.patrol.simulation.alert_sequence`).
    control_variate : bool
        Subtract the zero-mean control variate built from ``lower`` (module docstring):
        the same expectation, a far smaller variance when ``lower`` is close to
        ``V_pis``. False gives the plain returns.

    Returns
    -------
    GreedyValueEstimate

    Raises
    ------
    ValidationError
        Naming the argument: a bound vector of the wrong length or not finite, a start
        that is not a state, ``paths < 2``, ``horizon < 1``, ``level`` outside (0, 1).
    """
    lo = _lower(params, lower, "lower")
    up = _lower(params, upper, "upper")
    seed = check_int("seed", seed, lo=0)
    paths = check_int("paths", paths, lo=2)
    horizon = default_horizon(params) if horizon is None else check_int("horizon", horizon, lo=1)
    level = check_real("level", level, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    upper_error = check_real("upper_error", upper_error, lo=0.0)
    control_variate = check_bool("control_variate", control_variate)
    xs, labels = _start_states(params, starts, seed)
    k = _Kernel.of(params)
    p0 = float(k.probs[0])
    returns = np.empty((xs.size, paths))
    t0 = time.perf_counter()
    for i, x in enumerate(xs):
        sub = int(np.random.SeedSequence([seed, i]).generate_state(1)[0])
        y = alert_sequence(paths * horizon, p0, params.m, sub).reshape(paths, horizon)
        _returns(int(x), y, lo, k, control_variate, returns[i])
    seconds = time.perf_counter() - t0
    parts = PatrolModel(params).state_partition(xs)
    return GreedyValueEstimate(
        starts=xs,
        start_labels=labels,
        partitions=parts,
        **_intervals(returns, level, truncation_bound(params, horizon)),
        upper=up[parts],
        upper_error=upper_error,
        lower=lo[parts],
        paths=paths,
        horizon=horizon,
        level=level,
        seed=seed,
        interval="student-t",
        control_variate=control_variate,
        seconds=seconds,
    )


def _intervals(returns: np.ndarray, level: float, trunc: float) -> dict[str, Any]:
    """Per row of ``returns``: mean, std, Student's t half-width, the interval widened by
    the truncation bound ``trunc``."""
    paths = returns.shape[1]
    mean = returns.mean(axis=1)
    std = returns.std(axis=1, ddof=1)
    half = float(stats.t.ppf(0.5 + level / 2, paths - 1)) * std / math.sqrt(paths)
    return {
        "mean": mean,
        "std": std,
        "half_width": half,
        "truncation": trunc,
        "ci_low": mean - half - trunc,
        "ci_high": mean + half + trunc,
    }


# ---------------------------------------------------------------------- Table 1
class _VisitedModel:
    """The states one trajectory visited, as the model :func:`simulate` reads: ``params``
    and ``mdp()`` (one state per visited state, the taken transitions filled in)."""

    def __init__(self, params: PatrolParams, mdp: FiniteMDP) -> None:
        self.params = params
        self._mdp = mdp

    def mdp(self) -> FiniteMDP:
        return self._mdp


def _visited_chain(
    params: PatrolParams, states: np.ndarray, actions: np.ndarray, outcomes: np.ndarray
) -> tuple[_VisitedModel, np.ndarray, np.ndarray, int]:
    """(model, local policy, components, local start) of a trajectory's visited states."""
    pm = PatrolModel(params)
    uniq, inv = np.unique(states, return_inverse=True)
    n = uniq.size
    l, w, d, tau = pm.decode(uniq)
    allowed = pm.allowed(l, d, tau)
    policy = np.zeros(n, dtype=np.int64)  # continue (always allowed) at an unvisited end
    policy[inv[:-1]] = actions
    if not np.array_equal(policy[inv[:-1]], actions):  # pragma: no cover - a deterministic policy
        raise ConsistencyError("pi_s chose two different actions in one state")
    succ = np.empty((n, 3, params.m + 1), dtype=np.int64)
    succ[:] = np.arange(n)[:, None, None]
    succ[inv[:-1], actions, outcomes] = inv[1:]
    rewards = pm.rewards(d, tau)
    rewards[~allowed] = 0.0
    mdp = FiniteMDP(
        succ,
        params.alert_probabilities(),
        rewards,
        params.discount,
        allowed=allowed,
        action_names=ACTION_NAMES,
        copy=False,
    )
    comps = np.column_stack([l, w, d, tau]).astype(np.int64)
    return _VisitedModel(params, mdp), policy, comps, int(inv[0])


def greedy_simulate(
    params: PatrolParams,
    lower: Any,
    outcomes: Any,
    *,
    start: int | None = None,
    seed: int | None = None,
) -> SimulationResult:
    """One trajectory of ``pi_s`` under the given alert sequence, counted by
    :func:`~lpbounds.patrol.simulation.simulate` (every convention of Table 1).

    Parameters
    ----------
    params : PatrolParams
    lower : array (M,)
        ``w*``, the partition values ``pi_s`` is greedy for.
    outcomes : array of int
        The disturbance of each step (:func:`~lpbounds.patrol.simulation.alert_sequence`).
    start : int, optional
        Initial state index; default ``simulate``'s: ``l = 0, w = +1, d = 0``, no alert.
    seed : int, optional
        Recorded in the result (the seed that made ``outcomes``).

    Raises
    ------
    ValidationError
        If ``lower``, ``outcomes`` or ``start`` do not fit the model.
    ConsistencyError
        If a step disagrees with the specification's dynamics (``simulate``'s check).
    """
    lo = _lower(params, lower)
    y = np.asarray(outcomes)
    if y.ndim != 1 or y.size == 0 or not np.issubdtype(y.dtype, np.integer):
        raise ValidationError(f"outcomes must be a non-empty 1-d integer array; got {y.shape}")
    if y.min() < 0 or y.max() > params.m:
        bad = int(np.flatnonzero((y < 0) | (y > params.m))[0])
        raise ValidationError(f"outcomes[{bad}] = {y[bad]} is not an outcome 0..{params.m}")
    y = np.ascontiguousarray(y, dtype=np.int64)
    pm = PatrolModel(params)
    if start is None:
        x0 = int(pm.encode(0, 1, 0, np.zeros((1, params.m), dtype=np.int64))[0])
    else:
        x0 = int(_states(params, np.array([start]), "start")[0])
    res, _ = _greedy_run(params, lo, y, x0, seed)
    return res


def _greedy_run(
    params: PatrolParams, lo: np.ndarray, y: np.ndarray, x0: int, seed: int | None
) -> tuple[SimulationResult, np.ndarray]:
    """:func:`greedy_simulate` on checked inputs; also the visited state indices."""
    states = np.empty(y.size + 1, dtype=np.int64)
    actions = np.empty(y.size, dtype=np.int64)
    k = _Kernel.of(params)
    _c.greedy_trajectory(x0, y, lo, k.args(), states, actions)
    model, policy, comps, x_local = _visited_chain(params, states, actions, y)
    res = simulate(model, policy, y, start=x_local, policy_name="pi_s", seed=seed, components=comps)
    if res.mismatches:
        raise ConsistencyError(
            f"pi_s trajectory (seed {seed}): {res.mismatches} steps disagree with the "
            f"specification's dynamics (first at step {res.first_mismatch})"
        )
    res.final_state = int(states[-1])  # the model's index, not the visited chain's
    return res, states


@dataclass(frozen=True)
class GreedyTable1:
    """Table 1's row of ``pi_s`` at one size (pooled over the seeds).

    Attributes
    ----------
    statistics : PolicyStatistics
        :func:`~lpbounds.patrol.simulation.pooled_statistics` of the runs: mean loiters,
        mean and worst service delay under every convention of the 4-station table.
    seeds : list of int
    steps : int
        Steps per seed.
    visited_states : int
        Distinct states the runs visited (of ``|S|``).
    seconds : float
    """

    statistics: PolicyStatistics
    seeds: list[int]
    steps: int
    visited_states: int
    seconds: float

    def summary(self) -> dict[str, Any]:
        """Table 1's numbers and the counts behind them, for JSON."""
        s = self.statistics
        keys = (
            "mean_loiters",
            "mean_delay",
            "worst_delay",
            "mean_delay_plus_one",
            "worst_delay_plus_one",
            "mean_delay_capped",
            "worst_delay_capped",
            "std_mean_delay",
            "std_mean_loiters",
            "n_arrivals",
            "n_serviced",
            "mismatches",
        )
        out: dict[str, Any] = {k: getattr(s, k) for k in keys}
        out.update(seeds=self.seeds, steps=self.steps, visited_states=self.visited_states)
        out["seconds"] = self.seconds
        return out


def table1_markdown(tables: dict[str, GreedyTable1]) -> str:
    """Table 1 rows of ``pi_s`` (Markdown), one per named size, with the 4-station
    conventions: delay to the first loiter, uncapped; in brackets to its end."""
    from .report import markdown_table

    header = ["instance", "mean loiters", "mean delay (+1)", "worst delay (+1)",
              "alerts serviced", "states visited"]  # fmt: skip
    rows = []
    for name, t in tables.items():
        s = t.statistics
        rows.append(
            [str(name), f"{s.mean_loiters:.2f}",
             f"{s.mean_delay:.2f} ({s.mean_delay_plus_one:.2f})",
             f"{s.worst_delay} ({s.worst_delay_plus_one})", f"{s.n_serviced:,}",
             f"{t.visited_states:,}"]
        )  # fmt: skip
    return markdown_table(header, rows, align="lrrrrr")


def greedy_table1(
    params: PatrolParams,
    lower: Any,
    *,
    steps: int = 60_000,
    seeds: Sequence[int] = DEFAULT_SEEDS,
) -> GreedyTable1:
    """Table 1 for ``pi_s``: ``steps`` steps per seed, pooled, as at 4 stations.

    The alert sequence of each seed is ``alert_sequence(steps, p_0, m, seed)`` and the
    start is ``simulate``'s default, as in :func:`lpbounds.patrol.reproduce.reproduce`
    (defaults: its 5 seeds and 60,000 steps).
    """
    lo = _lower(params, lower)
    steps = check_int("steps", steps, lo=1)
    seed_list = [check_int(f"seeds[{i}]", s, lo=0) for i, s in enumerate(seeds)]
    if not seed_list:
        raise ValidationError("seeds must name at least one seed")
    p0 = float(params.alert_probabilities()[0])
    t0 = time.perf_counter()
    pm = PatrolModel(params)
    x0 = int(pm.encode(0, 1, 0, np.zeros((1, params.m), dtype=np.int64))[0])
    runs, visited = [], []
    for s in seed_list:
        res, states = _greedy_run(params, lo, alert_sequence(steps, p0, params.m, s), x0, s)
        runs.append(res)
        visited.append(states)
    return GreedyTable1(
        statistics=PolicyStatistics(**pooled_statistics(runs)),
        seeds=seed_list,
        steps=steps,
        visited_states=int(np.unique(np.concatenate(visited)).size),
        seconds=time.perf_counter() - t0,
    )
