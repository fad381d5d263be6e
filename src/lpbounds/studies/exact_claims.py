r"""Exact verdicts: the paper's claims decided in rational arithmetic on one instance.

:class:`ExactInstance` holds one instance (an MDP, a partition, the costs and LLP's surplus
costs of a verification run) and decides each built-in claim *exactly*
(:meth:`ExactInstance.decide`): holds or violated, never inconclusive, with the exact size
of the difference and a certificate that :mod:`lpbounds.exact.check` verifies with the
standard library alone (:mod:`lpbounds.exact.files`). Every exact LP optimum it uses is
proved by an exact primal and dual (:mod:`lpbounds.exact.lp`), every fixed point checked
as one. :meth:`ExactInstance.judge` says, for a float solve of one of the instance's LPs by
any solver, whether its certified bracket held and its exact error.

The claims (the exact counterparts of :mod:`lpbounds.studies.verify`'s records):

* **Lemma 1** -- ``V*`` (the fixed point of the exact rows) is an optimum of ELP for every
  cost (and the unique one where the dual proves it), and ``Phi v* >= V*`` (RLP's bound
  dominates ``V*``). Difference: ``min (Phi v* - V*)``.
* **Theorem 1** -- RLP's optimum for every cost is the same ``v*`` (the fixed point of its
  rows). Difference: ``max_k max |x_k - v*|`` (0).
* **Lemma 2** -- with ``mu-bar`` RLP's exact optimal dual (its policy's occupation measure
  over the pairs), ``SLP(mu-bar)`` has the optimum ``v*``. Difference: ``max |SLP(mu-bar)
  - v*|``.
* **Theorem 2** -- every block of IB's optimum (``L`` in ``ib_blocks``) is ``v*``, and LLP's
  optimal ``v`` dominates ``v*`` for each ``d``. Difference: the first comparison's.
* **Remark 2** (:func:`decide_remark2`) -- on a soft-aggregation ALP, ``OPT(c1 + c2) >
  OPT(c1) + OPT(c2)``, which no cost-independent optimum allows. Difference: ``OPT(c1 +
  c2) - OPT(c1) - OPT(c2)``.

Every comparison of a claim is in its certificate (``claim.comparisons``), each with its
own difference; the verdict holds when all hold.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ValidationError
from ..exact.files import certificate, mdp_data, write_certificate
from ..exact.fixed_point import ExactFixedPoint, least_fixed_point
from ..exact.lp import ExactLP, bellman_lp, certify_optimum, ib_lp, llp_lp, simplex_lp
from ..exact.rationals import RationalVector, fraction_text
from ..exact.system import ExactRows
from ..formulations.base import Formulation, LPResult
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from ..status import Verdict

__all__ = [
    "EXACT_CHECKS",
    "ExactInstance",
    "ExactJudge",
    "ExactVerdict",
    "SolverJudgement",
    "certificate_name",
    "comparison",
    "decide_remark2",
    "exact_verdict",
    "write_certificates",
]

#: The instance claims :meth:`ExactInstance.decide` decides (Remark 2: :func:`decide_remark2`).
EXACT_CHECKS: tuple[str, ...] = ("Lemma 1", "Theorem 1", "Lemma 2", "Theorem 2")

Progress = Callable[[str], None]


@dataclass(repr=False)
class ExactVerdict:
    """A claim decided exactly on one instance.

    Attributes
    ----------
    check : str
        The paper's result ("Lemma 1", ...).
    claim : str
        What was compared.
    instance : str
    verdict : Verdict
        ``HOLDS`` or ``VIOLATED`` (never inconclusive).
    difference : Fraction
        The exact size of the first comparison's difference (``max |left - right|`` for an
        equality, ``min (left - right)`` for an inequality: negative when violated).
    differences : dict of str to Fraction
        Every comparison's.
    certificate : dict
        The self-contained certificate (already verified by the checker).
    seconds : float
    """

    check: str
    claim: str
    instance: str
    verdict: Verdict
    difference: Fraction
    differences: dict[str, Fraction]
    certificate: dict[str, Any]
    seconds: float

    def __repr__(self) -> str:
        return (
            f"ExactVerdict({self.check}: {self.claim} on {self.instance}: {self.verdict}, "
            f"difference {float(self.difference):.6g})"
        )

    def record(self) -> dict[str, Any]:
        """A flat record (JSON-ready): the verdict, the difference exactly and as a float."""
        return {
            "check": self.check,
            "claim": self.claim,
            "instance": self.instance,
            "solver": "exact",
            "verdict": self.verdict.value,
            "difference": fraction_text(self.difference),
            "difference_float": float(self.difference),
            "comparisons": len(self.differences),
            "seconds": self.seconds,
        }


@dataclass(repr=False)
class SolverJudgement:
    """A float solve judged against the exact optimum of its LP.

    Attributes
    ----------
    formulation, solver : str
    status : str
        The float result's status.
    inside_bracket : bool or None
        Whether its certified bracket contained the exact quantity it is about (``None``:
        it has no bracket).
    error : Fraction or None
        ``max |values - exact values|``.
    objective_error : Fraction or None
        ``|objective - exact objective|``.
    exact : ExactLP
        The exact optimum (judged copy).
    """

    formulation: str
    solver: str
    status: str
    inside_bracket: bool | None
    error: Fraction | None
    objective_error: Fraction | None
    exact: ExactLP

    def __repr__(self) -> str:
        err = "none" if self.error is None else f"{float(self.error):.3e}"
        return (
            f"SolverJudgement({self.formulation} with {self.solver}: inside bracket "
            f"{self.inside_bracket}, exact error {err})"
        )

    def record(self) -> dict[str, Any]:
        """A flat record (JSON-ready)."""

        def text(x: Fraction | None) -> str | None:
            return None if x is None else fraction_text(x)

        return {
            "formulation": self.formulation,
            "solver": self.solver,
            "status": self.status,
            "inside_bracket": self.inside_bracket,
            "exact_error": text(self.error),
            "exact_error_float": None if self.error is None else float(self.error),
            "objective_error": text(self.objective_error),
        }


def _hex(values: Any) -> list[str]:
    return [float(t).hex() for t in np.asarray(values, dtype=np.float64).ravel()]


def _spec_key(spec: dict[str, Any]) -> str:
    return json.dumps(spec, sort_keys=True)


def _without_partition(model: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in model.items() if k != "partition"}


class ExactJudge:
    """Judges float solves against exact optima, each LP's computed once (by its spec).

    Parameters
    ----------
    size_limit : int, optional
        As for :class:`ExactInstance`.
    route : callable(form, spec) -> ExactLP or None, optional
        Where an LP's exact optimum can be had more cheaply (an instance's fixed points);
        None falls back to ``form.exact_optimum()``.
    """

    def __init__(
        self,
        size_limit: int | None = None,
        route: Callable[[Formulation, dict[str, Any]], ExactLP | None] | None = None,
    ) -> None:
        self.size_limit = size_limit
        self.route = route
        self._cache: dict[str, ExactLP] = {}

    def exact(self, form: Formulation) -> ExactLP:
        """The exact optimum of ``form``'s LP (computed once per LP)."""
        if not hasattr(form, "exact_lp"):
            return form.exact_optimum(size_limit=self.size_limit)
        _, spec = form.exact_lp()
        key = _spec_key(spec)
        if key not in self._cache:
            found = None if self.route is None else self.route(form, spec)
            self._cache[key] = found or form.exact_optimum(size_limit=self.size_limit)
        return self._cache[key]

    def __call__(self, form: Formulation, result: LPResult) -> SolverJudgement:
        """``result`` (a float solve of ``form``) judged: whether its certified bracket
        held, and its exact error."""
        judged = form.judge_exact(self.exact(form), result, size_limit=self.size_limit)
        return SolverJudgement(
            form.name,
            result.solver,
            str(result.status),
            judged.inside_bracket,
            judged.error,
            judged.objective_error,
            judged,
        )


