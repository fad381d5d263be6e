"""Partition-level UBLP/LBLP rows against the rows aggregated from the full MDP.

Theorem 4 (UBLP = RLP) and Theorem 3 (LBLP = NLP, a lower bound on min V* per
partition) are checked with exact DP on small instances, under the specification's
model (no loitering at an empty station) and with ``allow_empty_loiter``. Claim 2
(monotonicity of V*) fails under the default model; the tests pin down exactly where,
and that the theorems' reductions do not depend on those pairs.
"""

from __future__ import annotations

import numpy as np
import pytest

from lpbounds import BellmanRows, solve_exact, solve_game
from lpbounds.errors import ValidationError
from lpbounds.patrol import PatrolModel, PatrolParams
from lpbounds.patrol.bounds import (
    LBLP,
    UBLP,
    lemma3_cardinality,
    partition_keys,
    patrol_rows,
)
from lpbounds.patrol.partitions import partition_components

SIZES = [
    dict(N=6, stations=(0, 3), D=2, Gamma=4),
    dict(N=5, stations=(0, 2, 3), D=2, Gamma=3),
    dict(N=3, stations=(1,), D=1, Gamma=2),
    dict(N=6, stations=(0, 1), D=3, Gamma=5),
    dict(N=4, stations=(3, 0), D=2, Gamma=1),
]
IDS = ["N6m2", "N5m3", "N3m1", "N6m2-adjacent", "N4m2-G1"]
#: DP tolerance of the fixed points compared here (absolute Bellman residual)
DP_TOL = 1e-13
#: two fixed points of the same rows at residual DP_TOL differ by <= 2 DP_TOL / (1 - 0.9)
FP_ATOL = 1e-11


def _canonical(rows: BellmanRows) -> set:
    """Each row as (owner, action, reward, sorted merged (target, prob)) - order free."""
    a, b = rows.constraint_matrix()
    a = a.tocsr()
    out = set()
    for r in range(rows.n_rows):
        s = slice(a.indptr[r], a.indptr[r + 1])
        cols, vals = a.indices[s].tolist(), np.round(a.data[s], 13).tolist()
        entries = tuple(sorted(zip(cols, vals, strict=True)))
        out.add((int(rows.owner[r]), int(rows.action[r]), round(float(b[r]), 13), entries))
    return out


@pytest.fixture(
    scope="module",
    params=[(s, e) for s in range(len(SIZES)) for e in (False, True)],
    ids=[f"{i}-{'empty' if e else 'spec'}" for i in IDS for e in (False, True)],
)
def case(request):
    k, empty = request.param
    p = PatrolParams(**SIZES[k], allow_empty_loiter=empty)
    model = PatrolModel(p)
    mdp, part = model.mdp(), model.partition()
    vstar = solve_exact(mdp, tol=DP_TOL).values
    return p, model, mdp, part, vstar


def test_all_tuples_equal_the_aggregated_mdp_rows(case):
    p, _model, mdp, part, _ = case
    full_max = _canonical(BellmanRows.aggregate(mdp, part, "max"))
    full_min = _canonical(BellmanRows.aggregate(mdp, part, "min"))
    built = _canonical(patrol_rows(p, "all"))
    assert built == full_max, "T(i, u) built from keys == distinct RLP rows of the full MDP"
    assert built == full_min, "rewards are constant on partitions: NLP terms are the same rows"


def test_upper_and_lower_pick_the_theorem_tuples(case):
    p, *_ = case
    everything = _canonical(patrol_rows(p, "all"))
    pc = partition_components(p)
    tb_col = pc[:, -1]
    for kind in ("upper", "lower"):
        rows = patrol_rows(p, kind)
        assert _canonical(rows) <= everything, f"{kind} rows are RLP rows"
        counts = np.zeros((p.n_partitions, 3), dtype=int)
        np.add.at(counts, (rows.owner, rows.action), 1)
        assert counts.max() == 1, "one row per (partition, action)"
        lemma = lemma3_cardinality(p)
        assert np.array_equal(counts > 0, lemma.construction > 0), "same allowed pairs"
        t1 = np.flatnonzero(lemma.type1)
        for i in t1:
            r = np.flatnonzero((rows.owner == i) & (rows.action == 2))[0]
            next_tb = set(tb_col[rows.targets[r]].tolist())
            want = min(2, p.Gamma) if kind == "upper" else min(tb_col[i] + 1, p.Gamma)
            assert next_tb == {want}, f"{kind}: type-1 partition {pc[i].tolist()}"


