"""Every kind of certified bracket against the exact optimum of the model as stored.

The models sit at the edge of what lpbounds accepts: rows summing to ``1 +- 1e-9`` (the
row-sum tolerance, both signs, up to its last accepted float), discounts up to 0.99999,
rewards from 1e-6 to 1e6, one- and two-state models with closed-form values. The exact
optimum (``V*``, RLP's ``v*``, the NLP's ``w*``, ``V_pi``) is computed here in rational
arithmetic from the stored floats (``tests/_exact.py``, no lpbounds code), and each
bracket is compared with it **exactly**: ``Fraction(lower) <= exact <= Fraction(upper)``,
no tolerance beyond the bracket itself. Each bracket must also be no wider than its
point allows (``tests/_exact.width_limit``), so that a bracket made infinite fails too.

The brackets: the certificate of :func:`lpbounds.certify` from many points (the exact
value rounded, points a few ulps off it, fixed points of the computed operator, far
points), on the MDP's rows and RLP's (operator ``max``) and on the NLP's (``maxmin``);
the brackets of LP and NLP results (``lower_values``/``upper_values``, the objective
bracket); the exact DP's ``lower_values``/``upper_values`` (``DPResult``,
``PolicyEvaluation``, the game's ``solve_game``); and the Porteus bounds.

Why points a few ulps off: at discount 0.99999 the computed Bellman operator has floating
fixed points thousands of ulps from the exact one (its rounding, about one ulp, over ``1
- kappa``). There the computed residual is 0 and only the certificate's rounding margin
keeps the exact value inside; a far point (``0``) has a residual of the size of the values
and is caught only by a contraction modulus that counts rows summing above 1.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.formulations import ELP, NLP, RLP
from lpbounds.rows import BellmanRows
from lpbounds.tolerances import PROBABILITY_SUM_ATOL
from tests import _exact as ex

EPS = float(np.finfo(np.float64).eps)


# ---------------------------------------------------------------------- the models
def edge_row(p: np.ndarray, delta: float) -> np.ndarray:
    """``p`` (summing to 1) with its largest entry moved by ``delta``, then nudged by ulps
    back inside the row-sum rule (``|computed sum - 1| <= PROBABILITY_SUM_ATOL``): with
    ``delta = +-PROBABILITY_SUM_ATOL`` the last accepted row on that side."""
    p = np.array(p, dtype=np.float64)
    k = int(np.argmax(p))
    p[k] += delta
    while abs(float(p.sum()) - 1.0) > PROBABILITY_SUM_ATOL:
        p[k] = np.nextafter(p[k], -np.inf if p.sum() > 1.0 else np.inf)
    return p


@dataclass
class Case:
    """A model as arrays, its partition labels, and its exact optima (cached)."""

    name: str
    succ: np.ndarray  # (n, A, L)
    probs: np.ndarray  # (n, A, L)
    rewards: np.ndarray  # (n, A)
    allowed: np.ndarray  # (n, A)
    discount: float
    labels: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __post_init__(self) -> None:
        if self.labels.size == 0:
            self.labels = np.zeros(self.succ.shape[0], dtype=np.int64)

    @cached_property
    def mdp(self) -> lb.FiniteMDP:
        r = np.where(self.allowed, self.rewards, 0.0)
        return lb.FiniteMDP(self.succ, self.probs, r, self.discount, allowed=self.allowed)

    @cached_property
    def partition(self) -> lb.Partition:
        return lb.Partition(self.labels)

    @property
    def arrays(self) -> tuple:
        return self.succ, self.probs, np.where(self.allowed, self.rewards, 0.0), self.allowed

    @cached_property
    def vstar(self) -> list[Fraction]:
        return ex.fixed_point(ex.mdp_groups(*self.arrays, self.discount))

    @cached_property
    def rlp(self) -> list[Fraction]:
        return ex.fixed_point(ex.rlp_groups(*self.arrays, self.discount, self.labels))

    @cached_property
    def nlp(self) -> list[Fraction]:
        return ex.fixed_point(ex.nlp_groups(*self.arrays, self.discount, self.labels))

    @cached_property
    def kappa(self) -> Fraction:
        return ex.mdp_groups(*self.arrays, self.discount).kappa()

    @property
    def n_out(self) -> int:
        return int(self.succ.shape[2])

    @property
    def reward_absmax(self) -> float:
        return float(np.abs(self.rewards[self.allowed]).max())


def one_state(name, rows, rewards, discount) -> Case:
    """One state, one action per row of ``rows`` (every successor the state itself):
    ``V* = max_u R_u / (1 - lambda s_u)``."""
    p = np.array(rows, dtype=np.float64)[None]
    n_act, n_out = p.shape[1:]
    return Case(
        name,
        np.zeros((1, n_act, n_out), dtype=np.int64),
        p,
        np.array([rewards], dtype=np.float64),
        np.ones((1, n_act), dtype=bool),
        discount,
    )


def two_state(name, stay0, move0, stay1, r0, r1, discount, labels=(0, 1)) -> Case:
    """State 0: stay (reward ``r0``, rows ``stay0`` to 0) or move (reward 0, ``move0`` to 1);
    state 1: stay only (reward ``r1``). ``V*(1) = r1 / (1 - lambda s(stay1))``, ``V*(0) =
    max(r0 / (1 - lambda s(stay0)), lambda s(move0) V*(1))``."""
    succ = np.array([[[0, 0], [1, 1]], [[1, 1], [1, 1]]])
    probs = np.array([[stay0, move0], [stay1, stay1]], dtype=np.float64)
    rewards = np.array([[r0, 0.0], [r1, 0.0]])
    allowed = np.array([[True, True], [True, False]])
    return Case(name, succ, probs, rewards, allowed, discount, np.array(labels))


def random_case(name, seed, n, n_act, n_out, discount, scale, deltas) -> Case:
    """A random model whose rows are moved by ``deltas`` (drawn per row) within the rule;
    action 0 allowed everywhere (so that every partition has a common action)."""
    rng = np.random.default_rng(seed)
    succ = rng.integers(0, n, size=(n, n_act, n_out))
    probs = np.empty((n, n_act, n_out))
    for x in range(n):
        for u in range(n_act):
            base = rng.dirichlet(np.ones(n_out)) if n_out > 1 else np.ones(1)
            probs[x, u] = edge_row(base, float(rng.choice(deltas)))
    rewards = scale * rng.uniform(-1.0, 1.0, size=(n, n_act))
    allowed = rng.random((n, n_act)) < 0.7
    allowed[:, 0] = True
    labels = rng.integers(0, max(1, n - 1), size=n)
    labels = np.unique(labels, return_inverse=True)[1].astype(np.int64)
    return Case(name, succ, probs, rewards, allowed, discount, labels)


ATOL = PROBABILITY_SUM_ATOL
HALF_UP, HALF_DOWN = edge_row([0.5, 0.5], ATOL), edge_row([0.5, 0.5], -ATOL)

EDGE_CASES = [
    one_state("issue: 0.5 / 0.5 + 9e-10 at 0.99999", [[0.5, 0.5 + 9e-10]], [1.0], 0.99999),
    one_state("sum 1 + 1e-9 at 0.99999, rewards 1e6", [HALF_UP, HALF_DOWN], [1e6, 0.99e6], 0.99999),
    one_state("sum 1 - 1e-9 at 0.9999, rewards -1e-6", [HALF_DOWN], [-1e-6], 0.9999),
    one_state("three outcomes, sum 1 + 1e-9", [edge_row([0.2, 0.3, 0.5], ATOL)], [3.0], 0.999),
    two_state(
        "two states, sums 1 +- 1e-9 at 0.99999",
        HALF_UP, HALF_DOWN, HALF_UP, 1.0, 2.0, 0.99999,
    ),
    two_state(
        "two states in one block, rewards 1e-6 at 0.99999",
        HALF_DOWN, HALF_UP, HALF_UP, 3e-6, -1e-6, 0.99999, labels=(0, 0),
    ),
    two_state(
        "two states, rewards 1e6 at 0.9",
        HALF_UP, HALF_UP, HALF_DOWN, -5e5, 1e6, 0.9,
    ),
    random_case("3 states, sums 1 + 1e-9, 0.99999", 1, 3, 2, 3, 0.99999, 1.0, [ATOL]),
    random_case("3 states, sums 1 +- 1e-9, 0.9999, 1e6", 2, 3, 2, 2, 0.9999, 1e6, [ATOL, -ATOL]),
    random_case("4 states, sums 1 +- 1e-9, 0.99999", 3, 4, 2, 2, 0.99999, 1e-6, [ATOL, -ATOL]),
]  # fmt: skip
IDS = [c.name for c in EDGE_CASES]


# ---------------------------------------------------------------------- the points
def ulps(v: np.ndarray, k: int) -> np.ndarray:
    """``v`` moved ``k`` ulps entry by entry (up for ``k > 0``)."""
    out = np.array(v, dtype=np.float64)
    for _ in range(abs(k)):
        out = np.nextafter(out, np.inf if k > 0 else -np.inf)
    return out


def float_iterates(op, start: np.ndarray, n: int) -> list[np.ndarray]:
    """``n`` iterates of a floating-point operator from ``start``: near its fixed point they
    wander among floats whose computed residual is a few ulps or exactly 0."""
    out, v = [], np.array(start, dtype=np.float64)
    for _ in range(n):
        v = op(v)
        out.append(v)
    return out


def points_near(exact: list[Fraction], op, scale: float, seed: int) -> list[np.ndarray]:
    """The exact value rounded; shifted by 2..3000 ulps both ways (all entries, and
    alternating); iterates of the computed operator from 3000 ulps off; ``0``, ``-v``
    and random points of the values' size."""
    v = ex.rounded(exact)
    sign = np.where(np.arange(v.size) % 2 == 0, 1, -1)
    pts = [v]
    for k in (2, 3, 5, 17, 100, 3000):
        pts += [ulps(v, k), ulps(v, -k)]
        pts.append(np.where(sign > 0, ulps(v, k), ulps(v, -k)))
    pts += float_iterates(op, ulps(v, 3000), 12) + float_iterates(op, ulps(v, -3000), 12)
    rng = np.random.default_rng(seed)
    pts += [np.zeros_like(v), -v, 2.0 * v + scale, rng.uniform(-2.0, 2.0, v.size) * scale]
    return pts


