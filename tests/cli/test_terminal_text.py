"""What the terminal shows: readable numbers and lists, no Python reprs, no repeated or
misplaced notices, summaries that agree with their tables.

The commands run in-process (:func:`lpbounds.cli.main.main`) on the packaged small models;
the warm-cache compile check runs the console command twice in a subprocess.
"""

from __future__ import annotations

import io
import logging
import re
import shlex
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.cli import score as score_cli
from lpbounds.cli.main import COMMANDS, main
from lpbounds.formulations import NLP, RLP

#: Python reprs that must never reach a reader: lists of strings or numbers ("['ELP',
#: 'RLP']", "taubar in [15]", "[1, 2, 3]"; two numbers in brackets are a bracket), dicts,
#: bools, None, numpy scalars and arrays, and argparse's unexpanded "%(default)s".
REPR = re.compile(
    r"\['|'\]|\{'|\bTrue\b|\bFalse\b|\bNone\b|np\.\w+\(|array\(|%\(|in \[\d+\]"
    r"|\[\d+(, \d+){2,}\]"
)
#: A float at Python's repr precision (``0.790292``): six or more decimals, no exponent.
RAW_FLOAT = re.compile(r"(?<![\d.])\d+\.\d{6,}(?![\d.e])")
#: A zero-padded exponent as ``%g`` writes it (``1e-06``).
PADDED_EXPONENT = re.compile(r"\de[-+]0\d")


def _run(capsys, *argv: str) -> tuple[str, str]:
    assert main(list(argv)) == 0
    cap = capsys.readouterr()
    return cap.out, cap.err


def _no_reprs(text: str) -> None:
    found = REPR.search(text)
    assert found is None, f"a Python repr {found.group()!r} in:\n{text}"


