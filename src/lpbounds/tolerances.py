"""Every numerical tolerance lpbounds uses, in one place.

Each constant is documented with what it bounds and why it has its value; the
functions and results that use one report it next to the quantity it bounds.
"""

from __future__ import annotations

#: Absolute tolerance on ``|sum_l p_l - 1|`` for the probabilities of an allowed
#: (state, action) pair. Probabilities are read from files and built from sums of
#: floats, so a few ulps of slack are needed; 1e-9 is far below any modelling error.
PROBABILITY_SUM_ATOL: float = 1e-9

#: Probabilities above ``-PROBABILITY_NEGATIVE_ATOL`` are accepted (and clipped to 0).
PROBABILITY_NEGATIVE_ATOL: float = 1e-12

#: Default relative stopping tolerance of the exact DP solvers: the Bellman residual
#: ``||T V - V||_inf`` of the returned ``V`` is at most ``DP_RTOL * scale`` with
#: ``scale = max|R| / (1 - discount)`` (the largest possible ``|V*|``).
DP_RTOL: float = 1e-10

#: Relative tolerance under which two Q-values count as tied in a greedy policy
#: (``q >= max q - GREEDY_TIE_RTOL * max(1, |max q|)``); ties go to the lowest action.
GREEDY_TIE_RTOL: float = 1e-12

#: Default relative tolerance on the primal residual of an LP solution,
#: ``max(b - A v)_+ <= LP_RESIDUAL_RTOL * max(1, max|b|)``, checked by lpbounds on the
#: returned point (never trusted from the solver). Interior point solvers (Clarabel)
#: stop at about 1e-8 relative, so 1e-6 leaves room without hiding a wrong answer.
LP_RESIDUAL_RTOL: float = 1e-6

#: Default relative tolerance when an LP optimum is compared with its exact,
#: solver-free counterpart (``max|v_lp - v_fp| <= LP_COMPARE_RTOL * max(1, max|v_fp|)``).
LP_COMPARE_RTOL: float = 1e-6


def dp_scale(rewards_absmax: float, discount: float) -> float:
    """Scale of the value function, ``max|R| / (1 - discount)`` (at least 1e-300)."""
    return max(float(rewards_absmax) / (1.0 - float(discount)), 1e-300)
