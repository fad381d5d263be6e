r"""A row system in exact arithmetic, and the exact solve of one policy's rows.

:class:`ExactRows` holds the rows ``sum_j a_rj x_j >= b_r`` of an LP (or of a fixed point)
exactly as the certificate checker :mod:`lpbounds.exact.check` builds them from the model
data: the checker's builders are the one definition of every exact LP, so what lpbounds
computes and what the checker verifies are the same rows. For the engine each row is also
kept in integer form, ``d_r a_r`` and ``d_r b_r`` with ``d_r > 0`` the least common
denominator of the row (a power of two for rows of doubles), so that with a vector
``x = N / D`` the row's slack ``a_r'x - b_r`` has the sign of the integer
``S_r = sum_j (d_r a_rj) N_j - (d_r b_r) D``.

**One policy's rows** (one row per variable: a Bellman policy, an LP basis of such rows)
form a square system ``A_pi x = b_pi``. :meth:`ExactRows.solve_policy` solves it (or its
transpose, for the occupation measure ``A_pi' y = c``) exactly, component by component:
the strongly connected components of the policy's graph (``i -> j`` when row ``pi(i)``
reads ``x_j``) are solved in topological order, sinks first, each by one dense
python-flint solve of its block (a single variable by one division), with the values of
the components it reads already known. The solution is unique and the same as one dense
solve's; what changes is the cost: the dense solve of ``n`` variables takes about ``n^3``
operations on numbers of about ``n`` times a row's bits (measured: 0.1 s at 100 states of a
random garnet, 4 s at 400, 20-40 s at 800), while a model whose policy graph is a chain of
small components pays for its largest component only (the patrol's 320 states: 231
components, the largest 90; taxi's 501: every component one state).

Interrupting: python-flint holds the interpreter during a block solve, so Ctrl-C takes
effect when the block in progress returns (Python raises ``KeyboardInterrupt`` between
blocks and iterations; nothing is left half-built).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from ..errors import ConsistencyError, SizeLimitError
from ..tolerances import EXACT_MAX_VARIABLES
from . import check
from .rationals import RationalVector, flint_module

__all__ = ["ExactProgress", "ExactRows", "ProgressCallback", "check_size"]


@dataclass(frozen=True)
class ExactProgress:
    """One step of an exact computation, for a progress bar.

    Attributes
    ----------
    stage : str
        ``"evaluate"`` (a policy's solve: ``done`` of ``total`` variables solved),
        ``"improve"`` (an improvement check; ``residual`` is the largest exact improvement,
        as a float), ``"switch"`` (the game's outer step), ``"dual"`` (the occupation
        measure's solve), ``"verify"`` (the certificate checked).
    iteration : int
        Improvement steps so far.
    done, total : int
        Work done and to do in this stage (variables solved).
    seconds : float
        Since the computation started.
    residual : float or None
        ``max (T v - v)`` of the current exact iterate (``"improve"`` only).
    """

    stage: str
    iteration: int
    done: int
    total: int
    seconds: float
    residual: float | None = None


ProgressCallback = Callable[[ExactProgress], None]


def check_size(n_block: int, size_limit: int | None, what: str, n_vars: int | None = None) -> None:
    """Refuse, before it starts, a dense exact solve of more than ``size_limit`` variables.

    Parameters
    ----------
    n_block : int
        Variables of the largest dense system the solve needs (a policy's largest strongly
        connected component, :meth:`ExactRows.solve_policy`; an LP basis).
    size_limit : int or None
        The limit (default :data:`lpbounds.tolerances.EXACT_MAX_VARIABLES`).
    what : str
        The system, for the message ("the MDP's states", "RLP's partitions").
    n_vars : int, optional
        All the system's variables, when the block is part of them (for the message).

    Raises
    ------
    SizeLimitError
        One line naming the size, the limit and the option that lifts it.
    """
    limit = EXACT_MAX_VARIABLES if size_limit is None else int(size_limit)
    if n_block > limit:
        part = "" if n_vars is None else f" (the largest strongly connected block of {n_vars})"
        raise SizeLimitError(
            f"exact arithmetic on {what}: {n_block} variables solved together{part}, above "
            f"the limit of {limit} (a dense rational solve grows as n^3 on numbers of about "
            f"n * 100 bits); pass size_limit={n_block} to lift it",
            size=n_block,
            limit=limit,
        )


@dataclass(eq=False)
class ExactRows:
    """A row system ``sum_j a_rj x_j >= b_r`` over ``n_vars`` variables, exactly.

    Build it with :meth:`build` from a certificate's model data and a row or LP spec (the
    checker's :func:`~lpbounds.exact.check.rows_of` / :func:`~lpbounds.exact.check.lp_of`
    make the rows).

    Attributes
    ----------
    rows : list
        The checker's rows ``(coefs, rhs, owner, group)``: ``coefs`` maps a column to its
        Fraction, ``owner`` is the variable a Bellman row bounds (-1 for other rows) and
        ``group`` its ``(owner, action)``.
    n_vars : int
    model : dict
        The certificate's model data the rows were built from.
    spec : dict
        How the checker builds them (``{"rows": "RLP"}``, ``{"formulation": "ALP", ...}``).
    cost : list of Fraction
        The LP's cost when built from an LP spec (empty for a fixed point's rows).
    """

    rows: list[Any]
    n_vars: int
    model: dict[str, Any]
    spec: dict[str, Any]
    cost: list[Fraction] = field(default_factory=list)
    _form: list[tuple[tuple[int, ...], tuple[int, ...], int, int]] = field(
        default_factory=list, repr=False
    )

    @classmethod
    def build(cls, model: dict[str, Any], spec: dict[str, Any]) -> ExactRows:
        """The rows of ``spec`` on ``model`` (a fixed point's ``{"rows": ...}`` or an LP's
        ``{"formulation": ...}``), as the checker builds them."""
        parsed = check.load_model(model)
        if "rows" in spec:
            rows = check.rows_of(spec, parsed)
            owners = [r[2] for r in rows]
            n = max(owners) + 1 if owners else 0
            return cls(rows, n, model, spec)
        rows, cost = check.lp_of(spec, parsed)
        return cls(rows, len(cost), model, spec, cost)

    # ------------------------------------------------------------------ integer form
    def form(self) -> list[tuple[tuple[int, ...], tuple[int, ...], int, int]]:
        """Per row ``(columns, d_r a_r, d_r b_r, d_r)``: integers (computed once)."""
        if not self._form:
            out = []
            for coefs, rhs, *_ in self.rows:
                d = math.lcm(rhs.denominator, *(a.denominator for a in coefs.values()))
                cols = tuple(coefs)
                out.append((cols, tuple(int(coefs[j] * d) for j in cols), int(rhs * d), d))
            self._form = out
        return self._form

    @property
    def n_rows(self) -> int:
        """Number of rows."""
        return len(self.rows)

    def owners(self) -> np.ndarray:
        """The owner of every row (``-1``: not a Bellman row)."""
        return np.array([r[2] for r in self.rows], dtype=np.int64)

    def subset(self, index: Sequence[int]) -> ExactRows:
        """The rows ``index`` (same variables), sharing their integer form."""
        form = self.form()
        return ExactRows(
            [self.rows[i] for i in index],
            self.n_vars,
            self.model,
            self.spec,
            self.cost,
            [form[i] for i in index],
        )

    def slacks(self, x: RationalVector) -> list[int]:
        """``S_r = d_r D (a_r'x - b_r)`` for ``x = N / D``: the slack of every row, scaled by
        the positive ``d_r D`` (its sign is the slack's)."""
        num, den = x.numerators, x.denominator
        return [
            sum(a * num[j] for j, a in zip(cols, ints, strict=True)) - rhs * den
            for cols, ints, rhs, _ in self.form()
        ]

    def float_slacks(self, x: np.ndarray) -> np.ndarray:
        """``a_r'x - b_r`` in floating point, for choosing a starting policy."""
        out = np.empty(self.n_rows)
        for r, (coefs, rhs, *_) in enumerate(self.rows):
            out[r] = sum(float(a) * float(x[j]) for j, a in coefs.items()) - float(rhs)
        return out

    # ------------------------------------------------------------------ policy solves
    def solve_policy(
        self,
        sel: Sequence[int],
        *,
        transpose: bool = False,
        rhs: Sequence[Fraction] | None = None,
        progress: Callable[[int, int], None] | None = None,
        size_limit: int | None = None,
        what: str = "a row system",
    ) -> RationalVector:
        """The exact solution of the square system of the rows ``sel`` (one per variable).

        Parameters
        ----------
        sel : sequence of int
            ``sel[i]``: the row of variable ``i`` (``n_vars`` rows, a nonsingular system).
        transpose : bool
            Solve ``A_sel' z = rhs`` instead of ``A_sel x = b_sel``.
        rhs : sequence of Fraction, optional
            The right-hand side of the transposed system (required with ``transpose``).
        progress : callable(done, total), optional
            Called after each component with the variables solved so far.
        size_limit : int, optional
            The largest component accepted (:func:`check_size`, before any block is solved).
        what : str
            The system's name in the size error.

        Returns
        -------
        RationalVector
            ``x`` with ``A_sel x = b_sel``, or ``z`` with ``A_sel' z = rhs``.
        """
        flint = flint_module()
        n = self.n_vars
        if len(sel) != n:
            raise ConsistencyError(f"a policy of {len(sel)} rows for {n} variables")
        form = self.form()
        rows = [form[int(r)] for r in sel]
        if transpose:
            if rhs is None or len(rhs) != n:
                raise ConsistencyError("the transposed solve needs a right-hand side per variable")
            # column j of A_sel: (i, d_i a_ij); A' z = c  <=>  M' (z / d) = c with M = D A
            cols: list[list[tuple[int, int]]] = [[] for _ in range(n)]
            for i, (cc, ints, _, _) in enumerate(rows):
                for j, a in zip(cc, ints, strict=True):
                    cols[j].append((i, a))
            links = [[i for i, _ in cols[j]] for j in range(n)]
        else:
            links = [list(cc) for cc, *_ in rows]
        # a component after every component it reads (for the transpose, ``links`` are the
        # reversed edges: the rows that read a column come first)
        comps = _components(links)
        check_size(max((len(c) for c in comps), default=0), size_limit, what, n)
        val: list[Any] = [None] * n
        done = 0
        for comp in comps:
            if transpose:
                assert rhs is not None
                _solve_block_t(flint, comp, cols, rhs, val)
            else:
                _solve_block(flint, comp, rows, val)
            done += len(comp)
            if progress is not None:
                progress(done, n)
        if transpose:  # z = M'^{-1} c solved for M = D A: y = D z
            val = [val[i] * rows[i][3] for i in range(n)]
        return RationalVector.from_fmpq(val)


def _components(links: list[list[int]]) -> list[list[int]]:
    """Strongly connected components of the graph ``i -> links[i]``, sinks first
    (Tarjan's algorithm, iterative: a component is emitted after every component it
    reaches)."""
    n = len(links)
    index = [-1] * n
    low = [0] * n
    on_stack = [False] * n
    stack: list[int] = []
    out: list[list[int]] = []
    counter = 0
    for root in range(n):
        if index[root] >= 0:
            continue
        work = [(root, 0)]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack[root] = True
        while work:
            v, k = work[-1]
            if k < len(links[v]):
                work[-1] = (v, k + 1)
                w = links[v][k]
                if index[w] < 0:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack[w] = True
                    work.append((w, 0))
                elif on_stack[w]:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                u = work[-1][0]
                low[u] = min(low[u], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack[w] = False
                    comp.append(w)
                    if w == v:
                        break
                out.append(sorted(comp))
    return out


def _solve_block(flint: Any, comp: list[int], rows: list[Any], val: list[Any]) -> None:
    """``A_CC x_C = b_C - A_C,out x_out`` for one component (its outside values known)."""
    inside = {j: k for k, j in enumerate(comp)}
    rhs = []
    for i in comp:
        cols, ints, b, _ = rows[i]
        acc = flint.fmpq(b)
        for j, a in zip(cols, ints, strict=True):
            if j not in inside:
                acc -= a * val[j]
        rhs.append(acc)
    if len(comp) == 1:
        i = comp[0]
        cols, ints, _, _ = rows[i]
        val[i] = rhs[0] / ints[cols.index(i)]
        return
    k = len(comp)
    mat = flint.fmpz_mat(k, k)
    for r, i in enumerate(comp):
        cols, ints, _, _ = rows[i]
        for j, a in zip(cols, ints, strict=True):
            if j in inside:
                mat[r, inside[j]] = a
    x = flint.fmpq_mat(mat).solve(flint.fmpq_mat(k, 1, rhs))
    for r, i in enumerate(comp):
        val[i] = x[r, 0]


def _solve_block_t(
    flint: Any,
    comp: list[int],
    cols: list[list[tuple[int, int]]],
    rhs: Sequence[Fraction],
    val: list[Any],
) -> None:
    """``M_CC' z_C = c_C - M_out,C' z_out`` for one component of the transposed system."""
    inside = {j: k for k, j in enumerate(comp)}
    b = []
    for j in comp:
        acc = flint.fmpq(rhs[j].numerator, rhs[j].denominator)
        for i, a in cols[j]:
            if i not in inside:
                acc -= a * val[i]
        b.append(acc)
    if len(comp) == 1:
        j = comp[0]
        diag = next(a for i, a in cols[j] if i == j)
        val[j] = b[0] / diag
        return
    k = len(comp)
    mat = flint.fmpz_mat(k, k)
    for c, j in enumerate(comp):
        for i, a in cols[j]:
            if i in inside:
                mat[c, inside[i]] = a
    z = flint.fmpq_mat(mat).solve(flint.fmpq_mat(k, 1, b))
    for c, j in enumerate(comp):
        val[j] = z[c, 0]
