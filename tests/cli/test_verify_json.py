"""``lpbounds verify --json PATH`` is checked before any computation (issue 40's outputs:
an unwritable path failed after the whole run, as "No such file or directory")."""

from __future__ import annotations

import os

import pytest

import lpbounds.studies.verify as verify
from lpbounds.cli.main import main


def _never(*args, **kwargs):
    raise AssertionError("computed before the output was checked")


@pytest.mark.parametrize(
    ("path", "message"),
    [
        pytest.param(
            "/proc/forbidden/records.json",
            "--json: cannot create '/proc/forbidden/records.json'",
            marks=pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="Linux's /proc"),
        ),
        (".", "--json: '.' is a directory, not a file"),
    ],
)
def test_an_unwritable_json_is_refused_before_the_run(path, message, monkeypatch, capsys):
    monkeypatch.setattr(verify, "verify_instance", _never)
    monkeypatch.setattr(verify, "verify_remark2", _never)
    argv = ["verify", "garnet-small", "--random", "0", "--solvers", "HIGHS", "--json", path]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err


def test_write_json_replaces_the_file_whole_or_not_at_all(tmp_path, monkeypatch):
    """The records file holds the old list or the new one, never a part, with the mode
    every other output of lpbounds gets (0666 less the umask)."""
    import json

    from lpbounds.studies.verify import write_json

    path = tmp_path / "records.json"
    write_json([{"check": "Lemma 1", "width": 0.5}], path)
    assert json.loads(path.read_text()) == [{"check": "Lemma 1", "width": 0.5}]
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask

    def full_disk(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", full_disk)  # the new list fails on its way to the disk
    with pytest.raises(OSError, match="No space"):
        write_json([{"check": "Theorem 2", "width": 0.25}], path)
    assert json.loads(path.read_text()) == [{"check": "Lemma 1", "width": 0.5}]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["records.json"]  # no temporary
