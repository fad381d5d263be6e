"""PatrolModel against the loop-based reference of the specification (tests/patrol/reference.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lpbounds import solve_exact
from lpbounds.errors import ValidationError
from lpbounds.patrol import PatrolModel, PatrolParams

from .reference import RefPatrol

SMALL = [
    dict(N=6, stations=(0, 3), D=2, Gamma=4),
    dict(N=5, stations=(0, 2, 3), D=2, Gamma=2),
    dict(N=3, stations=(1,), D=1, Gamma=2),
    dict(N=4, stations=(3, 0), D=3, Gamma=1),
]
IDS = ["N6m2", "N5m3", "N3m1", "N4m2-unsorted"]


def _pair(size, empty=False):
    params = PatrolParams(**size, allow_empty_loiter=empty)
    return PatrolModel(params), RefPatrol(**size, allow_empty_loiter=empty)


def _model_to_ref(model, ref):
    """ref index of every model state (via the components), checking a bijection."""
    comp = model.state_components()
    idx = np.array([ref.index[tuple(int(v) for v in row)] for row in comp])
    assert np.array_equal(np.sort(idx), np.arange(len(ref.states))), "states are a bijection"
    return idx


@pytest.mark.parametrize("size", SMALL, ids=IDS)
@pytest.mark.parametrize("empty", [False, True], ids=["spec", "empty-loiter"])
def test_mdp_identical_to_reference(size, empty):
    model, ref = _pair(size, empty)
    mdp = model.mdp()
    assert mdp.n_states == len(ref.states) == model.n_states
    to_ref = _model_to_ref(model, ref)
    trans = ref.transitions()
    probs = ref.probabilities()
    np.testing.assert_allclose(mdp.probabilities, probs, rtol=1e-15, atol=0)
    assert mdp.action_names == ("continue", "reverse", "loiter")
    for x in range(mdp.n_states):
        rx = ref.states[to_ref[x]]
        acts = ref.allowed(rx)
        assert list(np.flatnonzero(mdp.allowed[x])) == acts, f"allowed at {rx}"
        for a in acts:
            got = [int(to_ref[s]) for s in mdp.successors[x, a]]
            want = [j for j, _ in trans[(int(to_ref[x]), a)]]
            assert got == want, f"successors of {rx} under action {a}"
            assert mdp.rewards[x, a] == pytest.approx(ref.reward(rx, a), abs=1e-15), (
                f"reward of {rx} under action {a} (abs tol 1e-15)"
            )


@pytest.mark.parametrize("size", SMALL[:2], ids=IDS[:2])
def test_optimal_values_match_reference_value_iteration(size):
    model, ref = _pair(size)
    to_ref = _model_to_ref(model, ref)
    v_ref = np.array(ref.value_iteration(tol=1e-13))
    v = solve_exact(model.mdp()).values
    # reference VI stops at sup-change 1e-13: error <= 1e-13 * 0.9 / 0.1 ~ 1e-12
    np.testing.assert_allclose(v, v_ref[to_ref], atol=1e-10, rtol=0, err_msg="V* vs reference")


@pytest.mark.parametrize("size", SMALL, ids=IDS)
def test_encode_decode_round_trip_and_step(size):
    model = PatrolModel(PatrolParams(**size))
    x = np.arange(model.n_states)
    l, w, d, tau = model.decode(x)
    assert np.array_equal(model.encode(l, w, d, tau), x)
    comp = model.state_components()
    assert comp.shape == (model.n_states, 3 + model.m)
    assert np.array_equal(comp[:, 0], l) and np.array_equal(comp[:, 3:], tau)
    mdp = model.mdp()
    for a in range(3):
        ok = np.flatnonzero(mdp.allowed[:, a])
        for y in range(model.m + 1):
            assert np.array_equal(model.step(ok, a, y), mdp.successors[ok, a, y])


def test_step_and_encode_reject_bad_input():
    model = PatrolModel(PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4))
    x_empty_station = model.encode([0], [1], [0], [[0, 0]])
    with pytest.raises(ValidationError, match="loiter is not allowed"):
        model.step(x_empty_station, 2, 0)
    with pytest.raises(ValidationError, match="not a state: d >= 1 at a node"):
        model.encode([1], [1], [1], [[0, 0]])
    with pytest.raises(ValidationError, match="own station"):
        model.encode([3], [1], [1], [[0, 2]])
    with pytest.raises(ValidationError, match="delay outside"):
        model.encode([0], [1], [0], [[5, 0]])
    with pytest.raises(ValidationError, match="outside"):
        model.decode([model.n_states])
    with pytest.raises(ValidationError, match="outcome_index"):
        model.step(0, 0, 3)


@pytest.mark.parametrize("size", SMALL, ids=IDS)
def test_partition_is_the_reference_key_partition(size):
    model, ref = _pair(size)
    to_ref = _model_to_ref(model, ref)
    part = model.partition()
    keys = [ref.partition_key(ref.states[i]) for i in to_ref]
    pc = model.partition_components()
    assert part.n_partitions == model.n_partitions == len(set(keys)) == pc.shape[0]
    for x, key in enumerate(keys):
        assert tuple(int(v) for v in pc[part.labels[x]]) == key
    assert np.array_equal(model.state_partition(np.arange(model.n_states)), part.labels)
    l, w, d, A, tb = pc[:, 0], pc[:, 1], pc[:, 2], pc[:, 3:-1], pc[:, -1]
    assert np.array_equal(model.partition_index(l, w, d, A, tb), np.arange(pc.shape[0]))


@settings(max_examples=12, deadline=None)
@given(
    n_nodes=st.integers(2, 6),
    data=st.data(),
    big_d=st.integers(1, 3),
    gamma=st.integers(1, 3),
    empty=st.booleans(),
)
def test_random_small_instances_match_reference(n_nodes, data, big_d, gamma, empty):
    m = data.draw(st.integers(1, min(3, n_nodes)))
    stations = tuple(data.draw(st.permutations(range(n_nodes)))[:m])
    size = dict(N=n_nodes, stations=stations, D=big_d, Gamma=gamma)
    model, ref = _pair(size, empty)
    mdp = model.mdp()
    to_ref = _model_to_ref(model, ref)
    trans = ref.transitions()
    for x in range(mdp.n_states):
        rx = ref.states[to_ref[x]]
        for a in ref.allowed(rx):
            got = [int(to_ref[s]) for s in mdp.successors[x, a]]
            assert got == [j for j, _ in trans[(int(to_ref[x]), a)]]
        assert list(np.flatnonzero(mdp.allowed[x])) == ref.allowed(rx)


def test_paper_instance_builds_with_the_paper_counts():
    model = PatrolModel()
    mdp = model.mdp()
    assert mdp.n_states == 2_048_000, "eq. 27"
    assert model.partition().n_partitions == 8_900, "eq. 28"
    # spot-check 1000 random pairs against the reference's step (no enumeration needed)
    ref = RefPatrol(N=15, stations=(0, 3, 7, 11), D=5, Gamma=15)
    rng = np.random.default_rng(5)
    xs = rng.integers(0, mdp.n_states, 1000)
    comp = model.state_components()
    for x in xs:
        rx = tuple(int(v) for v in comp[x])
        assert list(np.flatnonzero(mdp.allowed[x])) == ref.allowed(rx)
        for a in ref.allowed(rx):
            for y in range(5):
                nxt = tuple(int(v) for v in comp[mdp.successors[x, a, y]])
                assert nxt == ref.step(rx, a, y)
            assert mdp.rewards[x, a] == pytest.approx(ref.reward(rx, a), abs=1e-15)
