"""IB's number of blocks L: sizes it implies are checked before anything is allocated."""

from __future__ import annotations

import os
import re

import numpy as np
import pytest

import lpbounds as lb
from lpbounds.errors import ValidationError
from lpbounds.formulations import IB


def _model():
    mdp = lb.garnet(12, 2, 2, 0.9, seed=4)
    return mdp, lb.random_partition(12, 3, seed=4)


def _fake_memory(monkeypatch, n_bytes):
    """Make ``SC_PHYS_PAGES * SC_PAGE_SIZE`` report ``n_bytes`` (pages of 4096 bytes)."""
    real = os.sysconf

    def sysconf(name):
        if name == "SC_PHYS_PAGES":
            return n_bytes // 4096
        if name == "SC_PAGE_SIZE":
            return 4096
        return real(name)

    monkeypatch.setattr(os, "sysconf", sysconf)


@pytest.mark.parametrize("L", [10**9, 10**15, 2**70])
def test_huge_L_is_refused_before_allocation(L):
    # 10**9 used to raise a raw MemoryError (numpy asking for 149 GiB); 2**70 an
    # OverflowError from numpy. Each is beyond any machine's memory.
    mdp, part = _model()
    with pytest.raises(ValidationError, match=rf"L = {L}: IB's .* need [\d,]+ bytes"):
        IB(mdp, part, L)


def test_the_message_names_L_the_bytes_needed_and_available(monkeypatch):
    mdp, part = _model()
    _fake_memory(monkeypatch, 2**14)  # 16 KiB
    with pytest.raises(ValidationError) as info:
        IB(mdp, part, 200)
    msg = str(info.value)
    needed, available = (int(x.replace(",", "")) for x in re.findall(r"([\d,]{5,}) bytes", msg))
    assert msg.startswith("L = 200: ")
    assert available == 2**14 and needed > available
    # the estimate is a lower bound: at least the L copies of the rows' targets
    rows = lb.BellmanRows.aggregate(mdp, part, reduce="max")
    assert needed >= 200 * rows.targets.size * 8
    assert "of memory" in msg


def test_a_small_L_still_builds_and_solves(monkeypatch):
    mdp, part = _model()
    _fake_memory(monkeypatch, 2**30)
    ib = IB(mdp, part, np.int64(3))
    assert ib.L == 3 and ib.rows.n_vars == 3 * part.n_partitions
    res = ib.solve("HIGHS")
    np.testing.assert_allclose(res.extra["blocks"], ib.fixed_point(), rtol=1e-6, atol=1e-6)


def test_without_sysconf_only_the_size_rule_applies(monkeypatch):
    # a platform without os.sysconf (Windows): no memory figure, L is still an integer >= 1
    mdp, part = _model()
    monkeypatch.delattr(os, "sysconf")
    assert IB(mdp, part, 2).L == 2
    for bad in (0, True, 2.0):
        with pytest.raises(ValidationError, match="L must be an integer >= 1"):
            IB(mdp, part, bad)
