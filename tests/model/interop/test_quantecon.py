"""QuantEcon's published ``DiscreteDP`` test cases through ``FiniteMDP.from_quantecon``.

Upstream: repository QuantEcon/QuantEcon.py, file ``quantecon/markov/tests/test_ddp.py``
(and the docstring example of ``quantecon/markov/ddp.py``, Puterman 2005, Section 3.1).
Only data and published values are copied. The argument forms need no QuantEcon; the
``DiscreteDP``-object tests run only when QuantEcon is installed (the ``interop`` extra).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import lpbounds as lb
from lpbounds.errors import ValidationError

from ._reference import assert_policy_optimal, brute_force, exact, porteus_bracket

BETA = 0.95
# test_ddp.py::TestDiscreteDP.setup_method: Puterman (2005), Section 3.1; action 1 is
# not available in state 1 (reward -inf)
R_PUTERMAN = [[5, 10], [-1, -np.inf]]
Q_PUTERMAN = np.empty((2, 2, 2))
Q_PUTERMAN[0, 0, :] = 0.5, 0.5
Q_PUTERMAN[0, 1, :] = 0, 1
Q_PUTERMAN[1, :, :] = 0, 1
S_IND, A_IND = [0, 0, 1], [0, 1, 0]
R_SA = [5, 10, -1]
# the analytical solution for beta > 10/11 (Puterman, Example 6.2.1)
V_STAR = [(5 - 5.5 * BETA) / ((1 - 0.5 * BETA) * (1 - BETA)), -1 / (1 - BETA)]
SIGMA_STAR = [0, 0]


def _q_sa_lil():
    q = sp.lil_matrix((3, 2))
    q[0, :] = Q_PUTERMAN[0, 0, :]
    q[1, :] = Q_PUTERMAN[0, 1, :]
    q[2, :] = Q_PUTERMAN[1, 0, :]
    return q


PUTERMAN_FORMS = {
    # product form: n == m == 2, so the layout of Q must be said (never guessed)
    "product": lambda: lb.FiniteMDP.from_quantecon(R_PUTERMAN, Q_PUTERMAN, BETA, layout="sas"),
    # state-action pairs with a sparse (lil) Q: ddp_sa_sparse
    "sa-sparse": lambda: lb.FiniteMDP.from_quantecon(R_SA, _q_sa_lil(), BETA, S_IND, A_IND),
    # state-action pairs with a dense Q: ddp_sa_dense
    "sa-dense": lambda: lb.FiniteMDP.from_quantecon(
        R_SA, _q_sa_lil().toarray(), BETA, S_IND, A_IND
    ),
    # the docstring of ddp.py: Q[1, 1] is "an arbitrary probability vector" (ignored)
    "docstring-product": lambda: lb.FiniteMDP.from_quantecon(
        [[5, 10], [-1, -float("inf")]],
        [[(0.5, 0.5), (0, 1)], [(0, 1), (0.5, 0.5)]],
        0.95,
        layout="sas",
    ),
}


@pytest.mark.parametrize("form", sorted(PUTERMAN_FORMS))
def test_puterman_example(form):
    # test_ddp.py::TestDiscreteDP::test_policy_iteration (and the other methods):
    # v_star analytical, sigma_star = [0, 0]
    mdp = PUTERMAN_FORMS[form]()
    assert mdp.allowed.tolist() == [[True, True], [True, False]]
    v, pol = exact(mdp)
    np.testing.assert_allclose(v, V_STAR, rtol=1e-12)
    np.testing.assert_array_equal(pol, SIGMA_STAR)


@pytest.mark.parametrize(
    "published",
    [
        # ddp.py docstring, value iteration from [0, 0] with epsilon=0.01 (162 iterations)
        [-8.5665053, -19.99507673],
        # ddp.py docstring, modified policy iteration from [0, 0] with epsilon=0.01
        [-8.57142826, -19.99999965],
    ],
    ids=["value-iteration", "modified-policy-iteration"],
)
def test_puterman_docstring_iterates_bracket_v_star(published):
    # iterates, not V*: V* (exact) must lie in the Porteus bracket each one certifies
    # (computed with numpy; the unavailable pair's -inf reward never wins the max)
    mdp = PUTERMAN_FORMS["docstring-product"]()
    v, pol = exact(mdp)
    lo, hi = porteus_bracket(Q_PUTERMAN.transpose(1, 0, 2), R_PUTERMAN, BETA, published)
    assert np.all(lo - 1e-9 <= v) and np.all(v <= hi + 1e-9), (lo, v, hi)
    np.testing.assert_array_equal(pol, SIGMA_STAR)  # the docstring's res.sigma


def test_puterman_product_form_is_read_in_quantecons_layout():
    # n == m: Q[s, a, s'] and P[a, s, s'] have the same shape; from_quantecon reads
    # QuantEcon's layout without being told (the published V* and sigma* below are
    # QuantEcon's; test_constructors.py shows a model where the two readings differ)
    v, pol = exact(lb.FiniteMDP.from_quantecon(R_PUTERMAN, Q_PUTERMAN, BETA))
    np.testing.assert_allclose(v, V_STAR, rtol=1e-9)
    np.testing.assert_array_equal(pol, SIGMA_STAR)


def _cake_eating(n, beta, seed):
    """A stochastic cake-eating (savings) problem on a grid of n cake sizes: the action is
    next period's planned size a <= s (the actions ARE the grid points, so m == n), eating
    s - a with utility sqrt; the planned size is kept with probability 0.8, else a
    random grid point at or below it (spoilage). QuantEcon's product form R (n, n),
    Q (n, n, n), infeasible actions marked -inf."""
    rng = np.random.default_rng(seed)
    grid = np.linspace(0.0, 1.0, n)
    R = np.full((n, n), -np.inf)
    Q = np.zeros((n, n, n))
    for s in range(n):
        for a in range(s + 1):
            R[s, a] = np.sqrt(grid[s] - grid[a])
            Q[s, a, a] = 0.8
            spoil = rng.random(a + 1)
            Q[s, a, : a + 1] += 0.2 * spoil / spoil.sum()
    return R, Q


@pytest.mark.parametrize("beta", [0.9, 0.99])
def test_square_savings_problem_equals_quantecons_own_solve(beta):
    qe = pytest.importorskip("quantecon")
    R, Q = _cake_eating(25, beta, seed=1)
    res = qe.markov.DiscreteDP(R, Q, beta).solve(method="policy_iteration")
    mdp = lb.FiniteMDP.from_quantecon(R, Q, beta)  # n == m == 25, no layout=
    dp = lb.solve_exact(mdp)
    # QuantEcon's policy iteration solves the final linear system: exact to rounding
    slack = 1e-12 * np.abs(res.v).max()
    assert np.all(dp.lower_values - slack <= res.v) and np.all(res.v <= dp.upper_values + slack)
    assert dp.upper_values.max() - dp.lower_values.min() > 0
    np.testing.assert_allclose(dp.values, res.v, rtol=0, atol=2 * dp.error_bound + slack)
    np.testing.assert_array_equal(dp.policy, res.sigma)


def test_beta_zero():
    # test_ddp.py::test_ddp_beta_0: v_star = [1, 1, 1], sigma_star = [1, 0, 1]
    R = np.array([[0, 1], [1, 0], [0, 1]])
    Q = np.full((3, 2, 3), 1 / 3)
    v, pol = exact(lb.FiniteMDP.from_quantecon(R, Q, 0))  # (3, 2, 3): the shapes decide
    np.testing.assert_array_equal(v, [1, 1, 1])
    np.testing.assert_array_equal(pol, [1, 0, 1])


def test_sorting_of_state_action_pairs():
    # test_ddp.py::test_ddp_sorting: sorted and shuffled pairs are the same model
    Q = [(1, 0), (1 / 2, 1 / 2), (0, 1)]
    sorted_ = lb.FiniteMDP.from_quantecon([0, 1, 2], Q, BETA, [0, 0, 1], [0, 1, 0])
    shuffled = lb.FiniteMDP.from_quantecon(
        [0, 2, 1], sp.csr_matrix([(1, 0), (0, 1), (1 / 2, 1 / 2)]), BETA, [0, 1, 0], [0, 0, 1]
    )
    for mdp in (sorted_, shuffled):
        np.testing.assert_array_equal(mdp.rewards, [[0, 1], [2, 0]])
        np.testing.assert_array_equal(mdp.allowed, [[True, True], [True, False]])
    # no published values upstream: V* against the enumeration of every policy
    v_ref, optimal = brute_force(
        [[[1, 0], [0, 1]], [[0.5, 0.5], [0, 1]]], [[0, 1], [2, 0]], BETA, sorted_.allowed
    )
    for mdp in (sorted_, shuffled):
        v, pol = exact(mdp)
        np.testing.assert_allclose(v, v_ref, rtol=1e-12)
        assert_policy_optimal(pol, optimal)


def test_to_sa_and_to_product_forms_agree():
    # test_ddp.py::test_ddp_to_sa_and_to_product: one -inf reward; the product Q keeps an
    # all-zero row for the unavailable pair ("funky_Q"), which must be ignored
    R = np.array([[0, 1], [1, 0], [-np.inf, 1]])
    Q = np.full((3, 2, 3), 1 / 3)
    Q[0, 0, 0], Q[0, 0, 1] = 0, 2 / 3
    funky = Q.copy()
    funky[2, 0, :] = 0
    sa_R = [0, 1, 1, 0, 1]
    sa_Q = np.full((5, 3), 1 / 3)
    sa_Q[0, 0], sa_Q[0, 1] = 0, 2 / 3
    models = [
        lb.FiniteMDP.from_quantecon(R, Q, BETA),
        lb.FiniteMDP.from_quantecon(R, funky, BETA),
        lb.FiniteMDP.from_quantecon(
            sa_R, sp.coo_matrix(sa_Q), BETA, [0, 0, 1, 1, 2], [0, 1, 0, 1, 1]
        ),
    ]
    allowed = R > -np.inf
    v_ref, optimal = brute_force(Q.transpose(1, 0, 2), np.where(allowed, R, 0), BETA, allowed)
    for mdp in models:
        np.testing.assert_array_equal(mdp.allowed, allowed)
        v, pol = exact(mdp)
        np.testing.assert_allclose(v, v_ref, rtol=1e-12)
        assert_policy_optimal(pol, optimal)


# ---------------------------------------------------------------------- refused inputs
def test_negative_inf_everywhere_in_a_state():
    # test_ddp.py::test_ddp_negative_inf_error: state 2 has no finite reward
    R = np.array([[0, 1], [0, -np.inf], [-np.inf, -np.inf]])
    Q = np.full((3, 2, 3), 1 / 3)
    with pytest.raises(ValidationError, match="state 2 has no allowed action"):
        lb.FiniteMDP.from_quantecon(R, Q, BETA)
    with pytest.raises(ValidationError, match="state 2 has no allowed action"):
        lb.FiniteMDP.from_quantecon(
            R.reshape(6), sp.csr_matrix(Q.reshape(6, 3)), BETA, [0, 0, 1, 1, 2, 2], [0, 1] * 3
        )


@pytest.mark.parametrize(
    "s_indices",
    [[0, 0, 2, 2], [0, 0, 1, 1], [1, 0, 1, 0]],
    ids=["state-1-missing", "trailing-state-missing", "trailing-unsorted"],
)
def test_state_without_feasible_action(s_indices):
    # test_ddp.py::test_ddp_no_feasible_action_error(_trailing_state)
    a_indices = [0, 1, 0, 1] if s_indices[0] == 0 else [0, 0, 1, 1]
    missing = 1 if s_indices == [0, 0, 2, 2] else 2
    with pytest.raises(ValidationError, match=f"state {missing} has no allowed action"):
        lb.FiniteMDP.from_quantecon([1, 0, 0, 1], [(1 / 3,) * 3] * 4, BETA, s_indices, a_indices)


@pytest.mark.parametrize("sparse", [False, True])
def test_duplicate_state_action_pair(sparse):
    # test_ddp.py::test_ddp_duplicate_sa_pair_error: (1, 0) is listed twice
    Q = [(0.5, 0.5), (1.0, 0.0), (0.25, 0.75), (0.6, 0.4)]
    Q = sp.csr_matrix(Q) if sparse else Q
    with pytest.raises(ValidationError, match=r"pair \(state 1, action 0\) is listed twice"):
        lb.FiniteMDP.from_quantecon([1.0, 2.0, 3.0, 4.0], Q, BETA, [1, 1, 0, 0], [0, 0, 0, 1])


@pytest.mark.parametrize(
    ("s_indices", "a_indices", "message"),
    [
        ([0, 2], [0, 0], r"s_indices\[1\] = 2 is out of range \[0, 2\)"),
        ([2, 0], [0, 0], r"s_indices\[0\] = 2 is out of range"),
        ([-1, 0], [0, 0], r"s_indices\[0\] = -1 is out of range"),
        ([0, 1], [0, -1], r"a_indices\[1\] = -1 is out of range"),
    ],
)
def test_out_of_range_indices(s_indices, a_indices, message):
    # test_ddp.py::test_ddp_out_of_range_indices_error
    with pytest.raises(ValidationError, match=message):
        lb.FiniteMDP.from_quantecon(
            [1.0, 2.0], [(1.0, 0.0), (0.0, 1.0)], BETA, s_indices, a_indices
        )


# ---------------------------------------------------------------------- DiscreteDP objects
def test_discrete_dp_objects_and_back():
    qe = pytest.importorskip("quantecon", reason="the interop extra: pip install -e '.[interop]'")
    ddp0 = qe.markov.DiscreteDP(R_PUTERMAN, Q_PUTERMAN, BETA)
    ddps = [
        ddp0,
        qe.markov.DiscreteDP(R_SA, _q_sa_lil(), BETA, S_IND, A_IND),
        qe.markov.DiscreteDP(R_SA, _q_sa_lil().toarray(), BETA, S_IND, A_IND),
        ddp0.to_sa_pair_form(),
    ]
    for ddp in ddps:  # an object's layout is its own: no layout= needed even with n == m
        mdp = lb.FiniteMDP.from_quantecon(ddp)
        v, pol = exact(mdp)
        np.testing.assert_allclose(v, V_STAR, rtol=1e-12)
        np.testing.assert_array_equal(pol, SIGMA_STAR)
        for form in ("sa", "product"):  # and back: QuantEcon's own policy iteration agrees
            res = mdp.to_quantecon(form).solve(method="policy_iteration")
            np.testing.assert_allclose(res.v, V_STAR, rtol=1e-10)
            np.testing.assert_array_equal(res.sigma, SIGMA_STAR)
