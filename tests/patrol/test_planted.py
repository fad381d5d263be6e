"""Every check of the reproduction on a planted violation of known size (issue 35).

The reproduction reports Theorems 3-4, Lemma 3, Claim 2, the sandwich and the policy
chain as numbers beside a tolerance; on the paper's instance they hold, so a check that
always said "holds" (a difference reported as 0, a margin clipped at 0, a count of 0)
would pass every test that only runs the instance. Here each check is fed the step
results of patrol-small with one planted violation whose size is known from the plant
alone (a bound lowered by 1, a value raised by 1 above its neighbour, one count changed)
and must report both the violation and its size.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lpbounds.patrol.bounds import lemma3_cardinality
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.reproduce import (
    Tracker,
    VStar,
    build_model,
    check_claims,
    check_general,
    check_lemma3,
    check_sandwich,
    claim_pairs,
    inequality,
    lemma3_summary,
    policy_chain,
    solve_bounds,
    solve_vstar,
)

SMALL = "models/patrol-small.toml"


@pytest.fixture(scope="module")
def steps():
    """The reproduction's step results on patrol-small, up to the bounds."""
    params = params_from_instance(SMALL)
    tr = Tracker()
    built, _ = build_model(params, tr)
    vs = solve_vstar(built, tr)
    bounds = solve_bounds(params, "HIGHS", tr)
    return params, built, vs, bounds


# ---------------------------------------------------------------------- Theorems 3-4
@pytest.mark.parametrize("general", ["aggregate", "residual"])
def test_theorem4_on_ublp_lowered_by_one(steps, general):
    """UBLP's optimum lowered by 1 everywhere is 1 from RLP's: measured (aggregate: the
    RLP of the full MDP solved exactly), or bounded by the residual of RLP's operator,
    ``(1 - lambda) / (1 - kappa) = 1`` (``T(v - 1) = T v - lambda``: stochastic rows).
    Theorem 3 is untouched and still holds."""
    _, built, _, bounds = steps
    planted = dataclasses.replace(bounds, v_up=bounds.v_up - 1.0)
    t = check_general(built, planted, general, Tracker()).summary
    assert t.theorem4_max_abs_diff == pytest.approx(1.0, abs=1e-8)
    assert t.theorem4_max_abs_diff > t.tolerance_theorem4, "the difference must be reported"
    assert t.theorem3_max_abs_diff <= t.tolerance_theorem3
    if general == "residual":
        lam = built.mdp.discount
        assert t.rlp_residual == pytest.approx(1.0 - lam, abs=1e-8)
        assert t.rlp_distance_bound == t.theorem4_max_abs_diff
        # the residual also proves the difference: ||v - v_RLP|| >= residual / (1 + kappa)
        assert t.rlp_residual / (1.0 + lam) > t.tolerance_theorem4


@pytest.mark.parametrize("general", ["aggregate", "residual"])
def test_theorem3_on_lblp_lowered_by_a_half(steps, general):
    """LBLP's optimum lowered by 0.5: the NLP's game value is 0.5 from it (``G(w - c) = G w
    - lambda c``); Theorem 4 still holds."""
    _, built, _, bounds = steps
    planted = dataclasses.replace(bounds, w_low=bounds.w_low - 0.5)
    t = check_general(built, planted, general, Tracker()).summary
    assert t.theorem3_max_abs_diff == pytest.approx(0.5, abs=1e-8)
    assert t.theorem3_max_abs_diff > t.tolerance_theorem3
    assert t.theorem4_max_abs_diff <= t.tolerance_theorem4
    if general == "residual":
        assert t.nlp_residual == pytest.approx(0.5 * (1.0 - built.mdp.discount), abs=1e-8)


def test_theorems_hold_unplanted(steps):
    """The control: the same call without a plant reports both theorems within their
    tolerances (so the plants above are what the checks see)."""
    _, built, _, bounds = steps
    t = check_general(built, bounds, "aggregate", Tracker()).summary
    assert t.theorem4_max_abs_diff <= t.tolerance_theorem4
    assert t.theorem3_max_abs_diff <= t.tolerance_theorem3


# ---------------------------------------------------------------------- the sandwich
def _plant_vstar(vs: VStar, state: int, value: float) -> VStar:
    v = vs.values.copy()
    v[state] = value
    return dataclasses.replace(vs, values=v)


def test_sandwich_lower_side_on_v_star_planted_below_w_star(steps):
    """``V*`` at one state set to ``w*(i) - 1``: the lower inequality ``w*(i) <= V*(x)``
    fails there alone, by 1, and its worst state is that state; the certified margin
    (from LBLP's certified bracket) is about -1 as well."""
    params, built, vs, bounds = steps
    x = int(np.argmax(vs.values))
    w = float(bounds.w_low[built.labels[x]])
    sw = check_sandwich(params, built, _plant_vstar(vs, x, w - 1.0), bounds, Tracker()).sandwich
    assert sw.lower.violations == 1 and sw.lower.worst_state["state"] == x
    assert sw.lower.margin == pytest.approx(-1.0, abs=1e-12) == sw.lower_margin
    assert sw.upper.violations == 0 and sw.upper.margin > 0
    assert sw.certified_lower_margin == pytest.approx(-1.0, abs=1e-6)


