"""The command line never shows a traceback for a user error: one line on stderr and a
documented exit status (2 input/usage, 1 computation failed), and every output is
checked before any computation (the computation is replaced here by a function that
fails the test if it is ever called)."""

from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

import lpbounds.dp
import lpbounds.patrol.reproduce as rp
from lpbounds.cli import bounds as cli_bounds
from lpbounds.cli import solve as cli_solve
from lpbounds.cli.main import EXIT_CODES, main
from lpbounds.errors import ConvergenceError, OutputError
from lpbounds.outputs import AtomicDirectory, check_output_dir, check_output_file

SMALL = "models/patrol-small.toml"
QUICK = ["--seeds", "1", "--steps", "200", "--no-figures"]


def _never(*args, **kwargs):
    raise AssertionError("computation started although an input or output is bad")


@pytest.fixture
def no_computation(monkeypatch):
    """Any computation (of reproduce, solve or bounds) fails the test."""
    monkeypatch.setattr(rp, "build_model", _never)
    # the commands import solve_exact at module level or inside run(): patch both places
    monkeypatch.setattr(lpbounds.dp, "solve_exact", _never)
    monkeypatch.setattr(cli_solve, "solve_exact", _never, raising=False)
    monkeypatch.setattr(cli_bounds, "solve_exact", _never, raising=False)


def _one_line_error(capsys, *fragments: str) -> str:
    """The error is one line, the only one on stderr, containing every fragment."""
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("lpbounds "), err
    for f in fragments:
        assert f in lines[0], (f, err)
    return lines[0]


def _unwritable_dir(tmp_path: Path) -> Path:
    """A folder no file can be created in, also for root (a read-only bind is not
    available everywhere; /proc refuses new files for everyone)."""
    if sys.platform.startswith("linux") and Path("/proc").is_dir():
        return Path("/proc")
    if os.geteuid() == 0:  # pragma: no cover
        pytest.skip("no unwritable directory for root on this platform")
    d = tmp_path / "ro"
    d.mkdir()
    d.chmod(0o555)
    return d


# ---------------------------------------------------------------------- reproduce --out
def test_out_that_is_a_file_is_rejected_before_any_computation(tmp_path, capsys, no_computation):
    f = tmp_path / "taken"
    f.write_text("mine")
    assert main(["reproduce", SMALL, "--out", str(f), *QUICK]) == 2
    _one_line_error(capsys, "--out", "not a directory")
    assert f.read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]


def test_out_holding_other_files_is_refused_not_replaced(tmp_path, capsys, no_computation):
    """--out is replaced as a whole, so a folder with anything but this command's files
    (here a user's notes, or a subfolder) is refused before any computation."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    (out / "summary.json").write_text("{}")
    assert main(["reproduce", SMALL, "--out", str(out), *QUICK]) == 2
    _one_line_error(capsys, "--out", "notes.txt", "new or empty folder")
    assert (out / "notes.txt").read_text() == "keep me"
    (out / "notes.txt").unlink()
    (out / "sub").mkdir()
    assert main(["reproduce", SMALL, "--out", str(out), *QUICK]) == 2
    _one_line_error(capsys, "sub")


def test_out_below_a_file_is_rejected(tmp_path, capsys, no_computation):
    f = tmp_path / "file"
    f.write_text("")
    assert main(["reproduce", SMALL, "--out", str(f / "sub" / "out"), *QUICK]) == 2
    _one_line_error(capsys, "--out")


def test_out_in_an_unwritable_folder_is_rejected(tmp_path, capsys, no_computation):
    ro = _unwritable_dir(tmp_path)
    target = ro / "lpbounds-out"
    assert main(["reproduce", SMALL, "--out", str(target), *QUICK]) == 2
    line = _one_line_error(capsys, "--out", f"cannot create {str(target)!r}", f"{str(ro)!r}")
    assert "No such file or directory" not in line  # /proc's ENOENT, about a folder that is
    assert not target.exists()


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="a Linux /proc")
@pytest.mark.parametrize("flag", ["--out", "--json"])
def test_out_in_proc_says_the_folder_refuses_new_entries(flag, capsys, no_computation):
    """/proc refuses a new file with ENOENT: "(No such file or directory)" was printed
    about /proc, which exists; the message names the path and the folder's refusal."""
    assert main(["solve", "garnet-small", flag, "/proc/forbidden/x"]) == 2
    line = _one_line_error(
        capsys, flag, "cannot create '/proc/forbidden/x'", "the folder '/proc' accepts no new"
    )
    assert "No such file or directory" not in line


