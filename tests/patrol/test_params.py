"""PatrolParams: the paper's defaults, eq. 27-28 against brute-force counts, Appendix A."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lpbounds.errors import ValidationError
from lpbounds.patrol.params import PatrolParams

from .reference import RefPatrol, information

SIZES = [
    dict(N=3, stations=(1,), D=1, Gamma=2),
    dict(N=6, stations=(0, 3), D=2, Gamma=4),
    dict(N=5, stations=(0, 2, 3), D=2, Gamma=2),
    dict(N=4, stations=(3, 0), D=3, Gamma=1),
    dict(N=7, stations=(0, 2, 4, 6), D=1, Gamma=1),
]


def test_paper_defaults_and_counts():
    p = PatrolParams()
    assert (p.N, p.stations, p.D, p.Gamma, p.m) == (15, (0, 3, 7, 11), 5, 15, 4)
    assert (p.rho, p.discount, p.alpha) == (0.005, 0.9, 1 / 60)
    assert not p.allow_empty_loiter
    assert p.n_states == 2_048_000, "eq. 27 for the paper's example (Section 6 states 2,048,000)"
    assert p.n_partitions == 8_900, "eq. 28 for the paper's example (Section 6.1 states 8900)"


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"N{s['N']}m{len(s['stations'])}")
def test_counts_match_brute_force(size):
    ref = RefPatrol(**size)
    p = PatrolParams(**size)
    assert p.n_states == len(ref.states) == len(set(ref.states))
    keys = {ref.partition_key(x) for x in ref.states}
    assert p.n_partitions == len(keys)


@pytest.mark.parametrize(
    "kw",
    [{}, dict(a=0.6, b=0.3, c=0.4, g=0.5, mu1=0.5, mu2=2.0, p_threat=0.2), dict(a=0.55, b=0.45)],
)
def test_information_matches_term_by_term_reference(kw):
    p = PatrolParams(**kw)
    ds = np.arange(0, 9)
    got = p.information(ds)
    want = [information(int(d), p.p_threat, p.a, p.b, p.c, p.g, p.mu1, p.mu2) for d in ds]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15, err_msg="I(d) vs reference")
    assert p.information(2.5) == pytest.approx(
        information(2.5, p.p_threat, p.a, p.b, p.c, p.g, p.mu1, p.mu2), rel=1e-12
    )


def test_information_paper_shape():
    p = PatrolParams()
    info = p.information(np.arange(0, 7))
    assert info[0] == 0.0, "a + c = 1: an uninformed operator gains nothing at d = 0"
    assert np.all(np.diff(info) > 0), "I(d) increases with the dwell"
    # Figure 2's axis: the gain stays below 0.03 nats and saturates
    assert 0.02 < info[5] < 0.03
    inc = p.information_increments()
    assert inc.shape == (5,) and np.all(inc > 0)
    np.testing.assert_allclose(inc, np.diff(info[:6]), rtol=1e-15, atol=0)
    # limit d -> inf: P_TR = P_FTR = 0.95; mutual information of that channel
    q, pr = 0.95, p.p_threat
    z1 = pr * q + (1 - pr) * (1 - q)
    z2 = 1 - z1
    lim = (
        pr * q * math.log(q / z1)
        + pr * (1 - q) * math.log((1 - q) / z2)
        + (1 - pr) * (1 - q) * math.log((1 - q) / z1)
        + (1 - pr) * q * math.log(q / z2)
    )
    assert p.information(60.0) == pytest.approx(lim, rel=1e-12)


def test_information_zero_probability_terms():
    p = PatrolParams(a=0.0, b=1.0, c=0.0, g=1.0)  # P_TR(0) = 0: a 0 log 0 term
    val = p.information(np.array([0.0, 1.0]))
    assert np.all(np.isfinite(val))
    assert val[0] == pytest.approx(
        information(0, p.p_threat, 0.0, 1.0, 0.0, 1.0, 1.0, 1.0), abs=1e-15
    )


def test_alert_probabilities():
    p = PatrolParams(alpha=0.3, stations=(0, 1, 2))
    pr = p.alert_probabilities()
    assert pr.shape == (4,)
    assert pr[0] == pytest.approx(math.exp(-0.3), rel=1e-15)
    np.testing.assert_allclose(pr[1:], (1 - math.exp(-0.3)) / 3, rtol=1e-14)
    assert pr.sum() == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(N=0), "N"),
        (dict(N=2.5), "N"),
        (dict(D=True), "D"),
        (dict(Gamma=0), "Gamma"),
        (dict(stations=()), "stations"),
        (dict(stations=(0, 0)), "distinct"),
        (dict(stations=(0, 15)), r"stations\[1\]"),
        (dict(stations=(-1,)), r"stations\[0\]"),
        (dict(discount=1.0), "discount"),
        (dict(alpha=0.0), "alpha"),
        (dict(rho=-1.0), "rho"),
        (dict(a=0.6, b=0.45), "a \\+ b"),
        (dict(c=0.0, g=0.0), "c \\+ g"),
        (dict(mu1=-1.0), "mu1"),
        (dict(p_threat=1.0), "p_threat"),
        (dict(rho=float("nan")), "rho"),
        (dict(allow_empty_loiter="yes"), "allow_empty_loiter"),
    ],
)
def test_validation_names_the_entry(kw, match):
    with pytest.raises(ValidationError, match=match):
        PatrolParams(**kw)


def test_from_table_names_paper_keys_and_rejects_typos():
    t = {"kind": "patrol", "N": 6, "stations": [0, 3], "D": 2, "Gamma": 4, "rho": 0.01}
    p = PatrolParams.from_table(t)
    assert p == PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4, rho=0.01)
    assert PatrolParams.from_table(p.to_table()) == p
    with pytest.raises(ValidationError, match="Gama"):
        PatrolParams.from_table({"kind": "patrol", "Gama": 3})
    assert hash(p) == hash(PatrolParams.from_table(t)), "usable as a cache key"
