"""Types of the patrol's C trajectories (``patrolmc.c``; :mod:`lpbounds.patrol.greedy_mc` and
:mod:`lpbounds.patrol.simulation` call them)."""

from typing import Any

def greedy_actions(
    xs: Any, lower: Any, mt: tuple[Any, ...], out: Any, start: int, end: int, /
) -> None: ...
def greedy_returns(
    x0: int,
    outcomes: Any,
    lower: Any,
    mt: tuple[Any, ...],
    cv: bool,
    out: Any,
    start: int,
    end: int,
    /,
) -> None: ...
def greedy_trajectory(
    x0: int, outcomes: Any, lower: Any, mt: tuple[Any, ...], states: Any, actions: Any, /
) -> None: ...
def simulate(
    x0: int,
    policy: Any,
    successors: Any,
    comps: Any,
    stations: Any,
    N: int,
    Gamma: int,
    outcomes: Any,
    check: bool,
    r_station: Any,
    r_arrival: Any,
    r_start: Any,
    r_visit: Any,
    r_loiters: Any,
    r_done: Any,
    r_merged: Any,
    r_merged_delay: Any,
    counts: Any,
    /,
) -> tuple[int, int, int]: ...
