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
    values: the partition aggregation theory favours) and ``one-block``.

Batches, disk and resuming
    The instances run in batches of ``batch_size`` consecutive indices, serially, on one of
    Dask's local schedulers or on a Dask cluster (``scheduler``: the helper
    :func:`lpbounds.studies.compare.dask_map` that ``compare`` uses). With ``out``, each
    finished batch is written at once (``batches/batch-NNNNNN.csv`` or ``.parquet``,
    atomically), so an interrupted campaign keeps what it finished; running it again with
    the same arguments into the same folder skips the batches on disk and ends with the
    same records as an uninterrupted run. At the end ``out`` holds ``records.csv`` (and
    ``records.parquet``), ``summary.csv`` (per claim and solver,
    :func:`~lpbounds.studies.verify.summarize`), ``counterexamples/`` (shrunk instances as
    model files, ``counterexamples.csv``), ``campaign.json`` (the arguments) and
    ``metadata.json`` (versions, machine, command line, as ``compare`` writes them).

Shrinking
    Every *violated* record (with ``shrink_inconclusive``, every *inconclusive* one too) is
    shrunk (:func:`lpbounds.studies.shrink.shrink`) while the verdict of that claim and
    solver stays the same, and the smallest instance found is written as a model file that
    ``lpbounds solve`` and ``lpbounds verify`` read.

