"""A partition that mixes a model's sink with live states: accepted, but said so (a
PartitionWarning naming the set, at the caller's line, and a ``partition:`` line in the
result's summary), for every formulation over a partition; and what it costs on
FrozenLake, against ``V*`` by an independent dense policy iteration (issue 40, item 4).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.errors import LPBoundsWarning, PartitionWarning
from lpbounds.formulations import IB, LLP, NLP, RLP, SLP
from tests import _independent as ind
from tests.model.test_sink_partitions import model_with_sink

#: six live states and the sink (state 6) in set 1 with states 2 and 3
PLANTED = [0, 0, 1, 1, 2, 2, 1]

FORMULATIONS = {
    "RLP": lambda mdp, part: RLP(mdp, part),
    "SLP": lambda mdp, part: SLP(mdp, part, "uniform"),
    "IB": lambda mdp, part: IB(mdp, part, 2),
    "LLP": lambda mdp, part: LLP(mdp, part, np.zeros((mdp.n_states, mdp.n_actions))),
    "NLP": lambda mdp, part: NLP(mdp, part),
}


@pytest.mark.parametrize("name", FORMULATIONS)
def test_a_mixed_partition_warns_naming_its_set(name):
    mdp = model_with_sink(6, 2, 7)
    with pytest.warns(PartitionWarning) as caught:
        form = FORMULATIONS[name](mdp, lb.Partition(PLANTED))
    messages = [str(w.message) for w in caught if w.category is PartitionWarning]
    assert messages and all(
        m.startswith("partition: block 1 holds the sink (state 6, worth 0) and 2 live states")
        for m in messages
    ), messages
    assert all(w.filename == __file__ for w in caught)  # the caller's line, not lpbounds'
    assert issubclass(PartitionWarning, LPBoundsWarning)
    assert issubclass(PartitionWarning, UserWarning)
    summary = form.solve().summary()
    lines = [ln.strip() for ln in summary.splitlines() if ln.strip().startswith("partition:")]
    assert len(lines) == 1 and "block 1 holds the sink (state 6" in lines[0], summary


@pytest.mark.parametrize("labels", [[0, 0, 1, 1, 2, 1, 2], [0, 0, 1, 1, 0, 2, 0]])
def test_the_warning_names_the_set_that_holds_the_sink(labels):
    mdp = model_with_sink(6, 1, 8)
    block, others = labels[-1], labels.count(labels[-1]) - 1
    with pytest.warns(PartitionWarning, match=rf"block {block} holds the sink .* and {others} "):
        RLP(mdp, lb.Partition(labels))


@pytest.mark.parametrize("name", FORMULATIONS)
def test_the_sink_alone_or_no_sink_says_nothing(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails
        for mdp, part in (
            (model_with_sink(6, 2, 7), lb.Partition([0, 0, 1, 1, 2, 2, 3])),
            (lb.garnet(7, 2, 2, seed=1), lb.Partition(PLANTED)),
        ):
            summary = FORMULATIONS[name](mdp, part).solve().summary()
            assert "partition:" not in summary


def test_on_frozenlake_the_sink_alone_gives_a_bound_near_vstar():
    """RLP's upper bound over random partitions of FrozenLake (M = 5, seeds 0-9). Measured
    (HiGHS 1.16): the mean excess over ``V*`` of the user's 16 states is 0.50-0.57 with the
    sink alone, 9.1-24.4 with the partition of the state count (which mixes it, every seed
    here), 16-44 times more. Asserted with margin: at most 0.6 alone, at least 8 mixed, and
    12 times; both are upper bounds on the independent ``V*``."""
    pytest.importorskip("gymnasium")
    mdp = lb.load_instance("frozenlake").mdp()
    P = ind.dense_transitions(mdp.successors, mdp.probabilities)
    R = np.where(mdp.allowed, mdp.rewards, 0.0)
    ref = ind.policy_iteration(P, R, mdp.allowed, mdp.discount)
    vstar, live = ref.values, slice(0, mdp.n_user_states)
    for seed in range(10):
        alone = lb.random_partition(mdp, 5, seed=seed)
        mixed = lb.random_partition(mdp.n_states, 5, seed=seed)
        with pytest.warns(PartitionWarning):
            res_mixed = RLP(mdp, mixed).solve()
        res_alone = RLP(mdp, alone).solve()
        excess = {}
        for key, part, res in (("alone", alone, res_alone), ("mixed", mixed, res_mixed)):
            assert res.ok, (key, seed, res)
            upper = part.lift(res.upper_values)
            assert (upper >= vstar - ref.error).all(), (key, seed)  # a bound, both ways
            excess[key] = float((upper - vstar)[live].mean())
        assert excess["alone"] <= 0.6, (seed, excess)
        assert excess["mixed"] >= 8.0, (seed, excess)
        assert excess["mixed"] >= 12 * excess["alone"], (seed, excess)
