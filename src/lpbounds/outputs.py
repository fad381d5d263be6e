"""Outputs that are complete or absent: writability checks, atomic files and directories.

A command that writes a folder (``lpbounds reproduce --out DIR``) writes everything into a
temporary folder beside ``DIR`` and renames it into place only when every file is
written, with a ``manifest.json`` (file names, sizes, SHA-256, package version). Until
then a previous complete ``DIR`` is left untouched. A lock file beside ``DIR``
(``.DIR.lock``, created with ``O_EXCL``) keeps two runs from writing into one folder.

One rule decides what an interruption means. **Before** the rename of the new folder into
place, Ctrl-C (or any error) removes the temporary folder and the lock and leaves ``DIR``
exactly as it was (the command line exits 130). **Once** the rename has happened the run
is committed: the commit (moving a previous ``DIR`` aside, renaming the new folder into
place, removing the previous copy and the lock) runs with SIGINT held, so nothing is
left beside ``DIR`` whenever Ctrl-C comes; the held KeyboardInterrupt is raised after the
commit, and the command line, seeing :func:`committed_outputs`, exits 0.

Single files (``--json PATH``) are written to a temporary name in the same folder and
renamed over ``PATH``.

Every output folder and JSON file records how it was made: :func:`run_metadata` (the
lpbounds version and git commit, the versions of the dependencies and solvers, the
machine and the date) goes into ``manifest.json`` and into the files' own summaries.

Every check runs before any computation: :func:`check_output_file` and
:func:`check_output_dir` probe the folder that will receive the output by creating and
removing a temporary file there, and :func:`check_output_dir` takes the lock for a moment
and moves an existing ``DIR`` aside and back (what its replacement will do), which are
the only reliable tests (permission bits say nothing for root, read-only mounts, ACLs,
immutable folders, mount points or sticky folders).
"""

from __future__ import annotations

import contextlib
import fnmatch
import hashlib
import json
import os
import platform
import secrets
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from .errors import OutputError

__all__ = [
    "MANIFEST",
    "AtomicDirectory",
    "check_output_dir",
    "check_output_file",
    "committed_outputs",
    "file_sha256",
    "metadata_lines",
    "run_metadata",
    "write_atomic",
    "write_text_atomic",
]

#: Name of the manifest inside a complete output folder.
MANIFEST = "manifest.json"

#: Packages whose versions every output records (``None`` when not installed).
DEPENDENCIES: tuple[str, ...] = ("numpy", "scipy", "cvxpy", "highspy", "clarabel")
#: Solver packages (beyond the dependencies) whose versions every output records.
SOLVER_PACKAGES: tuple[str, ...] = ("scs", "ecos", "osqp", "gurobipy", "mosek", "cylp")


def _dist_version(name: str) -> str | None:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return None


