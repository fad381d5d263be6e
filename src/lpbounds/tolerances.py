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

#: Default stopping tolerance of the exact DP solvers, relative to the largest reward:
#: the Bellman residual ``||T V - V||_inf`` of the returned ``V`` is at most
#: ``DP_RTOL * max|R|`` (never below the rounding floor, :func:`dp_default_tol`), so its
#: certified error bound, residual / (1 - discount), is ``DP_RTOL`` of the value scale
#: ``max|R| / (1 - discount)``: V* to about 11 significant digits of its largest
#: possible size. Measured (2026-12-02, docs/benchmarks.md): with values of order 1 at
#: discount 0.99 (FrozenLake 4x4 and 8x8) the error of the returned V* equals its bound,
#: 2.9e-9 at 1e-10 and 2.9e-10 at 1e-11, so 1e-11 is the largest setting whose default
#: V* passes a 1e-9 cross-check there; the cost over the former default (1e-10 of the
#: value scale, 1e-9 of max|R| at discount 0.9) is 1-2 improvement sweeps on the patrol
#: and the garnets.
DP_RTOL: float = 1e-11

#: Floor of the default DP tolerance in units of ``eps``: the residual of a sweep is
#: computed with a rounding error of up to about ``(L + 3) eps max|V|`` (``L`` outcomes
#: per row, ``max|V| <= max|R| / (1 - discount)``), so a tolerance below that may never
#: be reached (at discount 0.9999, ``DP_RTOL * max|R|`` is 1e-15 of the value scale).
#: The default is at least ``DP_FLOOR_ULPS (L + 3) eps max|R| / (1 - discount)``, 8
#: times the worst-case rounding of the residual.
DP_FLOOR_ULPS: float = 8.0

#: Relative tolerance under which two Q-values count as tied in a greedy policy
#: (``q >= max q - GREEDY_TIE_RTOL * max(1, |max q|)``); ties go to the lowest action.
GREEDY_TIE_RTOL: float = 1e-12

#: Default requested accuracy of an LP solve, relative to the problem's scale: a result is
#: OPTIMAL when the Bellman residual of its returned point is at most
#: ``LP_CERT_RTOL * max|R|``, so that its certified error (lpbounds.certification.certificate) is
#: at most
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
#: (:mod:`lpbounds.studies.export`): the fixed point's Bellman residual is at most
#: ``EXPORT_DP_RTOL * max|R|`` (never below the rounding floor of :func:`dp_default_tol`),
#: a tenth of the default ``DP_RTOL``, so the reference is more accurate than a default
#: ``solve_exact`` at every discount. A benchmark's reference must be far more accurate
#: than the solvers it judges (HiGHS reaches 1e-13 to 1e-11 relative on the shipped
#: models, see LP_CERT_RTOL). (Until the default accuracy was measured this was relative to
#: the value scale ``max|R| / (1 - lambda)``, which at discount 0.99 left the reference's
#: error bound at 1e-10 of the value scale, above a default solve's 1e-11.)
EXPORT_DP_RTOL: float = 1e-12


#: Rows whose exact sums are certified within this of 1 (``RowSums.delta``) are treated
#: as stochastic by the exact DP's Porteus offset, which is then carried as a scalar
#: (``T(u + c) = T u + lambda c``); its error ``lambda |c| delta`` is added to the reported
#: residual, and kept below :data:`DP_OFFSET_CARRY_SHARE` of the tolerance (the offset is
#: folded into the iterate whenever it would be more). Rows normalised in floating point
#: sum to 1 within ``(L - 1) eps`` and are certified within about ``2 (L + 1) eps``
#: (2.7e-15 for L = 5); rows summing to ``1 +- 1e-9`` (accepted, PROBABILITY_SUM_ATOL) are
#: not, and the DP folds the offset into the iterate every sweep (dp.PorteusShift) and
#: extrapolates with the rows' mean effective discount.
DP_OFFSET_ROWSUM_ATOL: float = 1e-12


def offset_folds(row_delta: float) -> bool:
    """True when rows whose sums are certified within ``row_delta`` of 1 are not
    stochastic to rounding (:data:`DP_OFFSET_ROWSUM_ATOL`): the exact DP then folds its
    Porteus offset into the iterate after every sweep (``dp.PorteusShift``), and its
    default tolerance has the higher floor of :func:`dp_default_tol`."""
    return float(row_delta) > DP_OFFSET_ROWSUM_ATOL


