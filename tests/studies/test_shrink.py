"""lpbounds.studies.shrink: smaller instances that keep a verdict, and their model files."""

from __future__ import annotations

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.model.instances import load_instance
from lpbounds.model.mdp import FiniteMDP
from lpbounds.model.partition import Partition
from lpbounds.studies import shrink as sh
from tests import _independent as ind


def test_a_size_predicate_is_shrunk_to_its_minimum():
    """keep = "at least 3 states and 2 blocks": the smallest instance has exactly that, one
    action, one outcome, zero rewards and discount 0 (every smaller step is refused)."""
    mdp = lb.garnet(20, 3, 4, 0.93, seed=4, allowed_fraction=0.7, reward_range=(-3.0, 7.0))
    part = lb.random_partition(20, 6, seed=1)
    calls = []

    def keep(m, p):
        calls.append(m.n_states)
        return m.n_states >= 3 and p.n_partitions >= 2

    out = sh.shrink(mdp, part, keep, max_evaluations=10_000)
    assert sh.size_of(out.mdp, out.partition) == {
        "states": 3,
        "actions": 1,
        "outcomes": 1,
        "blocks": 2,
    }
    assert np.all(out.mdp.rewards == 0.0) and out.mdp.discount == 0.0
    assert calls[0] == 20  # the start is tested first (not counted as a candidate)
    assert out.evaluations == len(calls) - 1 and 0 < out.steps <= out.evaluations
    assert out.shown and keep(out.mdp, out.partition)


def test_the_result_always_passes_and_the_budget_is_kept():
    mdp = lb.garnet(15, 2, 3, 0.8, seed=2)
    part = lb.random_partition(15, 4, seed=3)
    rng = np.random.default_rng(0)
    verdicts = {}

    def keep(m, p):  # an arbitrary (but fixed per candidate) verdict
        key = (m.n_states, p.n_partitions, m.n_actions, m.n_outcomes, float(m.rewards.sum()))
        return verdicts.setdefault(key, bool(rng.random() < 0.5))

    out = sh.shrink(mdp, part, keep, max_evaluations=40)
    assert out.evaluations <= 40
    if out.steps:
        key = (
            out.mdp.n_states,
            out.partition.n_partitions,
            out.mdp.n_actions,
            out.mdp.n_outcomes,
            float(out.mdp.rewards.sum()),
        )
        assert verdicts[key] is True
    else:  # nothing kept: the input itself
        assert out.mdp is mdp and out.partition is part
    none = sh.shrink(mdp, part, lambda m, p: False)
    assert none.steps == 0 and none.mdp is mdp


def test_a_start_that_does_not_show_the_verdict_is_not_shrunk():
    """The start is re-tested: a record may say "violated" where the instance shows
    nothing (edited on disk, a solver that answers differently now); then no candidate is
    tried and ``shown`` is False, so no counterexample is written from it."""
    mdp = lb.garnet(6, 2, 2, 0.5, seed=1)
    part = lb.random_partition(6, 2, seed=0)
    calls = []

    def keep(m, p):
        calls.append(m.n_states)
        return False

    out = sh.shrink(mdp, part, keep)
    assert calls == [6] and not out.shown
    assert (out.evaluations, out.steps) == (0, 0) and out.mdp is mdp and out.partition is part
    assert sh.shrink(mdp, part, lambda m, p: True).shown


def test_shrinking_keeps_a_violated_claim_checked_independently():
    """keep = "Phi v* differs from V* by more than both error bounds" (dense PI, no
    lpbounds DP): the shrunk instance still shows it, with at most 3 states."""

    def differs(m, p):
        P = ind.dense_transitions(m.successors, m.probabilities)
        R = np.where(m.allowed, m.rewards, 0.0)
        vstar = ind.policy_iteration(P, R, m.allowed, m.discount)
        vbar = ind.rlp_optimum(P, R, m.allowed, m.discount, p.labels)
        gap = np.abs(p.lift(vbar.values) - vstar.values).max()
        return bool(gap > vstar.error + vbar.error)

    mdp = lb.garnet(18, 2, 3, 0.9, seed=8)
    part = lb.random_partition(18, 3, seed=8)
    assert differs(mdp, part)
    out = sh.shrink(mdp, part, differs)
    assert out.mdp.n_states <= 3 and differs(out.mdp, out.partition)


def test_removed_states_become_self_loops():
    """A chain 0 -> 1 -> 2 -> 0: dropping states keeps every successor inside the model."""
    succ = np.array([[[1]], [[2]], [[0]]])
    mdp = FiniteMDP(succ, [1.0], np.array([[1.0], [2.0], [3.0]]), 0.5)
    part = Partition([0, 1, 2])
    seen = []

    def keep(m, p):
        seen.append(np.asarray(m.successors).copy())
        return m is mdp  # only the start shows it: every candidate is tested, none kept

    sh.shrink(mdp, part, keep)
    two = [s for s in seen if s.shape[0] == 2]
    assert two and all(s.max() <= 1 for s in two)
    # dropping state 2 (0 -> 1 kept, 1 -> 2 becomes 1 -> 1)
    assert any(np.array_equal(s[:, 0, 0], [1, 1]) for s in two)


def test_model_files_read_back_bit_for_bit(tmp_path):
    for mdp in (
        lb.garnet(7, 3, 2, 0.37, seed=5, allowed_fraction=0.6, reward_range=(-1e6, 1e-6)),
        lb.garnet(5, 2, 3, 0.9999, seed=6, shared_probabilities=True),
        FiniteMDP([[[0]], [[1]]], [1.0], [[0.1 + 0.2], [1e-300]], 0.0),
    ):
        part = lb.random_partition(mdp.n_states, 2, seed=0)
        path = sh.write_model(tmp_path / "m.toml", mdp, part, ["a header", "two lines"])
        text = path.read_text()
        assert text.startswith('# a header\n# two lines\n[model]\nkind = "explicit"')
        inst = load_instance(str(path))
        back = inst.mdp()
        for attr in ("successors", "probabilities"):
            assert np.array_equal(getattr(back, attr), getattr(mdp, attr))
            assert getattr(back, attr).shape == getattr(mdp, attr).shape
        assert np.array_equal(back.allowed, mdp.allowed) and back.discount == mdp.discount
        assert np.array_equal(back.rewards[mdp.allowed], mdp.rewards[mdp.allowed])
        assert np.array_equal(inst.partition().labels, part.labels)


def test_bad_input_is_refused():
    mdp = lb.garnet(5, 1, 1, 0.5, seed=0)
    with pytest.raises(ValidationError, match="partition has 4 states; the MDP has 5"):
        sh.shrink(mdp, Partition([0, 1, 0, 1]), lambda m, p: True)
