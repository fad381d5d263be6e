"""Exact V*, RLP fixed points and game values against references written in the tests.

The reference (tests/exact/_reference.py) enumerates every deterministic policy of a tiny
model and solves each policy's equations by Gauss-Jordan elimination in Python's
Fractions: nothing of lpbounds. The model is the one *stored* (its doubles taken exactly,
rows summing to 1 +- 9e-10 included), so the exact answers must agree to the last bit of
the last rational.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

import lpbounds as lb
from lpbounds.errors import SizeLimitError, ValidationError
from lpbounds.formulations import NLP
from lpbounds.rows import BellmanRows

from . import _reference as ref
from ._models import stored_mdps, with_partition

EXACT = settings(max_examples=40, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.too_slow])  # fmt: skip


@EXACT
@given(stored_mdps())
def test_exact_vstar_equals_policy_enumeration(mdp):
    res = lb.solve_exact(mdp, arithmetic="rational")
    want = ref.vstar(mdp)
    assert list(res.rational_values) == want
    # values are the nearest doubles of the exact ones, and error_bound covers them exactly
    assert res.values.tolist() == [float(t) for t in want]
    err = max(abs(Fraction(float(v)) - t) for v, t in zip(res.values, want, strict=True))
    assert Fraction(res.error_bound) >= err
    assert res.error_bound <= 2 * np.spacing(np.abs(res.values).max(initial=0.0)) + 1e-300
    assert res.arithmetic == "rational" and res.residual >= 0.0


@EXACT
@given(stored_mdps())
def test_exact_policy_is_optimal(mdp):
    """The returned policy's own exact value is V* (the policy is exactly optimal)."""
    res = lb.solve_exact(mdp, arithmetic="rational")
    sub = mdp.allowed.copy()
    sub[:] = False
    sub[np.arange(mdp.n_states), res.policy] = True
    fixed = lb.FiniteMDP(mdp.successors, mdp.probabilities, mdp.rewards, mdp.discount, sub)
    assert ref.vstar(fixed) == list(res.rational_values)


@EXACT
@given(stored_mdps(max_states=3, max_actions=2))
def test_exact_fixed_point_of_rows_as_stored(mdp):
    """solve_exact on a BellmanRows system: its rows as stored (RLP's float-merged rows)."""
    rows = BellmanRows.from_mdp(mdp)
    res = lb.solve_exact(rows, arithmetic="rational")
    assert list(res.rational_values) == ref.vstar(mdp)


@EXACT
@given(with_partition(stored_mdps(max_states=4, max_actions=2, action0=True)))
def test_exact_game_value_equals_enumeration(case):
    """The NLP's w* (exact strategy iteration) = min over strategies of their V*."""
    mdp, part = case
    res = NLP(mdp, part).solve("fixed-point", arithmetic="rational")
    want = ref.game_value(mdp, part.labels, part.n_partitions)
    assert list(res.exact.values) == want
    assert res.exact.inside_bracket  # the float method's certified bracket held
    assert res.exact.error == max(
        abs(Fraction(float(a)) - b) for a, b in zip(res.values, want, strict=True)
    )


@EXACT
@given(with_partition(stored_mdps(max_states=4, max_actions=2, action0=True)))
def test_solve_game_rational_on_rows_as_stored(case):
    mdp, part = case
    rows = BellmanRows.aggregate(mdp, part, reduce="min")
    res = lb.solve_game(rows, arithmetic="rational")
    lam = Fraction(float(rows.discount))
    groups: dict = {}
    probs = np.asarray(rows.probs)
    for r in range(rows.n_rows):
        a = [Fraction(0)] * rows.n_vars
        a[int(rows.owner[r])] += 1
        for t, q in zip(rows.targets[r], probs[r], strict=True):
            a[int(t)] -= lam * Fraction(float(q))
        groups.setdefault((int(rows.owner[r]), int(rows.action[r])), []).append(
            (a, Fraction(float(rows.reward[r])), int(rows.owner[r]))
        )
    import itertools

    best = None
    for tau in itertools.product(*groups.values()):
        v = ref._least_fixed_point(list(tau), rows.n_vars)
        best = v if best is None else [min(s, t) for s, t in zip(best, v, strict=True)]
    assert list(res.rational_values) == best


