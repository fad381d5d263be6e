"""The NLP (eq. 25) as cvxpy models: ``NLP(...).problem`` (the big-M
MILP) and ``NLP(...).master`` (the cutting-plane master LP, updated round by round).

References independent of the package's NLP code: ``reference_w`` (value iteration by plain
loops over the member states of each partition, in ``test_nlp``), the two-state masked case
derived by hand (``test_nlp_masks``), and a count of the distinct successor tuples of
``T(i, u)`` by Python sets.
"""

from __future__ import annotations

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.formulations import NLP, NLPMILP
from lpbounds.formulations.nlp.cuts import NLPMaster
from lpbounds.model.partition import Partition

from .test_nlp import check_result, reference_w
from .test_nlp_masks import two_state_mdp

#: instances small enough for HiGHS' branch and bound at its default settings
SMALL = [(8, 2, 2, 3, 0), (10, 2, 2, 3, 1), (12, 2, 3, 4, 2)]


def _instance(n, a, l_out, m, seed, masked=False):
    mdp = lb.garnet(n, a, l_out, 0.9, seed=seed)
    if masked:  # forbid action 1 on a third of the states (action 0 stays everywhere)
        allowed = np.ones((n, a), dtype=bool)
        allowed[np.random.default_rng(seed).random(n) < 0.35, 1] = False
        mdp = lb.FiniteMDP(
            mdp.successors, mdp.probabilities, np.where(allowed, mdp.rewards, 0.0),
            mdp.discount, allowed,
        )  # fmt: skip
    return mdp, lb.random_partition(n, m, seed=seed)


def _n_terms(mdp, part):
    """Distinct successor tuples of each (i, u) kept by eq. 25 (u allowed on all of S_i)."""
    counts = []
    for i in range(part.n_partitions):
        states = np.flatnonzero(part.labels == i)
        for u in range(mdp.n_actions):
            if not mdp.allowed[states, u].all():
                continue
            tuples = set()
            for x in states:
                succ = part.labels[mdp.successors[x, u]]
                prob = np.broadcast_to(mdp.probabilities, mdp.successors.shape)[x, u]
                dist: dict[int, float] = {}
                for k, p in zip(succ, prob, strict=True):
                    if p > 0:
                        dist[int(k)] = dist.get(int(k), 0.0) + float(p)
                tuples.add(tuple(sorted((k, round(p, 12)) for k, p in dist.items())))
            counts.append(len(tuples))
    return np.array(counts)


@pytest.mark.parametrize("masked", [False, True], ids=["plain", "masked"])
@pytest.mark.parametrize("spec", SMALL, ids=lambda s: "n{}-A{}-L{}-M{}-s{}".format(*s))
def test_problem_solve_with_highs_gives_c_w_star(spec, masked):
    mdp, part = _instance(*spec, masked=masked)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    opt = float(nlp.cost @ ref)
    value = nlp.problem.solve(solver="HIGHS")
    assert nlp.problem.status == "optimal"
    si = NLP(mdp, part).solve("strategy-iteration")
    assert check_result(mdp, part, si, ref) == "optimal"  # its bracket, both ways
    # the solver's MILP tolerances (feasibility 1e-7 on O(1) rows): 1e-6 of the scale
    tol = 1e-6 * nlp.scale * float(nlp.cost.sum())
    assert si.lower_bound - tol <= value <= si.upper_bound + tol, (value, si.summary())
    assert abs(value - opt) <= tol
    # with c > 0 the minimiser is w* itself (Fact 2), within the same tolerance
    assert np.abs(nlp.milp.w.value - ref).max() <= 1e-6 * nlp.scale
    # one boolean per term of each multi-term disjunction, one selector row per such (i, u)
    terms = _n_terms(mdp, part)
    n_multi = int(terms[terms >= 2].sum())
    assert (0 if nlp.milp.z is None else nlp.milp.z.size) == n_multi
    if n_multi:
        assert nlp.milp.constraints["select"].size == int((terms >= 2).sum())
        z = np.round(nlp.milp.z.value)
        assert set(np.unique(z)) <= {0.0, 1.0}


def test_two_state_masked_case_as_a_cvxpy_model():
    """Hand-derived: the forbidden (0, 1) is dropped, w* = 0 (not 10)."""
    nlp = NLP(two_state_mdp(), Partition(np.array([0, 0])))
    assert nlp.problem.solve(solver="HIGHS") == pytest.approx(0.0, abs=1e-9)
    assert nlp.milp.z is None and list(nlp.milp.constraints) == [
        "single",
        "box_lower",
        "box_upper",
    ]


def test_milp_box_is_certified_and_contains_w_star():
    mdp, part = _instance(12, 2, 3, 4, 2)
    nlp = NLP(mdp, part)
    ref = reference_w(mdp, part)
    milp = nlp.milp
    assert isinstance(milp, NLPMILP) and nlp.milp is milp  # built once
    assert (milp.lo <= ref).all() and (ref <= milp.hi).all()
    # the box is certified, yet not vacuous: finite, within the value range +-max|R|/(1-lam)
    # (its ends are certificates at the constant -max|R|/(1-lam) and at a strategy's value)
    assert np.isfinite(milp.lo).all() and np.isfinite(milp.hi).all()
    assert (milp.hi - milp.lo).max() <= 2 * np.abs(mdp.rewards).max() / (1 - 0.9) * (1 + 1e-9)
    assert (milp.big_m >= 0).all()
    groups = list(milp.constraints)
    assert groups[-2:] == ["box_lower", "box_upper"]
    assert set(groups) <= {"single", "disjunction", "select", "box_lower", "box_upper"}
    assert "disjunction" in groups and milp.constraints["disjunction"].size == milp.z.size


@pytest.mark.parametrize("backend", ["highspy", "cvxpy"])
def test_master_is_updated_round_by_round(backend):
    mdp, part = _instance(12, 2, 3, 4, 2)
    ref = reference_w(mdp, part)
    nlp = NLP(mdp, part)
    first = nlp.master
    assert isinstance(first, NLPMaster) and first.n_cuts == 0 and "cuts" not in first.constraints
    opt = float(nlp.cost @ ref)
    tol = 1e-7 * nlp.scale * float(nlp.cost.sum())
    assert first.solve("HIGHS").objective <= opt + tol  # a relaxation: a lower bound
    res = nlp.solve("cutting-planes", cuts="lift-and-project", backend=backend, max_iter=15)
    check_result(mdp, part, res, ref)  # the incumbent's certificate, whatever its status
    last = nlp.master
    assert last is not first and last.n_cuts == res.cuts
    if res.cuts:
        assert last.constraints["cuts"].size == res.cuts
        np.testing.assert_allclose(last.data.A[last.n_single :].toarray(), res.extra["cut_alpha"])
    bound = last.solve("HIGHS").objective
    # every cut is valid: the last master still bounds c'w* from below, and it is at least
    # the loop's own (earlier) master bound
    assert bound <= opt + tol
    assert bound >= res.log[-1].lower - tol


def test_master_add_cuts_keeps_the_variable():
    mdp, part = _instance(10, 2, 2, 3, 1)
    master = NLP(mdp, part).master
    w = master.w
    master.add_cuts(np.ones((1, 3)), np.array([-1e9]))
    assert master.w is w and master.n_cuts == 1 and master.constraints["cuts"].size == 1
    assert len(master.problem.constraints) == len(master.constraints)