# ---------------------------------------------------------------------- --help
@pytest.mark.parametrize("command", ["", *COMMANDS])
def test_help_texts_print_no_reprs(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"] if command else ["--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    _no_reprs(text)
    if command != "verify":  # verify's help is worded in cli/verify.py
        assert not PADDED_EXPONENT.search(text), text


def test_score_help_runs_no_program_that_is_not_installed(capsys):
    with pytest.raises(SystemExit):
        main(["score", "--help"])
    text = capsys.readouterr().out
    assert not re.search(r"^\s*highs\s", text, re.M), "no 'highs' program comes with lpbounds"
    assert "highspy" in text


def test_score_help_example_runs_as_written(tmp_path, monkeypatch, capsys):
    """The epilog's three commands, run as given (the python line in a subprocess)."""
    monkeypatch.chdir(tmp_path)
    lines = [ln.strip() for ln in score_cli.EPILOG.splitlines()[1:] if ln.strip()]
    assert [ln.split()[0] for ln in lines] == ["lpbounds", "python", "lpbounds"]
    for line in lines:
        words = shlex.split(line)
        if words[0] == "lpbounds":
            assert main(words[1:]) == 0, line
        else:
            proc = subprocess.run(
                [sys.executable, *words[1:]], capture_output=True, text=True, timeout=120
            )
            assert proc.returncode == 0, proc.stderr
    out = capsys.readouterr().out
    _no_reprs(out)
    assert "status" in out and "optimal: certified error within 1e-6" in out
    assert re.search(r"certified (in \[[-\d.]+, [-\d.]+\]|= 0 ± )", out), out


# ---------------------------------------------------------------------- results
def test_solve_table_reads_as_words(capsys):
    out, err = _run(capsys, "solve", "garnet-small")
    _no_reprs(out)
    assert not RAW_FLOAT.search(out), out
    assert "build_seconds" not in out and "solve_seconds" not in out
    assert re.search(r"time\s+│ build [\d.]+ m?s, solve [\d.]+ m?s", out), out
    assert "modified policy iteration (mpi)" in out
    assert "300 states, 3 actions" in out
    assert err == ""


def test_bounds_table_says_taubar_equals(capsys):
    out, _ = _run(capsys, "bounds", "patrol-small")
    _no_reprs(out)
    assert "taubar = 4" in out, out  # the one taubar where Lemma 3's formula is capped
    assert re.search(r"allow_empty_loiter\s+│ false", out), out
    assert not RAW_FLOAT.search(out.split("largest gaps")[0]), out


def test_verify_prints_no_reprs(capsys):
    out, _ = _run(
        capsys, "verify", "garnet-small", "--random", "0", "--costs", "1", "--solvers", "HIGHS"
    )
    _no_reprs(out)
    assert "holds" in out


def test_compare_lists_uninstalled_solvers_only_with_verbose(tmp_path, capsys):
    args = ["compare", "garnet:12:3:1", "--formulations", "RLP", "--jobs", "1"]
    out, err = _run(capsys, *args, "--out", str(tmp_path / "a"))
    _no_reprs(out)
    assert not PADDED_EXPONENT.search(out), out
    notes = (tmp_path / "a" / "notes.txt").read_text()
    if "not installed" not in notes:
        pytest.skip("every known LP solver is installed here")
    assert "not installed" not in err and "install" not in err, err
    _, err_v = _run(capsys, *args, "--out", str(tmp_path / "b"), "--verbose")
    (line,) = [ln for ln in err_v.splitlines() if "not installed here" in ln]
    assert line.startswith("lpbounds: INFO: ")
    assert "['" not in line and "," in line


# ---------------------------------------------------------------------- compile notice
def test_a_log_record_during_a_progress_display_is_printed_once_above_it(capsys):
    """The display's console prints the record above the live lines; written to the
    terminal directly (the old handler), it landed inside the display and rich redrew it
    once per wrapped line."""
    from rich.console import Console
    from rich.progress import Progress

    from lpbounds.cli._common import LazyProgress, configure_output

    buf = io.StringIO()
    term = Console(file=buf, force_terminal=True, width=60)
    message = "a warning long enough to wrap the display's line " + "x" * 80
    with configure_output():
        lazy = LazyProgress(Progress(console=term, transient=True))
        task = lazy.add_task("working", total=3)
        logging.getLogger("lpbounds.test").warning("%s", message)
        lazy.update(task, advance=1)
        lazy.stop()
        logging.getLogger("lpbounds.test").warning("after the display")
    plain = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", buf.getvalue()).replace("\n", "")
    assert plain.count("x" * 80) == 1, buf.getvalue()
    err = capsys.readouterr().err
    assert message not in err  # not also on the raw stream under the display
    assert "lpbounds: WARNING: after the display" in err


@pytest.mark.slow
def test_a_first_run_prints_no_compile_notice(tmp_path):
    """A model whose sweeps run on several threads (20,000 x 3 x 4 = 240,000 reads per
    sweep), solved twice in fresh processes, the first with an empty numba cache: neither
    compiles anything or says so (the kernels are C, built at install), and the cache
    stays empty."""
    import os

    model = tmp_path / "big.toml"
    model.write_text(
        '[model]\nkind = "garnet"\nn_states = 20000\nn_actions = 3\nbranching = 4\n'
        "discount = 0.9\nseed = 1\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    cmd = [sys.executable, "-m", "lpbounds.cli.main", "solve", str(model)]
    errs = []
    for _ in range(2):
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env)
        assert proc.returncode == 0, proc.stderr
        assert "exact solve of big" in proc.stdout
        errs.append(proc.stderr)
    assert all("compil" not in err for err in errs), errs
    assert not (tmp_path / "numba-cache").exists() or not any((tmp_path / "numba-cache").iterdir())


# ---------------------------------------------------------------------- result texts
@pytest.fixture(scope="module")
def nlp() -> NLP:
    return NLP(lb.garnet(30, 3, 4, 0.9, seed=0), lb.random_partition(30, 5, seed=0))


NLP_RUNS = {
    "strategy": ("strategy-iteration", {}),
    "fixed-point": ("fixed-point", {}),
    "fixed-point-limit": ("fixed-point", {"max_iter": 5}),
    "monotone-limit": ("cutting-planes", {"max_iter": 3}),
    "monotone": ("cutting-planes", {}),
    "lift-limit": ("cutting-planes", {"cuts": "lift-and-project", "max_iter": 2}),
    "lift-time": ("cutting-planes", {"cuts": "lift-and-project", "time_limit": 1e-9}),
}


def _item(summary: str, key: str) -> str:
    (line,) = [ln for ln in summary.splitlines() if ln.strip().startswith(key + ":")]
    return line.split(":", 1)[1].strip()


def _count(text: str) -> int:
    return int(text.split()[0].replace(",", ""))


@pytest.mark.parametrize("run", list(NLP_RUNS))
def test_nlp_summary_counts_as_its_table_does(nlp, run):
    method, kw = NLP_RUNS[run]
    r = nlp.solve(method, raise_on_failure=False, **kw)
    text, table = r.summary(), r.log_table()
    _no_reprs(text)
    assert len(table) == len(r.log) and table.index[-1] == r.iterations
    work = _item(text, "work")
    assert _count(work) == table.index[-1], (text, table)
    unit = {"cutting-planes": "round", "strategy-iteration": "strateg"}.get(method, "sweep")
    assert unit in work.split(" in ")[0], work
    if method == "cutting-planes":
        cuts = _item(text, "cuts")
        if kw.get("cuts") == "lift-and-project":
            in_master = _count(cuts)
            assert in_master == r.cuts
            found = int(table["cuts_added"].sum())
            assert (found == in_master) is ("more, not added" not in cuts), cuts
            if found != in_master:
                assert f"found {found - in_master:,} more" in cuts
        else:  # monotone: the table's column summed over the rounds
            assert _count(cuts) == int(table["cuts_added"].sum()), (cuts, table)
            assert f"{r.cuts:,} in the last" in cuts
    else:
        assert "cuts:" not in text and (table["cuts_added"] == 0).all()


@pytest.mark.parametrize("run", list(NLP_RUNS))
def test_nlp_summary_never_calls_a_limit_converged(nlp, run):
    method, kw = NLP_RUNS[run]
    r = nlp.solve(method, raise_on_failure=False, **kw)
    text = r.summary()
    stopped = _item(text, "method stopped")
    assert stopped.startswith(f"{r.stop_reason}: ")
    assert "converged" not in stopped
    if r.stop_reason.is_limit:
        assert "limit was reached" in stopped
        assert ("within the asked accuracy all the same" in stopped) is r.ok, stopped


@pytest.mark.parametrize("run", ["strategy", "monotone-limit", "fixed-point-limit"])
def test_nlp_summary_bracket_contains_the_certified_one(nlp, run):
    method, kw = NLP_RUNS[run]
    r = nlp.solve(method, raise_on_failure=False, **kw)
    shown = _item(r.summary(), "c'w*")
    m = re.match(r"in \[([-\d.e+]+), ([-\d.e+]+)\]", shown)
    assert m, shown
    lo, hi = Fraction(m.group(1)), Fraction(m.group(2))
    assert lo <= Fraction(r.lower_bound) and hi >= Fraction(r.upper_bound)
    assert lo < hi


def test_a_bracket_around_zero_reads_as_zero_plus_minus():
    """An NLP whose c'w* is 0 (every reward 0): its certified bracket is a few ulps of the
    rounding allowance around 0, printed ``0 ± m`` (not ``[-2.7e-305, 2.7e-305]``)."""
    mdp = lb.garnet(30, 3, 4, 0.9, seed=0)
    zero = lb.FiniteMDP(
        mdp.successors, mdp.probabilities, np.zeros_like(mdp.rewards), 0.9, mdp.allowed
    )
    r = NLP(zero, lb.random_partition(30, 5, seed=0)).solve("strategy-iteration")
    assert r.lower_bound < 0 < r.upper_bound
    shown = _item(r.summary(), "c'w*")
    m = re.match(r"0 ± ([\d.]+e-\d+) \(certified", shown)
    assert m, shown
    assert Fraction(m.group(1)) >= max(-Fraction(r.lower_bound), Fraction(r.upper_bound))


def test_rlp_repr_on_a_2000_state_garnet_is_short():
    mdp = lb.garnet(2000, 4, 5, 0.95, seed=1)
    r = RLP(mdp, lb.random_partition(2000, 50, seed=2)).solve()
    text = repr(r)
    assert len(text) < 300 and "\n" not in text, text
    assert text.startswith("LPResult(RLP, status=")
    _no_reprs(text)


# ---------------------------------------------------------------------- the host's state
def test_study_figures_leave_the_matplotlib_backend_alone(tmp_path):
    """A notebook's backend is the session's: drawing a study's figures neither selects a
    backend nor imports pyplot (a fresh process, so no other test's imports count)."""
    code = f"""
import sys, matplotlib
matplotlib.use("svg")
import pandas as pd
from lpbounds.studies import profiles, report
table = pd.DataFrame({{"A": [1.0, 2.0, float("inf")], "B": [2.0, 1.0, 3.0]}})
path = profiles.plot_performance_profile(
    table, {str(tmp_path / "p.png")!r}, title="t", measure="time"
)
assert path.stat().st_size > 0
assert matplotlib.get_backend() == "svg", matplotlib.get_backend()
assert "matplotlib.pyplot" not in sys.modules
print("ok")
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr


# ---------------------------------------------------------------------- one label per message
#: a log line whose message starts with a second label ("lpbounds: WARNING: note: ...")
TWO_LABELS = re.compile(r"^lpbounds: [A-Z]+: (?:note|warning|error|info|debug)\b", re.I | re.M)


def test_compare_notes_have_one_label(tmp_path, monkeypatch, capsys):
    """A study's notes reach stderr as warnings, labelled once: "lpbounds: WARNING: no
    time-limit option known ...", not "lpbounds: WARNING: note: ..."."""
    from lpbounds.formulations import solvers

    monkeypatch.delitem(solvers.TIME_LIMIT_OPTIONS, "CLARABEL")  # a note: runs without one
    argv = ["compare", "garnet:40:5:1", "--formulations", "RLP", "--solvers", "CLARABEL"]
    argv += ["--time-limit", "60", "--jobs", "1", "--out", str(tmp_path / "cmp")]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "lpbounds: WARNING: no time-limit option known for CLARABEL" in err, err
    assert not TWO_LABELS.search(err), TWO_LABELS.search(err).group()
    assert not TWO_LABELS.search("lpbounds: WARNING: no time-limit option known")
    assert TWO_LABELS.search("lpbounds: WARNING: note: no time-limit option known")
