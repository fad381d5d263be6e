"""The documentation: its code blocks run and check their claims; the site builds strict.

Every fenced ``python`` block of a page under ``docs/`` is executed, in order, in one
namespace per page (blocks assert what the text says they show). A page whose code needs
a module not in the package yet is skipped while that import fails.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
FENCE = re.compile(r"^```python[^\n]*\n(.*?)^```", re.S | re.M)
#: Pages whose code another test runs: interop.md section by section, skipping a section
#: whose optional package (pymdptoolbox, MDPSolver, ...) is missing
#: (tests/model/interop/test_interop_docs.py).
RUN_ELSEWHERE = {"interop.md"}
PAGES = sorted(
    p
    for p in DOCS.rglob("*.md")
    if FENCE.search(p.read_text()) and p.relative_to(DOCS).as_posix() not in RUN_ELSEWHERE
)


def test_pages_with_code_exist():
    names = {p.relative_to(DOCS).as_posix() for p in PAGES}
    assert {"tutorial.md", "formulations/rlp.md", "formulations/elp.md"} <= names, names


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(DOCS).as_posix())
def test_page_code_runs(page, tmp_path, monkeypatch, capsys):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": f"docs_{page.stem}"}
    for k, block in enumerate(FENCE.findall(page.read_text())):
        # a page naming an lpbounds module that does not exist (renamed, removed) fails
        exec(compile(block, f"{page.name}[block {k}]", "exec"), namespace)


def test_mkdocs_builds_strict(tmp_path):
    pytest.importorskip("mkdocs", reason="the docs extra: pip install -e '.[docs]'")
    pytest.importorskip("mkdocstrings", reason="the docs extra: pip install -e '.[docs]'")
    pytest.importorskip("material", reason="the docs extra: pip install -e '.[docs]'")
    # copy the sources so a build never writes into the working tree
    src = tmp_path / "src"
    shutil.copytree(DOCS, src / "docs")
    shutil.copy(ROOT / "mkdocs.yml", src / "mkdocs.yml")
    (src / "src").symlink_to(ROOT / "src")
    (src / "examples").symlink_to(ROOT / "examples")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=src,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stderr[-4000:]}"
    site = tmp_path / "site"
    assert (site / "index.html").exists()
    assert (site / "api" / "formulations" / "index.html").exists()
    _assert_rendered(site)


#: reStructuredText that Markdown shows as text: Sphinx roles (the backticks became
#: <code>) and directives.
RAW_RST = re.compile(
    r":(?:py:)?(?:class|meth|func|mod|data|attr|exc|obj|const|ref|math):(?:<code>|`)"
    r"|\.\. (?:math|note|warning|seealso|code-block|literalinclude|autoclass)::"
)


def _assert_rendered(site: Path) -> None:
    """No raw role or directive on any page; the API pages have math and cross-links."""
    raw = {}
    for page in site.rglob("*.html"):
        hits = RAW_RST.findall(page.read_text(errors="replace"))
        if hits:
            raw[page.relative_to(site).as_posix()] = sorted(set(hits))[:5]
    assert not raw, f"raw reStructuredText in the built site: {raw}"
    api = (site / "api" / "formulations" / "index.html").read_text()
    assert api.count("<math ") >= 5  # the LPs' .. math:: blocks, as MathML (docs/_hooks/math.py)
    models = (site / "api" / "models" / "index.html").read_text()
    assert 'href="#lpbounds.model.mdp.FiniteMDP.user_values"' in models  # a :meth: cross-link
    assert "autorefs-internal" in api


def test_rst_extension_rewrites_roles_math_and_admonitions():
    """The griffe extension of mkdocs.yml on a docstring with each construct it handles."""
    import importlib.util

    griffe = pytest.importorskip("griffe", reason="the docs extra: pip install -e '.[docs]'")
    spec = importlib.util.spec_from_file_location(
        "rst_docstrings", DOCS / "_hooks" / "rst_docstrings.py"
    )
    assert spec is not None and spec.loader is not None
    ext = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ext)
    rows = griffe.load("lpbounds.rows", search_paths=[str(ROOT / "src")])
    cls = rows["BellmanRows"]
    text = (
        "See :class:`~lpbounds.rows.BellmanRows` and :meth:`BellmanRows.aggregate`, "
        ":func:`numpy.zeros`, :math:`x^2`.\n\n"
        ".. math:: a = b\n   + c\n\n"
        ".. warning::\n   Careful.\n\nAfter."
    )
    out = ext.rewrite(cls, text)
    where = str(cls.canonical_path)  # the defining module's path, lpbounds.rows.system...
    assert where.startswith("lpbounds.rows.") and where.endswith(".BellmanRows")
    assert f'<autoref identifier="{where}" optional><code>BellmanRows</code>' in out
    assert f'identifier="{where}.aggregate"' in out
    assert "`numpy.zeros`" in out and "$x^2$" in out
    assert "$$\na = b\n+ c\n$$" in out
    assert "!!! warning\n    Careful." in out and out.endswith("After.")
    assert ":class:" not in out and ".. math::" not in out
