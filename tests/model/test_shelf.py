"""The shelf of known models: each against an independent computation of its source.

* forest: pymdptoolbox's own ``mdptoolbox.example.forest`` arrays and its
  ``PolicyIteration`` / ``ValueIteration`` (skipped without pymdptoolbox);
* savings: QuantEcon's lecture code (``SimpleOG``, written out here) and
  ``DiscreteDP.solve()`` (skipped without QuantEcon);
* queue, inventory, gridworld: dense matrices built here from the documented formulas
  (a transient chain solved for the queue, the book's demand sum for the inventory, the
  book's moves for the gridworld), never from the shelf's arrays, solved by the dense
  policy iteration of ``tests/_independent.py``; plus the numbers the sources publish
  (MDPSolver's mean 17075, Sutton and Barto's Figure 3.5);
* FrozenLake, Taxi, CliffWalking: value iteration on Gymnasium's own ``env.P``
  (``tests/model/interop/test_gymnasium.py``; skipped without Gymnasium).

Then the instance files: every shelf name is a MODEL of ``solve``, ``compare``,
``export`` and ``verify``; the sizes read from a file's parameters are those of the
built model; bad parameters name the key; a missing Gymnasium is one clear line.
"""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.cli.main import main
from lpbounds.errors import SolverNotInstalledError, ValidationError
from lpbounds.formulations import RLP
from lpbounds.model import shelf
from tests import _independent as ind

SHELF_FILES = ["forest", "gridworld", "queue", "inventory", "savings"]
GYM_FILES = ["frozenlake", "taxi", "cliffwalking"]


def _dense(mdp: lb.FiniteMDP) -> np.ndarray:
    """``P`` (A, n, n) of the allowed pairs (rows of pairs not allowed are 0)."""
    P = ind.dense_transitions(mdp.successors, mdp.probabilities)
    return P * mdp.allowed.T[:, :, None]


def _assert_values(mdp: lb.FiniteMDP, ref: ind.Reference, atol: float = 0.0) -> lb.DPResult:
    """lpbounds' V* within its certificate plus the reference's own error of ``ref``."""
    res = lb.solve_exact(mdp, "pi")
    slack = res.error_bound + ref.error + atol
    np.testing.assert_allclose(res.values, ref.values, rtol=0, atol=slack)
    assert np.all(res.lower_values <= ref.values + ref.error + atol)
    assert np.all(ref.values - ref.error - atol <= res.upper_values)
    return res


# ---------------------------------------------------------------------- forest
@pytest.mark.parametrize(
    ("S", "r1", "r2", "p", "discount"),
    [(3, 4, 2, 0.1, 0.9), (7, 10, 3, 0.25, 0.95), (2, 1, 5, 0.0, 0.5), (12, 4, 2, 0.9, 0.99)],
)
def test_forest_is_pymdptoolbox_example(S, r1, r2, p, discount):
    ex = pytest.importorskip("mdptoolbox.example")
    mdp_mod = pytest.importorskip("mdptoolbox.mdp")
    P, R = ex.forest(S=S, r1=r1, r2=r2, p=p)
    mdp = lb.instances.forest(S=S, r1=r1, r2=r2, p=p, discount=discount)
    np.testing.assert_array_equal(_dense(mdp), P)
    np.testing.assert_array_equal(mdp.rewards, R)
    pi = mdp_mod.PolicyIteration(P, R, discount)  # exact policy evaluation (a matrix solve)
    pi.run()
    res = lb.solve_exact(mdp, "pi")
    scale = max(1.0, float(np.abs(pi.V).max()))
    np.testing.assert_allclose(res.values, pi.V, rtol=0, atol=res.error_bound + 1e-12 * scale)
    assert tuple(res.policy) == tuple(pi.policy)
    # ValueIteration stops on the span of its last step, so its V is V* plus a constant
    # (forest's iterates from 0 rise by the same amount everywhere); the policy is optimal
    vi = mdp_mod.ValueIteration(P, R, discount, epsilon=1e-6)
    vi.run()
    assert np.ptp(res.values - vi.V) <= 1e-6 + 2 * res.error_bound
    assert tuple(res.policy) == tuple(vi.policy)