def mdp_operator(case: Case):
    """The MDP's Bellman operator in floating point, numpy only."""
    succ, probs, rewards, allowed = case.arrays

    def op(v):
        q = rewards + case.discount * (probs * v[succ]).sum(axis=2)
        return np.where(allowed, q, -np.inf).max(axis=1)

    return op


def partition_operator(case: Case, game: bool):
    """RLP's (``max``) or the NLP's (``max``-``min``) operator in floating point."""
    succ, probs, rewards, allowed = case.arrays
    lab, m = case.labels, int(case.labels.max()) + 1

    def op(w):
        q = rewards + case.discount * (probs * w[lab][succ]).sum(axis=2)
        out = np.full(m, np.inf if game else -np.inf)
        if not game:
            np.maximum.at(out, lab, np.where(allowed, q, -np.inf).max(axis=1))
            return out
        mins = np.full((m, q.shape[1]), np.inf)
        for a in range(q.shape[1]):
            np.minimum.at(mins[:, a], lab, np.where(allowed[:, a], q[:, a], -np.inf))
        return mins.max(axis=1)

    return op


def magnitude(case: Case, *vectors) -> float:
    """The scale of the rounding allowance: ``max|R|`` plus twice the largest entries."""
    return case.reward_absmax + 2.0 * max(float(np.abs(v).max()) for v in vectors)


