"""docs/interop.md runs: each ``##`` section's ``python`` blocks, in order, in a fresh namespace.

A section is skipped when a module its blocks import is not installed (pymdptoolbox,
QuantEcon, MDPSolver and Gymnasium are optional: the ecosystem's own section needs its
package), so the other sections still run. The blocks assert what the text says they
show (the round trips compare lpbounds' certified brackets with each package's own
solver). ``tests/project/test_docs.py`` leaves this page to this file.
"""

from __future__ import annotations

import ast
import importlib.util
import re
from pathlib import Path

import pytest

PAGE = Path(__file__).resolve().parents[3] / "docs" / "interop.md"
FENCE = re.compile(r"^```python[^\n]*\n(.*?)^```", re.S | re.M)

#: Each ecosystem's section (its heading starts so) and the module its round trip imports.
ECOSYSTEMS = {
    "pymdptoolbox": "mdptoolbox",
    "QuantEcon": "quantecon",
    "MDPSolver": "mdpsolver",
    "Gymnasium": "gymnasium",
}


def sections() -> dict[str, list[str]]:
    """``## heading`` -> the python blocks of that section (its ``###`` subsections too)."""
    out: dict[str, list[str]] = {}
    for chunk in re.split(r"^## ", PAGE.read_text(), flags=re.M)[1:]:
        heading, _, body = chunk.partition("\n")
        out[heading.strip()] = FENCE.findall(body)
    return out


def imported_roots(code: str) -> set[str]:
    """The top-level packages a block imports."""
    roots = set()
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, ast.Import):
            roots |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            roots.add(node.module.split(".")[0])
    return roots


SECTIONS = sections()


def test_one_section_per_ecosystem_with_a_round_trip():
    for prefix, module in ECOSYSTEMS.items():
        heading = next((h for h in SECTIONS if h.startswith(prefix)), None)
        assert heading is not None, f"docs/interop.md has no section on {prefix}"
        blocks = SECTIONS[heading]
        assert any(module in imported_roots(b) for b in blocks), f"{heading}: no {module} block"
    text = PAGE.read_text()
    assert text.count("### Round trip") >= len(ECOSYSTEMS)


def test_every_block_is_in_a_section():
    assert sum(len(b) for b in SECTIONS.values()) == len(FENCE.findall(PAGE.read_text()))


@pytest.mark.parametrize("heading", list(SECTIONS))
def test_section_code_runs(heading, tmp_path, monkeypatch, capsys):
    blocks = SECTIONS[heading]
    if not blocks:
        pytest.skip("no code")
    missing = sorted(
        root
        for root in set().union(*map(imported_roots, blocks))
        if importlib.util.find_spec(root) is None
    )
    if missing:
        pytest.skip(f"not installed: {', '.join(missing)}")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "docs_interop"}
    for k, block in enumerate(blocks):
        exec(compile(block, f"interop.md[{heading}, block {k}]", "exec"), namespace)


def test_the_sink_table_is_what_its_block_asserts():
    """The table of "Partitions: the sink in a set of its own" shows the figures its block
    computes and asserts (``assert rows == {...}``; the block runs in the Gymnasium
    section above), so the page's table cannot drift from the run."""
    text = PAGE.read_text()
    part = text[text.index("### Partitions: the sink in a set of its own") :]
    part = part[: part.index("\n## ")]
    table = {
        cells[0].split(",")[0].strip().lower(): tuple(c.strip() for c in cells[1:])
        for line in part.splitlines()
        if line.startswith("| ") and not line.startswith("| model")
        for cells in [line.strip().strip("|").split("|")]
    }
    asserted = re.search(r"^assert rows == (\{.*?^\})", part, re.S | re.M)
    assert asserted, "the block asserts no table"
    assert table == ast.literal_eval(asserted.group(1))
