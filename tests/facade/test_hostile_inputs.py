"""Malformed input through the public API: each case must raise a typed error that names
the argument (and, for arrays, the offending entry) -- never a wrong answer, a silent
coercion or a bare NumPy/Python exception.

Each case is ``(call, pattern)``: ``call()`` must raise
:class:`~lpbounds.errors.ValidationError` whose message matches ``pattern`` (a regex that
names the argument). Each case can fail: before the shared checks of
:mod:`lpbounds.validation`, many of them returned a result or raised TypeError,
AttributeError, IsADirectoryError or numpy's ValueError.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

import lpbounds as lb
from lpbounds import dp
from lpbounds.errors import ValidationError
from lpbounds.formulations.alp import ALP
from lpbounds.formulations.elp import ELP
from lpbounds.formulations.ib import IB
from lpbounds.formulations.rlp import RLP
from lpbounds.formulations.slp import SLP
from lpbounds.model.instances import load_instance

N, A, L = 6, 2, 3
MDP = lb.garnet(N, A, L, 0.9, seed=3)
PART = lb.random_partition(N, 3, seed=1)
SUCC = np.asarray(MDP.successors, dtype=np.int64)
PROBS = np.asarray(MDP.probabilities)
REW = np.asarray(MDP.rewards)
GARNET_TABLE = {"kind": "garnet", "n_states": 5, "n_actions": 2, "branching": 2}


def mdp_with(**kw: object) -> lb.FiniteMDP:
    """``FiniteMDP`` of the module's arrays with some of them replaced."""
    args: dict[str, object] = {
        "successors": SUCC,
        "probabilities": PROBS,
        "rewards": REW,
        "discount": 0.9,
    }
    args.update(kw)
    return lb.FiniteMDP(**args)  # type: ignore[arg-type]


def succ_with(index: tuple[int, int, int], value: float, dtype: type = np.int64) -> np.ndarray:
    s = SUCC.astype(dtype)
    s[index] = value
    return s


def probs_with(index: tuple[int, int, int], value: float) -> np.ndarray:
    p = PROBS.copy()
    p[index] = value
    return p


def one_disallowed() -> np.ndarray:
    allowed = np.ones((N, A), bool)
    allowed[0, 1] = False
    return allowed


def rew_with(index: tuple[int, int], value: float) -> np.ndarray:
    r = REW.copy()
    r[index] = value
    return r


def no_action_at_1() -> np.ndarray:
    allowed = np.ones((N, A), bool)
    allowed[1, :] = False
    return allowed


def values_with(i: int, value: float) -> np.ndarray:
    v = np.zeros(N)
    v[i] = value
    return v


def instance_mdp(**model: object) -> lb.FiniteMDP:
    return load_instance({"model": {**GARNET_TABLE, **model}}).mdp()


def instance_partition(table: object) -> lb.Partition:
    return load_instance({"model": dict(GARNET_TABLE), "partition": table}).partition()


Case = tuple[Callable[[], object], str]