@pytest.mark.parametrize(
    ("err", "words"),
    [
        (errno.EACCES, "is not writable (permission denied)"),
        (errno.EPERM, "is not writable (permission denied)"),
        (errno.EROFS, "is on a read-only file system"),
        (errno.ENOSPC, "refused a new entry (No space left on device)"),
    ],
)
def test_each_refusal_is_said_in_words(tmp_path, monkeypatch, err, words):
    """The reason a folder refuses the probe file, for each errno (run as root, a folder
    without write permission cannot be made: the refusal is simulated)."""
    from lpbounds import outputs

    def refuse(*args, **kwargs):
        raise OSError(err, os.strerror(err))

    monkeypatch.setattr(outputs.tempfile, "mkstemp", refuse)
    target = tmp_path / "new" / "out"
    with pytest.raises(OutputError) as exc:
        outputs.check_output_dir(target)
    text = str(exc.value)
    assert text == f"--out: cannot create {str(target)!r}: the folder {str(tmp_path)!r} {words}"


@pytest.mark.parametrize(
    "args",
    [
        ["--seeds", "-1"],
        ["--seeds", "1", "x"],
        ["--seeds", "1.5"],
        ["--steps", "0"],
        ["--steps", "-3"],
        ["--steps", "ten"],
        ["--general", "both"],
    ],
)
def test_bad_numbers_are_rejected_by_argparse(tmp_path, capsys, args, no_computation):
    out = tmp_path / "o"
    with pytest.raises(SystemExit) as exc:
        main(["reproduce", SMALL, "--out", str(out), *args])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "error: argument" in err
    assert not out.exists()


@pytest.mark.parametrize(
    ("model", "fragment"),
    [
        ("models/garnet-small.toml", "patrol"),
        ("no-such-model", "no instance file"),
        (".", "directory"),
    ],
)
def test_a_rejected_model_creates_nothing(tmp_path, capsys, model, fragment, no_computation):
    out = tmp_path / "o"
    assert main(["reproduce", model, "--out", str(out), *QUICK]) == 2
    _one_line_error(capsys, fragment)
    assert list(tmp_path.iterdir()) == []


def test_a_model_with_wrong_toml_creates_nothing(tmp_path, capsys, no_computation):
    bad = tmp_path / "bad.toml"
    bad.write_text("[model\nkind = 'patrol'\n")
    out = tmp_path / "o"
    assert main(["reproduce", str(bad), "--out", str(out), *QUICK]) == 2
    _one_line_error(capsys, "not valid TOML")
    assert not out.exists()


def test_a_held_lock_is_named_and_nothing_is_written(tmp_path, capsys, no_computation):
    out = tmp_path / "o"
    lock = tmp_path / ".o.lock"
    lock.write_text(f"{os.getpid()}\n")  # a live process holds it
    assert main(["reproduce", SMALL, "--out", str(out), *QUICK]) == 2
    _one_line_error(capsys, "locked by another run", str(lock), str(os.getpid()))
    assert lock.exists() and not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".o.lock"]


