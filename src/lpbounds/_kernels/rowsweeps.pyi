"""Types of the C row sweeps (``rowsweeps.c``; :mod:`lpbounds._kernels.native` calls them)."""

from typing import Any

def bellman_max_stats(
    indptr: Any,
    reward: Any,
    targets: Any,
    probs: Any,
    discount: float,
    v: Any,
    out: Any,
    arg: Any,
    start: int,
    end: int,
    /,
) -> tuple[float, float]: ...
def policy_sweep_stats(
    rows: Any,
    reward: Any,
    targets: Any,
    probs: Any,
    discount: float,
    v: Any,
    out: Any,
    start: int,
    end: int,
    /,
) -> tuple[float, float]: ...
def gather_rows(
    sel: Any,
    reward: Any,
    targets: Any,
    probs: Any,
    out_reward: Any,
    out_targets: Any,
    out_probs: Any,
    copy_probs: bool,
    start: int,
    end: int,
    /,
) -> None: ...
def check_successors(
    succ: Any, allow: Any, n: int, start: int, end: int, /
) -> tuple[int, int, int]: ...
