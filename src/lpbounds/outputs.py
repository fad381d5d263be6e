"""Outputs that are complete or absent: writability checks, atomic files and directories.

A command that writes a folder (``lpbounds reproduce --out DIR``) writes everything into a
temporary folder beside ``DIR`` and renames it into place only when every file is
written, with a ``manifest.json`` (file names, sizes, SHA-256, package version). Until
then a previous complete ``DIR`` is left untouched. A lock file beside ``DIR``
(``.DIR.lock``, created with ``O_EXCL``) keeps two runs from writing into one folder.
Ctrl-C (or any error) removes the temporary folder and the lock; the rename itself runs
with SIGINT blocked, so an interrupt cannot fall between its two steps.

Single files (``--json PATH``) are written to a temporary name in the same folder and
renamed over ``PATH``.

Every output folder and JSON file records how it was made: :func:`run_metadata` (the
lpbounds version and git commit, the versions of the dependencies and solvers, the
machine and the date) goes into ``manifest.json`` and into the files' own summaries.

Every check runs before any computation: :func:`check_output_file` and
:func:`check_output_dir` probe the folder that will receive the output by creating and
removing a temporary file there, which is the only reliable test (permission bits say
nothing for root, read-only mounts or ACLs).
"""

from __future__ import annotations

import contextlib
import fnmatch
import hashlib
import json
import os
import platform
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from .errors import OutputError

__all__ = [
    "MANIFEST",
    "AtomicDirectory",
    "check_output_dir",
    "check_output_file",
    "metadata_lines",
    "run_metadata",
    "write_text_atomic",
]

#: Name of the manifest inside a complete output folder.
MANIFEST = "manifest.json"

#: Packages whose versions every output records (``None`` when not installed).
DEPENDENCIES: tuple[str, ...] = ("numpy", "scipy", "cvxpy", "highspy", "clarabel", "numba")
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
    from . import __version__

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


def _probe_writable(folder: Path, what: str) -> None:
    """Create and remove a temporary file in ``folder``; OutputError if that fails."""
    if not folder.is_dir():
        raise OutputError(f"{what}: {str(folder)!r} is not a directory")
    try:
        fd, name = tempfile.mkstemp(prefix=".lpbounds-probe-", dir=folder)
    except OSError as exc:
        raise OutputError(
            f"{what}: cannot write into {str(folder)!r} ({exc.strerror or exc})"
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
    _probe_writable(_existing_ancestor(p.parent), what)
    return p


def check_output_dir(
    path: str | Path, what: str = "--out", replaceable: Sequence[str] = ("*",)
) -> Path:
    """Check, before any computation, that the folder ``path`` can be (re)written.

    An existing ``path`` must be a directory whose entries all match ``replaceable``
    (glob patterns of the files the command writes: a folder holding anything else is
    not replaced, so ``--out ~/Documents`` cannot delete a user's files); the folder that
    will hold it (or its nearest existing ancestor) must accept new entries. Nothing is
    created.

    Raises
    ------
    OutputError
        Naming ``what`` and the path (and the foreign entries).
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
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
    _probe_writable(_existing_ancestor(p.parent), what)
    return p


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename:
    ``path`` holds either its previous content or the new one, never a part."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return p


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@contextlib.contextmanager
def _sigint_blocked() -> Iterator[None]:
    """Hold SIGINT (delivered after the block) on the main thread, where POSIX allows."""
    can = (
        hasattr(signal, "pthread_sigmask") and threading.current_thread() is threading.main_thread()
    )
    if can:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        if can:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists but not ours
        return True
    return True


class AtomicDirectory:
    """A folder that appears complete (with a manifest) or not at all.

    ``with AtomicDirectory(out) as tmp:`` takes the lock ``.<name>.lock`` beside ``out``
    and gives a fresh temporary folder ``tmp`` beside it; write every file there and call
    :meth:`commit` at the end. Leaving the block without :meth:`commit` (an exception,
    Ctrl-C) deletes ``tmp`` and leaves ``out`` as it was; the lock is removed either way.

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
        self.lock = self.out.parent / f".{self.out.name}.lock"
        self.tmp: Path | None = None
        self.committed = False
        self._locked = False

    # ------------------------------------------------------------------ lock
    def _acquire(self) -> None:
        self.out.parent.mkdir(parents=True, exist_ok=True)
        for _ in range(2):
            try:
                fd = os.open(self.lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                holder = self._holder()
                if holder is not None and not _pid_alive(holder):
                    with contextlib.suppress(OSError):
                        os.unlink(self.lock)  # a run that was killed left it
                    continue
                raise OutputError(
                    f"--out {str(self.out)!r} is locked by another run "
                    f"(lock file {str(self.lock)!r}"
                    + (f", process {holder}" if holder is not None else "")
                    + "); wait for it, or delete the lock file if no such run is active"
                ) from None
            except OSError as exc:
                raise OutputError(
                    f"cannot create the lock file {str(self.lock)!r} ({exc.strerror or exc})"
                ) from exc
            with os.fdopen(fd, "w") as fh:
                fh.write(f"{os.getpid()}\n")
            self._locked = True
            return
        raise OutputError(f"cannot take the lock file {str(self.lock)!r}")  # pragma: no cover

    def _holder(self) -> int | None:
        try:
            return int(self.lock.read_text().split()[0])
        except (OSError, ValueError, IndexError):
            return None

    # ------------------------------------------------------------------ context
    def __enter__(self) -> Path:
        check_output_dir(self.out, replaceable=self.replaceable)
        self._acquire()
        try:
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
        try:
            if self.tmp is not None and self.tmp.exists():
                shutil.rmtree(self.tmp, ignore_errors=True)
        finally:
            self._release()

    def _release(self) -> None:
        if self._locked:
            with contextlib.suppress(OSError):
                os.unlink(self.lock)
            self._locked = False

    # ------------------------------------------------------------------ commit
    def manifest(self, extra: dict[str, Any] | None = None) -> dict[str, Any]:
        """Every file under the temporary folder (name, size in bytes, SHA-256) and the
        :func:`run_metadata` of the run (``environment``)."""
        from . import __version__

        assert self.tmp is not None, "manifest() outside the with-block"
        files = [
            {
                "name": p.relative_to(self.tmp).as_posix(),
                "bytes": p.stat().st_size,
                "sha256": _sha256(p),
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
        """Write ``manifest.json`` and move the folder into place; returns ``out``."""
        if self.tmp is None:
            raise OutputError("commit() outside the with-block")
        man = self.manifest(extra)
        (self.tmp / MANIFEST).write_text(json.dumps(man, indent=2) + "\n")
        for p in self.tmp.rglob("*"):  # on disk before the rename makes them visible
            if p.is_file():
                with p.open("rb") as fh:
                    os.fsync(fh.fileno())
        with _sigint_blocked():
            old: Path | None = None
            if self.out.exists():
                old = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.old-", dir=self.out.parent))
                os.replace(self.out, old / "out")
            os.replace(self.tmp, self.out)
            self.tmp = None
            self.committed = True
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        return self.out
