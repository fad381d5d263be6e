"""Sizes and ranges from a model file or an argument are checked before anything is
allocated from them: a typed error naming the argument (on the command line one line,
exit status 2), never a MemoryError, numpy's "array is too big" or an OverflowError.

Each case failed before these checks: ``n_states = 10000000000`` raised numpy's
``_ArrayMemoryError`` (894 GiB), ``2**63 - 1`` its "array is too big", and rewards in
``[-1e308, 1e308]`` an ``OverflowError`` from the width of the range."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import lpbounds as lb
import lpbounds.validation as validation
from lpbounds.cli.main import main
from lpbounds.errors import ValidationError
from lpbounds.model.generators import garnet_bytes

HUGE = [10_000_000_000, 2**63 - 1, 2**64 + 1]


def _model(tmp_path: Path, **keys: object) -> Path:
    table = {"n_states": 10, "n_actions": 3, "branching": 4, **keys}
    lines = ["[model]", 'kind = "garnet"', *(f"{k} = {v}" for k, v in table.items())]
    f = tmp_path / "m.toml"
    f.write_text("\n".join(lines) + "\n")
    return f


def _one_line(capsys, *fragments: str) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("lpbounds solve: error: "), err
    for f in fragments:
        assert f in lines[0], (f, err)
    return lines[0]


# ---------------------------------------------------------------------- sizes
@pytest.mark.parametrize("key", ["n_states", "n_actions", "branching"])
@pytest.mark.parametrize("value", HUGE)
def test_a_size_beyond_memory_is_refused_naming_the_key(tmp_path, capsys, key, value):
    assert main(["solve", str(_model(tmp_path, **{key: value}))]) == 2
    line = _one_line(capsys, f"[model] {key} = {value}", "bytes", "memory")
    assert f"{garnet_bytes(**{'n_states': 10, 'n_actions': 3, 'branching': 4, key: value}):,}" in (
        line
    )


def test_the_message_gives_the_bytes_needed_and_available(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(validation, "physical_memory", lambda: 1_000_000)
    assert main(["solve", str(_model(tmp_path, n_states=100_000))]) == 2
    needed = garnet_bytes(100_000, 3, 4)
    _one_line(capsys, "[model] n_states = 100000", f"{needed:,} bytes", "1,000,000 bytes")
    assert main(["solve", str(_model(tmp_path, n_states=100))]) == 0  # small enough


def test_a_float_where_an_integer_is_needed_names_the_key(tmp_path, capsys):
    assert main(["solve", str(_model(tmp_path, n_states="1e10"))]) == 2
    _one_line(capsys, "[model] n_states must be an integer", "float")


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: lb.garnet(2**63 - 1, 3, 4), r"n_states = 9223372036854775807 .*bytes"),
        (lambda: lb.garnet(10, 10**12, 4), r"n_actions = 1000000000000 .*bytes"),
        (lambda: lb.garnet(10, 3, 10**15), r"branching = 1000000000000000 .*bytes"),
        (
            lambda: lb.random_partition(2**62, 3),
            r"n_states = 4611686018427387904: the labels need .*bytes",
        ),
    ],
)
def test_the_generators_refuse_sizes_beyond_memory(call, pattern):
    with pytest.raises(ValidationError, match=pattern):
        call()


def test_export_of_a_huge_garnet_spec_is_refused_before_any_work(tmp_path, capsys):
    out = tmp_path / "e"
    code = main(["export", "garnet:10000000000:3", "--formulation", "RLP", "--out", str(out)])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "n_states = 10000000000" in err and "bytes" in err
    assert not out.exists()


# ---------------------------------------------------------------------- reward ranges
@pytest.mark.parametrize(
    ("low", "high", "discount"),
    [(-1e308, 1e308, 0.9), (0.0, 1.7e308, 0.5), (-1e305, 0.0, 0.9), (0.0, 1e299, 0.999)],
)
def test_a_reward_range_beyond_float64_is_refused_naming_the_keys(
    tmp_path, capsys, low, high, discount
):
    f = _model(tmp_path, reward_low=low, reward_high=high, discount=discount)
    assert main(["solve", str(f)]) == 2
    _one_line(capsys, "[model] reward_low", "reward_high", "max|R|")


def test_garnet_refuses_a_reward_range_whose_width_overflows():
    with pytest.raises(ValidationError, match=r"reward_range.*max\|R\|"):
        lb.garnet(5, 2, 2, reward_range=(-1e308, 1e308))
    lb.garnet(5, 2, 2, reward_range=(-1e290, 1e290))  # representable: accepted


# ---------------------------------------------------------------------- the console script
@pytest.mark.parametrize(
    ("keys", "fragment"),
    [
        ({"n_states": 2**63 - 1}, "[model] n_states = 9223372036854775807"),
        ({"reward_low": -1e308, "reward_high": 1e308}, "[model] reward_low"),
    ],
)
def test_the_console_script_prints_one_line_and_exits_2(tmp_path, keys, fragment):
    proc = subprocess.run(
        [sys.executable, "-m", "lpbounds.cli.main", "solve", str(_model(tmp_path, **keys))],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and proc.stderr.strip().count("\n") == 0
    assert fragment in proc.stderr
