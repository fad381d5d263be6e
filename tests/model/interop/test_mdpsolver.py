"""MDPSolver's published test cases through ``from_quantecon`` and ``from_transitions``.

Upstream: repository areenberg/MDPSolver, file ``Python/tests/test1.py`` (configurations
1 and 2) and the quick-start of its ``README.md``. Only data and published values are
copied. MDPSolver's ``tranMatWithZeros`` is ``Q[state, action, next]`` (QuantEcon's
layout) and ``tranMatElementwise`` is ``[s, a, s', p]`` rows. The published values come
from MDPSolver's iterative solvers (tolerance 1e-3) and are compared rounded to three
decimals upstream: they are iterates, so here V* must lie in the Porteus bracket each
published vector certifies, and agree with it to the upstream rounding.

Test 2 of that suite (a 202-state queue written by a generator script, checked only by
the rounded mean of V) is not ported: its data is produced by code, not published.
"""

from __future__ import annotations

import numpy as np
import pytest

import lpbounds as lb

from ._reference import brute_force, exact, porteus_bracket

REWARDS = [[5, -1], [1, -2], [50, 0]]
TRAN_WITH_ZEROS = [
    [[0.9, 0.1, 0.0], [0.1, 0.9, 0.0]],
    [[0.4, 0.5, 0.1], [0.3, 0.5, 0.2]],
    [[0.2, 0.2, 0.6], [0.5, 0.5, 0.0]],
]
TRAN_ELEMENTWISE = [
    [0, 0, 0, 0.9], [0, 0, 1, 0.1], [0, 1, 0, 0.1], [0, 1, 1, 0.9],
    [1, 0, 0, 0.4], [1, 0, 1, 0.5], [1, 0, 2, 0.1], [1, 1, 0, 0.3], [1, 1, 1, 0.5],
    [1, 1, 2, 0.2], [2, 0, 0, 0.2], [2, 0, 1, 0.2], [2, 0, 2, 0.6], [2, 1, 0, 0.5],
    [2, 1, 1, 0.5],
]  # fmt: skip
P_ASS = np.array(TRAN_WITH_ZEROS).transpose(1, 0, 2)  # for the numpy references

# test1.py, discount 0.95: the published value vectors of models 1a/2a (mpi, pi),
# 3a (vi), 1c (mpi, Gauss-Seidel) and 3c; every one with policy [1, 1, 0]
PUBLISHED = {
    "mpi-pi": [200.00114718191236, 212.86672887958622, 298.7090458676583],
    "vi": [200.0013199959708, 212.86689665815788, 298.709197760198],
    "gs": [200.0012771893156, 212.86686671568802, 298.7091798650016],
    "vi-gs": [200.0010604606014, 212.86664512773723, 298.7089561808565],
}
POLICY = [1, 1, 0]

CONSTRUCTORS = {
    # CONFIGURATION 1: rewards (n, A) and tranMatWithZeros (n, A, n); 3 states and 2
    # actions, so the shape alone decides the layout
    "tranMatWithZeros": lambda d: lb.FiniteMDP.from_quantecon(REWARDS, TRAN_WITH_ZEROS, d),
    # CONFIGURATION 2: the elementwise rows, rewards (n, A)
    "tranMatElementwise": lambda d: lb.FiniteMDP.from_transitions(TRAN_ELEMENTWISE, d, REWARDS),
    # MDPSolver's rewardsElementwise ([s, a, r] rows) with the same transitions
    "rewardsElementwise": lambda d: lb.FiniteMDP.from_transitions(
        TRAN_ELEMENTWISE,
        d,
        reward_rows=[[x, a, REWARDS[x][a]] for x in range(3) for a in range(2)],
    ),
}


@pytest.mark.parametrize("published", sorted(PUBLISHED))
@pytest.mark.parametrize("form", sorted(CONSTRUCTORS))
def test_test1_discounted(form, published):
    mdp = CONSTRUCTORS[form](0.95)
    v, pol = exact(mdp)
    np.testing.assert_array_equal(pol, POLICY)
    pub = np.array(PUBLISHED[published])
    lo, hi = porteus_bracket(P_ASS, REWARDS, 0.95, pub)
    assert np.all(lo - 1e-9 <= v) and np.all(v <= hi + 1e-9), (lo, v, hi)
    # upstream compares np.round(V, 3); the iterates are within 1e-3 of V*
    np.testing.assert_allclose(v, pub, atol=1e-3)
    np.testing.assert_allclose(v, brute_force(P_ASS, REWARDS, 0.95)[0], rtol=1e-12)


@pytest.mark.parametrize("form", sorted(CONSTRUCTORS))
def test_readme_quick_start_policy(form):
    # README.md quick start: discount 0.8, "print(mdl.getPolicy())  #[1, 1, 0]"
    v, pol = exact(CONSTRUCTORS[form](0.8))
    np.testing.assert_array_equal(pol, [1, 1, 0])
    np.testing.assert_allclose(v, brute_force(P_ASS, REWARDS, 0.8)[0], rtol=1e-12)
