r"""Theorem verdicts: the paper's LP results checked solver by solver with certified intervals.

Every check compares two **certified intervals**, never a point against a tolerance:

* the LP side: the bracket ``lower <= exact optimum <= upper`` that lpbounds certifies from
  the returned point alone (:func:`lpbounds.certification.checks.lp_bracket`, the result's
  ``certificate``; the contraction argument of :mod:`lpbounds.certification.certificate`), or the
  bracket on the LP's optimal objective (:func:`lpbounds.certification.checks.lp_objective_bracket`:
  a certified feasible point above, weak duality below);
* the exact side: ``[values - error_bound, values + error_bound]`` of the fixed points of
  :func:`lpbounds.dp.solve_exact` (``V*``, RLP's ``v*``).

Each record has a :class:`~lpbounds.status.Verdict`:

``holds``
    The intervals are consistent with the claim and narrow enough: the largest
    difference they allow is within the requested accuracy ``rtol * max|R| / (1 -
    lambda)`` (times ``sum c`` for objectives).
``violated``
    The intervals *prove* the claim false: for an equality, some entry's intervals are
    disjoint; for ``a >= b``, some entry has ``a_hi < b_lo``. The record names the entry
    (``index``) and both intervals (``lp_interval``, ``exact_interval``): a counterexample.
``inconclusive``
    Neither: the solver was not accurate enough to decide (the widths are shown).

A solver's inaccuracy therefore never reads as a broken theorem: an inaccurate point has
a wide (still valid) bracket, which gives *inconclusive*, not *violated*.

A record whose claim gave no verdict at all has the outcome ``error`` (:data:`ERROR`, not a
:class:`~lpbounds.status.Verdict`): a conjecture's predicate that raised, called
``sys.exit`` or returned something other than a verdict (:mod:`lpbounds.studies.claims`),
or a campaign's instance that could not be built or checked. Its ``error`` says why. It is
counted apart from the three verdicts (:func:`summarize`) and fails the run
(:func:`exit_status`): evidence that could not be produced is not evidence either way.

Record keys: ``check`` (the paper's result), ``claim`` (what was compared), ``instance``,
``solver`` ("exact" for solver-free checks, "all" across solvers), ``verdict``, ``width``,
``deviation`` (distance of the interval midpoints), ``accuracy``, ``index``,
``lp_interval``, ``exact_interval``, ``detail``, and the LP solves the record rests on
(:class:`Tally`): ``solves``, ``solve_seconds``, ``compile_seconds``, ``lp_status``,
``solver_status``. :func:`records_frame` (and ``to_pandas()`` of a :class:`VerifyResult`)
gives them as a table, one row per record, with the columns :data:`RECORD_COLUMNS`.

The claims (``c`` are ``n_costs`` random non-negative costs: the first strictly positive,
the others with zeros):

* **Lemma 1** - ELP's optimum is ``V*``: per entry for ``c > 0`` (the unique optimum),
  and the optimal objective ``c'V*`` for every cost (with zeros in ``c`` the minimiser is
  not unique and an interior point solver returns a point far from ``V*`` where ``c = 0``;
  the optimal *value* is still ``c'V*``). Solver "exact": ``Phi v* >= V*``.
* **Theorem 1** - RLP's optimum is ``v*`` for every cost (as Lemma 1); the certified
  feasible point of every solve (the certificate's ``upper``) dominates ``v*``, and so do
  the value-iteration iterates ``T^k u`` (solver "exact", certified the same way); the
  brackets of all solvers agree (solver "all").
* **Lemma 2** - ``SLP(mu-bar)`` with each solver's own RLP duals ``y`` (spread to pairs,
  ``mu-bar``) has the optimum ``v*``, and so has the reduced MDP of step 2 (exact DP).
  Solver duals are never exactly optimal, so the claim checked is the lemma's proof made
  quantitative (:func:`lemma2_slack`): with ``eps' = y'(A v* - b) >= 0`` (complementary
  slackness, 0 for optimal duals) and the dual residual ``r = A'y - c-bar``, every
  partition ``i`` has an action ``u`` whose surrogate row is slack by at most
  ``sigma_i = eps' n_A / (c-bar(i) - |r_i|)`` at ``v*``, so ``v* - sigma/(1-kappa) <=
  SLP(mu-bar) <= v*``. Optimal duals give ``sigma = 0``: Lemma 2 itself; inaccurate
  duals widen the predicted interval (inconclusive), they cannot produce *violated*.
* **Theorem 2** - IB for ``L = 1..5``: every block of the LP optimum equals ``v*`` (the
  certified feasible point dominates ``v*``: the theorem; equality: Lemma 1 for IB);
  solver "exact": the fixed point of IB's cyclic rows is ``(v*, ..., v*)``. LLP (surplus
  lifting) with random ``d >= 0``: its certified feasible ``v`` dominates ``v*``.
* **Remark 2** - :func:`~lpbounds.formulations.alp.find_cost_dependent_alp` finds a small
  MDP and soft-aggregation basis; each solver's answers for ``c1``, ``c2`` and ``c1 + c2``
  are turned into *exact* rational brackets on the three optimal values
  (:func:`alp_value_bracket`), and the dependence on the cost is a certified difference:
  if one point were optimal for both ``c1`` and ``c2``, then ``OPT(c1 + c2) = OPT(c1) +
  OPT(c2)`` (in general ``>=``), so ``lower(OPT(c1 + c2)) > upper(OPT(c1)) +
  upper(OPT(c2))`` proves that the optimum depends on the cost (*holds*); otherwise
  *inconclusive* (never *violated*: a failure to show a difference proves nothing).

Rational arithmetic (``arithmetic="rational"``)
    Every claim is also decided *exactly* on the stored model
    (:mod:`lpbounds.studies.exact_claims`: exact fixed points, exact LP optima proved by
    exact primal and dual points, docs/exact.md), and the records say so: the same
    records as in floating point, each with ``verdict`` the **exact** verdict (*holds* or
    *violated*, never *inconclusive*) of the exact comparisons its claim rests on
    (:data:`EXACT_OF_CLAIM`), and the columns :data:`EXACT_COLUMNS`: ``float_verdict``
    (the floating-point verdict the record had), ``exact_difference`` (``"p/q"``: ``max
    |left - right|`` of an equality, ``min (left - right)`` of an inequality, negative
    when violated) and its nearest double ``exact_difference_float``, ``exact_seconds``
    (the exact work of the claim), ``certificate`` (the file proving it, when written),
    and per solver ``inside_bracket`` (whether every certified bracket of the record's
    solves contained its LP's exact optimum), ``exact_error`` (``"p/q"``: the largest
    ``|objective - exact optimum|`` of those solves, defined for every LP: its optimal
    value is unique) with ``exact_error_float``, and ``exact_value_error`` (``"p/q"``:
    the largest ``max |values - exact values|`` of those solves whose exact dual proves
    the optimal point unique; empty when none does, as with a cost with zeros, where any
    point of the optimal face is as right as another) with ``exact_value_error_float``.
    Records without an LP solve have these empty. The records of the solver ``"exact"``
    (exact DP, no LP) have ``width`` 0: their sides are exact values, points; their
    ``lp_lo`` ... ``exact_hi`` stay the floating-point intervals the float verdict was
    made on. The floating-point records and columns are unchanged.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..certification.certificate import contraction_modulus, objective_bracket
from ..certification.checks import (
    Comparison,
    combine,
    compare_at_least,
    compare_equal,
    dp_interval,
    lp_bracket,
    lp_objective_bracket,
)
from ..dp import exact_rows, solve_exact
from ..errors import ConvergenceError, LPBoundsError, SolverNotInstalledError, ValidationError
from ..exact.rationals import fraction_text, solve_rational
from ..formulations import (
    ELP,
    IB,
    LLP,
    RLP,
    SLP,
    find_cost_dependent_alp,
    installed_lp_solvers,
    resolve_solver,
)
from ..formulations.alp import ALP
from ..formulations.base import LPResult
from ..model.generators import garnet, random_partition
from ..model.instances import load_instance, models_dir
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from ..rows import BellmanRows
from ..status import Verdict
from ..tolerances import LP_COMPARE_RTOL, dp_scale
from ..validation import check_choice

__all__ = [
    "ARITHMETICS",
    "ERROR",
    "EXACT_COLUMNS",
    "EXACT_METHODS",
    "EXACT_OF_CLAIM",
    "EXACT_SOLVER",
    "INSTANCE_CHECKS",
    "OUTCOMES",
    "RECORD_COLUMNS",
    "RELIABLE_LP_SOLVERS",
    "Tally",
    "VerdictRecords",
    "VerifyInstance",
    "VerifyResult",
    "alp_value_bracket",
    "check_arithmetic",
    "check_exact_method",
    "default_solvers",
    "due_solvers",
    "error_record",
    "estimated_states",
    "exact_instance",
    "exact_interval",
    "exit_status",
    "flat_record",
    "lemma2_slack",
    "make_record",
    "model_instances",
    "outcome_of",
    "random_instances",
    "records_frame",
    "run_verification",
    "summarize",
    "try_solve",
    "verify_instance",
    "verify_remark2",
]

if TYPE_CHECKING:  # annotations only
    import pandas as pd

    from .exact_claims import ExactInstance, ExactVerdict, SolverJudgement

Record = dict[str, Any]
Progress = Callable[[str], None]

#: The default set of :func:`run_verification` (those installed): solvers that usually
#: reach ``LP_COMPARE_RTOL`` at their defaults, so that the verdicts are mostly *holds*.
#: Any installed LP solver may be named: a less accurate one (SCS, OSQP, PDLP) gives
#: *inconclusive* verdicts, never *violated* ones.
RELIABLE_LP_SOLVERS: tuple[str, ...] = (
    "HIGHS",
    "CLARABEL",
    "SCIPY",
    "GLPK",
    "ECOS",
    "CVXOPT",
    "MOSEK",
    "GUROBI",
    "COPT",
    "XPRESS",
    "CPLEX",
)

#: Number of IB blocks checked for Theorem 2.
IB_BLOCKS: tuple[int, ...] = (1, 2, 3, 4, 5)

#: The checks :func:`verify_instance` makes, in its order (Remark 2 is an existence claim,
#: checked once per run by :func:`verify_remark2`).
INSTANCE_CHECKS: tuple[str, ...] = ("Lemma 1", "Theorem 1", "Lemma 2", "Theorem 2")

#: The outcome of a record whose claim gave no verdict (see the module docstring).
ERROR = "error"

#: Every outcome a record can have, from best to worst: the verdicts, then :data:`ERROR`.
OUTCOMES: tuple[str, ...] = ("holds", "inconclusive", "violated", ERROR)

#: The solver of the solver-free records (exact DP, no LP).
EXACT_SOLVER = "exact"

#: The checks whose records include one of solver "exact" (solver-free) on every instance.
_EXACT_CHECKS = ("Lemma 1", "Theorem 1", "Theorem 2")

#: The arithmetics of a verification: ``"float"`` (certified floating-point intervals:
#: *holds*, *violated* or *inconclusive*) and ``"rational"`` (every claim also decided
#: exactly; see the module docstring).
ARITHMETICS: tuple[str, ...] = ("float", "rational")

#: The columns a record has in rational arithmetic, after the floating-point ones (see the
#: module docstring).
EXACT_COLUMNS: tuple[str, ...] = (
    "float_verdict",
    "exact_difference",
    "exact_difference_float",
    "exact_seconds",
    "inside_bracket",
    "exact_error",
    "exact_error_float",
    "exact_value_error",
    "exact_value_error_float",
    "certificate",
)

#: In rational arithmetic, the exact comparisons (of the check's
#: :class:`~lpbounds.studies.exact_claims.ExactVerdict`) a record's claim rests on: its
#: ``(check, claim)`` -> the start of their names; a claim not listed rests on all of its
#: check's (Theorem 1's, Lemma 2's).
EXACT_OF_CLAIM: dict[tuple[str, str], str] = {
    ("Lemma 1", "Phi v* >= V*"): "Phi v*",
    ("Lemma 1", "optimal value = c'(exact)"): "ELP",
    ("Lemma 1", "optimum = exact (c > 0)"): "ELP",
    ("Theorem 2", "fixed point of IB = (v*, ..., v*)"): "IB",
    ("Theorem 2", "IB blocks = v*"): "IB",
    ("Theorem 2", "IB feasible point >= v*"): "IB",
    ("Theorem 2", "LLP v >= v*"): "LLP",
    ("Remark 2", "ALP optimum depends on c"): "OPT",
}


def check_arithmetic(arithmetic: Any) -> str:
    """``arithmetic`` checked: one of :data:`ARITHMETICS`.

    Raises
    ------
    ValidationError
        For any other value (the message lists the known ones).
    """
    return check_choice("arithmetic", arithmetic, ARITHMETICS)


def due_solvers(check: str, solvers: Sequence[str]) -> list[str]:
    """The solvers a built-in check gives records for on every instance: each of
    ``solvers`` (one record or more each), and "exact" for the checks with a solver-free
    record (Lemma 1, Theorem 1, Theorem 2; Remark 2: ``solvers`` only). The "all" record
    of Theorem 1 needs two solvers with a point, so it is never due."""
    return [*solvers, *(["exact"] if check in _EXACT_CHECKS else [])]


def default_solvers() -> list[str]:
    """The installed solvers of :data:`RELIABLE_LP_SOLVERS` (HiGHS, Clarabel, SciPy here)."""
    have = set(installed_lp_solvers())
    return [s for s in RELIABLE_LP_SOLVERS if s in have]


@dataclass
class VerifyInstance:
    """A model to verify on: a name, an MDP and a partition."""

    name: str
    mdp: FiniteMDP
    partition: Partition


def random_instances(n: int, seed: int = 0) -> list[VerifyInstance]:
    """``n`` seeded random MDPs (8-60 states, 1-3 actions) with random partitions."""
    if n < 0:
        raise ValidationError(f"the number of random instances must be >= 0; got {n}")
    out = []
    for k in range(n):
        rng = np.random.default_rng([seed, k])
        n_states = int(rng.integers(8, 61))
        n_actions = int(rng.integers(1, 4))
        mdp = garnet(
            n_states,
            n_actions,
            int(rng.integers(1, 5)),
            float(rng.uniform(0.5, 0.95)),
            seed=int(rng.integers(2**31)),
            shared_probabilities=bool(rng.random() < 0.3),
            reward_range=(-1.0, 1.0),
            allowed_fraction=float(rng.choice([1.0, 0.7])),
        )
        m = int(rng.integers(1, max(2, n_states // 3) + 1))
        part = random_partition(n_states, m, seed=int(rng.integers(2**31)))
        out.append(VerifyInstance(f"random-{seed}-{k}", mdp, part))
    return out


def model_instances(
    names: Iterable[str] | None = None, max_states: int = 10_000
) -> tuple[list[VerifyInstance], list[str]]:
    """Instances from ``models/`` (all with a ``[partition]`` table by default).

    Returns the instances and the names skipped for having more than ``max_states``
    states, or a size not known without building the model (ELP is solved by every
    solver, so only small models are verified by default).
    A model named explicitly is never skipped.
    """
    explicit = names is not None
    if names is None:
        names = [str(p) for p in sorted(models_dir().glob("*.toml"))]
    out: list[VerifyInstance] = []
    skipped: list[str] = []
    for name in names:
        inst = load_instance(name)
        if not inst.has_partition:
            if explicit:
                raise ValidationError(f"instance {inst.name!r} has no [partition]: cannot verify")
            continue
        if not explicit:
            size = estimated_states(inst)
            if size is None or size > max_states:
                skipped.append(inst.name)
                continue
        mdp = inst.mdp()
        out.append(VerifyInstance(inst.name, mdp, inst.partition()))
    return out, skipped


def estimated_states(inst: Any) -> int | None:
    """The number of states of an instance without building it (None if unknown).

    Parameters
    ----------
    inst : lpbounds.model.instances.Instance
        A loaded instance file (its MDP not built).

    Returns
    -------
    int or None
        ``[model] n_states`` when the file gives it, a patrol model's or a shelf model's
        count from its parameters (:func:`lpbounds.model.shelf.model_sizes`), a Gymnasium
        model's from the model itself (built: a toy-text environment holds its whole table
        ``P`` once made, so the model costs what making the environment does), else None
        (Gymnasium not installed; a patrol without its package).
    """
    size = inst.config["model"].get("n_states")
    if isinstance(size, int):
        return size
    if inst.kind == "gymnasium":
        try:
            return int(inst.mdp().n_states)  # kept by the instance: verified as built here
        except SolverNotInstalledError:
            return None
    from ..model import shelf

    if inst.kind in shelf.SHELF_KINDS:
        return shelf.model_sizes(inst.config["model"]).n_states
    if inst.kind == "patrol":
        try:
            from ..patrol.instance import model_for, params_from_instance

            return int(model_for(params_from_instance(inst)).n_states)
        except Exception:  # the patrol package is optional here: unknown size
            return None
    return None


_EPS = float(np.finfo(np.float64).eps)


@dataclass
class Tally:
    """The LP solves behind one record: their number, times and statuses.

    ``lp_status`` is lpbounds' status of each returned point (decided from its certificate,
    :class:`~lpbounds.status.Status`; ``"none"`` when no point came back), ``solver_status``
    the solver's own answer as cvxpy reports it (``"optimal"``, ``"optimal_inaccurate"``,
    ...; ``"error"`` when the solve raised): the distinct values in order, comma-joined.

    With a ``judge`` (rational arithmetic: an
    :class:`~lpbounds.studies.exact_claims.ExactJudge`) every returned point is also judged
    against its LP's exact optimum, and the record gets ``inside_bracket`` and
    ``exact_error`` (:data:`EXACT_COLUMNS`).
    """

    solves: int = 0
    solve_seconds: float = 0.0
    compile_seconds: float = 0.0
    lp: list[str] = field(default_factory=list)
    own: list[str] = field(default_factory=list)
    judge: Callable[[Any, LPResult], SolverJudgement] | None = field(default=None, repr=False)
    judged: list[SolverJudgement] = field(default_factory=list, repr=False)

    def add(self, res: LPResult | None, form: Any = None) -> None:
        """Count one solve of ``form`` (``res`` None: the solve returned no point)."""
        self.solves += 1
        if res is None:
            self.lp.append("none")
            self.own.append("error")
            return
        self.solve_seconds += float(res.solve_seconds or 0.0)
        self.compile_seconds += float(res.compile_seconds or 0.0)
        self.lp.append(str(res.status))
        own = res.extra.get("solver_status") or res.extra.get("message")
        self.own.append(str(own or "unknown"))
        if self.judge is not None and form is not None:
            self.judged.append(self.judge(form, res))

    def fields(self) -> Record:
        """The record keys this tally fills (with a judge, also the exact ones)."""
        out: Record = {
            "solves": self.solves,
            "solve_seconds": self.solve_seconds,
            "compile_seconds": self.compile_seconds,
            "lp_status": ",".join(dict.fromkeys(self.lp)),
            "solver_status": ",".join(dict.fromkeys(self.own)),
        }
        if self.judge is not None:
            out.update(judged_fields(self.judged))
        return out


def judged_fields(judged: Sequence[SolverJudgement]) -> Record:
    """``inside_bracket`` (every judged solve's certified bracket held; None when none had
    one), ``exact_error`` (the largest ``|objective - exact optimum|``, ``"p/q"``; None
    without a point) and ``exact_value_error`` (the largest ``max |values - exact
    values|`` of the solves whose optimal point the exact dual proves unique; None when
    none does), each with its nearest double (``..._float``)."""
    held = [j.inside_bracket for j in judged if j.inside_bracket is not None]
    objective = [j.objective_error for j in judged if j.objective_error is not None]
    values = [j.error for j in judged if j.error is not None and j.exact.unique]
    out: Record = {"inside_bracket": all(held) if held else None}
    for key, errors in (("exact_error", objective), ("exact_value_error", values)):
        worst = max(errors) if errors else None
        out[key] = None if worst is None else fraction_text(worst)
        out[f"{key}_float"] = None if worst is None else float(worst)
    return out


def make_record(
    check: str,
    claim: str,
    instance: str,
    solver: str,
    cmp: Comparison | None,
    detail: str = "",
    tally: Tally | None = None,
    *,
    error: str | None = None,
) -> Record:
    """A JSON-able record of one verdict: the one record builder of verify, its claims and
    campaigns.

    Parameters
    ----------
    check, claim, instance, solver : str
    cmp : Comparison or None
        The verdict and its intervals; None: no verdict (every number NaN).
    detail : str
    tally : Tally, optional
        The solves the record rests on (none if None).
    error : str, optional
        The record of a claim that gave no verdict: outcome :data:`ERROR` and ``error``
        saying why.
    """
    nan = float("nan")
    if cmp is None:
        cmp = Comparison(Verdict.INCONCLUSIVE, nan, nan, nan, 0, (nan, nan), (nan, nan))
    record: Record = {
        "check": check,
        "claim": claim,
        "instance": instance,
        "solver": solver,
        "verdict": cmp.verdict if error is None else ERROR,
        "width": cmp.width,
        "deviation": cmp.deviation,
        "accuracy": cmp.accuracy,
        "index": cmp.index,
        "lp_interval": list(cmp.a_interval),
        "exact_interval": list(cmp.b_interval),
        "detail": detail,
        **(tally or Tally()).fields(),
    }
    if error is not None:
        record["error"] = error
    return record


def error_record(
    check: str, claim: str, instance: str, solver: str, error: str, detail: str = "",
    tally: Tally | None = None,
) -> Record:  # fmt: skip
    """The record of a claim that gave no verdict: outcome :data:`ERROR`, no interval,
    ``error`` saying why (``tally``: the solves made before it failed); :func:`make_record`
    with ``error``."""
    return make_record(check, claim, instance, solver, None, detail, tally, error=error)


def _no_point(accuracy: float) -> Comparison:
    """The verdict when a solve returned no point: nothing is certified, so inconclusive."""
    inf = float("inf")
    return Comparison(Verdict.INCONCLUSIVE, inf, inf, accuracy, 0, (-inf, inf), (-inf, inf))


def _random_costs(n: int, k: int, rng: np.random.Generator) -> list[np.ndarray]:
    """``k`` costs: strictly positive first, then with about 40% zeros (never all zero)."""
    costs = [rng.uniform(0.1, 1.0, n)]
    for _ in range(k - 1):
        c = rng.uniform(0.0, 1.0, n)
        c[rng.random(n) < 0.4] = 0.0
        if not c.any():
            c[rng.integers(n)] = 1.0
        costs.append(c)
    return costs


def try_solve(form: Any, solver: str) -> tuple[LPResult | None, str]:
    """Solve ``form`` with ``solver`` for a check: ``(result, "")`` when a point came back
    (whatever its status: its certified bracket is valid), else ``(None, why)``; a solver
    that raises or crashes is such a ``why``, never an exception.

    Parameters
    ----------
    form : Formulation
    solver : str
        An installed cvxpy LP solver.

    Returns
    -------
    (LPResult or None, str)
    """
    try:
        res = form.solve(solver, raise_on_failure=False)
    except LPBoundsError as exc:
        return None, f"solve failed: {exc}"
    if not np.all(np.isfinite(res.x)):
        return None, f"no point: status {res.status} ({res.extra.get('message', '')})"
    return res, ""


@dataclass
class _Refs:
    """The exact side of one instance: ``V*`` and ``v*`` as certified intervals."""

    vfull_lo: np.ndarray
    vfull_hi: np.ndarray
    v_lo: np.ndarray
    v_hi: np.ndarray
    rlp_rows: BellmanRows
    accuracy: float
    costs: list[np.ndarray]
    d_list: list[np.ndarray]
    method: str = "mpi"
    judge: Callable[[Any, LPResult], SolverJudgement] | None = None

    def exact(self, model: Any) -> tuple[np.ndarray, np.ndarray]:
        """The certified interval of a model's or row system's fixed point."""
        return exact_interval(model, self.method)

    def tally(self) -> Tally:
        """A tally of solves (judging each against its exact optimum in rational mode)."""
        return Tally(judge=self.judge)


#: The methods of :func:`~lpbounds.dp.solve_exact` a check may use for its exact side.
EXACT_METHODS: tuple[str, ...] = ("mpi", "vi", "pi", "ipi")


def check_exact_method(method: Any) -> str:
    """``method`` checked: one of :data:`EXACT_METHODS`.

    Raises
    ------
    ValidationError
        For any other value (the message lists the known methods).
    """
    if method not in EXACT_METHODS:
        raise ValidationError(
            f"exact_method: unknown method {method!r}; known: {', '.join(EXACT_METHODS)}"
        )
    return str(method)


def exact_interval(model: Any, method: str = "mpi") -> tuple[np.ndarray, np.ndarray]:
    """The certified interval ``[values - error_bound, values + error_bound]`` (rounded
    outward) of the fixed point of ``model`` by :func:`~lpbounds.dp.solve_exact`.

    A method other than MPI that stops short of the tolerance raises
    :class:`~lpbounds.errors.ConvergenceError` in :func:`~lpbounds.dp.solve_exact`; it is
    then redone by MPI (policy iteration stops at a stable policy, which leaves a
    residual of rounding size that a tolerance set near the rounding floor can miss: seen
    on about 1 % of a campaign's instances, at reward scales near 1e-4).

    Parameters
    ----------
    model : FiniteMDP or BellmanRows
    method : str
        One of :data:`EXACT_METHODS`.

    Returns
    -------
    (ndarray, ndarray)
    """
    try:
        return dp_interval(solve_exact(model, cast(Any, method)))  # a name of EXACT_METHODS
    except ConvergenceError:
        if method == "mpi":
            raise
        return dp_interval(solve_exact(model, "mpi"))


def _draws(inst: VerifyInstance, n_costs: int, seed: int) -> tuple[list, list]:
    """The instance's costs ``c`` and LLP's surplus costs ``d`` (one dense, one with about
    half zeros), drawn from ``default_rng([seed, n_states, n_blocks])``."""
    mdp, part = inst.mdp, inst.partition
    rng = np.random.default_rng([seed, mdp.n_states, part.n_partitions])
    costs = _random_costs(mdp.n_states, n_costs, rng)
    d_list = [rng.uniform(0.0, 1.0, (mdp.n_states, mdp.n_actions)) for _ in range(2)]
    d_list[1][rng.random(d_list[1].shape) < 0.5] = 0.0
    return costs, d_list


def _references(
    inst: VerifyInstance, n_costs: int, seed: int, rtol: float, method: str = "mpi"
) -> _Refs:
    mdp, part = inst.mdp, inst.partition
    vfull_lo, vfull_hi = exact_interval(mdp, method)
    rlp_rows = BellmanRows.aggregate(mdp, part, reduce="max")
    v_lo, v_hi = exact_interval(rlp_rows, method)
    costs, d_list = _draws(inst, n_costs, seed)
    scale = dp_scale(mdp.reward_absmax, mdp.discount)
    return _Refs(vfull_lo, vfull_hi, v_lo, v_hi, rlp_rows, rtol * scale, costs, d_list, method)


def exact_instance(
    inst: VerifyInstance,
    n_costs: int = 3,
    seed: int = 0,
    *,
    size_limit: int | None = None,
    progress: Progress | None = None,
) -> ExactInstance:
    """The instance in exact arithmetic, with the costs and surplus costs
    :func:`verify_instance` draws for it (the same ``n_costs`` and ``seed``): what its
    rational mode decides the claims on (share one between :func:`verify_instance` and
    conjectures with ``exact=``).

    Parameters
    ----------
    inst : VerifyInstance
    n_costs, seed : int
        As for :func:`verify_instance`.
    size_limit : int, optional
        The most variables one exact solve takes (default
        :data:`~lpbounds.tolerances.EXACT_MAX_VARIABLES`).
    progress : callable(str), optional
        Called as each exact piece starts.

    Returns
    -------
    lpbounds.studies.exact_claims.ExactInstance
    """
    from .exact_claims import ExactInstance

    costs, d_list = _draws(inst, n_costs, seed)
    return ExactInstance(
        inst.name, inst.mdp, inst.partition, costs=costs, d_list=d_list, ib_blocks=IB_BLOCKS,
        size_limit=size_limit, progress=progress,
    )  # fmt: skip


def _optimum_claims(
    form: Any, res: LPResult, cost: np.ndarray, ref_lo: np.ndarray, ref_hi: np.ndarray, acc: float
) -> tuple[Comparison, Comparison | None, np.ndarray]:
    """``(objective verdict, per-entry verdict or None, certified feasible point)`` of the
    claim "this LP's optimum is the reference" (per entry only when ``cost > 0``: the
    optimum is unique only then)."""
    br = lp_bracket(form, res)
    lo, hi = lp_objective_bracket(form, res, br)
    rlo, rhi = objective_bracket(cost, ref_lo, ref_hi)
    obj = compare_equal(lo, hi, rlo, rhi, acc * float(cost.sum()))
    entry = compare_equal(br.lower, br.upper, ref_lo, ref_hi, acc) if np.all(cost > 0) else None
    return obj, entry, br.upper


# ---------------------------------------------------------------------- solver-free checks
def _exact_checks(
    inst: VerifyInstance, refs: _Refs, checks: tuple[str, ...] = INSTANCE_CHECKS
) -> list[Record]:
    """Phi v* >= V*; every VI iterate from a feasible start dominates v*; IB's fixed point
    (those of ``checks``)."""
    out: list[Record] = []
    if "Lemma 1" in checks:
        out.append(_lemma1_exact(inst, refs))
    if "Theorem 1" in checks:
        out.append(_theorem1_exact(inst, refs))
    if "Theorem 2" in checks:
        out.append(_theorem2_exact(inst, refs))
    return out


def _lemma1_exact(inst: VerifyInstance, refs: _Refs) -> Record:
    part, acc = inst.partition, refs.accuracy
    return make_record(
        "Lemma 1",
        "Phi v* >= V*",
        inst.name,
        "exact",
        compare_at_least(
            part.lift(refs.v_lo), part.lift(refs.v_hi), refs.vfull_lo, refs.vfull_hi, acc
        ),
        "RLP's bound dominates the exact value (both exact DP)",
    )


def _theorem1_exact(inst: VerifyInstance, refs: _Refs) -> Record:
    from ..certification.certificate import certify

    mdp, part, acc = inst.mdp, inst.partition, refs.accuracy
    u = np.full(part.n_partitions, float(refs.rlp_rows.reward.max()) / (1.0 - mdp.discount))
    cmps = []
    for _ in range(50):
        u, _ = refs.rlp_rows.apply_max(u)
        feas = certify(refs.rlp_rows, u).upper  # the computed iterate, made certainly feasible
        cmps.append(compare_at_least(feas, feas, refs.v_lo, refs.v_hi, acc))
    return make_record(
        "Theorem 1",
        "feasible points >= v*",
        inst.name,
        "exact",
        combine(cmps),
        "50 iterates T^k(max R/(1-lambda)), each certified feasible",
    )


def _theorem2_exact(inst: VerifyInstance, refs: _Refs) -> Record:
    mdp, part, acc = inst.mdp, inst.partition, refs.accuracy
    cmps = []
    for L in IB_BLOCKS:
        lo, hi = refs.exact(IB(mdp, part, L).rows)
        cmps.append(compare_equal(lo, hi, np.tile(refs.v_lo, L), np.tile(refs.v_hi, L), acc))
    return make_record(
        "Theorem 2",
        "fixed point of IB = (v*, ..., v*)",
        inst.name,
        "exact",
        combine(cmps),
        f"IB's cyclic rows, L = {IB_BLOCKS[0]}..{IB_BLOCKS[-1]} (exact DP)",
    )


# ---------------------------------------------------------------------- per solver
def _cost_claims(
    check: str,
    name: str,
    solver: str,
    forms: list[tuple[Any, np.ndarray]],
    ref_lo: np.ndarray,
    ref_hi: np.ndarray,
    acc: float,
    tally: Tally,
) -> tuple[list[Record], list[Comparison], LPResult | None, Tally]:
    """Objective and per-entry verdicts over the costs, the domination comparisons of the
    certified feasible points, the first cost's result (for Lemma 2) and the solves'
    ``tally`` (filled)."""
    objs, entries, doms, fail, first = [], [], [], "", None
    for k, (form, cost) in enumerate(forms):
        res, msg = try_solve(form, solver)
        tally.add(res, form)
        if res is None:
            objs.append(_no_point(acc))
            entries.append(_no_point(acc))
            doms.append(_no_point(acc))
            fail = msg
            continue
        first = res if k == 0 else first
        obj, entry, feas = _optimum_claims(form, res, cost, ref_lo, ref_hi, acc)
        objs.append(obj)
        if entry is not None:
            entries.append(entry)
        doms.append(compare_at_least(feas, feas, ref_lo, ref_hi, acc))
    n = len(forms)
    recs = [
        make_record(
            check,
            "optimal value = c'(exact)",
            name,
            solver,
            combine(objs),
            fail or f"{n} costs ({n - 1} with zeros); objective bracket vs exact",
            tally,
        )
    ]
    if entries:
        recs.append(
            make_record(
                check,
                "optimum = exact (c > 0)",
                name,
                solver,
                combine(entries),
                fail or "per entry, strictly positive cost (unique optimum)",
                tally,
            )
        )
    return recs, doms, first, tally


def _lemma2_checks(
    inst: VerifyInstance, refs: _Refs, solver: str, rlp: Any, rlp_res: LPResult
) -> list[Record]:
    """SLP(mu-bar) and the reduced MDP against Lemma 2's predicted interval."""
    name, acc = inst.name, refs.accuracy
    try:
        slp = SLP(inst.mdp, inst.partition, rlp_res.mu)
    except LPBoundsError as exc:
        cmp = _no_point(acc)
        return [make_record("Lemma 2", "SLP(mu-bar) = v*", name, solver, cmp, f"SLP failed: {exc}")]
    sigma = lemma2_slack(rlp, rlp_res, refs.v_lo, refs.v_hi)
    beta = float(
        np.nextafter(sigma / (1.0 - contraction_modulus(slp.rows)) * (1 + 4 * _EPS), np.inf)
    )
    pred_lo = np.nextafter(refs.v_lo - beta, -np.inf)
    note = f"predicted [v* - {beta:.2e}, v*] from the duals' certified slack"
    res, msg = try_solve(slp, solver)
    tally = refs.tally()
    tally.add(res, slp)
    if res is None:
        cmp, detail = _no_point(acc), msg
    else:
        br = lp_bracket(slp, res)
        cmp, detail = compare_equal(br.lower, br.upper, pred_lo, refs.v_hi, acc), note
    red_lo, red_hi = refs.exact(slp.reduced_mdp())
    return [
        make_record("Lemma 2", "SLP(mu-bar) = v*", name, solver, cmp, detail, tally),
        make_record(
            "Lemma 2",
            "reduced MDP value = v*",
            name,
            solver,
            compare_equal(red_lo, red_hi, pred_lo, refs.v_hi, acc),
            f"exact DP of step 2's MDP ({int(slp.rows.n_rows)} (i, u) rows); {note}",
        ),
    ]


def _lemma2_without_duals(name: str, solver: str, acc: float, tally: Tally) -> list[Record]:
    """Lemma 2's records when the first RLP solve returned no point (no duals to build
    ``SLP(mu-bar)`` from): *inconclusive*, so that the claim still has its records."""
    why = "no RLP point, so no duals mu-bar to build SLP(mu-bar) from"
    return [
        make_record("Lemma 2", "SLP(mu-bar) = v*", name, solver, _no_point(acc), why, tally),
        make_record("Lemma 2", "reduced MDP value = v*", name, solver, _no_point(acc), why),
    ]


def lemma2_slack(rlp: Any, result: LPResult, v_lo: np.ndarray, v_hi: np.ndarray) -> float:
    r"""Certified upper bound on ``sigma = max_i min_u`` (slack at ``v*`` of ``SLP(mu-bar)``'s
    row ``(i, u)``) for the pair duals ``mu-bar = result.mu`` of an RLP solve.

    Lemma 2's proof: by complementary slackness an optimal dual puts weight only on rows
    tight at ``v*``, so every surrogate row is tight and ``SLP(mu-bar) = v*``. For any
    ``mu >= 0`` the surrogate row ``(i, u)`` is the ``mu``-weighted average of its pairs'
    RLP rows, so its slack at ``v*`` is ``sum_x mu(x, u) s_(x,u) / Y_iu`` with ``s`` the
    RLP row slacks (``>= 0``) and ``Y_iu = sum_{x in S_i} mu(x, u)``; the smallest over
    ``u`` bounds ``(v* - T_mu v*)(i)``, and by the contraction argument SLP's optimum
    ``w*`` satisfies ``v* - sigma / (1 - kappa) <= w* <= v*`` (``<= v*``: SLP is a
    relaxation of RLP). Exactly optimal duals give ``sigma = 0``: Lemma 2; a solver's
    near-optimal duals give a small ``sigma`` (their complementary slackness
    ``y'(A v* - b)`` is small), inaccurate ones a large one, which widens the predicted
    interval (*inconclusive*), never a *violated* verdict.

    ``s`` is bounded above from ``[v_lo, v_hi]`` with a rounding allowance of ``2 (L + 3)
    eps`` times the magnitudes summed (as in :mod:`lpbounds.certification.certificate`), the
    weighted
    sums by ``(n + 3) eps`` relative, and ``(L + 4) eps (max|R| + max|v|)`` covers SLP's
    renormalised probabilities. ``inf`` when the result has no pair duals.
    """
    rows = rlp.rows
    mu = None if result.mu is None else np.asarray(result.mu, dtype=np.float64)
    if mu is None or rows.pair_row is None or not np.all(np.isfinite(mu)):
        return float("inf")
    lam, n_out = rows.discount, rows.n_outcomes
    probs = np.asarray(rows.probs)
    t_lo = (probs * v_lo[rows.targets]).sum(axis=1)
    t_abs = (probs * np.abs(v_lo[rows.targets])).sum(axis=1)
    own = v_hi[rows.owner]
    mag = np.abs(rows.reward) + np.abs(own) + lam * t_abs
    s_hi = np.maximum(own - rows.reward - lam * t_lo + 2 * (n_out + 3) * _EPS * mag, 0.0)
    part, n_actions = rlp.partition, mu.shape[1]
    w = np.maximum(mu, 0.0)
    pair_s = np.where(w > 0, s_hi[np.maximum(rows.pair_row, 0)], 0.0)
    key = (part.labels[:, None] * n_actions + np.arange(n_actions)).ravel()
    size = part.n_partitions * n_actions
    num = np.bincount(key, weights=(w * pair_s).ravel(), minlength=size)
    den = np.bincount(key, weights=w.ravel(), minlength=size)
    rel = (mu.shape[0] + 3) * _EPS
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(den > 0, num * (1 + rel) / (den * (1 - rel)), np.inf)
    sigma = float(ratio.reshape(part.n_partitions, n_actions).min(axis=1).max(initial=0.0))
    vmax = float(np.maximum(np.abs(v_lo), np.abs(v_hi)).max(initial=0.0))
    rounding = (n_out + 4) * _EPS * (float(np.abs(rows.reward).max(initial=0.0)) + vmax)
    return sigma * (1.0 + 4 * _EPS) + rounding


def _theorem2_checks(inst: VerifyInstance, refs: _Refs, solver: str) -> list[Record]:
    """IB: every block = v* (and its certified feasible point >= v*); LLP: v >= v*."""
    name, acc, mdp, part = inst.name, refs.accuracy, inst.mdp, inst.partition
    eq, dom, fail, tally = [], [], "", refs.tally()
    for L in IB_BLOCKS:
        ib = IB(mdp, part, L)
        res, msg = try_solve(ib, solver)
        tally.add(res, ib)
        if res is None:
            eq.append(_no_point(acc))
            dom.append(_no_point(acc))
            fail = msg
            continue
        br = lp_bracket(ib, res)
        lo, hi = np.tile(refs.v_lo, L), np.tile(refs.v_hi, L)
        eq.append(compare_equal(br.lower, br.upper, lo, hi, acc))
        dom.append(compare_at_least(br.upper, br.upper, lo, hi, acc))
    span = f"IB L={IB_BLOCKS[0]}..{IB_BLOCKS[-1]}"
    out = [
        make_record("Theorem 2", "IB blocks = v*", name, solver, combine(eq), fail or span, tally),
        make_record(
            "Theorem 2",
            "IB feasible point >= v*",
            name,
            solver,
            combine(dom),
            fail or f"{span}: certified feasible point, every block",
            tally,
        ),
    ]
    llp, fail, tally = [], "", refs.tally()
    for d in refs.d_list:
        form = LLP(mdp, part, d)
        res, msg = try_solve(form, solver)
        tally.add(res, form)
        if res is None:
            llp.append(_no_point(acc))
            fail = msg
            continue
        feas = lp_bracket(form, _LLPView(res)).upper
        llp.append(compare_at_least(feas, feas, refs.v_lo, refs.v_hi, acc))
    out.append(
        make_record(
            "Theorem 2",
            "LLP v >= v*",
            name,
            solver,
            combine(llp),
            fail or f"LLP with {len(refs.d_list)} random d >= 0: certified feasible v",
            tally,
        )
    )
    return out


class _LLPView:
    """An LLP result seen as a point of RLP's rows (its ``v``): LLP's certificate is on them."""

    def __init__(self, res: LPResult) -> None:
        self.x = np.asarray(res.values, dtype=np.float64)
        self.certificate = res.certificate
        self.lower_values = res.lower_values
        self.upper_values = res.upper_values
        self.duals = None


def _across_solvers(name: str, firsts: dict[str, tuple[Any, LPResult]], acc: float) -> list[Record]:
    """The first cost's RLP brackets of every pair of solvers overlap (same optimum)."""
    if len(firsts) < 2:
        return []
    brs = {s: lp_bracket(form, res) for s, (form, res) in firsts.items()}
    cmps = [
        compare_equal(a.lower, a.upper, b.lower, b.upper, acc)
        for i, a in enumerate(brs.values())
        for b in list(brs.values())[i + 1 :]
    ]
    return [
        make_record(
            "Theorem 1",
            "RLP optima agree",
            name,
            "all",
            combine(cmps),
            f"certified brackets of {', '.join(brs)} (first cost)",
        )
    ]


def _check_names(checks: Iterable[str] | None) -> tuple[str, ...]:
    """The selected checks of :data:`INSTANCE_CHECKS` (all when None), in their order."""
    if checks is None:
        return INSTANCE_CHECKS
    chosen = list(checks)
    unknown = [c for c in chosen if c not in INSTANCE_CHECKS]
    if unknown:
        raise ValidationError(
            f"checks: unknown check {unknown[0]!r}; known: {', '.join(INSTANCE_CHECKS)}"
        )
    return tuple(c for c in INSTANCE_CHECKS if c in chosen)


def _solver_checks(
    inst: VerifyInstance, refs: _Refs, solver: str, checks: tuple[str, ...]
) -> tuple[list[Record], tuple[Any, LPResult] | None]:
    """One solver's records of ``checks`` and its first RLP solve (for "RLP optima agree")."""
    mdp, part, name, acc = inst.mdp, inst.partition, inst.name, refs.accuracy
    records: list[Record] = []
    if "Lemma 1" in checks:
        elps = [(ELP(mdp, c), c) for c in refs.costs]
        records += _cost_claims(
            "Lemma 1", name, solver, elps, refs.vfull_lo, refs.vfull_hi, acc, refs.tally()
        )[0]
    first_rlp = None
    if "Theorem 1" in checks or "Lemma 2" in checks:
        m = part.n_partitions
        rlps = [
            (RLP(mdp, part, c), np.bincount(part.labels, weights=c, minlength=m))
            for c in refs.costs
        ]
        recs, doms, first, tally = _cost_claims(
            "Theorem 1", name, solver, rlps, refs.v_lo, refs.v_hi, acc, refs.tally()
        )
        if "Theorem 1" in checks:
            records += recs
            records.append(
                make_record(
                    "Theorem 1",
                    "feasible points >= v*",
                    name,
                    solver,
                    combine(doms),
                    f"certified feasible point of each of the {len(rlps)} RLP solves",
                    tally,
                )
            )
        if first is not None:
            first_rlp = (rlps[0][0], first)
            if "Lemma 2" in checks:
                records += _lemma2_checks(inst, refs, solver, rlps[0][0], first)
        elif "Lemma 2" in checks:
            records += _lemma2_without_duals(inst.name, solver, acc, tally)
    if "Theorem 2" in checks:
        records += _theorem2_checks(inst, refs, solver)
    return records, first_rlp


def verify_instance(
    inst: VerifyInstance,
    solvers: Sequence[str],
    *,
    n_costs: int = 3,
    seed: int = 0,
    rtol: float = LP_COMPARE_RTOL,
    progress: Progress | None = None,
    checks: Iterable[str] | None = None,
    exact_method: str = "mpi",
    arithmetic: str = "float",
    exact_size_limit: int | None = None,
    certificates: str | Path | None = None,
    exact: ExactInstance | None = None,
) -> list[Record]:
    """Lemma 1, Theorem 1, Lemma 2 and Theorem 2 on one instance, for each solver.

    Parameters
    ----------
    inst : VerifyInstance
    solvers : sequence of str
        Installed cvxpy LP solvers (checked with :func:`resolve_solver`).
    n_costs : int
        Number of random costs per LP (>= 1; the first is strictly positive).
    seed : int
        Seed of the costs and of LLP's ``d``.
    rtol : float
        Requested accuracy, relative to ``max|R| / (1 - lambda)``: a claim *holds* when
        the intervals allow no difference larger than that.
    progress : callable(str), optional
        Called before each solver's checks.
    checks : iterable of str, optional
        The checks to make, names of :data:`INSTANCE_CHECKS` (default all of them).
    exact_method : str
        The method of :func:`~lpbounds.dp.solve_exact` for every exact fixed point
        (:data:`EXACT_METHODS`; the certified intervals are valid whichever it is): MPI
        by default; policy iteration (``"pi"``) is far faster on small models at discounts
        near 1 (a 6-state model at 0.9994: 0.03 s against 6 s), so campaigns use it.
    arithmetic : {"float", "rational"}
        ``"rational"``: every check is also decided exactly, before any LP is solved, and
        every solve judged against its exact optimum (see the module docstring).
    exact_size_limit : int, optional
        ``"rational"``: the most variables one exact solve takes (default
        :data:`~lpbounds.tolerances.EXACT_MAX_VARIABLES`); a larger instance is refused
        before any exact or LP work (:class:`~lpbounds.errors.SizeLimitError`).
    certificates : str or Path, optional
        ``"rational"``: a folder to write one certificate per check into
        (:func:`~lpbounds.studies.exact_claims.write_certificates`); each record names
        its file (``certificate``).
    exact : ExactInstance, optional
        ``"rational"``: the instance's exact side (:func:`exact_instance` with the same
        ``n_costs`` and ``seed``), to share its exact solves with conjectures.

    Returns
    -------
    list of dict
        One record per claim and solver (see the module docstring).

    Raises
    ------
    SizeLimitError
        ``"rational"``: above ``exact_size_limit``.
    """
    if n_costs < 1:
        raise ValidationError(f"n_costs must be >= 1; got {n_costs}")
    if not (np.isfinite(rtol) and rtol > 0):
        raise ValidationError(f"rtol must be a positive finite number; got {rtol!r}")
    chosen = _check_names(checks)
    check_exact_method(exact_method)
    check_arithmetic(arithmetic)
    names = [resolve_solver(s) for s in solvers]
    refs = _references(inst, n_costs, seed, rtol, exact_method)
    decided = None
    if arithmetic == "rational":  # decided first: a size above the limit is refused at once
        if exact is None:
            exact = exact_instance(
                inst, n_costs, seed, size_limit=exact_size_limit, progress=progress
            )
        _check_same_draws(exact, refs)
        decided = decide_checks(exact, chosen, certificates)
        refs.judge = exact.judge
    records = _exact_checks(inst, refs, chosen)
    firsts: dict[str, tuple[Any, LPResult]] = {}
    for solver in names:
        if progress is not None:
            progress(f"{inst.name}: {solver}")
        recs, first = _solver_checks(inst, refs, solver, chosen)
        records += recs
        if first is not None:
            firsts[solver] = first
    if "Theorem 1" in chosen:
        records += _across_solvers(inst.name, firsts, refs.accuracy)
    return records if decided is None else [rational_record(r, decided) for r in records]


# ---------------------------------------------------------------------- rational arithmetic
#: A check decided exactly and the name of its certificate file ("" when none was written).
Decided = dict[str, "tuple[ExactVerdict, str]"]


def _check_same_draws(exact: ExactInstance, refs: _Refs) -> None:
    same = len(exact.costs) == len(refs.costs) and all(
        np.array_equal(a, b) for a, b in zip(exact.costs, refs.costs, strict=False)
    )
    if not same or len(exact.d_list) != len(refs.d_list):
        raise ValidationError(
            "exact: its costs are not the ones drawn for this instance; build it with "
            "exact_instance(inst, n_costs, seed) of the same n_costs and seed"
        )


def decide_checks(
    exact: ExactInstance, checks: Iterable[str], certificates: str | Path | None = None
) -> Decided:
    """The checks decided exactly on ``exact`` (each with its certificate's file name when
    written into the folder ``certificates``), by check."""
    verdicts = exact.decide(checks)
    names = [""] * len(verdicts)
    if certificates is not None:
        from .exact_claims import write_certificates

        names = [p.name for p in write_certificates(verdicts, certificates)]
    return {v.check: (v, name) for v, name in zip(verdicts, names, strict=True)}


def _rests_on(verdict: ExactVerdict, prefix: str | None) -> tuple[bool, Fraction]:
    """Whether the exact comparisons whose names start with ``prefix`` (all when None or
    none match) hold, and their difference (the largest of equalities, the smallest of
    inequalities)."""
    comps = verdict.certificate["claim"]["comparisons"]
    chosen = [c for c in comps if prefix is None or c["claim"].startswith(prefix)] or comps
    diffs = [verdict.differences[c["claim"]] for c in chosen]
    worst = max(diffs) if chosen[0]["relation"] == "==" else min(diffs)
    return all(c["verdict"] == "holds" for c in chosen), worst


def rational_record(record: Record, decided: Decided) -> Record:
    """A floating-point record in rational arithmetic: ``verdict`` the exact verdict of the
    comparisons its claim rests on (:data:`EXACT_OF_CLAIM`), ``float_verdict`` the one it
    had, and the other :data:`EXACT_COLUMNS` (an *error* record stays one).

    Parameters
    ----------
    record : dict
        A record of :func:`verify_instance` or :func:`verify_remark2` (``inside_bracket``
        and ``exact_error`` from its judged tally, when it has one).
    decided : dict
        The record's check decided exactly, by check (:func:`decide_checks`).
    """
    out = {k: v for k, v in record.items() if k not in EXACT_COLUMNS}
    extra: Record = {k: record.get(k) for k in EXACT_COLUMNS}
    extra["float_verdict"] = outcome_of(record)
    found = decided.get(record["check"])
    if found is not None and outcome_of(record) != ERROR:
        verdict, name = found
        holds, diff = _rests_on(verdict, EXACT_OF_CLAIM.get((record["check"], record["claim"])))
        out["verdict"] = Verdict.HOLDS if holds else Verdict.VIOLATED
        if record["solver"] == EXACT_SOLVER:  # exact values are points: no width left
            out["width"] = 0.0
        extra.update(
            exact_difference=fraction_text(diff),
            exact_difference_float=float(diff),
            exact_seconds=verdict.seconds,
            certificate=name,
        )
    return {**out, **extra}


# ---------------------------------------------------------------------- Remark 2
def _exact_alp_data(
    mdp: FiniteMDP, basis: np.ndarray, cost: np.ndarray
) -> tuple[list[list[Fraction]], list[Fraction], list[Fraction]]:
    """``G = (E - lambda P) Phi``, ``b = R`` and ``Phi' c`` in exact rational arithmetic,
    from the floating-point data taken as exact."""
    rows = exact_rows(mdp)
    lam = Fraction(float(rows.discount))
    phi = [[Fraction(float(t)) for t in row] for row in np.asarray(basis, dtype=np.float64)]
    n_feat = len(phi[0])
    probs = np.asarray(rows.probs)
    g = []
    for r in range(rows.n_rows):
        own = phi[int(rows.owner[r])]
        row = list(own)
        for t, p in zip(rows.targets[r], probs[r], strict=True):
            if p != 0.0:
                fp = lam * Fraction(float(p))
                row = [row[k] - fp * phi[int(t)][k] for k in range(n_feat)]
        g.append(row)
    b = [Fraction(float(t)) for t in rows.reward]
    cf = [Fraction(float(t)) for t in cost]
    c_phi = [sum((cf[x] * phi[x][k] for x in range(len(cf))), Fraction(0)) for k in range(n_feat)]
    return g, b, c_phi


def _exact_dual_bound(
    g: list[list[Fraction]], b: list[Fraction], c_phi: list[Fraction], y: np.ndarray
) -> Fraction | None:
    """``b'y'`` for the solver's duals repaired to exact feasibility ``G'y' = Phi'c``, ``y' >=
    0`` (the residual is absorbed by the rows with the largest duals); None if that fails."""
    k = len(c_phi)
    yf = [Fraction(float(t)) for t in np.maximum(y, 0.0)]
    resid = [
        sum((g[r][j] * yf[r] for r in range(len(g))), Fraction(0)) - c_phi[j] for j in range(k)
    ]
    for start in range(max(1, len(g) - k + 1)):
        chosen = [int(r) for r in np.argsort(-y, kind="stable")[start : start + k]]
        if len(chosen) < k:
            return None
        delta = solve_rational([[g[r][j] for r in chosen] for j in range(k)], [-t for t in resid])
        if delta is None:
            continue
        yy = list(yf)
        for r, dlt in zip(chosen, delta, strict=True):
            yy[r] += dlt
        if all(t >= 0 for t in yy):
            return sum((b[r] * yy[r] for r in range(len(b))), Fraction(0))
    return None


def alp_value_bracket(
    mdp: FiniteMDP, basis: np.ndarray, cost: np.ndarray, result: LPResult
) -> tuple[Fraction | None, Fraction | None]:
    r"""Exact rational bracket ``[lo, hi]`` on the optimal value of ``ALP(mdp, basis, cost)``.

    The LP ``min (Phi'c)'r  s.t.  G r >= b`` (``G = (E - lambda P) Phi``) is rebuilt in
    exact rational arithmetic from its floating-point data, so no rounding argument is
    needed:

    * ``hi``: the solver's ``r`` shifted along ``1`` (``G 1`` is about ``(1 - lambda) Phi 1
      > 0`` for a soft-aggregation basis) by the least ``delta`` making it exactly
      feasible; its objective is an upper bound;
    * ``lo``: the solver's duals ``y >= 0``, with the residual ``G'y - Phi'c`` cancelled
      exactly on the ``K`` rows of largest dual (a ``K x K`` rational solve,
      :func:`lpbounds.exact.rationals.solve_rational`), stay ``>= 0``
      and give the weak-duality bound ``b'y'``.

    Either end is None when its construction fails (the bracket is then unbounded on that
    side). Meant for the small instances of Remark 2 (cost grows with rows times ``K``).
    """
    g, b, c_phi = _exact_alp_data(mdp, basis, cost)
    r = [Fraction(float(t)) for t in np.asarray(result.values, dtype=np.float64)]
    k = len(r)
    slack = [
        sum((row[j] * r[j] for j in range(k)), Fraction(0)) - bb
        for row, bb in zip(g, b, strict=True)
    ]
    step = [sum(row, Fraction(0)) for row in g]
    need = [-s / d for s, d in zip(slack, step, strict=True) if s < 0 and d > 0]
    hi: Fraction | None = None
    if all(s >= 0 or d > 0 for s, d in zip(slack, step, strict=True)):
        delta = max(need, default=Fraction(0))
        hi = sum((cj * (rj + delta) for cj, rj in zip(c_phi, r, strict=True)), Fraction(0))
    y = np.asarray(result.duals, dtype=np.float64)
    lo = _exact_dual_bound(g, b, c_phi, y) if np.all(np.isfinite(y)) else None
    return lo, hi


def verify_remark2(
    solvers: Sequence[str],
    *,
    seed: int = 0,
    rtol: float = LP_COMPARE_RTOL,
    arithmetic: str = "float",
    exact_size_limit: int | None = None,
    certificates: str | Path | None = None,
) -> list[Record]:
    """Remark 2: a soft-aggregation ALP whose optimum depends on the cost, per solver.

    The verdict is *holds* when the exact brackets prove ``OPT(c1 + c2) > OPT(c1) +
    OPT(c2)`` (no point is optimal for both costs), *inconclusive* otherwise; see the
    module docstring. ``deviation`` is the certified difference ``lo(OPT(c1 + c2)) -
    hi(OPT(c1)) - hi(OPT(c2))``, ``width`` the widest of the three brackets.

    With ``arithmetic="rational"`` the three ALP optima are computed exactly
    (:func:`~lpbounds.studies.exact_claims.decide_remark2`: exact simplex, exact duals),
    the claim decided on them (*holds* or *violated*), each solve judged against its
    exact optimum, and the certificate written into ``certificates`` when given (see
    :func:`verify_instance`).
    """
    check_arithmetic(arithmetic)
    names = [resolve_solver(s) for s in solvers]
    ex = find_cost_dependent_alp(seed, rtol=rtol)
    inst = f"soft-agg garnet seed {ex.seed} (n=6, K=2)"
    costs = [ex.cost1, ex.cost2, ex.cost1 + ex.cost2]
    judge, decided = None, None
    if arithmetic == "rational":
        from .exact_claims import ExactJudge, decide_remark2, write_certificates

        verdict = decide_remark2(
            ex.mdp, ex.basis, ex.cost1, ex.cost2, name=inst, size_limit=exact_size_limit
        )
        written = [] if certificates is None else write_certificates([verdict], certificates)
        decided = {verdict.check: (verdict, written[0].name if written else "")}
        judge = ExactJudge(exact_size_limit)
    out = []
    for solver in names:
        brackets, fail, tally = [], "", Tally(judge=judge)
        for c in costs:
            form = ALP(ex.mdp, ex.basis, c)
            res, msg = try_solve(form, solver)
            tally.add(res, form)
            fail = fail or msg
            brackets.append(
                (None, None) if res is None else alp_value_bracket(ex.mdp, ex.basis, c, res)
            )
        out.append(_remark2_record(inst, solver, brackets, fail, tally))
    return out if decided is None else [rational_record(r, decided) for r in out]


def _remark2_record(
    inst: str,
    solver: str,
    brackets: list[tuple[Fraction | None, Fraction | None]],
    fail: str,
    tally: Tally,
) -> Record:
    (_lo1, hi1), (_lo2, hi2), (lo12, hi12) = brackets
    inf = float("inf")

    def width(lo: Fraction | None, hi: Fraction | None) -> float:
        return inf if lo is None or hi is None else float(hi - lo)

    if lo12 is None or hi1 is None or hi2 is None:
        diff, verdict = -inf, Verdict.INCONCLUSIVE
    else:
        exact = lo12 - hi1 - hi2
        diff = float(exact)
        verdict = Verdict.HOLDS if exact > 0 else Verdict.INCONCLUSIVE
    w = max(width(*bk) for bk in brackets)
    cmp = Comparison(
        verdict,
        w,
        diff,
        0.0,
        0,
        (-inf if lo12 is None else float(lo12), inf if hi12 is None else float(hi12)),
        (-inf if hi1 is None or hi2 is None else float(hi1 + hi2),) * 2,
    )
    detail = fail or (
        "certified OPT(c1+c2) - OPT(c1) - OPT(c2) > 0: no common optimum (exact rational "
        "brackets); the LP interval is OPT(c1+c2)'s bracket, the exact one the upper "
        "end of OPT(c1) + OPT(c2)"
    )
    return make_record("Remark 2", "ALP optimum depends on c", inst, solver, cmp, detail, tally)


def run_verification(
    models: Iterable[str] | None = None,
    *,
    solvers: Sequence[str] | None = None,
    n_random: int = 5,
    seed: int = 0,
    n_costs: int = 3,
    rtol: float = LP_COMPARE_RTOL,
    max_states: int = 10_000,
    include_models: bool = True,
    progress: Progress | None = None,
    arithmetic: str = "float",
    exact_size_limit: int | None = None,
    certificates: str | Path | None = None,
) -> VerifyResult:
    """Every check on the models and ``n_random`` random instances, for each solver.

    Parameters
    ----------
    models : iterable of str, optional
        Model names or paths; default all of ``models/`` with a partition and at most
        ``max_states`` states.
    solvers : sequence of str, optional
        Any installed LP solvers; default :func:`default_solvers`.
    include_models : bool
        False: random instances (and Remark 2) only.
    arithmetic, exact_size_limit, certificates
        As for :func:`verify_instance` (``"rational"``: every claim decided exactly).

    Returns
    -------
    VerifyResult
        ``(records, skipped)``, a named tuple: ``skipped`` are the default models left out
        for their size; ``to_pandas()`` gives the records as a table.
    """
    check_arithmetic(arithmetic)
    solver_names = [resolve_solver(s) for s in (solvers or default_solvers())]
    exact: dict[str, Any] = {}
    if arithmetic == "rational":
        exact = dict(
            arithmetic=arithmetic, exact_size_limit=exact_size_limit, certificates=certificates
        )
    insts: list[VerifyInstance] = []
    skipped: list[str] = []
    if include_models:
        insts, skipped = model_instances(models, max_states)
    insts += random_instances(n_random, seed)
    records: list[Record] = []
    for inst in insts:
        records += verify_instance(
            inst, solver_names, n_costs=n_costs, seed=seed, rtol=rtol, progress=progress,
            **exact,
        )  # fmt: skip
    if progress is not None:
        progress("Remark 2")
    records += verify_remark2(solver_names, seed=seed, rtol=rtol, **exact)
    return VerifyResult(records, skipped)


#: The columns of :func:`records_frame`, in order: the record keys (see the module
#: docstring) with ``lp_interval`` and ``exact_interval`` split into their ends
#: ``lp_lo``, ``lp_hi``, ``exact_lo``, ``exact_hi``. ``verdict`` is the verdict's word.
RECORD_COLUMNS: tuple[str, ...] = (
    "check",
    "claim",
    "instance",
    "solver",
    "verdict",
    "width",
    "deviation",
    "accuracy",
    "index",
    "lp_lo",
    "lp_hi",
    "exact_lo",
    "exact_hi",
    "detail",
    "solves",
    "solve_seconds",
    "compile_seconds",
    "lp_status",
    "solver_status",
)


def flat_record(record: Record) -> Record:
    """A record with plain values only: the intervals split into their ends, the verdict
    as its word (the row of :func:`records_frame`, and of a campaign's CSV files)."""
    out = {k: v for k, v in record.items() if k not in ("lp_interval", "exact_interval")}
    nan = (float("nan"), float("nan"))
    out["lp_lo"], out["lp_hi"] = (float(t) for t in record.get("lp_interval", nan))
    out["exact_lo"], out["exact_hi"] = (float(t) for t in record.get("exact_interval", nan))
    out["verdict"] = str(record["verdict"])
    return out


def records_frame(records: Sequence[Record]) -> pd.DataFrame:
    """The records as a table, one row per record: :data:`RECORD_COLUMNS` first, then any
    other keys the records carry (a campaign's instance columns), in order of appearance.

    Parameters
    ----------
    records : sequence of dict
        Records of :func:`verify_instance`, :func:`verify_remark2` or a campaign.

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    rows = [flat_record(r) for r in records]
    extra = list(dict.fromkeys(k for r in rows for k in r if k not in RECORD_COLUMNS))
    return pd.DataFrame.from_records(rows, columns=[*RECORD_COLUMNS, *extra])


class VerdictRecords:
    """What a verification's and a campaign's results share, from their records (the
    hook :meth:`record_list`): outcome counts, the summary table and the exit status."""

    def record_list(self) -> list[Record]:
        """The records (hook)."""
        raise NotImplementedError

    def incomplete(self) -> bool:
        """Whether records due are missing (hook; a campaign's), which fails the run."""
        return False

    def verdicts(self) -> dict[str, int]:
        """How many records have each outcome (:data:`OUTCOMES`: the three verdicts and
        "error")."""
        found = [outcome_of(r) for r in self.record_list()]
        return {w: found.count(w) for w in OUTCOMES}

    def summary(self) -> pd.DataFrame:
        """One row per (check, solver): outcome counts and the worst record
        (:func:`summarize`)."""
        import pandas as pd

        return pd.DataFrame.from_records(summarize(self.record_list()))

    def exit_status(self, strict: bool = False) -> int:
        """1 if a record is *violated* or an *error*, or its exact side shows a defect (a
        certified bracket that missed, a floating-point *violated* that holds exactly), or
        records due are missing; with ``strict`` also if one is *inconclusive*; else 0
        (:func:`exit_status`)."""
        return 1 if self.incomplete() else exit_status(self.record_list(), strict=strict)


@dataclass
class VerifyResult(VerdictRecords):
    """What :func:`run_verification` returns: the records and the models skipped for
    their size (it unpacks as ``records, skipped = run_verification(...)``)."""

    records: list[Record]
    skipped: list[str]

    def __iter__(self) -> Iterator[Any]:
        return iter((self.records, self.skipped))

    def record_list(self) -> list[Record]:
        """The records."""
        return self.records

    def to_pandas(self) -> pd.DataFrame:
        """The records as a table (:func:`records_frame`, columns :data:`RECORD_COLUMNS`)."""
        return records_frame(self.records)


_CHECK_ORDER = [*INSTANCE_CHECKS, "Remark 2"]
_OUTCOME_RANK = {v: k for k, v in enumerate(OUTCOMES)}


def outcome_of(record: Record) -> str:
    """A record's outcome as a word of :data:`OUTCOMES` (its verdict's, or "error")."""
    v = record["verdict"]
    return str(v.value if isinstance(v, Verdict) else v)


def _badness(r: Record) -> tuple[int, float]:
    acc = r["accuracy"]
    ratio = r["width"] / acc if acc and np.isfinite(acc) else float(r["width"])
    return _OUTCOME_RANK[outcome_of(r)], ratio if np.isfinite(ratio) else float("inf")


def summarize(records: Sequence[Record]) -> list[Record]:
    """One row per (check, solver): the counts of each outcome and the worst record.

    Each row has ``check``, ``solver``, ``records``, ``holds``, ``inconclusive``,
    ``violated``, ``error`` (records without a verdict), and ``verdict``, ``width``,
    ``accuracy`` of the worst record (worst outcome, an error worst of all, then the
    largest ``width / accuracy``). Records of rational arithmetic add
    ``float_inconclusive`` (decided exactly where the floating-point intervals could
    not), ``disagree`` (a floating-point verdict, decided, other than the exact one) and
    ``missed`` (records with a certified bracket that missed its exact optimum).
    """
    groups: dict[tuple[str, str], list[Record]] = {}
    for r in records:
        groups.setdefault((r["check"], r["solver"]), []).append(r)
    out = []
    for (check, solver), recs in sorted(
        groups.items(),
        key=lambda kv: (
            _CHECK_ORDER.index(kv[0][0]) if kv[0][0] in _CHECK_ORDER else 99,
            kv[0][1],
        ),
    ):
        worst = max(recs, key=_badness)
        row: Record = {"check": check, "solver": solver, "records": len(recs)}
        for word in OUTCOMES:
            row[word] = sum(outcome_of(r) == word for r in recs)
        if any("float_verdict" in r for r in recs):
            row.update(_exact_counts(recs))
        row.update(verdict=worst["verdict"], width=worst["width"], accuracy=worst["accuracy"])
        out.append(row)
    return out


def _disagrees(r: Record) -> bool:
    """A decided floating-point verdict other than the record's exact one."""
    was = r.get("float_verdict")
    return was in ("holds", "violated") and was != outcome_of(r)


def _missed(r: Record) -> bool:
    """A certified bracket of the record's solves missed its exact optimum (``False``,
    or ``"False"`` as read back from a campaign's CSV)."""
    return str(r.get("inside_bracket")) == "False"


def _exact_counts(recs: Sequence[Record]) -> Record:
    return {
        "float_inconclusive": sum(r.get("float_verdict") == "inconclusive" for r in recs),
        "disagree": sum(_disagrees(r) for r in recs),
        "missed": sum(_missed(r) for r in recs),
    }


def exit_status(records: Sequence[Record], *, strict: bool = False) -> int:
    """1 if a record is *violated* or an *error* (with ``strict``, also *inconclusive*),
    or (rational arithmetic) one shows a defect of the floating-point side: a certified
    bracket that missed its exact optimum, or a floating-point *violated* (a proof) where
    the exact verdict holds; else 0."""
    bad = {"violated", ERROR, *(["inconclusive"] if strict else [])}
    defect = any(_missed(r) or r.get("float_verdict") == "violated" for r in records)
    return 1 if defect or any(outcome_of(r) in bad for r in records) else 0


def write_json(records: list[Record], path: str | Path) -> None:
    """Write the records as a JSON list, atomically (:func:`~lpbounds.outputs.write_text_atomic`:
    the file holds its previous content or the whole list, never a part)."""
    import json

    from ..outputs import write_text_atomic

    write_text_atomic(path, json.dumps(records, indent=2))
