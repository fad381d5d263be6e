"""The thread count of the C kernels from the environment: ``LPBOUNDS_NUM_THREADS``, then
``NUMBA_NUM_THREADS`` (the variable job scripts set while the kernels were numba's), then
the CPUs this process may run on; a value that is not a positive integer is an error
naming the variable, never a silent fallback to every CPU."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from lpbounds._kernels import threads
from lpbounds.errors import ValidationError


def cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


@pytest.fixture
def env(monkeypatch):
    for name in threads.THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(threads, "_threads", None)  # no set_threads: the environment's count
    return monkeypatch


def test_without_a_variable_every_usable_cpu(env):
    assert threads.default_threads() == cpus()


@pytest.mark.parametrize(
    ("lpbounds_value", "numba_value", "want"),
    [("3", None, 3), (None, "5", 5), ("3", "5", 3), (" 7 ", None, 7), ("", "5", 5)],
)
def test_lpbounds_variable_first_then_numba(env, lpbounds_value, numba_value, want):
    if lpbounds_value is not None:
        env.setenv("LPBOUNDS_NUM_THREADS", lpbounds_value)
    if numba_value is not None:
        env.setenv("NUMBA_NUM_THREADS", numba_value)
    assert threads.default_threads() == want
    assert threads.get_threads() == want


@pytest.mark.parametrize("name", ["LPBOUNDS_NUM_THREADS", "NUMBA_NUM_THREADS"])
@pytest.mark.parametrize("value", ["0", "-2", "two", "1.5"])
def test_a_bad_value_is_an_error_naming_the_variable(env, name, value):
    env.setenv(name, value)
    with pytest.raises(ValidationError, match=rf"^{name} = '{value}': .*positive integer"):
        threads.default_threads()


def test_set_threads_within_the_environment_count(env):
    env.setenv("LPBOUNDS_NUM_THREADS", "2")
    threads.set_threads(1)
    assert threads.get_threads() == 1
    with pytest.raises(ValueError, match="between 1 and 2; got 3"):
        threads.set_threads(3)


def test_the_command_line_words_a_bad_value():
    env = {**os.environ, "LPBOUNDS_NUM_THREADS": "many"}
    proc = subprocess.run(
        [sys.executable, "-m", "lpbounds.cli.main", "solve", "forest"],
        capture_output=True, text=True, timeout=120, env=env,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == (
        "lpbounds solve: error: LPBOUNDS_NUM_THREADS = 'many': the threads of lpbounds' "
        "kernels must be a positive integer"
    )
