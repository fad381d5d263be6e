"""Fingerprints of the kernel paths of large models, to show a change of the kernels left
every number bit-identical (the companion of ``benchmarks/fingerprints.py``).

``fingerprints.py`` hashes V*, policies and the reproduction; most of its models are small.
This script hashes what the Bellman-row kernels compute on models large enough for every
kernel to run at full size (more than 200,000 values read per sweep, where numba's
kernels ran before they were C):

* the aggregated rows (``BellmanRows.aggregate``, reduce ``max`` and ``min``: every array,
  the pair map included) of a 100,000 x 3 x 5 garnet with 10,000 random partitions (few
  merges), of one with shared probabilities, an action mask and 50 partitions (many
  merges), and of the paper's patrol instance (2,048,000 states, M = 8,900);
* RLP's least fixed point of those rows, ``q_values`` and the game operator ``G`` at a
  random point, the NLP's value by game value iteration, and two rounds of its cutting
  planes on a 20,000-state garnet (HiGHS);
* the post-decision form of the patrol instance (its arrays, reward codes, one
  improvement sweep, one evaluation sweep and the row map of a policy);
* the exact grouping of rows by hash (``hash_rows``).

Run it on two trees and ``diff`` the outputs (about two minutes, under 3 GB)::

    python benchmarks/fingerprints_kernels.py > before.txt   # on the old tree
    python benchmarks/fingerprints_kernels.py > after.txt    # on the new tree
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
from fingerprints import digest


def say(name: str, what: str, *arrays: Any) -> None:
    print(f"{name:26s} {what:28s} {digest(*arrays)}", flush=True)


def rows_arrays(rows: Any) -> tuple[Any, ...]:
    return (
        rows.indptr, rows.owner, rows.action, rows.reward, rows.targets,
        np.asarray(rows.probs), rows.pair_row, rows.pair_tight,
    )  # fmt: skip


def aggregation(name: str, mdp: Any, part: Any, nlp: bool) -> None:
    from lpbounds.dp import solve_exact
    from lpbounds.rows import BellmanRows
    from lpbounds.rows.aggregation import group_rows

    rng = np.random.default_rng(5)
    high = BellmanRows.aggregate(mdp, part, reduce="max")
    say(name, f"aggregate max ({high.n_rows:,} rows)", *rows_arrays(high))
    low = BellmanRows.aggregate(mdp, part, reduce="min")
    say(name, f"aggregate min ({low.n_rows:,} rows)", *rows_arrays(low))
    fixed = solve_exact(high)
    say(name, "RLP fixed point", fixed.values, fixed.policy_rows)
    w = rng.normal(size=part.n_partitions) * 10
    say(name, "q_values (min rows)", low.q_values(w))
    say(name, "G w (game operator)", *low.apply_maxmin(w))
    group, count = group_rows(low.owner, low.action, low.targets, np.asarray(low.probs))
    say(name, f"hash grouping ({count:,})", group)
    if nlp:
        from lpbounds.formulations import NLP

        res = NLP(mdp, part).solve("fixed-point")
        say(name, "NLP fixed point", res.lower_values, res.upper_values)


def post_decision(name: str, mdp: Any) -> None:
    from lpbounds.rows import PostDecisionRows

    ps = PostDecisionRows.detect(mdp)
    assert ps is not None
    say(name, "post-decision form", ps.first, ps.outcomes)
    say(name, "reward codes", ps.reward_codes, ps.reward_table)
    v = np.random.default_rng(6).normal(size=mdp.n_states) * 100
    out, arg = ps.new_vector(), ps.new_arg()
    lo, hi = ps.sweep_max(v, out, arg)
    say(name, "T v (post-decision)", out, arg, np.array([lo, hi]))
    lo, hi = ps.sweep_policy(arg, v, out)
    say(name, "T_pi v (post-decision)", out, np.array([lo, hi]))
    lo, hi = ps.sweep_policy(arg, v, out, reward=ps.zero_rewards())
    say(name, "lambda P_pi v", out, np.array([lo, hi]))
    say(name, "rows_of(policy)", ps.rows_of(arg))


def nlp_rounds() -> None:
    from lpbounds import garnet, random_partition
    from lpbounds.formulations import NLP

    mdp = garnet(20_000, 3, 5, 0.9, seed=8)
    part = random_partition(20_000, 2_000, seed=9)
    res = NLP(mdp, part).solve("cutting-planes", max_iter=2)
    say("garnet 20,000 / 2,000", "NLP 2 cutting-plane rounds", res.lower_values, res.upper_values)


def main() -> int:
    from lpbounds import garnet, load_instance, random_partition

    mdp = garnet(100_000, 3, 5, 0.9, seed=1)
    aggregation("garnet 100,000 / 10,000", mdp, random_partition(100_000, 10_000, seed=2), True)
    mdp = garnet(100_000, 3, 5, 0.9, seed=3, shared_probabilities=True, allowed_fraction=0.7)
    aggregation("garnet 100,000 masked / 50", mdp, random_partition(100_000, 50, seed=4), True)
    nlp_rounds()
    inst = load_instance("patrol-paper")
    mdp = inst.mdp()
    post_decision("patrol-paper", mdp)
    aggregation("patrol-paper / 8,900", mdp, inst.partition(), False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
