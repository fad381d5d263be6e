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
