r"""Verification campaigns: claims checked on thousands of seeded instances, counterexamples shrunk.

A **campaign** draws ``n`` instances from named **families** and checks every claim
(:mod:`lpbounds.studies.claims`: the paper's results, built in, and your own conjectures) on
each with every solver, with the certified verdicts of :mod:`lpbounds.studies.verify`
(*holds*, *violated*, *inconclusive*). One record per (instance, claim, solver).

Instances
    Instance ``k`` of a campaign with seed ``S`` is drawn by ``numpy.random.default_rng([S,
    k])``: its family (weighted, :data:`FAMILY_WEIGHTS`) and its own seed. The instance is a
    function of ``(family, seed)`` alone (:func:`campaign_instance`), and records name it
    so: ``instance`` is ``"family:seed"``, with the columns ``family`` and ``seed``. Every
    family draws a discount from 0 to 0.9999 (:func:`draw_discount`), a reward scale from
    1e-6 to 1e6 (rewards multiplied by it) and a partition of one of the kinds
    :data:`PARTITION_KINDS`:

    ``garnet``
        Random MDPs (2-40 states, 1-3 actions, 1-4 outcomes, sometimes one shared
        distribution ``p_l``), rewards of either sign.
    ``masked-garnet``
        The same with 30-70 % of the (state, action) pairs disallowed (every state keeps
        one).
    ``shelf``
        The shelf of known models (:mod:`lpbounds.model.shelf`) at small random
        parameters: forest management, gridworld, admission queue, inventory, savings.
    ``patrol``
        Small perimeter patrol instances (3-6 nodes, 1-2 stations; 17-130 states), half
        of them with the paper's partition of Section 4.2.

    Partitions: ``random`` (1 to ``n/2`` blocks), ``coarse`` (2-3 blocks), ``singletons``,
    ``value-ordered`` (states sorted by ``V*``, cut into 2 to ``n/2`` runs of consecutive
    values: the partition aggregation theory favours) and ``one-block``. A model with a
    sink (``mdp.sink``; no family draws one today) keeps it in a block of its own in every
    kind, as :func:`~lpbounds.model.generators.random_partition` of a model does.

Batches, disk and resuming
    The instances run in batches of ``batch_size`` consecutive indices, serially, on one of
    Dask's local schedulers or on a Dask cluster (``scheduler``: the helper
    :func:`lpbounds.studies.compare.dask_map` that ``compare`` uses; checked, and an address
    connected to, before anything is written). With ``out``, each finished batch is written
    at once (``batches/batch-NNNNNN.csv`` or ``.parquet``, atomically) with its entry in
    ``manifest.json`` (atomically, before the file is renamed into place: file name, number
    of records, instance range, SHA-256, lpbounds version and the fingerprints of its
    claims), so an interrupted campaign keeps what it finished. ``campaign.json`` records
    the arguments, the lpbounds version and every claim's fingerprint
    (:func:`~lpbounds.studies.claims.claim_fingerprint`).

    Running it again with the same arguments into the same folder resumes it, and every
    batch on disk is checked against the manifest first (its entry, the hash, the
    instances, that it parses, the count, a record for each (instance, claim, solver)
    due): one that fails is named in a note, moved into ``rejected/`` (never
    deleted) and recomputed, so the campaign ends with the same records as an
    uninterrupted run. A folder whose ``campaign.json`` or manifest cannot be read, written
    before the manifest existed, holding other arguments, or whose claims (a conjecture's
    source, the lpbounds version) changed since is refused with nothing changed; with
    ``rerun_changed`` the changed claims' records are recomputed instead (the old files
    moved into ``rejected/``). At the end the
    records on disk, read back and checked, are counted against those due
    (:meth:`Batch.due`): batches that lack some are named in ``CampaignResult.missing`` and
    fail the campaign. ``out`` then holds ``records.csv`` (and ``records.parquet``),
    ``summary.csv`` (per claim and solver, :func:`~lpbounds.studies.verify.summarize`),
    ``counterexamples/`` (shrunk instances as model files, ``counterexamples.csv``),
    ``campaign.json``, ``manifest.json`` and ``metadata.json`` (versions, machine, command
    line, as ``compare`` writes them; the records due and missing; the run's notes).

Shrinking
    Every *violated* record (with ``shrink_inconclusive``, every *inconclusive* one too) is
    shrunk (:func:`lpbounds.studies.shrink.shrink`) while the verdict of that claim and
    solver stays the same, and the smallest instance found is written as a model file that
    ``lpbounds solve`` and ``lpbounds verify`` read. The start is re-tested first (nothing is
    written when it does not show the verdict), and each file is loaded back and the claim
    run on it again before it is reported (also a file from an earlier run).

Rational arithmetic
    With ``arithmetic="rational"`` every claim is also decided exactly on every instance
    (:mod:`lpbounds.studies.verify`, "Rational arithmetic"): ``verdict`` is the exact one,
    *holds* or *violated*, and the records add :data:`~lpbounds.studies.verify.EXACT_COLUMNS`
    (``float_verdict``, the exact difference, each solve's ``inside_bracket`` and exact
    error, ``certificate``). The arithmetic, ``exact_size_limit`` and ``certificates`` are
    among the campaign's arguments in ``campaign.json``, so a resume never mixes
    arithmetics. With ``certificates`` each decided claim's certificate is written into
    ``out/certificates/`` (:func:`~lpbounds.studies.exact_claims.certificate_name`) and
    listed with its SHA-256 in its batch's manifest entry: a resume checks them with the
    batch (a certificate missing or changed: the batch is recomputed). An instance above
    ``exact_size_limit`` gets an *error* record per claim and solver due, whose ``error``
    is the one-line :class:`~lpbounds.errors.SizeLimitError` (size, limit, how to lift it):
    its claims were not decided. Shrinking keeps a step only while the **exact** verdict
    stays, and writes the counterexample's certificate beside its model file
    (``counterexamples/<name>.certificate.json``).

Record columns: :data:`CAMPAIGN_COLUMNS` (:data:`~lpbounds.studies.verify.RECORD_COLUMNS`,
``error``, then the instance's :data:`INSTANCE_COLUMNS`; in rational arithmetic
:func:`campaign_columns`, with the exact ones before ``error``); :data:`TIMING_COLUMNS`
(and in rational arithmetic :data:`EXACT_TIMING_COLUMNS`) are the only ones that differ
between two runs of one campaign. ``verdict`` is one of
:data:`~lpbounds.studies.verify.OUTCOMES`: an *error* record (a predicate that raised,
exited or returned no verdict; an instance that could not be built or checked) says why in
``error``.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._defaults import VERSION
from ..errors import OutputError, SizeLimitError, SolverNotInstalledError, ValidationError
from ..formulations import resolve_solver
from ..model.generators import garnet, random_partition
from ..model.mdp import FiniteMDP
from ..model.partition import Partition, with_sink_block
from ..outputs import file_sha256, write_atomic, write_text_atomic
from ..tolerances import LP_COMPARE_RTOL
from .claims import (
    REMARK2,
    BuiltinClaim,
    Claim,
    Conjecture,
    claim_fingerprint,
    claim_names,
    resolve_claims,
    run_claims,
    run_remark2,
)
from .shrink import shrink, size_of, write_model
from .verify import (
    EXACT_COLUMNS,
    INSTANCE_CHECKS,
    OUTCOMES,
    RECORD_COLUMNS,
    Record,
    VerdictRecords,
    VerifyInstance,
    check_arithmetic,
    check_exact_method,
    default_solvers,
    due_solvers,
    exact_interval,
    make_record,
    records_frame,
)

if TYPE_CHECKING:  # annotations only
    import pandas as pd

__all__ = [
    "CAMPAIGN_COLUMNS",
    "CAMPAIGN_FILE",
    "CERTIFICATES_DIR",
    "EXACT_TIMING_COLUMNS",
    "FAMILIES",
    "FAMILY_WEIGHTS",
    "FOLDER_VERSION",
    "INSTANCE_COLUMNS",
    "MANIFEST_FILE",
    "PARTITION_KINDS",
    "REJECTED_DIR",
    "TIMING_COLUMNS",
    "Batch",
    "CampaignInstance",
    "CampaignResult",
    "Counterexample",
    "campaign_columns",
    "campaign_instance",
    "draw_discount",
    "instance_plan",
    "read_records",
    "run_batch",
    "run_campaign",
    "size_error",
]

#: A campaign's progress: ``progress(done, total, note)`` after each batch on disk
#: (``note`` says which), and during shrinking (``done == total`` then).
CampaignProgress = Callable[[int, int, str], None]

# ---------------------------------------------------------------------- families
#: The partition kinds a family draws from (patrol instances also use ``"patrol"``).
PARTITION_KINDS: tuple[str, ...] = ("random", "coarse", "singletons", "value-ordered", "one-block")

#: Columns that describe a campaign's instance, after the verdict columns.
INSTANCE_COLUMNS: tuple[str, ...] = (
    "campaign_index",
    "family",
    "seed",
    "model",
    "n_states",
    "n_actions",
    "n_outcomes",
    "n_blocks",
    "discount",
    "reward_scale",
    "partition_kind",
)

#: Every column of a campaign's records, in order.
CAMPAIGN_COLUMNS: tuple[str, ...] = (*RECORD_COLUMNS, "error", *INSTANCE_COLUMNS)

#: The columns that differ between two runs of one campaign (wall-clock measurements).
TIMING_COLUMNS: tuple[str, ...] = ("solve_seconds", "compile_seconds")

#: In rational arithmetic, the exact work's time: it too differs between two runs.
EXACT_TIMING_COLUMNS: tuple[str, ...] = ("exact_seconds",)


def campaign_columns(arithmetic: str = "float") -> tuple[str, ...]:
    """Every column of a campaign's records in ``arithmetic``: :data:`CAMPAIGN_COLUMNS`,
    and in rational arithmetic :data:`~lpbounds.studies.verify.EXACT_COLUMNS` before
    ``error``."""
    if arithmetic == "float":
        return CAMPAIGN_COLUMNS
    return (*RECORD_COLUMNS, *EXACT_COLUMNS, "error", *INSTANCE_COLUMNS)


_STRING_COLUMNS = (
    "check",
    "claim",
    "instance",
    "solver",
    "verdict",
    "detail",
    "lp_status",
    "solver_status",
    "error",
    "family",
    "model",
    "partition_kind",
    "float_verdict",
    "exact_difference",
    "inside_bracket",
    "exact_error",
    "exact_value_error",
    "certificate",
)


def draw_discount(rng: np.random.Generator) -> float:
    """A discount in ``[0, 0.9999]``: 0 (5 %), uniform on ``[0, 0.5)`` (15 %), on ``[0.5,
    0.9)`` (30 %), on ``[0.9, 0.99)`` (25 %), or ``1 - 10^-u`` with ``u`` uniform on ``[2,
    4]`` (25 %: 0.99 to 0.9999)."""
    kind = int(rng.choice(5, p=[0.05, 0.15, 0.30, 0.25, 0.25]))
    if kind == 0:
        return 0.0
    if kind == 4:
        return float(1.0 - 10.0 ** -rng.uniform(2.0, 4.0))
    lo, hi = ((0.0, 0.5), (0.5, 0.9), (0.9, 0.99))[kind - 1]
    return float(rng.uniform(lo, hi))


def _reward_scale(rng: np.random.Generator) -> float:
    """``10^u``, ``u`` uniform on ``[-6, 6]``."""
    return float(10.0 ** rng.uniform(-6.0, 6.0))


def _scaled(mdp: FiniteMDP, scale: float) -> FiniteMDP:
    rewards = np.where(mdp.allowed, np.asarray(mdp.rewards) * scale, 0.0)
    return FiniteMDP(
        mdp.successors, mdp.probabilities, rewards, mdp.discount, mdp.allowed, sink=mdp.sink
    )


Drawn = tuple[FiniteMDP, dict[str, Any], Partition | None]


def _garnet(rng: np.random.Generator, masked: bool) -> Drawn:
    n = int(rng.integers(2, 41))
    n_actions = int(rng.integers(2 if masked else 1, 4))
    scale = _reward_scale(rng)
    low = -scale if rng.random() < 0.5 else 0.0
    mdp = garnet(
        n,
        n_actions,
        int(rng.integers(1, 5)),
        draw_discount(rng),
        seed=int(rng.integers(2**31)),
        shared_probabilities=bool(rng.random() < 0.3),
        reward_range=(low, scale),
        allowed_fraction=float(rng.uniform(0.3, 0.7)) if masked else 1.0,
    )
    return mdp, {"model": "garnet", "reward_scale": scale}, None


def _shelf(rng: np.random.Generator) -> Drawn:
    from ..model import shelf

    lam = draw_discount(rng)
    which = str(rng.choice(["forest", "gridworld", "admission_queue", "inventory", "savings"]))
    if which == "forest":
        mdp = shelf.forest(
            int(rng.integers(2, 31)),
            float(rng.uniform(1, 10)),
            float(rng.uniform(1, 10)),
            float(rng.uniform(0, 0.5)),
            lam,
        )
    elif which == "gridworld":
        rows, cols = int(rng.integers(1, 6)), int(rng.integers(2, 6))
        cells = rng.integers([0, 0, 0, 0], [rows, cols, rows, cols])
        jump = (*(int(t) for t in cells), float(rng.uniform(1, 10)))
        mdp = shelf.gridworld(rows, cols, [jump], -1.0, lam)
    elif which == "admission_queue":
        rates = tuple(float(r) for r in rng.uniform(0.5, 5.0, 2))
        rewards = (1.0, float(rng.uniform(1, 100)))
        mdp = shelf.admission_queue(
            int(rng.integers(1, 16)), rates, float(rng.uniform(0.2, 2.0)), rewards, lam
        )
    elif which == "inventory":
        mdp = shelf.inventory(int(rng.integers(1, 16)), 0.2, 2.0, float(rng.uniform(0.2, 0.9)), lam)
    else:
        mdp = shelf.savings(int(rng.integers(1, 16)), int(rng.integers(1, 6)), 0.5, lam)
    scale = _reward_scale(rng)
    return _scaled(mdp, scale), {"model": which, "reward_scale": scale}, None


def _patrol(rng: np.random.Generator) -> Drawn:
    from ..patrol.instance import model_for
    from ..patrol.params import PatrolParams

    n_nodes = int(rng.integers(3, 7))
    stations = tuple(sorted(int(s) for s in rng.choice(n_nodes, int(rng.integers(1, 3)), False)))
    params = PatrolParams(
        N=n_nodes,
        stations=stations,
        D=int(rng.integers(1, 3)),
        Gamma=int(rng.integers(1, 4)),
        discount=draw_discount(rng),
    )
    model = model_for(params)
    scale = _reward_scale(rng)
    own = model.partition() if rng.random() < 0.5 else None  # else a drawn kind
    name = f"patrol N={n_nodes} stations={list(stations)} D={params.D} Gamma={params.Gamma}"
    return _scaled(model.mdp(), scale), {"model": name, "reward_scale": scale}, own


#: The families by name: ``draw(rng) -> (mdp, description, partition or None)``.
FAMILIES: dict[str, Callable[[np.random.Generator], Drawn]] = {
    "garnet": lambda rng: _garnet(rng, masked=False),
    "masked-garnet": lambda rng: _garnet(rng, masked=True),
    "shelf": _shelf,
    "patrol": _patrol,
}

#: How often a campaign draws each family (relative weights).
FAMILY_WEIGHTS: dict[str, float] = {
    "garnet": 4.0,
    "masked-garnet": 3.0,
    "shelf": 2.0,
    "patrol": 1.0,
}


def _partition(kind: str, mdp: FiniteMDP, rng: np.random.Generator) -> Partition:
    """A partition of ``kind`` of ``mdp``'s states; a sink (``mdp.sink``) keeps a block of
    its own in every kind (``one-block``: the other states in one), as
    :func:`~lpbounds.model.generators.random_partition` of the model does."""
    n = mdp.n_user_states  # the states but the sink; all of them without one
    if kind == "singletons":
        return Partition.singletons(mdp.n_states)
    if kind == "one-block":
        return with_sink_block(np.zeros(n, dtype=np.int64), mdp.sink)
    if kind == "coarse":
        m = min(n, int(rng.integers(2, 4)))
        return random_partition(mdp, m + int(mdp.sink), seed=int(rng.integers(2**31)))
    low = 1 if kind == "random" else min(n, 2)
    m = int(rng.integers(low, max(low, n // 2) + 1))
    if kind == "random":
        return random_partition(mdp, m + int(mdp.sink), seed=int(rng.integers(2**31)))
    lo, hi = exact_interval(mdp, "pi")  # value-ordered: runs of consecutive V*
    order = np.argsort(0.5 * (lo + hi)[:n], kind="stable")
    labels = np.empty(n, dtype=np.int64)
    labels[order] = np.arange(n) * m // n
    return with_sink_block(labels, mdp.sink)


@dataclass
class CampaignInstance(VerifyInstance):
    """A campaign's instance: the MDP and partition of ``(family, seed)`` and what was drawn
    (``params``: the record's :data:`INSTANCE_COLUMNS` but ``campaign_index``)."""

    family: str = ""
    seed: int = 0
    params: dict[str, Any] = field(default_factory=dict)


def campaign_instance(family: str, seed: int) -> CampaignInstance:
    """The instance ``(family, seed)``: the same MDP and partition on every machine.

    Parameters
    ----------
    family : str
        A name of :data:`FAMILIES`.
    seed : int
        The instance's seed (a record's ``seed``), ``>= 0``.

    Returns
    -------
    CampaignInstance
        Named ``"family:seed"``.
    """
    draw = FAMILIES.get(family)
    if draw is None:
        raise ValidationError(f"family: unknown family {family!r}; known: {', '.join(FAMILIES)}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValidationError(f"seed must be an integer >= 0; got {seed!r}")
    rng = np.random.default_rng(int(seed))
    mdp, desc, own = draw(rng)
    if own is not None:
        kind, part = "patrol", own
    else:
        kind = str(rng.choice(PARTITION_KINDS))
        part = _partition(kind, mdp, rng)
    params = {
        "family": family,
        "seed": int(seed),
        "model": desc["model"],
        "n_states": mdp.n_states,
        "n_actions": mdp.n_actions,
        "n_outcomes": mdp.n_outcomes,
        "n_blocks": part.n_partitions,
        "discount": float(mdp.discount),
        "reward_scale": float(desc["reward_scale"]),
        "partition_kind": kind,
    }
    return CampaignInstance(f"{family}:{int(seed)}", mdp, part, family, int(seed), params)


def instance_plan(n: int, seed: int, families: Sequence[str]) -> list[tuple[int, str, int]]:
    """The campaign's instances: ``(k, family, instance seed)`` for ``k = 0..n-1``.

    Instance ``k`` is drawn by ``numpy.random.default_rng([seed, k])``: a family of
    ``families`` (weighted by :data:`FAMILY_WEIGHTS`), then its seed in ``[0, 2^32)``. The
    plan of the first ``n`` instances is the start of the plan of more.
    """
    weights = np.array([FAMILY_WEIGHTS.get(f, 1.0) for f in families], dtype=np.float64)
    weights /= weights.sum()
    out = []
    for k in range(n):
        rng = np.random.default_rng([seed, k])
        family = families[int(rng.choice(len(families), p=weights))]
        out.append((k, family, int(rng.integers(2**32))))
    return out


# ---------------------------------------------------------------------- one batch
@dataclass(frozen=True)
class Batch:
    """One unit of a campaign's work: the instances ``items`` (``(k, family, seed)``), or
    Remark 2 (``number`` -1, no items), with the claims and solvers to check."""

    number: int
    items: tuple[tuple[int, str, int], ...]
    claims: tuple[Claim, ...]
    solvers: tuple[str, ...]
    n_costs: int
    rtol: float
    seed: int
    exact_method: str = "pi"
    arithmetic: str = "float"
    exact_size_limit: int | None = None
    certificates: str | None = None

    @property
    def stem(self) -> str:
        """The batch file's name without suffix."""
        return "remark2" if self.number < 0 else f"batch-{self.number:06d}"

    @property
    def instances(self) -> list[int] | None:
        """``[first, last]`` campaign index of its instances (None for Remark 2)."""
        return None if self.number < 0 else [self.items[0][0], self.items[-1][0]]

    def due(self) -> set[tuple[int, str, str]]:
        """The ``(campaign_index, check, solver)`` that must each have a record or more:
        every instance x claim x solver (a built-in check's solvers:
        :func:`~lpbounds.studies.verify.due_solvers`; a solver-free conjecture: "exact"),
        and Remark 2 once per solver (``campaign_index`` -1)."""
        if self.number < 0:
            return {(-1, REMARK2, s) for s in self.solvers} if self._has_remark2() else set()
        per = [(c.name, s) for c in self.claims if c.name != REMARK2 for s in _solvers_of(c, self)]
        return {(k, name, s) for k, _, _ in self.items for name, s in per}

    def _has_remark2(self) -> bool:
        return any(c.name == REMARK2 for c in self.claims)


def _solvers_of(claim: Claim, batch: Batch) -> list[str]:
    """The solvers a claim gives records for on one instance (see :meth:`Batch.due`)."""
    if isinstance(claim, BuiltinClaim):
        return due_solvers(claim.name, batch.solvers)
    return list(batch.solvers) if claim.uses_solver else ["exact"]


#: The ``claim`` of the records of an instance that could not be built or checked.
NOT_CHECKED = "the instance could not be checked"


def _in_record_order(claims: Sequence[Claim]) -> list[Claim]:
    """Claims in the order of their records on an instance: the built-in checks in
    :data:`~lpbounds.studies.verify.INSTANCE_CHECKS` order, then the conjectures."""
    builtin = {c.name: c for c in claims if isinstance(c, BuiltinClaim) and c.name != REMARK2}
    return [
        *(builtin[c] for c in INSTANCE_CHECKS if c in builtin),
        *(c for c in claims if isinstance(c, Conjecture)),
    ]


def _not_checked(name: str, claims: Sequence[Claim], batch: Batch, error: str) -> list[Record]:
    """The *error* records of an instance whose claims could not be checked: one per
    (claim, solver) due, so that the claim still has its records."""
    detail = "the instance could not be checked"
    return [
        make_record(c.name, NOT_CHECKED, name, s, None, detail, error=error)
        for c in _in_record_order(claims)
        for s in _solvers_of(c, batch)
    ]


def _raised(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def size_error(exc: SizeLimitError) -> str:
    """The ``error`` of the records of an instance above ``exact_size_limit``: one line
    naming the size, the limit and the argument that lifts it."""
    if exc.size is None or exc.limit is None:
        return _raised(exc)
    return (
        f"SizeLimitError: {exc.size} variables solved together in exact arithmetic, above "
        f"exact_size_limit={exc.limit}; exact_size_limit={exc.size} lifts it"
    )


def run_batch(batch: Batch) -> list[Record]:
    """The records of one batch (a module-level function: Dask ships it to workers).

    Each instance's costs are seeded by its own seed, so a record depends on ``(family,
    seed)``, the claims, the solvers, ``n_costs`` and ``rtol`` only. An instance that
    cannot be built gives an *error* record for every (claim, solver) due, whose ``error``
    says what was raised; one whose built-in checks raise, such records for the built-in
    checks (its conjectures still run: each is sandboxed, :mod:`~lpbounds.studies.claims`).
    """
    claims = list(batch.claims)
    exact: dict[str, Any] = {}
    if batch.arithmetic != "float":
        exact = {
            "arithmetic": batch.arithmetic,
            "exact_size_limit": batch.exact_size_limit,
            "certificates": batch.certificates,
        }
    if batch.number < 0:
        records = run_remark2(claims, batch.solvers, seed=batch.seed, rtol=batch.rtol, **exact)
        return [{**r, "campaign_index": -1} for r in records]
    builtin = [c for c in _in_record_order(claims) if isinstance(c, BuiltinClaim)]
    conjectures = [c for c in claims if isinstance(c, Conjecture)]
    kw: dict[str, Any] = {"n_costs": batch.n_costs, "rtol": batch.rtol, **exact}
    kw["exact_method"] = batch.exact_method
    out: list[Record] = []
    for k, family, seed in batch.items:
        name = f"{family}:{seed}"
        try:
            inst = campaign_instance(family, seed)
        except Exception as exc:  # a finding: the campaign goes on with the other instances
            found = _not_checked(name, claims, batch, _raised(exc))
            out += [{**r, "family": family, "seed": seed, "campaign_index": k} for r in found]
            continue
        found = []
        try:
            if builtin:
                try:
                    found += run_claims(inst, builtin, batch.solvers, seed=seed, **kw)
                except SizeLimitError:
                    raise
                except Exception as exc:  # a crash of a built-in check: a finding too
                    found += _not_checked(name, builtin, batch, _raised(exc))
            if conjectures:  # sandboxed: a predicate's crash is its record's error
                found += run_claims(inst, conjectures, batch.solvers, seed=seed, **kw)
        except SizeLimitError as exc:  # refused before any exact or LP work: not decided
            found = _not_checked(name, claims, batch, size_error(exc))
        out += [{**r, **inst.params, "campaign_index": k} for r in found]
    return out


# ---------------------------------------------------------------------- files
def _frame(records: Sequence[Record], columns: Sequence[str] = CAMPAIGN_COLUMNS) -> pd.DataFrame:
    """Records as a table of ``columns`` (:func:`campaign_columns`; missing entries
    empty)."""
    frame = records_frame(records)
    for col in columns:
        if col not in frame:
            frame[col] = "" if col in _STRING_COLUMNS else np.nan
    frame = frame[list(columns)]
    for col in _STRING_COLUMNS:
        if col in frame:
            frame[col] = frame[col].map(_text)
    return frame


def _text(x: Any) -> str:
    """A string column's entry: "" for a missing one (None, NaN), else its text."""
    if x is None or (isinstance(x, float) and np.isnan(x)):
        return ""
    return str(x)


def _write_frame(
    frame: pd.DataFrame, path: Path, before_rename: Callable[[str], None] | None = None
) -> str:
    """Write a table atomically (CSV with ``nan`` for missing numbers, or Parquet); the
    SHA-256 of the bytes written, hashed from the temporary file, which is handed to
    ``before_rename`` before that file is renamed into place (if it raises, ``path`` is
    left as it was)."""
    digest: list[str] = []

    def write(tmp: Path) -> None:
        if path.suffix == ".csv":
            with open(tmp, "w", newline="") as fh:
                frame.to_csv(fh, index=False, na_rep="nan")
                fh.flush()
                os.fsync(fh.fileno())
        else:
            frame.to_parquet(tmp, index=False)
        digest.append(file_sha256(tmp))
        if before_rename is not None:
            before_rename(digest[0])

    write_atomic(path, write)
    return digest[0]


def _read_frame(path: Path) -> pd.DataFrame:
    import pandas as pd

    if path.suffix == ".parquet":
        return pd.read_parquet(path)
    every = dict.fromkeys((*CAMPAIGN_COLUMNS, *EXACT_COLUMNS))
    numeric = [c for c in every if c not in _STRING_COLUMNS]
    return pd.read_csv(
        path,
        dtype={c: str for c in _STRING_COLUMNS},
        keep_default_na=False,
        na_values={c: ["nan"] for c in numeric},
    )  # pandas' default float parser reads repr() back exactly (its "round_trip")


def _check_parquet(fmt: str) -> None:
    if fmt not in ("csv", "parquet"):
        raise ValidationError(f"fmt must be 'csv' or 'parquet'; got {fmt!r}")
    if fmt == "parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError as exc:
            raise SolverNotInstalledError(
                "fmt='parquet' needs pyarrow (pip install pyarrow); 'csv' needs nothing"
            ) from exc


# ---------------------------------------------------------------------- the folder
#: The layout version of a campaign folder written here: ``campaign.json`` (arguments,
#: lpbounds version, claims' fingerprints) and ``manifest.json`` (one entry per batch
#: file). Folders written before (no version, no manifest) are refused on resume.
FOLDER_VERSION = 2
#: The campaign's arguments, lpbounds version and claims' fingerprints.
CAMPAIGN_FILE = "campaign.json"
#: One entry per batch written: file, records, instances, SHA-256, lpbounds, claims.
MANIFEST_FILE = "manifest.json"
#: Where files that fail their check on resume are moved (never deleted).
REJECTED_DIR = "rejected"
#: Where a rational campaign's certificates are written (``certificates=True``).
CERTIFICATES_DIR = "certificates"

#: The value of an argument a campaign folder written before it existed stands for (such a
#: folder resumes in floating point).
_ARGUMENT_DEFAULTS: dict[str, Any] = {
    "arithmetic": "float",
    "exact_size_limit": None,
    "certificates": False,
}

#: A note of a campaign for its user, one line (a batch recomputed, a counterexample not
#: reproduced): ``notify(line)``.
CampaignNote = Callable[[str], None]

_HEX = re.compile(r"[0-9a-f]{64}")


def _unreadable(path: Path, why: str) -> OutputError:
    return OutputError(
        f"out: {str(path)!r} cannot be read ({why}); nothing was changed: restore it, or "
        "run the campaign into another folder"
    )


def _read_json(path: Path) -> dict[str, Any]:
    """A JSON object from ``path``; OutputError naming the file when it cannot be read."""
    try:
        data = json.loads(path.read_bytes())
    except FileNotFoundError:
        raise _unreadable(path, "no such file") from None
    except OSError as exc:
        raise _unreadable(path, exc.strerror or type(exc).__name__) from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _unreadable(path, f"not valid JSON: {' '.join(str(exc).split())[:120]}") from None
    if not isinstance(data, dict):
        raise _unreadable(path, f"a JSON {type(data).__name__}, not an object")
    return data


def _checked_manifest(path: Path, data: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The batch entries of a manifest, each of the right shape (else OutputError)."""
    batches = data.get("batches")
    if data.get("campaign_folder") != FOLDER_VERSION or not isinstance(batches, dict):
        raise _unreadable(path, f"not a campaign manifest of layout {FOLDER_VERSION}")
    for stem, e in batches.items():
        span = e.get("instances") if isinstance(e, dict) else None
        ok = (
            isinstance(e, dict)
            and isinstance(e.get("file"), str)
            and Path(e["file"]).stem == stem
            and isinstance(e.get("records"), int)
            and (span is None or (isinstance(span, list) and len(span) == 2))
            and isinstance(e.get("sha256"), str)
            and _HEX.fullmatch(e["sha256"]) is not None
            and isinstance(e.get("lpbounds"), str)
            and isinstance(e.get("claims"), dict)
            and isinstance(e.get("certificates", {}), dict)
            and all(
                isinstance(h, str) and _HEX.fullmatch(h) is not None
                for h in e.get("certificates", {}).values()
            )
        )
        if not ok:
            raise _unreadable(path, f"its entry {stem!r} is malformed")
    return batches


def _changed_claims(old: dict[str, Any], new: dict[str, dict[str, Any]]) -> list[tuple[str, str]]:
    """``(claim, what changed)`` for each claim whose fingerprint differs."""
    out = []
    for name, fp in new.items():
        before = old.get(name)
        if before == fp:
            continue
        if not isinstance(before, dict) or before.get("kind") != fp.get("kind"):
            out.append((name, "it was another kind of claim"))
            continue
        diff = [k for k in fp if before.get(k) != fp[k]]
        what = "; ".join(
            f"SHA-256 of {fp['source']!r} {str(before.get(k))[:12]}... then, "
            f"{str(fp[k])[:12]}... now"
            if k == "sha256"
            else f"{k} {before.get(k)!r} then, {fp[k]!r} now"
            for k in diff
        )
        out.append((name, what))
    return out


@dataclass
class _Folder:
    """A campaign's folder: its manifest's entries (kept in step with the batch files)."""

    path: Path
    fmt: str
    fingerprints: dict[str, dict[str, Any]]
    entries: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def batches(self) -> Path:
        return self.path / "batches"

    def file(self, stem: str) -> Path:
        return self.batches / f"{stem}.{self.fmt}"

    def save_manifest(self) -> None:
        data = {"campaign_folder": FOLDER_VERSION, "batches": self.entries}
        write_text_atomic(self.path / MANIFEST_FILE, json.dumps(data, indent=1) + "\n")

    def write(self, batch: Batch, frame: pd.DataFrame) -> None:
        """The batch file with its manifest entry, each atomically: the entry is written
        while the file is still a temporary one, then the file is renamed into place. So a
        batch file on disk has its entry whenever the run stops (Ctrl-C, a kill); an entry
        whose file is missing or differs (stopped in between) is recomputed on resume."""
        path, stem = self.file(batch.stem), batch.stem
        before = self.entries.get(stem)

        certs = self.certificate_hashes(frame)

        def record(digest: str) -> None:
            self.entries[stem] = {
                "file": path.name,
                "records": len(frame),
                "instances": batch.instances,
                "sha256": digest,
                "lpbounds": VERSION,
                "claims": {c.name: self.fingerprints[c.name] for c in batch.claims},
                **({"certificates": certs} if certs else {}),
            }
            try:
                self.save_manifest()
            except BaseException:  # the file is not renamed: its entry is not kept either
                if before is None:
                    self.entries.pop(stem, None)
                else:
                    self.entries[stem] = before
                raise

        _write_frame(frame, path, record)

    def certificate_hashes(self, frame: pd.DataFrame) -> dict[str, str]:
        """The SHA-256 of every certificate the records name (``certificates/``)."""
        if "certificate" not in frame:
            return {}
        names = sorted({str(t) for t in frame["certificate"] if isinstance(t, str) and t})
        return {n: file_sha256(self.path / CERTIFICATES_DIR / n) for n in names}

    def bad_certificate(self, stem: str) -> tuple[Path, str] | None:
        """The first certificate of a batch's manifest entry that is missing or differs
        from its SHA-256 there, and what is wrong; None when all match."""
        for name, digest in self.entries.get(stem, {}).get("certificates", {}).items():
            path = self.path / CERTIFICATES_DIR / name
            if not path.exists():
                return path, f"names the certificate {CERTIFICATES_DIR}/{name}, which is missing"
            if file_sha256(path) != digest:
                return path, (
                    f"names the certificate {CERTIFICATES_DIR}/{name}, which does not match "
                    "the manifest (its SHA-256 differs)"
                )
        return None

    def aside(self, path: Path) -> Path:
        """Move ``path`` into ``rejected/`` under a free name (never over another)."""
        where = self.path / REJECTED_DIR
        where.mkdir(exist_ok=True)
        target = where / path.name
        k = 1
        while target.exists():
            k += 1
            target = where / f"{path.stem}-{k}{path.suffix}"
        os.replace(path, target)
        return target

    def read(self, batch: Batch) -> tuple[pd.DataFrame | None, str]:
        """The batch's records as verified against the manifest: ``(frame, "")``, or
        ``(None, why not)``. Checked: the entry and the file exist, the file's SHA-256,
        its instances, that it parses, its number of records, that every record is of one
        of its instances and every (instance, claim, solver) due has one."""
        entry, path = self.entries.get(batch.stem), self.file(batch.stem)
        if entry is None:
            return None, "is not in the manifest"
        if not path.exists():
            return None, "is listed in the manifest but missing"
        if entry["file"] != path.name or entry["instances"] != batch.instances:
            return None, "does not match its manifest entry (another file or other instances)"
        if file_sha256(path) != entry["sha256"]:
            return None, "does not match the manifest (its SHA-256 differs)"
        try:
            frame = _read_frame(path)
        except Exception as exc:  # what the parser says of a file that is not a table
            return None, f"cannot be read ({type(exc).__name__})"
        if len(frame) != entry["records"] or "campaign_index" not in frame:
            return None, f"holds {len(frame)} records, the manifest says {entry['records']}"
        ks = {-1} if batch.number < 0 else {k for k, _, _ in batch.items}
        if not set(frame["campaign_index"].astype(int)) <= ks:
            return None, "holds records of instances outside it"
        bad = self.bad_certificate(batch.stem)
        if bad is not None:
            return None, bad[1]
        return frame, ""


def _init_folder(out: Path, params: dict[str, Any], fps: dict[str, Any], fmt: str) -> _Folder:
    """A new campaign in ``out`` (absent, empty, or left by an initialisation that was
    interrupted): ``batches/``, an empty manifest, then ``campaign.json``, which marks the
    folder as a campaign's."""
    leftovers = [p for p in out.iterdir() if not p.name.startswith(".")] if out.exists() else []
    ours = {"batches", MANIFEST_FILE}
    if any(p.name not in ours for p in leftovers) or any(
        p.is_dir() and any(p.iterdir()) for p in leftovers
    ):
        raise OutputError(
            f"out: {str(out)!r} is not empty and holds no campaign (no {CAMPAIGN_FILE}): "
            "give a new or empty folder"
        )
    folder = _Folder(out, fmt, fps)
    folder.batches.mkdir(parents=True, exist_ok=True)
    folder.save_manifest()
    write_text_atomic(out / CAMPAIGN_FILE, json.dumps(_campaign_file(params, fps), indent=2) + "\n")
    return folder


def _campaign_file(params: dict[str, Any], fps: dict[str, Any]) -> dict[str, Any]:
    return {
        "campaign_folder": FOLDER_VERSION,
        "arguments": params,
        "lpbounds": VERSION,
        "claims": fps,
    }


def _open_folder(
    out: Path, params: dict[str, Any], fps: dict[str, Any], rerun_changed: bool
) -> tuple[_Folder, list[str]]:
    """Create ``out`` for a new campaign, or check that it holds this one: its
    ``campaign.json`` and manifest readable, the same arguments, lpbounds version and
    claims (a changed claim only with ``rerun_changed``, which records the new ones).
    Returns the folder and the notes of what changed. Nothing is written when refused."""
    if out.exists() and not out.is_dir():
        raise OutputError(f"out: {str(out)!r} is not a folder")
    if not (out / CAMPAIGN_FILE).exists():
        return _init_folder(out, params, fps, params["format"]), []
    meta = _read_json(out / CAMPAIGN_FILE)
    if "campaign_folder" not in meta and {"n", "seed", "claims"} <= set(meta):
        raise OutputError(
            f"out: {str(out)!r} holds a campaign written before campaigns kept a manifest "
            "(its batches cannot be checked): move it aside and run the campaign into a new "
            "folder, where its records are recomputed"
        )
    args, version, old_fps = meta.get("arguments"), meta.get("lpbounds"), meta.get("claims")
    if meta.get("campaign_folder") != FOLDER_VERSION or not (
        isinstance(args, dict) and isinstance(version, str) and isinstance(old_fps, dict)
    ):
        raise _unreadable(out / CAMPAIGN_FILE, f"not a campaign file of layout {FOLDER_VERSION}")
    known = {**_ARGUMENT_DEFAULTS, **args}
    diff = [k for k in dict.fromkeys((*params, *args)) if known.get(k) != params.get(k)]
    if diff:
        k = diff[0]
        raise ValidationError(
            f"out: {str(out)!r} holds a campaign with other arguments ({k} = "
            f"{known.get(k)!r}, now {params.get(k)!r}): rerun with its arguments to resume "
            "it, or give another folder"
        )
    entries = _checked_manifest(out / MANIFEST_FILE, _read_json(out / MANIFEST_FILE))
    changed = [("lpbounds", f"{version} then, {VERSION} now")] if version != VERSION else []
    changed += _changed_claims(old_fps, fps)
    if changed and not rerun_changed:
        name, what = changed[0]
        subject = "lpbounds itself" if name == "lpbounds" else f"the claim {name!r}"
        raise ValidationError(
            f"out: {subject} changed since the campaign's records were made ({what}): they "
            "would be reported as the new one's; rerun_changed=True (--rerun-changed) "
            "recomputes the records it changed, or restore it to resume"
        )
    if changed:
        write_text_atomic(
            out / CAMPAIGN_FILE, json.dumps(_campaign_file(params, fps), indent=2) + "\n"
        )
    notes = [
        f"{n if n == 'lpbounds' else repr(n)} changed ({w}): its records are recomputed"
        for n, w in changed
    ]
    return _Folder(out, params["format"], fps, dict(entries)), notes


def read_records(out: str | Path) -> pd.DataFrame:
    """A campaign's records from its folder, verified: the batch files its manifest
    lists, in campaign order (also of an unfinished campaign), each checked against its
    entry (SHA-256, number of records) as it is read.

    Parameters
    ----------
    out : str or Path
        The campaign's ``out`` folder.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`CAMPAIGN_COLUMNS`.

    Raises
    ------
    OutputError
        No readable manifest, or a batch that does not match it (named).
    """
    import pandas as pd

    folder = Path(out)
    entries = _checked_manifest(folder / MANIFEST_FILE, _read_json(folder / MANIFEST_FILE))
    frames = []
    for stem in sorted(entries, key=lambda s: (s == "remark2", s)):
        entry, path = entries[stem], folder / "batches" / entries[stem]["file"]
        if not path.exists() or file_sha256(path) != entry["sha256"]:
            raise OutputError(f"{str(path)!r} does not match the campaign's manifest")
        frame = _read_frame(path)
        if len(frame) != entry["records"]:
            raise OutputError(
                f"{str(path)!r} holds {len(frame)} records, the manifest says {entry['records']}"
            )
        frames.append(frame)
    return pd.concat(frames, ignore_index=True) if frames else _frame([])


# ---------------------------------------------------------------------- resuming
def _merge(old: pd.DataFrame, new: pd.DataFrame, batch: Batch, redone: set[str]) -> pd.DataFrame:
    """A batch's records with those of the claims ``redone`` replaced by ``new``, in the
    order an uninterrupted run gives them (by instance, then claim: built-in checks
    first, then the conjectures in their order)."""
    import pandas as pd

    group = {
        c.name: 1 + j for j, c in enumerate(c for c in batch.claims if isinstance(c, Conjecture))
    }
    kept = old[~old["check"].isin(list(redone))]
    both = pd.concat([kept, new.astype(kept.dtypes.to_dict(), errors="ignore")], ignore_index=True)
    pos = {k: j for j, (k, _, _) in enumerate(batch.items)}
    key = pd.DataFrame({
        "k": both["campaign_index"].astype(int).map(pos),
        "g": both["check"].map(lambda c: group.get(c, 0)),
    })  # fmt: skip
    order = key.sort_values(["k", "g"], kind="stable").index
    return both.loc[order].reset_index(drop=True)[list(old.columns)]


@dataclass
class _Work:
    """What a run does with one batch: compute it (``redo`` None: all its claims; else
    those claims only, merged into ``kept``), or keep it (``done``)."""

    batch: Batch
    done: bool = False
    kept: pd.DataFrame | None = None
    redo: set[str] | None = None


def _plan_work(folder: _Folder, batches: list[Batch], note: CampaignNote) -> list[_Work]:
    """Check every batch on disk against the manifest: a batch that passes is kept (or,
    where some of its claims changed since it was written, those are redone); one that
    fails is named, moved aside and recomputed; a file that is not a batch of this
    campaign is moved aside. One note per file moved or batch redone."""
    work, replaced = [], 0
    planned = {folder.file(b.stem).name for b in batches}
    for path in sorted(folder.batches.iterdir()):
        if path.name not in planned:
            what = (
                "is an unfinished write of an interrupted run"
                if path.name.startswith(".") and path.suffix == ".tmp"
                else "is not a batch of this campaign"
            )
            note(f"batches/{path.name} {what}: moved to {_rel(folder, folder.aside(path))}")
    for b in batches:
        path = folder.file(b.stem)
        if b.stem not in folder.entries and not path.exists():
            work.append(_Work(b))
            continue
        frame, why = folder.read(b)
        if frame is None:
            bad = folder.bad_certificate(b.stem)
            if bad is not None and bad[0].exists():
                note(f"{_rel(folder, bad[0])} moved to {_rel(folder, folder.aside(bad[0]))}")
            gone = f": moved to {_rel(folder, folder.aside(path))}" if path.exists() else ""
            folder.entries.pop(b.stem, None)
            note(f"{path.name} {why}{gone}; it is recomputed")
            work.append(_Work(b))
            continue
        entry, fps = folder.entries[b.stem], folder.fingerprints
        changed = {
            c.name
            for c in b.claims
            if entry["lpbounds"] != VERSION or entry["claims"].get(c.name) != fps[c.name]
        }
        missing = b.due() - _present(frame)
        if missing:
            where = _rel(folder, folder.aside(path))
            note(
                f"{path.name} lacks the records of {len(missing)} (instance, claim, solver) "
                f"due: moved to {where}; it is recomputed"
            )
            folder.entries.pop(b.stem)
            work.append(_Work(b))
        elif not changed:
            work.append(_Work(b, done=True, kept=frame))
        else:  # the old records are kept aside; the batch is rewritten
            folder.aside(path)
            folder.entries.pop(b.stem)
            replaced += 1
            if b.number < 0 or changed >= {c.name for c in b.claims}:
                work.append(_Work(b))  # every claim changed: computed again
            else:
                work.append(_Work(b, kept=frame, redo=changed))
    if replaced:
        note(
            f"{replaced} batch file{'s' if replaced != 1 else ''} held records of changed "
            f"claims: moved to {REJECTED_DIR}/, their records recomputed"
        )
    stems = {b.stem for b in batches}
    for stem in [s for s in folder.entries if s not in stems]:
        del folder.entries[stem]
        note(f"the manifest's entry {stem!r} is not a batch of this campaign: dropped")
    folder.save_manifest()
    return work


def _rel(folder: _Folder, path: Path) -> str:
    return str(path.relative_to(folder.path))


def _present(frame: pd.DataFrame) -> set[tuple[int, str, str]]:
    cols = zip(frame["campaign_index"].astype(int), frame["check"], frame["solver"], strict=True)
    return {(int(k), str(c), str(s)) for k, c, s in cols}


# ---------------------------------------------------------------------- running batches
def _execute(
    pending: list[Batch], scheduler: str | Any | None, done: Callable[[Batch, list[Record]], None]
) -> None:
    """Run the batches, handing each one's records to ``done`` as it finishes: here, on
    one of Dask's local schedulers (in waves of twice the cores, so that results reach the
    disk as they come), or on a cluster (all submitted, taken as they complete)."""
    if scheduler is None:
        for b in pending:
            done(b, run_batch(b))
        return
    from .compare import DASK_LOCAL, dask_map

    if scheduler in DASK_LOCAL:
        wave = 1 if scheduler == "synchronous" else 2 * (os.cpu_count() or 1)
        for start in range(0, len(pending), wave):
            part = pending[start : start + wave]
            for k, records in dask_map(run_batch, part, scheduler):
                done(part[k], records)
        return
    for k, records in dask_map(run_batch, pending, scheduler):
        done(pending[k], records)


@dataclass
class _Ran:
    """The records of a campaign's run and what it knows of them."""

    frame: pd.DataFrame
    run: int
    due: int
    missing: dict[str, int]


def _run_batches(
    batches: list[Batch],
    folder: _Folder | None,
    scheduler: str | Any | None,
    progress: CampaignProgress | None,
    note: CampaignNote,
) -> _Ran:
    """Run the batches not on disk yet (all without a folder; on resume, those that fail
    their check and the claims that changed), then count the records against those due."""
    work = [_Work(b) for b in batches] if folder is None else _plan_work(folder, batches, note)
    pending = [w for w in work if not w.done]
    by_stem = {w.batch.stem: w for w in pending}
    kept: dict[str, list[Record]] = {}
    count = [len(work) - len(pending)]

    def finish(batch: Batch, records: list[Record]) -> None:
        w = by_stem[batch.stem]
        what = f"{len(records)} records"
        if folder is not None:
            frame = _frame(records, campaign_columns(batch.arithmetic))
            if w.redo is not None and w.kept is not None:
                frame, what = _merge(w.kept, frame, w.batch, w.redo), f"{what} redone"
            folder.write(w.batch, frame)
        else:
            kept[batch.stem] = records
        count[0] += 1
        if progress is not None:
            progress(count[0], len(batches), f"{batch.stem}: {what}")

    tasks = [
        w.batch if w.redo is None else replace(w.batch, claims=_only(w.batch.claims, w.redo))
        for w in pending
    ]
    _execute(tasks, scheduler, finish)
    due = sum(len(b.due()) for b in batches)
    if folder is None:
        records = [r for b in batches for r in kept.get(b.stem, [])]
        frame = _frame(records, campaign_columns(batches[0].arithmetic if batches else "float"))
        return _Ran(frame, len(pending), due, _missing(batches, _present(frame)))
    frames: dict[str, pd.DataFrame] = {}
    for b in batches:  # every batch read back and checked against the manifest
        got, why = folder.read(b)
        if got is None:
            note(f"{folder.file(b.stem).name} {why}")
        else:
            frames[b.stem] = got
    present = set().union(*(_present(f) for f in frames.values()))
    return _Ran(_concat(list(frames.values())), len(pending), due, _missing(batches, present))


def _only(claims: tuple[Claim, ...], names: set[str]) -> tuple[Claim, ...]:
    return tuple(c for c in claims if c.name in names)


def _concat(frames: list[pd.DataFrame]) -> pd.DataFrame:
    import pandas as pd

    return pd.concat(frames, ignore_index=True) if frames else _frame([])


def _missing(batches: list[Batch], present: set[tuple[int, str, str]]) -> dict[str, int]:
    """Per batch, how many (instance, claim, solver) due have no record (only batches
    that lack some)."""
    out = {}
    for b in batches:
        lacking = len(b.due() - present)
        if lacking:
            out[b.stem] = lacking
    return out


# ---------------------------------------------------------------------- shrinking
@dataclass(frozen=True)
class Counterexample:
    """The smallest instance found on which a claim keeps its (violated) verdict.

    Attributes
    ----------
    instance, check, claim, solver, verdict : str
        The record shrunk (its instance ``"family:seed"``).
    original, shrunk : dict
        :func:`~lpbounds.studies.shrink.size_of` before and after.
    evaluations, steps : int
        Candidates tested, and kept.
    mdp, partition
        The shrunk instance.
    path : Path or None
        Its model file (``out/counterexamples/*.toml``), None without ``out``.
    certificate : Path or None
        Rational arithmetic: the certificate of the verdict on the shrunk instance
        (``out/counterexamples/*.certificate.json``), when the claim's record has one.
    """

    instance: str
    check: str
    claim: str
    solver: str
    verdict: str
    original: dict[str, int]
    shrunk: dict[str, int]
    evaluations: int
    steps: int
    mdp: FiniteMDP
    partition: Partition
    path: Path | None = None
    certificate: Path | None = None

    def row(self) -> dict[str, Any]:
        """A flat row (``counterexamples.csv``): sizes as ``states``, ``states_before``, ..."""
        out: dict[str, Any] = {
            k: getattr(self, k) for k in ("instance", "check", "claim", "solver", "verdict")
        }
        for k, v in self.shrunk.items():
            out[k], out[f"{k}_before"] = v, self.original[k]
        out.update(
            evaluations=self.evaluations,
            steps=self.steps,
            path="" if self.path is None else str(self.path),
        )
        if self.certificate is not None:
            out["certificate"] = str(self.certificate)
        return out


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


@dataclass(frozen=True)
class _Target:
    """What a shrink keeps: one record's claim, solver and verdict."""

    claim: Claim
    text: str
    solver: str
    verdict: str
    solvers: tuple[str, ...]
    n_costs: int
    rtol: float
    seed: int
    exact_method: str
    arithmetic: str = "float"
    exact_size_limit: int | None = None

    def records(
        self,
        mdp: FiniteMDP,
        partition: Partition,
        name: str = "candidate",
        certificates: Any = None,
    ) -> list[Record]:
        """The claim's records on an instance (for the record's solver), the kept one
        first; raises what the claim raises."""
        if self.solver == "all":
            solvers: tuple[str, ...] = self.solvers
        else:
            solvers = () if self.solver == "exact" else (self.solver,)
        found = run_claims(
            VerifyInstance(name, mdp, partition),
            [self.claim],
            solvers,
            n_costs=self.n_costs,
            seed=self.seed,
            rtol=self.rtol,
            exact_method=self.exact_method,
            arithmetic=self.arithmetic,
            exact_size_limit=self.exact_size_limit,
            certificates=certificates,
        )
        return sorted(found, key=lambda r: not self.shows(r))

    def shows(self, record: Record) -> bool:
        """Whether a record is the kept one: its claim and solver, with the verdict kept
        (in rational arithmetic the exact verdict)."""
        return bool(
            record["claim"] == self.text
            and record["solver"] == self.solver
            and str(record["verdict"]) == self.verdict
        )

    def __call__(self, mdp: FiniteMDP, partition: Partition) -> bool:
        try:
            found = self.records(mdp, partition)
        except Exception:  # a candidate the claim cannot be checked on shows nothing
            return False
        return bool(found) and self.shows(found[0])


def _stem_of(row: dict[str, Any]) -> str:
    digest = hashlib.sha256(str(row["claim"]).encode()).hexdigest()[:6]  # the claim, short
    stem = "-".join(
        (row["family"], str(int(row["seed"])), _slug(row["check"])[:24], _slug(row["solver"]))
    )
    return f"{stem}-{digest}"


def _load_counterexample(head: dict[str, Any], folder: Path, stem: str) -> Counterexample | None:
    """An earlier run's counterexample of this record from its files (None when they are
    absent, unreadable or of another record)."""
    from ..model.instances import load_instance

    try:
        saved = json.loads((folder / f"{stem}.json").read_text())
        if any(str(saved.get(k)) != v for k, v in head.items()):
            return None
        inst = load_instance(str(folder / f"{stem}.toml"))
        return Counterexample(
            **head,
            original=saved["original"],
            shrunk=saved["shrunk"],
            evaluations=saved["evaluations"],
            steps=saved["steps"],
            mdp=inst.mdp(),
            partition=inst.partition(),
            path=folder / f"{stem}.toml",
        )
    except Exception:  # LPBoundsError, OSError, JSON, a missing key: not a usable file
        return None


def _confirmed(cex: Counterexample, target: _Target) -> bool:
    """The counterexample's model file, loaded back, holds the shrunk instance bit for bit
    and still shows the record's verdict (the claim run on it again)."""
    from ..model.instances import load_instance

    assert cex.path is not None
    try:
        inst = load_instance(str(cex.path))
        mdp, part = inst.mdp(), inst.partition()
    except Exception:  # a file that does not load back shows nothing
        return False
    same = all(
        np.array_equal(getattr(mdp, a), getattr(cex.mdp, a))
        for a in ("successors", "probabilities", "allowed")
    ) and np.array_equal(mdp.rewards[mdp.allowed], cex.mdp.rewards[cex.mdp.allowed])
    same = same and mdp.discount == cex.mdp.discount
    return bool(same and np.array_equal(part.labels, cex.partition.labels) and target(mdp, part))


#: The suffix of a counterexample's certificate beside its model file (rational arithmetic).
CERTIFICATE_SUFFIX = ".certificate.json"


def _certified(cex: Counterexample, target: _Target, folder: Path, stem: str) -> Counterexample:
    """Rational arithmetic: the counterexample with the certificate of its record on the
    shrunk instance (``<stem>.certificate.json``, written anew; the claim run once more,
    its certificates into a temporary folder beside it), when the record has one."""
    import tempfile

    if target.arithmetic == "float":
        return cex
    with tempfile.TemporaryDirectory(dir=folder, prefix=".certificates-") as tmp:
        found = target.records(cex.mdp, cex.partition, name=stem, certificates=tmp)
        name = found[0].get("certificate") if found and target.shows(found[0]) else None
        if not name:
            return cex
        dest = folder / f"{stem}{CERTIFICATE_SUFFIX}"
        os.replace(Path(tmp) / str(name), dest)
    return replace(cex, certificate=dest)


def _set_aside(folder: Path, stem: str) -> str:
    """Move a counterexample's files into ``counterexamples/rejected/``; where to."""
    where = folder / REJECTED_DIR
    for suffix in (".toml", ".json", CERTIFICATE_SUFFIX):
        path = folder / f"{stem}{suffix}"
        if path.exists():
            where.mkdir(exist_ok=True)
            target, k = where / path.name, 1
            while target.exists():
                k += 1
                target = where / f"{stem}-{k}{suffix}"
            os.replace(path, target)
    return f"{folder.name}/{REJECTED_DIR}/"


def _shrink_one(
    row: dict[str, Any],
    target: _Target,
    folder: Path | None,
    max_seconds: float,
    note: CampaignNote,
) -> Counterexample | None:
    """Shrink the instance of one record, or take an earlier run's shrink from disk; None
    when the record's verdict does not show on its instance when re-checked. A model
    file is reported only once it is loaded back and shows the verdict again."""
    stem = _stem_of(row)
    head: dict[str, Any] = {
        k: str(row[k]) for k in ("instance", "check", "claim", "solver", "verdict")
    }
    what = f"{row['instance']}: {row['check']} ({row['solver']}) {row['verdict']}"
    if folder is not None and (folder / f"{stem}.json").exists():
        earlier = _load_counterexample(head, folder, stem)
        if earlier is not None and _confirmed(earlier, target):
            return _certified(earlier, target, folder, stem)
        where = _set_aside(folder, stem)
        note(
            f"the counterexample of {what} on disk does not show it: moved to {where}; shrunk again"
        )
    start = campaign_instance(str(row["family"]), int(row["seed"]))
    found = shrink(start.mdp, start.partition, target, max_seconds=max_seconds)
    if not found.shown:
        note(f"{what}: not so when checked again on its instance: no counterexample written")
        return None
    cex = Counterexample(
        **head,
        original=size_of(start.mdp, start.partition),
        shrunk=size_of(found.mdp, found.partition),
        evaluations=found.evaluations,
        steps=found.steps,
        mdp=found.mdp,
        partition=found.partition,
        path=None if folder is None else folder / f"{stem}.toml",
    )
    if cex.path is not None:
        _write_counterexample(cex, row)
        if not _confirmed(cex, target):
            where = _set_aside(folder, stem)  # type: ignore[arg-type]  # path set: a folder
            note(
                f"the counterexample of {what} does not show it when loaded back: moved to {where}"
            )
            return None
        return _certified(cex, target, cex.path.parent, stem)
    return cex


def _sizes(size: dict[str, int]) -> str:
    """``"2 states, 1 action, 1 outcome, 1 block"``."""
    return ", ".join(f"{size[k]} {k if size[k] != 1 else k[:-1]}" for k in size)


def _write_counterexample(cex: Counterexample, row: dict[str, Any]) -> None:
    """The model file (with a header saying what it shows) and its sidecar JSON."""
    assert cex.path is not None
    header = [
        f"counterexample: {cex.check}: {cex.claim!r} is {cex.verdict} (solver {cex.solver})",
        f"shrunk from {cex.instance} ({_sizes(cex.original)}) to {_sizes(cex.shrunk)} in "
        f"{cex.evaluations} tests ({cex.steps} kept)",
        f"the original: lpbounds.studies.campaign.campaign_instance({row['family']!r}, "
        f"{int(row['seed'])})",
    ]
    if cex.check in INSTANCE_CHECKS and cex.solver not in ("exact", "all"):
        exact = " --arithmetic rational" if "float_verdict" in row else ""
        header.append(
            f"check it: lpbounds verify {cex.path.name} --random 0 --solvers {cex.solver}{exact}"
        )
    write_model(cex.path, cex.mdp, cex.partition, header)
    side = cex.row()
    side.update(original=cex.original, shrunk=cex.shrunk)
    write_text_atomic(cex.path.with_suffix(".json"), json.dumps(side, indent=2) + "\n")


def _shrink_all(
    frame: pd.DataFrame,
    claims: Sequence[Claim],
    verdicts: Sequence[str],
    run: dict[str, Any],
    folder: Path | None,
    max_seconds: float,
    progress: CampaignProgress | None,
    note: CampaignNote,
) -> list[Counterexample]:
    """One counterexample per (instance, check, claim, solver) record of ``verdicts``."""
    by_name = {c.name: c for c in claims}
    bad = frame[
        frame["verdict"].isin(list(verdicts))
        & (frame["campaign_index"] >= 0)
        & (frame["claim"] != NOT_CHECKED)
        & frame["check"].isin(list(by_name))
    ]
    bad = bad.drop_duplicates(["instance", "check", "claim", "solver"])
    out = []
    if folder is not None and len(bad):
        folder.mkdir(parents=True, exist_ok=True)
    for done, row in enumerate(bad.to_dict("records"), 1):
        if progress is not None:
            progress(done - 1, len(bad), f"shrinking {row['instance']}: {row['check']}")
        target = _Target(
            by_name[row["check"]],
            row["claim"],
            row["solver"],
            row["verdict"],
            tuple(run["solvers"]),
            run["n_costs"],
            run["rtol"],
            int(row["seed"]),
            run["exact_method"],
            run.get("arithmetic", "float"),
            run.get("exact_size_limit"),
        )
        cex = _shrink_one(row, target, folder, max_seconds, note)
        if cex is not None:
            out.append(cex)
    return out


# ---------------------------------------------------------------------- the campaign
# ---------------------------------------------------------------------- the campaign
@dataclass(repr=False)
class CampaignResult(VerdictRecords):
    """A campaign's records, counterexamples and how it was run.

    Attributes
    ----------
    frame : pandas.DataFrame
        One row per (instance, claim, solver), columns :func:`campaign_columns`.
    params : dict
        The arguments that define the campaign (``campaign.json``).
    counterexamples : list of Counterexample
    out : Path or None
    seconds : float
        Wall-clock time of this run (not of earlier runs it resumed).
    batches_run, batches_resumed : int
        Batches computed by this run (wholly or the claims that changed), and kept from
        an earlier one.
    scheduler : str
        How the batches ran (``"serial"``, a local scheduler's name, ``"cluster"``).
    due : int
        The (instance, claim, solver) that must each have a record or more
        (:meth:`Batch.due`): instances x claims x solvers, and Remark 2 per solver.
    missing : dict
        Batch name -> how many of its (instance, claim, solver) due have no record on
        disk (empty when every one has): such a campaign fails (:meth:`exit_status`).
    notes : list of str
        What this run found and did beyond computing (one line each): batches that failed
        their check on resume (moved aside and recomputed), claims that changed,
        counterexamples not reproduced.
    """

    frame: pd.DataFrame
    params: dict[str, Any]
    counterexamples: list[Counterexample]
    out: Path | None
    seconds: float
    batches_run: int
    batches_resumed: int
    scheduler: str
    due: int = 0
    missing: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def __repr__(self) -> str:
        counts = self.verdicts()
        words = ", ".join(f"{counts[w]:,} {w}" for w in OUTCOMES)
        lacking = sum(self.missing.values())
        return (
            f"CampaignResult({self.params['n']:,} instances, {len(self.frame):,} records: "
            f"{words}; {lacking:,} due missing; {len(self.counterexamples)} counterexamples)"
        )

    def records(self) -> list[Record]:
        """The records as dicts (flat: :func:`campaign_columns`)."""
        return list(self.frame.to_dict("records"))

    def record_list(self) -> list[Record]:
        """The records (:class:`~lpbounds.studies.verify.VerdictRecords`: ``verdicts()``,
        ``summary()`` and ``exit_status()``, which also fails when records due are
        missing)."""
        return self.records()

    def incomplete(self) -> bool:
        """Whether records due are missing from the folder."""
        return bool(self.missing)


def _check_params(
    n: int,
    seed: int,
    families: Sequence[str] | None,
    batch_size: int,
    n_costs: int,
    rtol: float,
) -> list[str]:
    """Check the campaign's numbers; the families (all by default)."""
    from ..validation import check_int, check_real

    check_int("n", n, lo=0)
    check_int("seed", seed, lo=0)
    check_int("batch_size", batch_size, lo=1)
    check_int("n_costs", n_costs, lo=1)
    check_real("rtol", rtol, lo=0.0, lo_open=True)
    chosen = list(FAMILIES) if families is None else list(families)
    for f in chosen:
        if f not in FAMILIES:
            raise ValidationError(f"families: unknown family {f!r}; known: {', '.join(FAMILIES)}")
    if not chosen:
        raise ValidationError("families: no family to draw from")
    return list(dict.fromkeys(chosen))


def _check_exact(
    arithmetic: Any, size_limit: Any, certificates: Any, out: str | Path | None
) -> None:
    """The exact arguments: a known arithmetic; a size limit and certificates only in
    rational arithmetic (certificates with ``out``)."""
    from ..validation import check_int

    check_arithmetic(arithmetic)
    if size_limit is not None:
        check_int("exact_size_limit", size_limit, lo=1)
    if arithmetic == "float" and (size_limit is not None or certificates):
        what = "exact_size_limit" if size_limit is not None else "certificates"
        raise ValidationError(f"{what} belongs to arithmetic='rational'")
    if certificates and out is None:
        raise ValidationError(
            "certificates: a campaign writes them into out/certificates; give out"
        )


def _batches(
    params: dict[str, Any], claims: Sequence[Claim], out: Path | None = None
) -> list[Batch]:
    plan = instance_plan(params["n"], params["seed"], params["families"])
    size = params["batch_size"]
    certificates = None
    if params["certificates"] and out is not None:
        certificates = str(out / CERTIFICATES_DIR)
    common: dict[str, Any] = {
        "claims": tuple(claims),
        "solvers": tuple(params["solvers"]),
        "n_costs": params["n_costs"],
        "rtol": params["rtol"],
        "seed": params["seed"],
        "exact_method": params["exact_method"],
        "arithmetic": params["arithmetic"],
        "exact_size_limit": params["exact_size_limit"],
        "certificates": certificates,
    }
    batches = [
        Batch(b, tuple(plan[i : i + size]), **common)
        for b, i in enumerate(range(0, len(plan), size))
    ]
    if REMARK2 in params["claims"]:
        batches.append(Batch(-1, (), **common))
    return batches


def run_campaign(
    n: int,
    seed: int = 0,
    *,
    families: Sequence[str] | None = None,
    claims: Iterable[str | Claim | Callable[..., Any]] | None = None,
    solvers: Sequence[str] | None = None,
    n_costs: int = 3,
    rtol: float = LP_COMPARE_RTOL,
    exact_method: str = "pi",
    arithmetic: str = "float",
    exact_size_limit: int | None = None,
    certificates: bool = False,
    out: str | Path | None = None,
    fmt: str = "csv",
    batch_size: int = 10,
    scheduler: str | Any | None = None,
    shrink: bool = True,
    shrink_inconclusive: bool = False,
    shrink_seconds: float = 60.0,
    progress: CampaignProgress | None = None,
    notify: CampaignNote | None = None,
    rerun_changed: bool = False,
    command_line: Sequence[str] | None = None,
) -> CampaignResult:
    """Check ``claims`` on ``n`` seeded instances with every solver (a campaign).

    Parameters
    ----------
    n : int
        Instances to draw (:func:`instance_plan`).
    seed : int
        The campaign's seed: the same seed draws the same instances.
    families : sequence of str, optional
        Names of :data:`FAMILIES` to draw from (default all).
    claims : iterable, optional
        Built-in claim names, :class:`~lpbounds.studies.claims.Conjecture` objects or bare
        predicates (:func:`~lpbounds.studies.claims.resolve_claims`; default every
        built-in claim, Remark 2 included: it runs once per campaign).
    solvers : sequence of str, optional
        LP solvers (default :func:`~lpbounds.studies.verify.default_solvers`); ``[]`` for
        solver-free conjectures only.
    n_costs, rtol, exact_method
        As for :func:`~lpbounds.studies.verify.verify_instance` (``exact_method``: policy
        iteration by default, fast on small models at every discount).
    arithmetic : {"float", "rational"}
        ``"rational"``: every claim also decided exactly (see the module docstring).
    exact_size_limit : int, optional
        ``"rational"``: the most variables one exact solve takes (default
        :data:`~lpbounds.tolerances.EXACT_MAX_VARIABLES`); an instance above it gets
        *error* records saying so.
    certificates : bool
        ``"rational"`` with ``out``: write every decided claim's certificate into
        ``out/certificates/`` (listed in the manifest, checked on resume).
    out : str or Path, optional
        The campaign's folder: batches are written there as they finish, each with its
        manifest entry, and a rerun with the same arguments resumes, checking every batch
        on disk first (see the module docstring). None: in memory only.
    fmt : {"csv", "parquet"}
        The batch files' format (Parquet needs pyarrow).
    batch_size : int
        Instances per batch (the unit of work, of a file on disk and of resuming).
    scheduler : str or dask.distributed.Client, optional
        None: serially, here; ``"synchronous"``, ``"threads"``, ``"processes"``: Dask's
        local schedulers; a scheduler's address (``"tcp://127.0.0.1:8786"``) or a
        client: a Dask cluster (conjectures are pickled to its workers). Checked, and an
        address connected to, before anything is written
        (:func:`~lpbounds.studies.compare.check_scheduler`).
    shrink, shrink_inconclusive : bool
        Shrink the instance of every *violated* record (and of every *inconclusive* one).
    shrink_seconds : float
        Time budget of each shrink.
    progress : callable(done, total, note), optional
        Called after each batch (and before each shrink).
    notify : callable(str), optional
        Called with each note of the run as it happens (one line: a batch that failed its
        check and is recomputed, a counterexample not reproduced); all are also in the
        result's ``notes`` and ``metadata.json``.
    rerun_changed : bool
        Resume a campaign whose claims (a conjecture's source, description or
        ``uses_solver``) or lpbounds version changed since its records were made,
        recomputing the records of what changed; False (default): such a folder is
        refused, naming what changed.
    command_line : sequence of str, optional
        Recorded in ``metadata.json`` (default ``sys.argv``).

    Returns
    -------
    CampaignResult

    Raises
    ------
    ValidationError
        Before any work: a bad number, an unknown family, claim or solver, a bad
        ``scheduler`` or an address where none answers, an ``out`` folder that holds a
        campaign with other arguments or whose claims changed (without
        ``rerun_changed``).
    OutputError
        Before any work: ``out`` is a file, a folder that holds something other than a
        campaign, a campaign whose ``campaign.json`` or ``manifest.json`` cannot be read,
        or one written before campaigns kept a manifest (nothing is changed in it).
    """
    from .compare import DASK_LOCAL, check_scheduler, connect_scheduler

    t0 = time.perf_counter()
    chosen = _check_params(n, seed, families, batch_size, n_costs, rtol)
    check_exact_method(exact_method)
    _check_exact(arithmetic, exact_size_limit, certificates, out)
    _check_parquet(fmt)
    claim_list = resolve_claims(claims)
    names = [resolve_solver(s) for s in (default_solvers() if solvers is None else solvers)]
    scheduler = check_scheduler(scheduler)
    params: dict[str, Any] = {
        "n": int(n),
        "seed": int(seed),
        "families": chosen,
        "claims": claim_names(claim_list),
        "solvers": names,
        "n_costs": int(n_costs),
        "rtol": float(rtol),
        "exact_method": exact_method,
        "arithmetic": arithmetic,
        "exact_size_limit": None if exact_size_limit is None else int(exact_size_limit),
        "certificates": bool(certificates),
        "batch_size": int(batch_size),
        "format": fmt,
    }
    fps = {c.name: claim_fingerprint(c) for c in claim_list}
    batches = _batches(params, claim_list, None if out is None else Path(out))
    notes: list[str] = []

    def note(line: str) -> None:
        notes.append(line)
        if notify is not None:
            notify(line)

    client = None
    if isinstance(scheduler, str) and scheduler not in DASK_LOCAL:
        client = scheduler = connect_scheduler(scheduler)  # before anything is written
    try:
        folder = None
        if out is not None:
            folder, changed = _open_folder(Path(out), params, fps, rerun_changed)
            for line in changed:
                note(line)
        ran = _run_batches(batches, folder, scheduler, progress, note)
    finally:
        if client is not None:
            client.close()
    verdicts = ["violated", "inconclusive"] if shrink_inconclusive else ["violated"]
    cexs: list[Counterexample] = []
    if shrink:
        where = None if folder is None else folder.path / "counterexamples"
        cexs = _shrink_all(
            ran.frame, claim_list, verdicts, params, where, shrink_seconds, progress, note
        )
    how = "serial"
    if scheduler is not None:
        how = str(scheduler) if scheduler in DASK_LOCAL else "cluster"
    result = CampaignResult(
        ran.frame,
        params,
        cexs,
        None if folder is None else folder.path,
        time.perf_counter() - t0,
        ran.run,
        len(batches) - ran.run,
        how,
        ran.due,
        ran.missing,
        notes,
    )
    if folder is not None:
        _save(result, folder.path, command_line)
    return result


def campaign_metadata(
    result: CampaignResult, command_line: Sequence[str] | None = None
) -> dict[str, Any]:
    """How a campaign was made, as ``compare`` records a study: :func:`lpbounds.outputs.
    run_metadata` (lpbounds, Python, dependencies, machine, date), the command line, the
    campaign's arguments, per solver its backend and package versions, and this run's
    scheduler, seconds, batches and verdict counts."""
    import sys

    from ..formulations.solvers import solver_distributions
    from ..outputs import run_metadata

    return {
        **run_metadata(),
        "command_line": list(sys.argv if command_line is None else command_line),
        "campaign": dict(result.params),
        "campaign_solvers": solver_distributions(list(result.params["solvers"])),
        "scheduler": result.scheduler,
        "seconds": result.seconds,
        "batches": {"run": result.batches_run, "resumed": result.batches_resumed},
        "records": len(result.frame),
        "due": result.due,
        "missing": dict(result.missing),
        "verdicts": result.verdicts(),
        "counterexamples": [c.row() for c in result.counterexamples],
        "notes": list(result.notes),
    }


def _save(result: CampaignResult, folder: Path, command_line: Sequence[str] | None) -> None:
    """``records.csv`` (and ``.parquet``), ``summary.csv``, ``counterexamples.csv``,
    ``metadata.json``."""
    import pandas as pd

    _write_frame(result.frame, folder / "records.csv")
    if result.params["format"] == "parquet":
        _write_frame(result.frame, folder / "records.parquet")
    write_text_atomic(folder / "summary.csv", result.summary().to_csv(index=False))
    rows = [c.row() for c in result.counterexamples]
    write_text_atomic(folder / "counterexamples.csv", pd.DataFrame(rows).to_csv(index=False))
    meta = campaign_metadata(result, command_line)
    write_text_atomic(folder / "metadata.json", json.dumps(meta, indent=2, default=str) + "\n")