def test_exact_is_opt_in_float_path_unchanged():
    """arithmetic="float" is the default and gives the very same result object contents."""
    mdp = lb.garnet(40, 3, 4, 0.95, seed=3)
    a, b = lb.solve_exact(mdp), lb.solve_exact(mdp, arithmetic="float")
    assert a.values.tobytes() == b.values.tobytes() and a.rational_values is None
    assert a.arithmetic == "float"


def test_exact_from_a_bad_start_needs_more_iterations_same_answer():
    from lpbounds.exact.files import mdp_data
    from lpbounds.exact.fixed_point import least_fixed_point
    from lpbounds.exact.system import ExactRows

    mdp = lb.garnet(25, 3, 3, 0.99, seed=11)
    rows = ExactRows.build(mdp_data(mdp), {"rows": "ELP"})
    best = lb.solve_exact(mdp, arithmetic="rational")
    worst = least_fixed_point(rows, np.array([int(np.flatnonzero(rows.owners() == i)[-1])
                                              for i in range(25)]))  # fmt: skip
    assert worst.values == best.rational_values
    assert worst.iterations >= best.iterations


def test_size_limit_refused_before_any_exact_solve(monkeypatch):
    """A random garnet's policy graph is one strongly connected block: refused before any
    rational solve starts, in one line naming the size, the limit and the option."""
    mdp = lb.garnet(30, 2, 3, 0.9, seed=1)
    called = []
    monkeypatch.setattr("lpbounds.exact.system._solve_block", lambda *a, **k: called.append(1))
    with pytest.raises(SizeLimitError) as exc:
        lb.solve_exact(mdp, arithmetic="rational", size_limit=5)
    msg = str(exc.value)
    k = int(msg.split(": ")[1].split(" variables")[0])
    assert 5 < k <= 30 and "limit of 5" in msg and f"size_limit={k}" in msg and "of 30" in msg
    assert "\n" not in msg and not called  # one line; no exact block solved
    assert isinstance(exc.value, ValidationError)
    monkeypatch.undo()
    lb.solve_exact(mdp, arithmetic="rational", size_limit=k)  # the option lifts it


def test_a_chain_passes_any_size_limit():
    """Sparsity pays: a chain's policy graph has components of one state, solved one by one,
    so even size_limit=1 passes (and the answer is the reference's)."""
    n = 6
    succ = np.minimum(np.arange(n) + 1, n - 1)[:, None, None] * np.ones((1, 2, 1), dtype=int)
    rewards = np.random.default_rng(0).uniform(0, 1, (n, 2))
    mdp = lb.FiniteMDP(succ, [1.0], rewards, 0.9)
    res = lb.solve_exact(mdp, arithmetic="rational", size_limit=1)
    assert list(res.rational_values) == ref.vstar(mdp)


def test_progress_callback_and_interrupt_propagates():
    mdp = lb.garnet(30, 3, 3, 0.9, seed=2)
    seen = []
    lb.solve_exact(mdp, arithmetic="rational", callback=lambda it, res: seen.append((it, res)))
    assert seen and seen[-1][1] == 0.0  # the last check: exact residual 0

    def stop(it, res):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        lb.solve_exact(mdp, arithmetic="rational", callback=stop)


def test_unknown_arithmetic_is_a_validation_error():
    with pytest.raises(ValidationError, match="arithmetic"):
        lb.solve_exact(lb.garnet(5, 2, 2, seed=0), arithmetic="exact")


@pytest.mark.parametrize("solve", ["solve_game", "RLP", "NLP", "run_verification"])
def test_every_entry_refuses_an_unknown_arithmetic_in_the_same_words(solve):
    """solve_game, an LP formulation, the NLP and verify name the argument and the choices
    alike (one check, validation.check_choice), before any work."""
    from lpbounds.formulations import NLP, RLP
    from lpbounds.studies.verify import run_verification

    mdp = lb.garnet(6, 2, 2, seed=0)
    part = lb.random_partition(6, 2, seed=0)
    call = {
        "solve_game": lambda: lb.solve_game(
            BellmanRows.aggregate(mdp, part, reduce="min"), arithmetic="exact"
        ),
        "RLP": lambda: RLP(mdp, part).solve("HIGHS", arithmetic="exact"),
        "NLP": lambda: NLP(mdp, part).solve(arithmetic="exact"),
        "run_verification": lambda: run_verification(arithmetic="exact"),
    }[solve]
    with pytest.raises(
        ValidationError, match=r"arithmetic must be one of \['float', 'rational'\]; got 'exact'"
    ):
        call()