#: The periodic-chain floor of :func:`dp_default_tol`, in units of ``eps max|R| / (1 -
#: lambda)^2``. Rounding adds about ``eps |V|`` to the iterate every sweep; on a periodic
#: chain (period 2: x -> y -> x) the alternating error mode decays at ``lambda`` only (the
#: Porteus shift removes the constant mode alone), so that rounding accumulates to about
#: ``eps max|V| / (1 - lambda)`` and the residual stalls there. Measured (hypothesis cases
#: of tests/dp/test_row_sums.py, rewards ~1e-3, discount 0.999): MPI stalled at a residual
#: of ``0.48 eps max|R| / (1 - lambda)^2`` (9.7e-14 against a default of 9.1e-15), and
#: policy evaluation at 8.021e-15 against 8.020e-15. 2 leaves a factor 4.
DP_NOISE_ULPS: float = 2.0

#: The share of the stopping tolerance that the error of a carried Porteus offset,
#: ``lambda |c| delta``, may take: beyond it the offset is folded into the iterate
#: before the next sweep, so the added error never keeps the loop from reaching its
#: tolerance (with ``|c|`` up to the value scale and ``delta`` up to
#: DP_OFFSET_ROWSUM_ATOL it could be 1e-12 of the value scale, above the default
#: tolerance at discounts from 0.9).
DP_OFFSET_CARRY_SHARE: float = 1.0 / 16.0


#: A partition's upper and lower bounds are reported out of order (``v*(i) - w*(i) <
#: -BOUND_ORDER_ATOL``, against Theorems 3-4's ``w*(i) <= V*(x) <= v*(i)``) only beyond
#: this: both are fixed points computed to ``DP_RTOL`` of the value scale (patrol values
#: are O(1)-O(10)), so a few ulps of disagreement on a zero gap are rounding, not a defect.
BOUND_ORDER_ATOL: float = 1e-9

#: Figure 3 (:func:`lpbounds.patrol.figures.plot_ordered_states`) marks an increase of
#: ``V*`` along a chain of ordered states (against Claim 2: ``V*`` is non-increasing in the
#: delays) only beyond ``FIGURE_MONOTONE_RTOL * max|V*|``: ``V*`` is computed to
#: ``DP_RTOL`` of the value scale, so smaller rises are the fixed point's residual.
FIGURE_MONOTONE_RTOL: float = 1e-9

#: Default absolute truncation error of a Monte Carlo return
#: (:func:`lpbounds.patrol.greedy_mc.default_horizon`): paths are cut at the smallest
#: horizon ``H`` with ``lambda^H max|R| / (1 - lambda) <= MC_TRUNCATION_TARGET``. Far below
#: the sampling error of any feasible number of paths (standard errors of 1e-3-1e-2 on the
#: patrol's values of order 10), so the cut never shows in a result.
MC_TRUNCATION_TARGET: float = 1e-6

#: Default tolerance of :func:`lpbounds.formulations.alp.find_cost_dependent_alp`: the ALP
#: optimum for one cost counts as worse than the other's (Remark 2: the ALP depends on its
#: cost) only by more than ``ALP_COST_DEPENDENCE_RTOL * max(1, |objective|)``, the accuracy
#: an LP solve is asked for (``LP_CERT_RTOL``), so solver round-off is never taken for it.
ALP_COST_DEPENDENCE_RTOL: float = 1e-6

#: Smallest denominator of a relative quantity whose denominator may be exactly 0 (a range
#: of values, a scale): keeps the quotient finite without changing any non-zero one.
TINY: float = 1e-300


def dp_scale(rewards_absmax: float, discount: float) -> float:
    """Scale of the value function, ``max|R| / (1 - discount)`` (at least 1e-300)."""
    return max(float(rewards_absmax) / (1.0 - float(discount)), 1e-300)