def test_sandwich_upper_side_on_v_star_planted_above_v_star_of_ublp(steps):
    """``V*`` at one state set to ``v*(i) + 2``: ``V*(x) <= v*(i)`` fails there, by 2."""
    params, built, vs, bounds = steps
    x = int(np.argmin(vs.values))
    v = float(bounds.v_up[built.labels[x]])
    sp = check_sandwich(params, built, _plant_vstar(vs, x, v + 2.0), bounds, Tracker())
    sw = sp.sandwich
    assert sw.upper.violations == 1 and sw.upper.worst_state["state"] == x
    assert sw.upper.margin == pytest.approx(-2.0, abs=1e-12) == sw.upper_margin
    assert sw.lower.violations == 0 and sw.lower.margin > 0
    assert sw.certified_upper_margin == pytest.approx(-2.0, abs=1e-6)
    # the chain's last link is the same inequality
    link = sp.policy.chain["vstar_le_vup"]
    assert (link.violations, link.worst_state["state"]) == (1, x)
    assert link.margin == pytest.approx(-2.0, abs=1e-12)


def test_inequality_counts_only_beyond_its_tolerance():
    """``a <= b`` with ``a - b`` = 0.5, 1, 3 at three states and tolerance 0.75: two
    violations, margin -3 at the third state."""
    comps = np.zeros((4, 5), dtype=np.int64)
    a = np.array([0.5, 1.0, 3.0, -1.0])
    ineq = inequality(a, np.zeros(4), 0.75, comps, [0, 3])
    assert (ineq.violations, ineq.margin, ineq.tolerance) == (2, -3.0, 0.75)
    assert ineq.worst_state["state"] == 2


# ---------------------------------------------------------------------- the policy chain
@pytest.mark.parametrize(
    ("link", "which", "size"),
    [("vlow_le_vsub", 0, 1.0), ("vsub_le_vstar", 1, 0.25), ("vstar_le_vup", 2, 4.0)],
)
def test_policy_chain_on_one_planted_link(steps, link, which, size):
    """``V_low <= V_sub <= V* <= V_up`` fed arrays that satisfy it with room, except one
    link broken at one state by ``size``: that link alone is violated there, by ``size``.
    The arrays are the run's (``V*``, lifted bounds) with ``V_sub = V*``."""
    _, built, vs, bounds = steps
    lab, x = built.labels, 7
    vecs = [bounds.w_low[lab], vs.values.copy(), vs.values.copy(), bounds.v_up[lab]]
    vecs[which][x] = vecs[which + 1][x] + size  # the left side above the right by `size`
    chain = policy_chain(*vecs, errors=(1e-9, 1e-9, 1e-9, 1e-9), comps=built.comps, stations=[0, 3])
    for key, ineq in chain.items():
        if key == link:
            assert (ineq.violations, ineq.worst_state["state"]) == (1, x), key
            assert ineq.margin == pytest.approx(-size, abs=1e-12), key
            assert ineq.tolerance == 2e-9
        else:
            assert ineq.violations == 0, key


# ---------------------------------------------------------------------- Lemma 3
def test_lemma3_on_a_planted_count(steps):
    """One ``|T(i, u)|`` of the construction raised by 1 where it agreed with the formula:
    one more differing pair, named with both counts, and the full MDP's rows (the real
    construction) differ from it at exactly that pair."""
    params, built, _, _ = steps
    card = lemma3_cardinality(params)
    names = built.mdp.action_names
    base = lemma3_summary(card, card.construction, names, 100)
    assert base.full_mdp_rows_equal_construction and base.full_mdp_rows_differ_pairs == 0
    i, a = (int(t) for t in np.argwhere((card.construction == card.paper) & (card.paper > 0))[0])
    planted = card.construction.copy()
    planted[i, a] += 1
    lem = lemma3_summary(
        dataclasses.replace(card, construction=planted), card.construction, names, 100
    )
    assert lem.pairs_differing == base.pairs_differing + 1
    assert lem.full_mdp_rows_equal_construction is False
    assert lem.full_mdp_rows_differ_pairs == 1
    ex = [e for e in lem.examples if (e["partition"], e["action"]) == (i, names[a])]
    assert ex == [
        {
            "partition": i,
            "action": names[a],
            "taubar": int(card.taubar[i]),
            "construction": int(card.paper[i, a]) + 1,
            "paper": int(card.paper[i, a]),
        }
    ]


