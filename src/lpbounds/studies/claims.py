r"""The claims a verification campaign checks: the paper's, built in, and your own conjectures.

A **claim** is checked on one instance (an MDP and a partition) and gives records, one per
solver, each with a :class:`~lpbounds.status.Verdict` (*holds*, *violated*,
*inconclusive*; see :mod:`lpbounds.studies.verify`):

* :class:`BuiltinClaim` -- one of the paper's results as
  :func:`~lpbounds.studies.verify.verify_instance` checks it (``"Lemma 1"``,
  ``"Theorem 1"``, ``"Lemma 2"``, ``"Theorem 2"``), every claim of that check for every
  solver;
* :class:`Conjecture` -- a predicate you write over a :class:`Trial` (the instance, one
  solver, exact fixed points and certified LP solves on demand), returning a verdict.

A conjecture's predicate returns one of

* a :class:`~lpbounds.certification.checks.Comparison` (from :meth:`Trial.equal` or
  :meth:`Trial.at_least`, which compare *certified intervals* as the built-in checks do:
  *violated* only when the intervals prove the claim false) -- the record then carries
  its width, deviation and intervals;
* a :class:`~lpbounds.status.Verdict`, or its word (``"holds"``, ...);
* a bool: ``True`` is *holds*, ``False`` is *violated*. A bool is taken as proof either
  way, so a predicate that compares floating-point numbers without a margin can report
  rounding as a counterexample: return a Comparison (or *inconclusive*) where the answer
  is not certain;
* any of these paired with a string, ``(verdict, "why")``, which becomes ``detail``.

A predicate is sandboxed from the run, not trusted with it: one that raises, calls
``sys.exit`` (``SystemExit``) or returns anything else (``None``, another string, an
array) gives an *error* record (:data:`~lpbounds.studies.verify.ERROR`) whose ``error``
says what happened; the other trials and instances still run, and the run's exit status
says so. Only ``KeyboardInterrupt`` goes through: Ctrl-C still stops the run. (A predicate
that ends the process itself, ``os._exit`` or a crash in C code, cannot be caught in the
process.)

Every claim has a **fingerprint** (:func:`claim_fingerprint`): a conjecture's is the
SHA-256 of its predicate's source file (or of its compiled code when it has no file), with
its description and ``uses_solver``. A campaign records them, so that records are never
reported as those of a predicate that has changed since (:mod:`lpbounds.studies.campaign`).

Conjectures are pickled to run on Dask workers: write them as module-level functions
(or lambdas, which Dask's cloudpickle carries by value).

**Rational arithmetic** (``run_claims(..., arithmetic="rational")``, ``lpbounds verify
--arithmetic rational``): a conjecture is written once and runs unchanged; the same
:class:`Trial` methods return *exact* values instead of certified floating-point ones.
An interval of float mode, ``(lo, hi)``, is then ``(x, x)`` with ``x`` a numpy array of
:class:`~fractions.Fraction` (``dtype=object``: arithmetic, indexing and comparisons work
entry by entry): :meth:`Trial.vstar` is the stored model's exact ``V*``,
:meth:`Trial.rlp_values` RLP's exact ``v*``, :meth:`Trial.rlp_bound` ``Phi v*``,
:meth:`Trial.exact` any row system's exact fixed point, and :meth:`Trial.solve` the LP's
exact optimum as its bracket (the solver still runs: its answer is judged, the record's
``inside_bracket`` and ``exact_error``; the float result is ``Solved.result``, the exact
optimum with its proof ``Solved.exact``). :meth:`Trial.equal` and :meth:`Trial.at_least`
compare exactly: *holds* or *violated* for points (an interval of your own that is not a
point keeps the interval logic, without a margin, and may be *inconclusive*), and the
record carries the exact difference (``exact_difference``). When both sides of the
returned comparison come from the Trial's methods (or are numbers the predicate
computed, written into the file as given) the record gets a certificate
(``certificates=``): the checker verifies the exact values and the comparison. A bool or
a :class:`~lpbounds.status.Verdict` the predicate returns is taken as it is (no
certificate), and ``float_verdict`` is empty: the predicate runs once, in rational
arithmetic.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..certification.checks import (
    Bracket,
    Comparison,
    compare_at_least,
    compare_equal,
    lp_bracket,
)
from ..errors import ValidationError
from ..formulations.base import LPResult
from ..rows import BellmanRows
from ..status import Verdict
from ..tolerances import LP_COMPARE_RTOL, dp_scale
from .verify import (
    EXACT_COLUMNS,
    INSTANCE_CHECKS,
    Record,
    Tally,
    VerifyInstance,
    check_arithmetic,
    error_record,
    exact_instance,
    exact_interval,
    make_record,
    try_solve,
    verify_instance,
    verify_remark2,
)

if TYPE_CHECKING:  # annotations only
    from ..exact.lp import ExactLP
    from .exact_claims import ExactInstance

__all__ = [
    "BUILTIN_CLAIMS",
    "REMARK2",
    "BuiltinClaim",
    "Claim",
    "Conjecture",
    "ExactComparison",
    "Interval",
    "Solved",
    "SplitClaims",
    "Trial",
    "claim_fingerprint",
    "claim_names",
    "load_claim",
    "resolve_claims",
    "run_claims",
    "run_remark2",
    "split_claims",
]

#: A certified interval vector: ``(lower, upper)``, one entry per state or block.
Interval = tuple[np.ndarray, np.ndarray]

#: The word of a Remark 2 claim: an existence claim, checked once per run, not per instance.
REMARK2 = "Remark 2"


class Solved(NamedTuple):
    """An LP solved by :meth:`Trial.solve`: the result (None without a point), its certified
    bracket (``(-inf, inf)`` without a point) and why there is no point (else ""); in
    rational arithmetic the bracket is the exact optimum (``lower = upper``, Fractions)
    and ``exact`` the :class:`~lpbounds.exact.lp.ExactLP` that proves it."""

    result: LPResult | None
    bracket: Bracket
    message: str
    exact: ExactLP | None = None


@dataclass(frozen=True)
class ExactComparison(Comparison):
    """A comparison decided in rational arithmetic (:meth:`Trial.equal`,
    :meth:`Trial.at_least`): a :class:`~lpbounds.certification.checks.Comparison` (its
    floats: ``width`` the widest interval, 0 for points; ``deviation`` ``|difference|``
    for ``==``, the shortfall ``max(-difference, 0)`` for ``>=``; ``accuracy`` 0) with
    the exact ``difference`` (``max |a - b|`` for ``==``, ``min (a - b)`` for ``>=``)
    and, for the certificate, each side's expression (None when a side cannot be
    written: an interval that is not a point) and the relation."""

    difference: Fraction = Fraction(0)
    left: dict[str, Any] | None = None
    right: dict[str, Any] | None = None
    relation: str = "=="


class _Exact:
    """The exact fixed points of one instance, computed once and shared by its trials
    (certified intervals; with ``exact``, an ExactInstance: rational values, each array
    registered with the certificate expression and entries it is)."""

    def __init__(
        self, inst: VerifyInstance, method: str = "mpi", exact: ExactInstance | None = None
    ) -> None:
        self.inst = inst
        self.method = method
        self.exact = exact
        self._vstar: Interval | None = None
        self._rlp: Interval | None = None
        self._bound: Interval | None = None
        #: id(array) -> (array, its certificate expression, the entries it needs)
        self.sources: dict[int, tuple[np.ndarray, dict[str, Any], list[dict[str, Any]]]] = {}

    def point(self, values: Any, expr: dict[str, Any] | None, entries: list) -> Interval:
        """``(x, x)`` of exact values (an object array of Fractions), registered."""
        x = np.array(list(values), dtype=object)
        if expr is not None:
            self.sources[id(x)] = (x, expr, entries)
        return x, x

    def vstar(self) -> Interval:
        if self._vstar is None:
            if self.exact is None:
                self._vstar = exact_interval(self.inst.mdp, self.method)
            else:
                fp = self.exact.fixed_point("ELP")
                self._vstar = self.point(fp.values, {"of": "V*"}, [fp.entry("V*")])
        return self._vstar

    def rlp(self) -> Interval:
        if self._rlp is None:
            if self.exact is None:
                rows = BellmanRows.aggregate(self.inst.mdp, self.inst.partition, reduce="max")
                self._rlp = exact_interval(rows, self.method)
            else:
                fp = self.exact.fixed_point("RLP")
                self._rlp = self.point(fp.values, {"of": "v*"}, [fp.entry("v*")])
        return self._rlp

    def bound(self) -> Interval:
        if self._bound is None:
            lo, hi = self.rlp()
            lift = self.inst.partition.lift
            if self.exact is None:
                self._bound = lift(lo), lift(hi)
            else:
                _, _, entries = self.sources[id(lo)]
                lifted = lo[self.inst.partition.labels]
                self._bound = self.point(lifted, {"of": "v*", "lift": True}, entries)
        return self._bound

    def optimum(self, form: Any, ident: str) -> tuple[ExactLP, Interval]:
        """The exact optimum of ``form``'s LP and its values as a point, registered as
        the certificate entry ``ident`` when ``form`` is an LP of this instance."""
        assert self.exact is not None
        exact = self.exact.exact_lp(form)
        whole = exact.formulation in ("ELP", "RLP", "SLP", "IB")  # the row system's variables
        values = exact.x if whole else exact.values
        if not self.exact.owns(form):
            return exact, self.point(values, None, [])
        expr: dict[str, Any] = {"of": ident}
        if not whole and len(values) != len(exact.x):
            expr["slice"] = [0, len(values)]
        return exact, self.point(values, expr, [exact.entry(ident)])


def _as_interval(x: Any) -> Interval:
    """``(lo, hi)`` from an interval pair, or a point (an array) as a zero-width interval."""
    if isinstance(x, tuple | list) and len(x) == 2 and not np.isscalar(x[0]):
        return np.asarray(x[0], dtype=np.float64), np.asarray(x[1], dtype=np.float64)
    a = np.asarray(x, dtype=np.float64)
    return a, a


@dataclass
class Trial:
    """One instance as a conjecture sees it, with one solver (None for solver-free claims).

    Attributes
    ----------
    instance : VerifyInstance
        The instance (a campaign's carries its ``family`` and ``seed``).
    solver : str or None
        The solver the trial's :meth:`solve` uses.
    rtol : float
        The requested accuracy relative to ``max|R| / (1 - lambda)``.
    tally : Tally
        The solves made through :meth:`solve` (their times and statuses go into the record).
    exact_method : str
        The method of :func:`~lpbounds.solve_exact` behind :meth:`vstar`,
        :meth:`rlp_values` and :meth:`exact` (``"mpi"``; a campaign uses ``"pi"``).
    arithmetic : {"float", "rational"}
        ``"rational"``: every method returns exact values (see the module docstring).
    """

    instance: VerifyInstance
    solver: str | None
    rtol: float = LP_COMPARE_RTOL
    tally: Tally = field(default_factory=Tally)
    exact_method: str = "mpi"
    _exact: _Exact | None = field(default=None, repr=False)
    arithmetic: str = "float"
    _solves: int = field(default=0, repr=False)

    def __post_init__(self) -> None:
        check_arithmetic(self.arithmetic)
        if self.rational and self._exact is None:
            self._exact = _Exact(self.instance, self.exact_method, exact_instance(self.instance))
        if self.rational and self.tally.judge is None:
            self.tally.judge = self.exact_instance.judge

    @property
    def rational(self) -> bool:
        """Whether the trial runs in rational arithmetic."""
        return self.arithmetic == "rational"

    @property
    def exact_instance(self) -> ExactInstance:
        """The instance in exact arithmetic behind the rational methods (its exact fixed
        points and LP optima, :class:`~lpbounds.studies.exact_claims.ExactInstance`).

        Raises
        ------
        ValidationError
            In floating point (``arithmetic="float"``).
        """
        exact = self._fixed().exact
        if exact is None:
            raise ValidationError("this Trial has no exact instance: arithmetic='rational'")
        return exact

    @property
    def mdp(self) -> Any:
        """The MDP (:class:`~lpbounds.FiniteMDP`)."""
        return self.instance.mdp

    @property
    def partition(self) -> Any:
        """The partition (:class:`~lpbounds.Partition`)."""
        return self.instance.partition

    @property
    def accuracy(self) -> float:
        """The requested accuracy in value units: ``rtol * max|R| / (1 - lambda)``."""
        return self.rtol * dp_scale(self.mdp.reward_absmax, self.mdp.discount)

    def _fixed(self) -> _Exact:
        if self._exact is None:
            self._exact = _Exact(self.instance, self.exact_method)
        return self._exact

    # ------------------------------------------------------------------ exact sides
    def vstar(self) -> Interval:
        """``V*`` per state as a certified interval (exact DP, :func:`~lpbounds.solve_exact`)."""
        return self._fixed().vstar()

    def rlp_values(self) -> Interval:
        """RLP's optimum ``v*`` per block as a certified interval (the exact fixed point of
        RLP's rows, Theorem 4: no LP solver involved)."""
        return self._fixed().rlp()

    def rlp_bound(self) -> Interval:
        """``Phi v*``: RLP's upper bound on ``V*`` per state, as a certified interval."""
        return self._fixed().bound()

    def exact(self, rows: Any) -> Interval:
        """The fixed point of any Bellman row system (``max`` over its rows) as a certified
        interval: e.g. ``trial.exact(IB(trial.mdp, trial.partition, 2).rows)``. In rational
        arithmetic its exact values (written into a certificate as the numbers they are:
        the row system is not the instance's model)."""
        if not self.rational:
            return exact_interval(rows, self.exact_method)
        from ..dp import solve_exact

        size = self.exact_instance.size_limit
        res = solve_exact(rows, arithmetic="rational", size_limit=size)
        return self._fixed().point(res.rational_values, None, [])

    # ------------------------------------------------------------------ LP side
    def solve(self, formulation: Any) -> Solved:
        """Solve ``formulation`` with the trial's solver; its certified bracket.

        The solve is counted in :attr:`tally` (the record's ``solves``, ``solve_seconds``,
        ``lp_status``, ``solver_status``). A solve that returns no point gives the bracket
        ``(-inf, inf)``, so comparisons made with it are *inconclusive*, never *violated*.
        The bracket is :func:`~lpbounds.certification.checks.lp_bracket`'s: on the exact
        optimum of an LP of Bellman rows (ELP, RLP, SLP, IB, UBLP, LBLP).

        Raises
        ------
        ValidationError
            On a solver-free trial (``solver`` is None).
        """
        if self.solver is None:
            raise ValidationError(
                "Trial.solve: this claim was declared solver-free (uses_solver=False)"
            )
        res, msg = try_solve(formulation, self.solver)
        self.tally.add(res, formulation)
        if self.rational:
            self._solves += 1
            ident = f"{formulation.name} #{self._solves} ({self.solver})"
            exact, (x, _) = self._fixed().optimum(formulation, ident)
            point = np.full(len(x), np.nan) if res is None else np.asarray(res.values)
            err = float("inf") if exact.error is None else float(exact.error)
            return Solved(res, Bracket(x, x, point, err), msg, exact)
        if res is None:
            size = int(formulation.A.shape[1])
            inf = np.full(size, np.inf)
            return Solved(None, Bracket(-inf, inf, np.full(size, np.nan), float("inf")), msg)
        return Solved(res, lp_bracket(formulation, res), "")

    # ------------------------------------------------------------------ verdicts
    def equal(self, a: Any, b: Any, accuracy: float | None = None) -> Comparison:
        """The claim ``a = b`` entry by entry, from certified intervals (``(lo, hi)`` pairs,
        or arrays for exact points): :func:`~lpbounds.certification.checks.compare_equal`
        at :attr:`accuracy` (or ``accuracy``). In rational arithmetic: exactly, without a
        margin (``accuracy`` is not used), an :class:`ExactComparison`."""
        if self.rational:
            return self._compare(a, b, "==")
        (alo, ahi), (blo, bhi) = _as_interval(a), _as_interval(b)
        return compare_equal(alo, ahi, blo, bhi, self.accuracy if accuracy is None else accuracy)

    def at_least(self, a: Any, b: Any, accuracy: float | None = None) -> Comparison:
        """The claim ``a >= b`` entry by entry, from certified intervals:
        :func:`~lpbounds.certification.checks.compare_at_least`. In rational arithmetic:
        exactly (an :class:`ExactComparison`)."""
        if self.rational:
            return self._compare(a, b, ">=")
        (alo, ahi), (blo, bhi) = _as_interval(a), _as_interval(b)
        acc = self.accuracy if accuracy is None else accuracy
        return compare_at_least(alo, ahi, blo, bhi, acc)

    def _compare(self, a: Any, b: Any, relation: str) -> ExactComparison:
        sides = [_exact_side(t, self._fixed().sources) for t in (a, b)]
        (alo, ahi, left), (blo, bhi, right) = sides
        n = max(len(alo), len(blo))
        alo, ahi, blo, bhi = (_broadcast(t, n) for t in (alo, ahi, blo, bhi))
        return exact_compare(alo, ahi, blo, bhi, relation, left, right)

    def entries(self, cmp: ExactComparison) -> list[dict[str, Any]]:
        """The certificate entries (LP optima, fixed points) both sides of ``cmp`` need."""
        out: dict[str, dict[str, Any]] = {}
        for expr in (cmp.left, cmp.right):
            for _, e, entries in self._fixed().sources.values():
                if expr is not None and e is expr:
                    out.update({x["id"]: x for x in entries})
        return list(out.values())


def _exact_side(
    x: Any, sources: dict[int, tuple[np.ndarray, dict[str, Any], list]]
) -> tuple[list[Fraction], list[Fraction], dict[str, Any] | None]:
    """``(lo, hi, expression)`` of one side of an exact comparison: an interval pair or a
    point (arrays, numbers; doubles taken exactly), its certificate expression when it is
    a Trial's value (registered), numbers stated as given when it is a point, else None."""
    if isinstance(x, tuple | list) and len(x) == 2 and not np.isscalar(x[0]):
        lo_arr, hi_arr = x
    else:
        lo_arr = hi_arr = x
    lo, hi = _fractions(lo_arr), _fractions(hi_arr)
    found = sources.get(id(lo_arr))
    if found is not None and found[0] is lo_arr and (hi_arr is lo_arr or lo == hi):
        return lo, hi, found[1]
    if lo != hi:
        return lo, hi, None
    from ..exact.rationals import RationalVector

    return lo, hi, {"vector": RationalVector.from_fractions(lo).to_json()}


def _fractions(x: Any) -> list[Fraction]:
    """Exact entries of an array or number (a double is the dyadic rational it is)."""
    from ..exact.rationals import rational

    arr = np.asarray(x, dtype=object).ravel()
    return [rational(t) for t in arr]


def _broadcast(x: list[Fraction], n: int) -> list[Fraction]:
    if len(x) == n:
        return x
    if len(x) == 1:
        return x * n
    raise ValidationError(f"cannot compare {len(x)} entries with {n}")


def exact_compare(
    a_lo: list[Fraction],
    a_hi: list[Fraction],
    b_lo: list[Fraction],
    b_hi: list[Fraction],
    relation: str,
    left: dict[str, Any] | None = None,
    right: dict[str, Any] | None = None,
) -> ExactComparison:
    """The claim ``a == b`` or ``a >= b`` (``relation``) between exact intervals, entry by
    entry, without a margin: for points (``lo == hi``) *holds* or *violated* by the exact
    difference (``max |a - b|``, ``min (a - b)``); for wider intervals *violated* when
    they prove it false (disjoint; ``a_hi < b_lo``), *holds* when they prove it (all four
    ends equal; ``a_lo >= b_hi``), else *inconclusive*. The deciding ``index``: the most
    separated entry (the largest difference of ``==``, the smallest of ``>=``)."""
    ends = list(zip(a_lo, a_hi, b_lo, b_hi, strict=True))
    if relation == "==":
        sep = [max(al - bh, bl - ah) for al, ah, bl, bh in ends]
        idx = max(range(len(sep)), key=sep.__getitem__, default=0)
        diff = sep[idx] if sep else Fraction(0)
        proven = all(al == ah == bl == bh for al, ah, bl, bh in ends)
        disproven = diff > 0
        dev = abs(diff)
    elif relation == ">=":
        gap = [al - bh for al, _, _, bh in ends]
        idx = min(range(len(gap)), key=gap.__getitem__, default=0)
        diff = gap[idx] if gap else Fraction(0)
        proven = diff >= 0
        disproven = any(ah < bl for _, ah, bl, _ in ends)
        dev = max(-diff, Fraction(0))  # as compare_at_least: the shortfall
    else:
        raise ValidationError(f"relation must be '==' or '>='; got {relation!r}")
    verdict = Verdict.HOLDS if proven else Verdict.VIOLATED if disproven else Verdict.INCONCLUSIVE
    width = max((max(ah - al, bh - bl) for al, ah, bl, bh in ends), default=Fraction(0))
    a_iv, b_iv = (0.0, 0.0), (0.0, 0.0)
    if ends:
        al, ah, bl, bh = ends[idx]
        a_iv, b_iv = (float(al), float(ah)), (float(bl), float(bh))
    return ExactComparison(
        verdict, float(width), float(dev), 0.0, int(idx), a_iv, b_iv,
        difference=diff, left=left, right=right, relation=relation,
    )  # fmt: skip


# ---------------------------------------------------------------------- the claims
@dataclass(frozen=True)
class BuiltinClaim:
    """One of the paper's results as :func:`~lpbounds.studies.verify.verify_instance`
    checks it: ``check`` is ``"Lemma 1"``, ``"Theorem 1"``, ``"Lemma 2"`` or ``"Theorem 2"``
    (:data:`~lpbounds.studies.verify.INSTANCE_CHECKS`), or ``"Remark 2"`` (an existence
    claim: run once per campaign, not per instance)."""

    check: str

    @property
    def name(self) -> str:
        """The check's name."""
        return self.check


Predicate = Callable[[Trial], Any]


@dataclass(frozen=True)
class Conjecture:
    """A claim of your own: a predicate over a :class:`Trial`.

    Parameters
    ----------
    name : str
        The record's ``check`` (e.g. ``"RLP bound = V*"``).
    predicate : callable(Trial) -> Comparison, Verdict, str or bool
        See the module docstring for what it may return.
    description : str
        The record's ``claim`` (default: the name).
    uses_solver : bool
        True (default): the predicate is called once per solver of the campaign
        (``trial.solver``); False: once per instance, with ``trial.solver`` None (records
        with solver "exact").
    """

    name: str
    predicate: Predicate
    description: str = ""
    uses_solver: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValidationError(f"conjecture name must be a non-empty string; got {self.name!r}")
        if not callable(self.predicate):
            raise ValidationError(
                f"conjecture {self.name!r}: predicate must be callable; got {self.predicate!r}"
            )


Claim = BuiltinClaim | Conjecture

#: The built-in claims by name, in the order of :data:`INSTANCE_CHECKS`, then Remark 2.
BUILTIN_CLAIMS: dict[str, BuiltinClaim] = {c: BuiltinClaim(c) for c in (*INSTANCE_CHECKS, REMARK2)}


def _key(text: str) -> str:
    return re.sub(r"[\s_\-]+", "", text.lower())


def claim_names(claims: Iterable[Claim]) -> list[str]:
    """The names of ``claims`` (a check's, or a conjecture's ``name``), in order."""
    return [c.name for c in claims]


def _predicate_source(predicate: Any) -> tuple[str, bytes]:
    """Where a predicate's code is and its bytes: its source file (the whole file: the
    predicate may call helpers defined beside it), else its compiled code."""
    import functools
    import inspect
    import marshal

    target = predicate.func if isinstance(predicate, functools.partial) else predicate
    target = inspect.unwrap(target)
    holder = target if inspect.isfunction(target) or inspect.ismethod(target) else type(target)
    try:
        path = inspect.getsourcefile(holder)
    except TypeError:  # a builtin or a C function: no source
        path = None
    if path:
        try:
            with open(path, "rb") as fh:
                return path, fh.read()
        except OSError:
            pass
    call = type(target).__call__ if callable(target) else None
    code = getattr(target, "__code__", None) or getattr(call, "__code__", None)
    if code is not None:
        return f"<compiled code of {getattr(target, '__qualname__', type(target).__name__)}>", (
            marshal.dumps(code)
        )
    return f"<{type(target).__name__} object: no source>", repr(target).encode()


def claim_fingerprint(claim: Claim) -> dict[str, Any]:
    """What a claim's records depend on besides lpbounds itself (whose version a campaign
    records apart).

    Returns
    -------
    dict
        A built-in claim: ``{"kind": "built in"}``. A conjecture: ``{"kind":
        "conjecture", "source": its file, "sha256": that file's SHA-256, "description":
        ..., "uses_solver": ...}`` (``source`` names the compiled code when the predicate
        has no source file). Two fingerprints are equal when the records would be.
    """
    import hashlib

    if isinstance(claim, BuiltinClaim):
        return {"kind": "built in"}
    where, data = _predicate_source(claim.predicate)
    return {
        "kind": "conjecture",
        "source": where,
        "sha256": hashlib.sha256(data).hexdigest(),
        "description": claim.description,
        "uses_solver": bool(claim.uses_solver),
    }


def load_claim(spec: str) -> Claim:
    """A claim named on a command line: a built-in claim's name, or ``FILE.py:NAME`` /
    ``package.module:NAME`` naming a :class:`Conjecture` or a predicate in a file or an
    importable module (a predicate becomes a Conjecture called ``NAME``).

    A file's module is registered with cloudpickle (when installed) to be pickled by
    value, so that its conjectures also run on Dask workers that cannot import it.

    Raises
    ------
    ValidationError
        An unknown claim name, a missing file or module, or no such ``NAME`` in it.
    """
    if ":" not in spec:
        return resolve_claims([spec])[0]
    where, _, name = spec.rpartition(":")
    module = _load_module(where, spec)
    obj = getattr(module, name, None)
    if obj is None:
        raise ValidationError(f"claims: {spec!r}: {where!r} defines no {name!r}")
    if isinstance(obj, BuiltinClaim | Conjecture):
        return obj
    if callable(obj):
        return Conjecture(name, obj)
    raise ValidationError(f"claims: {spec!r} is neither a Conjecture nor a callable")


def _load_module(where: str, spec: str) -> Any:
    import importlib
    import importlib.util
    import sys
    from pathlib import Path

    if not where.endswith(".py"):
        try:
            return importlib.import_module(where)
        except ImportError as exc:
            raise ValidationError(f"claims: {spec!r}: cannot import {where!r} ({exc})") from None
    path = Path(where)
    if not path.is_file():
        raise ValidationError(f"claims: {spec!r}: no file {where!r}")
    mod_name = "lpbounds_claims_" + re.sub(r"\W", "_", str(path.resolve()))
    loader = importlib.util.spec_from_file_location(mod_name, path)
    assert loader is not None and loader.loader is not None
    module = importlib.util.module_from_spec(loader)
    sys.modules[mod_name] = module
    try:
        loader.loader.exec_module(module)
    except Exception as exc:  # the user's file: its error, named, as bad input
        del sys.modules[mod_name]
        raise ValidationError(
            f"claims: {spec!r}: running {where!r} raised {type(exc).__name__}: {exc}"
        ) from exc
    try:
        import cloudpickle

        cloudpickle.register_pickle_by_value(module)
    except (ImportError, ValueError):  # without cloudpickle: local runs need no pickling
        pass
    return module


def resolve_claims(claims: Iterable[str | Claim | Predicate] | None) -> list[Claim]:
    """Claims from names, claims and bare predicates (default: every built-in claim).

    A name is a built-in check, written as the paper does or without spaces and case
    (``"Theorem 1"``, ``"theorem1"``, ``"lemma-2"``); a bare callable becomes a
    :class:`Conjecture` named after the function.

    Raises
    ------
    ValidationError
        An unknown name (the message lists the known ones), two claims of one name, or an
        empty list.
    """
    if claims is None:
        return list(BUILTIN_CLAIMS.values())
    by_key = {_key(k): v for k, v in BUILTIN_CLAIMS.items()}
    out: list[Claim] = []
    for item in claims:
        if isinstance(item, BuiltinClaim | Conjecture):
            out.append(item)
        elif isinstance(item, str):
            found = by_key.get(_key(item))
            if found is None:
                raise ValidationError(
                    f"claims: unknown claim {item!r}; built in: {', '.join(BUILTIN_CLAIMS)} "
                    "(or give a Conjecture)"
                )
            out.append(found)
        elif callable(item):
            out.append(Conjecture(getattr(item, "__name__", "conjecture"), item))
        else:
            raise ValidationError(f"claims: {item!r} is neither a claim name nor a Conjecture")
    names = claim_names(out)
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup is not None:
        raise ValidationError(f"claims: {dup!r} is given twice")
    if not out:
        raise ValidationError("claims: no claim to check")
    return out


# ---------------------------------------------------------------------- running them
class SplitClaims(NamedTuple):
    """Claims by how they run: the built-in checks of one instance (names of
    :data:`INSTANCE_CHECKS`), the conjectures, and whether Remark 2 is among them."""

    checks: list[str]
    conjectures: list[Conjecture]
    remark2: bool


def split_claims(claims: Iterable[Claim]) -> SplitClaims:
    """``claims`` split by how they run (:class:`SplitClaims`), each kind in its order."""
    items = list(claims)
    builtin = [c.check for c in items if isinstance(c, BuiltinClaim)]
    return SplitClaims(
        [c for c in builtin if c != REMARK2],
        [c for c in items if isinstance(c, Conjecture)],
        REMARK2 in builtin,
    )


def _verdict_of(outcome: Any, name: str, accuracy: float) -> tuple[Comparison, str]:
    """A predicate's outcome as a Comparison and a detail string (ValidationError: not a
    verdict)."""
    detail = ""
    if isinstance(outcome, tuple) and len(outcome) == 2 and isinstance(outcome[1], str):
        outcome, detail = outcome
    if isinstance(outcome, Comparison) and isinstance(outcome.verdict, Verdict):
        return outcome, detail
    if isinstance(outcome, bool | np.bool_):
        verdict = Verdict.HOLDS if bool(outcome) else Verdict.VIOLATED
    elif isinstance(outcome, Verdict):
        verdict = outcome
    elif isinstance(outcome, str) and outcome in {v.value for v in Verdict}:
        verdict = Verdict(outcome)
    else:
        shown = repr(outcome)
        shown = shown if len(shown) <= 80 else shown[:77] + "..."
        raise ValidationError(
            f"conjecture {name!r} returned {shown}, not a verdict: return a Comparison "
            "(Trial.equal, Trial.at_least), a Verdict, 'holds'/'violated'/'inconclusive' or "
            "a bool"
        )
    nan = float("nan")
    return Comparison(verdict, nan, nan, accuracy, 0, (nan, nan), (nan, nan)), detail


def _conjecture_record(
    conj: Conjecture, trial: Trial, certificates: str | Path | None = None
) -> Record:
    """Call the predicate on one trial, sandboxed: its record, or an *error* record when
    it raised, called ``sys.exit`` or returned no verdict (KeyboardInterrupt goes through).
    In rational arithmetic the record has :data:`~lpbounds.studies.verify.EXACT_COLUMNS`
    and, with ``certificates``, the certificate of an exact comparison is written there."""
    head = (conj.name, conj.description or conj.name, trial.instance.name, trial.solver or "exact")
    t0 = time.perf_counter()
    try:
        outcome = conj.predicate(trial)
    except SystemExit as exc:  # sys.exit in a predicate ends the trial, not the run
        error = f"SystemExit: the predicate called sys.exit({exc.code!r})"
        record = error_record(*head, error, "the predicate called sys.exit", trial.tally)
        return _with_exact(record, trial, None, "")
    except Exception as exc:  # a crash of the predicate (or of what it calls) is a finding
        error = f"{type(exc).__name__}: {exc}"
        record = error_record(*head, error, "the predicate raised an exception", trial.tally)
        return _with_exact(record, trial, None, "")
    try:
        cmp, detail = _verdict_of(outcome, conj.name, trial.accuracy)
    except ValidationError as exc:
        record = error_record(*head, str(exc), "the predicate returned no verdict", trial.tally)
        return _with_exact(record, trial, None, "")
    record = {**make_record(*head, cmp, detail, trial.tally), "error": ""}
    name = ""
    if trial.rational and certificates is not None and isinstance(cmp, ExactComparison):
        name = _write_certificate(conj, trial, cmp, certificates, t0)
    return _with_exact(record, trial, cmp, name, time.perf_counter() - t0)


def _with_exact(
    record: Record, trial: Trial, cmp: Comparison | None, certificate: str, seconds: float = 0.0
) -> Record:
    """A conjecture's record with the exact columns (rational arithmetic only): no float
    verdict (the predicate ran once, exactly), the exact difference of an exact comparison,
    the judged solves' ``inside_bracket`` and ``exact_error``, the certificate's name."""
    if not trial.rational:
        return record
    extra = {k: record.get(k) for k in EXACT_COLUMNS}
    extra.update(float_verdict="", exact_seconds=seconds, certificate=certificate)
    if isinstance(cmp, ExactComparison):
        from ..exact.rationals import fraction_text

        extra.update(
            exact_difference=fraction_text(cmp.difference),
            exact_difference_float=float(cmp.difference),
        )
    return {**{k: v for k, v in record.items() if k not in EXACT_COLUMNS}, **extra}


def _write_certificate(
    conj: Conjecture, trial: Trial, cmp: ExactComparison, folder: str | Path, t0: float
) -> str:
    """The certificate of a conjecture's exact comparison (both sides written), its file
    name ("" when a side cannot be written: an interval that is not a point)."""
    from ..errors import ConsistencyError
    from .exact_claims import comparison, exact_verdict, write_certificates

    if cmp.left is None or cmp.right is None:
        return ""
    exact = trial.exact_instance
    entries = trial.entries(cmp)
    lps = [e for e in entries if "lp" in e]
    fixed = [e for e in entries if "lp" not in e]
    text = conj.description or conj.name
    check = conj.name if trial.solver is None else f"{conj.name} ({trial.solver})"
    comps = [comparison(text, cmp.left, cmp.right, cmp.relation)]
    verdict = exact_verdict(check, text, trial.instance.name, exact.model, lps, fixed, comps, t0)
    if verdict.verdict is not cmp.verdict:
        raise ConsistencyError(
            f"conjecture {conj.name!r}: the certificate says {verdict.verdict}, the comparison "
            f"{cmp.verdict}"
        )
    return write_certificates([verdict], folder)[0].name


def run_claims(
    inst: VerifyInstance,
    claims: Sequence[Claim],
    solvers: Sequence[str],
    *,
    n_costs: int = 3,
    seed: int = 0,
    rtol: float = LP_COMPARE_RTOL,
    exact_method: str = "mpi",
    arithmetic: str = "float",
    exact_size_limit: int | None = None,
    certificates: str | Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[Record]:
    """Every claim of ``claims`` on one instance, for each solver: the records.

    The built-in checks run together in one :func:`~lpbounds.studies.verify.verify_instance`
    call (they share the exact fixed points and the RLP solves), then each conjecture for
    each solver (once, solver "exact", when it does not use one). Remark 2 is not checked
    here (it does not depend on the instance; see :func:`run_remark2`). Every record has an
    ``error`` key ("" unless a predicate raised).

    Parameters
    ----------
    inst : VerifyInstance
    claims : sequence of BuiltinClaim or Conjecture
    solvers : sequence of str
    n_costs, seed, rtol, exact_method
        As for :func:`~lpbounds.studies.verify.verify_instance` (``seed`` seeds its costs;
        ``exact_method`` also serves the conjectures' :class:`Trial`).
    arithmetic, exact_size_limit, certificates
        As for :func:`~lpbounds.studies.verify.verify_instance`; ``"rational"`` also gives
        the conjectures exact values (see the module docstring), all sharing one
        :func:`~lpbounds.studies.verify.exact_instance`.
    progress : callable(str), optional
        Called as each piece of exact work starts and before each solver's checks.

    Returns
    -------
    list of dict

    Raises
    ------
    SizeLimitError
        ``"rational"``: above ``exact_size_limit`` (before any LP is solved).
    """
    check_arithmetic(arithmetic)
    checks, conjectures, _ = split_claims(claims)
    ex = None
    if arithmetic == "rational":
        ex = exact_instance(inst, n_costs, seed, size_limit=exact_size_limit, progress=progress)
    records: list[Record] = []
    if checks:
        found = verify_instance(
            inst,
            solvers,
            n_costs=n_costs,
            seed=seed,
            rtol=rtol,
            checks=checks,
            exact_method=exact_method,
            arithmetic=arithmetic,
            certificates=certificates,
            exact=ex,
            progress=progress,
        )
        records += [{**r, "error": ""} for r in found]
    exact = _Exact(inst, exact_method, ex)
    for conj in conjectures:
        for solver in list(solvers) if conj.uses_solver else [None]:
            trial = Trial(
                inst, solver, rtol, exact_method=exact_method, _exact=exact, arithmetic=arithmetic
            )
            records.append(_conjecture_record(conj, trial, certificates))
    return records


def run_remark2(
    claims: Sequence[Claim],
    solvers: Sequence[str],
    *,
    seed: int = 0,
    rtol: float = LP_COMPARE_RTOL,
    arithmetic: str = "float",
    exact_size_limit: int | None = None,
    certificates: str | Path | None = None,
) -> list[Record]:
    """Remark 2's records (:func:`~lpbounds.studies.verify.verify_remark2`) when ``claims``
    has it, else none."""
    if not split_claims(claims).remark2:
        return []
    found = verify_remark2(
        solvers, seed=seed, rtol=rtol, arithmetic=arithmetic,
        exact_size_limit=exact_size_limit, certificates=certificates,
    )  # fmt: skip
    return [{**r, "error": ""} for r in found]