def test_a_stale_lock_of_a_dead_process_is_taken_over(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    out = tmp_path / "o"
    (tmp_path / ".o.lock").write_text(f"{dead.pid}\n")
    target = AtomicDirectory(out)
    with target as tmp:
        (tmp / "a.txt").write_text("a")
        target.commit()
    assert (out / "a.txt").read_text() == "a"
    assert not (tmp_path / ".o.lock").exists()


def test_a_failed_computation_exits_1_and_keeps_the_previous_output(tmp_path, capsys, monkeypatch):
    out = tmp_path / "o"
    out.mkdir()
    (out / "summary.json").write_text("{}")

    def fail(*a, **k):
        raise ConvergenceError("no convergence in 3 iterations")

    monkeypatch.setattr(rp, "solve_vstar", fail)
    assert main(["reproduce", SMALL, "--out", str(out), *QUICK]) == 1
    _one_line_error(capsys, "no convergence")
    assert [p.name for p in out.iterdir()] == ["summary.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]  # no partial folder, no lock


# ---------------------------------------------------------------------- --json of solve, bounds
@pytest.mark.parametrize("command", ["solve", "bounds"])
def test_json_that_is_a_directory_is_rejected_before_any_computation(
    tmp_path, capsys, command, no_computation
):
    model = "garnet-small" if command == "solve" else "patrol-small"
    assert main([command, model, "--json", str(tmp_path)]) == 2
    _one_line_error(capsys, "--json", "is a directory")


@pytest.mark.parametrize("command", ["solve", "bounds"])
def test_json_in_an_unwritable_folder_is_rejected(tmp_path, capsys, command, no_computation):
    model = "garnet-small" if command == "solve" else "patrol-small"
    target = _unwritable_dir(tmp_path) / "stats.json"
    assert main([command, model, "--json", str(target)]) == 2
    _one_line_error(capsys, "--json", f"cannot create {str(target)!r}")


@pytest.mark.parametrize(
    "args", [["--tol", "-1"], ["--tol", "nan"], ["--tol", "inf"], ["--max-iter", "0"]]
)
def test_solve_bad_numbers_are_rejected_by_argparse(capsys, args, no_computation):
    with pytest.raises(SystemExit) as exc:
        main(["solve", "garnet-small", *args])
    assert exc.value.code == 2
    assert "Traceback" not in capsys.readouterr().err


def test_bounds_negative_limit_is_rejected_by_argparse(capsys, no_computation):
    with pytest.raises(SystemExit) as exc:
        main(["bounds", "patrol-small", "--lp-max-partitions", "-5"])
    assert exc.value.code == 2


def test_solve_json_is_written_whole(tmp_path):
    target = tmp_path / "deep" / "s.json"
    assert main(["solve", "garnet-small", "--method", "pi", "--json", str(target)]) == 0
    assert json.loads(target.read_text())["n_states"] == 300
    assert sorted(p.name for p in target.parent.iterdir()) == ["s.json"]  # no temporary


# ---------------------------------------------------------------------- the documentation
def test_help_documents_the_exit_codes(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "exit status" in out
    for code in (0, 1, 2, 130):
        assert f"  {code} " in out, code
    assert set(EXIT_CODES) == {0, 1, 2, 130}


def test_console_script_prints_one_line_for_a_bad_out(tmp_path):
    f = tmp_path / "file"
    f.write_text("")
    proc = subprocess.run(
        [sys.executable, "-m", "lpbounds.cli.main", "reproduce", SMALL, "--out", str(f)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "Traceback" not in proc.stderr
    assert proc.stderr.startswith("lpbounds reproduce: error: --out")


# ---------------------------------------------------------------------- the library helpers
def test_check_helpers_raise_output_error(tmp_path):
    f = tmp_path / "f"
    f.write_text("")
    with pytest.raises(OutputError, match="not a directory"):
        check_output_dir(f)
    with pytest.raises(OutputError, match="is a directory"):
        check_output_file(tmp_path)
    assert check_output_dir(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    assert not (tmp_path / "new").exists()  # a check creates nothing
    with pytest.raises(OutputError):
        rp.reproduce(SMALL, f, seeds=(1,), n_steps=10, figures=False)


def test_atomic_directory_replaces_the_previous_output_only_on_commit(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(RuntimeError), AtomicDirectory(out) as tmp:
        (tmp / "new.txt").write_text("new")
        raise RuntimeError("boom")
    assert [p.name for p in out.iterdir()] == ["old.txt"]
    target = AtomicDirectory(out)
    with target as tmp:
        (tmp / "new.txt").write_text("new")
        target.commit()
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]


# ---------------------------------------------------------------------- models as package data
def test_models_are_package_data_and_resolve_from_any_directory(tmp_path, monkeypatch):
    """Every file of the repository's models/ is in the package's folder, and a bare name,
    a file name and the README's models/... path all resolve there from a directory
    without a models/ folder."""
    from lpbounds.model.instances import load_instance, packaged_models_dir, resolve_instance_path

    repo_models = Path(__file__).resolve().parents[2] / "models"
    packaged = packaged_models_dir()
    assert packaged.is_dir()
    assert {p.name for p in repo_models.glob("*.toml")} <= {p.name for p in packaged.glob("*")}
    monkeypatch.chdir(tmp_path)
    for spec in ("patrol-small", "patrol-small.toml", "models/patrol-small.toml"):
        assert resolve_instance_path(spec) == packaged / "patrol-small.toml", spec
    assert load_instance("models/garnet-small.toml").name == "garnet-small"
    # a file that exists is used first, even with a packaged model's name
    (tmp_path / "models").mkdir()
    own = tmp_path / "models" / "garnet-small.toml"
    own.write_text(
        (packaged / "garnet-small.toml").read_text().replace("n_states = 300", "n_states = 40")
    )
    assert load_instance("models/garnet-small.toml").mdp().n_states == 40


def test_cli_runs_a_packaged_model_outside_the_checkout(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "lpbounds.cli.main", "solve", "models/garnet-small.toml"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert "exact solve of garnet-small" in proc.stdout


# ------------------------------------------------------------ --out that cannot be replaced
def _previous(tmp_path: Path, *files: str) -> Path:
    """An earlier output ``tmp_path/o`` holding ``files`` (each with the text "old")."""
    out = tmp_path / "o"
    out.mkdir()
    for name in files:
        (out / name).write_text("old")
    return out


def _refuse_moving(monkeypatch, path: Path) -> None:
    """``os.rename`` and ``os.replace`` of ``path`` fail, as for a folder that cannot be
    moved (immutable, a mount point, another user's in a sticky folder)."""
    target = os.path.abspath(path)

    def refusing(real):
        def move(src, dst, *args, **kwargs):
            if os.path.abspath(src) == target:
                raise PermissionError(errno.EPERM, "Operation not permitted", os.fspath(src))
            return real(src, dst, *args, **kwargs)

        return move

    monkeypatch.setattr(os, "rename", refusing(os.rename))
    monkeypatch.setattr(os, "replace", refusing(os.replace))


@pytest.mark.parametrize("command", ["reproduce", "solve"])
def test_an_out_that_cannot_be_moved_is_refused_before_any_computation(
    tmp_path, capsys, monkeypatch, no_computation, command
):
    name = "summary.json" if command == "reproduce" else "solution.json"
    out = _previous(tmp_path, name)
    _refuse_moving(monkeypatch, out)
    model = [SMALL, *QUICK] if command == "reproduce" else ["garnet-small"]
    assert main([command, *model, "--out", str(out)]) == 2
    _one_line_error(capsys, "--out", str(out), "cannot be replaced", "Operation not permitted")
    assert [p.name for p in out.iterdir()] == [name] and (out / name).read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]  # no .o.old-*, no lock


def test_check_output_dir_tries_the_move_and_puts_the_folder_back(tmp_path, monkeypatch):
    out = _previous(tmp_path, "a.txt")
    assert check_output_dir(out) == out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]
    assert (out / "a.txt").read_text() == "old"
    _refuse_moving(monkeypatch, out)
    with pytest.raises(OutputError, match="cannot be replaced"):
        check_output_dir(out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]


def test_an_immutable_out_is_refused_before_the_computation(tmp_path):
    """A real folder that cannot be moved (``chattr +i``; where it is available)."""
    out = _previous(tmp_path, "solution.json")
    chattr = shutil.which("chattr")
    if chattr is None or subprocess.run([chattr, "+i", str(out)], capture_output=True).returncode:
        pytest.skip("chattr +i is not available here (root and a file system with the flag)")
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "lpbounds.cli.main", "solve", "garnet-small", "--out", str(out)],
            capture_output=True,
            text=True,
            timeout=300,
        )
    finally:
        subprocess.run([chattr, "-i", str(out)], check=True)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().count("\n") == 0 and "Traceback" not in proc.stderr
    assert "cannot be replaced" in proc.stderr
    assert "exact solve" not in proc.stdout  # refused before the solve, not after it
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]


def test_a_held_lock_is_reported_before_the_computation_of_solve(tmp_path, capsys, no_computation):
    out = tmp_path / "o"
    lock = tmp_path / ".o.lock"
    lock.write_text(f"{os.getpid()}\n")  # a live process holds it
    assert main(["solve", "garnet-small", "--out", str(out)]) == 2
    _one_line_error(capsys, "locked by another run", str(lock))
    assert sorted(p.name for p in tmp_path.iterdir()) == [".o.lock"]


def test_a_failed_move_into_place_keeps_the_previous_output_and_leaves_nothing(
    tmp_path, monkeypatch
):
    out = _previous(tmp_path, "old.txt")
    target = AtomicDirectory(out)
    with pytest.raises(OSError), target as tmp:
        (tmp / "new.txt").write_text("new")
        _refuse_moving(monkeypatch, tmp)  # the new folder cannot be moved into place
        target.commit()
    assert [p.name for p in out.iterdir()] == ["old.txt"]
    assert (out / "old.txt").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]


# ---------------------------------------------------------------------- Ctrl-C at the commit
@pytest.fixture
def sigint_raises():
    """SIGINT raises KeyboardInterrupt, as in a terminal (even when the suite runs as a
    background job, which ignores it)."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


def _sigint_after_the_move_into_place(monkeypatch) -> None:
    """Ctrl-C just after the commit renamed the new folder (``.NAME.partial-*``) into place."""

    def signalling(real):
        def move(src, dst, *args, **kwargs):
            real(src, dst, *args, **kwargs)
            if ".partial-" in os.path.basename(os.fspath(src)):
                os.kill(os.getpid(), signal.SIGINT)

        return move

    monkeypatch.setattr(os, "rename", signalling(os.rename))
    monkeypatch.setattr(os, "replace", signalling(os.replace))


def test_ctrl_c_just_after_the_rename_leaves_the_new_output_and_nothing_else(
    tmp_path, monkeypatch, sigint_raises
):
    out = _previous(tmp_path, "old.txt")
    _sigint_after_the_move_into_place(monkeypatch)
    target = AtomicDirectory(out)
    try:
        with target as tmp:
            (tmp / "new.txt").write_text("new")
            target.commit()
    except KeyboardInterrupt:  # handed on once the commit is complete
        pass
    assert target.committed
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]  # no .o.old-*, no lock


def test_ctrl_c_while_the_previous_output_is_removed_still_removes_it(
    tmp_path, monkeypatch, sigint_raises
):
    out = _previous(tmp_path, "old.txt")
    real = shutil.rmtree

    def rmtree(path, *args, **kwargs):
        if ".old-" in os.path.basename(os.fspath(path)):
            os.kill(os.getpid(), signal.SIGINT)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(shutil, "rmtree", rmtree)
    target = AtomicDirectory(out)
    try:
        with target as tmp:
            (tmp / "new.txt").write_text("new")
            target.commit()
    except KeyboardInterrupt:
        pass
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]


def test_ctrl_c_after_the_rename_exits_0_with_the_new_output(
    tmp_path, capsys, monkeypatch, sigint_raises
):
    out = tmp_path / "o"
    assert main(["solve", "garnet-small", "--out", str(out), "--quiet"]) == 0
    _sigint_after_the_move_into_place(monkeypatch)
    assert main(["solve", "garnet-small", "--method", "pi", "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1
    assert err.startswith("lpbounds solve: interrupted after") and str(out) in err
    assert json.loads((out / "solution.json").read_text())["method"] == "pi"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]


# ---------------------------------------------------------------------- a model that is no file
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_a_fifo_as_the_model_is_refused_without_opening_it(tmp_path):
    fifo = tmp_path / "model.toml"
    os.mkfifo(fifo)
    proc = subprocess.run(  # a process of its own: opening the FIFO would block it
        [sys.executable, "-m", "lpbounds.cli.main", "solve", str(fifo)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().count("\n") == 0 and "Traceback" not in proc.stderr
    assert f"not a regular file: {str(fifo)!r}" in proc.stderr


# ---------------------------------------------------------------------- file modes
def _lpbounds(args: list[str], umask: int, cwd: Path) -> None:
    code = "import sys; sys.argv[0] = 'lpbounds'; from lpbounds.cli.main import entry; entry()"
    proc = subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        preexec_fn=lambda: os.umask(umask),
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]


@pytest.mark.parametrize("umask", [0o022, 0o027])
def test_every_command_writes_files_with_the_mode_open_would_give(tmp_path, umask):
    """verify --out wrote 0600 (mkstemp's mode, kept by the atomic rename) where the other
    commands wrote 0644: every file of every command gets 0666 less the umask, every
    folder 0777 less the umask, as a plain open() and mkdir() would."""
    verify = ["verify", "--random", "2", "--seed", "1", "--families", "garnet"]
    verify += ["--claims", "theorem1", "--solvers", "HIGHS", "-q"]
    _lpbounds([*verify, "--out", "v"], umask, tmp_path)
    _lpbounds(["solve", "garnet-small", "--out", "s", "--json", "s.json", "-q"], umask, tmp_path)
    _lpbounds(["bounds", "patrol-small", "--json", "b.json", "-q"], umask, tmp_path)
    files = [p for p in tmp_path.rglob("*") if p.is_file()]
    folders = [p for p in tmp_path.rglob("*") if p.is_dir()]
    assert {"s.json", "b.json", "solution.npz"} <= {p.name for p in files}
    assert len([p for p in files if p.is_relative_to(tmp_path / "v")]) >= 3
    modes = {str(p.relative_to(tmp_path)): oct(p.stat().st_mode & 0o777) for p in files}
    assert set(modes.values()) == {oct(0o666 & ~umask)}, modes
    dirs = {str(p.relative_to(tmp_path)): oct(p.stat().st_mode & 0o777) for p in folders}
    assert set(dirs.values()) == {oct(0o777 & ~umask)}, dirs


def test_an_existing_file_keeps_its_mode_when_rewritten(tmp_path):
    """As open(path, "w") would: a file the user made private stays private."""
    from lpbounds.outputs import write_text_atomic

    f = tmp_path / "stats.json"
    f.write_text("old")
    f.chmod(0o600)
    write_text_atomic(f, "new")
    assert f.read_text() == "new" and f.stat().st_mode & 0o777 == 0o600
    f.chmod(0o664)
    write_text_atomic(f, "newer")
    assert f.stat().st_mode & 0o777 == 0o664
