"""The command line: `lpbounds solve` prints and writes numbers equal to the library's."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.cli.main import main


def test_help_lists_solve(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    assert "solve" in capsys.readouterr().out


def test_solve_writes_the_library_numbers(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert main(["solve", "garnet-small", "--json", str(out)]) == 0
    stats = json.loads(out.read_text())
    res = lb.solve_exact(lb.load_instance("garnet-small").mdp())
    assert stats["n_states"] == 300
    assert stats["residual"] <= stats["tol"]
    assert stats["value_max"] == pytest.approx(float(np.max(res.values)), abs=2 * res.error_bound)
    assert "exact solve of garnet-small" in capsys.readouterr().out


def _meaning(text: str) -> tuple[float, float]:
    """The interval a printed statistic claims: ``[a, b]`` as written, or a number with
    ``k`` significant digits as its rounding cell (half a unit of its last digit)."""
    from decimal import Decimal

    text = text.strip()
    if text.startswith("["):
        a, b = text[1:-1].split(",")
        return float(a), float(b)
    d = Decimal(text.replace(",", ""))
    half = Decimal(5) * Decimal(10) ** (d.as_tuple().exponent - 1)
    return float(d - half), float(d + half)


@pytest.mark.parametrize("model", ["frozenlake", "garnet-small", "patrol-small"])
def test_solve_prints_statistics_of_v_star_that_are_true(model, capsys):
    """Each of min, mean and max V* as printed holds the statistic of V* from an independent
    dense policy iteration: frozenlake's least value is 0 (its sink), where the computed V
    is 2.9e-10 ("min 2.937e-10" was printed, with an error bound of 2.9e-10)."""
    if model == "frozenlake":
        pytest.importorskip("gymnasium", reason="the interop extra")
    from tests import _independent as ind

    assert main(["solve", model]) == 0
    lines = capsys.readouterr().out.splitlines()
    at = next(k for k, ln in enumerate(lines) if "V* (certified)" in ln)
    parts = [lines[at].split("\u2502")[2]]
    for ln in lines[at + 1 :]:  # the cell wraps on a narrow terminal: its next lines
        cols = ln.split("\u2502")
        if len(cols) < 3 or cols[1].strip():
            break
        parts.append(cols[2])
    cells = " ".join(p.strip() for p in parts)  # min ..., mean ..., max ...
    said = dict(re.findall(r"(min|mean|max) (\[[^\]]*\]|[-\d.,e]+)", cells))
    assert set(said) == {"min", "mean", "max"}, cells
    mdp = lb.load_instance(model).mdp()
    ref = ind.policy_iteration(
        ind.dense_transitions(mdp.successors, mdp.probabilities_full()),
        mdp.rewards, mdp.allowed, mdp.discount,
    )  # fmt: skip
    true = {"min": ref.values.min(), "mean": ref.values.mean(), "max": ref.values.max()}
    for k, value in true.items():
        lo, hi = _meaning(said[k])
        assert lo - ref.error <= value <= hi + ref.error, (k, said[k], value)
    if model == "frozenlake":
        assert said["min"].startswith("[") and _meaning(said["min"])[0] <= 0.0


def test_solve_bad_model_exits_with_one_clear_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(
        '[model]\nkind = "garnet"\nn_states = 3\nn_actions = 1\nbranching = 1\ndiscount = 1.2\n'
    )
    assert main(["solve", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "discount must lie in [0, 1)" in err and "Traceback" not in err


def test_console_script_runs():
    proc = subprocess.run(
        [sys.executable, "-m", "lpbounds.cli.main", "solve", "garnet-small", "--method", "pi"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "residual" in proc.stdout


def test_quiet_prints_nothing_and_verbose_logs_the_environment(capsys):
    import logging

    log = logging.getLogger("lpbounds")
    before = (log.level, log.propagate, list(log.handlers))
    assert main(["solve", "garnet-small", "--quiet"]) == 0
    out = capsys.readouterr()
    assert out.out == "" and out.err == ""
    assert main(["solve", "garnet-small", "--verbose"]) == 0
    out = capsys.readouterr()
    assert "exact solve of garnet-small" in out.out
    assert f"lpbounds: DEBUG: lpbounds {lb.__version__}" in out.err
    assert "numpy " + np.__version__ in out.err
    # the command's logging set-up is undone: no handler, level or propagation left behind
    assert (log.level, log.propagate, list(log.handlers)) == before


def test_quiet_and_verbose_exclude_each_other(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["solve", "garnet-small", "--quiet", "--verbose"])
    assert exc.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["solve", "verify", "bounds", "reproduce", "compare"])
def test_every_subcommand_has_quiet_and_verbose(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = capsys.readouterr().out
    assert "--quiet" in text and "--verbose" in text


TINY_TOML = """[model]
kind = "garnet"
n_states = 12
n_actions = 2
branching = 3
discount = 0.9
seed = 5

[partition]
kind = "random"
n_partitions = 3
seed = 2
"""


@pytest.fixture
def console_100():
    from lpbounds.cli._common import console

    old = console.width
    console.width = 100
    yield
    console.width = old


def test_compare_table_fits_100_columns_without_cutting_numbers(tmp_path, capsys, console_100):
    import pandas as pd

    model = tmp_path / "tiny.toml"
    model.write_text(TINY_TOML)
    args = ["compare", str(model), "--formulations", "ELP", "RLP", "--solvers", "HIGHS:ipm"]
    assert main([*args, "CLARABEL", "--jobs", "1", "--out", str(tmp_path / "c")]) == 0
    out = capsys.readouterr().out
    assert max(len(line) for line in out.splitlines()) <= 100
    assert "…" not in out and "..." not in out
    summary = pd.read_csv(tmp_path / "c" / "summary.csv")
    for row in summary.itertuples():
        assert format(row.objective, ".8g") in out  # every objective printed whole
        assert str(row.config) in out


def test_verify_tables_fit_100_columns(tmp_path, capsys, console_100):
    model = tmp_path / "tiny.toml"
    model.write_text(TINY_TOML)
    args = ["verify", str(model), "--random", "0", "--costs", "1", "--solvers", "HIGHS"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert max(len(line) for line in out.splitlines()) <= 100
    assert "…" not in out and "holds" in out