CASES: dict[str, Case] = {
    # --------------------------------------------------------------- FiniteMDP: successors
    "succ-int64-above-2**32-wraps": (
        lambda: mdp_with(successors=succ_with((2, 1, 0), 2**32 + 1)),
        r"successors\[2, 1, 0\] = 4294967297 is out of range \[0, 6\)",
    ),
    "succ-uint64-huge": (
        lambda: mdp_with(successors=succ_with((0, 0, 2), 2**63, np.uint64)),
        r"successors\[0, 0, 2\] = 9223372036854775808 is out of range",
    ),
    "succ-negative-huge": (
        lambda: mdp_with(successors=succ_with((1, 0, 1), -(2**40))),
        r"successors\[1, 0, 1\] = -1099511627776 is out of range",
    ),
    "succ-fractional": (
        lambda: mdp_with(successors=SUCC + 0.5),
        r"successors must be integers; successors\[0, 0, 0\] = ",
    ),
    "succ-nan": (
        lambda: mdp_with(successors=succ_with((0, 1, 2), np.nan, float)),
        r"successors\[0, 1, 2\] = nan is not finite",
    ),
    "succ-strings": (
        lambda: mdp_with(successors=SUCC.astype(str)),
        r"successors must hold integers; got strings",
    ),
    "succ-bool": (
        lambda: mdp_with(successors=SUCC > 2),
        r"successors must hold integers; got booleans",
    ),
    "succ-complex": (
        lambda: mdp_with(successors=SUCC + 0j),
        r"successors must hold integers; got complex",
    ),
    "succ-object-none": (
        lambda: mdp_with(successors=np.where(SUCC == SUCC[0, 0, 0], None, SUCC).astype(object)),
        r"successors\[0, 0, 0\] = None .* is not an integer",
    ),
    "succ-ragged": (
        lambda: mdp_with(successors=[[[0]], [[0, 1]]]),
        r"successors is not a rectangular array",
    ),
    "succ-none": (lambda: mdp_with(successors=None), r"successors must be an array; got None"),
    "succ-2d": (lambda: mdp_with(successors=SUCC[0]), r"successors must have shape"),
    "model-0x0": (
        lambda: lb.FiniteMDP(np.zeros((0, 0, 0), int), np.zeros(0), np.zeros((0, 0)), 0.9),
        r"successors has an empty dimension",
    ),
    # --------------------------------------------------------------- probabilities
    "probs-strings": (
        lambda: mdp_with(probabilities=PROBS.astype(str)),
        r"probabilities must hold real numbers; got strings",
    ),
    "probs-complex": (
        lambda: mdp_with(probabilities=PROBS + 0j),
        r"probabilities must hold real numbers; got complex",
    ),
    "probs-bool": (
        lambda: mdp_with(probabilities=PROBS > 0),
        r"probabilities must hold real numbers; got booleans",
    ),
    "probs-nan": (
        lambda: mdp_with(probabilities=probs_with((2, 0, 1), np.nan)),
        r"probabilities\[2, 0, 1\] = nan is not finite",
    ),
    "probs-sum-0.9": (
        lambda: mdp_with(probabilities=PROBS * 0.9),
        r"probabilities\[0, 0, :\] sum to 0\.9",
    ),
    "probs-negative": (
        lambda: mdp_with(probabilities=probs_with((1, 1, 0), -0.5)),
        r"probabilities\[1, 1, 0\] = -0\.5 is negative",
    ),
    "probs-wrong-shape": (
        lambda: mdp_with(probabilities=PROBS[:, :, :2]),
        r"probabilities must have shape",
    ),
    "probs-empty": (lambda: mdp_with(probabilities=[]), r"probabilities must have shape"),
    # --------------------------------------------------------------- rewards
    "rew-strings": (
        lambda: mdp_with(rewards=REW.astype(str)),
        r"rewards must hold real numbers; got strings",
    ),
    "rew-complex": (
        lambda: mdp_with(rewards=REW + 1j),
        r"rewards must hold real numbers; got complex",
    ),
    "rew-inf": (
        lambda: mdp_with(rewards=rew_with((4, 1), np.inf)),
        r"rewards\[4, 1\] = inf is not finite",
    ),
    "rew-nan": (
        lambda: mdp_with(rewards=rew_with((0, 1), np.nan)),
        r"rewards\[0, 1\] = nan is not finite",
    ),
    "rew-wrong-shape": (lambda: mdp_with(rewards=REW.T), r"rewards must have shape"),
    "rew-1e308-overflows": (
        lambda: mdp_with(rewards=REW * 1e308),
        r"rewards: max\|R\| = .* above 1e\+300",
    ),
    "rew-1e298-at-0.9999": (
        lambda: mdp_with(rewards=REW * 1e298, discount=0.9999),
        r"rewards: max\|R\| .* overflow",
    ),
    # --------------------------------------------------------------- discount
    "discount-False": (
        lambda: mdp_with(discount=False),
        r"discount must be a real number; got False",
    ),
    "discount-True": (lambda: mdp_with(discount=True), r"discount must be a real number; got True"),
    "discount-str": (
        lambda: mdp_with(discount="0.9"),
        r"discount must be a real number; got '0\.9'",
    ),
    "discount-None": (lambda: mdp_with(discount=None), r"discount must be a real number; got None"),
    "discount-complex": (lambda: mdp_with(discount=0.9 + 0j), r"discount must be a real number"),
    "discount-1": (lambda: mdp_with(discount=1), r"discount must lie in \[0, 1\); got 1\.0"),
    "discount-negative": (lambda: mdp_with(discount=-0.1), r"discount must lie in \[0, 1\)"),
    "discount-1.0000001": (lambda: mdp_with(discount=1.0000001), r"discount must lie in \[0, 1\)"),
    "discount-int-beyond-float64": (
        lambda: mdp_with(discount=2**2000),
        r"discount = 11481306952742545242\d+\.\.\. \(int\) is beyond float64",
    ),
    "discount-nan": (lambda: mdp_with(discount=float("nan")), r"discount must be a finite number"),
    "discount-inf": (lambda: mdp_with(discount=float("inf")), r"discount must be a finite number"),
    # --------------------------------------------------------------- allowed, names, copy
    "allowed-state-without-action": (
        lambda: mdp_with(allowed=no_action_at_1()),
        r"state 1 has no allowed action",
    ),
    "allowed-strings": (
        lambda: mdp_with(allowed=np.full((N, A), "yes")),
        r"allowed must hold integers; got strings .*boolean",
    ),
    "allowed-value-2": (
        lambda: mdp_with(allowed=np.full((N, A), 2)),
        r"allowed must be boolean \(or 0/1\); allowed\[0, 0\] = 2",
    ),
    "allowed-wrong-shape": (
        lambda: mdp_with(allowed=np.ones((A, N), bool)),
        r"allowed must have shape",
    ),
    "action-names-count": (
        lambda: mdp_with(action_names=["a"]),
        r"action_names has 1 names for 2 actions",
    ),
    "action-names-a-string": (
        lambda: mdp_with(action_names="ab"),
        r"action_names must be a sequence",
    ),
    "action-names-not-str": (
        lambda: mdp_with(action_names=["a", 3]),
        r"action_names\[1\] = 3 is not a string",
    ),
    "copy-not-bool": (lambda: mdp_with(copy="no"), r"copy must be True or False"),
    # --------------------------------------------------------------- matrices
    "from-matrices-P-strings": (
        lambda: lb.FiniteMDP.from_matrices([[["1"]]], [0.0], 0.9),
        r"P\[0\] must hold real numbers; got strings",
    ),
    "from-matrices-rows-0.5": (
        lambda: lb.FiniteMDP.from_matrices([np.eye(2) * 0.5], [0.0, 0.0], 0.9),
        r"row 0 of P\[0\]: the probabilities sum to 0\.5",
    ),
    "from-matrices-R-complex": (
        lambda: lb.FiniteMDP.from_matrices([np.eye(2)], [0.0, 1j], 0.9),
        r"R must hold real numbers; got complex",
    ),
    "from-matrices-discount-str": (
        lambda: lb.FiniteMDP.from_matrices([np.eye(2)], [0.0, 1.0], "0.9"),
        r"discount must be a real number",
    ),
    "to-matrices-disallowed-reward-str": (
        lambda: mdp_with(allowed=one_disallowed()).to_matrices(disallowed_reward="x"),
        r"disallowed_reward must be a real number",
    ),
    # --------------------------------------------------------------- Partition
    "labels-2**40-no-8TiB-bincount": (
        lambda: lb.Partition([0, 2**40]),
        r"labels\[1\] = 1099511627776 is out of range \[0, 2\)",
    ),
    "labels-beyond-int64": (
        lambda: lb.Partition([0, 2**70]),
        r"labels\[1\] = 1180591620717411303424 is out of range \(beyond 64-bit",
    ),
    "succ-beyond-uint64": (
        lambda: lb.FiniteMDP([[[0, 2**64]]], [0.5, 0.5], [[0.0]], 0.9),
        r"successors\[0, 0, 1\] = 18446744073709551616 is out of range",
    ),
    "rew-python-int-beyond-float64": (
        lambda: lb.FiniteMDP([[[0]]], [1.0], [[2**2000]], 0.9),
        r"rewards has an entry beyond float64",
    ),
    "labels-strings": (lambda: lb.Partition(["a", "b"]), r"labels must hold integers; got strings"),
    "labels-bool": (
        lambda: lb.Partition([True, False]),
        r"labels must hold integers; got booleans",
    ),
    "labels-fractional": (lambda: lb.Partition([0.0, 1.5]), r"labels\[1\] = 1\.5 is not"),
    "labels-nan": (lambda: lb.Partition([0.0, np.nan]), r"labels\[1\] = nan is not finite"),
    "labels-empty": (lambda: lb.Partition([]), r"labels must be a non-empty 1-d array"),
    "labels-2d": (lambda: lb.Partition([[0, 1]]), r"labels must be a non-empty 1-d array"),
    "labels-negative": (lambda: lb.Partition([0, -1]), r"labels\[1\] = -1 is negative"),
    "labels-unused-index": (lambda: lb.Partition([0, 2, 2]), r"partition index 1 has no state"),
    "n-partitions-float": (
        lambda: lb.Partition([0, 1], n_partitions=3.7),
        r"n_partitions must be an integer; got 3\.7",
    ),
    "n-partitions-bool": (
        lambda: lb.Partition([0, 0], n_partitions=True),
        r"n_partitions must be an integer",
    ),
    "n-partitions-2**40": (
        lambda: lb.Partition([0, 1], n_partitions=2**40),
        r"n_partitions must lie in \[1, 2\]",
    ),
    "singletons-str": (lambda: lb.Partition.singletons("3"), r"n_states must be an integer"),
    "aggregate-how": (
        lambda: PART.aggregate(np.zeros(N), how="median"),
        r"unknown aggregation 'median'",
    ),
    "aggregate-strings": (lambda: PART.aggregate(["a"] * N), r"x must hold real numbers"),
    "lift-wrong-length": (
        lambda: PART.lift(np.zeros(N)),
        r"a vector over partitions must have length 3",
    ),
    "members-str": (lambda: PART.members("0"), r"i must be an integer"),
    "from-keys-empty": (lambda: lb.Partition.from_keys([]), r"keys must be a non-empty"),
    # --------------------------------------------------------------- generators
    "garnet-n-states-str": (
        lambda: lb.garnet("10", 2, 2),
        r"n_states must be an integer; got '10'",
    ),
    "garnet-n-states-float": (
        lambda: lb.garnet(10.7, 2, 2),
        r"n_states must be an integer; got 10\.7",
    ),
    "garnet-n-states-0": (lambda: lb.garnet(0, 2, 2), r"n_states must lie in \[1, inf\]"),
    "garnet-n-actions-bool": (
        lambda: lb.garnet(5, True, 2),
        r"n_actions must be an integer; got True",
    ),
    "garnet-branching-negative": (lambda: lb.garnet(5, 2, -1), r"branching must lie in \[1, inf\]"),
    "garnet-discount-str": (lambda: lb.garnet(5, 2, 2, "0.9"), r"discount must be a real number"),
    "garnet-seed-negative": (lambda: lb.garnet(5, 2, 2, seed=-1), r"seed must lie in \[0, inf\]"),
    "garnet-seed-float": (lambda: lb.garnet(5, 2, 2, seed=1.5), r"seed must be an integer"),
    "garnet-reward-range-reversed": (
        lambda: lb.garnet(5, 2, 2, reward_range=(1, 0)),
        r"reward_range = \(1\.0, 0\.0\) has low > high",
    ),
    "garnet-reward-range-str": (
        lambda: lb.garnet(5, 2, 2, reward_range="ab"),
        r"reward_range must be a pair",
    ),
    "garnet-reward-range-nan": (
        lambda: lb.garnet(5, 2, 2, reward_range=(0, np.nan)),
        r"reward_range\[1\] must be a finite number",
    ),
    "garnet-allowed-fraction-0": (
        lambda: lb.garnet(5, 2, 2, allowed_fraction=0),
        r"allowed_fraction must lie in \(0, 1\]",
    ),
    "garnet-shared-str": (
        lambda: lb.garnet(5, 2, 2, shared_probabilities="yes"),
        r"shared_probabilities must be True or False",
    ),
    "random-partition-float": (
        lambda: lb.random_partition(10, 3.7),
        r"n_partitions must be an integer; got 3\.7",
    ),
    "random-partition-too-many": (
        lambda: lb.random_partition(10, 11),
        r"n_partitions must lie in \[1, n_states=10\]",
    ),
    "random-partition-n-states-str": (
        lambda: lb.random_partition("10", 3),
        r"n_states must be an integer",
    ),
    "random-partition-seed-str": (
        lambda: lb.random_partition(10, 3, seed="x"),
        r"seed must be an integer",
    ),
    # --------------------------------------------------------------- exact DP
    "tol-str": (lambda: lb.solve_exact(MDP, tol="abc"), r"tol must be a real number; got 'abc'"),
    "tol-negative": (lambda: lb.solve_exact(MDP, tol=-1.0), r"tol must lie in \(0, inf\]"),
    "tol-zero": (lambda: lb.solve_exact(MDP, tol=0.0), r"tol must lie in \(0, inf\]"),
    "tol-nan": (lambda: lb.solve_exact(MDP, tol=float("nan")), r"tol must be a finite number"),
    "tol-inf": (lambda: lb.solve_exact(MDP, tol=float("inf")), r"tol must be a finite number"),
    "tol-bool": (lambda: lb.solve_exact(MDP, tol=True), r"tol must be a real number; got True"),
    "initial-nan": (
        lambda: lb.solve_exact(MDP, initial=values_with(2, np.nan)),
        r"initial\[2\] = nan is not finite",
    ),
    "initial-inf-vi": (
        lambda: lb.solve_exact(MDP, "vi", initial=values_with(0, -np.inf)),
        r"initial\[0\] = -inf is not finite",
    ),
    "initial-inf-pi": (
        lambda: lb.solve_exact(MDP, "pi", initial=values_with(5, np.inf)),
        r"initial\[5\] = inf is not finite",
    ),
    "initial-huge": (
        lambda: lb.solve_exact(MDP, initial=values_with(1, 1e305)),
        r"initial\[1\] = 1e\+305 exceeds",
    ),
    "initial-wrong-length": (
        lambda: lb.solve_exact(MDP, initial=np.zeros(N + 1)),
        r"initial: expected a vector of length 6",
    ),
    "initial-strings": (
        lambda: lb.solve_exact(MDP, initial=["0"] * N),
        r"initial must hold real numbers; got strings",
    ),
    "initial-complex": (
        lambda: lb.solve_exact(MDP, initial=np.zeros(N) + 0j),
        r"initial must hold real numbers; got complex",
    ),
    "max-iter-0": (lambda: lb.solve_exact(MDP, max_iter=0), r"max_iter must lie in \[1, inf\]"),
    "max-iter-float": (lambda: lb.solve_exact(MDP, max_iter=10.5), r"max_iter must be an integer"),
    "eval-sweeps-negative": (
        lambda: lb.solve_exact(MDP, eval_sweeps=-1),
        r"eval_sweeps must lie in \[0, inf\]",
    ),
    "eval-sweeps-word": (
        lambda: lb.solve_exact(MDP, eval_sweeps="fast"),
        r"eval_sweeps must be a non-negative integer or 'auto'; got 'fast'",
    ),
    "eval-sweeps-float": (
        lambda: lb.solve_exact(MDP, eval_sweeps=2.5),
        r"eval_sweeps must be a non-negative integer or 'auto'; got 2.5",
    ),
    "eval-sweeps-bool": (
        lambda: lb.solve_exact(MDP, eval_sweeps=True),
        r"eval_sweeps must be a non-negative integer or 'auto'; got True",
    ),
    "method-unknown": (lambda: lb.solve_exact(MDP, "newton"), r"unknown method 'newton'"),
    "evaluation-unknown": (
        lambda: lb.solve_exact(MDP, "pi", evaluation="lu"),
        r"evaluation must be one of",
    ),
    "extrapolate-str": (
        lambda: lb.solve_exact(MDP, extrapolate="yes"),
        r"extrapolate must be True or False",
    ),
    "raise-on-failure-int": (
        lambda: lb.solve_exact(MDP, raise_on_failure=1),
        r"raise_on_failure must be True or False",
    ),
    "callback-not-callable": (
        lambda: lb.solve_exact(MDP, callback=3),
        r"callback must be callable",
    ),
    "solve-exact-none": (
        lambda: lb.solve_exact(None),
        r"expected a FiniteMDP or BellmanRows; got NoneType",
    ),
    "solve-game-on-mdp": (lambda: dp.solve_game(MDP), r"rows must be a BellmanRows system"),
    "greedy-nan": (
        lambda: lb.greedy_policy(MDP, values_with(3, np.nan)),
        r"values\[3\] = nan is not finite",
    ),
    "greedy-tie-negative": (
        lambda: lb.greedy_policy(MDP, np.zeros(N), tie_rtol=-1),
        r"tie_rtol must lie in \[0, inf\]",
    ),
    "greedy-tie-nan": (
        lambda: lb.greedy_policy(MDP, np.zeros(N), tie_rtol=float("nan")),
        r"tie_rtol must be a finite number",
    ),
    "greedy-tie-str": (
        lambda: lb.greedy_policy(MDP, np.zeros(N), tie_rtol="0"),
        r"tie_rtol must be a real number",
    ),
    "greedy-wrong-length": (
        lambda: lb.greedy_policy(MDP, np.zeros(N - 1)),
        r"values: expected a vector of length 6",
    ),
    "greedy-none-model": (
        lambda: lb.greedy_policy(None, np.zeros(N)),
        r"expected a FiniteMDP or BellmanRows",
    ),
    "porteus-nan": (
        lambda: lb.porteus_bounds(MDP, values_with(4, np.nan)),
        r"values\[4\] = nan is not finite",
    ),
    "porteus-inf": (
        lambda: lb.porteus_bounds(MDP, values_with(0, np.inf)),
        r"values\[0\] = inf is not finite",
    ),
    "residual-nan": (
        lambda: lb.bellman_residual(MDP, values_with(1, np.nan)),
        r"values\[1\] = nan is not finite",
    ),
    "evaluate-policy-fractional": (
        lambda: lb.evaluate_policy(MDP, np.full(N, 0.5)),
        r"policy must be integers; policy\[0\] = 0\.5",
    ),
    "evaluate-policy-2**40": (
        lambda: lb.evaluate_policy(MDP, np.where(np.arange(N) == 2, 2**40, 0)),
        r"policy\[2\] = 1099511627776 is not an action index",
    ),
    "evaluate-policy-strings": (
        lambda: lb.evaluate_policy(MDP, ["0"] * N),
        r"policy must hold integers; got strings",
    ),
    "evaluate-policy-method": (
        lambda: lb.evaluate_policy(MDP, np.zeros(N, int), method="x"),
        r"unknown evaluation 'x'",
    ),
    "evaluate-policy-tol": (
        lambda: lb.evaluate_policy(MDP, np.zeros(N, int), tol=-1),
        r"tol must lie in",
    ),
    # --------------------------------------------------------------- row systems
    "rows-owner-2**40": (
        lambda: lb.BellmanRows.from_arrays(
            [0, 2**40], [0, 0], [0.0, 0.0], [[0], [0]], [1.0], 0.9, 2
        ),
        r"owner\[1\] = 1099511627776 is out of range \[0, 2\)",
    ),
    "rows-reward-nan": (
        lambda: lb.BellmanRows.from_arrays(
            [0, 1], [0, 0], [0.0, np.nan], [[0], [1]], [1.0], 0.9, 2
        ),
        r"reward\[1\] = nan is not finite",
    ),
    "rows-reward-1e308": (
        lambda: lb.BellmanRows.from_arrays([0, 1], [0, 0], [0.0, 1e308], [[0], [1]], [1.0], 0.9, 2),
        r"reward: max\|R\|",
    ),
    "rows-n-vars-float": (
        lambda: lb.BellmanRows.from_arrays([0, 1], [0, 0], [0.0, 0.0], [[0], [1]], [1.0], 0.9, 2.5),
        r"n_vars must be an integer",
    ),
    "rows-probs-strings": (
        lambda: lb.BellmanRows.from_arrays([0, 1], [0, 0], [0.0, 0.0], [[0], [1]], ["1"], 0.9, 2),
        r"probs must hold real numbers",
    ),
    "rows-apply-max-strings": (
        lambda: dp.exact_rows(MDP).apply_max(["a"] * N),
        r"v must hold real numbers; got strings",
    ),
    # --------------------------------------------------------------- formulations
    "rlp-mdp-none": (lambda: RLP(None, PART), r"mdp must be a FiniteMDP; got None"),
    "rlp-partition-none": (lambda: RLP(MDP, None), r"partition must be a Partition; got None"),
    "rlp-partition-str": (
        lambda: RLP(MDP, "coarse"),
        r"partition must be a Partition; got 'coarse'",
    ),
    "rlp-partition-size": (
        lambda: RLP(MDP, lb.random_partition(N + 1, 2)),
        r"the partition has 7 states but the MDP has 6",
    ),
    "rlp-cost-strings": (
        lambda: RLP(MDP, PART, cost=["1"] * N),
        r"cost must hold real numbers; got strings",
    ),
    "rlp-partition-cost-complex": (
        lambda: RLP(MDP, PART, partition_cost=np.ones(3) + 0j),
        r"partition_cost must hold real numbers; got complex",
    ),
    "elp-mdp-dict": (lambda: ELP({"n_states": 3}), r"mdp must be a FiniteMDP; got \{"),
    "elp-cost-bool": (
        lambda: ELP(MDP, cost=np.ones(N, bool)),
        r"cost must hold real numbers; got booleans",
    ),
    "slp-mu-strings": (
        lambda: SLP(MDP, PART, np.full((N, A), "x")),
        r"mu must hold real numbers; got strings",
    ),
    "ib-partition-none": (lambda: IB(MDP, None, 2), r"partition must be a Partition"),
    "alp-basis-complex": (
        lambda: ALP(MDP, np.ones((N, 2)) + 0j),
        r"basis must hold real numbers; got complex",
    ),
    # --------------------------------------------------------------- instances
    "instance-directory": (lambda: load_instance("/"), r"not a regular file: '/' \(a directory\)"),
    "instance-source-int": (
        lambda: load_instance(42),
        r"source must be a path, a model name or a mapping",
    ),
    "instance-name-int": (
        lambda: load_instance({"model": dict(GARNET_TABLE)}, name=3),
        r"name must be a string",
    ),
    "instance-kind-list": (
        lambda: load_instance({"model": {"kind": ["garnet"]}}),
        r"unknown model kind \['garnet'\]",
    ),
    "instance-n-states-float": (
        lambda: instance_mdp(n_states=10.7),
        r"\[model\] n_states must be an integer; got 10\.7",
    ),
    "instance-discount-str": (
        lambda: instance_mdp(discount="0.9"),
        r"\[model\] discount must be a real number",
    ),
    "instance-discount-bool": (
        lambda: instance_mdp(discount=False),
        r"\[model\] discount must be a real number; got False",
    ),
    "instance-seed-negative": (
        lambda: instance_mdp(seed=-1),
        r"\[model\] seed must lie in \[0, inf\]",
    ),
    "instance-shared-str": (
        lambda: instance_mdp(shared_probabilities="yes"),
        r"\[model\] shared_probabilities must be True or False",
    ),
    "instance-reward-high-str": (
        lambda: instance_mdp(reward_high="1"),
        r"\[model\] reward_high must be a real number",
    ),
    "instance-partition-float": (
        lambda: instance_partition({"kind": "random", "n_partitions": 3.7}),
        r"\[partition\] n_partitions must be an integer; got 3\.7",
    ),
    "instance-partition-not-table": (
        lambda: instance_partition(3),
        r"\[partition\] must be a table",
    ),
    "instance-partition-kind-list": (
        lambda: instance_partition({"kind": ["random"], "n_partitions": 2}),
        r"unknown partition kind \['random'\]",
    ),
    # LP solve arguments: refused before the solver is called
    "solve-time-limit-negative": (
        lambda: ELP(MDP).solve("HIGHS", time_limit=-1),
        r"time_limit must lie in \(0",
    ),
    "solve-time-limit-str": (
        lambda: ELP(MDP).solve("HIGHS", time_limit="a"),
        r"time_limit must be a real number",
    ),
    "solve-max-iters-float": (
        lambda: ELP(MDP).solve("HIGHS", max_iters=2.5),
        r"max_iters must be an integer",
    ),
    "solve-accuracy-negative": (
        lambda: ELP(MDP).solve("HIGHS", accuracy=-1.0),
        r"accuracy must be a positive",
    ),
    "solve-accuracy-str": (
        lambda: ELP(MDP).solve("HIGHS", accuracy="abc"),
        r"accuracy must be a positive",
    ),
    "solve-verbose-str": (
        lambda: ELP(MDP).solve("HIGHS", verbose="yes"),
        r"verbose must be True or False",
    ),
    "solve-raise-on-failure-int": (
        lambda: ELP(MDP).solve("HIGHS", raise_on_failure=1),
        r"raise_on_failure must be True or False",
    ),
    "solve-solver-none": (
        lambda: ELP(MDP).solve(None),
        r"solver must be a name",
    ),
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_malformed_input_raises_a_typed_error_naming_it(case: str) -> None:
    call, pattern = CASES[case]
    with pytest.raises(ValidationError, match=pattern):
        call()


def test_there_are_at_least_sixty_cases() -> None:
    assert len(CASES) >= 60


def test_unreadable_instance_file_is_a_validation_error(tmp_path) -> None:
    """Binary junk in a model file: a ValidationError, not a UnicodeDecodeError."""
    junk = tmp_path / "junk.toml"
    junk.write_bytes(b"\xff\xfe\x00model")
    with pytest.raises(ValidationError, match="not valid TOML"):
        load_instance(junk)


def test_checks_do_not_copy_arrays_handed_over() -> None:
    """``copy=False`` keeps arrays of the stored dtype (the checks read them in place)."""
    succ = SUCC.astype(np.int32)
    rew = REW.copy()
    mdp = lb.FiniteMDP(succ, PROBS, rew, 0.9, copy=False)
    assert np.shares_memory(mdp.successors, succ)
    assert np.shares_memory(mdp.rewards, rew)


def test_valid_edge_values_are_accepted() -> None:
    """The boundaries themselves are valid: discount 0, an int discount, numpy scalars,
    whole-number float successors and labels, 0/1 masks, tie_rtol 0."""
    assert mdp_with(discount=0).discount == 0.0
    assert mdp_with(discount=np.float32(0.5)).discount == 0.5
    assert mdp_with(successors=SUCC.astype(float)).successors.dtype == np.int32
    allowed = np.ones((N, A), dtype=np.int64)
    allowed[0, 1] = 0
    assert mdp_with(allowed=allowed).n_pairs == N * A - 1
    assert lb.Partition(np.array([0.0, 1.0, 1.0])).n_partitions == 2
    assert lb.Partition([0, 1], n_partitions=np.int64(2)).n_partitions == 2
    assert lb.garnet(np.int64(4), 2, 2, seed=np.int32(3)).n_states == 4
    v = lb.solve_exact(MDP).values
    assert lb.greedy_policy(MDP, v, tie_rtol=0).shape == (N,)
