r"""An LP benchmark library with known optima: export a Bellman-row LP, score any solution.

Every LP lpbounds builds from Bellman rows (ELP, RLP, SLP, IB, UBLP, LBLP) is
``min c'x  s.t.  A x >= b`` (``x`` free) whose exact optimum is the least feasible point,
the fixed point of the max over its rows (Fact 1 of :mod:`lpbounds.rows.system`), computable
without an LP solver at any size. :func:`export_lp` writes such an LP for solvers outside
lpbounds and cvxpy, with what is needed to judge their answers:

* ``lp.mps`` or ``lp.lp``: the model, written by HiGHS (:func:`highs_lp` then
  ``Highs.writeModel``; no hand-written MPS). Columns are named ``c0 .. c{N-1}`` and rows
  ``r0 .. r{R-1}`` (HiGHS' default names): column ``c{j}`` is ``x[j]``, row ``r{k}`` is
  Bellman row ``k`` of ``rows.npz``;
* ``optimum.npy``: the exact optimum (the fixed point, float64, one entry per column in
  column order), computed by exact DP to a residual of ``EXPORT_DP_RTOL * max|R|`` and
  certified from the point alone (:func:`lpbounds.certification.certificate.certify`): the true
  optimum
  lies within the sidecar's ``certificate`` bracket of it;
* ``rows.npz``: the Bellman rows (``owner``, ``action``, ``reward``, ``targets``,
  ``probs``, ``discount``), the cost ``c`` and the column meaning (``partition_labels``
  of the states, or the patrol partitions' keys ``column_keys``): everything
  :func:`score_solution` needs to rebuild ``A``, ``b`` and certify a point, without the
  model file;
* ``lp.json`` (the sidecar): sizes, the optimal objective and its certified bracket,
  the certificate, the naming of columns and rows, and the provenance (model file and its
  SHA-256, parameters, partition, lpbounds version, command line, date, machine);
* ``manifest.json``: every file with its SHA-256 (:class:`lpbounds.outputs.AtomicDirectory`:
  the folder appears complete or not at all).

:func:`score_solution` reads a solution file (HiGHS' raw or sparse solution format, as
``highs --solution_file`` or ``Highs.writeSolution`` write it; a ``.npy`` vector; or a
plain text vector) and measures it against the export: objective error, deviation from
the exact optimum, primal infeasibility, and the certified error of the point itself.
"""

from __future__ import annotations

import json
import re
import shlex
import time
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..certification.certificate import Certificate, certify
from ..errors import ConvergenceError, OutputError, ValidationError
from ..outputs import MANIFEST, AtomicDirectory, file_sha256, run_metadata
from ..rows import BellmanRows
from ..status import Status
from ..tolerances import EXPORT_DP_RTOL, LP_CERT_RTOL, dp_default_tol
from ..validation import check_vector

__all__ = [
    "EXPORTABLE",
    "EXPORT_FILES",
    "FORMATS",
    "Export",
    "ExportArgumentError",
    "ExportResult",
    "Score",
    "export_lp",
    "load_export",
    "read_solution",
    "score_solution",
]

#: The formulations that can be exported: the Bellman-row LPs, each with a solver-free
#: exact optimum. (ALP has none in general and is not offered.)
EXPORTABLE: tuple[str, ...] = ("ELP", "RLP", "SLP", "IB", "UBLP", "LBLP")
#: ``--format`` -> the model file's name.
FORMATS: dict[str, str] = {"mps": "lp.mps", "lp": "lp.lp"}
SIDECAR = "lp.json"
OPTIMUM = "optimum.npy"
ROWS = "rows.npz"
#: What an export folder holds (an existing folder holding anything else is refused).
EXPORT_FILES: tuple[str, ...] = (*FORMATS.values(), SIDECAR, OPTIMUM, ROWS, MANIFEST)
#: The sidecar's format tag (a reader checks it).
SIDECAR_FORMAT = "lpbounds-export/1"

_PATROL = ("UBLP", "LBLP")
#: What a column of each formulation stands for.
_ENTRY = {
    "ELP": "state x of the MDP (column first + x)",
    "RLP": "partition i (column first + i; its states: partition_labels == i in rows.npz)",
    "SLP": "partition i (column first + i; its states: partition_labels == i in rows.npz)",
    "IB": "partition i of this block (column first + i; states: partition_labels == i)",
    "UBLP": "patrol partition i (column first + i; its key: column_keys[i] in rows.npz)",
    "LBLP": "patrol partition i (column first + i; its key: column_keys[i] in rows.npz)",
}