class ExactInstance:
    """One instance of a verification run, in exact arithmetic.

    Parameters
    ----------
    name : str
    mdp : FiniteMDP
    partition : Partition
    costs : sequence of array_like (n_states,)
        The state costs ``c_k >= 0`` of the run (ELP's costs; RLP's are ``c-bar_k``, summed
        per partition in floating point as :class:`~lpbounds.formulations.RLP` does).
    d_list : sequence of array_like (n_states, n_actions)
        LLP's surplus costs.
    ib_blocks : sequence of int
        IB's block counts (Theorem 2).
    size_limit : int, optional
        The most variables an exact solve solves together (default
        :data:`~lpbounds.tolerances.EXACT_MAX_VARIABLES`), checked before each exact solve.
    progress : callable(str), optional
        Called as each exact piece starts.

    Raises
    ------
    SizeLimitError
        From an exact solve above ``size_limit`` (before it starts).
    """

    def __init__(
        self,
        name: str,
        mdp: FiniteMDP,
        partition: Partition,
        *,
        costs: Sequence[Any],
        d_list: Sequence[Any] = (),
        ib_blocks: Sequence[int] = (1, 2, 3, 4, 5),
        size_limit: int | None = None,
        progress: Progress | None = None,
    ) -> None:
        if partition.n_states != mdp.n_states:
            raise ValidationError(
                f"the partition has {partition.n_states} states but the MDP has {mdp.n_states}"
            )
        if not costs:
            raise ValidationError("costs: at least one cost is needed")
        self.name, self.mdp, self.partition = name, mdp, partition
        self.costs = [np.asarray(c, dtype=np.float64) for c in costs]
        self.d_list = [np.asarray(d, dtype=np.float64) for d in d_list]
        self.ib_blocks = tuple(int(L) for L in ib_blocks)
        self.size_limit = size_limit
        self.progress = progress
        self.model = mdp_data(mdp, partition)
        self._cache: dict[str, ExactLP] = {}
        self._fixed: dict[str, ExactFixedPoint] = {}
        self._judge = ExactJudge(size_limit, self._route)

    # ------------------------------------------------------------------ exact pieces
    def _say(self, what: str) -> None:
        if self.progress is not None:
            self.progress(f"{self.name}: exact {what}")

    def fixed_point(self, rows: str) -> ExactFixedPoint:
        """The exact least fixed point of the ``"ELP"`` rows (``V*``) or the ``"RLP"`` rows
        (``v*``), computed once."""
        if rows not in self._fixed:
            self._say("V*" if rows == "ELP" else "v*")
            er = ExactRows.build(self.model, {"rows": rows})
            self._fixed[rows] = least_fixed_point(
                er, size_limit=self.size_limit, what=f"{self.name}'s {rows} rows"
            )
        return self._fixed[rows]

    def cbar(self, k: int) -> np.ndarray:
        """``c-bar_k``: cost ``k`` summed per partition (as RLP sums it, in floating point)."""
        return np.bincount(
            self.partition.labels, weights=self.costs[k], minlength=self.partition.n_partitions
        )

    def spec(self, formulation: str, k: int = 0, **extra: Any) -> dict[str, Any]:
        """The certificate's LP spec of one of the instance's LPs (as the formulation's
        ``exact_lp()`` gives it): ``"ELP"``, ``"RLP"``, ``"IB"`` (``L=``), ``"LLP"``
        (``j=``: the surplus cost)."""
        if formulation == "ELP":
            return {"formulation": "ELP", "cost": _hex(self.costs[k])}
        cbar = self.cbar(k)
        if formulation == "RLP":
            return {"formulation": "RLP", "cost": _hex(cbar)}
        if formulation == "IB":
            return {
                "formulation": "IB",
                "L": int(extra["L"]),
                "cost": _hex(np.tile(cbar, extra["L"])),
            }
        if formulation == "LLP":
            d = self.d_list[int(extra["j"])]
            return {"formulation": "LLP", "cost": _hex(cbar), "d": _hex(d[self.mdp.allowed])}
        raise ValidationError(f"no spec for {formulation!r}")

    def optimum(self, spec: dict[str, Any]) -> ExactLP:
        """The exact optimum of the LP ``spec`` (computed once per spec)."""
        key = _spec_key(spec)
        if key in self._cache:
            return self._cache[key]
        kind = spec["formulation"]
        self._say(f"{kind} optimum")
        if kind in ("ELP", "RLP"):
            fp = self.fixed_point(kind)
            out = bellman_lp(self.model, spec, fixed_point=fp, size_limit=self.size_limit)
        elif kind == "IB":
            out = ib_lp(
                self.model,
                spec["L"],
                spec["cost"],
                rlp=self.fixed_point("RLP"),
                size_limit=self.size_limit,
            )
        elif kind == "LLP":
            out = llp_lp(
                self.model,
                spec["cost"],
                spec["d"],
                rlp=self.fixed_point("RLP"),
                size_limit=self.size_limit,
            )
        elif kind == "SLP":
            out = bellman_lp(self.model, spec, fixed_point=None, size_limit=self.size_limit)
        else:
            raise ValidationError(f"no exact route for {kind!r} on an instance")
        self._cache[key] = out
        return out

    def slp_mu_bar(self) -> ExactLP:
        """``SLP(mu-bar)`` with RLP's exact optimal dual (cost 0's), its optimum proved by
        the surrogate dual ``y = 1`` on every row (scaled by ``mu-bar``'s denominator)."""
        rlp = self.optimum(self.spec("RLP", 0))
        assert rlp.y is not None
        spec = {"formulation": "SLP", "cost": rlp.spec["cost"], "mu": rlp.y.to_json()}
        key = _spec_key(spec)
        if key not in self._cache:
            self._say("SLP(mu-bar) optimum")
            t0 = time.perf_counter()
            rows = ExactRows.build(self.model, spec)
            y = RationalVector([1] * rows.n_rows, rlp.y.denominator)
            self._cache[key] = certify_optimum("SLP", rows, rlp.x, y, "surrogate dual", t0)
        return self._cache[key]

    # ------------------------------------------------------------------ judging solvers
    def judge(self, form: Formulation, result: LPResult) -> SolverJudgement:
        """A float solve of ``form`` (an LP of this instance, or any formulation with an
        exact route) judged against its exact optimum (computed once per LP; the
        instance's own LPs from its exact fixed points)."""
        return self._judge(form, result)

    def exact_lp(self, form: Formulation) -> ExactLP:
        """The exact optimum of ``form``'s LP (computed once per LP; this instance's own
        LPs from its exact fixed points)."""
        return self._judge.exact(form)

    def owns(self, form: Formulation) -> bool:
        """Whether ``form``'s exact LP is built on this instance's model (so that it can
        stand in this instance's certificates)."""
        if not hasattr(form, "exact_lp"):
            return False
        model, _ = form.exact_lp()
        return bool(model == self.model or model == _without_partition(self.model))

    def _route(self, form: Formulation, spec: dict[str, Any]) -> ExactLP | None:
        """The exact optimum of ``form``'s LP from this instance's fixed points when it is
        one of its LPs (ELP, RLP, IB, LLP, SLP on its model), else None."""
        if spec.get("formulation") not in ("ELP", "RLP", "IB", "LLP", "SLP"):
            return None
        return self.optimum(spec) if self.owns(form) else None

    # ------------------------------------------------------------------ the claims
    def decide(self, checks: Iterable[str] | None = None) -> list[ExactVerdict]:
        """Decide the claims ``checks`` (default :data:`EXACT_CHECKS`), in that order."""
        chosen = EXACT_CHECKS if checks is None else tuple(checks)
        unknown = [c for c in chosen if c not in EXACT_CHECKS]
        if unknown:
            raise ValidationError(
                f"checks: unknown check {unknown[0]!r}; known: {', '.join(EXACT_CHECKS)}"
            )
        table = {
            "Lemma 1": self._lemma1,
            "Theorem 1": self._theorem1,
            "Lemma 2": self._lemma2,
            "Theorem 2": self._theorem2,
        }
        return [table[c]() for c in EXACT_CHECKS if c in chosen]

    def _verdict(
        self,
        check: str,
        claim: str,
        lps: list[tuple[str, ExactLP]],
        fixed: list[str],
        comparisons: list[dict[str, Any]],
        t0: float,
    ) -> ExactVerdict:
        entries = [lp.entry(ident) for ident, lp in lps]
        fps = [self.fixed_point(r).entry("V*" if r == "ELP" else "v*") for r in fixed]
        return exact_verdict(check, claim, self.name, self.model, entries, fps, comparisons, t0)

    def _lemma1(self) -> ExactVerdict:
        t0 = time.perf_counter()
        lps = [(f"ELP c{k + 1}", self.optimum(self.spec("ELP", k))) for k in range(len(self.costs))]
        comps = [
            comparison(f"ELP c{k + 1} optimum = V*", {"of": ident}, {"of": "V*"}, "==")
            for k, (ident, _) in enumerate(lps)
        ]
        comps.append(comparison("Phi v* >= V*", {"of": "v*", "lift": True}, {"of": "V*"}, ">="))
        return self._verdict(
            "Lemma 1", "ELP optimum = V*; Phi v* >= V*", lps, ["ELP", "RLP"], comps, t0
        )

    def _theorem1(self) -> ExactVerdict:
        t0 = time.perf_counter()
        lps = [(f"RLP c{k + 1}", self.optimum(self.spec("RLP", k))) for k in range(len(self.costs))]
        comps = [
            comparison(f"RLP c{k + 1} optimum = v*", {"of": ident}, {"of": "v*"}, "==")
            for k, (ident, _) in enumerate(lps)
        ]
        return self._verdict(
            "Theorem 1", "RLP optimum = v* for every cost", lps, ["RLP"], comps, t0
        )

    def _lemma2(self) -> ExactVerdict:
        t0 = time.perf_counter()
        lps = [("RLP c1", self.optimum(self.spec("RLP", 0))), ("SLP(mu-bar)", self.slp_mu_bar())]
        comps = [
            comparison(
                "SLP(mu-bar) optimum = RLP optimum", {"of": "SLP(mu-bar)"}, {"of": "RLP c1"}, "=="
            )
        ]
        return self._verdict("Lemma 2", "SLP(mu-bar) = RLP", lps, [], comps, t0)

    def _theorem2(self) -> ExactVerdict:
        t0 = time.perf_counter()
        m = self.partition.n_partitions
        lps, comps = [], []
        for L in self.ib_blocks:
            ident = f"IB L={L}"
            lps.append((ident, self.optimum(self.spec("IB", 0, L=L))))
            comps += [
                comparison(
                    f"IB L={L} block {j + 1} = v*",
                    {"of": ident, "slice": [j * m, (j + 1) * m]},
                    {"of": "v*"},
                    "==",
                )
                for j in range(L)
            ]
        for j in range(len(self.d_list)):
            ident = f"LLP d{j + 1}"
            lps.append((ident, self.optimum(self.spec("LLP", 0, j=j))))
            comps.append(
                comparison(
                    f"LLP d{j + 1}: v >= v*", {"of": ident, "slice": [0, m]}, {"of": "v*"}, ">="
                )
            )
        return self._verdict("Theorem 2", "IB blocks = v*; LLP v >= v*", lps, ["RLP"], comps, t0)


