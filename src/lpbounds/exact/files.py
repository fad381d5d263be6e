r"""The certificate file format: model data, the file's layout, and the writer.

A certificate is one JSON object, checked by :mod:`lpbounds.exact.check` (standard
library only)::

    {
      "format": "lpbounds-exact-certificate", "version": 1,
      "claim": {"name": "Theorem 1", "statement": "...", "instance": "...",
                "verdict": "holds" | "violated", "comparisons": [COMPARISON, ...]},
      "model": MODEL, "model_digest": "<sha256 of MODEL's canonical JSON>",
      "lps": [LP, ...], "fixed_points": [FIXED_POINT, ...],
      "meta": {...}                      # provenance: versions, seconds (not checked)
    }

``MODEL``: ``{"kind": "mdp", "n_states", "n_actions", "discount", "successors" [x][u][l],
"probabilities" [x][u][l] (or "shared_probabilities" [l]), "rewards" [x][u],
"allowed" [x][u] (0/1; omitted when every action is allowed), "partition" [x] (optional)}``
or ``{"kind": "rows", "n_vars", "discount", "owner", "action", "reward", "targets", "probs"
(or "shared_probabilities")}`` (a row system given as data: UBLP, LBLP). Every real
number of the model is a hex float (``float.hex``): the stored double, exactly.

``LP``: ``{"id", "lp": {"formulation": "ELP" | "RLP" | "IB" | "SLP" | "LLP" | "ALP" |
"ROWS", "cost": [...], and "L" (IB), "mu" (SLP: a vector over the allowed pairs), "d"
(LLP: over the pairs), "basis" and "state_cost" (ALP)}, "x": VECTOR, "y": VECTOR,
"objective": "p/q", "unique": bool}``: ``x`` the exact optimum, ``y`` the exact duals
(one per row, in the checker's row order: the allowed pairs row-major, block by block for
IB, then LLP's three groups).

``FIXED_POINT``: ``{"id", "rows": "ELP" | "RLP" | "IB" | "ROWS" | "NLP" | "SLP", "x":
VECTOR, "game": bool, ...}``.

``VECTOR``: ``{"den": "D", "num": ["N_1", ...]}``, entry ``i`` being ``N_i / D`` (decimal
integers; one common denominator, so that checking is integer arithmetic).

``COMPARISON``: ``{"claim", "left": EXPR, "right": EXPR, "relation": "==" | ">=" | ">",
"difference": "p/q", "verdict"}`` with ``EXPR`` ``{"of": id, "part": "x" | "objective" |
"lp.<field>", "slice": [a, b], "lift": bool}``, ``{"sum": [EXPR, ...]}`` or ``{"vector":
VECTOR}`` (numbers stated in the file: a conjecture's own values, compared as given); the
difference is ``max |left - right|`` for ``==`` and ``min (left - right)`` otherwise.
"""

from __future__ import annotations

import json
import platform
from pathlib import Path
from typing import Any

import numpy as np

from .._defaults import VERSION as LPBOUNDS_VERSION
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from ..outputs import write_text_atomic
from ..rows import BellmanRows
from . import check

__all__ = ["certificate", "mdp_data", "rows_data", "write_certificate"]


def _hex(a: Any) -> Any:
    """Nested lists of hex floats of an array."""
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 0:
        return float(arr).hex()
    return [_hex(t) for t in arr]


def mdp_data(mdp: FiniteMDP, partition: Partition | None = None) -> dict[str, Any]:
    """The certificate's MODEL of an MDP (and optionally a partition): the stored doubles
    as hex floats, exactly."""
    out: dict[str, Any] = {
        "kind": "mdp",
        "n_states": mdp.n_states,
        "n_actions": mdp.n_actions,
        "discount": float(mdp.discount).hex(),
        "successors": np.asarray(mdp.successors).tolist(),
        "rewards": _hex(np.where(mdp.allowed, mdp.rewards, 0.0)),
    }
    if mdp.shared_probabilities:
        out["shared_probabilities"] = _hex(mdp.probabilities)
    else:
        out["probabilities"] = _hex(mdp.probabilities)
    if not mdp.allowed.all():
        out["allowed"] = mdp.allowed.astype(int).tolist()
    if partition is not None:
        if partition.n_states != mdp.n_states:
            from ..errors import ValidationError

            raise ValidationError(
                f"the partition has {partition.n_states} states but the MDP has {mdp.n_states}"
            )
        out["partition"] = np.asarray(partition.labels).tolist()
    return out


def rows_data(rows: BellmanRows) -> dict[str, Any]:
    """The certificate's MODEL of a row system (``kind="rows"``), rows in stored order."""
    probs = np.asarray(rows.probs)
    out: dict[str, Any] = {
        "kind": "rows",
        "n_vars": rows.n_vars,
        "discount": float(rows.discount).hex(),
        "owner": np.asarray(rows.owner).tolist(),
        "action": np.asarray(rows.action).tolist(),
        "reward": _hex(rows.reward),
        "targets": np.asarray(rows.targets).tolist(),
    }
    if probs.ndim == 2 and probs.strides[0] == 0:
        out["shared_probabilities"] = _hex(probs[0])
    else:
        out["probs"] = _hex(probs)
    return out


def certificate(
    claim: dict[str, Any],
    model: dict[str, Any],
    lps: list[dict[str, Any]] | None = None,
    fixed_points: list[dict[str, Any]] | None = None,
    meta: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """A certificate (the JSON object of the module docstring), checked before it is
    returned: a certificate lpbounds cannot verify is a defect, never a file.

    Raises
    ------
    ConsistencyError
        If :func:`lpbounds.exact.check.check_certificate` rejects it.
    """
    from ..errors import ConsistencyError

    cert = {
        "format": check.FORMAT,
        "version": check.VERSION,
        "claim": claim,
        "model": model,
        "model_digest": check.digest(model),
        "lps": lps or [],
        "fixed_points": fixed_points or [],
        "meta": {
            "lpbounds": LPBOUNDS_VERSION,
            "python": platform.python_version(),
            **(meta or {}),
        },
    }
    try:
        check.check_certificate(cert)
    except check.CheckError as exc:
        raise ConsistencyError(
            f"the certificate of {claim.get('name')!r} fails its check: {exc}"
        ) from exc
    return cert


def write_certificate(path: str | Path, cert: dict[str, Any]) -> Path:
    """Write ``cert`` to ``path`` atomically (a complete file or none)."""
    p = Path(path)
    write_text_atomic(p, json.dumps(cert, indent=1) + "\n")
    return p
