"""The C row kernels against the numba kernels they replaced, and a cold first RLP.

Measures, in one run (writes the ``kernels`` section of docs/benchmarks.md):

1. each replaced kernel group, C (:mod:`lpbounds._kernels.ckernels`) against numba (the
   ``compiled.py`` / ``aggregate.py`` of an older source tree, ``--old-src``, warm: one
   call before the timed ones, numba's cache filled), on the same inputs, alternating, at
   the sizes where the numba kernels ran: the aggregation of a 100,000 x 3 x 5 garnet into
   10,000 random partitions and of the paper's patrol instance (2,048,000 states) into its
   M = 8,900 partitions, the post-decision form of that instance (its detection passes,
   reward codes and sweeps), and the Q-values and game operator of the garnet's NLP rows;
2. the C kernels against their numpy twins on small models (what the twins ran before:
   every model below 200,000 values read per sweep), to decide whether the twins still
   have a use outside the tests;
3. a cold first RLP (build, HiGHS solve through highspy, certificate) of a 20,000 x 3 x 5
   garnet with 200 random partitions in fresh processes, each with its own empty numba
   cache: the older tree (numba compiling the aggregation kernels) against this one.

``--old-src`` is the ``src`` directory of a tree at the last commit with numba's row kernels
(for instance ``git archive 1571e7d | tar -x -C /tmp/old`` with its ``rowsweeps`` extension
built); without it only part 2 runs. Parts 1 and 3 run the older tree's numba kernels, so they
need numba in this environment (``pip install numba``), which lpbounds no longer installs:
this script imports it only through the older tree's modules.

    python benchmarks/bench_kernels.py --old-src /tmp/old/src [--repeat 5] [--no-write]
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from _common import machine, today, write_section

from lpbounds import BellmanRows, garnet, load_instance, random_partition
from lpbounds._kernels import ckernels as C
from lpbounds._kernels import threads
from lpbounds._kernels import twins as T
from lpbounds.model.mdp import index_dtype

#: the cold RLP, in a fresh process (the same script on both trees)
COLD_RLP = """
import lpbounds as lb
from lpbounds.formulations import RLP
mdp = lb.garnet(20_000, 3, 5, 0.9, seed=1)  # 300,000 values read per sweep
res = RLP(mdp, lb.random_partition(20_000, 200, seed=2)).solve("HIGHS", backend="highspy")
assert res.values is not None
"""


def load_numba(old_src: Path) -> tuple[ModuleType, ModuleType]:
    """numba's ``compiled`` and ``aggregate`` kernel modules of the older tree, loaded from
    their files under their old names (they import only numpy and numba; numba caches next
    to them, and its cache names the module)."""
    mods = []
    for name in ("compiled", "aggregate"):
        path = old_src / "lpbounds" / "_kernels" / f"{name}.py"
        full = f"lpbounds._kernels.{name}"
        spec = importlib.util.spec_from_file_location(full, path)
        assert spec is not None and spec.loader is not None, path
        mod = importlib.util.module_from_spec(spec)
        sys.modules[full] = mod
        spec.loader.exec_module(mod)
        mods.append(mod)
    return mods[0], mods[1]


def best(f: Callable[[], Any], reps: int) -> float:
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return min(ts)


#: seconds of calls each side of a comparison gets at least (fast kernels: many calls, so
#: that the best of them is not a call the loaded machine descheduled)
BUDGET = 1.0


def side_by_side(c: Callable[[], Any], other: Callable[[], Any], reps: int) -> tuple[float, float]:
    """Best seconds of ``c`` and ``other``, warmed once each, then timed alternately: at
    least ``reps`` calls each, more (up to 400) when a call is short (:data:`BUDGET`)."""
    once = max(best(c, 1), best(other, 1), 1e-6)
    reps = max(reps, min(400, int(BUDGET / once)))
    tc, to = [], []
    for _ in range(reps):
        tc.append(best(c, 1))
        to.append(best(other, 1))
    return min(tc), min(to)


# ---------------------------------------------------------------------- kernel groups
def aggregation_calls(numba: ModuleType, mdp: Any, part: Any) -> tuple[dict, dict]:
    """The five aggregation steps of BellmanRows.aggregate, on C and on ``numba`` (whose
    kernels take ``nchunks``): closures over one set of buffers, each step's inputs
    precomputed."""
    exact = BellmanRows.from_mdp(mdp)
    m, (n_rows, n_out) = part.n_partitions, exact.targets.shape
    idt = index_dtype(m)
    labels = part.labels.astype(idt)
    owner, oa = np.empty(n_rows, idt), np.empty(n_rows, np.int64)
    targets, probs = np.empty((n_rows, n_out), idt), np.empty((n_rows, n_out))
    key, new = np.empty(n_rows, np.uint64), np.empty(n_rows, bool)
    canon = (labels, exact.owner, exact.action, exact.targets, exact.probs, mdp.n_actions)
    C.canonical_rows(*canon, owner, targets, probs, oa, key)
    order, offsets = C.bucket_order(oa, m * mdp.n_actions)
    sorted_order = order.copy()
    C.sort_buckets(sorted_order, offsets, key)
    C.mark_groups(sorted_order, oa, key, targets, probs.view(np.int64), new)
    starts = np.append(np.flatnonzero(new), n_rows)
    g = starts.size - 1
    outs = (
        np.empty(n_rows, np.int64), np.empty(g), np.empty(g, idt), np.empty(g, np.int32),
        np.empty((g, n_out), idt), np.empty((g, n_out)),
    )  # fmt: skip
    scratch = (np.empty_like(owner), np.empty_like(targets), np.empty_like(probs),
               np.empty_like(oa), np.empty_like(key))  # fmt: skip
    work, new2 = order.copy(), np.empty_like(new)
    nch = (8 * threads.get_threads(),)

    def calls(kern: ModuleType, extra: tuple) -> dict[str, Callable]:
        def sort() -> None:
            work[:] = order
            kern.sort_buckets(work, offsets, key)

        return {
            "canonical_rows": lambda: kern.canonical_rows(*canon, *scratch, *extra),
            "bucket_order": lambda: kern.bucket_order(oa, m * mdp.n_actions),
            "sort_buckets (and a copy of order)": sort,
            "mark_groups": lambda: kern.mark_groups(
                sorted_order, oa, key, targets, probs.view(np.int64), new2, *extra
            ),
            "merge_groups": lambda: kern.merge_groups(
                sorted_order,
                starts,
                exact.reward,
                True,
                owner,
                exact.action,
                targets,
                probs,
                *outs,
            ),
        }

    return calls(C, ()), calls(numba, nch)


def post_decision_calls(numba: ModuleType, mdp: Any) -> tuple[dict, dict]:
    """The passes and sweeps of the post-decision form of ``mdp``, on C and on ``numba``."""
    from lpbounds.rows import PostDecisionRows

    ps = PostDecisionRows.detect(mdp)
    assert ps is not None and ps.reward_codes is not None
    succ, allowed = mdp.successors, mdp.allowed
    n = succ.shape[0]
    post_id = np.full(n, -1, dtype=ps.first.dtype)
    post_id[ps.outcomes[:, 0]] = np.arange(ps.n_post, dtype=ps.first.dtype)
    rew = np.ascontiguousarray(mdp.rewards, dtype=np.float64)
    codes, table = np.empty(rew.shape, np.uint16), np.empty(PostDecisionRows.MAX_REWARD_CODES)
    v = np.random.default_rng(1).normal(size=n)
    w, out, arg = ps.new_work(), ps.new_vector(), ps.new_arg()
    ps.sweep_max(v, out, arg)
    row_start = np.zeros(n, dtype=np.int64)
    np.cumsum(allowed.sum(axis=1)[:-1], out=row_start[1:])
    seen, oc, first = np.zeros(n, dtype=bool), np.empty_like(ps.outcomes), np.empty_like(ps.first)
    out2, arg2, rows_out = np.empty(n), np.empty_like(arg), np.empty(n, np.int64)

    def calls(kern: ModuleType, numba_: bool) -> dict[str, Callable]:
        extra = (8 * threads.get_threads(),) if numba_ else ()
        chunks = (max(64, 8 * threads.get_threads()),) if numba_ else ()
        code_args = (rew, rew.view(np.int64)) if numba_ else (rew,)
        lam, tab = ps.discount, ps.reward_table
        return {
            "ps_mark": lambda: kern.ps_mark(succ, allowed, seen),
            "ps_fill": lambda: kern.ps_fill(succ, allowed, post_id, oc, first),
            "ps_verify": lambda: kern.ps_verify(succ, ps.first, ps.outcomes, *chunks),
            "reward_codes": lambda: kern.reward_codes(
                *code_args, PostDecisionRows.MAX_REWARD_CODES, codes, table
            ),
            "ps_expect": lambda: kern.ps_expect(ps.outcomes, ps.probs, v, w),
            "ps_max_stats_coded": lambda: kern.ps_max_stats_coded(
                ps.first, ps.reward_codes, tab, w, lam, v, out2, arg2, *extra
            ),
            "ps_policy_stats_coded": lambda: kern.ps_policy_stats_coded(
                ps.first, ps.reward_codes, tab, arg, w, lam, v, out2, *extra
            ),
            "ps_max_stats (float rewards)": lambda: kern.ps_max_stats(
                ps.first, rew, w, lam, v, out2, arg2, *extra
            ),
            "ps_rows": lambda: kern.ps_rows(allowed, row_start, arg, rows_out),
        }

    return calls(C, False), calls(numba, True)


def row_calls(kern: ModuleType, rows: BellmanRows) -> dict[str, Callable]:
    """Q-values, the game operator and row hashes of ``rows`` (the NLP's terms)."""
    v = np.random.default_rng(2).normal(size=rows.n_vars)
    q = np.empty(rows.n_rows)
    out, arg = np.empty(rows.n_vars), np.empty(rows.n_vars, np.int64)
    pbits = np.ascontiguousarray(rows.probs).view(np.int64)
    h = np.empty(rows.n_rows, np.uint64)
    return {
        "q_values": lambda: kern.q_values(
            rows.reward, rows.targets, rows.probs, rows.discount, v, q
        ),
        "bellman_maxmin": lambda: kern.bellman_maxmin(
            rows.indptr,
            rows.action,
            rows.reward,
            rows.targets,
            rows.probs,
            rows.discount,
            v,
            out,
            arg,
        ),
        "hash_rows": lambda: kern.hash_rows(rows.owner, rows.action, rows.targets, pbits, h),
    }


def compare(group: str, c_calls: dict, o_calls: dict, reps: int, rows: list) -> None:
    """Each kernel of a group side by side on the threads set now; a row each into ``rows``."""
    k = threads.get_threads()
    for name in c_calls:
        tc, to = side_by_side(c_calls[name], o_calls[name], reps)
        rows.append((group, name, k, tc, to))
        print(
            f"{group:38s} {name:36s} {k} thr C {tc * 1e3:9.2f} ms  other {to * 1e3:9.2f} ms  "
            f"{to / tc:6.2f}x",
            flush=True,
        )


def compare_threads(group: str, calls: tuple[dict, dict], reps: int, rows: list) -> None:
    """:func:`compare` on all threads and on one, numba's and the C pool's alike (numba as
    the older tree's kernels loaded it: this tree does not use it)."""
    set_numba_threads = sys.modules["numba"].set_num_threads
    many = threads.get_threads()
    try:
        for k in sorted({many, 1}, reverse=True):
            threads.set_threads(k)
            set_numba_threads(k)
            compare(group, *calls, reps, rows)
    finally:
        threads.set_threads(many)
        set_numba_threads(many)


# ---------------------------------------------------------------------- cold processes
def cold_wall(code: str, src: Path | None) -> float:
    """Wall seconds of ``code`` in a fresh process with an empty numba cache (``src``: an
    older tree put first on the path)."""
    cache = tempfile.mkdtemp(prefix="numba-cold-")
    try:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        if src is not None:
            env["PYTHONPATH"] = str(src)
        t = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        dt = time.perf_counter() - t
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr[-2000:])
        return dt
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def load_average() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old-src", type=Path, help="src of a tree with numba's row kernels")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cold-repeat", type=int, default=3)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    load_before = load_average()
    rows: list[tuple[str, str, int, float, float]] = []
    tiny: list[tuple[str, str, int, float, float]] = []
    cold: list[tuple[str, float, float]] = []
    # 2. C against the numpy twins at the sizes the twins ran
    for n in (3, 300, 3_000):
        mdp = garnet(n, 3, 4, 0.9, seed=1)
        part = random_partition(n, max(1, n // 10), seed=2)
        low = BellmanRows.aggregate(mdp, part, reduce="min")
        label = f"garnet {n:,} x 3 x 4, M = {part.n_partitions:,}"
        compare(label, row_calls(C, low), row_calls(T, low), args.repeat, tiny)
        tc, tt = side_by_side(
            lambda m=mdp, p=part: BellmanRows.aggregate(m, p),
            lambda m=mdp, p=part: _on_twins(lambda: BellmanRows.aggregate(m, p)),
            args.repeat,
        )
        tiny.append((label, "BellmanRows.aggregate", threads.get_threads(), tc, tt))
        print(f"{label:38s} {'aggregate':36s} C {tc * 1e3:9.2f} ms  twins {tt * 1e3:9.2f} ms")
    if args.old_src is not None:
        numba_rows, numba_agg = load_numba(args.old_src)
        # 1. C against numba, warm
        mdp = garnet(100_000, 3, 5, 0.9, seed=1)
        part = random_partition(100_000, 10_000, seed=2)
        group = "aggregation, garnet 100,000 x 3 x 5, M = 10,000"
        compare_threads(group, aggregation_calls(numba_agg, mdp, part), args.repeat, rows)
        low = BellmanRows.aggregate(mdp, part, reduce="min")
        group = f"NLP rows of that garnet ({low.n_rows:,} x 5)"
        calls = (row_calls(C, low), row_calls(numba_rows, low))
        compare_threads(group, calls, args.repeat, rows)
        del mdp, part, low, calls
        inst = load_instance("patrol-paper")
        mdp = inst.mdp()
        group = "post-decision form, patrol-paper (2,048,000)"
        compare_threads(group, post_decision_calls(numba_rows, mdp), args.repeat, rows)
        group = "aggregation, patrol-paper, M = 8,900"
        calls = aggregation_calls(numba_agg, mdp, inst.partition())
        compare_threads(group, calls, args.repeat, rows)
        del mdp, calls
        # 3. a cold first RLP, alternating the trees
        before, after = [], []
        for _ in range(args.cold_repeat):
            before.append(cold_wall(COLD_RLP, args.old_src))
            after.append(cold_wall(COLD_RLP, None))
        cold.append(
            ("before (numba compiles the aggregation)", min(before), statistics.median(before))
        )
        cold.append(("after (C)", min(after), statistics.median(after)))
        for name, lo, med in cold:
            print(f"cold RLP {name:42s} min {lo:6.2f} s  median {med:6.2f} s", flush=True)
    load_after = load_average()
    print(f"load average: {load_before} -> {load_after}")
    if not args.no_write:
        write_section("kernels", _section(rows, tiny, cold, args, load_before, load_after))


def _on_twins(func: Callable[[], Any]) -> Any:
    """``func()`` with the library's kernels replaced by their numpy twins."""
    from lpbounds._kernels import dispatch

    saved = dispatch.kernels, dispatch.row_sweeps
    dispatch.kernels = dispatch.row_sweeps = lambda: T  # type: ignore[assignment]
    try:
        return func()
    finally:
        dispatch.kernels, dispatch.row_sweeps = saved  # type: ignore[assignment]


def _section(rows, tiny, cold, args, load_before, load_after) -> str:
    def table(items, other: str) -> str:
        head = (
            f"| operation | kernel | threads | C (ms) | {other} (ms) | {other} / C |\n"
            "|---|---|---|---|---|---|\n"
        )
        return head + "\n".join(
            f"| {g} | `{k}` | {n} | {tc * 1e3:.2f} | {to * 1e3:.2f} | **{to / tc:.2f}** |"
            for g, k, n, tc, to in items
        )

    parts = [
        "## Kernels: C against the numba kernels it replaced (benchmarks/bench_kernels.py)",
        "",
        f"Machine: {machine()}. Date: {today()}. Load average (1, 5, 15 min) before and "
        f"after: {load_before} -> {load_after}. Each figure is the best of at least "
        f"{args.repeat} calls (as many as fill {BUDGET:.0f} s, up to 400) after one warm-up "
        "call each (numba's on-disk cache filled), C and numba alternating on the same "
        "inputs, on all threads and on one (numba's count and the C pool's set alike); "
        "numba's kernels are those of the tree before the move (`--old-src`). On a loaded "
        "machine the one-thread rows are the steadier comparison.",
        "",
    ]
    if rows:
        parts += [table(rows, "numba"), ""]
    parts += [
        "The C kernels against their numpy twins on the small models the twins ran before "
        "(below 200,000 values read per sweep; timed the same way): the twins lose at every "
        "size, so every model runs on C and the twins are the tests' reference only.",
        "",
        table(tiny, "twins"),
        "",
    ]
    if cold:
        parts += [
            "A cold first RLP (`garnet(20_000, 3, 5)`, 300,000 values read per sweep, 200 "
            "random partitions; built, solved with HiGHS through highspy and certified) as a "
            f"whole fresh process with an empty numba cache, {args.cold_repeat} runs of each "
            "tree alternating:",
            "",
            "| tree | min (s) | median (s) |",
            "|---|---|---|",
            *(f"| {name} | {lo:.2f} | {med:.2f} |" for name, lo, med in cold),
            "",
        ]
    return "\n".join(parts)


if __name__ == "__main__":
    main()