def comparison(
    claim: str, left: dict[str, Any], right: dict[str, Any], relation: str
) -> dict[str, Any]:
    """A comparison entry; its difference and verdict are filled in by :func:`_finish`."""
    return {"claim": claim, "left": left, "right": right, "relation": relation}


def exact_verdict(
    check: str,
    claim: str,
    instance: str,
    model: dict[str, Any],
    lps: list[dict[str, Any]],
    fixed_points: list[dict[str, Any]],
    comparisons: list[dict[str, Any]],
    t0: float,
) -> ExactVerdict:
    """The exact verdict of ``comparisons`` among certified entries, with its certificate.

    Each comparison (``{"claim", "left", "right", "relation"}``, see
    :mod:`lpbounds.exact.files`) is evaluated by the checker's own
    :func:`~lpbounds.exact.check.evaluate` on the entries ``lps`` and ``fixed_points``
    (certificate entries: :meth:`ExactLP.entry <lpbounds.exact.lp.ExactLP.entry>`,
    :meth:`ExactFixedPoint.entry <lpbounds.exact.fixed_point.ExactFixedPoint.entry>`); its
    exact difference and verdict are written into it, the claim holds when every comparison
    does, and the certificate is verified before it is returned. The built-in claims are
    made this way; so can a conjecture of one's own (a false one gets ``VIOLATED`` and a
    certificate of the counterexample).

    Parameters
    ----------
    check, claim, instance : str
        The claim's name, statement and instance (for the record and the file).
    model : dict
        The certificate's model data.
    lps, fixed_points : list of dict
        Certificate entries (each with a distinct ``"id"``).
    comparisons : list of dict
        Filled in place with ``"difference"`` and ``"verdict"``.
    t0 : float
        ``time.perf_counter()`` when the work started (for ``seconds``).
    """
    from ..exact import check as checker

    parsed = checker.load_model(model)
    found = {
        e["id"]: {"spec": e, "objective": checker.rat(e["objective"]) if "objective" in e else None}
        for e in lps + fixed_points
    }
    diffs: dict[str, Fraction] = {}
    for k, c in enumerate(comparisons):
        d, holds = checker.evaluate(k, c, found, parsed)
        c["difference"], c["verdict"] = fraction_text(d), "holds" if holds else "violated"
        diffs[c["claim"]] = d
    verdict = (
        Verdict.HOLDS if all(c["verdict"] == "holds" for c in comparisons) else Verdict.VIOLATED
    )
    head = {
        "name": check,
        "statement": claim,
        "instance": instance,
        "verdict": verdict.value,
        "comparisons": comparisons,
    }
    cert = certificate(head, model, lps, fixed_points)
    first = next(iter(diffs.values()))
    return ExactVerdict(
        check, claim, instance, verdict, first, diffs, cert, time.perf_counter() - t0
    )


