r"""Lifted restricted LPs (paper Section 3.2): the iterated-Bellman LP (eq. 20-22) and LLP (eq. 18).

Theorem 2 and the remark before it say that neither lifting improves RLP's bound:
every feasible point of either LP has ``v_j >= v*`` (each block, for IB) or ``v >= v*``
(for LLP), where ``v*`` is RLP's optimum.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..certification.certificate import Certificate, certify
from ..errors import ValidationError
from ..model.checks import check_formulation_inputs, sink_block_note
from ..model.mdp import FiniteMDP
from ..model.partition import Partition
from ..rows import BellmanRows
from ..validation import check_allocation
from .base import Formulation, check_cost
from .rows_lp import RowsLP

if TYPE_CHECKING:  # annotations only
    from ..exact.lp import ExactLP

__all__ = ["IB", "LLP"]


class IB(RowsLP):
    r"""The iterated-Bellman lifted LP over partitions (eq. 20-22), ``L >= 1`` blocks.

    .. math::

        \begin{array}{l}
        IB := \min \sum_{j=1}^L \bar c^T v_j \quad\text{s.t.} \\
        \qquad v_{j+1}(i) \ge R_u(x) + \lambda \sum_l p_l\, v_j(\bar f(x,u,Y_l))
        \ (j = 1..L-1), \\
        \qquad v_1(i) \ge R_u(x) + \lambda \sum_l p_l\, v_L(\bar f(x,u,Y_l)),
        \end{array}

    for all ``x in S_i``, ``i``, ``u``. Theorem 2: every feasible ``(v_1, ..., v_L)`` has
    ``v_j >= v*`` (RLP's optimum) for every ``j``, so lifting with iterated Bellman
    inequalities gives no better upper bound. ``L = 1`` is RLP itself.

    The rows are RLP's (merged) aggregated rows, one copy per block, with owner in
    block ``j+1`` and targets in block ``j`` (cyclically): a row system on ``L * M``
    variables, whose least feasible point (Fact 1 of :mod:`lpbounds.rows.system`, so the LP's
    optimum for every ``c >= 0``) is ``(v*, ..., v*)`` (:meth:`fixed_point`).

    Parameters
    ----------
    mdp : FiniteMDP
    partition : Partition
    L : int
        Number of blocks, ``>= 1``. An ``L`` whose ``L`` copies of the rows and LP matrix
        would not fit in the machine's physical memory (a lower-bound estimate against
        ``SC_PHYS_PAGES * SC_PAGE_SIZE``) is refused before anything is allocated.
    cost : array_like (n_states,), optional
        ``c(x) >= 0`` (default ones); every block gets the cost ``c-bar``.

    Raises
    ------
    ValidationError
        For an ``L`` that is not an integer ``>= 1``, or too large for the memory (the
        message gives the bytes needed and available).

    Attributes
    ----------
    problem : cvxpy.Problem
        ``min sum_j c-bar'v_j  s.t.  bellman_1, ..., bellman_L``.
    v : list of cvxpy.Variable
        ``v[j - 1]`` is the paper's ``v_j`` (``variables["v_j"]``), ``M`` entries each.
    constraints : dict
        One group per block, each one sparse vector constraint over RLP's merged rows:
        ``"bellman_1"`` is eq. 22, ``v_1(i) >= R_u(x) + lambda sum_l p_l v_L(...)``, and
        ``"bellman_{j+1}"`` is eq. 21 for ``j``, ``v_{j+1}(i) >= R_u(x) + lambda sum_l p_l
        v_j(...)`` (for ``L = 1`` the single group is RLP's eq. 9). Duals:
        ``result.group_duals["bellman_j"]``.

    Notes
    -----
    Result: ``values`` is ``v_1``, ``extra["blocks"]`` the (L, M) array of all blocks,
    ``extra["block_mu"]`` the (L, n, A) pair duals of each block's rows and ``mu`` their
    sum over blocks.
    """

    name = "IB"

    def __init__(self, mdp: FiniteMDP, partition: Partition, L: int, cost: Any = None) -> None:
        check_formulation_inputs(mdp, partition, cost=cost)
        if isinstance(L, bool) or not isinstance(L, (int, np.integer)) or L < 1:
            raise ValidationError(f"L must be an integer >= 1; got {L!r}")
        self.mdp = mdp
        self.partition = partition
        self.partition_note = sink_block_note(mdp, partition)
        self.L = int(L)
        c = check_cost(cost, mdp.n_states)
        cbar = np.bincount(partition.labels, weights=c, minlength=partition.n_partitions)
        self.base_rows = BellmanRows.aggregate(mdp, partition, reduce="max")
        _check_lift_size(self.L, self.base_rows)  # before anything of size L is allocated
        super().__init__(_cyclic_rows(self.base_rows, self.L), np.tile(cbar, self.L))

    def _variable_blocks(self) -> list[tuple[str, int]]:
        """``v_1, ..., v_L``: ``M`` columns each (the cyclic rows' variable blocks)."""
        m = self.partition.n_partitions
        return [(f"v_{j}", m) for j in range(1, self.L + 1)]

    def _group_blocks(self) -> list[tuple[str, int]]:
        """``bellman_j``: the copy of RLP's rows owned by ``v_j`` (copy ``j - 1``)."""
        r = self.base_rows.n_rows
        return [(f"bellman_{j}", r) for j in range(1, self.L + 1)]

    @property
    def v(self) -> list[cp.Variable]:
        """``[v_1, ..., v_L]``: the cvxpy variable of each block."""
        return [self.variables[f"v_{j}"] for j in range(1, self.L + 1)]

    def _interpret(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
        m = self.partition.n_partitions
        blocks = x.reshape(self.L, m)
        yb = y.reshape(self.L, self.base_rows.n_rows)
        block_mu = np.stack([self.base_rows.pair_values(yj) for yj in yb])
        extra = {"blocks": blocks, "block_mu": block_mu}
        return blocks[0], self.partition.lift(blocks[0]), block_mu.sum(axis=0), extra

    def _bracket(
        self, cert: Certificate
    ) -> tuple[np.ndarray, np.ndarray, tuple[float, float] | None]:
        """Block ``v_1``'s bracket as ``lower_values``/``upper_values``; every block's is in
        ``result.certificate`` (shape (L * M,)); the objective bracket covers all blocks."""
        m = self.partition.n_partitions
        return cert.lower[:m], cert.upper[:m], cert.objective_bracket(self.c)

    def fixed_point(self, tol: float | None = None) -> np.ndarray:
        """``(v*, ..., v*)`` stacked as an (L, M) array, ``v*`` = RLP's fixed point (Lemma 1)."""
        from ..dp import solve_exact

        v = solve_exact(self.base_rows, tol=tol).values
        return np.tile(v, (self.L, 1))

    # ------------------------------------------------------------------ exact arithmetic
    def exact_size(self) -> tuple[int, str]:
        """RLP's partitions: IB's exact optimum is ``(v*, ..., v*)`` from one RLP solve."""
        return self.partition.n_partitions, "IB's partitions (RLP's fixed point)"

    def exact_lp(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """``(model, lp)``: eq. 20-22 built by the checker from the MDP and the partition."""
        from ..exact.files import mdp_data

        model = mdp_data(self.mdp, self.partition)
        return model, {"formulation": "IB", "L": self.L, "cost": self.exact_cost()}

    def _exact_route(self, approx: Any, size_limit: int | None, callback: Any) -> ExactLP:
        """RLP's exact fixed point in every block and the cyclic policy's duals."""
        from ..exact.lp import ib_lp

        model, _ = self.exact_lp()
        return ib_lp(model, self.L, list(self.c), approx=approx, callback=callback,
                     size_limit=size_limit)  # fmt: skip


def _check_lift_size(L: int, rows: BellmanRows) -> None:
    """Refuse an ``L`` whose lifted rows cannot fit in this machine's memory.

    The estimate is a lower bound on what IB holds at once: the ``L`` copies of the
    rows as :func:`_cyclic_rows` builds them (int64 owner, block and targets, int32
    action, float64 reward, and float64 probabilities unless shared by every row) and
    the LP's constraint matrix (CSR: one float64 entry and int32 index per owner and per
    target). Python integers: no overflow for any ``L``.
    """
    r, width = rows.targets.shape
    per_row_probs = np.asarray(rows.probs).strides[0] != 0
    per_row = 8 * 2 + 4 + 8 + 8 * width + (8 * width if per_row_probs else 0) + 12 * (1 + width)
    check_allocation(
        f"L = {L}",
        L * r * per_row,
        f"IB's {L} blocks of RLP's {r} rows ({L * r:,} rows, {L * rows.n_vars:,} variables:"
        " the lifted rows and the LP's constraint matrix, at least)",
    )


def _cyclic_rows(rows: BellmanRows, L: int) -> BellmanRows:
    """``L`` copies of ``rows``: copy ``j`` owned by block ``j``, targets in block ``j-1 mod L``."""
    m, r = rows.n_vars, rows.n_rows
    blk = np.repeat(np.arange(L, dtype=np.int64), r)
    owner = np.tile(rows.owner.astype(np.int64), L) + blk * m
    src = (blk - 1) % L
    targets = np.tile(rows.targets.astype(np.int64), (L, 1)) + src[:, None] * m
    probs = np.asarray(rows.probs)
    probs = (
        np.broadcast_to(probs[0], targets.shape)
        if probs.strides[0] == 0
        else np.tile(probs, (L, 1))
    )
    return BellmanRows.from_arrays(
        owner,
        np.tile(rows.action, L),
        np.tile(rows.reward, L),
        targets,
        probs,
        rows.discount,
        L * m,
    )


class LLP(Formulation):
    r"""A lifted restricted LP of the form of eq. 18, with surplus variables as the lifting.

    .. math::

        \begin{array}{l}
        LLP := \min \bar c^T v + d^T z \quad\text{s.t.} \\
        \qquad V(x) \ge R_u(x) + \lambda \sum_l p_l V(f(x,u,Y_l)),\quad V(x) = v(i)\ (x \in S_i),
        \quad z \ge 0.
        \end{array}

    The paper leaves the lifting ``z`` generic. lpbounds makes it concrete: ``z`` has
    one entry per allowed (state, action) pair, the **surplus** of that pair's Bellman
    inequality (eq. 18 in standard form),

    .. math:: z_u(x) = V(x) - R_u(x) - \lambda \sum_l p_l V(f(x,u,Y_l)) \;\ge\; 0,

    with ``V = Phi v`` substituted (eq. 18's second constraint). So the variables are
    ``(v, z)`` (``M + #pairs``), the constraints ``A_pair v - z = R`` (two inequalities
    each) and ``z >= 0``, and the cost ``d >= 0`` prices the surplus: a positive ``d``
    rewards points where the Bellman inequalities are tight, which is the hope of a
    lifting, yet the projection of the feasible set onto ``v`` is exactly RLP's feasible
    set, so (the argument after eq. 18, Theorem 2's companion) every optimal
    ``(v~, z~)`` has ``v~ >= v*`` and ``Phi v~ >= Phi v*``: no better bound. Since
    ``z = A_pair v - R``, the objective is ``g' v - d' R`` with the effective cost
    ``g = c-bar + A_pair' d``: when ``g >= 0`` the optimal ``v`` is ``v*`` again (Fact 1
    of :mod:`lpbounds.rows.system`); when ``g`` has negative entries it may be larger than
    ``v*``, never smaller.

    Parameters
    ----------
    mdp : FiniteMDP
    partition : Partition
    d : array_like (n_states, n_actions)
        Cost of the surplus variables, ``>= 0`` (entries of disallowed pairs ignored).
    cost : array_like (n_states,), optional
        ``c(x) >= 0`` (default ones).

    Attributes
    ----------
    problem : cvxpy.Problem
        ``min c-bar'v + d'z  s.t.  surplus_lower, surplus_upper, z_nonneg``.
    v : cvxpy.Variable (M,)
        The paper's ``v`` (``variables["v"]``).
    z : cvxpy.Variable (#pairs,)
        The lifting: one surplus per allowed pair, in the order of :attr:`pairs`.
    constraints : dict
        Eq. 18 with ``V = Phi v`` substituted (eq. 18's second line) and the surplus made
        explicit, each one sparse vector constraint: ``"surplus_lower"``, ``A_pair v - z
        >= R`` and ``"surplus_upper"``, ``z - A_pair v >= -R`` (together ``z_u(x) = V(x) -
        R_u(x) - lambda sum_l p_l V(f(x, u, Y_l))``, eq. 18's Bellman inequality as an
        equation), and ``"z_nonneg"``, ``z >= 0`` (the inequality itself).

    Notes
    -----
    Result: ``values`` is ``v``, ``extra["z"]`` the surplus per pair (shape (n, A), 0 on
    disallowed pairs). ``mu`` is the dual of the equality rows ``y+ - y-`` per pair (its
    sign is free).
    """

    name = "LLP"
    #: LLP's ``v`` need not be ``v*`` (it dominates it): only its feasibility, the certified
    #: upper bound's distance from ``v``, is judged
    upper_side_only = True
    feasible_by_construction = True
    feasibility_reason = (
        "the constant v = max(R)^+ / (1 - kappa) satisfies RLP's rows (they contract: "
        "kappa = lambda max_r sum_l p_rl < 1), and z = A_pair v - R >= 0 is then its surplus"
    )
    bounded_by_construction = True
    boundedness_reason = (
        "the projection of its feasible set onto v is RLP's, so v >= v*, and z >= 0; with "
        "c >= 0 and d >= 0 the objective is at least c-bar'v*"
    )

    def __init__(self, mdp: FiniteMDP, partition: Partition, d: Any, cost: Any = None) -> None:
        check_formulation_inputs(mdp, partition, cost=cost, d=d)
        self.mdp = mdp
        self.partition = partition
        self.partition_note = sink_block_note(mdp, partition)
        n, n_actions = mdp.n_states, mdp.n_actions
        d_arr = np.asarray(d, dtype=np.float64)
        if d_arr.shape != (n, n_actions):
            raise ValidationError(f"d must have shape {(n, n_actions)}; got {d_arr.shape}")
        if not np.all(np.isfinite(d_arr)):
            raise ValidationError("d must be finite")
        if (d_arr < 0).any():
            x, u = (int(t) for t in np.argwhere(d_arr < 0)[0])
            raise ValidationError(f"d[{x}, {u}] = {d_arr[x, u]} is negative; d must be >= 0")
        self.d = np.where(mdp.allowed, d_arr, 0.0)
        c = check_cost(cost, n)
        m = partition.n_partitions
        cbar = np.bincount(partition.labels, weights=c, minlength=m)
        rows = BellmanRows.aggregate(mdp, partition, reduce="max")
        a_rows, _ = rows.constraint_matrix()
        self.pairs = np.argwhere(mdp.allowed)  # (x, u) of each z entry, row-major
        xs, us = self.pairs[:, 0], self.pairs[:, 1]
        assert rows.pair_row is not None  # rows built from an MDP carry the pair map
        a_pair = a_rows[rows.pair_row[xs, us]]  # row of pair (x,u) with ITS reward below
        b_pair = mdp.rewards[xs, us]
        k = xs.size
        eye = sp.identity(k, format="csr")
        a = sp.vstack(
            [
                sp.hstack([a_pair, -eye]),
                sp.hstack([-a_pair, eye]),
                sp.hstack([sp.csr_matrix((k, m)), eye]),
            ],
            format="csr",
        )
        b = np.concatenate([b_pair, -b_pair, np.zeros(k)])
        self.rows = rows
        self._m = m
        super().__init__(
            a,
            b,
            np.concatenate([cbar, self.d[xs, us]]),
            variables=[("v", m), ("z", k)],
            groups=[("surplus_lower", k), ("surplus_upper", k), ("z_nonneg", k)],
        )

    @property
    def v(self) -> cp.Variable:
        """The cvxpy variable ``v`` (one entry per partition)."""
        return self.variables["v"]

    @property
    def z(self) -> cp.Variable:
        """The cvxpy variable ``z`` (one surplus per allowed pair, rows of :attr:`pairs`)."""
        return self.variables["z"]

    def _interpret(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict[str, Any]]:
        m, k = self._m, self.pairs.shape[0]
        v = x[:m]
        z = np.zeros(self.d.shape)
        z[self.pairs[:, 0], self.pairs[:, 1]] = x[m:]
        mu = np.zeros(self.d.shape)
        mu[self.pairs[:, 0], self.pairs[:, 1]] = y[:k] - y[k : 2 * k]
        return v, self.partition.lift(v), mu, {"z": z}

    def _certify(self, x: np.ndarray) -> Certificate:
        """The bracket on RLP's ``v*`` from LLP's ``v`` (LLP's optimal ``v`` dominates ``v*``)."""
        return certify(self.rows, x[: self._m])

    def _discount(self) -> float:
        return float(self.rows.discount)

    def _value_bound(self) -> float:
        """``3 max|R| / (1 - lambda)``: ``v``'s scale, and ``z = v - R - lambda P v``'s."""
        return 3.0 * float(np.abs(self.b).max(initial=0.0)) / (1.0 - self._discount())

    def _bracket(
        self, cert: Certificate
    ) -> tuple[np.ndarray, np.ndarray, tuple[float, float] | None]:
        return cert.lower, cert.upper, None

    def fixed_point(self, tol: float | None = None) -> np.ndarray:
        """``v*``: the least element of the projection of LLP's feasible set onto ``v``.

        That projection is RLP's feasible set, so this is RLP's fixed point; it is
        LLP's optimal ``v`` when ``d = 0`` and a lower bound on it for every ``d >= 0``.
        """
        from ..dp import solve_exact

        return solve_exact(self.rows, tol=tol).values

    # ------------------------------------------------------------------ exact arithmetic
    def exact_size(self) -> tuple[int, str]:
        """The partitions (the reduced LP's variables, :func:`lpbounds.exact.lp.llp_lp`)."""
        return self._m, "LLP's partitions"

    def exact_lp(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """``(model, lp)``: eq. 18 with surplus lifting, built by the checker from the MDP,
        the partition, ``c-bar`` and ``d`` over the allowed pairs (each double exact)."""
        from ..exact.files import mdp_data

        xs, us = self.pairs[:, 0], self.pairs[:, 1]
        lp = {
            "formulation": "LLP",
            "cost": [float(t).hex() for t in self.c[: self._m]],
            "d": [float(t).hex() for t in self.d[xs, us]],
        }
        return mdp_data(self.mdp, self.partition), lp

    def _exact_route(self, approx: Any, size_limit: int | None, callback: Any) -> ExactLP:
        """Eliminate ``z``: RLP's fixed point when ``c-bar + A'd >= 0``, else the exact
        simplex from it (:func:`lpbounds.exact.lp.llp_lp`)."""
        from ..exact.lp import llp_lp

        model, spec = self.exact_lp()
        v0 = None if approx is None else np.asarray(approx)[: self._m]
        return llp_lp(model, spec["cost"], spec["d"], approx=v0, callback=callback,
                      size_limit=size_limit)  # fmt: skip

    def _exact_bracket_target(self, exact: ExactLP, size_limit: int | None) -> Any:
        """LLP's bracket is on RLP's ``v*`` (:meth:`_certify`)."""
        assert exact.fixed_point is not None
        return exact.fixed_point.values