def test_lemma3_full_mdp_counts_planted(steps):
    """Counts from the full MDP off at three pairs: three differing pairs reported."""
    params, built, _, _ = steps
    card = lemma3_cardinality(params)
    counted = card.construction.copy()
    counted[:3, 0] += 2
    lem = lemma3_summary(card, counted, built.mdp.action_names, 10)
    assert lem.full_mdp_rows_equal_construction is False
    assert lem.full_mdp_rows_differ_pairs == 3
    assert (
        lem.pairs_differing
        == lemma3_summary(card, None, built.mdp.action_names, 10).pairs_differing
    )


def test_lemma3_step_passes_the_full_mdp_counts_through(steps):
    """The pipeline's step (``check_lemma3``) fed a ``General`` whose counts from the full MDP
    are off at two pairs: it reports two differing pairs, and none without counts."""
    params, built, _, bounds = steps
    general = check_general(built, bounds, "residual", Tracker())  # counts nothing
    assert check_lemma3(params, built, general, 3, Tracker()).full_mdp_rows_differ_pairs is None
    counted = lemma3_cardinality(params).construction.copy()
    counted[-2:, 1] += 1
    planted = dataclasses.replace(general, counted=counted)
    lem = check_lemma3(params, built, planted, 3, Tracker())
    assert lem.full_mdp_rows_equal_construction is False
    assert lem.full_mdp_rows_differ_pairs == 2


# ---------------------------------------------------------------------- Claim 2
def _pairs_by_loops(comps, stations, gamma):
    """Every ``(x1, x2, j)`` with ``x1 = x2 + e_j``, by a plain loop over the states."""
    index = {tuple(int(c) for c in row): i for i, row in enumerate(comps)}
    out = []
    for x2, row in enumerate(comps):
        c = tuple(int(t) for t in row)
        for j in range(len(stations)):
            tau = list(c[3:])
            if tau[j] >= gamma:
                continue
            tau[j] += 1
            x1 = index.get((*c[:3], *tau))
            if x1 is not None:
                out.append((x1, x2, j))
    return out


def test_claim2_on_one_state_raised_by_one(steps):
    """``V*`` = 0 except 1 at one state ``x``: every pair ``x1 = x2 + e_j`` with ``x1 = x``
    has excess 1 (a violation, tolerance 0), every other pair excess 0 or -1. The counts
    are those of a plain loop over the states; the largest excess is 1."""
    params, built, vs, _ = steps
    pairs = _pairs_by_loops(built.comps, params.stations, params.Gamma)
    x = max({p[0] for p in pairs}, key=lambda s: sum(p[0] == s for p in pairs))
    planted = np.zeros_like(vs.values)
    planted[x] = 1.0
    cl = check_claims(params, built, VStar(vs.summary, planted, vs.policy, 0.0), 5, Tracker())
    mine = [p for p in pairs if p[0] == x]
    new_alert = [p for p in mine if built.comps[p[1], 3 + p[2]] == 0]
    assert cl.pairs == len(pairs) and cl.tolerance == 0.0
    assert cl.violations == len(mine) >= 2
    assert cl.max_excess == 1.0
    assert cl.violations_new_alert == len(new_alert)
    assert cl.violations_same_alert_status == len(mine) - len(new_alert)
    assert {e["x1"]["state"] for e in cl.examples} == {x}
    assert all(e["excess"] == 1.0 for e in cl.examples)


def test_claim2_partition_level_on_one_partition_raised(steps):
    """``V*`` = 0 except 1 on every state of one partition ``P``: the partition-level claim
    fails exactly on the pairs whose higher partition is ``P``, by 1 (and the state-level
    claim on the pairs leaving ``P``)."""
    params, built, vs, _ = steps
    pc = built.pcomps
    m = params.m
    key = {tuple(int(t) for t in row): i for i, row in enumerate(pc)}
    # pairs (hi, lo): same (l, w, d, A), taubar(hi) = taubar(lo) + 1, taubar(lo) >= 1
    pairs = []
    for lo, row in enumerate(pc):
        tb = int(row[-1])
        if 1 <= tb < params.Gamma:
            hi = key.get((*(int(t) for t in row[: 3 + m]), tb + 1))
            if hi is not None:
                pairs.append((hi, lo))
    target = pairs[0][0]
    planted = np.where(built.labels == target, 1.0, 0.0)
    cl = check_claims(params, built, VStar(vs.summary, planted, vs.policy, 0.0), 5, Tracker())
    assert cl.partition_pairs == len(pairs)
    assert cl.partition_violations == sum(h == target for h, _ in pairs) >= 1
    assert cl.partition_max_excess == 1.0
    assert {tuple(e["higher"]) for e in cl.partition_examples} == {tuple(pc[target].tolist())}


def test_claim_pairs_are_the_loops_pairs(steps):
    """The pairs the check iterates are the plain loop's (so the counts above compare
    like with like)."""
    params, built, _, _ = steps
    mine = {(int(a), int(b), j) for j, x1, x2 in claim_pairs(built.pm, built.comps)
            for a, b in zip(x1, x2, strict=True)}  # fmt: skip
    assert mine == set(_pairs_by_loops(built.comps, params.stations, params.Gamma))