def _git(*args: str) -> str | None:
    """``git args`` in the folder of this source file; None outside a checkout or on error."""
    try:
        proc = subprocess.run(
            ["git", *args],
            cwd=Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return proc.stdout.strip() if proc.returncode == 0 else None


def git_commit() -> dict[str, Any] | None:
    """The commit lpbounds runs from and whether tracked files differ from it; None when
    it is not a git checkout (an installed wheel)."""
    top = _git("rev-parse", "--show-toplevel")
    if top is None or not (Path(top) / "src" / "lpbounds").is_dir():
        return None  # a checkout of something else that happens to hold site-packages
    commit = _git("rev-parse", "HEAD")
    if commit is None:
        return None
    changed = _git("status", "--porcelain", "--untracked-files=no")
    return {"commit": commit, "modified": None if changed is None else bool(changed)}


def _machine() -> dict[str, Any]:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next(
                (ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name")), cpu
            )
    except OSError:
        pass
    try:
        memory_gb: float | None = round(
            os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1
        )
    except (ValueError, OSError, AttributeError):
        memory_gb = None
    return {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "cpu": cpu,
        "cpus": os.cpu_count(),
        "memory_gb": memory_gb,
    }


def run_metadata() -> dict[str, Any]:
    """How an output was made: lpbounds' version and git commit (``None`` outside a
    checkout), Python, the dependencies' and solvers' versions, the machine and the date.

    Imports nothing heavy (versions come from the installed package metadata), so a
    command that never touched cvxpy does not pay for it here. The HiGHS library is the
    one bundled in ``highspy`` (same version number).
    """
    from ._defaults import VERSION as __version__

    return {
        "lpbounds": __version__,
        "git": git_commit(),
        "python": platform.python_version(),
        "dependencies": {name: _dist_version(name) for name in DEPENDENCIES},
        "solvers": {
            name: v
            for name in ("highspy", "clarabel", "scipy", *SOLVER_PACKAGES)
            if (v := _dist_version(name)) is not None
        },
        "machine": _machine(),
        "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def metadata_lines(meta: dict[str, Any]) -> list[str]:
    """:func:`run_metadata` as short human-readable lines (for reports)."""
    git = meta.get("git")
    where = (
        "not a git checkout"
        if not git
        else f"git commit {git['commit'][:12]}" + (" (modified)" if git.get("modified") else "")
    )
    deps = ", ".join(f"{k} {v}" for k, v in meta["dependencies"].items() if v)
    solvers = ", ".join(f"{k} {v}" for k, v in meta["solvers"].items())
    m = meta["machine"]
    mem = f", {m['memory_gb']} GB" if m.get("memory_gb") else ""
    return [
        f"lpbounds {meta['lpbounds']} ({where}), Python {meta['python']}",
        f"dependencies: {deps}",
        f"solvers: {solvers}",
        f"machine: {m['cpu']}, {m['cpus']} CPUs{mem}, {m['platform']}",
        f"date: {meta['date']}",
    ]


def _existing_ancestor(path: Path) -> Path:
    """The nearest ancestor of ``path`` (or ``path``) that exists."""
    p = path.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _refusal(folder: Path, exc: OSError) -> str:
    """Why ``folder`` refused a new entry, in words that name the folder: the error's own
    text misleads where a virtual file system refuses with ENOENT (``/proc``: "No such
    file or directory" about a folder that exists)."""
    import errno

    where = f"the folder {str(folder)!r}"
    if exc.errno in (errno.EACCES, errno.EPERM):
        return f"{where} is not writable (permission denied)"
    if exc.errno == errno.EROFS:
        return f"{where} is on a read-only file system"
    if exc.errno in (errno.ENOENT, errno.ENOTDIR) and folder.is_dir():
        return f"{where} accepts no new entries (its file system refuses them)"
    return f"{where} refused a new entry ({exc.strerror or exc})"


def _probe_writable(folder: Path, what: str, target: Path) -> None:
    """Create and remove a temporary file in ``folder``, where ``target`` is to be made;
    OutputError naming ``target`` and the folder's reason if that fails."""
    if not folder.is_dir():
        raise OutputError(f"{what}: {str(folder)!r} is not a directory")
    try:
        fd, name = tempfile.mkstemp(prefix=".lpbounds-probe-", dir=folder)
    except OSError as exc:
        raise OutputError(
            f"{what}: cannot create {str(target)!r}: {_refusal(folder, exc)}"
        ) from exc
    os.close(fd)
    os.unlink(name)


def check_output_file(path: str | Path, what: str = "output") -> Path:
    """Check, before any computation, that the file ``path`` can be written.

    It must not be a directory, and its folder (or the nearest existing ancestor, when
    folders are still to be created) must accept a new file. Nothing is left behind.

    Raises
    ------
    OutputError
        Naming ``what`` (e.g. ``"--json"``) and the path.
    """
    p = Path(path)
    if p.is_dir():
        raise OutputError(f"{what}: {str(p)!r} is a directory, not a file")
    _probe_writable(_existing_ancestor(p.parent), what, p)
    return p


def _check_dir(p: Path, what: str, replaceable: Sequence[str]) -> None:
    """The checks of :func:`check_output_dir` that create nothing and touch no lock."""
    if os.path.lexists(p) and not p.is_dir():
        raise OutputError(f"{what}: {str(p)!r} exists and is not a directory")
    if p.is_dir():
        foreign = sorted(
            e.name
            for e in p.iterdir()
            if not any(fnmatch.fnmatchcase(e.name, pat) for pat in replaceable) or e.is_dir()
        )
        if foreign:
            shown = ", ".join(foreign[:5]) + (" ..." if len(foreign) > 5 else "")
            raise OutputError(
                f"{what}: {str(p)!r} holds {len(foreign)} entries this command does not write "
                f"({shown}); it replaces the folder as a whole, so give a new or empty folder"
            )
    _probe_writable(_existing_ancestor(p.parent), what, p)


def check_output_dir(
    path: str | Path, what: str = "--out", replaceable: Sequence[str] = ("*",)
) -> Path:
    """Check, before any computation, that the folder ``path`` can be (re)written.

    An existing ``path`` must be a directory whose entries all match ``replaceable``
    (glob patterns of the files the command writes: a folder holding anything else is
    not replaced, so ``--out ~/Documents`` cannot delete a user's files) and that can be
    moved (it is moved aside and back, with its lock held and SIGINT held: an immutable
    folder, a mount point or another user's folder in a sticky one cannot); the folder
    that will hold it (or its nearest existing ancestor) must accept new entries; and no
    other live run may hold its lock. Nothing is left behind.

    Raises
    ------
    OutputError
        Naming ``what`` and the path (and the foreign entries, or the lock).
    """
    p = Path(os.path.abspath(path))
    _check_dir(p, what, replaceable)
    if p.parent.is_dir():
        lock = _take_lock(p, what)
        try:
            if p.is_dir():
                _probe_movable(p, what)
        finally:
            _drop_lock(lock)
    return Path(path)


def write_atomic(path: str | Path, write: Callable[[Path], Any]) -> Path:
    """Make ``path`` through a temporary file in the same folder and a rename: ``write(tmp)``
    fills the temporary file (any writer that takes a path: ``DataFrame.to_parquet``, ...),
    then it replaces ``path``, which holds either its previous content or the new one, never
    a part. If ``write`` raises, the temporary file is removed and ``path`` is untouched."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    try:
        # mkstemp's 0600 is for temporaries: the file gets the mode a plain open() would
        # give it (an existing file's own, else 0666 less the umask)
        os.fchmod(fd, _file_mode(p))
    finally:
        os.close(fd)
    try:
        write(Path(tmp))
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return p


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (:func:`write_atomic`), flushed to the disk
    before the rename."""

    def write(tmp: Path) -> None:
        with open(tmp, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())

    return write_atomic(path, write)


def file_sha256(path: Path) -> str:
    """The SHA-256 hex digest of a file's bytes, read in 1 MiB blocks.

    Parameters
    ----------
    path : pathlib.Path
        The file.

    Returns
    -------
    str
        64 lowercase hex digits, as recorded in manifests and provenance.
    """
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


class _HeldSigint:
    """Hold SIGINT during a ``with`` block and hand a Ctrl-C received meanwhile to the
    previous handler at its end (a KeyboardInterrupt, by default), so that the block's
    file operations all happen. Python handles signals on the main thread only, so
    elsewhere (and when SIGINT is ignored) this does nothing."""

    def __enter__(self) -> _HeldSigint:
        self.held = False
        self._previous: Any = None
        if threading.current_thread() is threading.main_thread():
            previous = signal.getsignal(signal.SIGINT)
            if previous not in (signal.SIG_IGN, None):
                self._previous = previous
                signal.signal(signal.SIGINT, self._hold)
        return self

    def _hold(self, signum: int, frame: Any) -> None:
        self.held = True

    def __exit__(self, *exc: object) -> None:
        previous, self._previous = self._previous, None
        if previous is None:
            return
        signal.signal(signal.SIGINT, previous)
        if self.held:
            if callable(previous):
                previous(signal.SIGINT, None)
            else:  # SIG_DFL: end the process as that SIGINT would have
                signal.raise_signal(signal.SIGINT)


def _umask() -> int:
    """The process's umask: read from /proc where the kernel shows it (Linux), else set
    and restored at once (a file another thread creates in between would miss it)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _file_mode(path: Path) -> int:
    """The permission bits ``open(path, "w")`` would leave on ``path``: an existing file's
    own, else ``0o666`` less the umask."""
    import stat

    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        return 0o666 & ~_umask()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists but not ours
        return True
    return True


# ---------------------------------------------------------------------- lock, moves
def _lock_path(out: Path) -> Path:
    return out.parent / f".{out.name}.lock"


def _lock_holder(lock: Path) -> int | None:
    try:
        return int(lock.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def _take_lock(out: Path, what: str = "--out") -> Path:
    """Create ``.NAME.lock`` beside ``out`` (``O_EXCL``, holding this process id); a lock
    left by a process that no longer exists is taken over. OutputError when another run
    holds it or it cannot be created."""
    lock = _lock_path(out)
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            holder = _lock_holder(lock)
            if holder is not None and not _pid_alive(holder):
                with contextlib.suppress(OSError):
                    os.unlink(lock)  # a run that was killed left it
                continue
            raise OutputError(
                f"{what} {str(out)!r} is locked by another run (lock file {str(lock)!r}"
                + (f", process {holder}" if holder is not None else "")
                + "); wait for it, or delete the lock file if no such run is active"
            ) from None
        except OSError as exc:
            raise OutputError(
                f"cannot create the lock file {str(lock)!r} ({exc.strerror or exc})"
            ) from exc
        with os.fdopen(fd, "w") as fh:
            fh.write(f"{os.getpid()}\n")
        return lock
    raise OutputError(f"cannot take the lock file {str(lock)!r}")  # pragma: no cover


def _drop_lock(lock: Path) -> None:
    with contextlib.suppress(OSError):
        os.unlink(lock)


def _aside(out: Path) -> Path:
    """A free name beside ``out`` to move it to: ``.NAME.old-XXXXXXXX``."""
    while True:
        p = out.parent / f".{out.name}.old-{secrets.token_hex(4)}"
        if not os.path.lexists(p):
            return p


def _remove(path: Path) -> None:
    """Delete ``path`` (a folder, or a symbolic link: ``--out`` may have been one)."""
    if path.is_symlink() or not path.is_dir():
        with contextlib.suppress(OSError):
            os.unlink(path)
    else:
        shutil.rmtree(path, ignore_errors=True)


def _probe_movable(out: Path, what: str) -> None:
    """Move ``out`` aside and back, as its replacement will (OutputError if it cannot be
    moved). Run with the lock held and SIGINT held, so ``out`` is back before Ctrl-C acts."""
    aside = _aside(out)
    with _HeldSigint():
        try:
            os.replace(out, aside)
        except OSError as exc:
            raise OutputError(
                f"{what}: {str(out)!r} cannot be replaced: moving it aside fails "
                f"({exc.strerror or exc}); give another folder"
            ) from exc
        try:
            os.replace(aside, out)
        except OSError as exc:  # pragma: no cover - the folder was just moved from there
            raise OutputError(
                f"{what}: {str(out)!r} was moved to {str(aside)!r} to test that it can be "
                f"replaced and cannot be moved back ({exc.strerror or exc}); move it back"
            ) from exc


#: Output folders this process has committed (renamed into place), oldest first.
_COMMITTED: list[Path] = []


def committed_outputs() -> tuple[Path, ...]:
    """The folders :meth:`AtomicDirectory.commit` has renamed into place in this process,
    oldest first: a Ctrl-C after a command's commit ends a completed run (the command
    line compares this before and after a command and exits 0)."""
    return tuple(_COMMITTED)


class AtomicDirectory:
    """A folder that appears complete (with a manifest) or not at all.

    ``with AtomicDirectory(out) as tmp:`` takes the lock ``.<name>.lock`` beside ``out``,
    checks that an existing ``out`` can be moved, and gives a fresh temporary folder
    ``tmp`` beside it; write every file there and call :meth:`commit` at the end. Leaving
    the block without :meth:`commit` (an exception, Ctrl-C) deletes ``tmp`` and leaves
    ``out`` as it was; the lock is removed either way.

    Parameters
    ----------
    out : path
        The final folder; an existing one is replaced as a whole on :meth:`commit`.
    replaceable : sequence of str
        Glob patterns of the names an existing ``out`` may hold: a folder with any other
        entry (or a subfolder) is refused before anything is written.
    """

    def __init__(self, out: str | Path, replaceable: Sequence[str] = ("*",)) -> None:
        self.out = Path(os.path.abspath(out))
        self.replaceable = tuple(replaceable)
        self.lock = _lock_path(self.out)
        self.tmp: Path | None = None
        self.committed = False
        self._locked = False

    # ------------------------------------------------------------------ context
    def __enter__(self) -> Path:
        _check_dir(self.out, "--out", self.replaceable)
        self.out.parent.mkdir(parents=True, exist_ok=True)
        _take_lock(self.out)
        self._locked = True
        try:
            if self.out.is_dir():
                _probe_movable(self.out, "--out")
            self.tmp = Path(
                tempfile.mkdtemp(prefix=f".{self.out.name}.partial-", dir=self.out.parent)
            )
            os.chmod(self.tmp, 0o777 & ~_umask())  # mkdtemp's 0700 is for temporaries
        except BaseException:
            self._release()
            raise
        return self.tmp

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        with _HeldSigint():  # a second Ctrl-C does not leave half of tmp behind
            try:
                if self.tmp is not None and self.tmp.exists():
                    shutil.rmtree(self.tmp, ignore_errors=True)
            finally:
                self._release()

    def _release(self) -> None:
        if self._locked:
            _drop_lock(self.lock)
            self._locked = False

    # ------------------------------------------------------------------ commit
    def manifest(self, extra: dict[str, Any] | None = None) -> dict[str, Any]:
        """Every file under the temporary folder (name, size in bytes, SHA-256) and the
        :func:`run_metadata` of the run (``environment``)."""
        from ._defaults import VERSION as __version__

        assert self.tmp is not None, "manifest() outside the with-block"
        files = [
            {
                "name": p.relative_to(self.tmp).as_posix(),
                "bytes": p.stat().st_size,
                "sha256": file_sha256(p),
            }
            for p in sorted(self.tmp.rglob("*"))
            if p.is_file() and p.name != MANIFEST
        ]
        return {
            "package": "lpbounds",
            "version": __version__,
            "created": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
            "environment": run_metadata(),
            **(extra or {}),
            "files": files,
        }

    def commit(self, extra: dict[str, Any] | None = None) -> Path:
        """Write ``manifest.json`` and move the folder into place; returns ``out``.

        The moves, the removal of the previous copy and of the lock run with SIGINT held:
        once the new folder is in place the run is committed and nothing is left beside
        it; a Ctrl-C received meanwhile is raised (KeyboardInterrupt) after all that. If
        the new folder cannot be moved into place, the previous ``out`` is put back
        (OutputError).
        """
        if self.tmp is None:
            raise OutputError("commit() outside the with-block")
        man = self.manifest(extra)
        (self.tmp / MANIFEST).write_text(json.dumps(man, indent=2) + "\n")
        for p in self.tmp.rglob("*"):  # on disk before the rename makes them visible
            if p.is_file():
                with p.open("rb") as fh:
                    os.fsync(fh.fileno())
        with _HeldSigint():
            old = self._move_into_place()
            self.tmp = None
            self.committed = True
            _COMMITTED.append(self.out)
            if old is not None:
                _remove(old)
            self._release()
        return self.out

    def _move_into_place(self) -> Path | None:
        """Move a previous ``out`` aside and the new folder to ``out``; returns where the
        previous one went. On failure the previous one is moved back (OutputError)."""
        assert self.tmp is not None
        old = _aside(self.out) if os.path.lexists(self.out) else None
        try:
            if old is not None:
                os.replace(self.out, old)
            os.replace(self.tmp, self.out)
        except OSError as exc:
            where = "is unchanged"
            if old is not None and os.path.lexists(old):
                try:
                    os.replace(old, self.out)
                except OSError:
                    where = f"is in {str(old)!r}"
            raise OutputError(
                f"--out {str(self.out)!r}: the new output cannot be moved into place "
                f"({exc.strerror or exc}); the previous output {where}"
            ) from exc
        return old