# ---------------------------------------------------------------------- inputs
#: :attr:`ExportArgumentError.value` of an error about an argument as a whole
NO_VALUE: Any = object()


class ExportArgumentError(ValidationError):
    """A bad argument of :func:`export_lp`, as data: which argument, its value, the problem.

    ``str(exc)`` names the argument by its Python name (``formulation``, ``partition``,
    ``fmt``); a caller that knows the argument under another name (the command line's
    ``--format``) words the error with :meth:`message`.

    Parameters
    ----------
    argument : str
        The parameter of :func:`export_lp`: ``"formulation"``, ``"partition"`` or ``"fmt"``.
    value : object
        The offending value, or :data:`NO_VALUE` when the argument as a whole is refused.
    problem : str
        What is wrong with it.
    sep : str
        Between the argument (and value) and ``problem``: ``": "``, or ``" "`` when
        ``problem`` continues the sentence (``"must be written ..."``).
    """

    def __init__(self, argument: str, value: Any, problem: str, sep: str = ": ") -> None:
        self.argument = argument
        self.value = value
        self.problem = problem
        self.sep = sep
        super().__init__(self.message(argument))

    def message(self, name: str) -> str:
        """The error with the argument called ``name``.

        Parameters
        ----------
        name : str
            The argument's name for the reader (``"--partition"``).

        Returns
        -------
        str
            ``name``, the value's ``repr`` (unless :data:`NO_VALUE`), ``sep``, ``problem``.
        """
        what = name if self.value is NO_VALUE else f"{name} {self.value!r}"
        return f"{what}{self.sep}{self.problem}"


def check_formulation(name: Any) -> str:
    """The paper name of an exportable formulation (case-insensitive), or a clear error.

    Raises
    ------
    ExportArgumentError
        For argument ``"formulation"``: not one of :data:`EXPORTABLE`.
    """
    key = str(name).upper() if isinstance(name, str) else None
    if key not in EXPORTABLE:
        raise ExportArgumentError(
            "formulation",
            name,
            f"not an exportable formulation; choose one of {', '.join(EXPORTABLE)} "
            "(the LPs of Bellman rows, whose exact optimum is known)",
        )
    return key


def _partition_from_spec(spec: str, mdp: Any) -> Any:
    """``random:M[:SEED]`` (:func:`lpbounds.model.generators.random_partition` of ``mdp``: a
    sink in a set of its own) or a ``.npy`` file of one partition label per state; every
    error is an :class:`ExportArgumentError` of argument ``"partition"``."""
    try:
        return _build_partition(spec, mdp)
    except ExportArgumentError:
        raise
    except ValidationError as exc:
        raise ExportArgumentError("partition", spec, str(exc)) from exc


def _build_partition(spec: str, mdp: Any) -> Any:
    from ..model.generators import random_partition
    from ..model.partition import Partition

    n_states = mdp.n_states
    if spec.startswith("random:"):
        parts = spec.split(":")[1:]
        if not 1 <= len(parts) <= 2 or not all(p.isdigit() for p in parts):
            raise ExportArgumentError("partition", spec, "must be written random:M[:SEED]", " ")
        seed = int(parts[1]) if len(parts) == 2 else 0
        return random_partition(mdp, int(parts[0]), seed)
    path = Path(spec)
    if path.suffix != ".npy" or not path.is_file():
        raise ExportArgumentError(
            "partition",
            spec,
            "expected random:M[:SEED] or an existing .npy file of partition labels (one per state)",
        )
    try:
        labels = np.load(path, allow_pickle=False)
    except (ValueError, OSError) as exc:
        raise ExportArgumentError("partition", spec, f"not a readable .npy file ({exc})") from exc
    part = Partition(labels)
    if part.n_states != n_states:
        raise ExportArgumentError(
            "partition", spec, f"labels {part.n_states} states; the model has {n_states}", " "
        )
    return part


