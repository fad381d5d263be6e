"""How accurate the LP solvers are at their default settings, certified: the table of
docs/tolerances.md ("Measured at the solvers' default settings").

For each model and formulation below, HiGHS and Clarabel solve at their default settings
and lpbounds certifies the returned point (``lower_values``/``upper_values``, never the
solver's status): the table shows the certified error over the value scale
``max|R| / (1 - lambda)`` (``result.relative_error``) and, for a result that is not
``optimal``, its status and the width of its certified bracket. Writes the ``lp-accuracy``
section of docs/tolerances.md; ``tests/project/test_docs_numbers.py`` solves the same rows again
and fails when the page and a fresh run disagree (the ``patrol-paper`` rows, about two
minutes, only in the slow suite).

    python benchmarks/bench_lp_accuracy.py
"""

from __future__ import annotations

import argparse
import datetime as _dt
from pathlib import Path
from typing import Any

PAGE = Path(__file__).resolve().parents[1] / "docs" / "tolerances.md"
SOLVERS = ("HIGHS", "CLARABEL")

#: (model as the page names it, LP): every row of the table, in order
ROWS = (
    ("garnet-small (300 states, 0.9)", "ELP"),
    ("garnet-small (300 states, 0.9)", "RLP"),
    ("garnet-small (300 states, 0.9)", "IB(3)"),
    ("patrol-small", "ELP"),
    ("patrol-small", "RLP"),
    ("patrol-small", "UBLP"),
    ("patrol-small", "LBLP"),
    ("patrol-paper (8,900 partitions)", "UBLP"),
    ("patrol-paper (8,900 partitions)", "LBLP"),
    ("garnet(200, 3, 4, 0.99, seed=1)", "ELP"),
)


def formulation(model: str, lp: str) -> Any:
    """The formulation of one row of :data:`ROWS`, built afresh."""
    import lpbounds as lb
    from lpbounds.formulations import ELP, IB, RLP
    from lpbounds.patrol.bounds import LBLP, UBLP
    from lpbounds.patrol.instance import params_from_instance

    if model.startswith("patrol-"):
        params = params_from_instance(model.split(" ")[0])
        if lp in ("UBLP", "LBLP"):
            return (UBLP if lp == "UBLP" else LBLP)(params)
        inst = lb.load_instance(model.split(" ")[0])
    elif model.startswith("garnet-small"):
        inst = lb.load_instance("garnet-small")
    else:  # garnet(200, 3, 4, 0.99, seed=1)
        return ELP(lb.garnet(200, 3, 4, 0.99, seed=1))
    mdp, part = inst.mdp(), inst.partition()
    if lp == "ELP":
        return ELP(mdp)
    if lp == "RLP":
        return RLP(mdp, part)
    return IB(mdp, part, 3)


def measure(model: str, lp: str, solver: str) -> dict[str, Any]:
    """One cell: the status, the certified relative error and the bracket's width."""
    res = formulation(model, lp).solve(solver, raise_on_failure=False)
    return {
        "status": str(res.status),
        "relative_error": float(res.relative_error),
        "width": float((res.upper_values - res.lower_values).max()),
    }


def cell(m: dict[str, Any]) -> str:
    """A table cell: the relative error, and the status and width when not optimal."""
    if m["status"] == "optimal":
        return f"{m['relative_error']:.1e}"
    return f"{m['relative_error']:.1e} **{m['status']}**, bracket width {m['width']:.1e}"


def versions() -> str:
    import importlib.metadata as md

    return ", ".join(f"{p} {md.version(p)}" for p in ("highspy", "clarabel", "cvxpy"))


def section(cells: dict[tuple[str, str, str], dict[str, Any]]) -> str:
    """The ``lp-accuracy`` section's Markdown from measured cells."""
    date = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d")
    lines = [
        f"Measured at the solvers' default settings ({date}; {versions()}; "
        "`python benchmarks/bench_lp_accuracy.py`): the certified error over the value "
        "scale `max|R| / (1 - lambda)`, and for a result that is not `optimal` its status "
        "and the width of its certified bracket, which is still a valid bound.",
        "",
        "| model | LP | HiGHS | Clarabel |",
        "| --- | --- | --- | --- |",
    ]
    for model, lp in ROWS:
        row = " | ".join(cell(cells[model, lp, s]) for s in SOLVERS)
        lines.append(f"| {model} | {lp} | {row} |")
    return "\n".join(lines)


def main() -> None:
    from _common import write_section

    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    cells = {}
    for model, lp in ROWS:
        for solver in SOLVERS:
            cells[model, lp, solver] = m = measure(model, lp, solver)
            print(f"{model:>34} {lp:>6} {solver:>9}: {cell(m)}", flush=True)
    write_section("lp-accuracy", section(cells), page=PAGE)
    print(f"wrote the lp-accuracy section of {PAGE}")


if __name__ == "__main__":
    main()