# ---------------------------------------------------------------------- Remark 2
def decide_remark2(
    mdp: FiniteMDP,
    basis: Any,
    cost1: Any,
    cost2: Any,
    *,
    name: str = "Remark 2 instance",
    approx: Sequence[Any] = (None, None, None),
    size_limit: int | None = None,
) -> ExactVerdict:
    """Remark 2 decided exactly: the ALP optima for ``c1``, ``c2`` and ``c1 + c2`` (the sum
    taken exactly) with ``OPT(c1 + c2) > OPT(c1) + OPT(c2)``, which a point optimal for both
    costs would make an equality. ``approx``: the solvers' points to start the exact
    simplex from (optional)."""
    t0 = time.perf_counter()
    model = mdp_data(mdp)
    phi = np.asarray(basis.toarray() if hasattr(basis, "toarray") else basis, dtype=np.float64)
    c1 = [Fraction(float(t)) for t in np.asarray(cost1, dtype=np.float64)]
    c2 = [Fraction(float(t)) for t in np.asarray(cost2, dtype=np.float64)]
    costs = {"c1": c1, "c2": c2, "c1+c2": [a + b for a, b in zip(c1, c2, strict=True)]}
    lps = []
    for (label, c), start in zip(costs.items(), approx, strict=True):
        spec = {
            "formulation": "ALP",
            "basis": [_hex(row) for row in phi],
            "state_cost": [fraction_text(t) for t in c],
        }
        lps.append(
            simplex_lp(
                model, spec, approx=start, size_limit=size_limit, what="ALP's weights"
            ).entry(f"ALP {label}")
        )
    comps = [
        comparison(
            "cost(c1+c2) = cost(c1) + cost(c2)",
            {"of": "ALP c1+c2", "part": "lp.state_cost"},
            {
                "sum": [
                    {"of": "ALP c1", "part": "lp.state_cost"},
                    {"of": "ALP c2", "part": "lp.state_cost"},
                ]
            },
            "==",
        ),
        comparison(
            "OPT(c1+c2) > OPT(c1) + OPT(c2)",
            {"of": "ALP c1+c2", "part": "objective"},
            {"sum": [{"of": "ALP c1", "part": "objective"}, {"of": "ALP c2", "part": "objective"}]},
            ">",
        ),
    ]
    out = exact_verdict("Remark 2", "ALP optimum depends on c", name, model, lps, [], comps, t0)
    out.difference = out.differences["OPT(c1+c2) > OPT(c1) + OPT(c2)"]
    return out


def certificate_name(instance: str, check: str) -> str:
    """The file name of the certificate of ``check`` on ``instance``:
    ``<instance>--<check>.json``, each part with every run of characters other than
    letters, digits and ``._=+-`` written ``_``, and followed by ``-`` and 6 hex digits of
    its SHA-256 when it held other characters than those, spaces and ``:`` (so that two
    names never share a file: ``"V >= W"`` and ``"V = W"``)."""

    def part(text: str) -> str:
        slug = re.sub(r"[^A-Za-z0-9._=+-]+", "_", text).strip("_")
        if re.fullmatch(r"[A-Za-z0-9._=+: -]*", text):
            return slug
        return f"{slug}-{hashlib.sha256(text.encode()).hexdigest()[:6]}"

    return f"{part(instance)}--{part(check)}.json"


def write_certificates(verdicts: Iterable[ExactVerdict], directory: str | Path) -> list[Path]:
    """Write one certificate per verdict into ``directory`` (created), named by
    :func:`certificate_name`; returns the paths."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    return [
        write_certificate(out / certificate_name(v.instance, v.check), v.certificate)
        for v in verdicts
    ]
