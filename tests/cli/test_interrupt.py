"""Ctrl-C during ``lpbounds reproduce``: exit status 130, one line on stderr, and ``--out``
holds the previous complete output (checked file by file against its manifest), with no
partial folder or lock left beside it.

The process is interrupted with a real SIGINT: at the start of chosen steps (a driver
script adds a hook to :data:`lpbounds.patrol.reproduce.STEP_HOOKS` that makes the process
signal itself there, so the point is exact), just after the commit's rename (through a
wrapper of ``os.replace``/``os.rename``), and after a delay measured from the moment the
run holds its lock. Once the new folder is renamed into place the run is committed: exit
status 0 and no ``.NAME.old-*`` left."""

from __future__ import annotations

import hashlib
import json
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from lpbounds.patrol.reproduce import reproduce

SMALL = "models/patrol-small.toml"
ARGS = ["--seeds", "1", "2", "--steps", "500"]


@pytest.fixture(scope="module")
def previous(tmp_path_factory) -> Path:
    """A complete earlier output (another seed, no figures: it differs from a new one)."""
    out = tmp_path_factory.mktemp("interrupt") / "out"
    reproduce(SMALL, out, seeds=(9,), n_steps=100, figures=False)
    return out


def _snapshot(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.iterdir())}


def _assert_complete(out: Path) -> dict:
    """Every file of ``out`` is in its manifest with the right size and hash."""
    man = json.loads((out / "manifest.json").read_text())
    listed = {f["name"]: f for f in man["files"]}
    assert set(listed) == {p.name for p in out.iterdir()} - {"manifest.json"}
    for name, f in listed.items():
        data = (out / name).read_bytes()
        assert len(data) == f["bytes"] and hashlib.sha256(data).hexdigest() == f["sha256"]
    return man


#: ``lpbounds`` with Ctrl-C sent to itself at the start of the step named by its first
#: argument (a hook of ``STEP_HOOKS``), as a user's Ctrl-C at that very point would.
AT_A_STEP = """
import os, signal, sys, time

from lpbounds.patrol import reproduce

step = sys.argv.pop(1)

def interrupt(name):
    if name == step:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(1.0)  # the handler runs at the next bytecode; never continue past

reproduce.STEP_HOOKS.append(interrupt)
from lpbounds.cli.main import entry
sys.argv[0] = "lpbounds"
entry()
"""


def _run(out: Path, step: str | None = None) -> subprocess.Popen:
    """``lpbounds reproduce`` into ``out``, interrupted at the start of ``step`` if given."""
    if step is None:
        cmd = [sys.executable, "-m", "lpbounds.cli.main"]
    else:
        cmd = [sys.executable, "-c", AT_A_STEP, step]
    return subprocess.Popen(
        [*cmd, "reproduce", SMALL, "--out", str(out), *ARGS],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # SIGINT as in a terminal, even when the suite itself runs as a background job
        # (which starts its children with SIGINT ignored)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def _assert_interrupted(proc: subprocess.Popen, out: Path, before: dict[str, bytes]) -> None:
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == "lpbounds reproduce: interrupted"
    assert _snapshot(out) == before, "the previous output changed"
    _assert_complete(out)
    assert sorted(p.name for p in out.parent.iterdir()) == [out.name], "leftovers beside --out"


@pytest.mark.parametrize("step", ["vstar", "figures", "write", "commit"])
def test_interrupt_at_a_step_keeps_the_previous_output(previous, step):
    before = _snapshot(previous)
    proc = _run(previous, step)
    _assert_interrupted(proc, previous, before)


def test_interrupt_after_a_delay_keeps_the_previous_output_or_completes(previous):
    """A real Ctrl-C 1.5 s after the run took its lock: the previous output unchanged, or
    (if the run finished first, or the signal came after its commit) a complete new one."""
    before = _snapshot(previous)
    lock = previous.parent / f".{previous.name}.lock"
    proc = _run(previous)
    t0 = time.monotonic()
    while not lock.exists() and proc.poll() is None and time.monotonic() - t0 < 300:
        time.sleep(0.02)
    time.sleep(1.5)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=600)
    assert "Traceback" not in err
    if proc.returncode == 130:  # interrupted before the rename: untouched
        assert _snapshot(previous) == before, "exit 130 but --out changed"
    else:  # completed, or interrupted after the rename (committed: exit 0)
        assert proc.returncode == 0, err
        assert _assert_complete(previous)["instance"] == "patrol-small"
    assert sorted(p.name for p in previous.parent.iterdir()) == [previous.name]


def test_interrupt_without_previous_output_leaves_nothing(tmp_path):
    out = tmp_path / "fresh"
    proc = _run(out, "figures")
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 130 and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


#: ``lpbounds`` with Ctrl-C sent to itself just after the commit renamed the new folder
#: (``.NAME.partial-*``) into place: the moment the previous output is only beside it.
AFTER_THE_RENAME = """
import os, signal, sys

def signalling(real):
    def move(src, dst, *args, **kwargs):
        real(src, dst, *args, **kwargs)
        if ".partial-" in os.path.basename(os.fspath(src)):
            os.kill(os.getpid(), signal.SIGINT)
    return move

os.replace, os.rename = signalling(os.replace), signalling(os.rename)
from lpbounds.cli.main import entry
sys.argv[0] = "lpbounds"
entry()
"""


def test_interrupt_just_after_the_rename_is_a_completed_run(previous, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(previous, out)
    before = _snapshot(out)
    proc = subprocess.Popen(
        [sys.executable, "-c", AFTER_THE_RENAME, "reproduce", SMALL, "--out", str(out), *ARGS],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("lpbounds reproduce: interrupted after")
    assert _snapshot(out) != before, "the new output is not in place"
    man = _assert_complete(out)
    assert man["instance"] == "patrol-small"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"], "leftovers beside --out"


SWALLOWED = """
import gc, sys, time, weakref
import lpbounds.cli.main as cli

class Thing:
    pass

def boom(_):
    raise KeyboardInterrupt  # what a Ctrl-C inside a weakref callback looks like

def run(args):
    t = Thing()
    r = weakref.ref(t, boom)
    del t  # the callback runs here: Python cannot raise from it, it calls unraisablehook
    gc.collect()
    end = time.monotonic() + 30  # the re-sent interrupt arrives a millisecond later
    while time.monotonic() < end:
        pass
    print("not interrupted")
    return 0

cli.build_parser = lambda: type("P", (), {"parse_args": lambda self, a: type(
    "A", (), {"func": staticmethod(run), "command": "x", "quiet": False, "verbose": 0})()})()
sys.argv = ["lpbounds"]
cli.entry()
"""


def test_a_ctrl_c_inside_a_weakref_callback_stops_the_command_without_a_traceback():
    """Python prints an exception raised in a weakref callback or ``__del__`` as "Exception
    ignored in ..." with a traceback, and goes on: the command delivers it again as SIGINT,
    so it ends as an interrupted command (130, one line), not with a traceback."""
    proc = subprocess.run(
        [sys.executable, "-c", SWALLOWED],
        capture_output=True,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert proc.returncode == 130, proc.stderr
    assert "Traceback" not in proc.stderr and "not interrupted" not in proc.stdout
    assert proc.stderr.strip().splitlines()[-1] == "lpbounds x: interrupted"
