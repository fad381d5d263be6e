"""pymdptoolbox's published test cases through ``FiniteMDP.from_pymdptoolbox``.

Upstream: repository sawcordwell/pymdptoolbox, files under ``src/tests/`` (and the
doctests of ``src/mdptoolbox/mdp.py``, run by its ``runtests.sh`` with ``--with-doctest``).
Only the data and the published values are copied. Values marked "from Octave
MDPtoolbox" upstream are exact solves (policy iteration with a linear solve) and are
compared to ``lpbounds.solve_exact`` directly; values that upstream publishes for value
iteration, Gauss-Seidel or modified policy iteration are approximate *iterates*: for
those the test checks the published policy and that V* (exact) lies in the Porteus
bracket the published iterate certifies (a bracket computed here with numpy).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import lpbounds as lb

from ._reference import assert_policy_optimal, brute_force, exact, porteus_bracket

# src/tests/utils.py: P_small, R_small = mdptoolbox.example.small() (values as published
# in src/tests/test_MDP.py::test_MDP_P_R_1)
P_SMALL = np.array([[[0.5, 0.5], [0.8, 0.2]], [[0.0, 1.0], [0.1, 0.9]]])
R_SMALL = np.array([[5.0, 10.0], [-1.0, 2.0]])


def p_sparse_object_array():
    """src/tests/utils.py: ``P_sparse = np.empty(2, dtype=object)`` holding CSR matrices."""
    out = np.empty(2, dtype=object)
    out[0] = sp.csr_matrix(P_SMALL[0])
    out[1] = sp.csr_matrix(P_SMALL[1])
    return out


def forest(S=3, r1=4.0, r2=2.0, p=0.1, is_sparse=False):
    """The forest example, written from its definition in the docstring of
    src/mdptoolbox/example.py::forest (Wait = 0: burn to 0 w.p. p, else age by one,
    the oldest stays; Cut = 1: back to 0; rewards r1 for waiting in the oldest state,
    1 for cutting (0 in state 0, r2 in the oldest))."""
    P = np.zeros((2, S, S))
    P[0, np.arange(S - 1), np.arange(1, S)] = 1 - p
    P[0, S - 1, S - 1] = 1 - p
    P[0, :, 0] += p
    P[1, :, 0] = 1.0
    R = np.zeros((S, 2))
    R[S - 1, 0] = r1
    R[1:, 1] = 1.0
    R[S - 1, 1] = r2
    if is_sparse:
        return [sp.csr_matrix(P[0]), sp.csr_matrix(P[1])], R
    return P, R


def test_forest_helper_matches_the_published_arrays():
    # src/tests/project/test_examples.py::TestExampleForest (P and R of forest())
    P_pub = np.array(
        [[[0.1, 0.9, 0.0], [0.1, 0.0, 0.9], [0.1, 0.0, 0.9]], [[1, 0, 0], [1, 0, 0], [1, 0, 0]]]
    )
    R_pub = np.array([[0, 0], [0, 1], [4, 2]])
    P, R = forest()
    np.testing.assert_allclose(P, P_pub, atol=1e-15)
    np.testing.assert_array_equal(R, R_pub)


# ---------------------------------------------------------------------- exact solves
@pytest.mark.parametrize("form", ["dense (A, n, n)", "object array of CSR"])
def test_policy_iteration_small(form):
    # src/tests/test_PolicyIteration.py::test_PolicyIteration_small and
    # ::test_PolicyIteration_small_sparse (v and p "from Octave MDPtoolbox")
    P = P_SMALL if form.startswith("dense") else p_sparse_object_array()
    v, pol = exact(lb.FiniteMDP.from_pymdptoolbox(P, R_SMALL, 0.9))
    np.testing.assert_allclose(v, [42.4418604651163, 36.0465116279070], atol=1e-11)
    np.testing.assert_array_equal(pol, [1, 0])


def test_google_code_issue_5_np_array_of_csr():
    # src/tests/test_PolicyIteration.py::test_goggle_code_issue_5: P = np.array([csr, csr])
    P = np.array([sp.csr_matrix([[0.5, 0.5], [0.8, 0.2]]), sp.csr_matrix([[0.0, 1.0], [0.1, 0.9]])])
    assert P.dtype == object and P.shape == (2,)
    v, pol = exact(lb.FiniteMDP.from_pymdptoolbox(P, np.array([[5, 10], [-1, 2]]), 0.96))
    np.testing.assert_allclose(v, [100.67873303167413, 94.45701357466055], atol=1e-11)
    # upstream publishes no policy here: the enumeration of all four policies decides it
    _, optimal = brute_force(P, [[5, 10], [-1, 2]], 0.96)
    assert_policy_optimal(pol, optimal)


@pytest.mark.parametrize(
    ("discount", "expected"),
    [
        # src/tests/test_PolicyIteration.py::test_PolicyIteration_matrix_forest
        (0.9, [26.2440000000000, 29.4840000000000, 33.4840000000000]),
        # src/tests/test_PolicyIteration.py::test_PolicyIterative_forest (from Octave)
        (0.96, [74.6496000000000, 78.1056000000000, 82.1056000000000]),
    ],
)
def test_policy_iteration_forest(discount, expected):
    P, R = forest()
    v, pol = exact(lb.FiniteMDP.from_pymdptoolbox(P, R, discount))
    np.testing.assert_allclose(v, expected, atol=1e-11)
    np.testing.assert_array_equal(pol, [0, 0, 0])


def test_policy_iteration_forest_sparse_ten_states():
    # src/tests/test_PolicyIteration.py::test_PolicyIterative_forest_sparse (from Octave):
    # P is a list of CSR matrices (forest(S=10, is_sparse=True)), R a dense (S, A) array
    P, R = forest(S=10, is_sparse=True)
    v, pol = exact(lb.FiniteMDP.from_pymdptoolbox(P, R, 0.96))
    expected = [26.8301859311444, 28.0723241686974, 29.5099841658652, 31.1739424959205,
                33.0998201927438, 35.3288453048078, 37.9087354808078, 40.8947194808078,
                44.3507194808078, 48.3507194808078]  # fmt: skip
    np.testing.assert_allclose(v, expected, atol=1e-10)
    np.testing.assert_array_equal(pol, np.zeros(10, int))


# ---------------------------------------------------------------------- published iterates
# Each row: (upstream location, P, R, discount, published V, published policy). The
# values are iterates stopped by the upstream algorithm's own criterion, not V*: V* must
# lie in the Porteus bracket they certify, and the published policy must be optimal.
ITERATES = {
    # src/tests/test_PolicyIteration.py::test_PolicyIteration_iterative_forest (eval_type=1:
    # iterative policy evaluation to epsilon=1e-4, so V is ~1e-4 below V*)
    "PI-iterative-forest": ("forest", 0.9, [26.2439058351861, 29.4839058351861,
                                            33.4839058351861], (0, 0, 0)),
    # src/tests/test_ValueIteration.py::test_ValueIteration_small (26 sweeps from 0)
    "VI-small": ("small", 0.9, [40.048625392716822, 33.65371175967546], (1, 0)),
    # src/tests/test_ValueIteration.py::test_ValueIteration_small_sparse (P_sparse)
    "VI-small-sparse": ("small-sparse", 0.9, [40.048625392716822, 33.65371175967546], (1, 0)),
    # src/tests/test_ValueIterationGS.py::test_ValueIterationGS_small (28 Gauss-Seidel sweeps)
    "VIGS-small": ("small", 0.9, [42.27744026138212, 35.89524504047155], (1, 0)),
    # src/tests/test_ValueIterationGS.py::test_ValueIterationGS_forest
    "VIGS-forest": ("forest", 0.96, [69.98910821400665, 73.46560194552877,
                                     77.46560194552877], (0, 0, 0)),
    # src/tests/test_PolicyIterationModified.py::TestPolicyIterationModified::test_small
    "PIM-small": ("small", 0.9, [41.8656419239403, 35.4702797722819], (1, 0)),
    # doctests of src/mdptoolbox/mdp.py: PolicyIterationModified(forest, 0.9)
    "PIM-forest-doctest": ("forest", 0.9, [21.81408652334702, 25.054086523347017,
                                           29.054086523347017], (0, 0, 0)),
    # doctests of src/mdptoolbox/mdp.py: ValueIteration(forest, 0.96), 4 sweeps from 0
    # (stopped by the span criterion: the policy is right, the values far below V*)
    "VI-forest-doctest": ("forest", 0.96, [5.93215488, 9.38815488, 13.38815488], (0, 0, 0)),
    # doctests of src/mdptoolbox/mdp.py: ValueIterationGS(forest, 0.9)
    "VIGS-forest-doctest": ("forest", 0.9, [25.5833879767579, 28.830654635546928,
                                            32.83065463554693], (0, 0, 0)),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(ITERATES))
def test_published_iterates_bracket_the_exact_solution(case):
    model, discount, published, policy = ITERATES[case]
    if model == "forest":
        P, R = forest()
    else:
        P = P_SMALL if model == "small" else p_sparse_object_array()
        R = R_SMALL
    v, pol = exact(lb.FiniteMDP.from_pymdptoolbox(P, R, discount))
    lo, hi = porteus_bracket(P, R, discount, np.array(published))
    assert np.all(lo - 1e-9 <= v) and np.all(v <= hi + 1e-9), (lo, v, hi)
    np.testing.assert_array_equal(pol, policy)
    # and V* itself, from the enumeration of every policy (independent of lpbounds)
    np.testing.assert_allclose(v, brute_force(P, R, discount)[0], rtol=1e-12)


# ---------------------------------------------------------------------- input forms
# src/tests/test_MDP.py::TestMDP: a 5-state model given as nested tuples, with
# per-transition rewards and the expected rewards pymdptoolbox computes from them
MDP_P = (((0.0, 0.0, 0.6, 0.4, 0.0), (0.0, 0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0, 0.0, 0.0),
          (0.0, 0.0, 0.0, 1.0, 0.0), (0.0, 0.0, 0.0, 0.0, 1.0)),
         ((0.0, 0.4, 0.0, 0.0, 0.6), (0.0, 1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0, 1.0),
          (0.0, 0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 0.0, 1.0)))  # fmt: skip
MDP_R = tuple(
    tuple(tuple(1 if (a, x, y) == (1, 0, 4) else 0 for y in range(5)) for x in range(5))
    for a in range(2)
)
COMPUTED_R = ((0.0, 0.0, 0.0, 0.0, 0.0), (0.6, 0.0, 0.0, 0.0, 0.0))


def _object_array(mats):
    out = np.empty(len(mats), dtype=object)
    for k, m in enumerate(mats):
        out[k] = m
    return out


MDP_FORMS = {
    # test_a: np.array(P), np.array(R) (3-d per-transition rewards)
    "a-3d-arrays": lambda: (np.array(MDP_P), np.array(MDP_R), np.array(COMPUTED_R).T),
    # test_b: R of shape (S, A)
    "b-R-(S,A)": lambda: (np.array(MDP_P), np.array(COMPUTED_R).T, np.array(COMPUTED_R).T),
    # test_c: R = (0, 1, 0, 1, 0), a tuple: one reward per state
    "c-R-per-state": lambda: (
        np.array(MDP_P),
        (0, 1, 0, 1, 0),
        np.repeat([[0.0], [1], [0], [1], [0]], 2, axis=1),
    ),
    # test_d: lists of CSR matrices for both P and R
    "d-lists-of-csr": lambda: (
        [sp.csr_matrix(np.array(m)) for m in MDP_P],
        [sp.csr_matrix(np.array(m)) for m in MDP_R],
        np.array(COMPUTED_R).T,
    ),
    # test_e: 1-d object arrays of dense matrices
    "e-object-arrays": lambda: (
        _object_array([np.array(m) for m in MDP_P]),
        _object_array([np.array(m) for m in MDP_R]),
        np.array(COMPUTED_R).T,
    ),
    # the raw nested tuples themselves (the matrices as tuples of tuples)
    "nested-tuples": lambda: (MDP_P, MDP_R, np.array(COMPUTED_R).T),
}


@pytest.mark.parametrize("form", sorted(MDP_FORMS))
def test_every_input_form_of_test_MDP(form):
    P, R, expected_r = MDP_FORMS[form]()
    # upstream builds these with discount=None (no solve); 0.9 is chosen here
    mdp = lb.FiniteMDP.from_pymdptoolbox(P, R, 0.9)
    np.testing.assert_allclose(mdp.rewards, expected_r, atol=1e-15)
    v, pol = exact(mdp)
    v_ref, optimal = brute_force(np.array(MDP_P), expected_r, 0.9)
    np.testing.assert_allclose(v, v_ref, rtol=1e-12, atol=1e-12)
    assert_policy_optimal(pol, optimal)


@pytest.mark.parametrize(
    ("P", "R", "expected"),
    [
        # src/tests/test_MDP.py::test_MDP_P_R_2: R of shape (A, S, S) on P_small
        (P_SMALL, [[[5, 10], [-1, 2]], [[1, 2], [3, 4]]], [[7.5, -0.4], [2, 3.9]]),
        # src/tests/test_MDP.py::test_MDP_P_R_3
        (
            [[[0.6116, 0.3884], [0, 1]], [[0.6674, 0.3326], [0, 1]]],
            [[[-0.2433, 0.7073], [0, 0.1871]], [[-0.0069, 0.6433], [0, 0.2898]]],
            [[0.12591304, 0.1871], [0.20935652, 0.2898]],
        ),
    ],
    ids=["P_R_2", "P_R_3"],
)
def test_transition_rewards_published_expectations(P, R, expected):
    mdp = lb.FiniteMDP.from_pymdptoolbox(P, R, 0.9)
    # upstream publishes R per action (rows); lpbounds stores R[state, action]
    np.testing.assert_allclose(mdp.rewards, np.array(expected).T, atol=1e-8)
    v, pol = exact(mdp)
    v_ref, optimal = brute_force(P, np.array(expected).T, 0.9)
    np.testing.assert_allclose(v, v_ref, atol=1e-7)  # the published expectations have 8 digits
    assert_policy_optimal(pol, optimal)


# src/tests/test_issue7.py::BaseTestIssue7: 9 states, P and R as lists of two matrices
ISSUE7_P0 = np.zeros((9, 9))
ISSUE7_P0[[0, 0, 1, 1, 2, 2], [3, 6, 4, 7, 5, 8]] = [0.64, 0.36, 0.93, 0.07, 0.2, 0.8]
ISSUE7_P0[np.arange(3, 9), np.arange(3, 9)] = 1.0
ISSUE7_P1 = np.zeros((9, 9))
ISSUE7_P1[[0, 0, 1, 2, 3, 3, 4, 5, 6, 6, 7, 8], [2, 4, 4, 2, 4, 5, 4, 5, 7, 8, 7, 8]] = [
    0.4, 0.6, 1.0, 1.0, 0.87, 0.13, 1.0, 1.0, 0.11, 0.89, 1.0, 1.0,
]  # fmt: skip
ISSUE7_R1 = np.zeros((9, 9))
ISSUE7_R1[[0, 1], [4, 4]] = 1.0
ISSUE7_COMPUTED_R = np.array([np.zeros(9), [0.6, 1.0, 0, 0, 0, 0, 0, 0, 0]]).T
ISSUE7_POLICY = (1, 1, 0, 0, 0, 0, 0, 0, 0)


@pytest.mark.parametrize("p_sparse", [False, True], ids=["dense-P", "sparse-P"])
@pytest.mark.parametrize("r_sparse", [False, True], ids=["dense-R", "sparse-R"])
def test_issue7_lists_of_matrices(p_sparse, r_sparse):
    # src/tests/test_issue7.py::dense_P_dense_R, sparse_P_dense_R, dense_P_sparse_R,
    # sparse_P_sparse_R (policy published; discount 0.9)
    P = [ISSUE7_P0, ISSUE7_P1]
    R = [np.zeros((9, 9)), ISSUE7_R1]
    if p_sparse:
        P = [sp.csr_matrix(m) for m in P]
    if r_sparse:
        R = [sp.csr_matrix(m) for m in R]
    mdp = lb.FiniteMDP.from_pymdptoolbox(P, R, 0.9)
    np.testing.assert_array_equal(mdp.rewards, ISSUE7_COMPUTED_R)
    v, pol = exact(mdp)
    np.testing.assert_array_equal(pol, ISSUE7_POLICY)
    np.testing.assert_allclose(v, brute_force(P, ISSUE7_COMPUTED_R, 0.9)[0], atol=1e-12)


def test_example_rand_published_arrays():
    # src/tests/project/test_examples.py::TestExampleRand: P (A, S, S) and per-transition R
    # (A, S, S) of example.rand(3, 2) with seed 0 (no solve upstream; discount 0.9 here)
    P = np.array(
        [[[0.28109922699468015, 0.4285572503528079, 0.2903435226525119],
          [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
         [[0.4656280088928742, 0.21500769329533384, 0.31936429781179193],
          [0.0, 0.0, 1.0], [0.19806726878845474, 0.8019327312115453, 0.0]]]
    )  # fmt: skip
    R = np.array(
        [[[0.7835460015641595, 0.9273255210020586, -0.2331169623484446],
          [0.0, -0.7192984391747097, 0.0], [0.0, -0.7881847856244157, -0.0]],
         [[-0.22702203774827612, 0.8051969510588093, -0.10010002017754482],
          [-0.0, -0.0, 0.14039354083575928],
          [-0.06737845428738742, -0.5111488159967945, -0.0]]]
    )  # fmt: skip
    mdp = lb.FiniteMDP.from_pymdptoolbox(P, R, 0.9)
    r_pairs = (P * R).sum(axis=2).T
    np.testing.assert_allclose(mdp.rewards, r_pairs, atol=1e-15)
    v, pol = exact(mdp)
    v_ref, optimal = brute_force(P, r_pairs, 0.9)
    np.testing.assert_allclose(v, v_ref, atol=1e-12)
    assert_policy_optimal(pol, optimal)
