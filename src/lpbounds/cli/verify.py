"""``lpbounds verify [MODEL]``: theorem verdicts (holds / violated / inconclusive) per solver.

Exit status 1 only when a claim is *violated* (the certified intervals prove it false);
``--strict`` also fails on *inconclusive*. See :mod:`lpbounds.studies.verify`.

With ``--out DIR`` it runs a campaign (:mod:`lpbounds.studies.campaign`): ``--random N``
instances drawn from the families, records streamed to DIR per batch, resumed when the
same command is run again, violated instances shrunk to model files.

With ``--arithmetic rational`` every claim is also decided exactly (holds or violated, never
inconclusive; docs/exact.md), each solver's answer judged against the exact optimum, and
``--certificates`` writes the proofs (``python -m lpbounds.exact.check`` verifies them)."""

from __future__ import annotations

import argparse
from typing import Any

from rich import box
from rich.markup import escape
from rich.table import Table

from ..errors import SizeLimitError, ValidationError
from ..text import fmt_number, fmt_sci
from ..tolerances import EXACT_MAX_VARIABLES, LP_COMPARE_RTOL
from ._common import (
    console,
    err_console,
    nonnegative_int,
    positive_float,
    positive_int,
    print_table,
    progress,
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "verify",
        help="check Lemma 1, Theorems 1-2, Lemma 2 and Remark 2 across LP solvers",
        description=(
            "Solve ELP, RLP, SLP(mu-bar), IB (L=1..5), LLP and ALP with each solver and "
            "compare certified intervals with the exact fixed points (value iteration): each "
            "claim holds, is violated (the intervals prove it false) or is inconclusive (not "
            "accurate enough to decide). Exits 1 only on a violated claim (--strict: also on "
            "an inconclusive one). With --out DIR: a campaign of --random N instances drawn "
            "from the families, streamed to DIR, resumable, counterexamples shrunk."
        ),
    )
    p.add_argument(
        "model",
        metavar="MODEL",
        nargs="?",
        default=None,
        help="instance file or name in models/ (default: every model with a partition "
        "and at most --max-states states)",
    )
    p.add_argument(
        "--solvers",
        nargs="+",
        metavar="SOLVER",
        default=None,
        help="LP solvers by cvxpy name, e.g. HIGHS CLARABEL SCIPY (default: those of the three "
        "installed here; a missing solver is refused with its install command, an unknown name "
        "with the list of installed ones)",
    )
    p.add_argument(
        "--random",
        type=nonnegative_int,
        default=5,
        metavar="N",
        help="random instances (default 5): seeded garnets, or with --out the campaign's instances",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the random instances and costs")
    p.add_argument(
        "--costs",
        type=nonnegative_int,
        default=3,
        metavar="K",
        help="random costs per LP (default 3)",
    )
    p.add_argument(
        "--rtol",
        type=float,
        default=LP_COMPARE_RTOL,
        help="requested accuracy relative to max|R|/(1-lambda): a claim holds when the "
        f"certified intervals allow no larger difference (default {fmt_number(LP_COMPARE_RTOL)})",
    )
    p.add_argument("--strict", action="store_true", help="also exit 1 when a claim is inconclusive")
    p.add_argument(
        "--max-states",
        type=positive_int,
        default=10_000,
        help="size cap of the default models (default 10,000)",
    )
    p.add_argument("--json", metavar="PATH", help="also write the records as JSON")
    p.add_argument(
        "--claims",
        nargs="+",
        metavar="CLAIM",
        default=None,
        help="the claims to check (default all built in): 'Lemma 1', theorem1, lemma2, "
        "theorem2, remark2, or a conjecture of your own as FILE.py:NAME or module:NAME "
        "(a Conjecture or a predicate over a Trial)",
    )
    _add_exact_arguments(p)
    _add_campaign_arguments(p)
    p.set_defaults(func=run)


def _add_exact_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("exact verdicts (rational arithmetic on the stored model)")
    g.add_argument(
        "--arithmetic",
        choices=("float", "rational"),
        default="float",
        help="float (default): certified floating-point intervals (holds, violated or "
        "inconclusive); rational: every claim also decided exactly (holds or violated), "
        "each solver's answer judged against the exact optimum",
    )
    g.add_argument(
        "--certificates",
        nargs="?",
        const=True,
        default=None,
        metavar="DIR",
        help="with --arithmetic rational: write one certificate per decided claim and "
        "instance into DIR (with --out: into DIR/certificates, no DIR given), checked by "
        "python -m lpbounds.exact.check",
    )
    g.add_argument(
        "--exact-size-limit",
        type=positive_int,
        default=None,
        metavar="N",
        help="with --arithmetic rational: the most variables one exact solve takes "
        f"(default {EXACT_MAX_VARIABLES}); a larger instance is refused before any work",
    )


def _add_campaign_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group(
        "campaign (with --out DIR: --random N instances drawn from the families)"
    )
    g.add_argument(
        "--out",
        metavar="DIR",
        default=None,
        help="run a campaign into DIR: records written per batch as they finish "
        "(batches/), records.csv, summary.csv, counterexamples/, metadata.json; the same "
        "command run again resumes it",
    )
    g.add_argument(
        "--families",
        nargs="+",
        metavar="FAMILY",
        default=None,
        help="instance families: garnet, masked-garnet, shelf, patrol (default all)",
    )
    g.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run through Dask: an existing cluster (tcp://127.0.0.1:8786) or a local "
        "scheduler (synchronous, threads, processes); pip install 'lpbounds[study]'",
    )
    g.add_argument(
        "--batch-size",
        type=positive_int,
        default=10,
        metavar="K",
        help="instances per batch (default 10)",
    )
    g.add_argument(
        "--format",
        choices=("csv", "parquet"),
        default="csv",
        help="the batch files' format (default csv; parquet needs pyarrow)",
    )
    g.add_argument(
        "--shrink-inconclusive",
        action="store_true",
        help="also shrink the instances of inconclusive records (violated ones always are)",
    )
    g.add_argument(
        "--shrink-seconds",
        type=positive_float,
        default=60.0,
        metavar="S",
        help="time budget of each shrink in seconds (default 60)",
    )
    g.add_argument(
        "--rerun-changed",
        action="store_true",
        help="resume a campaign whose conjectures (their files) or lpbounds version changed "
        "since its records were made, recomputing the records of what changed (without "
        "it such a folder is refused, naming what changed)",
    )


def _check_exact_arguments(args: argparse.Namespace) -> None:
    """--certificates and --exact-size-limit need --arithmetic rational; --certificates
    needs a DIR without --out, and none (or DIR/certificates) with it."""
    from pathlib import Path

    rational = args.arithmetic == "rational"
    for opt, value in (("--certificates", args.certificates),
                       ("--exact-size-limit", args.exact_size_limit)):  # fmt: skip
        if value is not None and not rational:
            raise ValidationError(f"{opt} belongs to exact verdicts: give --arithmetic rational")
    cert = args.certificates
    if args.out is None and cert is True:
        raise ValidationError("--certificates: give the folder to write them into (DIR)")
    if args.out is not None and isinstance(cert, str):
        inside = Path(args.out) / "certificates"
        if Path(cert).resolve() != inside.resolve():
            raise ValidationError(
                f"--certificates {cert!r}: a campaign writes its certificates into "
                f"{str(inside)!r} (covered by its manifest): give --certificates alone"
            )


def run(args: argparse.Namespace) -> int:
    from ..formulations import resolve_solver
    from ..studies.claims import load_claim
    from ..studies.verify import default_solvers

    _check_exact_arguments(args)
    claims = None if args.claims is None else [load_claim(c) for c in args.claims]
    if args.out is not None:
        return _run_campaign(args, claims)
    given = [
        opt
        for opt, value in (
            ("--families", args.families),
            ("--scheduler", args.scheduler),
            ("--shrink-inconclusive", args.shrink_inconclusive or None),
            ("--rerun-changed", args.rerun_changed or None),
        )
        if value is not None
    ]
    if given:
        raise ValidationError(f"{given[0]} belongs to a campaign: give --out DIR as well")
    if args.json:  # before any computation, as every command checks its outputs
        from ..outputs import check_output_file

        check_output_file(args.json, "--json")
    solvers = [resolve_solver(s) for s in (args.solvers or default_solvers())]
    return _run_models(args, solvers, claims)


def _run_models(args: argparse.Namespace, solvers: list[str], claims: list | None) -> int:
    """The packaged models (or MODEL) and --random N seeded garnets, every record shown."""
    from ..studies.claims import resolve_claims, run_claims, split_claims
    from ..studies.verify import (
        INSTANCE_CHECKS,
        exit_status,
        model_instances,
        random_instances,
        verify_instance,
        verify_remark2,
        write_json,
    )

    checks, conjectures, remark2 = split_claims(resolve_claims(claims))
    insts, skipped = model_instances(
        None if args.model is None else [args.model], max_states=args.max_states
    )
    insts += random_instances(args.random, args.seed)
    exact: dict[str, Any] = {}
    if args.arithmetic == "rational":
        exact = {
            "arithmetic": "rational",
            "exact_size_limit": args.exact_size_limit,
            "certificates": args.certificates,
        }
    records = []
    with progress() as prog:
        task = prog.add_task("verifying", total=len(insts) + 1, status="")

        def say(msg: str) -> None:
            prog.update(task, status=escape(msg))

        for inst in insts:
            prog.update(task, description=f"verifying {escape(inst.name)}")
            try:
                if checks:
                    records += verify_instance(
                        inst,
                        solvers,
                        n_costs=args.costs,
                        seed=args.seed,
                        rtol=args.rtol,
                        progress=say,
                        checks=None if len(checks) == len(INSTANCE_CHECKS) else checks,
                        **exact,
                    )
                if conjectures:
                    records += run_claims(
                        inst, conjectures, solvers, n_costs=args.costs, seed=args.seed,
                        rtol=args.rtol, progress=say, **exact,
                    )  # fmt: skip
            except SizeLimitError as exc:
                raise _size_refused(inst.name, exc) from None
            prog.advance(task)
        if remark2:
            prog.update(task, description="Remark 2 (soft aggregation)")
            records += verify_remark2(solvers, seed=args.seed, rtol=args.rtol, **exact)
        prog.advance(task)
    for table in _records_tables(records):
        print_table(table)
    print_table(_summary_table(records))
    if skipped:
        console.print(
            f"skipped (more than {args.max_states} states or size unknown; name one to "
            f"verify it): {', '.join(skipped)}"
        )
    if args.json:
        write_json(records, args.json)
    _say_errors(sum(r["verdict"] == "error" for r in records))
    _say_exact(records, args)
    return exit_status(records, strict=args.strict)


def _size_refused(name: str, exc: SizeLimitError) -> ValidationError:
    """An instance above the exact size limit, in the command line's words: one line."""
    if exc.size is None or exc.limit is None:
        return exc
    return ValidationError(
        f"{name}: exact arithmetic solves {exc.size} variables together, above the limit of "
        f"{exc.limit} (a dense rational solve grows as n^3); --exact-size-limit {exc.size} "
        "lifts it"
    )


def _say_exact(records: list[dict], args: argparse.Namespace) -> None:
    """Rational arithmetic: one line of what exact arithmetic decided beyond the float
    intervals, and of the defects it found (a bracket that missed; a float *violated*
    that holds exactly), and where the certificates are."""
    if args.arithmetic != "rational":
        return
    from ..studies.verify import summarize

    rows = summarize(records)
    opened = sum(row.get("float_inconclusive", 0) for row in rows)
    missed = sum(row.get("missed", 0) for row in rows)
    disagree = sum(row.get("disagree", 0) for row in rows)
    where = ""
    if args.certificates:
        names = {r["certificate"] for r in records if r.get("certificate")}
        folder = args.out + "/certificates" if args.out else args.certificates
        where = f"; {len(names):,} certificates in {folder}"
    console.print(
        f"exact: every claim decided in rational arithmetic; float intervals had left "
        f"{_count(opened, 'record')} inconclusive; {_count(disagree, 'float verdict')} "
        f"other than the exact one; {_count(missed, 'certified bracket')} outside its exact "
        f"optimum{where}",
        highlight=False,
        soft_wrap=True,
        markup=False,
    )


def _run_campaign(args: argparse.Namespace, claims: list | None) -> int:
    """``--out DIR``: a campaign of --random N drawn instances, streamed to DIR."""
    from pathlib import Path

    from ..studies.campaign import run_campaign
    from ..studies.compare import check_scheduler

    if args.model is not None:
        raise ValidationError(
            f"MODEL ({args.model!r}) and --out: a campaign draws its instances from "
            "--families; verify a model without --out"
        )
    if args.json:
        raise ValidationError("--json and --out: a campaign writes DIR/records.csv")
    out = Path(args.out)
    scheduler = check_scheduler(args.scheduler)  # before DIR is touched

    def note(line: str) -> None:  # a batch recomputed, a counterexample not reproduced
        err_console.print(f"lpbounds verify: {line}", highlight=False, soft_wrap=True, markup=False)

    with progress() as prog:
        task = prog.add_task("campaign", total=None, status="")

        def report(done: int, total: int, note: str) -> None:
            prog.update(task, total=total, completed=done, description=f"campaign {out}")
            prog.update(task, status=note)
            if not err_console.is_terminal:  # a log file: one plain line per batch
                err_console.print(
                    f"lpbounds verify: {done}/{total} {note}", highlight=False, soft_wrap=True
                )

        try:
            result = run_campaign(
                args.random,
                args.seed,
                families=args.families,
                claims=claims,
                solvers=args.solvers,
                n_costs=args.costs,
                rtol=args.rtol,
                arithmetic=args.arithmetic,
                exact_size_limit=args.exact_size_limit,
                certificates=args.certificates is not None,
                out=out,
                fmt=args.format,
                batch_size=args.batch_size,
                scheduler=scheduler,
                shrink_inconclusive=args.shrink_inconclusive,
                shrink_seconds=args.shrink_seconds,
                progress=report,
                notify=note,
                rerun_changed=args.rerun_changed,
                command_line=["lpbounds", *getattr(args, "argv", [])],
            )
        except KeyboardInterrupt:
            done = len(list((out / "batches").glob(f"*.{args.format}")))
            err_console.print(
                f"lpbounds verify: {done} finished batch{'es' if done != 1 else ''} kept in "
                f"{str(out)!r}; run the same command again to resume",
                highlight=False,
                soft_wrap=True,
            )
            raise
    _print_campaign(result)
    _say_exact(result.records(), args)
    _say_refused(result.records())
    return result.exit_status(strict=args.strict)


def _say_refused(records: list[dict]) -> None:
    """One line when instances were above the exact size limit (their records are
    errors): how many, and the --exact-size-limit that lifts it for all."""
    import re

    sizes = {
        r["instance"]: int(m.group(1))
        for r in records
        if (m := re.match(r"SizeLimitError: (\d+) variables", str(r.get("error", ""))))
    }
    if sizes:
        err_console.print(
            f"lpbounds verify: {len(sizes)} instance{'s' if len(sizes) != 1 else ''} above the "
            "exact size limit, not decided (error records); --exact-size-limit "
            f"{max(sizes.values())} lifts it",
            highlight=False,
            soft_wrap=True,
            markup=False,
        )


#: Counterexamples listed on the console (the smallest first; all are in counterexamples.csv).
SHOWN_COUNTEREXAMPLES = 10


def _print_counterexamples(result: Any) -> None:
    cexs = sorted(
        result.counterexamples,
        key=lambda c: (c.shrunk["states"], c.shrunk["blocks"], c.shrunk["actions"]),
    )
    table = Table(
        title=f"{len(cexs)} counterexamples, shrunk (model files lpbounds solve and verify read)",
        title_justify="left",
        box=box.SIMPLE_HEAD,
        show_edge=False,
        padding=(0, 1, 0, 0),
    )
    for col in ("check", "solver", "states", "actions", "blocks", "shrunk from"):
        table.add_column(col, no_wrap=True, justify="right" if col[-1] == "s" else "left")
    for c in cexs[:SHOWN_COUNTEREXAMPLES]:
        table.add_row(
            escape(c.check),
            c.solver,
            str(c.shrunk["states"]),
            str(c.shrunk["actions"]),
            str(c.shrunk["blocks"]),
            f"{c.instance} ({c.original['states']} states)",
        )
    print_table(table)
    folder = escape(str(result.out / "counterexamples"))
    more = len(cexs) - SHOWN_COUNTEREXAMPLES
    console.print(
        (f"... and {more} more; " if more > 0 else "")
        + f"model files in {folder}/ (one per row, named after the instance; "
        "counterexamples.csv lists them)",
        highlight=False,
    )


def _print_campaign(result: Any) -> None:
    counts = result.verdicts()
    params = result.params
    resumed = (
        f" ({result.batches_resumed} of {result.batches_run + result.batches_resumed} batches "
        "from an earlier run)"
        if result.batches_resumed
        else ""
    )
    lacking = sum(result.missing.values())
    due = "none missing" if not lacking else f"{lacking:,} of {result.due:,} due missing"
    sizes = (
        f"{_count(params['n'], 'instance')} x {_count(len(params['claims']), 'claim')} x "
        f"{_count(len(params['solvers']), 'solver')}"
    )
    console.print(
        f"lpbounds verify: {sizes}: {len(result.frame):,} records on disk, {due}: "
        f"{counts['holds']:,} hold, {counts['inconclusive']:,} inconclusive, "
        f"{counts['violated']:,} violated, {counts['error']:,} errors in "
        f"{result.seconds:.1f} s{resumed}",
        highlight=False,
        soft_wrap=True,
    )
    print_table(_summary_table(result.records()))
    if result.counterexamples:
        _print_counterexamples(result)
    console.print(f"records: {escape(str(result.out / 'records.csv'))}", highlight=False)
    _say_errors(counts["error"])
    if lacking:
        names = ", ".join(f"{stem} ({k})" for stem, k in result.missing.items())
        err_console.print(
            f"lpbounds verify: error: records due are missing from {len(result.missing)} "
            f"batch{'es' if len(result.missing) != 1 else ''}: {names}; run the same command "
            "again to recompute them",
            highlight=False,
            soft_wrap=True,
        )


def _count(k: int, word: str) -> str:
    return f"{k:,} {word}{'s' if k != 1 else ''}"


def _say_errors(count: int) -> None:
    """One line on stderr when records are errors (they also fail the exit status)."""
    if count:
        err_console.print(
            f"lpbounds verify: {count:,} record{'s are errors' if count != 1 else ' is an error'} "
            "(no verdict: a predicate raised, exited or returned none, or an instance could "
            "not be checked); the error column says why",
            highlight=False,
            soft_wrap=True,
        )


_STYLE = {"holds": "green", "inconclusive": "yellow", "violated": "bold red", "error": "bold red"}


def _verdict(v: str) -> str:
    return f"[{_STYLE[v]}]{v}[/]"


def _records_tables(records: list[dict]) -> list[Table]:
    """The records, one table per instance, each at most 100 columns wide (the claim and
    how it was checked fold; the numbers never do)."""
    counts = {v: sum(r["verdict"] == v for r in records) for v in _STYLE}
    tables: list[Table] = []
    by_instance: dict[str, list[dict]] = {}
    for r in records:
        by_instance.setdefault(r["instance"], []).append(r)
    for i, (instance, rows) in enumerate(by_instance.items()):
        title = f"{instance}"
        if i == 0:
            title = (
                f"lpbounds verify: {counts['holds']} hold, {counts['inconclusive']} "
                f"inconclusive, {counts['violated']} violated, {counts['error']} errors"
                f"\n\n{instance}"
            )
        table = Table(
            title=title,
            title_justify="left",
            box=box.SIMPLE_HEAD,
            show_edge=False,
            padding=(0, 1, 0, 0),
        )
        for col, just in (
            ("check", "left"),
            ("solver", "left"),
            ("verdict", "left"),
            ("width", "right"),
            ("dev.", "right"),
            ("acc.", "right"),
            ("claim: how it was checked", "left"),
        ):
            table.add_column(
                col,
                justify=just,  # type: ignore[arg-type]
                no_wrap=not col.startswith("claim"),
                overflow="fold",
            )
        for r in rows:
            table.add_row(*_record_cells(r))
        tables.append(table)
    return tables


def _exact_note(r: dict) -> str:
    """Rational arithmetic: the exact difference, the float verdict where it differs, and
    the solves' exact error and whether their brackets held."""
    if "float_verdict" not in r or r.get("exact_difference") is None:
        return ""
    parts = [f"exact difference {fmt_sci(r['exact_difference_float'])}"]
    if r["float_verdict"] and r["float_verdict"] != str(r["verdict"]):
        parts.append(f"float verdict {r['float_verdict']}")
    if r.get("exact_error") is not None:
        held = {True: "inside", False: "OUTSIDE"}.get(r["inside_bracket"], "no")
        off = f"solver's objective off by {fmt_sci(r['exact_error_float'])}"
        if r.get("exact_value_error") is not None:
            off += f", its point by {fmt_sci(r['exact_value_error_float'])}"
        parts.append(f"{off}, {held} its bracket")
    return "; ".join(parts) + "; "


def _record_cells(r: dict) -> tuple[str, ...]:
    detail = _exact_note(r) + r["detail"]
    if r.get("error"):
        detail = f"{detail}: {r['error']}" if detail else r["error"]
    if r["verdict"] == "violated":
        lo, hi = r["lp_interval"], r["exact_interval"]
        detail = (
            f"entry {r['index']}: [{lo[0]:.10g}, {lo[1]:.10g}] vs exact "
            f"[{hi[0]:.10g}, {hi[1]:.10g}]; {detail}"
        )
    return (
        r["check"],
        r["solver"],
        _verdict(r["verdict"]),
        fmt_sci(r["width"]),
        fmt_sci(r["deviation"]),
        fmt_sci(r["accuracy"]),
        f"{escape(r['claim'])}: [dim]{escape(detail)}[/dim]",
    )


def _summary_table(records: list[dict]) -> Table:
    from ..studies.verify import summarize

    summary = Table(
        title="summary: verdicts of each check and solver (worst record)",
        title_justify="left",
        box=box.SIMPLE_HEAD,
        show_edge=False,
        padding=(0, 1, 0, 0),
    )
    rows = summarize(records)
    errors = any(row["error"] for row in rows)  # the column only where there are some
    counts = ("holds", "inconclusive", "violated", *(["error"] if errors else []))
    for col in ("check", "solver", *counts, "worst", "width", "acc."):
        summary.add_column(col, justify="left" if col in ("check", "solver", "worst") else "right")
    for row in rows:
        summary.add_row(
            escape(row["check"]),
            row["solver"],
            *(str(row[c]) for c in counts),
            _verdict(str(row["verdict"])),
            fmt_sci(row["width"], 3),
            fmt_sci(row["accuracy"], 3),
        )
    return summary
