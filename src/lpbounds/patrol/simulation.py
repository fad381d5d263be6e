r"""Monte Carlo of the perimeter patrol (paper Section 6, Table 1 and Figure 7).

The simulator follows one trajectory of the patrol MDP under a fixed policy and a given
sequence of disturbances, and records every alert from its arrival to the end of its
service. The state index always comes from the MDP's own successor table
(``x' = successors[x, u, y]``); alongside, a compiled kernel applies the dynamics ``f``
of ``docs/patrol-model.md`` to the state's components *independently* and counts every step
on which the two disagree (:attr:`SimulationResult.mismatches`, which must be 0), so the
simulation doubles as a check of the model on the visited states.

Alert arrivals
--------------
Alerts form a Poisson stream of rate ``alpha`` per unit time and at most one arrives per
step: with probability ``1 - p_0 = 1 - exp(-alpha)`` one alert arrives at a station drawn
uniformly (:func:`alert_sequence`); the same sequence is used for every policy compared.

Conventions (what is counted, and when)
---------------------------------------
* An alert that arrives with the disturbance of step ``t`` is *pending* from time
  ``t + 1`` on, where the model shows it as ``tau_j(t + 1) = 1``. Its true delay at time
  ``s > t`` is ``s - t`` (the uncapped ``tau_j(s)``).
* **Service delay** (the primary convention): the time from arrival to the step ``s`` at
  which the UAV starts loitering at the station (``l(s) = j``, ``d(s) = 0``, ``u(s) = 0``),
  ``delay = s - t``: the model's ``tau_j`` at that moment, *not* capped at ``Gamma``.
  In this model the UAV reaches a station and starts loitering on the same step, so this
  is also the delay "until the UAV arrives at the station to service it".
* Reported beside it: ``delay_capped = min(delay, Gamma)`` (the model's ``tau``),
  ``delay_visit`` = time to the first step the UAV is at the station after the arrival,
  loitering or passing through, and ``delay + 1`` (to the end of the first loiter).
* **Loiters**: the number of consecutive loiter actions at the station from the start of
  the service (the dwell ``d`` reached when the UAV leaves; at most ``D``). A service still
  running when the simulation stops is *censored*: its delay counts, its loiters do not.
* **Merged alerts**: an alert arriving at a station that already has a pending alert is
  merged by the model (``tau_j`` keeps counting from the first). It is not a new serviced
  alert; the record of the pending alert counts it in ``merged``, and
  :func:`alert_statistics` also reports the mean delay over *all* arrivals, with each
  merged alert given its own delay (service start minus its own arrival).
* **Absorbed alerts**: an alert arriving at the station where the UAV is loitering on that
  step is cleared by the loiter (``tau_j' = 0``): counted in ``absorbed``, delay 0, not a
  serviced alert.
* Alerts still pending at the end are counted in ``unserviced`` (censored).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._kernels.extensions import patrolmc as _c
from ..errors import ValidationError

__all__ = [
    "SimulationResult",
    "alert_sequence",
    "alert_statistics",
    "pooled_statistics",
    "simulate",
    "spec_step",
]

#: Action index -> control ``u`` (contract: 0 continue, 1 reverse, 2 loiter).
U_OF_ACTION = np.array([1, -1, 0], dtype=np.int64)


# ---------------------------------------------------------------------- disturbances
def alert_sequence(n_steps: int, p0: float, m: int, seed: int) -> np.ndarray:
    """The outcome index of each step: 0 (no alert, prob. ``p0``) or ``k`` in ``1..m``.

    A Poisson stream of rate ``alpha`` thinned to at most one alert per unit time, as in
    the model: ``p0 = exp(-alpha)``, and an alert picks its station uniformly.
    """
    if n_steps < 1 or m < 1 or not (0.0 < p0 <= 1.0):
        raise ValidationError(f"need n_steps >= 1, m >= 1, 0 < p0 <= 1; got {n_steps}, {m}, {p0}")
    rng = np.random.default_rng(seed)
    alert = rng.random(n_steps) >= p0
    station = rng.integers(1, m + 1, size=n_steps)
    return np.where(alert, station, 0).astype(np.int64)


# ---------------------------------------------------------------------- the dynamics f
def spec_step(
    components: Any,
    action: Any,
    outcome: Any,
    stations: Any,
    N: int,
    Gamma: int,
) -> np.ndarray:
    """The dynamics ``f`` of ``docs/patrol-model.md`` on state components, vectorised.

    Parameters
    ----------
    components : array (k, 3 + m)
        Columns ``l, w, d, tau_1..tau_m``.
    action : array (k,)
        0 continue (``u = +1``), 1 reverse (``u = -1``), 2 loiter (``u = 0``).
    outcome : array (k,)
        0 no alert, ``j`` in ``1..m``: a new alert at the ``j``-th station.

    Returns
    -------
    ndarray (k, 3 + m)
        The successors' components. Written separately from the model so that tests
        and :func:`simulate` can check the model's ``step`` against it.
    """
    c = np.atleast_2d(np.asarray(components, dtype=np.int64))
    st = np.asarray(stations, dtype=np.int64)
    m = st.size
    a = np.broadcast_to(np.asarray(action, dtype=np.int64), c.shape[:1])
    y = np.broadcast_to(np.asarray(outcome, dtype=np.int64), c.shape[:1])
    if c.shape[1] != 3 + m:
        raise ValidationError(f"components must have 3 + m = {3 + m} columns; got {c.shape}")
    u = U_OF_ACTION[a]
    l, w, d, tau = c[:, 0], c[:, 1], c[:, 2], c[:, 3:]
    out = np.empty_like(c)
    move = u != 0
    out[:, 0] = np.where(move, (l + w * u) % N, l)
    out[:, 1] = np.where(move, w * u, 1)
    out[:, 2] = np.where(move, 0, d + 1)
    here = (~move)[:, None] & (l[:, None] == st[None, :])
    new = y[:, None] == np.arange(1, m + 1)[None, :]
    nt = np.where(tau > 0, np.minimum(tau + 1, Gamma), np.where(new, 1, 0))
    out[:, 3:] = np.where(here, 0, nt)
    return out


# ---------------------------------------------------------------------- the kernel
#: counts of the simulator (``patrolmc.c``): arrivals, merged, absorbed, loiter steps,
#: mismatches, first mismatch step, empty loiter steps, unused
_COUNTS = 8


def _simulate_kernel(
    x0: int, policy: np.ndarray, successors: np.ndarray, comps: np.ndarray,
    stations: np.ndarray, N: int, Gamma: int, outcomes: np.ndarray, check: bool,
) -> tuple[Any, ...]:  # fmt: skip
    """One trajectory, compiled (C, :mod:`lpbounds._kernels.patrolmc`): the per-alert
    records (station, arrival, start, first visit, loiters, complete, merged, merged delay
    sum), the counts, the unserviced alerts and the final state. The simulator checks
    every index it reads (a ValueError names the step, never a wild read)."""
    cap = outcomes.shape[0] + 1
    records = [np.empty(cap, np.int64) for _ in range(4)]
    records += [np.zeros(cap, np.int64), np.zeros(cap, np.bool_)]
    records += [np.zeros(cap, np.int64), np.zeros(cap, np.int64)]
    counts = np.empty(_COUNTS, np.int64)
    st, arr, start, visit, loiters, done, merged, merged_delay = records
    n_rec, n_unserviced, final = _c.simulate(
        x0, policy, successors, comps, stations, N, Gamma, outcomes, check,
        st, arr, start, visit, loiters, done, merged, merged_delay, counts,
    )  # fmt: skip
    return (*(r[:n_rec].copy() for r in records), counts, n_unserviced, final)


# ---------------------------------------------------------------------- results
@dataclass
class SimulationResult:
    """One simulated trajectory; one entry per serviced alert in the per-alert arrays.

    Attributes
    ----------
    station : ndarray of int
        Index of the station (in ``params.stations`` order).
    arrival, start : ndarray of int
        Step of the alert's arrival (its disturbance) and of its first loiter.
    delay : ndarray of int
        ``start - arrival``: the true (uncapped) service delay.
    delay_capped : ndarray of int
        ``min(delay, Gamma)``, the model's ``tau`` at the start of the service.
    delay_visit : ndarray of int
        Time to the UAV's first step at the station after the arrival.
    loiters : ndarray of int
        Consecutive loiters of the service (valid where ``complete``).
    complete : ndarray of bool
        False for a service still running at the end (loiters censored).
    merged : ndarray of int
        Later alerts at the same station merged into this one.
    merged_delay_sum : ndarray of int
        Sum of the merged alerts' own delays (service start minus their arrival).
    n_steps, n_arrivals, n_merged, n_absorbed, n_unserviced : int
    n_loiter_steps, n_empty_loiter_steps : int
        All loiter actions; those not attributed to an alert (only with
        ``allow_empty_loiter``).
    mismatches : int
        Steps on which the model's successor disagreed with :func:`spec_step`'s
        dynamics or with the alert bookkeeping (must be 0); ``first_mismatch`` is the
        first such step (-1 if none).
    final_state : int
    """

    policy_name: str
    seed: int | None
    station: np.ndarray
    arrival: np.ndarray
    start: np.ndarray
    delay: np.ndarray
    delay_capped: np.ndarray
    delay_visit: np.ndarray
    loiters: np.ndarray
    complete: np.ndarray
    merged: np.ndarray
    merged_delay_sum: np.ndarray
    n_steps: int
    n_arrivals: int
    n_merged: int
    n_absorbed: int
    n_unserviced: int
    n_loiter_steps: int
    n_empty_loiter_steps: int
    mismatches: int
    first_mismatch: int
    final_state: int

    @property
    def n_serviced(self) -> int:
        """Alerts whose service started."""
        return int(self.delay.size)


def simulate(
    model: Any,
    policy: Any,
    outcomes: Any,
    *,
    start: int | None = None,
    policy_name: str = "policy",
    seed: int | None = None,
    check: bool = True,
    components: Any = None,
) -> SimulationResult:
    """Simulate the patrol under ``policy`` for ``len(outcomes)`` steps.

    Parameters
    ----------
    model : PatrolModel
        Provides ``params`` (``stations``, ``N``, ``Gamma``), ``mdp()``,
        ``state_components()`` and ``encode``.
    policy : array (n_states,) of int
        Action index per state (0 continue, 1 reverse, 2 loiter).
    outcomes : array of int
        The disturbance of each step (:func:`alert_sequence`).
    start : int, optional
        Initial state; default ``l = 0, w = +1, d = 0``, no alert.
    check : bool
        Check every step against :func:`spec_step`'s dynamics (cheap; default on).
    components : array (n_states, 3 + m), optional
        ``model.state_components()`` if already at hand (building it costs more than
        simulating 60,000 steps on the paper's instance).

    Raises
    ------
    ValidationError
        If the policy or outcomes do not fit the model, or the policy picks a
        disallowed action on the trajectory.
    """
    params = model.params
    mdp = model.mdp()
    n = mdp.n_states
    pol = np.asarray(policy)
    if pol.shape != (n,) or not np.issubdtype(pol.dtype, np.integer):
        raise ValidationError(f"policy must be {n} action indices; got {pol.shape} {pol.dtype}")
    bad = ~mdp.allowed[np.arange(n), np.clip(pol, 0, mdp.n_actions - 1)] | (pol < 0)
    if bad.any():
        x = int(np.flatnonzero(bad)[0])
        raise ValidationError(f"policy[{x}] = {int(pol[x])} is not an allowed action of state {x}")
    y = np.ascontiguousarray(outcomes, dtype=np.int64)
    m = len(params.stations)
    if y.ndim != 1 or y.size == 0 or y.min() < 0 or y.max() > m:
        raise ValidationError(f"outcomes must be a non-empty 1-d array of 0..{m}")
    comps = np.ascontiguousarray(model.state_components() if components is None else components)
    if comps.shape != (n, 3 + m):
        raise ValidationError(f"state components must have shape {(n, 3 + m)}; got {comps.shape}")
    if not np.issubdtype(comps.dtype, np.integer):
        raise ValidationError(f"state components must be integers; got {comps.dtype}")
    if start is None:
        start = int(
            np.asarray(model.encode(0, 1, 0, np.zeros((1, m), dtype=np.int64))).reshape(-1)[0]
        )
    succ = np.ascontiguousarray(mdp.successors)
    out = _simulate_kernel(
        int(start),
        np.ascontiguousarray(pol, dtype=np.int64),
        succ,
        comps,
        np.asarray(params.stations, dtype=np.int64),
        int(params.N),
        int(params.Gamma),
        y,
        bool(check),
    )
    st, arr, s, vis, loit, done, mg, mgd, counts, unserv, final = out
    delay = s - arr
    return SimulationResult(
        policy_name=policy_name,
        seed=seed,
        station=st,
        arrival=arr,
        start=s,
        delay=delay,
        delay_capped=np.minimum(delay, int(params.Gamma)),
        delay_visit=vis - arr,
        loiters=loit,
        complete=done,
        merged=mg,
        merged_delay_sum=mgd,
        n_steps=int(y.size),
        n_arrivals=int(counts[0]),
        n_merged=int(counts[1]),
        n_absorbed=int(counts[2]),
        n_unserviced=int(unserv),
        n_loiter_steps=int(counts[3]),
        n_empty_loiter_steps=int(counts[6]),
        mismatches=int(counts[4]),
        first_mismatch=int(counts[5]),
        final_state=int(final),
    )


# ---------------------------------------------------------------------- statistics
def _stats(results: list[SimulationResult]) -> dict[str, Any]:
    delay = np.concatenate([r.delay for r in results])
    capped = np.concatenate([r.delay_capped for r in results])
    visit = np.concatenate([r.delay_visit for r in results])
    done = np.concatenate([r.complete for r in results])
    loiters = np.concatenate([r.loiters for r in results])[done]
    merged = np.concatenate([r.merged for r in results])
    merged_delay = np.concatenate([r.merged_delay_sum for r in results])
    absorbed = sum(r.n_absorbed for r in results)
    n_all = delay.size + int(merged.sum()) + absorbed

    def mean(a: np.ndarray) -> float:
        return float(a.mean()) if a.size else float("nan")

    def worst(a: np.ndarray) -> int:
        return int(a.max()) if a.size else 0

    return {
        "n_steps": int(sum(r.n_steps for r in results)),
        "n_arrivals": int(sum(r.n_arrivals for r in results)),
        "n_serviced": int(delay.size),
        "n_merged": int(merged.sum()),
        "n_absorbed": int(absorbed),
        "n_unserviced": int(sum(r.n_unserviced for r in results)),
        "n_censored_loiters": int((~done).sum()),
        "mean_loiters": mean(loiters),
        "mean_delay": mean(delay),
        "worst_delay": worst(delay),
        "mean_delay_capped": mean(capped),
        "worst_delay_capped": worst(capped),
        "mean_delay_visit": mean(visit),
        "worst_delay_visit": worst(visit),
        "mean_delay_plus_one": mean(delay + 1),
        "worst_delay_plus_one": worst(delay + 1),
        "mean_delay_all_arrivals": (
            float((delay.sum() + merged_delay.sum()) / n_all) if n_all else float("nan")
        ),
        "fraction_full_dwell": float(np.mean(loiters == loiters.max())) if loiters.size else 0.0,
        "fraction_delay_le_10": float(np.mean(delay <= 10)) if delay.size else 0.0,
        "loiter_steps_fraction": float(
            sum(r.n_loiter_steps for r in results) / max(1, sum(r.n_steps for r in results))
        ),
        "mismatches": int(sum(r.mismatches for r in results)),
    }


def alert_statistics(result: SimulationResult) -> dict[str, Any]:
    """Mean loiters (complete services), mean and worst delay, under every convention.

    Keys: ``mean_loiters``, ``mean_delay``, ``worst_delay`` (true, uncapped delay to the
    first loiter), the same with suffixes ``_capped``, ``_visit``, ``_plus_one``,
    ``mean_delay_all_arrivals`` (merged alerts with their own delays, absorbed ones with
    0), counts of arrivals, serviced, merged, absorbed, unserviced and censored alerts,
    ``loiter_steps_fraction`` (loiter actions per step) and ``mismatches``.
    """
    return _stats([result])


def pooled_statistics(results: list[SimulationResult]) -> dict[str, Any]:
    """:func:`alert_statistics` over the alerts of several runs pooled, plus the spread
    of the per-run means (``per_seed`` lists, ``std_mean_delay``, ``std_mean_loiters``)."""
    if not results:
        raise ValidationError("no simulation results to pool")
    out = _stats(results)
    per = [_stats([r]) for r in results]
    out["per_seed"] = {
        "seed": [r.seed for r in results],
        "mean_loiters": [p["mean_loiters"] for p in per],
        "mean_delay": [p["mean_delay"] for p in per],
        "worst_delay": [p["worst_delay"] for p in per],
    }
    for key in ("mean_delay", "mean_loiters"):
        vals = np.array([p[key] for p in per], dtype=float)
        out[f"std_{key}"] = float(vals.std(ddof=1)) if vals.size > 1 else 0.0
    return out
