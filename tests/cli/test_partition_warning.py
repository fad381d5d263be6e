"""On the command line a partition that mixes the sink with live states is said once, as
one log line (``lpbounds: WARNING: partition: ...``), not as a Python warning repeated for
every formulation built (issue 40, item 4)."""

from __future__ import annotations

import warnings

import pytest

from lpbounds.cli.main import main

MIXED = """\
[model]
kind = "gymnasium"
env_id = "FrozenLake-v1"
kwargs = { map_name = "4x4", is_slippery = true }
discount = 0.99

[partition]
kind = "labels"        # the sink (state 16) in set 3 with states 10, 11, 14 and 15
labels = [0, 0, 1, 1, 0, 0, 1, 1, 2, 2, 3, 3, 2, 2, 3, 3, 3]
"""


@pytest.mark.parametrize("quiet", [False, True])
def test_verify_says_a_mixed_partition_once(quiet, tmp_path, capsys):
    pytest.importorskip("gymnasium")
    model = tmp_path / "mixed.toml"
    model.write_text(MIXED)
    filters = list(warnings.filters)
    argv = ["verify", str(model), "--random", "0", "--solvers", "HIGHS"]
    assert main([*argv, *(["-q"] if quiet else [])]) == 0
    err = capsys.readouterr().err
    said = [ln for ln in err.splitlines() if "holds the sink" in ln]
    if quiet:
        assert said == [], err
    else:
        assert len(said) == 1, err
        assert said[0].startswith(
            "lpbounds: WARNING: partition: block 3 holds the sink (state 16, worth 0) and 4 "
            "live states"
        )
    assert "PartitionWarning" not in err
    assert warnings.filters == filters  # the command leaves the host's filters alone
