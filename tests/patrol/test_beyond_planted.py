"""The certified checks of the study beyond the paper on planted violations of known size.

:func:`lpbounds.patrol.beyond.study_from_arrays` decides ``V* <= v*``, ``w* <= V*``,
``V_sub <= V*`` and ``w* <= V_sub`` at every state from the arrays it is given. On a
real run they hold, so a verdict that always said "holds" would pass every test that only
runs the study; here each is fed the exact arrays of a tiny instance with one value moved
by a known amount at one state, and must say *violated* there, with that difference.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lpbounds import evaluate_policy, greedy_policy, solve_exact
from lpbounds.patrol.beyond import study_from_arrays
from lpbounds.patrol.greedy_mc import partition_bounds
from lpbounds.patrol.model import PatrolModel
from lpbounds.patrol.params import PatrolParams

PARAMS = PatrolParams(N=4, stations=(0, 2), D=2, Gamma=3)


@pytest.fixture(scope="module")
def arrays():
    """``V*``, the bounds, ``pi_s`` and ``V_sub`` of the instance (the array path)."""
    pm = PatrolModel(PARAMS)
    mdp = pm.mdp()
    labels = pm.partition().labels
    ref = solve_exact(mdp)
    pb = partition_bounds(PARAMS)
    pi_s = greedy_policy(mdp, pb.lower[labels]).astype(np.int8)
    ev = evaluate_policy(mdp, pi_s, method="direct")
    return {"ref": ref, "pb": pb, "pi_s": pi_s, "ev": ev, "labels": labels}


def _row(arrays, *, vstar=None, upper=None, vsub=None):
    ref, pb, ev = arrays["ref"], arrays["pb"], arrays["ev"]
    bounds = pb if upper is None else dataclasses.replace(pb, upper=upper)
    evaluation = ev if vsub is None else dataclasses.replace(ev, values=vsub)
    return study_from_arrays(
        PARAMS,
        "planted",
        vstar=ref.values if vstar is None else vstar,
        vstar_summary={"error_bound": ref.error_bound, "residual": ref.residual},
        pistar=ref.policy,
        bounds=bounds,
        pi_s=arrays["pi_s"],
        vsub=evaluation,
    )


def _assert_violated_alone(row, key, state, difference):
    for name, check in row.checks.items():
        if name != key:
            assert check.verdict == "holds", (name, check)
    c = row.checks[key]
    assert c.verdict == "violated" and not row.all_hold, c
    assert c.state == state
    assert c.min_difference == pytest.approx(difference, abs=1e-12)
    assert c.margin == pytest.approx(difference - c.errors, abs=1e-12)


def test_unplanted_every_check_holds(arrays):
    """The control: the arrays as computed give four verdicts *holds*."""
    assert _row(arrays).all_hold


def test_upper_bound_planted_below_v_star(arrays):
    """``v*(i)`` of the partition of the largest ``V*`` set to that ``V*`` minus 1: ``V* <=
    v*`` is violated at that state, by 1 (the greedy policy only reads ``w*``)."""
    v, lab = arrays["ref"].values, arrays["labels"]
    x = int(np.argmax(v))
    upper = arrays["pb"].upper.copy()
    upper[lab[x]] = v[x] - 1.0
    _assert_violated_alone(_row(arrays, upper=upper), "vstar_le_upper", x, -1.0)


def test_v_star_planted_below_the_lower_bound(arrays):
    """``V*(x)`` set to ``w*(i) - 1`` where ``V_sub(x) - w*(i)`` is largest: ``w* <= V*`` is
    violated there by 1; ``V_sub <= V*`` too (by ``V_sub(x) - w*(i) + 1``)."""
    v, lab, low = arrays["ref"].values, arrays["labels"], arrays["pb"].lower
    vsub = arrays["ev"].values
    x = int(np.argmax(vsub - low[lab]))
    planted = v.copy()
    planted[x] = low[lab[x]] - 1.0
    row = _row(arrays, vstar=planted)
    c = row.checks["lower_le_vstar"]
    assert (c.verdict, c.state) == ("violated", x)
    assert c.min_difference == pytest.approx(-1.0, abs=1e-12)
    s = row.checks["vsub_le_vstar"]
    assert (s.verdict, s.state) == ("violated", x)
    assert s.min_difference == pytest.approx(planted[x] - vsub[x], abs=1e-12)


def test_v_sub_planted_above_v_star(arrays):
    """``V_sub(x)`` set to ``V*(x) + 0.5``: ``V_sub <= V*`` is violated there by 0.5, beyond
    the accuracy ``2 (err(V*) + err(V_sub))`` that this check allows."""
    v = arrays["ref"].values
    x = int(np.argmin(v))
    vsub = arrays["ev"].values.copy()
    vsub[x] = v[x] + 0.5
    _assert_violated_alone(_row(arrays, vsub=vsub), "vsub_le_vstar", x, -0.5)


def test_v_sub_planted_below_the_lower_bound(arrays):
    """``V_sub(x)`` set to ``w*(i) - 2``: ``w* <= V_sub`` is violated there by 2."""
    lab, low = arrays["labels"], arrays["pb"].lower
    x = int(np.argmax(arrays["ref"].values))
    vsub = arrays["ev"].values.copy()
    vsub[x] = low[lab[x]] - 2.0
    _assert_violated_alone(_row(arrays, vsub=vsub), "lower_le_vsub", x, -2.0)