def resolve_case(model: str, formulation: str, partition: str | None = None) -> Any:
    """The study :class:`~lpbounds.studies.compare.Case` of ``model`` (a file, a packaged name or
    ``garnet:N:M[:SEED]``), its partition replaced by ``partition`` when given."""
    from .compare import Case, load_case

    case = load_case(str(model))
    if case.kind == "patrol" and formulation not in _PATROL:
        _check_enumerable(case, formulation)
    if partition is None:
        return case
    if formulation == "ELP" or formulation in _PATROL:
        why = "uses no partition" if formulation == "ELP" else "uses the patrol partition"
        raise ExportArgumentError(
            "partition", NO_VALUE, f"does not apply: {formulation} {why}", " "
        )
    part = _partition_from_spec(str(partition), case.mdp)
    return Case(case.spec, case.name, case.instance, case.mdp, part)


#: Peak memory per state of a formulation over an enumerated patrol MDP, measured: the
#: export of the ELP of patrol-paper (2,048,000 states) peaked at 2.1 GB.
_BYTES_PER_STATE = 1024


def _check_enumerable(case: Any, formulation: str) -> None:
    """Refuse, before building anything, a patrol MDP too large to enumerate here."""
    import os

    n = case.sizes()[0]
    need = n * _BYTES_PER_STATE
    try:
        have = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return
    if need > have:
        raise ValidationError(
            f"{formulation} of {case.name} enumerates its {n:,} states: about "
            f"{need / 2**30:,.0f} GB (measured: 2.1 GB for the 2,048,000 states of "
            f"patrol-paper), more than this machine's {have / 2**30:.0f} GB; UBLP and LBLP are "
            "built from the partitions alone"
        )


# ---------------------------------------------------------------------- provenance
def provenance(
    case: Any, formulation: str, partition: str | None, command: str | None
) -> dict[str, Any]:
    """Where the LP comes from: model file and hash, parameters, partition, versions."""
    from .._defaults import VERSION as __version__
    from .compare import FORMULATIONS, parse_instance

    out: dict[str, Any] = {"model": case.spec, "instance": case.name}
    inst = case.instance
    if inst is None:
        g = parse_instance(case.spec)[1]
        out.update(
            model_path=None,
            model_sha256=None,
            model_parameters={"kind": "garnet", **(g or {})},
            model_builder="lpbounds.studies.compare.load_case: garnet(N, 3, 4, 0.9, seed=SEED), "
            "random_partition(N, M, seed=SEED + 1)",
        )
        default_partition: Any = "random_partition(N, M, seed=SEED + 1)"
    else:
        path = Path(inst.path).resolve() if inst.path is not None else None
        out.update(
            model_path=None if path is None else str(path),
            model_sha256=None if path is None else file_sha256(path),
            model_parameters=inst.config.get("model"),
        )
        default_partition = inst.config.get("partition")
    if formulation == "ELP":
        out["partition"] = None
    else:
        out["partition"] = partition if partition is not None else default_partition
    out.update(
        formulation=formulation,
        formulation_description=FORMULATIONS[formulation].description,
        lpbounds=__version__,
        command=command,
        date=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        environment=run_metadata(),
    )
    return out


# ---------------------------------------------------------------------- the optimum
@dataclass
class Optimum:
    """The exact optimum of a Bellman-row LP and its certificate (or why there is none)."""

    x: np.ndarray | None
    certificate: Certificate | None
    seconds: float
    tol: float
    reason: str | None = None

    def summary(self, cost: np.ndarray) -> dict[str, Any]:
        """The sidecar's ``optimum`` entry."""
        if self.x is None or self.certificate is None:
            return {"exact": None, "reason": self.reason}
        cert = self.certificate
        lo, hi = cert.objective_bracket(cost)
        return {
            "exact": True,
            "how": "the least feasible point, i.e. the fixed point of the max over the rows "
            "(Fact 1), by exact DP (solver-free), then certified from the point alone",
            "objective": float(cost @ self.x),
            "objective_bracket": [lo, hi],
            "solution_file": OPTIMUM,
            "solution_format": "numpy .npy, float64, shape (columns,), column order c0..",
            "dp_tol": self.tol,
            "seconds": self.seconds,
            "certificate": _certificate_summary(cert, self.x),
        }


