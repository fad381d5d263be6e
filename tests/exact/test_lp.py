"""Exact LP optima of every formulation against an independent exact computation.

Each LP is rebuilt here from the model's arrays in Fractions (tests/exact/_reference.py,
not lpbounds' builders nor its checker's) and solved by enumerating every basis. The
exact optimum lpbounds returns must equal it, its primal and dual must prove it (checked
again here), and the float solve's certified bracket must contain it.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.errors import SizeLimitError, ValidationError
from lpbounds.formulations import ALP, ELP, IB, LLP, RLP, SLP, find_cost_dependent_alp
from lpbounds.patrol.bounds import LBLP, UBLP
from lpbounds.patrol.params import PatrolParams

from . import _reference as ref
from ._models import stored_mdps, with_partition

F = Fraction
LPS = settings(max_examples=15, deadline=None, derandomize=True,
               suppress_health_check=[HealthCheck.too_slow])  # fmt: skip
TINY = with_partition(stored_mdps(max_states=3, max_actions=2, max_outcomes=2))


def _costs(seed: int, n: int, zeros: bool = False) -> np.ndarray:
    rng = np.random.default_rng(seed)
    c = rng.uniform(0.1, 1.0, n)
    if zeros:
        c[rng.random(n) < 0.4] = 0.0
    return c


def _check_proof(rows, cost, exact):
    """Primal and dual feasibility and equal objectives, recomputed here (dense rows)."""
    x, y = exact.x.fractions(), exact.y.fractions()
    assert len(y) == len(rows) and all(t >= 0 for t in y)
    for a, b in rows:
        assert sum((s * t for s, t in zip(a, x, strict=True)), F(0)) >= b
    for j, c in enumerate(cost):
        assert sum((rows[r][0][j] * y[r] for r in range(len(rows))), F(0)) == c
    obj = sum((c * t for c, t in zip(cost, x, strict=True)), F(0))
    assert obj == sum((b * t for (_, b), t in zip(rows, y, strict=True)), F(0)) == exact.objective


def _bracket_holds(result, target):
    lo, hi = result.lower_values, result.upper_values
    assert all(F(float(a)) <= t <= F(float(b)) for a, t, b in zip(lo, target, hi, strict=True))
    if result.objective_bracket is not None:
        lo_o, hi_o = result.objective_bracket
        assert F(lo_o) <= result.exact.objective <= F(hi_o)


def _agree(result, rows, cost, proof: bool = True):
    """The exact optimum is the enumeration's (and so is the point, when unique); with
    ``proof``, its primal and dual are checked on the rows as written here (SLP's exact
    rows are eq. 12's, a positive multiple of the normalised rows here: same optimum,
    other duals)."""
    opt, x = ref.lp_optimum(rows, cost)
    ex = result.exact
    assert ex.objective == opt
    if proof:
        _check_proof(rows, cost, ex)
    if ex.unique:
        assert ex.x.fractions() == x
    err = max(abs(F(float(a)) - b) for a, b in zip(result.values, ex.values, strict=True))
    assert ex.error == err
    return opt


@LPS
@given(stored_mdps(max_states=3, max_actions=2, max_outcomes=2), st.integers(0, 99), st.booleans())
def test_elp(mdp, seed, zeros):
    form = ELP(mdp, _costs(seed, mdp.n_states, zeros))
    res = form.solve("HIGHS", arithmetic="rational")
    _agree(res, ref.elp(mdp), [F(float(c)) for c in form.c])
    _bracket_holds(res, res.exact.values)
    assert res.exact.inside_bracket
    assert list(res.exact.values) == ref.vstar(mdp)  # Lemma 1, exactly


@LPS
@given(TINY, st.integers(0, 99), st.booleans())
def test_rlp(case, seed, zeros):
    mdp, part = case
    form = RLP(mdp, part, _costs(seed, mdp.n_states, zeros))
    res = form.solve("HIGHS", arithmetic="rational")
    _agree(res, ref.rlp(mdp, part.labels, part.n_partitions), [F(float(c)) for c in form.c])
    _bracket_holds(res, res.exact.values)


@LPS
@given(TINY, st.integers(0, 99), st.integers(1, 2))
def test_ib(case, seed, L):
    mdp, part = case
    form = IB(mdp, part, L, _costs(seed, mdp.n_states))
    res = form.solve("HIGHS", arithmetic="rational")
    m = part.n_partitions
    _agree(res, ref.ib(mdp, part.labels, m, L), [F(float(c)) for c in form.c])
    _bracket_holds(res, res.exact.values)
    v = res.exact.x.fractions()
    assert all(v[j * m : (j + 1) * m] == v[:m] for j in range(L))  # Theorem 2, exactly


@LPS
@given(TINY, st.integers(0, 99))
def test_slp_with_rlp_duals_and_uniform(case, seed):
    mdp, part = case
    rlp = RLP(mdp, part, _costs(seed, mdp.n_states)).solve("HIGHS", arithmetic="rational")
    for mu in (rlp.mu, "uniform"):
        form = SLP(mdp, part, mu)
        res = form.solve("HIGHS", arithmetic="rational")
        _agree(res, ref.slp(mdp, part.labels, part.n_partitions, form.mu.tolist()),
               [F(float(c)) for c in form.c], proof=False)  # fmt: skip
        _bracket_holds(res, res.exact.values)


@LPS
@given(with_partition(stored_mdps(max_states=2, max_actions=2, max_outcomes=2)),
       st.integers(0, 99), st.booleans())  # fmt: skip
def test_llp(case, seed, zeros):
    mdp, part = case
    rng = np.random.default_rng(seed)
    d = rng.uniform(0.0, 2.0, (mdp.n_states, mdp.n_actions))
    form = LLP(mdp, part, d, _costs(seed, mdp.n_states, zeros))
    res = form.solve("HIGHS", arithmetic="rational")
    m = part.n_partitions
    rows, cost_z = ref.llp(mdp, part.labels, m, form.d)
    opt, _ = ref.lp_optimum(rows, [F(float(c)) for c in form.c[:m]] + cost_z)
    assert res.exact.objective == opt
    _check_proof(rows, [F(float(c)) for c in form.c], res.exact)
    v_star = res.exact.fixed_point.values.fractions()
    assert all(a >= b for a, b in zip(res.exact.values, v_star, strict=True))  # LLP's v >= v*
    assert res.exact.inside_bracket  # the bracket is on RLP's v*


@pytest.mark.parametrize("seed", [0, 3, 7])
def test_alp_against_enumeration_and_bracket_on_vstar(seed):
    ex = find_cost_dependent_alp(seed)
    for cost in (ex.cost1, ex.cost2):
        form = ALP(ex.mdp, ex.basis, cost)
        res = form.solve("HIGHS", arithmetic="rational")
        rows, phi = ref.alp(ex.mdp, ex.basis)
        c_phi = [sum((F(float(cost[x])) * phi[x][j] for x in range(len(phi))), F(0))
                 for j in range(len(phi[0]))]  # fmt: skip
        opt, _ = ref.lp_optimum(rows, c_phi)
        assert res.exact.objective == opt
        _check_proof(rows, c_phi, res.exact)
        vstar = ref.vstar(ex.mdp)
        assert res.exact.inside_bracket
        assert all(F(float(a)) <= t <= F(float(b)) for a, t, b in
                   zip(res.lower_values, vstar, res.upper_values, strict=True))  # fmt: skip


def test_alp_from_an_infeasible_start_needs_phase_one():
    """Started at 0 (infeasible for positive rewards), the simplex still ends optimal."""
    from lpbounds.exact.lp import simplex_lp

    ex = find_cost_dependent_alp(0)
    form = ALP(ex.mdp, ex.basis, ex.cost1)
    model, spec = form.exact_lp()
    got = simplex_lp(model, spec, approx=np.zeros(ex.basis.shape[1]))
    rows, phi = ref.alp(ex.mdp, ex.basis)
    c_phi = [sum((F(float(ex.cost1[x])) * phi[x][j] for x in range(6)), F(0)) for j in range(2)]
    assert got.objective == ref.lp_optimum(rows, c_phi)[0]


@pytest.mark.parametrize("kind", [UBLP, LBLP])
def test_patrol_bounds_checked_independently(kind):
    """UBLP and LBLP of a tiny patrol (19 partitions): too many bases to enumerate, so the
    proof is recomputed here: x = T x exactly, dual feasible, equal objectives."""
    form = kind(PatrolParams(N=3, stations=(0,), D=1, Gamma=2))
    res = form.solve("HIGHS", arithmetic="rational")
    rows = ref.rows_lp(form.rows)
    cost = [F(float(c)) for c in form.c]
    _check_proof(rows, cost, res.exact)
    x = res.exact.x.fractions()
    owner = form.rows.owner
    for i in range(form.rows.n_vars):  # x(i) = max over i's rows of q_r(x): the fixed point
        slack = [sum((s * t for s, t in zip(rows[r][0], x, strict=True)), F(0)) - rows[r][1]
                 for r in range(len(rows)) if owner[r] == i]  # fmt: skip
        assert min(slack) == 0
    _bracket_holds(res, res.exact.values)
    assert res.exact.unique  # positive cost: the occupation measure proves uniqueness


def test_rational_refused_with_extra_constraints_and_on_plain_formulations():
    import scipy.sparse as sp

    from lpbounds.formulations import Formulation

    form = ELP(lb.garnet(4, 2, 2, seed=0))
    with pytest.raises(ValidationError, match="extra_constraints"):
        form.solve("HIGHS", arithmetic="rational", extra_constraints=[form.V[0] <= 100])
    plain = Formulation(sp.csr_matrix(np.eye(2)), np.zeros(2), np.ones(2))
    with pytest.raises(ValidationError, match="no exact route"):
        plain.solve("HIGHS", arithmetic="rational")
    with pytest.raises(SizeLimitError, match="size_limit="):
        ELP(lb.garnet(12, 2, 3, seed=0)).solve("HIGHS", arithmetic="rational", size_limit=1)


def test_planted_wrong_dual_fails_the_check():
    """A dual that is off by one unit in one entry no longer proves the optimum: the check
    the library runs on every exact answer names the column."""
    from lpbounds.exact import check
    from lpbounds.exact.rationals import RationalVector

    form = ELP(lb.garnet(5, 2, 2, seed=1))
    ex = form.solve("HIGHS", arithmetic="rational").exact
    y = list(ex.y.numerators)
    k = next(r for r, t in enumerate(y) if t)
    y[k] += 1
    entry = {**ex.entry("ELP"), "y": RationalVector(y, ex.y.denominator).to_json()}
    with pytest.raises(check.CheckError, match="column"):
        check.check_lp("ELP", entry, check.load_model(ex.model))
