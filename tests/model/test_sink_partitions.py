"""Partitions built for a model keep its sink (the absorbing end state a converter adds)
in a set of its own: ``random_partition(mdp, M)``, ``block_partition(mdp, size)``, the
``[partition] kind = "random"`` table and the campaigns' kinds; and ``sink_block`` names
the set of a partition that mixes the sink with live states (issue 40, item 4).

Models with a sink are drawn at random through the public converter that adds one
(``FiniteMDP.from_matrices(..., terminal=True)``: rows summing to less than one send the
rest to the sink).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.model import shelf
from lpbounds.model.checks import sink_block
from lpbounds.model.instances import load_instance
from lpbounds.studies import campaign


def model_with_sink(n: int, n_actions: int, seed: int, end: float = 0.3) -> lb.FiniteMDP:
    """A random model of ``n`` live states whose rows end the episode with probability
    ``end`` (to the sink the converter appends: ``n + 1`` states)."""
    rng = np.random.default_rng(seed)
    P = [rng.dirichlet(np.ones(n), size=n) * (1.0 - end) for _ in range(n_actions)]
    R = rng.uniform(-1.0, 1.0, size=(n, n_actions))
    mdp = lb.FiniteMDP.from_matrices(P, R, 0.9, terminal=True)
    assert mdp.sink and mdp.n_states == n + 1
    return mdp


@st.composite
def sink_models(draw):
    n = draw(st.integers(1, 30))
    mdp = model_with_sink(n, draw(st.integers(1, 3)), draw(st.integers(0, 2**31 - 1)))
    m = draw(st.integers(2, n + 1))
    return mdp, m, draw(st.integers(0, 2**31 - 1))


@settings(max_examples=60)
@given(sink_models())
def test_random_partition_of_a_model_keeps_its_sink_alone(case):
    mdp, m, seed = case
    part = lb.random_partition(mdp, m, seed=seed)
    assert part.n_states == mdp.n_states  # every state covered, the sink too
    assert part.n_partitions == m and (part.sizes > 0).all()  # M sets, none empty
    sink = mdp.n_states - 1
    assert part.labels[sink] == m - 1 and part.sizes[m - 1] == 1  # the last set: the sink
    assert sink_block(mdp, part) is None
    # the live states split into the M - 1 others, each of them used
    assert set(part.labels[:sink].tolist()) == set(range(m - 1))


@settings(max_examples=40)
@given(st.integers(1, 40), st.integers(1, 3), st.data())
def test_a_model_without_a_sink_gets_the_partition_of_its_state_count(n, n_actions, data):
    mdp = lb.garnet(n, n_actions, 2, seed=data.draw(st.integers(0, 1000)))
    m = data.draw(st.integers(1, n))
    seed = data.draw(st.integers(0, 2**31 - 1))
    np.testing.assert_array_equal(
        lb.random_partition(mdp, m, seed=seed).labels, lb.random_partition(n, m, seed=seed).labels
    )


def test_a_model_with_a_sink_needs_two_sets():
    mdp = model_with_sink(4, 2, 0)
    with pytest.raises(ValidationError, match=r"n_partitions must lie in \[2, n_states=5\] \(the "):
        lb.random_partition(mdp, 1)
    with pytest.raises(ValidationError, match=r"n_partitions must lie in \[2, n_states=5\]"):
        lb.random_partition(mdp, 6)
    assert lb.random_partition(mdp, 5).n_partitions == 5  # singletons: the most there are


def test_sink_block_names_the_set_that_mixes_the_sink():
    mdp = model_with_sink(5, 2, 1)  # states 0..4 live, 5 the sink
    assert sink_block(mdp, lb.Partition([0, 0, 1, 1, 2, 1])) == 1  # with states 2 and 3
    assert sink_block(mdp, lb.Partition([2, 0, 1, 1, 0, 0])) == 0
    assert sink_block(mdp, lb.Partition([0, 0, 1, 1, 0, 2])) is None  # alone
    assert sink_block(lb.garnet(6, 2, 2), lb.Partition([0, 0, 1, 1, 2, 1])) is None  # no sink


def test_block_partition_of_a_model():
    mdp = model_with_sink(5, 1, 2)
    np.testing.assert_array_equal(shelf.block_partition(mdp, 2).labels, [0, 0, 1, 1, 2, 3])
    garnet = lb.garnet(5, 1, 2)
    np.testing.assert_array_equal(shelf.block_partition(garnet, 2).labels, [0, 0, 1, 1, 2])
    with pytest.raises(ValidationError, match="sink=True but the model has no sink"):
        shelf.block_partition(garnet, 2, sink=True)


def test_a_random_partition_table_keeps_the_sink_alone():
    pytest.importorskip("gymnasium")
    config = dict(load_instance("frozenlake").config)
    config["partition"] = {"kind": "random", "n_partitions": 5, "seed": 4}
    inst = load_instance(config, name="frozenlake-random")
    mdp, part = inst.mdp(), inst.partition()
    assert mdp.sink and part.n_partitions == 5 and sink_block(mdp, part) is None
    np.testing.assert_array_equal(part.labels, lb.random_partition(mdp, 5, seed=4).labels)


@pytest.mark.parametrize("kind", campaign.PARTITION_KINDS)
def test_every_campaign_kind_keeps_a_sink_alone(kind):
    for seed in range(5):
        mdp = model_with_sink(12, 2, seed)
        part = campaign._partition(kind, mdp, np.random.default_rng(seed))
        assert part.n_states == mdp.n_states
        assert sink_block(mdp, part) is None, (kind, seed, part.labels)