def dp_default_tol(
    rewards_absmax: float,
    discount: float,
    n_outcomes: int,
    rtol: float | None = None,
    row_delta: float = 0.0,
) -> float:
    """The exact DP's default residual tolerance: ``max(rtol max|R|, floor)``.

    ``rtol`` is :data:`DP_RTOL` unless given (:data:`EXPORT_DP_RTOL` for an exported LP's
    reference optimum). ``row_delta`` is the rows' certified distance of their sums from 1
    (``RowSums.delta``): when :func:`offset_folds` says the rows are not stochastic to
    rounding, the loops add the Porteus offset into the vector
    after every sweep, and that addition's rounding (``eps max|V|``) is extrapolated by the
    next shift (``lambda / (1 - lambda)``): the floor is then divided by ``1 - discount``
    once more. Measured: rows summing to ``1 + 9e-10`` at discount 0.999 stalled at a
    residual of ``2.6e-8``, 3.3 times ``DP_RTOL max|R|``, about ``eps max|V| / (1 - lambda)``.

    ``floor = DP_FLOOR_ULPS (L + 3) eps max|R| / (1 - discount)`` with ``L =
    n_outcomes`` (the most outcomes of a row): the smallest residual a sweep can be
    trusted to reach at any discount (:data:`DP_FLOOR_ULPS`). The certified error bound
    of the result is then at most ``DP_RTOL`` of the value scale where the floor does not
    bind (discounts up to about ``1 - 5e-3`` for ``L <= 40``).

    A second floor, ``DP_NOISE_ULPS eps max|R| / (1 - discount)^2``, is the residual that
    rounding keeps alive on a periodic chain (see :data:`DP_NOISE_ULPS`); it binds only
    above discount 0.99 (it is ``4.4e-12 max|R|`` there).
    """
    import numpy as np

    eps = float(np.finfo(np.float64).eps)
    scale = dp_scale(rewards_absmax, discount)
    floor = DP_FLOOR_ULPS * (int(n_outcomes) + 3) * eps * scale
    noise = DP_NOISE_ULPS * eps * scale
    if discount < 1.0:
        noise /= 1.0 - float(discount)
        if offset_folds(row_delta):
            floor /= 1.0 - float(discount)
    rel = (DP_RTOL if rtol is None else float(rtol)) * float(rewards_absmax)
    return max(rel, floor, noise)


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

#: The exact solves inside the NLP (a strategy's fixed point by policy iteration, the
#: fixed point of G, the monotone master's strategy values) stop at this residual relative
#: to ``max|R| / (1 - lambda)``: far below any gap the NLP is asked for (``NLP_GAP_RTOL``),
#: so that their rounding, not their stopping rule, limits the certified bracket.
NLP_EXACT_RTOL: float = 1e-13

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


# ---------------------------------------------------------------------- LP scaling
#: The band of ``max|b|`` (the rows' right-hand sides: the rewards) and of ``max|c|`` (the
#: cost) in which an LP of a discounted MDP is handed to the solver exactly as built;
#: outside it, ``b`` and ``c`` are each multiplied by a power of two (exact in binary
#: floating point) so that the largest entry lies in [1, 2), and the point and duals are
#: scaled back (:meth:`lpbounds.formulations.base.Formulation.solve`). Why these ends
#: (measured on 30- and 40-state garnets at discounts 0.9-0.9999, docs/benchmarks.md "LP
#: data scale"): below, the solvers' absolute tolerances (HiGHS' feasibility tolerance
#: 1e-7, Clarabel's 1e-8) meet the certificate's ``accuracy * max|R|`` (1e-6 relative):
#: HiGHS turns INACCURATE from max|R| ~ 1e-6 (relative error 0.05-0.08), Clarabel from
#: ~ 1e-3, and costs alike; 2**-10 (9.8e-4) is at Clarabel's edge. Above: HiGHS treats
#: 1e20 as infinity (passModel fails) and Clarabel calls feasible LPs infeasible or
#: unbounded once the values reach ~ 1e9 (see LP_VALUE_SCALE_MAX); 2**20 (1.05e6) keeps
#: the rows well away from both. The band contains every shipped model (patrol rewards
#: 1-100, garnets 0-1, unit costs), whose results are therefore bit for bit those of an
#: unscaled solve.
LP_DATA_BAND: tuple[float, float] = (2.0**-10, 2.0**20)

