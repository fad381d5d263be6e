"""Fingerprints of the numbers lpbounds computes, to show a change left them bit-identical.

Prints one line per item: a SHA-256 prefix (16 hex digits) of the exact bytes of

* V* and the policy of every packaged model (``solve_exact``, default MPI), and V* of the
  small ones by policy iteration;
* RLP's exact least fixed point of the packaged models that carry a partition (the row
  system's V* by MPI, no LP solver: a solver's answer may differ between versions);
* ``lpbounds reproduce`` of ``patrol-small`` (and, with ``--paper``, of the paper's
  instance): ``summary.json`` with its timings and machine fields removed, and every
  array of ``values.npz``.

Run it on two trees (an old worktree and the new one) and ``diff`` the outputs::

    python benchmarks/fingerprints.py > before.txt   # on the old tree
    python benchmarks/fingerprints.py > after.txt    # on the new tree
    diff before.txt after.txt

``--paper`` adds the paper's instance to the reproduction (about a minute); the 5-8
station patrols are never solved here (``reproduce --beyond`` checks those).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

#: packaged models solved here (the 5-8 station patrols take minutes to hours)
MODELS = (
    "cliffwalking",
    "forest",
    "frozenlake",
    "garnet-small",
    "garnet-paper-scale",
    "gridworld",
    "inventory",
    "patrol-small",
    "patrol-paper",
    "queue",
    "savings",
    "taxi",
)
#: small enough for policy iteration with direct evaluation
PI_MODELS = ("cliffwalking", "forest", "frozenlake", "gridworld", "inventory", "queue", "savings")
#: summary.json keys that hold timings, dates or the machine (not numbers of the method):
#: these names, and every key containing "seconds"
VOLATILE = {"timing", "machine", "date", "peak_rss_mb", "elapsed", "created"}


def digest(*arrays: Any) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def _strip(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k not in VOLATILE and "seconds" not in k}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def models() -> None:
    from lpbounds.dp import solve_exact
    from lpbounds.model.instances import load_instance

    for name in MODELS:
        try:
            inst = load_instance(name)
            mdp = inst.mdp()
        except Exception as exc:  # a model that needs an optional package
            print(f"{name:24s} V*+policy  unavailable ({type(exc).__name__})")
            continue
        r = solve_exact(mdp)
        print(f"{name:24s} V*+policy  {digest(r.values, r.policy)}", flush=True)
        if name in PI_MODELS:
            p = solve_exact(mdp, "pi")
            print(f"{name:24s} V* (pi)    {digest(p.values, p.policy)}", flush=True)
        if inst.has_partition and mdp.n_states <= 400_000:
            from lpbounds.rows import BellmanRows

            rows = BellmanRows.aggregate(mdp, inst.partition())
            f = solve_exact(rows)
            print(f"{name:24s} RLP fixed   {digest(f.values)}", flush=True)


def reproduction(name: str) -> None:
    from lpbounds.patrol.reproduce import reproduce

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        reproduce(name, out, seeds=(1, 2), n_steps=3000, figures=False)
        summary = _strip(json.loads((out / "summary.json").read_text()))
        text = json.dumps(summary, sort_keys=True).encode()
        print(f"reproduce {name:14s} summary.json  {hashlib.sha256(text).hexdigest()[:16]}")
        with np.load(out / "values.npz") as z:
            for key in sorted(z.files):
                print(f"reproduce {name:14s} values[{key}]  {digest(z[key])}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paper", action="store_true", help="also reproduce the paper's instance")
    ap.add_argument("--no-models", action="store_true", help="only the reproduction")
    args = ap.parse_args(argv)
    if not args.no_models:
        models()
    reproduction("patrol-small")
    if args.paper:
        reproduction("patrol-paper")
    return 0


if __name__ == "__main__":
    sys.exit(main())