def check_certificate(rows, exact, point, case, operator="max", what="") -> None:
    """``certify(rows, point)`` contains ``exact`` and is no wider than the point allows."""
    c = lb.certify(rows, point, operator=operator)
    ex.assert_contains(c.lower, c.upper, exact, what)
    limit = ex.width_limit(
        point, exact, case.kappa, magnitude(case, point, ex.rounded(exact)), case.n_out
    )
    ex.assert_not_vacuous(c.lower, c.upper, limit, what)


# ---------------------------------------------------------------------- the reference
def test_reference_matches_the_closed_forms():
    """The exact solver against ``R / (1 - lambda s)`` (one state) and the two-state
    formula, both in rationals: the reference is right before it judges anything."""
    f = ex.fr
    for case in EDGE_CASES[:4]:
        lam = f(case.discount)
        closed = max(
            f(case.rewards[0, u]) / (1 - lam * sum(f(p) for p in case.probs[0, u]))
            for u in range(case.rewards.shape[1])
        )
        assert case.vstar == [closed], case.name
    case = EDGE_CASES[4]
    lam, s = f(case.discount), [sum(f(p) for p in row) for row in (HALF_UP, HALF_DOWN)]
    v1 = f(2.0) / (1 - lam * s[0])
    assert case.vstar == [max(f(1.0) / (1 - lam * s[0]), lam * s[1] * v1), v1]
    # the example: V* = 1 / (1 - 0.99999 (1 + 9e-10)) is 100009.0007..., not 1e5
    assert float(EDGE_CASES[0].vstar[0]) == pytest.approx(100009.0007, abs=1e-4)