def _certificate_summary(cert: Certificate, x: np.ndarray) -> dict[str, Any]:
    return {
        "what": "lower <= exact optimum <= upper entrywise, lower = x - shift_down and "
        "upper = x + shift_up (rounded outward), from x alone "
        "(lpbounds.certification.certificate.certify on the rows of rows.npz, rounding included)",
        "error_bound": cert.error_bound,
        "width": cert.width,
        "shift_down": float(np.max(x - cert.lower, initial=0.0)),
        "shift_up": float(np.max(cert.upper - x, initial=0.0)),
        "residual_up": cert.residual_up,
        "residual_down": cert.residual_down,
        "margin": cert.margin,
        "modulus": cert.modulus,
        "reward_absmax": cert.reward_absmax,
        "relative_error": cert.relative_error(),
    }


def exact_optimum(form: Any, rtol: float = EXPORT_DP_RTOL) -> Optimum:
    """The formulation's solver-free optimum (its ``fixed_point``) and its certificate.

    The fixed point is computed to a residual of ``rtol * max|R|``, never below the
    rounding floor of :func:`lpbounds.tolerances.dp_default_tol`; a DP that does not
    converge gives ``x = None`` with the reason (no optimum is invented)."""
    rows = form.rows
    rmax = float(np.abs(rows.reward).max(initial=0.0))
    tol = dp_default_tol(rmax, rows.discount, rows.n_outcomes, rtol=rtol)
    t0 = time.perf_counter()
    try:
        x = np.ascontiguousarray(np.asarray(form.fixed_point(tol), dtype=np.float64).ravel())
    except ConvergenceError as exc:
        return Optimum(None, None, time.perf_counter() - t0, tol, f"exact DP failed: {exc}")
    cert = certify(rows, x)
    return Optimum(x, cert, time.perf_counter() - t0, tol)


# ---------------------------------------------------------------------- writing
def _rows_arrays(form: Any, case: Any, formulation: str) -> dict[str, Any]:
    """``rows.npz``: the rows, the cost and what the columns stand for."""
    rows = form.rows
    probs = np.asarray(rows.probs)
    shared = probs.ndim == 2 and probs.shape[0] > 0 and probs.strides[0] == 0
    arrays = {
        "owner": np.asarray(rows.owner),
        "action": np.asarray(rows.action),
        "reward": np.asarray(rows.reward),
        "targets": np.asarray(rows.targets),
        "probs": probs[0] if shared else probs,
        "discount": np.float64(rows.discount),
        "n_vars": np.int64(rows.n_vars),
        "cost": np.asarray(form.c),
    }
    if formulation in _PATROL:
        arrays["column_keys"] = form.partition_components()
    elif formulation != "ELP" and case.partition is not None:
        arrays["partition_labels"] = np.asarray(case.partition.labels)
    return arrays


def _naming(form: Any, formulation: str) -> dict[str, Any]:
    """The sidecar's ``naming``: which column is which state / partition, which row which."""
    blocks = [
        {"variable": k, "first": s.start, "count": s.stop - s.start, "entry": _ENTRY[formulation]}
        for k, s in form.variable_columns.items()
    ]
    groups = [
        {"group": k, "first": s.start, "count": s.stop - s.start}
        for k, s in form.constraint_rows.items()
    ]
    names = {
        "columns": "c0 .. c{N-1} (HiGHS' default names): column c{j} is x[j]",
        "rows": "r0 .. r{R-1}: row r{k} is x[owner[k]] - discount * sum_l probs[k, l] "
        "x[targets[k, l]] >= reward[k], the Bellman row of action action[k] (rows.npz)",
        "column_blocks": blocks,
        "row_groups": groups,
    }
    if formulation in _PATROL:
        m = form.params.m
        names["column_keys"] = ["l", "w", "d", *[f"A{j + 1}" for j in range(m)], "taubar"]
    return names


def _write_model(form: Any, path: Path) -> None:
    """The model file, written by HiGHS from the formulation's ``(A, b, c)``."""
    from ..formulations.highs import write_lp

    accepted, written = write_lp(form.A, form.b, form.c, path)
    if not accepted:
        raise OutputError(f"HiGHS refused the model of {form.name}")
    # HiGHS' kWarning (it names the unnamed columns c0.. and rows r0..: what the sidecar
    # says) counts as written
    if not written or not path.is_file():
        raise OutputError(f"HiGHS could not write {str(path)!r}")