def test_theorem4_ublp_equals_rlp_and_bounds_vstar_above(case):
    p, _model, mdp, part, vstar = case
    rlp = solve_exact(BellmanRows.aggregate(mdp, part, "max"), tol=DP_TOL).values
    ub = UBLP(p).fixed_point(tol=DP_TOL)
    np.testing.assert_allclose(ub, rlp, atol=FP_ATOL, rtol=0, err_msg="Theorem 4: UBLP == RLP")
    gap = ub - part.aggregate(vstar, "max")
    assert gap.min() >= -FP_ATOL, f"V*(x) <= v*(i) on S_i fails by {-gap.min():.3e}"


def test_theorem3_lblp_equals_nlp_and_bounds_min_vstar_below(case):
    p, _model, mdp, part, vstar = case
    nlp = solve_game(BellmanRows.aggregate(mdp, part, "min"), tol=DP_TOL).values
    lb = LBLP(p).fixed_point(tol=DP_TOL)
    np.testing.assert_allclose(lb, nlp, atol=FP_ATOL, rtol=0, err_msg="Theorem 3: LBLP == NLP")
    gap = part.aggregate(vstar, "min") - lb
    assert gap.min() >= -FP_ATOL, f"w*(i) <= min V* on S_i fails by {-gap.min():.3e}"


def _claim2_violations(p, model, vstar):
    """Pairs x2 <= x1 differing by one in one delay with V*(x1) > V*(x2) (Claim 2 says <=)."""
    l, w, d, tau = model.decode(np.arange(model.n_states))
    out = []
    for j in range(p.m):
        own_loiter = (d >= 1) & (p.station_pos[l] == j)
        sel = np.flatnonzero((tau[:, j] < p.Gamma) & ~own_loiter)
        t2 = tau[sel].copy()
        t2[:, j] += 1
        x1 = model.encode(l[sel], w[sel], d[sel], t2)
        bad = vstar[x1] - vstar[sel] > FP_ATOL
        for x in sel[bad]:
            out.append((int(l[x]), int(d[x]), j, int(tau[x, j])))
    return out


def test_claim2_fails_only_where_a_new_alert_appears(case):
    p, model, _mdp, _part, vstar = case
    viol = _claim2_violations(p, model, vstar)
    if p.allow_empty_loiter:
        assert viol == [], "with loitering allowed everywhere, V* is monotone (Claim 2)"
        return
    # Under the specification's model an alert is an opportunity: it opens the loiter
    # action (information reward) that an empty station forbids. So V* can increase when
    # tau_j goes 0 -> 1 (the alert pattern A changes). Within one alert pattern (tau_j >= 1
    # -> tau_j + 1) V* stays monotone, which is all the type-1 rule of Theorems 3-4 uses.
    assert viol, "the default model has Claim-2 violations on these instances"
    for l, d, j, t in viol:
        assert t == 0, f"violation with the same alert pattern at l={l}, d={d}, station {j}"
    if p.stations == (0, 3):  # stations far apart: only at the UAV's own station
        assert all((l, d) == (p.stations[j], 0) for l, d, j, _ in viol)


def test_lemma3_cardinality_against_full_mdp_rows(case):
    p, _model, mdp, part, _ = case
    agg = BellmanRows.aggregate(mdp, part, "max")
    counts = np.zeros((p.n_partitions, 3), dtype=int)
    np.add.at(counts, (agg.owner, agg.action), 1)
    lemma = lemma3_cardinality(p)
    assert np.array_equal(lemma.construction, counts)
    tb = partition_components(p)[:, -1]
    expect = np.zeros_like(lemma.differs)
    if p.Gamma >= 2:
        expect[:, 2] = lemma.type1 & (tb == p.Gamma)
    else:
        expect[:, 2] = lemma.type1  # Gamma = 1: one tuple, Lemma 3 also says taubar = 1
        expect[:, 2] &= tb != 1
    assert np.array_equal(lemma.differs, expect), "differs exactly where the Gamma cap merges"
    assert lemma.construction[lemma.differs].tolist() == [p.Gamma - 1] * int(lemma.n_differ)


def test_lemma3_paper_count_of_differences():
    p = PatrolParams()
    lemma = lemma3_cardinality(p)
    # type-1 with taubar = Gamma: l in Omega (4), w = +-1, A_l = 1 and another alert (7)
    assert lemma.n_differ == 4 * 2 * 7
    s = lemma.summary()
    assert s["differing_taubar_values"] == [15] and s["differing_all_type1_loiter"]


@pytest.mark.parametrize("cls", [UBLP, LBLP])
@pytest.mark.parametrize("solver", ["HIGHS", "CLARABEL"])
def test_lp_solution_equals_fixed_point(cls, solver):
    p = PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4)
    lp = cls(p)
    fp = lp.fixed_point(tol=DP_TOL)
    res = lp.solve(solver)
    scale = max(1.0, np.abs(fp).max())
    tol = 1e-9 if solver == "HIGHS" else 1e-6
    assert np.abs(res.values - fp).max() <= tol * scale, f"{solver} vs fixed point (rtol {tol})"
    assert lp.partition_components().shape == (p.n_partitions, 4 + p.m)


