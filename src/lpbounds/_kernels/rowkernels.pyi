"""Types of the C row kernels (``rowkernels.c``; :mod:`lpbounds._kernels.ckernels` calls them)."""

from typing import Any

def q_values(
    reward: Any, targets: Any, probs: Any, discount: float, v: Any, out: Any, start: int,
    end: int, /,
) -> None: ...  # fmt: skip
def bellman_maxmin(
    indptr: Any, action: Any, reward: Any, targets: Any, probs: Any, discount: float, v: Any,
    out: Any, arg: Any, start: int, end: int, /,
) -> None: ...  # fmt: skip
def hash_rows(
    owner: Any, action: Any, targets: Any, probbits: Any, out: Any, start: int, end: int, /
) -> None: ...
def ps_mark(succ: Any, allowed: Any, seen: Any, start: int, end: int, /) -> None: ...
def ps_fill(
    succ: Any, allowed: Any, post_id: Any, outcomes: Any, first: Any, start: int, end: int, /
) -> None: ...
def ps_verify(succ: Any, first: Any, outcomes: Any, start: int, end: int, /) -> int: ...
def ps_expect(outcomes: Any, probs: Any, v: Any, w: Any, start: int, end: int, /) -> None: ...
def ps_max_stats(
    first: Any, reward: Any, w: Any, discount: float, v: Any, out: Any, arg: Any, start: int,
    end: int, /,
) -> tuple[float, float]: ...  # fmt: skip
def ps_policy_stats(
    first: Any, reward: Any, act: Any, w: Any, discount: float, v: Any, out: Any, start: int,
    end: int, /,
) -> tuple[float, float]: ...  # fmt: skip
def ps_max_stats_coded(
    first: Any, codes: Any, table: Any, w: Any, discount: float, v: Any, out: Any, arg: Any,
    start: int, end: int, /,
) -> tuple[float, float]: ...  # fmt: skip
def ps_policy_stats_coded(
    first: Any, codes: Any, table: Any, act: Any, w: Any, discount: float, v: Any, out: Any,
    start: int, end: int, /,
) -> tuple[float, float]: ...  # fmt: skip
def ps_rows(allowed: Any, row_start: Any, act: Any, out: Any, start: int, end: int, /) -> None: ...
def reward_codes(reward: Any, max_codes: int, codes: Any, table: Any, /) -> int: ...
def canonical_rows(
    labels: Any, state: Any, action: Any, succ: Any, probs: Any, n_actions: int, out_owner: Any,
    out_t: Any, out_p: Any, out_oa: Any, out_key: Any, start: int, end: int, /,
) -> None: ...  # fmt: skip
def bucket_order(oa: Any, order: Any, offsets: Any, /) -> None: ...
def sort_buckets(order: Any, offsets: Any, key: Any, start: int, end: int, /) -> None: ...
def mark_groups(
    order: Any, oa: Any, key: Any, t: Any, pbits: Any, new: Any, start: int, end: int, /
) -> bool: ...
def merge_groups(
    order: Any, starts: Any, reward: Any, use_max: bool, owner: Any, action: Any, t: Any, p: Any,
    group: Any, red: Any, g_owner: Any, g_action: Any, g_t: Any, g_p: Any, start: int, end: int, /,
) -> None: ...  # fmt: skip
