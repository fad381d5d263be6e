r"""The approximate LP with a general basis (paper eq. 10 with any ``Phi``; Remark 2).

.. math:: ALP := \min c^T \Phi r \quad\text{s.t.}\quad \Phi r \ge R_u + \lambda P_u \Phi r
          \quad \forall u.

Every feasible ``Phi r`` satisfies the Bellman inequalities, so ``Phi r >= V*``
(Lemma 1): the optimum is an upper bound on ``V*``. With the 0/1 basis of a partition
(eq. 11) this is RLP, whose optimum does not depend on ``c`` (Theorem 1). With a
general basis it does: Remark 2 recalls that under *soft aggregation* (``Phi >= 0``
with rows summing to one, Singh et al.) the optimum depends on the cost (de Farias and
Van Roy 2003). :func:`find_cost_dependent_alp` finds a small seeded instance that shows
it, so Theorem 1's special structure can be seen by contrast.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..certification.certificate import Certificate, certify
from ..dp import exact_rows
from ..errors import ValidationError
from ..model.checks import check_formulation_inputs
from ..model.mdp import FiniteMDP
from ..tolerances import ALP_COST_DEPENDENCE_RTOL
from .base import Formulation, LPResult, check_cost

if TYPE_CHECKING:  # annotations only
    from ..exact.lp import ExactLP

__all__ = ["ALP", "CostDependenceExample", "find_cost_dependent_alp", "soft_aggregation_basis"]


def _check_basis(basis: Any, n: int) -> sp.csr_matrix:
    if sp.issparse(basis):
        phi = sp.csr_matrix(basis, dtype=np.float64)
    else:
        arr = np.asarray(basis, dtype=np.float64)
        if arr.ndim != 2:
            raise ValidationError(
                f"basis must be a 2-d (n_states, K) matrix; got shape {arr.shape}"
            )
        phi = sp.csr_matrix(arr)
    if phi.shape[0] != n or phi.shape[1] < 1:
        raise ValidationError(
            f"basis must have shape (n_states, K) = ({n}, K >= 1); got {phi.shape}"
        )
    if not np.all(np.isfinite(phi.data)):
        raise ValidationError("basis entries must be finite")
    return phi


def _strictly_feasible_direction(a: sp.csr_matrix) -> bool:
    """Whether ``A 1 > 0`` holds exactly, shown in floating point.

    The computed ``d = fl(A 1)`` is within ``(k + 1) eps (|A| 1)`` of the exact one (``k``
    the most entries of a row, any summation order), so ``d`` above twice that proves every
    exact row positive, and then ``t 1`` is feasible for every right-hand side once ``t``
    is large: true for a soft- or hard-aggregation basis (``Phi 1 = 1``: rows ``1 - lambda``).
    """
    if a.shape[0] == 0:
        return True
    ones = np.ones(a.shape[1])
    k = int(np.diff(a.indptr).max(initial=0))
    margin = 2.0 * (k + 1) * float(np.finfo(np.float64).eps) * (abs(a) @ ones)
    return bool(((a @ ones) > margin).all())


class ALP(Formulation):
    r"""The approximate LP ``min c' Phi r  s.t.  Phi r >= R_u + lambda P_u Phi r`` (eq. 10).

    An upper bound ``Phi r* >= V*`` whose optimum, unlike RLP's, depends on the cost
    ``c`` in general (Remark 2). There is therefore no cost-free ``fixed_point``.

    Parameters
    ----------
    mdp : FiniteMDP
    basis : array_like or sparse matrix (n_states, K)
        ``Phi``. The LP is infeasible unless some ``Phi r`` satisfies the Bellman
        inequalities (true when the constant vector is in the span, e.g. soft
        aggregation); :meth:`solve` then reports it.
    cost : array_like (n_states,), optional
        ``c >= 0`` (default ones); the objective is ``(Phi' c)' r``.

    Attributes
    ----------
    problem : cvxpy.Problem
        ``min (Phi'c)'r  s.t.  bellman``.
    r : cvxpy.Variable (K,)
        The weights ``r`` (``variables["r"]``).
    constraints : dict
        ``"bellman"``: eq. 10 with a general ``Phi``, ``(Phi r)(x) >= R_u(x) + lambda
        sum_l p_l (Phi r)(f(x, u, Y_l))`` for every allowed (x, u), one sparse vector
        constraint (the exact rows times ``Phi``); duals ``result.group_duals["bellman"]``.

    Notes
    -----
    Result: ``values`` is ``r``, ``state_values`` is ``Phi r``, ``mu`` the duals per
    (state, action). The ALP's optimum has no solver-free counterpart, so its certificate
    is on ``V*`` itself, per state: ``upper_values = Phi r + max(0, max(T(Phi r) - Phi r))
    / (1 - lambda)`` (rounded up) is a certified upper bound on ``V*`` whatever the solver
    returned (a feasible ``Phi r`` is its own bound, up to rounding), and ``lower_values``
    the matching lower bound from :func:`lpbounds.certification.certificate.certify`. The status
    judges
    only the upper side: OPTIMAL when ``upper_values`` is within ``accuracy`` (relative to
    ``max|R| / (1 - lambda)``) of ``Phi r``.
    """

    name = "ALP"
    #: only the upper side is judged: the point is not a fixed point (see the notes)
    upper_side_only = True
    #: Not in general (a basis without a Bellman-feasible direction: the LP is infeasible);
    #: an instance whose ``A 1 > 0`` is proved (soft or hard aggregation) sets it True.
    feasible_by_construction = False
    bounded_by_construction = True
    boundedness_reason = (
        "every feasible Phi r satisfies the Bellman inequalities, so Phi r >= V* (Lemma 1), "
        "and the cost is >= 0: c'Phi r >= c'V*"
    )

    def __init__(self, mdp: FiniteMDP, basis: Any, cost: Any = None) -> None:
        check_formulation_inputs(mdp, cost=cost, basis=basis)
        self.mdp = mdp
        self.basis = _check_basis(basis, mdp.n_states)
        c = check_cost(cost, mdp.n_states)
        #: the per-state cost ``c`` (the LP's is ``Phi'c``, summed in floating point)
        self.state_cost = c
        self.rows = exact_rows(mdp)
        a_exact, b = self.rows.constraint_matrix()
        super().__init__(
            a_exact @ self.basis,
            b,
            np.asarray(self.basis.T @ c).ravel(),
            variables=[("r", self.basis.shape[1])],
            groups=[("bellman", b.size)],
        )
        if _strictly_feasible_direction(self.A):
            self.feasible_by_construction = True
            self.feasibility_reason = (
                "its rows at r = 1 (all weights one) are > 0 beyond rounding, so r = t 1 "
                "satisfies every row for t large enough"
            )

    def _discount(self) -> float:
        return float(self.rows.discount)

    @property
    def r(self) -> cp.Variable:
        """The cvxpy variable ``r`` (one weight per basis column)."""
        return self.variables["r"]

    def _interpret(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
        return x, np.asarray(self.basis @ x).ravel(), self.rows.pair_values(y), {}

    # ------------------------------------------------------------------ exact arithmetic
    def exact_size(self) -> tuple[int, str]:
        """The MDP's states: the bracket of a float solve is on ``V*``, solved exactly to
        judge it (the simplex itself works on the ``K`` weights)."""
        return self.mdp.n_states, "ALP's states (V*)"

    def exact_lp(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """``(model, lp)``: eq. 10 with this basis, built by the checker from the MDP, the
        basis and the per-state cost (``Phi'c`` summed exactly)."""
        from ..exact.files import mdp_data

        phi = [[float(t).hex() for t in row] for row in self.basis.toarray()]
        lp = {"formulation": "ALP", "basis": phi,
              "state_cost": [float(t).hex() for t in self.state_cost]}  # fmt: skip
        return mdp_data(self.mdp), lp

    def _exact_route(self, approx: Any, size_limit: int | None, callback: Any) -> ExactLP:
        """The exact simplex method from the solver's ``r`` (exact.lp's ``simplex_lp``)."""
        from ..exact.lp import simplex_lp

        model, spec = self.exact_lp()
        return simplex_lp(model, spec, approx=approx, size_limit=size_limit, what="ALP's weights")

    def _exact_bracket_target(self, exact: ExactLP, size_limit: int | None) -> Any:
        """ALP's bracket is on ``V*`` itself (the class notes): solved exactly."""
        from ..dp import solve_exact

        return solve_exact(self.mdp, arithmetic="rational", size_limit=size_limit).rational_values

    def _certify(self, x: np.ndarray) -> Certificate:
        """The bracket on ``V*`` from the state values ``Phi r`` (see the class notes)."""
        return certify(self.rows, np.asarray(self.basis @ x).ravel())

    def _bracket(
        self, cert: Certificate
    ) -> tuple[np.ndarray, np.ndarray, tuple[float, float] | None]:
        return cert.lower, cert.upper, None


def soft_aggregation_basis(n_states: int, n_features: int, seed: int | None = 0) -> np.ndarray:
    """A random soft-aggregation basis: positive entries, each row summing to one (Remark 2)."""
    if n_features < 1 or n_states < 1:
        raise ValidationError("n_states and n_features must be >= 1")
    rng = np.random.default_rng(seed)
    return rng.dirichlet(np.ones(n_features), size=n_states)


@dataclass
class CostDependenceExample:
    """A small instance on which the ALP optimum changes with the cost (Remark 2).

    ``first`` is optimal for ``cost1``; ``second`` for ``cost2``; ``second`` is *not*
    optimal for ``cost1``: ``cost1' Phi r2 - cost1' Phi r1 = excess > tolerance``
    (so the difference is not a tie between alternative optima).
    """

    seed: int
    mdp: FiniteMDP
    basis: np.ndarray
    cost1: np.ndarray
    cost2: np.ndarray
    first: LPResult
    second: LPResult
    excess: float
    tolerance: float

    @property
    def deviation(self) -> float:
        """``max |Phi r1 - Phi r2|``."""
        assert self.first.state_values is not None and self.second.state_values is not None
        return float(np.abs(self.first.state_values - self.second.state_values).max())


def find_cost_dependent_alp(
    seed: int = 0,
    *,
    max_tries: int = 200,
    n_states: int = 6,
    n_actions: int = 2,
    n_features: int = 2,
    solver: str = "HIGHS",
    rtol: float = ALP_COST_DEPENDENCE_RTOL,
) -> CostDependenceExample:
    """Search seeded small random MDPs and soft-aggregation bases for cost dependence.

    Try ``seed, seed + 1, ...``: a Garnet MDP, a random soft-aggregation basis and two
    positive random costs; return the first instance where the optimum for ``cost2``
    is worse than the optimum for ``cost1`` under ``cost1`` by more than
    ``rtol * max(1, |cost1' Phi r1|)`` (default
    :data:`lpbounds.tolerances.ALP_COST_DEPENDENCE_RTOL`).

    Raises
    ------
    LPBoundsError
        If ``max_tries`` instances show no dependence (never observed for the defaults).
    """
    from ..errors import LPBoundsError
    from ..model.generators import garnet

    for k in range(max_tries):
        s = seed + k
        mdp = garnet(n_states, n_actions, 2, 0.9, seed=s)
        rng = np.random.default_rng(10_000 + s)
        basis = soft_aggregation_basis(n_states, n_features, seed=20_000 + s)
        # two positive costs that weight different states heavily
        c1 = 0.01 + rng.dirichlet(np.full(n_states, 0.3)) * n_states
        c2 = 0.01 + rng.dirichlet(np.full(n_states, 0.3)) * n_states
        r1 = ALP(mdp, basis, c1).solve(solver)
        r2 = ALP(mdp, basis, c2).solve(solver)
        assert r1.state_values is not None and r2.state_values is not None
        excess = float(c1 @ r2.state_values - c1 @ r1.state_values)
        tol = rtol * max(1.0, abs(r1.objective))
        if excess > tol:
            return CostDependenceExample(s, mdp, basis, c1, c2, r1, r2, excess, tol)
    raise LPBoundsError(f"no cost dependence found in {max_tries} tries from seed {seed}")