def test_the_edge_rows_are_accepted_and_really_at_the_edge():
    """The last accepted rows on each side: one ulp further is refused."""
    for p, side in ((HALF_UP, 1), (HALF_DOWN, -1)):
        assert abs(float(p.sum()) - 1.0) <= ATOL < abs(float(p.sum()) - 1.0) + 2 * EPS
        lb.FiniteMDP([[[0, 0]]], p, [[1.0]], 0.99999)
        q = p.copy()
        q[0] = np.nextafter(q[0], side * np.inf)
        with pytest.raises(lb.ValidationError):
            lb.FiniteMDP([[[0, 0]]], q, [[1.0]], 0.99999)


# ---------------------------------------------------------------------- certificates
@pytest.mark.parametrize("case", EDGE_CASES, ids=IDS)
def test_lp_certificate_of_any_point_contains_v_star(case):
    """The MDP's rows (ELP's): ``certify(rows, v)`` contains the exact ``V*`` from every
    point, and is no wider than the point's distance to ``V*`` allows."""
    rows = lb.dp.exact_rows(case.mdp)
    for k, v in enumerate(points_near(case.vstar, mdp_operator(case), case.reward_absmax, 0)):
        check_certificate(rows, case.vstar, v, case, what=f"{case.name}, point {k}")


@pytest.mark.parametrize("case", EDGE_CASES, ids=IDS)
def test_rlp_certificate_of_any_point_contains_v_star_of_rlp(case):
    """RLP's aggregated rows (duplicates merged, probabilities summed per block)."""
    rows = BellmanRows.aggregate(case.mdp, case.partition, reduce="max")
    op = partition_operator(case, game=False)
    for k, v in enumerate(points_near(case.rlp, op, case.reward_absmax, 1)):
        check_certificate(rows, case.rlp, v, case, what=f"{case.name}, point {k}")


@pytest.mark.parametrize("case", EDGE_CASES, ids=IDS)
def test_nlp_certificate_of_any_point_contains_w_star(case):
    """The NLP's min-rows with the max-min operator ``G``."""
    rows = NLP(case.mdp, case.partition).rows
    op = partition_operator(case, game=True)
    for k, w in enumerate(points_near(case.nlp, op, case.reward_absmax, 2)):
        check_certificate(rows, case.nlp, w, case, "maxmin", what=f"{case.name}, point {k}")


# ---------------------------------------------------------------------- LP and NLP results
def check_result(res, exact, case, what) -> None:
    """An LP or NLP result's ``lower_values``/``upper_values`` contain the exact optimum
    (exactly) and are no wider than its point allows."""
    assert res.status.has_point, f"{what}: {res.status}"
    ex.assert_contains(res.lower_values, res.upper_values, exact, what)
    point = np.asarray(res.values, dtype=np.float64)
    limit = ex.width_limit(point, exact, case.kappa, magnitude(case, point), case.n_out)
    ex.assert_not_vacuous(res.lower_values, res.upper_values, limit, what)