#: The largest value scale ``max|b| / (1 - lambda)`` (and dual scale ``max|c| / (1 -
#: lambda)``) left unscaled, whatever ``max|b|``: Clarabel's false "infeasible"/"unbounded"
#: starts at value scales of about 1e9 (2**30) in the measurements of LP_DATA_BAND
#: (rewards 1e9 at discount 0.9, 1e7 at 0.99, 1e5 at 0.9999); 2**26 (6.7e7) leaves a
#: factor 16 below that. The shipped models are far below it (patrol: 1e3). Scaling down
#: is not free for Clarabel: below that edge its certified accuracy at discounts >= 0.99
#: grows with the value scale (at 0.99 and rewards 1e6, value scale 1e8: 4 of 5 garnets
#: OPTIMAL as built, 2 of 5 scaled, the others INACCURATE with valid brackets), so the cap
#: is not set lower than the safety margin needs.
LP_VALUE_SCALE_MAX: float = 2.0**26

#: The largest objective ``sum|c| max|x|`` and dual total ``sum(c) / (1 - lambda)`` an LP
#: of a discounted MDP may have (else a ValidationError before the solver): scaling gives
#: the solver unit data, but the result is reported in the model's units, and the
#: certificate's objective bracket and weak-duality bound sum terms ``|c_i x_i|`` and
#: ``y_r |b_r|`` whose totals are bounded by these, inflated by rounding allowances of
#: ``(1 + n eps)`` and a few such terms added together. 2**1016 (7e305) leaves a factor 256
#: below float64's largest number (1.8e308) for that; a cost of 1e300 on a small model
#: (objective ~ 1e302) is accepted.
LP_OBJECTIVE_MAX: float = 2.0**1016


# ---------------------------------------------------------------------- exact arithmetic
#: The most variables one dense exact (rational) solve accepts unless ``size_limit=`` says
#: otherwise (:func:`lpbounds.exact.system.check_size`): the largest strongly connected
#: component of a policy's graph, which exact policy evaluation solves as one dense block
#: (:meth:`lpbounds.exact.system.ExactRows.solve_policy`), checked before it starts. Not a
#: tolerance but a cost limit, measured (docs/benchmarks.md,
#: "Exact arithmetic", 2 cores): exact ``V*`` of a random garnet (3 actions, 5 successors,
#: one strongly connected policy graph: the worst case, one dense solve) took 1.8 s at 200
#: states, 11 s at 400, 31 s at 600 and 73 s at 800 (time ~ n^3, the values' common
#: denominator ~ 105 bits per state; memory stayed below 140 MB). 600 keeps one exact
#: solve near half a minute, and a Ctrl-C waiting for the dense block in progress as long.
#: Models whose policy graph splits into small components pass at any size and pay far
#: less (taxi's 501 states: components of one state, 0.015 s against 0.65 s as one block;
#: a patrol of 812 states: largest component 190, 0.15 s).
EXACT_MAX_VARIABLES: int = 600


# ---------------------------------------------------------------------- plots
#: :func:`lpbounds.plot.bounds` circles a state whose ``V*`` lies outside a bound given as a
#: plain array (no certified bracket to judge by) only beyond ``PLOT_BOUND_RTOL * max(1,
#: max|V*|)``: such arrays are typically fixed points computed to ``DP_RTOL`` of the value
#: scale, so smaller excursions are their residual, not a broken bound.
PLOT_BOUND_RTOL: float = 1e-9

#: :func:`lpbounds.plot.nlp_bracket` accepts a reference LP as solved for the NLP's cost
#: when ``|c'values - objective| <= PLOT_COST_MATCH_RTOL * (|c|'|values| + |objective|)``:
#: the objective is ``c'x`` recomputed in floating point (a few ulps per term), while another
#: cost changes it by a share of the value scale.
PLOT_COST_MATCH_RTOL: float = 1e-9

# ---------------------------------------------------------------------- Dask
#: Seconds a campaign or a study waits for a Dask scheduler's address (``--scheduler
#: tcp://host:port``) to answer before refusing it, before anything is written: a TCP
#: connection on a local network opens in milliseconds and a scheduler answers a new
#: client in well under a second, while an address with nothing behind it (a firewall
#: dropping the packets) would otherwise hang for the system's TCP timeout (minutes).
SCHEDULER_CONNECT_SECONDS: float = 10.0
