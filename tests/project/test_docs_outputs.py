"""The outputs printed in the docs are what their code prints.

A page under ``docs/`` may follow a ``python`` block with a block fenced as
```` ```text title="Output" ````: the output it shows. Every page with such blocks is
executed here, block by block in one namespace (as ``tests/project/test_docs.py`` does), with the
output of each block captured and compared with the block shown under it: the text
exactly (whitespace aside), every number to a relative ``1e-4`` (the pages print 4
significant digits), and a number below ``1e-6`` (a residual, an error bound) only as
below ``1e-6``.
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
BLOCK = re.compile(r"^```(?P<info>[^\n]*)\n(?P<body>.*?)^```[ \t]*$", re.S | re.M)
OUTPUT_INFO = re.compile(r'text\s+title="Output"')
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
TOKEN = re.compile(rf"{NUMBER}|\S")
#: below this a printed number is a residual or an error bound: judged as small only
SMALL = 1e-6
#: the relative agreement of the other numbers (4 significant digits printed)
RTOL = 1e-4


def blocks(text: str) -> list[tuple[str, str | None]]:
    """A page's ``python`` blocks in order, each with the output block after it (or None)."""
    found = list(BLOCK.finditer(text))
    out: list[tuple[str, str | None]] = []
    for k, m in enumerate(found):
        if not m["info"].strip().startswith("python"):
            continue
        nxt = found[k + 1] if k + 1 < len(found) else None
        between = text[m.end() : nxt.start()] if nxt else ""
        shown = None
        if nxt and OUTPUT_INFO.fullmatch(nxt["info"].strip()) and not between.strip():
            shown = nxt["body"]
        out.append((m["body"], shown))
    return out


def _tokens(text: str) -> list[str]:
    return TOKEN.findall(text)


def _is_number(token: str) -> bool:
    return re.fullmatch(NUMBER, token) is not None and any(ch.isdigit() for ch in token)


def same_output(printed: str, shown: str) -> str | None:
    """None when ``printed`` matches ``shown`` (see the module docstring), else why not."""
    got, want = _tokens(printed), _tokens(shown)
    if len(got) != len(want):
        return f"{len(got)} tokens printed, {len(want)} shown"
    for k, (a, b) in enumerate(zip(got, want, strict=True)):
        if _is_number(a) and _is_number(b):
            x, y = float(a), float(b)
            ok = abs(x) < SMALL if abs(y) < SMALL else abs(x - y) <= RTOL * abs(y)
        else:
            ok = a == b
        if not ok:
            context = " ".join(want[max(0, k - 4) : k + 4])
            return f"token {k}: printed {a!r}, shown {b!r} (near: {context})"
    return None


PAGES = sorted(
    p for p in DOCS.rglob("*.md") if any(shown is not None for _, shown in blocks(p.read_text()))
)


def test_the_tutorial_shows_outputs():
    names = {p.relative_to(DOCS).as_posix() for p in PAGES}
    assert "tutorial.md" in names
    shown = [s for _, s in blocks((DOCS / "tutorial.md").read_text()) if s is not None]
    assert len(shown) >= 5


def test_comparison_catches_a_wrong_number():
    assert same_output("v* = [27. 30.]", "v* = [27.  30.]") is None
    assert same_output("residual 3.2e-13", "residual 6.1e-12") is None
    assert same_output("v* = [27.01 30.]", "v* = [27. 30.]") is not None
    assert same_output("residual 2.0e-5", "residual 6.1e-12") is not None
    assert same_output("status optimal", "status inconclusive") is not None
    assert same_output("[1 1 0 1]", "[1 1 0]") is not None


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(DOCS).as_posix())
def test_shown_outputs_are_printed(page, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": f"docs_{page.stem}"}
    for k, (code, shown) in enumerate(blocks(page.read_text())):
        buffer = io.StringIO()
        with contextlib.redirect_stdout(buffer):
            exec(compile(code, f"{page.name}[block {k}]", "exec"), namespace)
        if shown is not None:
            why = same_output(buffer.getvalue(), shown)
            assert why is None, f"{page.name} block {k}: {why}\nprinted:\n{buffer.getvalue()}"