@pytest.mark.parametrize("case", EDGE_CASES, ids=IDS)
def test_lp_results_contain_the_exact_optimum(case):
    """ELP (``V*``) and RLP (``v*``) solved by HiGHS: ``lower_values``/``upper_values`` and
    the objective bracket ``[lo, hi]`` on ``c'v*`` against the exact values."""
    elp = ELP(case.mdp).solve("HIGHS", raise_on_failure=False)
    check_result(elp, case.vstar, case, f"ELP {case.name}")
    lo, hi = elp.objective_bracket
    assert ex.fr(lo) <= sum(case.vstar) <= ex.fr(hi), f"ELP objective {case.name}"
    rlp = RLP(case.mdp, case.partition).solve("HIGHS", raise_on_failure=False)
    check_result(rlp, case.rlp, case, f"RLP {case.name}")
    sizes = np.bincount(case.labels)
    lo, hi = rlp.objective_bracket
    assert ex.fr(lo) <= sum(int(s) * v for s, v in zip(sizes, case.rlp, strict=True)) <= ex.fr(hi)


#: The NLP's methods. The default cutting planes (monotone cuts, master by the exact DP)
#: only up to discount 0.999: at 0.99999 each round's master takes about a second (its
#: MPI sweeps at the rate lambda), so there the masters are HiGHS LPs.
NLP_RUNS = [
    pytest.param(case, method, opts, id=f"{case.name}-{method}-{'-'.join(opts.values())}")
    for case in EDGE_CASES
    for method, opts in (
        ("strategy-iteration", {}),
        ("milp", {}),
        ("cutting-planes", {"backend": "highspy"}),
        ("cutting-planes", {"cuts": "lift-and-project"}),
        *((("cutting-planes", {}),) if case.discount <= 0.999 else ()),
    )
]


@pytest.mark.parametrize(("case", "method", "opts"), NLP_RUNS)
def test_nlp_results_contain_w_star(case, method, opts):
    """The NLP's certified bracket and its bracket on ``c'w*`` against the exact game value."""
    res = NLP(case.mdp, case.partition).solve(method, **opts)
    check_result(res, case.nlp, case, f"NLP {method} {opts} {case.name}")
    sizes = np.bincount(case.labels)
    c_w = sum(int(s) * w for s, w in zip(sizes, case.nlp, strict=True))
    assert ex.fr(res.lower_bound) <= c_w <= ex.fr(res.upper_bound), f"c'w* {case.name}"


# ---------------------------------------------------------------------- exact DP, Porteus
def check_dp(res, exact, case, what) -> None:
    """A DP result's ``[values -+ error_bound]`` contains the exact vector and is no wider
    than the returned vector's distance to it allows (its slack has a ``max(1, |V|)``)."""
    ex.assert_contains(res.lower_values, res.upper_values, exact, what)
    v = np.asarray(res.values, dtype=np.float64)
    limit = ex.width_limit(v, exact, case.kappa, magnitude(case, v) + 1.0, case.n_out)
    ex.assert_not_vacuous(res.lower_values, res.upper_values, limit, what)