def test_forest_published_values():
    """pymdptoolbox's PolicyIteration docstring: V = (26.244, 29.484, 33.484) at 0.9."""
    res = lb.solve_exact(lb.load_instance("forest").mdp(), "pi")
    np.testing.assert_allclose(res.values, [26.244, 29.484, 33.484], rtol=0, atol=5e-4)
    assert tuple(res.policy) == (0, 0, 0)


# ---------------------------------------------------------------------- savings
class SimpleOG:
    """QuantEcon's lecture *Discrete State Dynamic Programming*, its ``SimpleOG`` class."""

    def __init__(self, B=10, M=5, alpha=0.5, beta=0.9):
        self.B, self.M, self.alpha, self.beta = B, M, alpha, beta
        self.n = B + M + 1
        self.m = M + 1
        self.R = np.empty((self.n, self.m))
        self.Q = np.zeros((self.n, self.m, self.n))
        for a in range(self.m):
            self.Q[:, a, a : (a + B + 1)] = 1.0 / (B + 1)
        for s in range(self.n):
            for a in range(self.m):
                self.R[s, a] = (s - a) ** alpha if a <= s else -np.inf


@pytest.mark.parametrize(
    ("B", "M", "alpha", "beta"), [(10, 5, 0.5, 0.9), (4, 4, 0.3, 0.95), (6, 0, 1.0, 0.8)]
)
def test_savings_is_quantecon_discrete_dp(B, M, alpha, beta):
    qe = pytest.importorskip("quantecon")
    g = SimpleOG(B, M, alpha, beta)
    ddp = qe.markov.DiscreteDP(g.R, g.Q, g.beta)
    ref = ddp.solve(method="policy_iteration")
    mdp = lb.instances.savings(B=B, M=M, alpha=alpha, discount=beta)
    np.testing.assert_array_equal(mdp.allowed, np.isfinite(g.R))
    Q = g.Q * mdp.allowed[:, :, None]  # QuantEcon's rows of the pairs R = -inf are not read
    np.testing.assert_allclose(_dense(mdp), Q.transpose(1, 0, 2), rtol=0, atol=1e-15)
    res = lb.solve_exact(mdp, "pi")
    scale = max(1.0, float(np.abs(ref.v).max()))
    np.testing.assert_allclose(res.values, ref.v, rtol=0, atol=res.error_bound + 1e-12 * scale)
    assert np.all(res.lower_values <= ref.v + 1e-12 * scale)
    assert np.all(ref.v - 1e-12 * scale <= res.upper_values)
    np.testing.assert_array_equal(res.policy, ref.sigma)


def test_savings_file_is_the_lecture_model():
    """The lecture prints v[0] = 19.01740222 and v[-1] = 23.27761762 (SimpleOG())."""
    res = lb.solve_exact(lb.load_instance("savings").mdp(), "pi")
    np.testing.assert_allclose(res.values[[0, -1]], [19.01740222, 23.27761762], atol=1e-8)


