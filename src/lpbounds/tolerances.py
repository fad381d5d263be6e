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

#: Default requested accuracy of an LP solve, relative to the problem's scale: a result is
#: OPTIMAL when the Bellman residual of its returned point is at most
#: ``LP_CERT_RTOL * max|R|``, so that its certified error (lpbounds.certificate) is at most
#: ``LP_CERT_RTOL * max|R| / (1 - lambda)`` plus the rounding allowance. Relative to the
#: scale, never absolute, so that rewards of 1e-6 or 1e6 are judged alike. Measured at the
#: solvers' default settings (2026-12-01): on the shipped garnet-small and patrol-small
#: models HiGHS reaches 1e-13 to 1e-11 and Clarabel 3e-9 to 2e-8 (ELP, RLP, IB, UBLP, LBLP);
#: on a 200-state garnet at discount 0.99 Clarabel reaches 8.3e-7. 1e-6 accepts those and
#: is far below any modelling error; ask for more with ``solve(..., accuracy=...)``.
LP_CERT_RTOL: float = 1e-6

#: Default relative tolerance when an LP optimum is compared with its exact,
#: solver-free counterpart (``max|v_lp - v_fp| <= LP_COMPARE_RTOL * max(1, max|v_fp|)``).
LP_COMPARE_RTOL: float = 1e-6

#: Relative tolerance of the exact DP that computes an exported LP's optimum
#: (:mod:`lpbounds.export`): the fixed point's Bellman residual is at most
#: ``EXPORT_DP_RTOL * max|R| / (1 - lambda)``. A benchmark's reference must be far more
#: accurate than the solvers it judges (HiGHS reaches 1e-13 to 1e-11 relative on the
#: shipped models, see LP_CERT_RTOL); 1e-12 stays several hundred times above the rounding floor
#: of a Bellman sweep (about (L + 3) eps max|V|), so MPI reaches it at every size.
EXPORT_DP_RTOL: float = 1e-12


#: Rows whose exact sums are certified within this of 1 (``RowSums.delta``) are treated
#: as stochastic by the exact DP's Porteus offset, which is then carried as a scalar
#: (``T(u + c) = T u + lambda c``); its error ``lambda |c| delta`` is added to the reported
#: residual. With ``|c| <= max|R| / (1 - lambda)`` that is at most 1e-12 of the value scale,
#: 1 % of the default tolerance ``DP_RTOL``. Rows normalised in floating point sum to 1
#: within ``(L - 1) eps`` and are certified within about ``2 (L + 1) eps`` (2.7e-15 for
#: L = 5); rows summing to ``1 +- 1e-9`` (accepted, PROBABILITY_SUM_ATOL) are not, and the
#: DP folds the offset into the iterate every sweep instead (dp.PorteusShift).
DP_OFFSET_ROWSUM_ATOL: float = 1e-12


def dp_scale(rewards_absmax: float, discount: float) -> float:
    """Scale of the value function, ``max|R| / (1 - discount)`` (at least 1e-300)."""
    return max(float(rewards_absmax) / (1.0 - float(discount)), 1e-300)


# ---------------------------------------------------------------------- NLP (eq. 25)
#: Default relative gap at which the NLP's cutting-plane loop stops:
#: ``upper - lower <= NLP_GAP_RTOL * max(1, |upper|)`` on the bracket of ``c'w*``. The
#: measured runs (docs/nlp.md) close to 1e-6 in 5-90 rounds where they converge; a
#: smaller target mostly adds stalled rounds.
NLP_GAP_RTOL: float = 1e-6

#: A disjunction counts as violated by the master's ``w`` when
#: ``min_terms q_t(w) - w(i) > NLP_VIOLATION_RTOL * scale`` (``scale = max|R| / (1 -
#: discount)``): above the loop's HiGHS feasibility tolerance (``NLP_HIGHS_FEAS_TOL``, on
#: rows whose coefficients are O(1)), so a solver's round-off is not chased with cuts.
NLP_VIOLATION_RTOL: float = 1e-9

#: Primal and dual feasibility tolerance of the HiGHS models of the cutting-plane loop
#: (HiGHS' default is 1e-7). The CGLP's optimum near convergence is about -1e-7 under
#: the multiplier normalisation, i.e. at the default tolerance: measured on a 30-state
#: garnet, the cuts it returned were then no longer violated once given their exact
#: right-hand side and the loop stalled at a relative gap of 5.6e-6; with 1e-9 it closed
#: the gap to 1e-6 in 132 rounds. (Validity never depends on this: right-hand sides are
#: certified by weak duality whatever the tolerance.)
NLP_HIGHS_FEAS_TOL: float = 1e-9

#: Safety margin of a cut's right-hand side. After the cut ``alpha'w >= beta`` is
#: rescaled to ``max|alpha| = 1``, ``beta`` is recomputed as the smallest of the
#: rigorous (weak-duality) lower bounds on ``min alpha'w`` over each term's polyhedron
#: and then lowered by ``NLP_CUT_SAFETY_RTOL * max(1, |beta|)``. The weak-duality bound is
#: valid for any multipliers, so the margin only has to cover floating-point rounding in
#: evaluating it (about 1e-15 relative per term); 1e-9 is a million times that.
NLP_CUT_SAFETY_RTOL: float = 1e-9

#: A cut is added only if, after rescaling and the exact right-hand side, it cuts the
#: master's point off by more than ``NLP_CUT_MIN_DEPTH_RTOL * scale``; shallower cuts
#: do not move the master and only make it larger.
NLP_CUT_MIN_DEPTH_RTOL: float = 1e-9

#: Strategy iteration switches a disjunction to another term only when that term is
#: smaller by more than ``NLP_SWITCH_RTOL * scale`` at the current values: ties keep the
#: current term, which is what makes the method finite in floating point.
NLP_SWITCH_RTOL: float = 1e-12

#: Relative MILP gap asked of HiGHS for ``method="milp"`` (its default, 1e-4, is far
#: too loose for a bound that is compared with exact methods to 1e-9).
NLP_MILP_GAP_RTOL: float = 1e-10


#: Multiple of machine epsilon (times ``max|V|``) added to a measured Bellman residual
#: before it is turned into an error bound: the residual is computed in floating point,
#: and on chains where the bound ``residual / (1 - discount)`` is attained (absorbing
#: states) rounding alone would otherwise make the reported bound a few ulps too small.
ROUNDING_ULPS: float = 8.0


def error_bound(residual: float, values_absmax: float, modulus: float) -> float:
    """Bound on ``||V - V*||``: ``(residual + ROUNDING_ULPS eps max(1, max|V|)) / (1 - kappa)``.

    ``modulus`` is the contraction modulus ``kappa = lambda max_r s_r`` of the rows
    (``RowSums.modulus``, ``lpbounds.dp.modulus``), not the discount: with rows summing
    to ``1 + 9e-10`` at discount 0.99999 the discount alone understates the bound 10^4-fold.
    """
    import numpy as np

    slack = ROUNDING_ULPS * float(np.finfo(np.float64).eps) * max(1.0, float(values_absmax))
    return (float(residual) + slack) / (1.0 - float(modulus))