@pytest.mark.parametrize("case", EDGE_CASES, ids=IDS)
def test_dp_brackets_contain_the_exact_values(case):
    """``solve_exact`` (every method), ``evaluate_policy`` of its policy (against the exact
    ``V_pi``), the fixed points of RLP's rows and of the NLP's game (``solve_game``).

    Value iteration, MPI and the game's value iteration converge at the rate ``lambda``
    where the Porteus shift cannot help (two states that never meet, residuals of both
    signs): at 0.99999 that is 10^5 sweeps per digit. They are stopped at 3,000
    improvement sweeps here; a result stopped short must still bracket the exact value.
    """
    for method in ("mpi", "pi", "ipi", "vi"):
        res = lb.solve_exact(case.mdp, method, max_iter=3000, raise_on_failure=False)
        check_dp(res, case.vstar, case, f"{method} {case.name}")
    pol = lb.solve_exact(case.mdp, "pi").policy
    v_pi = ex.policy_value(*case.arrays[:3], case.discount, pol)
    # iterative evaluation has no iteration limit: at 0.99999 it sweeps for seconds
    for how in ("direct", "iterative") if case.discount <= 0.9999 else ("direct",):
        check_dp(lb.evaluate_policy(case.mdp, pol, how), v_pi, case, f"V_pi {how} {case.name}")
    rlp_rows = BellmanRows.aggregate(case.mdp, case.partition, reduce="max")
    check_dp(lb.solve_exact(rlp_rows, "pi"), case.rlp, case, f"RLP rows {case.name}")
    game = lb.solve_game(NLP(case.mdp, case.partition).rows, max_iter=3000, raise_on_failure=False)
    check_dp(game, case.nlp, case, f"game {case.name}")


@pytest.mark.parametrize("case", EDGE_CASES, ids=IDS)
def test_porteus_bounds_contain_the_exact_values(case):
    """``lower <= V_pi <= V* <= upper`` and ``lower_paper <= V_pi``, with ``pi`` the bounds'
    greedy policy and ``V_pi``, ``V*`` exact, from points near ``V*`` and far from it."""
    for k, v in enumerate(points_near(case.vstar, mdp_operator(case), case.reward_absmax, 3)):
        b = lb.porteus_bounds(case.mdp, v)
        v_pi = ex.policy_value(*case.arrays[:3], case.discount, b.policy)
        what = f"Porteus {case.name}, point {k}"
        ex.assert_contains(b.lower, b.upper, case.vstar, what)
        ex.assert_contains(b.lower, b.upper, v_pi, what)
        ex.assert_contains(b.lower_paper, b.upper, v_pi, what)
        limit = ex.width_limit(v, case.vstar, case.kappa, magnitude(case, v), case.n_out)
        ex.assert_not_vacuous(b.lower, b.upper, limit, what)


# ---------------------------------------------------------------------- random edge models
@st.composite
def edge_cases(draw):
    n = draw(st.integers(1, 3))
    n_act = draw(st.integers(1, 2))
    n_out = draw(st.integers(1, 3))
    discount = draw(st.sampled_from([0.5, 0.9, 0.99, 0.999, 0.9999, 0.99999]))
    scale = 10.0 ** draw(st.integers(-6, 6))
    deltas = draw(st.sampled_from([[ATOL], [-ATOL], [ATOL, -ATOL], [ATOL, 0.0, -3e-10]]))
    seed = draw(st.integers(0, 2**31 - 1))
    return random_case("random", seed, n, n_act, n_out, discount, scale, deltas)


@settings(max_examples=60)
@given(edge_cases())
def test_certificates_on_random_edge_models(case):
    """The certificates of the three operators from points near and far from the exact
    optima, the exact DP's bracket and the Porteus bounds, on random small models whose
    rows are at the edge of the row-sum rule."""
    rows = lb.dp.exact_rows(case.mdp)
    for v in points_near(case.vstar, mdp_operator(case), case.reward_absmax, 4)[::3]:
        check_certificate(rows, case.vstar, v, case, what="ELP rows")
        b = lb.porteus_bounds(case.mdp, v)
        ex.assert_contains(b.lower, b.upper, case.vstar, "Porteus")
    rlp_rows = BellmanRows.aggregate(case.mdp, case.partition, reduce="max")
    for v in points_near(case.rlp, partition_operator(case, False), case.reward_absmax, 5)[::3]:
        check_certificate(rlp_rows, case.rlp, v, case, what="RLP rows")
    nlp_rows = NLP(case.mdp, case.partition).rows
    for w in points_near(case.nlp, partition_operator(case, True), case.reward_absmax, 6)[::3]:
        check_certificate(nlp_rows, case.nlp, w, case, "maxmin", what="NLP rows")
    check_dp(lb.solve_exact(case.mdp, "pi"), case.vstar, case, "pi")
