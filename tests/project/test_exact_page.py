"""docs/exact.md's numbers, each against where it comes from: the limits table and prose
against the table ``benchmarks/bench_exact.py`` wrote into docs/benchmarks.md (timings are
never re-measured here, only copied faithfully), the checker's length against the file,
the default size limit against lpbounds.tolerances, taxi's components against a strongly
connected components count done here with scipy; and the 200-instance campaign section of
docs/benchmarks.md against its own table and the checker it names."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

import lpbounds as lb
from lpbounds.model.instances import load_instance
from lpbounds.tolerances import EXACT_MAX_VARIABLES

ROOT = Path(__file__).resolve().parents[2]
PAGE = (ROOT / "docs" / "exact.md").read_text()
BENCH = (ROOT / "docs" / "benchmarks.md").read_text()
CHECKER = ROOT / "src" / "lpbounds" / "exact" / "check.py"


def _section(name: str) -> str:
    m = re.search(rf"<!-- {name}:start -->(.*?)<!-- {name}:end -->", BENCH, re.S)
    assert m, f"docs/benchmarks.md has no {name} section"
    return m.group(1)


def _bench_rows() -> dict[str, list[str]]:
    """docs/benchmarks.md's exact-arithmetic table, by model."""
    out = {}
    for line in _section("exact").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 14 and cells[0] not in ("model", "---"):
            out[cells[0]] = cells
    return out


def _seconds(cell: str) -> float:
    return float(cell.removesuffix(" s"))


def _rounds_to(shown: str, value: float) -> bool:
    """Whether ``shown`` (a number as the page writes it) is ``value`` rounded to the
    digits shown (a half-unit either way: the table's value is itself rounded)."""
    digits = len(shown.partition(".")[2])
    return abs(float(shown) - value) <= 0.5 * 10.0**-digits + 0.005


def test_the_limits_table_is_the_benchmarks():
    rows = _bench_rows()
    m = re.search(r"\| states \|(.*?)\|\n\|---.*?\n\| exact `V\*` \|(.*?)\|\n\| bits of the common "
                  r"denominator \|(.*?)\|\n", PAGE)  # fmt: skip
    assert m, "docs/exact.md has no limits table"
    states, times, bits = ([c.strip() for c in g.split("|")] for g in m.groups())
    assert len(states) == len(times) == len(bits) >= 4
    for n, t, b in zip(states, times, bits, strict=True):
        row = rows[f"garnet {n}"]
        assert _rounds_to(t.removesuffix(" s"), _seconds(row[3])), (n, t, row[3])
        assert b == row[6], (n, b, row[6])
    shown = [int(n) for n in states]
    floats = [_seconds(rows[f"garnet {n}"][2]) * 1000 for n in shown]
    lo, hi = re.search(r"a float solve of (\d+)-(\d+) ms", PAGE).groups()
    assert round(min(floats)) == int(lo) and round(max(floats)) == int(hi)
    peak = re.search(r"memory stayed under (\d+) MB", PAGE).group(1)
    assert max(float(rows[f"garnet {n}"][4].split()[0]) for n in shown) < int(peak)
    patrol = rows["patrol-small"]
    m = re.search(r"patrol-small \((\d+) states\)\s+takes ([\d.]+) s, its RLP \((\d+) "
                  r"partitions\) ([\d.]+) s", PAGE)  # fmt: skip
    assert (m.group(1), m.group(3)) == (patrol[1], patrol[8])
    assert _rounds_to(m.group(2), _seconds(patrol[3]))
    assert _rounds_to(m.group(4), _seconds(patrol[10]))
    m = re.search(r"took ([\d.]+) s at (\d+) states and ([\d.]+) s at (\d+)", PAGE)
    for t, n in (m.group(1, 2), m.group(3, 4)):
        assert _rounds_to(t, _seconds(rows[f"garnet {n}"][10])), (n, t)
    at_limit = _seconds(rows[f"garnet {EXACT_MAX_VARIABLES}"][3])
    assert re.search(r"about half\s+a minute at the limit", PAGE) and 20 <= at_limit <= 45


def test_the_default_limit_and_the_checkers_length():
    assert f"EXACT_MAX_VARIABLES = {EXACT_MAX_VARIABLES}`" in PAGE
    lines = len(CHECKER.read_text().splitlines())
    m = re.search(r"`lpbounds\.exact\.check` \((\d+) lines", PAGE)
    assert m and int(m.group(1)) == lines
    about = re.search(r"this file, about (\d+) lines", CHECKER.read_text())
    assert about and abs(int(about.group(1)) - lines) <= 0.05 * lines


def test_taxis_policy_graph_is_501_components_of_one_state():
    mdp = load_instance(str(ROOT / "models" / "taxi.toml")).mdp()
    m = re.search(r"splits its (\d+)\s+states into (\d+) components of one state each", PAGE)
    assert m and int(m.group(1)) == mdp.n_states == int(m.group(2))
    pol = np.asarray(lb.solve_exact(mdp).policy)
    n = mdp.n_states
    succ = mdp.successors[np.arange(n), pol]
    if mdp.shared_probabilities:
        p = np.broadcast_to(mdp.probabilities, succ.shape)
    else:
        p = mdp.probabilities[np.arange(n), pol]
    keep = p.ravel() != 0
    rows = np.repeat(np.arange(n), succ.shape[1])[keep]
    g = sp.csr_matrix((np.ones(keep.sum()), (rows, succ.ravel()[keep])), shape=(n, n))
    k, labels = connected_components(g, directed=True, connection="strong")
    assert k == n and np.bincount(labels).max() == 1


def test_the_campaign_section_adds_up():
    text = _section("exact-campaign")
    cells = dict(
        (c[0], c[1])
        for c in (
            [x.strip() for x in line.strip().strip("|").split("|")]
            for line in text.splitlines()
            if line.startswith("| ") and not line.startswith("| |")
        )
        if len(c) == 2
    )

    def num(s: str) -> int:
        return int(s.replace(",", ""))

    records = num(cells["records"])
    verdicts = [num(t) for t in cells[
        "exact verdicts: holds / violated / inconclusive / errors"].split(" / ")]  # fmt: skip
    assert sum(verdicts) == records and verdicts[1:] == [0, 0, 0]
    decided = re.match(r"([\d,]+), every one the exact verdict \(0 disagreements\)",
                       cells["float verdicts decided (holds or violated)"])  # fmt: skip
    inconclusive = num(cells["float verdicts inconclusive, decided exactly"])
    assert decided and num(decided.group(1)) + inconclusive == records
    assert cells["certified brackets that missed their exact optimum"] == "0"
    m = re.match(r"([\d,]+), all ([\d,]+) accepted by the checker \((\d+) lines",
                 cells["certificates"])  # fmt: skip
    assert m and m.group(1) == m.group(2)
    assert int(m.group(3)) == len(CHECKER.read_text().splitlines())
    n = int(re.search(r"a (\d+)-instance campaign", text).group(1))
    assert num(cells["instances"].split()[0]) == n
    assert f"--random {n} " in text


@pytest.mark.parametrize("word", ["float_verdict", "exact_difference", "inside_bracket",
                                  "exact_error", "exact_value_error", "certificate"])  # fmt: skip
def test_every_exact_column_is_explained(word):
    from lpbounds.studies.verify import EXACT_COLUMNS

    assert word in EXACT_COLUMNS
    assert f"| `{word}` |" in PAGE