Record columns: :data:`CAMPAIGN_COLUMNS` (:data:`~lpbounds.studies.verify.RECORD_COLUMNS`,
``error``, then the instance's :data:`INSTANCE_COLUMNS`); :data:`TIMING_COLUMNS` are the
only ones that differ between two runs of one campaign.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import OutputError, SolverNotInstalledError, ValidationError
from ..formulations import resolve_solver
from ..model.generators import garnet, random_partition
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from ..outputs import write_atomic, write_text_atomic
from ..status import Verdict
from ..tolerances import LP_COMPARE_RTOL
from .claims import (
    REMARK2,
    Claim,
    claim_names,
    resolve_claims,
    run_claims,
    run_remark2,
)
from .shrink import shrink, size_of, write_model
from .verify import (
    INSTANCE_CHECKS,
    RECORD_COLUMNS,
    Record,
    VerifyInstance,
    check_exact_method,
    default_solvers,
    exact_interval,
    exit_status,
    records_frame,
    summarize,
)

if TYPE_CHECKING:  # annotations only
    import pandas as pd

__all__ = [
    "CAMPAIGN_COLUMNS",
    "FAMILIES",
    "FAMILY_WEIGHTS",
    "INSTANCE_COLUMNS",
    "PARTITION_KINDS",
    "TIMING_COLUMNS",
    "Batch",
    "CampaignInstance",
    "CampaignResult",
    "Counterexample",
    "campaign_instance",
    "draw_discount",
    "instance_plan",
    "read_records",
    "run_batch",
    "run_campaign",
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
    return FiniteMDP(mdp.successors, mdp.probabilities, rewards, mdp.discount, mdp.allowed)


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
    n = mdp.n_states
    if kind == "singletons":
        return Partition.singletons(n)
    if kind == "one-block":
        return Partition(np.zeros(n, dtype=np.int64))
    if kind == "coarse":
        return random_partition(n, min(n, int(rng.integers(2, 4))), seed=int(rng.integers(2**31)))
    low = 1 if kind == "random" else min(n, 2)
    m = int(rng.integers(low, max(low, n // 2) + 1))
    if kind == "random":
        return random_partition(n, m, seed=int(rng.integers(2**31)))
    lo, hi = exact_interval(mdp, "pi")  # value-ordered: runs of consecutive V*
    order = np.argsort(0.5 * (lo + hi), kind="stable")
    labels = np.empty(n, dtype=np.int64)
    labels[order] = np.arange(n) * m // n
    return Partition(labels)


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

    @property
    def stem(self) -> str:
        """The batch file's name without suffix."""
        return "remark2" if self.number < 0 else f"batch-{self.number:06d}"


#: The ``claim`` of the record of an instance that could not be built or checked.
NOT_CHECKED = "the instance could not be checked"


def _not_checked(inst_name: str, claim: Claim, error: str) -> Record:
    nan = float("nan")
    return {
        "check": claim.name,
        "claim": NOT_CHECKED,
        "instance": inst_name,
        "solver": "exact",
        "verdict": Verdict.INCONCLUSIVE,
        "width": nan,
        "deviation": nan,
        "accuracy": nan,
        "index": 0,
        "lp_interval": [nan, nan],
        "exact_interval": [nan, nan],
        "detail": "",
        "error": error,
    }


def run_batch(batch: Batch) -> list[Record]:
    """The records of one batch (a module-level function: Dask ships it to workers).

    Each instance's costs are seeded by its own seed, so a record depends on ``(family,
    seed)``, the claims, the solvers, ``n_costs`` and ``rtol`` only. An instance that cannot
    be built or checked (an exception outside a conjecture's predicate) gives one
    *inconclusive* record per claim whose ``error`` says what was raised.
    """
    claims = list(batch.claims)
    if batch.number < 0:
        records = run_remark2(claims, batch.solvers, seed=batch.seed, rtol=batch.rtol)
        return [{**r, "campaign_index": -1} for r in records]
    out: list[Record] = []
    for k, family, seed in batch.items:
        name = f"{family}:{seed}"
        try:
            inst = campaign_instance(family, seed)
            found = run_claims(
                inst,
                claims,
                batch.solvers,
                n_costs=batch.n_costs,
                seed=seed,
                rtol=batch.rtol,
                exact_method=batch.exact_method,
            )
            extra: dict[str, Any] = inst.params
        except Exception as exc:  # a finding: the campaign goes on with the other instances
            error = f"{type(exc).__name__}: {exc}"
            found = [_not_checked(name, c, error) for c in claims if c.name != REMARK2]
            extra = {"family": family, "seed": seed}
        out += [{**r, **extra, "campaign_index": k} for r in found]
    return out


# ---------------------------------------------------------------------- files
def _frame(records: Sequence[Record]) -> pd.DataFrame:
    """Records as a table of :data:`CAMPAIGN_COLUMNS` (missing entries empty)."""
    frame = records_frame(records)
    for col in CAMPAIGN_COLUMNS:
        if col not in frame:
            frame[col] = "" if col in _STRING_COLUMNS else np.nan
    frame = frame[list(CAMPAIGN_COLUMNS)]
    for col in _STRING_COLUMNS:
        frame[col] = frame[col].fillna("").astype(str)
    return frame


def _write_frame(frame: pd.DataFrame, path: Path) -> None:
    """Write a table atomically (CSV with ``nan`` for missing numbers, or Parquet)."""
    if path.suffix == ".csv":
        write_text_atomic(path, frame.to_csv(index=False, na_rep="nan"))
    else:
        write_atomic(path, lambda tmp: frame.to_parquet(tmp, index=False))


def _read_frame(path: Path) -> pd.DataFrame:
    import pandas as pd

    if path.suffix == ".parquet":
        return pd.read_parquet(path)
    numeric = [c for c in CAMPAIGN_COLUMNS if c not in _STRING_COLUMNS]
    return pd.read_csv(
        path,
        dtype={c: str for c in _STRING_COLUMNS},
        keep_default_na=False,
        na_values={c: ["nan"] for c in numeric},
    )  # pandas' default float parser reads repr() back exactly (its "round_trip")


def read_records(out: str | Path) -> pd.DataFrame:
    """A campaign's records from its folder: the batch files on disk, in campaign order
    (also of an unfinished campaign).

    Parameters
    ----------
    out : str or Path
        The campaign's ``out`` folder.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`CAMPAIGN_COLUMNS`.
    """
    import pandas as pd

    folder = Path(out) / "batches"
    files = sorted(p for p in folder.glob("batch-*") if p.suffix in (".csv", ".parquet"))
    files += [p for p in (folder / "remark2.csv", folder / "remark2.parquet") if p.exists()]
    if not files:
        return _frame([])
    return pd.concat([_read_frame(p) for p in files], ignore_index=True)


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


def _open_folder(out: Path, params: dict[str, Any]) -> None:
    """Create ``out`` for a new campaign, or check that it holds this one (to resume)."""
    manifest = out / "campaign.json"
    if out.exists() and not out.is_dir():
        raise OutputError(f"out: {str(out)!r} is not a folder")
    if manifest.exists():
        old = json.loads(manifest.read_text())
        diff = [k for k in params if old.get(k) != params[k]]
        if diff:
            k = diff[0]
            raise ValidationError(
                f"out: {str(out)!r} holds a campaign with other arguments ({k} = "
                f"{old.get(k)!r}, now {params[k]!r}): rerun with its arguments to resume it, "
                "or give another folder"
            )
        return
    if out.exists() and any(out.iterdir()):
        raise OutputError(
            f"out: {str(out)!r} is not empty and holds no campaign (no campaign.json): "
            "give a new or empty folder"
        )
    (out / "batches").mkdir(parents=True, exist_ok=True)
    write_text_atomic(manifest, json.dumps(params, indent=2) + "\n")


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

    def __call__(self, mdp: FiniteMDP, partition: Partition) -> bool:
        if self.solver == "all":
            solvers: tuple[str, ...] = self.solvers
        else:
            solvers = () if self.solver == "exact" else (self.solver,)
        inst = VerifyInstance("candidate", mdp, partition)
        try:
            found = run_claims(
                inst,
                [self.claim],
                solvers,
                n_costs=self.n_costs,
                seed=self.seed,
                rtol=self.rtol,
                exact_method=self.exact_method,
            )
        except Exception:  # a candidate the claim cannot be checked on shows nothing
            return False
        return any(
            r["claim"] == self.text and r["solver"] == self.solver and r["verdict"] == self.verdict
            for r in found
        )


def _shrink_one(
    row: dict[str, Any], target: _Target, folder: Path | None, max_seconds: float
) -> Counterexample:
    """Shrink the instance of one record (or read a shrink of an earlier run from disk)."""
    digest = hashlib.sha256(str(row["claim"]).encode()).hexdigest()[:6]  # the claim, short
    stem = "-".join(
        (row["family"], str(int(row["seed"])), _slug(row["check"])[:24], _slug(row["solver"]))
    )
    stem = f"{stem}-{digest}"
    head = {k: str(row[k]) for k in ("instance", "check", "claim", "solver", "verdict")}
    if folder is not None and (folder / f"{stem}.json").exists():
        from ..model.instances import load_instance

        saved = json.loads((folder / f"{stem}.json").read_text())
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
    start = campaign_instance(str(row["family"]), int(row["seed"]))
    found = shrink(start.mdp, start.partition, target, max_seconds=max_seconds)
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
        header.append(
            f"check it: lpbounds verify {cex.path.name} --random 0 --solvers {cex.solver}"
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
        )
        out.append(_shrink_one(row, target, folder, max_seconds))
    return out


# ---------------------------------------------------------------------- the campaign
@dataclass(repr=False)
class CampaignResult:
    """A campaign's records, counterexamples and how it was run.

    Attributes
    ----------
    frame : pandas.DataFrame
        One row per (instance, claim, solver), columns :data:`CAMPAIGN_COLUMNS`.
    params : dict
        The arguments that define the campaign (``campaign.json``).
    counterexamples : list of Counterexample
    out : Path or None
    seconds : float
        Wall-clock time of this run (not of earlier runs it resumed).
    batches_run, batches_resumed : int
        Batches computed by this run, and found on disk from an earlier one.
    scheduler : str
        How the batches ran (``"serial"``, a local scheduler's name, ``"cluster"``).
    """

    frame: pd.DataFrame
    params: dict[str, Any]
    counterexamples: list[Counterexample]
    out: Path | None
    seconds: float
    batches_run: int
    batches_resumed: int
    scheduler: str

    def __repr__(self) -> str:
        counts = self.verdicts()
        words = ", ".join(f"{counts[v.value]:,} {v.value}" for v in Verdict)
        return (
            f"CampaignResult({self.params['n']:,} instances, {len(self.frame):,} records: "
            f"{words}; {len(self.counterexamples)} counterexamples)"
        )

    def records(self) -> list[Record]:
        """The records as dicts (flat: :data:`CAMPAIGN_COLUMNS`)."""
        return list(self.frame.to_dict("records"))

    def verdicts(self) -> dict[str, int]:
        """How many records have each verdict."""
        col = self.frame["verdict"]
        return {v.value: int((col == v.value).sum()) for v in Verdict}

    def summary(self) -> pd.DataFrame:
        """One row per (claim, solver): verdict counts and the worst record
        (:func:`~lpbounds.studies.verify.summarize`)."""
        import pandas as pd

        return pd.DataFrame.from_records(summarize(self.records()))

    def exit_status(self, strict: bool = False) -> int:
        """1 if a record is *violated* (with ``strict``, also *inconclusive*), else 0."""
        return exit_status(self.records(), strict=strict)


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


def _batches(params: dict[str, Any], claims: Sequence[Claim]) -> list[Batch]:
    plan = instance_plan(params["n"], params["seed"], params["families"])
    size = params["batch_size"]
    common = (tuple(claims), tuple(params["solvers"]), params["n_costs"], params["rtol"])
    method = params["exact_method"]
    out = [
        Batch(b, tuple(plan[i : i + size]), *common, params["seed"], method)
        for b, i in enumerate(range(0, len(plan), size))
    ]
    if REMARK2 in params["claims"]:
        out.append(Batch(-1, (), *common, params["seed"], method))
    return out


def _run_batches(
    batches: list[Batch],
    params: dict[str, Any],
    folder: Path | None,
    scheduler: str | Any | None,
    progress: CampaignProgress | None,
) -> tuple[pd.DataFrame, int]:
    """Run the batches not on disk yet (all without a folder); the campaign's records and
    how many batches ran."""
    fmt = params["format"]
    on_disk: set[str] = set()
    if folder is not None:
        _open_folder(folder, params)
        on_disk = {p.stem for p in (folder / "batches").glob(f"*.{fmt}")}
    pending = [b for b in batches if b.stem not in on_disk]
    kept: dict[int, list[Record]] = {}
    count = [len(batches) - len(pending)]

    def finish(batch: Batch, records: list[Record]) -> None:
        if folder is not None:
            _write_frame(_frame(records), folder / "batches" / f"{batch.stem}.{fmt}")
        else:
            kept[batch.number] = records
        count[0] += 1
        if progress is not None:
            progress(count[0], len(batches), f"{batch.stem}: {len(records)} records")

    _execute(pending, scheduler, finish)
    if folder is not None:
        return read_records(folder), len(pending)
    order = sorted(kept, key=lambda b: (b < 0, b))
    return _frame([r for b in order for r in kept[b]]), len(pending)


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
    out: str | Path | None = None,
    fmt: str = "csv",
    batch_size: int = 10,
    scheduler: str | Any | None = None,
    shrink: bool = True,
    shrink_inconclusive: bool = False,
    shrink_seconds: float = 60.0,
    progress: CampaignProgress | None = None,
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
    out : str or Path, optional
        The campaign's folder: batches are written there as they finish, and a rerun with
        the same arguments resumes (see the module docstring). None: in memory only.
    fmt : {"csv", "parquet"}
        The batch files' format (Parquet needs pyarrow).
    batch_size : int
        Instances per batch (the unit of work, of a file on disk and of resuming).
    scheduler : str or dask.distributed.Client, optional
        None: serially, here; ``"synchronous"``, ``"threads"``, ``"processes"``: Dask's
        local schedulers; a scheduler's address (``"tcp://127.0.0.1:8786"``) or a
        client: a Dask cluster (conjectures are pickled to its workers).
    shrink, shrink_inconclusive : bool
        Shrink the instance of every *violated* record (and of every *inconclusive* one).
    shrink_seconds : float
        Time budget of each shrink.
    progress : callable(done, total, note), optional
        Called after each batch (and before each shrink).
    command_line : sequence of str, optional
        Recorded in ``metadata.json`` (default ``sys.argv``).

    Returns
    -------
    CampaignResult

    Raises
    ------
    ValidationError
        Before any work: a bad number, an unknown family, claim or solver, or an ``out``
        folder that holds a campaign with other arguments.
    OutputError
        ``out`` is a file, or a folder that holds something other than a campaign.
    """
    t0 = time.perf_counter()
    chosen = _check_params(n, seed, families, batch_size, n_costs, rtol)
    check_exact_method(exact_method)
    _check_parquet(fmt)
    claim_list = resolve_claims(claims)
    names = [resolve_solver(s) for s in (default_solvers() if solvers is None else solvers)]
    params: dict[str, Any] = {
        "n": int(n),
        "seed": int(seed),
        "families": chosen,
        "claims": claim_names(claim_list),
        "solvers": names,
        "n_costs": int(n_costs),
        "rtol": float(rtol),
        "exact_method": exact_method,
        "batch_size": int(batch_size),
        "format": fmt,
    }
    batches = _batches(params, claim_list)
    folder = None if out is None else Path(out)
    frame, n_run = _run_batches(batches, params, folder, scheduler, progress)
    verdicts = ["violated", "inconclusive"] if shrink_inconclusive else ["violated"]
    cexs: list[Counterexample] = []
    if shrink:
        where = None if folder is None else folder / "counterexamples"
        cexs = _shrink_all(frame, claim_list, verdicts, params, where, shrink_seconds, progress)
    how = "serial"
    if scheduler is not None:
        from .compare import DASK_LOCAL

        how = str(scheduler) if scheduler in DASK_LOCAL else "cluster"
    result = CampaignResult(
        frame,
        params,
        cexs,
        folder,
        time.perf_counter() - t0,
        n_run,
        len(batches) - n_run,
        how,
    )
    if folder is not None:
        _save(result, folder, command_line)
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
        "verdicts": result.verdicts(),
        "counterexamples": [c.row() for c in result.counterexamples],
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