@dataclass
class ExportResult:
    """What :func:`export_lp` wrote: the folder, its sidecar and the time of each step."""

    out: Path
    sidecar: dict[str, Any]
    seconds: dict[str, float] = field(default_factory=dict)


def export_lp(
    model: str,
    formulation: str,
    out: str | Path,
    *,
    partition: str | None = None,
    fmt: str = "mps",
    command: str | None = None,
    step: Callable[[str], None] | None = None,
) -> ExportResult:
    """Write a Bellman-row LP, its exact optimum and a sidecar into the folder ``out``.

    Parameters
    ----------
    model : str
        A ``models/*.toml`` file, a packaged model's name, or ``garnet:N:M[:SEED]``.
    formulation : str
        One of :data:`EXPORTABLE` (built as a study builds it: SLP with uniform ``mu``,
        IB with ``L = 2``; :data:`lpbounds.studies.compare.FORMULATIONS`).
    out : path
        The folder, replaced as a whole (an existing one may hold only
        :data:`EXPORT_FILES`); complete or absent (:class:`~lpbounds.outputs.AtomicDirectory`).
    partition : str, optional
        Replace the model's partition: ``random:M[:SEED]`` or a ``.npy`` file of labels.
    fmt : {"mps", "lp"}
    command : str, optional
        The command line recorded in the provenance.
    step : callable(str), optional
        Called with the name of each step as it starts (progress display).

    Returns
    -------
    ExportResult

    Raises
    ------
    ExportArgumentError
        An unknown formulation or format, or a bad partition (before any work): a
        :class:`ValidationError` naming the argument (``formulation``, ``fmt``,
        ``partition``) and its value as attributes.
    ValidationError
        A bad model (before any work).
    OutputError
        ``out`` not writable, holding other files, or locked (before any work).
    """
    from ..outputs import check_output_dir
    from .compare import FORMULATIONS

    name = check_formulation(formulation)
    if fmt not in FORMATS:
        raise ExportArgumentError("fmt", fmt, f"choose one of {', '.join(FORMATS)}")
    check_output_dir(out, "out", replaceable=EXPORT_FILES)
    say = step or (lambda _s: None)
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    say("building the LP")
    case = resolve_case(model, name, partition)
    form = FORMULATIONS[name].build(case)
    if form.A.nnz >= 2**31 - 1:  # HiGHS indexes its matrix with 32-bit integers
        raise ValidationError(
            f"{name} of {case.name} has {form.A.nnz:,} nonzeros: more than HiGHS can hold "
            "(2**31 - 1)"
        )
    seconds["build"] = time.perf_counter() - t0
    say("exact optimum (DP) and certificate")
    opt = exact_optimum(form)
    seconds["optimum"] = opt.seconds
    sidecar = {
        "format": SIDECAR_FORMAT,
        "formulation": name,
        "problem": "min c'x  s.t.  A x >= b, x free (c >= 0; A, b, c as in rows.npz)",
        "model_file": FORMATS[fmt],
        "sizes": {
            "rows": int(form.A.shape[0]),
            "columns": int(form.A.shape[1]),
            "nonzeros": int(form.A.nnz),
        },
        "optimum": opt.summary(form.c),
        "naming": _naming(form, name),
        "rows_file": ROWS,
        "provenance": provenance(case, name, partition, command),
    }
    target = AtomicDirectory(out, replaceable=EXPORT_FILES)
    with target as tmp:
        t1 = time.perf_counter()
        say(f"writing {FORMATS[fmt]} (HiGHS)")
        _write_model(form, tmp / FORMATS[fmt])
        seconds["write_model"] = time.perf_counter() - t1
        t1 = time.perf_counter()
        say("writing the rows, the optimum and the sidecar")
        np.savez(tmp / ROWS, **_rows_arrays(form, case, name))
        if opt.x is not None:
            np.save(tmp / OPTIMUM, opt.x)
        (tmp / SIDECAR).write_text(json.dumps(sidecar, indent=2) + "\n")
        path = target.commit({"formulation": name, "model": case.spec})
        seconds["write_rest"] = time.perf_counter() - t1
    seconds["total"] = time.perf_counter() - t0
    return ExportResult(path, sidecar, seconds)