# ---------------------------------------------------------------------- queue
def queue_reference(capacity, rates, mu, rewards, discount):
    """Dense ``P`` (2, n, n), ``R``, ``allowed`` of the admission queue from its description.

    A customer of type ``t`` arrives and finds ``j`` (state ``t * (capacity + 1) + j``);
    rejecting leaves ``K = j``, accepting ``K = j + 1`` (paying ``rewards[t]``, not when
    ``j = capacity``). Until the next arrival (rate ``lam = sum(rates)``) each of the
    ``k`` customers leaves at rate ``mu``: the embedded chain moves ``k -> k - 1`` with
    probability ``k mu / (k mu + lam)`` and is absorbed ("the arrival finds k") with
    probability ``lam / (k mu + lam)``. The absorption probabilities are one linear
    solve; the arrival is of type ``t'`` with probability ``rates[t'] / lam``.
    """
    rates = np.asarray(rates, float)
    lam, ns, types = rates.sum(), capacity + 1, len(rates)
    k = np.arange(ns)
    down = np.zeros((ns, ns))
    down[k[1:], k[1:] - 1] = k[1:] * mu / (k[1:] * mu + lam)
    absorb = np.diag(lam / (k * mu + lam))
    found = np.linalg.solve(np.eye(ns) - down, absorb)  # found[K, j]
    n = types * ns
    P = np.zeros((2, n, n))
    R = np.zeros((n, 2))
    allowed = np.ones((n, 2), bool)
    for t in range(types):
        for j in range(ns):
            x = t * ns + j
            allowed[x, 1] = j < capacity
            for a, after in ((0, j), (1, j + 1))[: 1 + int(allowed[x, 1])]:
                P[a, x] = np.concatenate([rates[u] / lam * found[after] for u in range(types)])
            R[x, 1] = rewards[t]
    return P, R, allowed