def test_bad_kind_raises():
    with pytest.raises(ValidationError, match="kind"):
        patrol_rows(PatrolParams(N=3, stations=(1,), D=1, Gamma=2), "middle")


def test_eight_stations_without_enumerating_states():
    p = PatrolParams(N=24, stations=tuple(range(0, 24, 3)), D=5, Gamma=12)
    assert p.n_states == 41_665_015_288
    rows = patrol_rows(p, "lower")
    assert rows.n_vars == p.n_partitions == 207_928
    assert rows.n_rows == 2 * p.n_partitions + int((np.diff(rows.indptr) == 3).sum())


def test_bounds_command_on_the_small_instance(tmp_path):
    from lpbounds.cli.main import main

    out = tmp_path / "b.json"
    assert main(["bounds", "models/patrol-small.toml", "--json", str(out)]) == 0
    import json

    res = json.loads(out.read_text())
    p = PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4)
    assert (res["n_states"], res["n_partitions"]) == (320, 176)
    # independent: RLP and NLP optima from the full MDP's aggregated rows
    model = PatrolModel(p)
    mdp, part = model.mdp(), model.partition()
    rlp = solve_exact(BellmanRows.aggregate(mdp, part, "max"), tol=DP_TOL).values
    nlp = solve_game(BellmanRows.aggregate(mdp, part, "min"), tol=DP_TOL).values
    gap = rlp - nlp
    # the command's fixed points use the default DP tolerance (1e-10 x value scale)
    assert res["gap"]["max"] == pytest.approx(gap.max(), abs=1e-9)
    assert res["gap"]["min"] == pytest.approx(gap.min(), abs=1e-9)
    assert res["UBLP"]["lp"]["agrees"] and res["LBLP"]["lp"]["agrees"]
    assert res["lemma3"]["pairs_differing"] == 4  # 2 stations x 2 directions, taubar = 4


# ---------------------------------------------------------------------- action sets
def test_allowed_actions_are_constant_on_each_partition(case):
    """The NLP keeps (i, u) only if u is allowed at every state of S_i. On the patrol
    partitions the allowed actions are a function of the key (l, d, A_l), so that rule
    drops nothing and LBLP's one row per allowed (partition, action) has no (i, u) the
    rule would drop: checked state by state against the full MDP's mask."""
    p, _model, mdp, part, _ = case
    keys = partition_keys(p)
    np.testing.assert_array_equal(mdp.allowed, keys.allowed[part.labels])
    assert not mdp.allowed.all() or p.allow_empty_loiter, "the spec model forbids some loiter"
    pairs = {(int(o), int(a)) for o, a in zip(*np.nonzero(keys.allowed), strict=True)}
    rows = BellmanRows.aggregate(mdp, part, "min")
    assert {(int(o), int(a)) for o, a in zip(rows.owner, rows.action, strict=True)} == pairs


def test_lblp_equals_nlp_of_full_mdp_and_bounds_v_star_on_patrol_small():
    """models/patrol-small.toml: LBLP (built from keys) against the NLP class on the full
    MDP (the masked rule applied), both certified, and both below min V* on each part."""
    from lpbounds.certification.certificate import certify
    from lpbounds.formulations import NLP
    from lpbounds.patrol.instance import params_from_instance

    p = params_from_instance("models/patrol-small.toml")
    assert not p.allow_empty_loiter
    model = PatrolModel(p)
    mdp, part = model.mdp(), model.partition()
    assert not mdp.allowed.all(), "loiter at an empty station is forbidden: masks present"
    nlp = NLP(mdp, part).solve("strategy-iteration")
    assert nlp.converged, nlp.summary()
    lb_rows = patrol_rows(p, "lower")
    lb = certify(lb_rows, LBLP(p).fixed_point(tol=DP_TOL), operator="max")
    # Theorem 3: the same optimum; each side is certified, so the brackets must meet
    assert (nlp.lower_values <= lb.upper).all() and (lb.lower <= nlp.upper_values).all()
    assert max(lb.width, float((nlp.upper_values - nlp.lower_values).max())) <= 1e-9
    # V* of the full MDP (policy iteration) with its own error bound
    ex = solve_exact(mdp, method="pi")
    vmin_hi = part.aggregate(ex.values + ex.error_bound, "min")
    assert (nlp.lower_values <= vmin_hi).all() and (lb.lower <= vmin_hi).all()
    # here the claim is even *proven*: w*'s certified upper end is below V*'s certified
    # lower end on every partition (measured: by 1.2e-5 at least)
    vmin_lo = part.aggregate(ex.values - ex.error_bound, "min")
    assert (nlp.upper_values <= vmin_lo).all() and (lb.upper <= vmin_lo).all()
