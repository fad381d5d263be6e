"""pi_s acted out on the fly (lpbounds.patrol.greedy_mc) against the MDP-array path.

Every expected value comes from the full MDP of a small instance, built by
:class:`PatrolModel` and solved by the DP code: ``greedy_policy`` on the lifted ``w*``,
``evaluate_policy`` for the exact ``V_pis``, ``simulate`` on the MDP's successor table
for Table 1, and plain numpy sweeps for the truncated values. At 8 stations, where no
MDP exists, the greedy action is checked against Q-values built with the vectorised
numpy model (``PatrolModel.step``, ``state_partition``, ``rewards``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lpbounds import evaluate_policy, greedy_policy, solve_exact
from lpbounds.errors import ValidationError
from lpbounds.model.instances import load_instance
from lpbounds.patrol import PatrolModel, PatrolParams
from lpbounds.patrol.greedy_mc import (
    default_horizon,
    default_starts,
    greedy_actions,
    greedy_simulate,
    greedy_table1,
    greedy_value_mc,
    partition_bounds,
    reward_absmax,
    table1_markdown,
    truncation_bound,
)
from lpbounds.patrol.instance import params_from_instance
from lpbounds.patrol.partitions import block_sizes, state_partition_kernel
from lpbounds.patrol.simulation import alert_sequence, simulate
from lpbounds.tolerances import GREEDY_TIE_RTOL

SMALL = {
    "small": PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4),
    "m3": PatrolParams(N=7, stations=(0, 2, 5), D=2, Gamma=3),
    "m3-empty-loiter": PatrolParams(N=7, stations=(5, 0, 2), D=3, Gamma=2, allow_empty_loiter=True),
    # frequent alerts: the returns are not dominated by rare events, so a few hundred paths
    # suffice for the t interval (at alpha = 1/60 the corrected returns are heavily skewed)
    "busy": PatrolParams(N=6, stations=(0, 3), D=2, Gamma=4, alpha=0.2),
}


@pytest.fixture(scope="module")
def solved():
    """Per small instance: model, MDP, lifted labels, the bounds and pi_s from the arrays."""
    out = {}
    for name, params in SMALL.items():
        pm = PatrolModel(params)
        mdp = pm.mdp()
        labels = pm.partition().labels
        b = partition_bounds(params)
        out[name] = (pm, mdp, labels, b, greedy_policy(mdp, b.lower[labels]))
    return out


@pytest.mark.parametrize("name", list(SMALL))
def test_state_partition_kernel_equals_partition_index(name):
    params = SMALL[name]
    pm = PatrolModel(params)
    l, w, d, tau = pm.decode(np.arange(pm.n_states))
    tb, lb = block_sizes(params)
    sp = params.station_pos
    got = [
        state_partition_kernel(
            l[i], w[i], d[i], tau[i], sp, params.N, params.D, params.Gamma, tb, lb
        )
        for i in range(pm.n_states)
    ]
    np.testing.assert_array_equal(got, pm.partition().labels)


@pytest.mark.parametrize("name", list(SMALL))
def test_greedy_action_equals_greedy_policy_state_by_state(solved, name):
    pm, _, _, b, pi_s = solved[name]
    got = greedy_actions(pm.params, b.lower, np.arange(pm.n_states))
    assert np.array_equal(got, pi_s), f"{int((got != pi_s).sum())} states differ"
    assert len(set(pi_s.tolist())) == 3, "the test should see all three actions chosen"


def test_greedy_action_tie_rule(solved):
    """Constant values tie continue and reverse everywhere: both paths pick the lowest."""
    pm, mdp, labels, b, _ = solved["m3"]
    for lower in (np.zeros(pm.params.n_partitions), np.full(pm.params.n_partitions, -3.0)):
        want = greedy_policy(mdp, lower[labels])
        got = greedy_actions(pm.params, lower, np.arange(pm.n_states))
        assert np.array_equal(got, want)
        assert (got != 1).all(), "reverse is never first among tied actions"
    # values within the tie tolerance of each other count as equal; beyond it they do not
    lower = b.lower.copy()
    want = greedy_policy(mdp, lower[labels])
    assert np.array_equal(greedy_actions(pm.params, lower, np.arange(pm.n_states)), want)
    assert GREEDY_TIE_RTOL > 0


def _numpy_greedy(pm, lower, xs):
    """The greedy action from the vectorised numpy model (step, partitions, rewards)."""
    params = pm.params
    l, _, d, tau = pm.decode(xs)
    allowed = pm.allowed(l, d, tau)
    rewards = pm.rewards(d, tau)
    probs = params.alert_probabilities()
    q = np.full((xs.size, 3), -np.inf)
    for a in range(3):
        ok = np.flatnonzero(allowed[:, a])
        acc = np.zeros(ok.size)
        for y in range(params.m + 1):
            nxt = pm.step(xs[ok], a, y)
            acc += probs[y] * lower[pm.state_partition(nxt)]
        q[ok, a] = rewards[ok, a] + params.discount * acc
    best = q.max(axis=1)
    thr = best - GREEDY_TIE_RTOL * np.maximum(1.0, np.abs(best))
    return np.argmax(q >= thr[:, None], axis=1)


def test_greedy_action_at_eight_stations_matches_numpy_model():
    params = params_from_instance(load_instance("patrol-m8"))
    pm = PatrolModel(params)
    rng = np.random.default_rng(5)
    lower = rng.normal(size=params.n_partitions)
    xs = np.concatenate([default_starts(params, n_random=300, seed=3), [params.n_states - 1]])
    got = greedy_actions(params, lower, xs)
    want = _numpy_greedy(pm, lower, xs)
    np.testing.assert_array_equal(got, want)


def test_reward_absmax_and_truncation(solved):
    pm, mdp, _, _, pi_s = solved["small"]
    params = pm.params
    assert reward_absmax(params) == pytest.approx(np.abs(mdp.rewards[mdp.allowed]).max(), rel=1e-15)
    # the return cut after H steps, computed exactly by H policy sweeps from 0
    ev = evaluate_policy(mdp, pi_s, method="direct")
    x = np.arange(mdp.n_states)
    r = mdp.rewards[x, pi_s]
    succ = mdp.successors[x, pi_s]
    for h in (1, 5, 20):
        v = np.zeros(mdp.n_states)
        for _ in range(h):
            v = r + params.discount * (v[succ] @ mdp.probabilities)
        err = np.abs(ev.values - v).max()
        assert err <= truncation_bound(params, h) + 1e-12
    h = default_horizon(params)
    assert truncation_bound(params, h) <= 1e-6 < truncation_bound(params, h - 1)


@pytest.mark.parametrize(("control_variate", "width"), [(True, 1e-3), (False, 1e-2)])
def test_monte_carlo_interval_covers_exact_value(solved, control_variate, width):
    """At 95 %, the exact V_pis lies in at least 35 of 40 start intervals (fixed seed; a
    correct estimator fails this with probability 1.4 %), and the standardised errors show
    no bias; with and without the control variate."""
    pm, mdp, labels, b, pi_s = solved["busy"]
    est = greedy_value_mc(
        pm.params,
        b.lower,
        b.upper,
        starts=40,
        paths=300,
        upper_error=b.upper_error,
        seed=7,
        control_variate=control_variate,
    )
    exact = evaluate_policy(mdp, pi_s, method="direct").values[est.starts]
    inside = (est.ci_low <= exact) & (exact <= est.ci_high)
    assert inside.sum() >= 35, f"covered {int(inside.sum())} of 40"
    z = (est.mean - exact) / (est.std / np.sqrt(est.paths))
    assert abs(z.mean()) < 3 / np.sqrt(z.size), f"mean standardised error {z.mean():.2f}"
    assert est.half_width.max() < width, "the intervals must be narrow enough to mean something"
    assert est.control_variate == control_variate
    assert est.n_starts == 40 and est.interval == "student-t" and est.level == 0.95
    # the statistical certificate holds where the interval covers
    vstar = solve_exact(mdp).values[est.starts]
    assert (vstar - exact <= est.gap_bound)[inside].all()
    np.testing.assert_array_equal(est.upper, b.upper[labels[est.starts]])
    np.testing.assert_array_equal(
        est.starts[:2], pm.encode([0, 3], [1, 1], [0, 0], np.zeros((2, 2)))
    )
    summary = est.summary()
    assert summary["contradicts_upper"] == 0 and len(summary["rows"]) == 40
    assert (
        summary["rows"][0]["start"] == "station 1 empty" and summary["rows"][2]["start"] == "random"
    )
    assert est.markdown().count("\n") == 41


def test_monte_carlo_is_reproducible_and_seeded(solved):
    pm, _, _, b, _ = solved["small"]
    kw = dict(starts=np.array([0, 5, 17]), paths=50, horizon=30)
    a = greedy_value_mc(pm.params, b.lower, b.upper, seed=1, **kw)
    again = greedy_value_mc(pm.params, b.lower, b.upper, seed=1, **kw)
    other = greedy_value_mc(pm.params, b.lower, b.upper, seed=2, **kw)
    np.testing.assert_array_equal(a.mean, again.mean)
    assert not np.array_equal(a.mean, other.mean)
    assert a.truncation == truncation_bound(pm.params, 30)


@pytest.mark.parametrize("cv", [False, True])
def test_path_returns_equal_a_walk_on_the_mdp(solved, cv):
    """Each path's (corrected) return equals the sum along the same alert sequence walked
    on the MDP's arrays under greedy_policy's pi_s (no code of greedy_mc involved)."""
    from lpbounds.patrol.greedy_mc import _Kernel, _returns

    pm, mdp, labels, b, pi_s = solved["busy"]
    lam, probs, w = mdp.discount, mdp.probabilities, b.lower[labels]
    y = alert_sequence(5 * 40, probs[0], pm.params.m, 2).reshape(5, 40)
    got = np.empty(5)
    _returns(17, y, b.lower, _Kernel.of(pm.params), cv, got)
    for p in range(5):
        x, g = 17, 0.0
        for t in range(40):
            a = pi_s[x]
            nxt = mdp.successors[x, a]
            g += lam**t * mdp.rewards[x, a]
            if cv:
                g -= lam ** (t + 1) * (w[nxt[y[p, t]]] - probs @ w[nxt])
            x = nxt[y[p, t]]
        assert got[p] == pytest.approx(g, rel=1e-12, abs=1e-15), p


def test_parallel_paths_do_not_share_work_arrays(solved):
    """The same returns on 1 and on 2 threads (a race on shared buffers would differ)."""
    from lpbounds._kernels import threads

    pm, _, _, b, _ = solved["busy"]
    kw = dict(starts=np.array([0, 7, 100]), paths=200, horizon=60, seed=4)
    before = threads.get_threads()
    try:
        threads.set_threads(1)
        one = greedy_value_mc(pm.params, b.lower, b.upper, **kw)
        threads.set_threads(min(2, threads.default_threads()))
        two = greedy_value_mc(pm.params, b.lower, b.upper, **kw)
    finally:
        threads.set_threads(before)
    np.testing.assert_array_equal(one.mean, two.mean)
    np.testing.assert_array_equal(one.std, two.std)


def test_control_variate_keeps_the_mean_and_cuts_the_spread(solved):
    """Same paths (same seed) with and without the control variate: the estimates agree
    within their intervals and the corrected returns spread far less."""
    pm, _, _, b, _ = solved["busy"]
    kw = dict(starts=8, paths=400, seed=3)
    on = greedy_value_mc(pm.params, b.lower, b.upper, control_variate=True, **kw)
    off = greedy_value_mc(pm.params, b.lower, b.upper, control_variate=False, **kw)
    assert (np.abs(on.mean - off.mean) <= on.half_width + off.half_width).all()
    assert (on.std * 3 < off.std).all(), (on.std, off.std)


def test_greedy_simulate_equals_simulate_on_the_mdp(solved):
    pm, _, _, b, pi_s = solved["m3"]
    y = alert_sequence(3000, 0.6, pm.params.m, 11)
    got = greedy_simulate(pm.params, b.lower, y, seed=11)
    want = simulate(pm, pi_s, y, policy_name="pi_s", seed=11)
    for f in dataclasses.fields(want):
        np.testing.assert_array_equal(getattr(got, f.name), getattr(want, f.name), err_msg=f.name)
    assert want.n_serviced > 100 and want.mismatches == 0


def test_greedy_table1_pools_the_seeds(solved):
    pm, _, _, b, pi_s = solved["small"]
    tab = greedy_table1(pm.params, b.lower, steps=4000, seeds=[1, 2])
    p0 = pm.params.alert_probabilities()[0]
    runs = [simulate(pm, pi_s, alert_sequence(4000, p0, 2, s), seed=s) for s in (1, 2)]
    delays = np.concatenate([r.delay for r in runs])
    assert tab.statistics.mean_delay == pytest.approx(delays.mean(), rel=1e-15)
    assert tab.statistics.worst_delay == delays.max()
    assert tab.statistics.n_steps == 8000 and tab.seeds == [1, 2]
    assert 0 < tab.visited_states <= pm.n_states
    assert tab.summary()["worst_delay"] == delays.max()
    assert f"| {delays.mean():.2f} (" in table1_markdown({"small": tab})


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"lower": np.zeros(3)}, "lower"),
        ({"upper": np.full(176, np.nan)}, "upper"),
        ({"starts": np.array([0, 320])}, r"starts\[1\] = 320"),
        ({"starts": np.array([0.5])}, "starts"),
        ({"paths": 1}, "paths"),
        ({"horizon": 0}, "horizon"),
        ({"level": 1.0}, "level"),
        ({"upper_error": -1.0}, "upper_error"),
    ],
)
def test_bad_input_names_the_argument(kwargs, match):
    params = SMALL["small"]
    args = {"lower": np.zeros(176), "upper": np.zeros(176), "paths": 10, "horizon": 3}
    args.update(kwargs)
    lower, upper = args.pop("lower"), args.pop("upper")
    with pytest.raises(ValidationError, match=match):
        greedy_value_mc(params, lower, upper, **args)


def test_params_must_be_patrol_params():
    for call in (
        lambda: partition_bounds({"N": 6}),
        lambda: greedy_actions("patrol-small", np.zeros(3), [0]),
        lambda: default_starts(None),
        lambda: truncation_bound(3, 10),
    ):
        with pytest.raises(ValidationError, match="params must be a PatrolParams"):
            call()


def test_bad_outcomes_and_start():
    params = SMALL["small"]
    with pytest.raises(ValidationError, match=r"outcomes\[1\] = 3"):
        greedy_simulate(params, np.zeros(176), np.array([0, 3]))
    with pytest.raises(ValidationError, match="start"):
        greedy_simulate(params, np.zeros(176), np.array([0, 1]), start=-1)
    with pytest.raises(ValidationError, match="seeds"):
        greedy_table1(params, np.zeros(176), seeds=[])


@pytest.mark.slow
def test_paper_instance_greedy_and_table1_equal_the_mdp_path():
    """On the paper's 2,048,000 states: pi_s on the fly equals greedy_policy everywhere, and
    one seed of Table 1 equals simulate on the MDP's successor table."""
    params = params_from_instance(load_instance("patrol-paper"))
    pm = PatrolModel(params)
    mdp = pm.mdp()
    b = partition_bounds(params)
    want = greedy_policy(mdp, b.lower[pm.partition().labels])
    got = greedy_actions(params, b.lower, np.arange(params.n_states))
    assert np.array_equal(got, want), f"{int((got != want).sum())} states differ"
    y = alert_sequence(60_000, params.alert_probabilities()[0], params.m, 1)
    mine = greedy_simulate(params, b.lower, y, seed=1)
    ref = simulate(pm, want, y, seed=1)
    for f in dataclasses.fields(ref):
        if f.name != "policy_name":
            np.testing.assert_array_equal(getattr(mine, f.name), getattr(ref, f.name), f.name)


def test_the_one_markdown_table_writer_aligns_and_escapes():
    """patrol.report.markdown_table writes the greedy tables too (issue 37): right-aligned
    columns are ``---:``, a ``|`` in a cell is escaped, a number is formatted as in the
    report (thousands separated), a string is kept as given."""
    from lpbounds.patrol.report import markdown_table

    text = markdown_table(["name", "n"], [["a|b", 12345], ["c", "7.50000"]], align="lr")
    assert text.splitlines() == [
        "| name | n |",
        "|---|---:|",
        "| a\\|b | 12,345 |",
        "| c | 7.50000 |",
    ]
    assert markdown_table(["x"], [[1]]).splitlines()[1] == "|---|"