@pytest.mark.parametrize(
    ("capacity", "rates", "mu", "rewards", "discount"),
    [(8, [2.0, 1.0], 0.75, [1.0, 10.0], 0.95), (5, [0.5, 3.0, 1.0], 2.0, [4, 1, 2], 0.9)],
)
def test_queue_against_its_description(capacity, rates, mu, rewards, discount):
    P, R, allowed = queue_reference(capacity, rates, mu, rewards, discount)
    mdp = lb.instances.admission_queue(capacity, rates, mu, rewards, discount)
    np.testing.assert_allclose(_dense(mdp), P, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(mdp.allowed, allowed)
    _assert_values(mdp, ind.policy_iteration(P, R, allowed, discount))


def test_queue_file_is_mdpsolver_test2():
    """MDPSolver's test2.py: the mean of V* rounds to 17075 (capacity 100, discount 0.99)."""
    mdp = lb.load_instance("queue").mdp()
    assert mdp.n_states == 202
    P, R, allowed = queue_reference(100, [50.0, 10.0], 0.75, [1.0, 1000.0], 0.99)
    np.testing.assert_allclose(_dense(mdp), P, rtol=0, atol=1e-12)
    ref = ind.policy_iteration(P, R, allowed, 0.99)
    res = _assert_values(mdp, ref)
    assert round(float(res.values.mean())) == round(float(ref.values.mean())) == 17075


# ---------------------------------------------------------------------- inventory
def inventory_reference(K, c, kappa, p, discount, d_max=101):
    """The book's ``inventory_dp.py``: demand ``phi(d) = (1 - p)^d p`` summed to ``d_max``,
    profit ``sum min(x, d) phi(d) - c a - kappa [a > 0]``, next ``max(x - d, 0) + a``."""
    n = K + 1
    phi = (1 - p) ** np.arange(d_max) * p
    P = np.zeros((n, n, n))
    R = np.zeros((n, n))
    allowed = np.zeros((n, n), bool)
    for x in range(n):
        for a in range(n - x):
            allowed[x, a] = True
            R[x, a] = sum(min(x, d) * phi[d] for d in range(d_max)) - c * a - kappa * (a > 0)
            for d in range(d_max):
                P[a, x, max(x - d, 0) + a] += phi[d]
    return P, R, allowed


@pytest.mark.parametrize(
    ("K", "c", "kappa", "p", "discount"),
    [(40, 0.2, 2.0, 0.6, 0.98), (6, 0.5, 0.0, 0.3, 0.9), (10, 0.1, 1.0, 0.9, 0.95)],
)
def test_inventory_against_the_book(K, c, kappa, p, discount):
    P, R, allowed = inventory_reference(K, c, kappa, p, discount)
    mdp = lb.instances.inventory(K=K, c=c, kappa=kappa, p=p, discount=discount)
    np.testing.assert_array_equal(mdp.allowed, allowed)
    # the book truncates the demand at 101: (1 - p)^101 of the mass is not summed
    trunc = (1 - p) ** 101
    np.testing.assert_allclose(_dense(mdp), P, rtol=0, atol=1e-14 + trunc)
    np.testing.assert_allclose(mdp.rewards[allowed], R[allowed], rtol=0, atol=1e-13 + 101 * trunc)
    ref = ind.policy_iteration(P, R, allowed, discount)
    _assert_values(mdp, ref, atol=1e-12 * max(1.0, float(np.abs(ref.values).max())))


# ---------------------------------------------------------------------- gridworld
def gridworld_reference(rows, cols, jumps, off, discount):
    """Sutton and Barto's Example 3.5: deterministic moves N, S, E, W; off the grid stays
    and pays ``off``; every action of a jump cell pays its reward and moves to its target."""
    n = rows * cols
    P = np.zeros((4, n, n))
    R = np.zeros((n, 4))
    jump = {(r0, c0): (r1, c1, w) for r0, c0, r1, c1, w in jumps}
    for r in range(rows):
        for c in range(cols):
            x = r * cols + c
            for a, (dr, dc) in enumerate([(-1, 0), (1, 0), (0, 1), (0, -1)]):
                if (r, c) in jump:
                    r1, c1, w = jump[(r, c)]
                    P[a, x, r1 * cols + c1], R[x, a] = 1.0, w
                elif 0 <= r + dr < rows and 0 <= c + dc < cols:
                    P[a, x, (r + dr) * cols + c + dc] = 1.0
                else:
                    P[a, x, x], R[x, a] = 1.0, off
    return P, R, np.ones((n, 4), bool)


#: Sutton and Barto (2018), Figure 3.5: the optimal values of Example 3.5, rounded.
FIGURE_3_5 = [
    [22.0, 24.4, 22.0, 19.4, 17.5],
    [19.8, 22.0, 19.8, 17.8, 16.0],
    [17.8, 19.8, 17.8, 16.0, 14.4],
    [16.0, 17.8, 16.0, 14.4, 13.0],
    [14.4, 16.0, 14.4, 13.0, 11.7],
]


def test_gridworld_is_the_book_example():
    mdp = lb.load_instance("gridworld").mdp()
    jumps = [(0, 1, 4, 1, 10.0), (0, 3, 2, 3, 5.0)]
    P, R, allowed = gridworld_reference(5, 5, jumps, -1.0, 0.9)
    np.testing.assert_array_equal(_dense(mdp), P)
    np.testing.assert_array_equal(mdp.rewards, R)
    res = _assert_values(mdp, ind.policy_iteration(P, R, allowed, 0.9))
    np.testing.assert_allclose(res.values.reshape(5, 5), FIGURE_3_5, atol=0.05 + 1e-9)
    assert res.values[1] == pytest.approx(10 / (1 - 0.9**5), abs=1e-9)  # V*(A), Example 3.8


def test_gridworld_other_shapes():
    jumps = [(2, 0, 0, 3, 3.0), (1, 2, 1, 2, 1.0)]  # a jump onto itself too
    P, R, allowed = gridworld_reference(3, 4, jumps, -0.5, 0.8)
    mdp = lb.instances.gridworld(rows=3, cols=4, jumps=jumps, off_grid_reward=-0.5, discount=0.8)
    np.testing.assert_array_equal(_dense(mdp), P)
    _assert_values(mdp, ind.policy_iteration(P, R, allowed, 0.8))


# ---------------------------------------------------------------------- Gymnasium
GYM_ENVS = {  # the file's model, as Gymnasium builds it
    "frozenlake": ("FrozenLake-v1", {"map_name": "4x4", "is_slippery": True}),
    "taxi": (("Taxi-v4", "Taxi-v3"), {}),
    "cliffwalking": (("CliffWalking-v1", "CliffWalking-v0"), {}),
}


def _make(gym, ids, kwargs):
    ids = (ids,) if isinstance(ids, str) else ids
    return gym.make(next(i for i in ids if i in gym.envs.registry), **kwargs)


@pytest.mark.parametrize("name", GYM_FILES)
def test_gymnasium_files_against_value_iteration_on_p(name):
    gym = pytest.importorskip("gymnasium")
    from tests.model.interop.test_gymnasium import value_iteration

    env = _make(gym, *GYM_ENVS[name])
    ref = value_iteration(env, 0.99)
    inst = lb.load_instance(name)
    mdp = inst.mdp()
    n = int(env.observation_space.n)
    assert mdp.sink and mdp.n_user_states == n
    scale = max(1.0, float(np.abs(mdp.rewards).max()))
    res = lb.solve_exact(mdp, tol=1e-12 * scale)
    np.testing.assert_allclose(mdp.user_values(res.values), ref, rtol=0, atol=1e-9)
    # the file's partition: the sink alone, and RLP's certified bound above V*
    part = inst.partition()
    assert part.n_states == n + 1
    assert np.sum(part.labels == part.labels[n]) == 1
    rlp = RLP(mdp, part).solve("HIGHS")
    assert rlp.status == lb.Status.OPTIMAL
    assert np.all(part.lift(rlp.upper_values)[:n] >= ref - 1e-9)


FROZEN_8X8 = ("FrozenLake-v1", {"map_name": "8x8", "is_slippery": False})


@pytest.mark.parametrize(
    ("call", "env"),
    [
        (lambda: shelf.frozen_lake("8x8", False, 0.9), FROZEN_8X8),
        (lambda: shelf.taxi(0.9), GYM_ENVS["taxi"]),
        (lambda: shelf.cliff_walking(0.9), GYM_ENVS["cliffwalking"]),
    ],
    ids=["frozen_lake-8x8", "taxi", "cliff_walking"],
)
def test_gymnasium_functions(call, env):
    gym = pytest.importorskip("gymnasium")
    from tests.model.interop.test_gymnasium import value_iteration

    ref = value_iteration(_make(gym, *env), 0.9)
    mdp = call()
    res = lb.solve_exact(mdp, tol=1e-13 * max(1.0, float(np.abs(mdp.rewards).max())))
    np.testing.assert_allclose(mdp.user_values(res.values), ref, rtol=0, atol=1e-9)


def test_missing_gymnasium_is_a_typed_error_and_one_line(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "gymnasium", None)  # import gymnasium -> ImportError
    with pytest.raises(SolverNotInstalledError, match=r"needs Gymnasium.*lpbounds\[interop\]"):
        lb.load_instance("frozenlake").mdp()
    with pytest.raises(SolverNotInstalledError, match="Taxi-v4 needs Gymnasium"):
        shelf.taxi()
    capsys.readouterr()
    assert main(["solve", "cliffwalking"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "CliffWalking-v1 needs Gymnasium" in err and 'pip install "lpbounds[interop]"' in err


def test_gymnasium_bad_id_and_options():
    pytest.importorskip("gymnasium")
    with pytest.raises(ValidationError, match="registers none of NoSuchEnv-v0"):
        shelf.gymnasium_model("NoSuchEnv-v0")
    with pytest.raises(ValidationError, match="kwargs of FrozenLake-v1: Gymnasium refused"):
        shelf.gymnasium_model("FrozenLake-v1", kwargs={"map_name": "3x3"})


# ---------------------------------------------------------------------- the files
@pytest.mark.parametrize("name", SHELF_FILES + GYM_FILES)
def test_file_sizes_are_the_built_model_sizes(name):
    inst = lb.load_instance(name)
    if inst.kind == "gymnasium":
        pytest.importorskip("gymnasium")
    about = inst.config["about"]
    assert about["title"] and about["source"]  # every file cites its source
    sizes = shelf.model_sizes(inst.config["model"])
    mdp, part = inst.mdp(), inst.partition()
    assert sizes.discount == mdp.discount
    if sizes.n_states is not None:
        got = (mdp.n_states, mdp.n_actions, mdp.n_outcomes, mdp.n_pairs)
        assert (sizes.n_states, sizes.n_actions, sizes.n_outcomes, sizes.n_pairs) == got
        assert shelf.partition_size(inst.config["partition"], sizes) == part.n_partitions
    assert part.n_states == mdp.n_states


@pytest.mark.parametrize("name", SHELF_FILES)
def test_file_partitions_give_rlp_upper_bounds(name):
    inst = lb.load_instance(name)
    mdp, part = inst.mdp(), inst.partition()
    P = _dense(mdp)
    ref = ind.policy_iteration(P, mdp.rewards, mdp.allowed, mdp.discount)
    res = RLP(mdp, part).solve("HIGHS")
    assert res.status == lb.Status.OPTIMAL
    assert np.all(part.lift(res.upper_values) >= ref.values - ref.error)


def test_partitions_by_hand():
    np.testing.assert_array_equal(shelf.block_partition(5, 2).labels, [0, 0, 1, 1, 2])
    np.testing.assert_array_equal(shelf.block_partition(3, 2, sink=True).labels, [0, 0, 1, 2])
    # 3 x 3 cells in 2 x 2 tiles: [[0, 0, 1], [0, 0, 1], [2, 2, 3]]
    labels = shelf.grid_partition(3, 3, (2, 2)).labels
    np.testing.assert_array_equal(labels, [0, 0, 1, 0, 0, 1, 2, 2, 3])
    # two states per cell (inner = 2) keep their own sets; the sink is alone
    labels = shelf.grid_partition(1, 2, (1, 2), inner=2, sink=True).labels
    np.testing.assert_array_equal(labels, [0, 1, 0, 1, 2])


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: shelf.forest(S=1), r"S must lie in \[2, inf\]; got 1"),
        (lambda: shelf.forest(p=1.5), "p must lie in"),
        (lambda: shelf.gridworld(rows=2, jumps=[[2, 0, 0, 0, 1.0]]), r"jumps\[0\]\[0\]"),
        (lambda: shelf.gridworld(jumps=[[0, 0, 1, 1]]), r"jumps\[0\] must have 5 items"),
        (lambda: shelf.admission_queue(rewards=[1.0]), "rewards must have 2 items"),
        (lambda: shelf.admission_queue(arrival_rates=[1.0, 0.0]), r"arrival_rates\[1\]"),
        (lambda: shelf.inventory(p=0.0), r"p must lie in \(0, 1\]"),
        (lambda: shelf.savings(alpha=-1.0), "alpha must lie in"),
        (lambda: shelf.savings(discount=1.0), "discount"),
    ],
)
def test_bad_parameters_name_the_argument(call, match):
    with pytest.raises(ValidationError, match=match):
        call()