def command_line(argv: Sequence[str]) -> str:
    """``argv`` as one shell-quoted line (for the provenance)."""
    return shlex.join([str(a) for a in argv])


# ---------------------------------------------------------------------- reading an export
@dataclass
class Export:
    """An export folder read back: its sidecar, rows, cost and optimum."""

    path: Path
    sidecar: dict[str, Any]
    rows: BellmanRows
    cost: np.ndarray
    optimum: np.ndarray | None

    @property
    def n_columns(self) -> int:
        return int(self.cost.size)


def load_export(path: str | Path) -> Export:
    """Read an export folder written by :func:`export_lp` (checked: a typed error names
    the folder and what is missing or inconsistent)."""
    folder = Path(path)
    if not folder.is_dir():
        raise ValidationError(f"export folder {str(folder)!r} does not exist or is not a folder")
    side_path = folder / SIDECAR
    if not side_path.is_file():
        raise ValidationError(
            f"{str(folder)!r} is not an lpbounds export: no {SIDECAR} (write one with "
            "lpbounds export)"
        )
    try:
        sidecar = json.loads(side_path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValidationError(f"{side_path}: not valid JSON ({exc})") from exc
    if not isinstance(sidecar, dict) or sidecar.get("format") != SIDECAR_FORMAT:
        raise ValidationError(f"{side_path}: not an lpbounds export sidecar ({SIDECAR_FORMAT})")
    rows, cost = _load_rows(folder / ROWS)
    n = int(sidecar["sizes"]["columns"])
    if cost.size != n or rows.n_rows != int(sidecar["sizes"]["rows"]):
        raise ValidationError(f"{folder / ROWS} does not match the sizes in {side_path}")
    optimum = None
    if sidecar["optimum"].get("exact"):
        if not (folder / OPTIMUM).is_file():
            raise ValidationError(f"the export is incomplete: {str(folder / OPTIMUM)!r} is missing")
        try:
            arr = np.load(folder / OPTIMUM, allow_pickle=False)
        except (ValueError, OSError) as exc:
            raise ValidationError(f"{folder / OPTIMUM}: not a readable .npy file ({exc})") from exc
        optimum = check_vector(str(folder / OPTIMUM), arr, n)
    return Export(folder, sidecar, rows, cost, optimum)


def _load_rows(path: Path) -> tuple[BellmanRows, np.ndarray]:
    if not path.is_file():
        raise ValidationError(f"the export is incomplete: {str(path)!r} is missing")
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (ValueError, OSError, KeyError, zipfile.BadZipFile) as exc:
        raise ValidationError(f"{path}: not a readable rows file ({exc})") from exc
    need = ("owner", "action", "reward", "targets", "probs", "discount", "n_vars", "cost")
    missing = [k for k in need if k not in data]
    if missing:
        raise ValidationError(f"{path}: missing {missing}")
    rows = BellmanRows.from_arrays(
        data["owner"],
        data["action"],
        data["reward"],
        data["targets"],
        data["probs"],
        float(data["discount"]),
        int(data["n_vars"]),
    )
    if not np.array_equal(rows.owner, data["owner"]):
        raise ValidationError(f"{path}: the rows are not sorted by (owner, action)")
    return rows, np.asarray(data["cost"], dtype=np.float64)


# ---------------------------------------------------------------------- solution files
_NUMBER = r"[-+]?(?:\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?|inf|nan|Inf|NaN)"
_COLUMNS_HEADER = re.compile(r"^# Columns (-?\d+)( sparse)?\s*$")


def read_solution(path: str | Path, n_columns: int) -> tuple[np.ndarray, dict[str, Any]]:
    """The primal vector of a solution file, and what was read (``format``, ``model_status``).

    Accepted: HiGHS' raw solution format (``write_solution_style`` 0, what ``highs
    --solution_file`` and ``Highs.writeSolution(path, 0)`` write) and its sparse form
    (style 4), with columns named ``c0 .. c{N-1}`` as in the exported model; a ``.npy``
    vector; a text file of ``N`` numbers (whitespace or newlines between them).

    Raises
    ------
    ValidationError
        Naming the file and the entry: unreadable, not one of these formats, the wrong
        number of columns, a column name of another model, or a non-finite value.
    """
    p = Path(path)
    if not p.is_file():
        raise ValidationError(f"solution file {str(p)!r} does not exist or is not a file")
    raw = p.read_bytes()
    if raw.startswith(b"\x93NUMPY"):
        try:
            arr = np.load(p, allow_pickle=False)
        except ValueError as exc:
            raise ValidationError(f"solution file {str(p)!r}: unreadable .npy ({exc})") from exc
        if arr.ndim != 1 or arr.size != n_columns:
            raise ValidationError(
                f"solution file {str(p)!r} holds an array of shape {arr.shape}; the exported "
                f"LP has {n_columns} columns (a vector of that length is expected)"
            )
        info: dict[str, Any] = {"format": "npy", "model_status": None}
        return check_vector(f"solution file {str(p)!r}: x", arr, n_columns), info
    try:
        lines = raw.decode("utf-8").splitlines()
    except UnicodeDecodeError:
        raise ValidationError(
            f"solution file {str(p)!r} is neither text nor a .npy file (a HiGHS solution "
            "file, a .npy vector or a text vector is expected)"
        ) from None
    if any(ln.strip() == "# Primal solution values" for ln in lines):
        x, info = _read_highs(p, lines, n_columns)
    else:
        x, info = _read_plain(p, lines, n_columns), {"format": "text", "model_status": None}
    return check_vector(f"solution file {str(p)!r}: x", x, n_columns), info


def _read_highs(p: Path, lines: list[str], n: int) -> tuple[np.ndarray, dict[str, Any]]:
    """The primal columns of a HiGHS raw (or sparse raw) solution file."""
    status = None
    for k, ln in enumerate(lines[:-1]):
        if ln.strip() == "Model status":
            status = lines[k + 1].strip()
            break
    start = next(k for k, ln in enumerate(lines) if ln.strip() == "# Primal solution values")
    where = f"solution file {str(p)!r}"
    valid = lines[start + 1].strip() if start + 1 < len(lines) else ""
    if valid not in ("Feasible", "Infeasible"):
        raise ValidationError(
            f"{where} line {start + 2}: the primal solution is {valid or 'missing'!r} "
            f"(model status {status!r}): there is no point to score"
        )
    head = next((k for k in range(start + 2, len(lines)) if lines[k].startswith("# Columns")), None)
    match = _COLUMNS_HEADER.match(lines[head]) if head is not None else None
    if head is None or match is None:
        raise ValidationError(f"{where}: no '# Columns N' line after '# Primal solution values'")
    count, sparse = int(match.group(1)), bool(match.group(2))
    count = abs(count)
    if not sparse and count != n:
        raise ValidationError(
            f"{where} line {head + 1}: the solution has {count} columns; the exported LP has "
            f"{n} (a solution of another model?)"
        )
    x = np.zeros(n) if sparse else np.full(n, np.nan)
    for k in range(head + 1, head + 1 + count):
        parts = lines[k].split() if k < len(lines) else []
        if len(parts) < 2:
            raise ValidationError(f"{where} line {k + 1}: expected 'NAME VALUE'; got {parts}")
        j = _column_index(parts[0], n, where, k) if sparse else k - head - 1
        if not sparse and parts[0] != f"c{j}":
            raise ValidationError(
                f"{where} line {k + 1}: column {parts[0]!r} where 'c{j}' was expected (the "
                "exported model names its columns c0 .. c{N-1}: a solution of another model?)"
            )
        x[j] = _number(parts[1], where, k)
    return x, {"format": "highs-sparse" if sparse else "highs-raw", "model_status": status}


def _column_index(name: str, n: int, where: str, k: int) -> int:
    if re.fullmatch(r"c\d+", name) and int(name[1:]) < n:
        return int(name[1:])
    raise ValidationError(
        f"{where} line {k + 1}: {name!r} is not a column of the exported model (c0 .. c{n - 1})"
    )


def _number(text: str, where: str, k: int) -> float:
    if not re.fullmatch(_NUMBER, text):
        raise ValidationError(f"{where} line {k + 1}: {text!r} is not a number")
    return float(text)


def _read_plain(p: Path, lines: list[str], n: int) -> np.ndarray:
    """A text vector: ``n`` numbers separated by whitespace or newlines."""
    where = f"solution file {str(p)!r}"
    values: list[float] = []
    for k, ln in enumerate(lines):
        for tok in ln.replace(",", " ").split():
            if not re.fullmatch(_NUMBER, tok):
                raise ValidationError(
                    f"{where} line {k + 1}: {tok[:40]!r} is not a number (expected a HiGHS "
                    f"solution file, a .npy vector or a text vector of {n} numbers)"
                )
            values.append(float(tok))
    if len(values) != n:
        raise ValidationError(
            f"{where} holds {len(values)} numbers; the exported LP has {n} columns"
        )
    return np.asarray(values)


# ---------------------------------------------------------------------- scoring
@dataclass
class Score:
    """A solution measured against an export (every number computed by lpbounds).

    Attributes
    ----------
    objective : float
        ``c'x`` of the solution.
    optimum_objective : float or None
        ``c'x*`` of the export's exact optimum; ``objective_bracket`` its certified bracket.
    objective_error : float or None
        ``|c'x - c'x*|``.
    max_deviation : float or None
        ``max_j |x_j - x*_j|`` (at column ``worst_column``); ``optimum_error_bound`` bounds
        how far ``x*`` itself is from the true optimum.
    primal_infeasibility : float
        ``max_k (b - A x)_k^+`` (at row ``worst_row``).
    certified_error : float
        A bound on ``max_j |x_j - v*_j|`` for the true optimum ``v*``, from ``x`` alone
        (:func:`lpbounds.certification.certificate.certify` on the export's rows).
    status : Status
        OPTIMAL when the certified error is within ``accuracy * max|R| / (1 - lambda)``
        (the Bellman residual within ``accuracy * max|R|``), else INACCURATE.
    """

    solution: str
    format: str
    model_status: str | None
    columns: int
    objective: float
    optimum_objective: float | None
    objective_bracket: tuple[float, float] | None
    objective_error: float | None
    max_deviation: float | None
    worst_column: int | None
    optimum_error_bound: float | None
    primal_infeasibility: float
    worst_row: int | None
    certified_error: float
    relative_error: float
    residual_up: float
    residual_down: float
    accuracy: float
    status: Status

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["status"] = self.status.value
        return out


def score_solution(
    export: str | Path | Export, solution: str | Path, accuracy: float = LP_CERT_RTOL
) -> Score:
    """Score the solution file ``solution`` against the export folder ``export``.

    Raises
    ------
    ValidationError
        A folder that is not an export, or a malformed or mismatched solution file (the
        message names the file and the entry).
    """
    exp = export if isinstance(export, Export) else load_export(export)
    x, info = read_solution(solution, exp.n_columns)
    a, b = exp.rows.constraint_matrix()
    slack = b - a @ x
    k = int(np.argmax(slack)) if slack.size else 0
    infeas = float(max(0.0, slack[k])) if slack.size else 0.0
    cert = certify(exp.rows, x)
    obj = float(exp.cost @ x)
    opt = exp.sidecar["optimum"]
    fields: dict[str, Any] = dict.fromkeys(
        (
            "optimum_objective",
            "objective_bracket",
            "objective_error",
            "max_deviation",
            "worst_column",
            "optimum_error_bound",
        ),
    )
    if exp.optimum is not None:
        dev = np.abs(x - exp.optimum)
        j = int(np.argmax(dev))
        fields.update(
            optimum_objective=float(opt["objective"]),
            objective_bracket=tuple(opt["objective_bracket"]),
            objective_error=abs(obj - float(opt["objective"])),
            max_deviation=float(dev[j]),
            worst_column=j,
            optimum_error_bound=float(opt["certificate"]["error_bound"]),
        )
    return Score(
        solution=str(solution),
        format=info["format"],
        model_status=info["model_status"],
        columns=exp.n_columns,
        objective=obj,
        primal_infeasibility=infeas,
        worst_row=k if infeas > 0 else None,
        certified_error=cert.error_bound,
        relative_error=cert.relative_error(),
        residual_up=cert.residual_up,
        residual_down=cert.residual_down,
        accuracy=accuracy,
        status=Status.OPTIMAL if cert.is_accurate(accuracy) else Status.INACCURATE,
        **fields,
    )
