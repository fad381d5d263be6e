"""The typed results of the reproduction's steps: what ``summary.json`` holds.

Each step of :func:`lpbounds.patrol.reproduce.reproduce` returns one of these dataclasses;
:class:`Summary` gathers them, ``summary.json`` is :func:`to_dict` of it, and
:mod:`lpbounds.patrol.report` reads the same objects by attribute, so a misspelt name
fails at once (``AttributeError``, or a type checker) instead of printing a default.

Fields marked ``optional`` (see :func:`optional`) are left out of ``summary.json`` when
they are ``None`` (the checks that only ``general="aggregate"`` makes); every other
``None`` is written as ``null``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..status import Status

__all__ = [
    "ClaimsSummary",
    "Counts",
    "Inequality",
    "LPSummary",
    "Lemma3Summary",
    "MonteCarloSummary",
    "PolicyStatistics",
    "PolicySummary",
    "SandwichSummary",
    "Summary",
    "TheoremsSummary",
    "Timing",
    "VStarSummary",
    "jsonable",
    "optional",
    "to_dict",
]


def optional() -> Any:
    """A field that defaults to ``None`` and is omitted from :func:`to_dict` when ``None``."""
    return field(default=None, metadata={"omit_none": True})


def to_dict(obj: Any) -> Any:
    """Plain dicts and lists of a (nested) dataclass, in field order; numpy scalars to
    Python numbers; optional ``None`` fields left out."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out = {}
        for f in dataclasses.fields(obj):
            value = getattr(obj, f.name)
            if value is None and f.metadata.get("omit_none"):
                continue
            out[f.name] = to_dict(value)
        return out
    if isinstance(obj, dict):
        return {k: to_dict(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_dict(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def jsonable(obj: Any) -> Any:
    """:func:`to_dict` with string keys and non-finite floats as ``null`` / ``"inf"``."""
    obj = to_dict(obj)
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [jsonable(v) for v in obj]
    if isinstance(obj, float) and not np.isfinite(obj):
        return None if np.isnan(obj) else ("inf" if obj > 0 else "-inf")
    return obj


# ---------------------------------------------------------------------- 1. model, V*
@dataclass
class Counts:
    """``|S|`` and ``M`` by eq. (27)-(28) and counted, and the paper's example."""

    n_states_eq27: int
    n_partitions_eq28: int
    n_states_counted: int
    n_partitions_counted: int
    n_state_action_pairs: int
    paper: dict[str, int]


@dataclass
class VStarSummary:
    """The exact ``V*`` and ``pi*`` (modified policy iteration)."""

    method: str
    iterations: int
    sweeps: int
    residual: float
    error_bound: float
    tol: float
    seconds: float
    min: float
    max: float
    mean: float
    policy_counts: dict[str, int]


# ---------------------------------------------------------------------- 2. UBLP, LBLP
@dataclass
class LPSummary:
    """One of UBLP / LBLP: the LP solve beside its solver-free fixed point."""

    solver: str
    solver_options: dict[str, Any]
    status: Status
    n_rows: int
    objective: float
    primal_residual: float
    residual_tol: float
    dual_residual: float | None
    gap: float | None
    solve_seconds: float | None
    compile_seconds: float | None
    fixed_point_seconds: float
    fixed_point_residual: float
    fixed_point_error_bound: float
    lp_minus_fixed_point_max_abs: float
    lp_values_min: float
    lp_values_max: float
    #: certified ``max |LP values - exact LP optimum|`` from the returned point
    #: (:attr:`lpbounds.formulations.base.LPResult.error_bound`; ``inf`` without one)
    certified_error_bound: float


@dataclass
class TheoremsSummary:
    """Theorems 3-4: the general RLP / NLP of the full MDP against UBLP / LBLP."""

    method: str
    rlp_residual: float
    rlp_distance_bound: float
    nlp_residual: float
    nlp_distance_bound: float
    reward_spread_within_partitions: float
    theorem4_max_abs_diff: float
    theorem3_max_abs_diff: float
    tolerance_theorem4: float
    tolerance_theorem3: float
    # general="aggregate" only: the aggregated rows solved exactly
    nlp_rows_shared_with_rlp: bool | None = optional()
    rlp_rows: int | None = optional()
    nlp_rows: int | None = optional()
    rlp_error_bound: float | None = optional()
    nlp_error_bound: float | None = optional()


@dataclass
class Lemma3Summary:
    """Lemma 3's ``|T(i, u)|``: construction against the paper's formula."""

    pairs: int
    type1_partitions: int
    pairs_differing: int
    differing_taubar_values: list[int]
    differing_all_type1_loiter: bool
    examples: list[dict[str, Any]]
    # general="aggregate" only: counted from the full MDP's aggregated rows
    full_mdp_rows_equal_construction: bool | None = optional()
    full_mdp_rows_differ_pairs: int | None = optional()


# ---------------------------------------------------------------------- 3. Claims
@dataclass
class ClaimsSummary:
    """Claims 1-2 on every ordered pair of states and of partitions."""

    pairs: int
    tolerance: float
    violations: int
    max_excess: float
    violations_new_alert: int
    violations_new_alert_own_station: int
    violations_same_alert_status: int
    pairs_same_alert_status: int
    max_excess_same_alert_status: float | None
    examples: list[dict[str, Any]]
    partition_pairs: int
    partition_violations: int
    partition_max_excess: float | None
    partition_examples: list[dict[str, Any]]
    figure4_chain: dict[str, Any]


# ---------------------------------------------------------------------- 4. sandwich
@dataclass
class Inequality:
    """``a <= b`` over all states: ``min(b - a)``, violations beyond ``tolerance``."""

    margin: float
    tolerance: float
    violations: int
    worst_state: dict[str, Any]


@dataclass
class SandwichSummary:
    """``w*(i) <= V*(x) <= v*(i)`` with margins, and the partition gaps."""

    lower_margin: float
    upper_margin: float
    lower: Inequality
    upper: Inequality
    partition_gap_max: float
    partition_gap_mean: float
    mean_vstar_minus_vlow: float
    mean_vup_minus_vstar: float
    lp_lower_margin: float
    lp_upper_margin: float
    #: ``min_x (V*(x) - err(V*)) - w_upper(i(x))`` with ``w_upper`` LBLP's certified upper
    #: bracket on its exact optimum: > 0 proves ``w*(i) <= V*(x)`` everywhere, from the
    #: returned points alone (``None`` when the LP result has no certificate)
    certified_lower_margin: float | None
    #: ``min_x v_lower(i(x)) - (V*(x) + err(V*))`` with ``v_lower`` UBLP's certified lower
    #: bracket: > 0 proves ``V*(x) <= v*(i)``
    certified_upper_margin: float | None


@dataclass
class PolicySummary:
    """The greedy policy ``pi_s`` w.r.t. ``V_low`` and its value ``V_sub``."""

    differs_fraction: float
    differs_states: int
    suboptimal_fraction: float
    suboptimal_tolerance: float
    max_one_step_loss: float
    max_vstar_minus_vsub: float
    max_vstar_minus_vsub_state: dict[str, Any]
    mean_vstar_minus_vsub: float
    vsub_residual: float
    vsub_error_bound: float
    vsub_sweeps: int
    vsub_method: str
    chain: dict[str, Inequality]
    pi_s_counts: dict[str, int]


# ---------------------------------------------------------------------- 5. Monte Carlo
@dataclass
class PolicyStatistics:
    """:func:`lpbounds.patrol.simulation.pooled_statistics` of one policy (every key of
    that dictionary is a field: a key added or renamed there fails here, loudly)."""

    n_steps: int
    n_arrivals: int
    n_serviced: int
    n_merged: int
    n_absorbed: int
    n_unserviced: int
    n_censored_loiters: int
    mean_loiters: float
    mean_delay: float
    worst_delay: int
    mean_delay_capped: float
    worst_delay_capped: int
    mean_delay_visit: float
    worst_delay_visit: int
    mean_delay_plus_one: float
    worst_delay_plus_one: int
    mean_delay_all_arrivals: float
    fraction_full_dwell: float
    fraction_delay_le_10: float
    loiter_steps_fraction: float
    mismatches: int
    per_seed: dict[str, list[Any]]
    std_mean_delay: float
    std_mean_loiters: float


@dataclass
class MonteCarloSummary:
    """Section 6's simulation of ``pi*`` and ``pi_s`` (Table 1)."""

    pi_star: PolicyStatistics
    pi_s: PolicyStatistics
    seeds: list[int]
    n_steps_per_seed: int
    conventions: dict[str, Any]

    def policy(self, key: str) -> PolicyStatistics:
        """``"pi_star"`` or ``"pi_s"``."""
        if key not in ("pi_star", "pi_s"):
            raise KeyError(key)
        return self.pi_star if key == "pi_star" else self.pi_s


# ---------------------------------------------------------------------- the whole
@dataclass
class Timing:
    """Wall and CPU seconds and the peak resident memory after each step."""

    seconds: dict[str, float] = field(default_factory=dict)
    peak_rss_mb: dict[str, float] = field(default_factory=dict)
    cpu_seconds: dict[str, float] = field(default_factory=dict)
    seconds_total: float = float("nan")


@dataclass
class Summary:
    """Everything ``summary.json`` holds, in its order.

    The top-level copies (``theorem3_max_abs_diff``, ``claim2_violations``, ...) are the
    headline numbers scripts read without knowing the nesting.
    """

    instance: str
    params: dict[str, Any]
    machine: dict[str, Any]
    date: str
    n_states: int
    n_partitions: int
    counts: Counts
    vstar: VStarSummary
    bounds: dict[str, LPSummary]
    theorems: TheoremsSummary
    theorem3_max_abs_diff: float
    theorem4_max_abs_diff: float
    lemma3: Lemma3Summary
    claims: ClaimsSummary
    claim2_violations: int
    sandwich: SandwichSummary
    policy: PolicySummary
    monte_carlo: MonteCarloSummary
    paper_table1: dict[str, dict[str, Any]]
    seconds: dict[str, float]
    peak_rss_mb: dict[str, float]
    cpu_seconds: dict[str, float]
    seconds_total: float