def test_bad_file_keys_are_named(tmp_path):
    f = tmp_path / "f.toml"
    f.write_text('[model]\nkind = "forest"\nS = 3\nseed = 1\n')
    with pytest.raises(ValidationError, match=r"unknown key seed in \[model\]"):
        lb.load_instance(f).mdp()
    f.write_text('[model]\nkind = "forest"\nS = 1.5\n')
    with pytest.raises(ValidationError, match=r"\[model\] S"):
        lb.load_instance(f).mdp()
    f.write_text('[model]\nkind = "gridworld"\n[partition]\nkind = "grid"\nrows = 5\ncols = 4\n')
    with pytest.raises(ValidationError, match=r"missing key tile in \[partition\]"):
        lb.load_instance(f).partition()
    f.write_text(
        '[model]\nkind = "gridworld"\n[partition]\nkind = "grid"\nrows = 5\ncols = 4\n'
        "tile = [2, 2]\n"
    )
    with pytest.raises(ValidationError, match=r"5 x 4 x 1 = 20 states, but the model has 25"):
        lb.load_instance(f).partition()


# ---------------------------------------------------------------------- every subcommand
SMALL = {  # five shelf models at small sizes, as instance files
    "forest": '[model]\nkind = "forest"\nS = 4\n[partition]\nkind = "blocks"\nsize = 2\n',
    "gridworld": '[model]\nkind = "gridworld"\nrows = 3\ncols = 3\njumps = [[0, 1, 2, 1, 10.0]]\n'
    '[partition]\nkind = "grid"\nrows = 3\ncols = 3\ntile = [2, 2]\n',
    "queue": '[model]\nkind = "admission_queue"\ncapacity = 6\narrival_rates = [2.0, 1.0]\n'
    "rewards = [1.0, 10.0]\ndiscount = 0.95\n"
    '[partition]\nkind = "grid"\nrows = 2\ncols = 7\ntile = [1, 3]\n',
    "inventory": '[model]\nkind = "inventory"\nK = 6\ndiscount = 0.95\n'
    '[partition]\nkind = "blocks"\nsize = 2\n',
    "savings": '[model]\nkind = "savings"\nB = 3\nM = 2\n[partition]\nkind = "blocks"\nsize = 2\n',
}


def test_compare_instances_runs_a_study_over_five_shelf_models(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name, text in SMALL.items():
        (tmp_path / f"{name}.toml").write_text(text)
    files = ",".join(f"{name}.toml" for name in SMALL)
    args = ["compare", "--instances", files, "--solvers", "HIGHS:simplex", "--jobs", "1"]
    assert main([*args, "--out", "study", "-q"]) == 0
    import pandas as pd

    frame = pd.read_csv(tmp_path / "study" / "study.csv")
    assert sorted(set(frame["instance"])) == sorted(SMALL)
    assert set(frame["formulation"]) == {"ELP", "RLP"}
    assert (frame["status"] == "optimal").all() and frame["accurate"].all()
    for name in SMALL:  # ELP's optimum c'V* (c = 1) against a dense policy iteration
        mdp = lb.load_instance(f"{name}.toml").mdp()
        ref = ind.policy_iteration(_dense(mdp), mdp.rewards, mdp.allowed, mdp.discount)
        elp = frame[(frame["instance"] == name) & (frame["formulation"] == "ELP")]
        objective = float(elp["objective"].iloc[0])
        assert objective == pytest.approx(ref.values.sum(), abs=1e-6 * abs(ref.values.sum()))
    # the same instances as MODEL arguments and as --instances at once: refused
    assert main([*args, "forest.toml", "--out", "again", "-q"]) == 2
    assert main(["compare", "--instances", "forest.toml,,queue.toml", "--out", "x", "-q"]) == 2


def test_solve_export_verify_by_shelf_name(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert main(["solve", "forest", "--json", str(out), "-q"]) == 0
    stats = json.loads(out.read_text())
    assert stats["n_states"] == 3
    assert stats["value_max"] == pytest.approx(33.484, abs=5e-4)  # pymdptoolbox's example
    export = ["export", "savings", "--formulation", "RLP", "--out", str(tmp_path / "e")]
    assert main([*export, "-q"]) == 0
    sizes = json.loads((tmp_path / "e" / "lp.json").read_text())["sizes"]
    assert sizes["columns"] == 8  # the file's partition: 16 stock levels in pairs
    report = tmp_path / "v.json"
    args = ["verify", "gridworld", "--solvers", "HIGHS", "--random", "0"]
    assert main([*args, "--json", str(report), "-q"]) == 0
    rows = [r for r in json.loads(report.read_text()) if r["instance"] == "gridworld"]
    assert len(rows) > 10 and {r["verdict"] for r in rows} == {"holds"}
