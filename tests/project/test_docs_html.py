"""The built documentation site, read as HTML: offline math, notebooks, clean API pages.

Builds the site once (``mkdocs build --strict`` from a copy of ``docs/`` and
``mkdocs.yml``, into a temporary folder) and checks what a reader would meet without a
network: no page loads a script, style sheet or font from another host (the math is
MathML written at build time, ``docs/_hooks/math.py``); every formula is MathML, none left
as TeX, and a display formula sits in a box that scrolls sideways; the notebooks are pages
with their outputs and figures; the API pages show no literal torn by a line break (a
``>`` turned into a quote, a ``#`` into a heading) and no escaped cross-reference markup.
``docs/screenshots.py`` checks the same pages in a real browser where one is installed.
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
NOTEBOOKS = sorted((DOCS / "notebooks").glob("*.py"))
REASON = "the docs extra: pip install -e '.[docs]'"
#: an attribute that makes the browser fetch something
FETCH = re.compile(
    r"<(?:script|link|img|iframe|source|audio|video)\b[^>]*?\b(?:src|href)=\"([^\"]*)\""
)
EXTERNAL = re.compile(r"^(?:[a-z][a-z0-9+.-]*:|//)", re.I)
#: TeX in a page's text, outside MathML and code: a command (``\Big``, ``\left``, ``\frac``)
#: or an escaped delimiter (``\{``, ``\}``, ``\|``)
TEX_IN_TEXT = re.compile(r"\\(?:[A-Za-z]+|[{}|])")
#: a MathML token whose text holds a backslash: TeX the converter copied instead of reading
#: (``<mo minsize="1.623em">\{</mo>`` shows ``\{``); every character it reads is an entity
TEX_IN_MATH = re.compile(r"<(m[a-z]+)\b[^>]*>[^<]*\\[^<]*</\1>")
#: the pages whose formulas have ``\Big\{ ... \Big\}`` (the NLP's defining inequality, the
#: Bellman equation of FiniteMDP's docstring)
SIZED_BRACES = (
    "formulations/nlp/index.html",
    "nlp/index.html",
    "notebooks/nlp_bracket/index.html",
    "api/formulations/index.html",
    "api/models/index.html",
)


#: an executed notebook a user left in docs/notebooks/ (valid nbformat, with a marker)
STRAY_IPYNB = (
    '{"cells": [{"cell_type": "markdown", "metadata": {}, "source": ["left by a user"]}], '
    '"metadata": {}, "nbformat": 4, "nbformat_minor": 5}'
)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site built from this tree (skipped without the docs extra)."""
    for name in ("mkdocs", "mkdocstrings", "material", "latex2mathml", "jupytext", "nbclient"):
        pytest.importorskip(name, reason=REASON)
    tmp = tmp_path_factory.mktemp("docs-html")
    src = tmp / "src"
    shutil.copytree(DOCS, src / "docs")
    shutil.copy(ROOT / "mkdocs.yml", src / "mkdocs.yml")
    (src / "src").symlink_to(ROOT / "src")
    (src / "examples").symlink_to(ROOT / "examples")
    # what the README's `jupytext --execute --to ipynb docs/notebooks/*.py` leaves beside a
    # notebook: the build publishes its own execution instead
    (src / "docs" / "notebooks" / f"{NOTEBOOKS[0].stem}.ipynb").write_text(STRAY_IPYNB)
    out = tmp / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=src,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stderr[-4000:]}"
    return out


def _pages(site: Path) -> dict[str, str]:
    return {p.relative_to(site).as_posix(): p.read_text() for p in site.rglob("*.html")}


def _text(html: str) -> str:
    """The page without its code blocks, code spans, scripts and MathML."""
    for tag in ("pre", "code", "script", "style", "math"):
        html = re.sub(rf"<{tag}\b.*?</{tag}>", " ", html, flags=re.S)
    return html


def test_no_page_fetches_from_another_host(site):
    fetched = {}
    for name, html in _pages(site).items():
        outside = [url for url in FETCH.findall(html) if EXTERNAL.match(url)]
        if outside:
            fetched[name] = sorted(set(outside))[:5]
    assert not fetched, f"pages that need the network: {fetched}"
    css = "\n".join(p.read_text() for p in site.rglob("*.css"))
    assert not re.search(r"@import\s+url\(\s*['\"]?(?:https?:)?//|fonts\.googleapis", css)
    everything = "\n".join(_pages(site).values()).lower()
    assert "mathjax" not in everything and "katex" not in everything


def test_formulas_are_mathml(site):
    pages = _pages(site)
    rlp = pages["formulations/rlp/index.html"]
    assert re.search(r'<div class="lpb-math-display"><math [^>]*display="block"', rlp)
    assert pages["api/formulations/index.html"].count("<math ") >= 5  # the LPs' .. math::
    assert pages["notebooks/theorem1_cost_independence/index.html"].count("<math ") >= 10
    left = {}
    for name, html in pages.items():
        # arithmatex's markers, or TeX delimiters in the text (page or table of contents)
        raw = re.findall(r'class="arithmatex"|\\\(|\\\[|\$\$', _text(html))
        raw += TEX_IN_TEXT.findall(_text(html))  # a \Big, \left or \{ outside MathML
        raw += [m.group(0) for m in TEX_IN_MATH.finditer(html)]  # or inside it, as text
        if raw:
            left[name] = raw[:3]
    assert not left, f"formulas left as TeX: {left}"


def test_sized_braces_are_drawn_as_braces(site):
    """``\\Big\\{ ... \\Big\\}``: a stretchy brace at TeX's \\Big size, not the text ``\\{``."""
    pages = _pages(site)
    for name in SIZED_BRACES:
        for code in ("0007B", "0007D"):  # { and }
            brace = rf'<mo stretchy="true" minsize="1\.623em" maxsize="1\.623em">&#x{code};</mo>'
            assert re.search(brace, pages[name]), f"{name}: no \\Big brace &#x{code};"


def _math_hook():
    import importlib.util

    pytest.importorskip("latex2mathml", reason=REASON)
    pytest.importorskip("mkdocs", reason=REASON)
    spec = importlib.util.spec_from_file_location("lpb_docs_math", DOCS / "_hooks" / "math.py")
    assert spec is not None and spec.loader is not None
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    return hook


@pytest.mark.parametrize("size", ["big", "Big", "bigg", "Bigg", "Bigl", "Bigr", "biggl"])
@pytest.mark.parametrize(
    ("tex", "code"),
    [
        ("\\{", "0007B"), ("\\}", "0007D"), ("\\lbrace", "0007B"), ("\\|", "02016"),
        ("\\langle", "027E8"), ("\\rangle", "027E9"), ("\\lvert", "0007C"),
        ("\\lfloor", "0230A"), ("\\rceil", "02309"), ("\\Vert", "02016"),
    ],
)  # fmt: skip
def test_every_sized_delimiter_becomes_its_character(size, tex, code):
    """The hook writes each sized delimiter as its character (latex2mathml copies its TeX)."""
    out = _math_hook().to_mathml(f"\\{size}{tex} x", display=True)
    assert re.search(rf'<mo [^>]*stretchy="true"[^>]*minsize="[0-9.]+em"[^>]*>&#x{code};</mo>', out)
    assert not TEX_IN_MATH.search(out), out


@pytest.mark.parametrize("tex", ["\\nosuchcommand x", "\\Big\\nosuchdelimiter x", "a & b"])
def test_unread_tex_fails_the_build(tex):
    with pytest.raises(ValueError, match="left as text"):
        _math_hook().to_mathml(tex, display=False)


def test_wide_equations_scroll(site):
    css = (site / "stylesheets" / "lpbounds.css").read_text()
    block = re.search(r"\.lpb-math-display\s*\{([^}]*)\}", css)
    assert block and re.search(r"overflow-x:\s*auto", block.group(1)), "display math clips"
    # a long formula is written as rows (\begin{array}{l}): MathML Core ignores latex2mathml's
    # columnalign, so the style sheet says it, or the rows come out centred
    for side in ("left", "right"):
        rule = rf'mtd\[columnalign="{side}"\]\s*\{{\s*text-align:\s*{side};'
        assert re.search(rule, css), f"no text-align for columnalign={side}"
    rows = (site / "formulations" / "rlp" / "index.html").read_text()
    assert re.search(r'<div class="lpb-math-display"><math [^>]*>\s*<mrow>\s*<mtable>', rows)
    for name, html in _pages(site).items():
        if "lpb-math" in html:
            assert "stylesheets/lpbounds.css" in html, f"{name} does not load lpbounds.css"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_pages_have_their_outputs(site, path):
    folder = site / "notebooks" / path.stem
    html = (folder / "index.html").read_text()
    assert (site / "notebooks" / f"{path.name}").exists()  # the text, for download
    if "Not executed when this site was built" in html:
        pytest.skip(f"{path.name} was not executed: its optional package is missing")
    assert html.count('class="nb-output"') >= 2
    images = re.findall(r'<img [^>]*src="([^"]+\.png)"', html)
    assert images, f"{path.stem}: no figure on the page"
    for src in images:
        data = (folder / src).read_bytes()
        assert data.startswith(b"\x89PNG") and len(data) > 5_000, src
    ipynb = (site / "notebooks" / f"{path.stem}.ipynb").read_text()
    assert '"outputs": [' in ipynb and '"output_type": "stream"' in ipynb
    assert "left by a user" not in ipynb  # the build's own execution, not a stray .ipynb


def test_site_publishes_no_script_but_the_notebooks(site):
    """docs/ holds tools (docs/screenshots.py, docs/_hooks/): none is a file of the site."""
    scripts = sorted(p.relative_to(site).as_posix() for p in site.rglob("*.py"))
    assert scripts == sorted(f"notebooks/{p.name}" for p in NOTEBOOKS)
    assert not (site / "screenshots.py").exists() and not (site / "screenshots").exists()


def test_notebooks_are_in_the_navigation(site):
    home = (site / "index.html").read_text()
    for path in NOTEBOOKS:
        assert f'href="notebooks/{path.stem}/"' in home, f"{path.stem} is not in the nav"


def test_api_pages_have_no_mangled_literals(site):
    problems = {}
    for name, html in _pages(site).items():
        if not name.startswith("api/"):
            continue
        found = []
        text = _text(html)
        found += ["``" + m for m in re.findall(r"``(.{0,40})", text)]  # an unpaired literal
        found += re.findall(r"&lt;/?(?:autoref|code)\b.{0,40}", html)  # escaped markup
        found += re.findall(r"<blockquote>.{0,60}", html, flags=re.S)  # a line read as a quote
        # the page's title is its one heading that is not an object's
        headings = re.findall(r"<h[1-6](?![^>]*doc-heading)[^>]*>", html)
        if len(headings) != 1:
            found += headings[1:4]
        if found:
            problems[name] = found[:4]
    assert not problems, f"mangled API pages: {problems}"


def test_literals_that_wrapped_a_line_stay_whole(site):
    api = (site / "api" / "formulations" / "index.html").read_text()
    # LLP's constraints: a literal of its docstring breaks its line before ">= R"
    assert "<code>A_pair v - z &gt;= R</code>" in api
    assert "<code>z - A_pair v &gt;= -R</code>" in api
    patrol = (site / "api" / "patrol" / "index.html").read_text()
    assert re.search(r'<details class="value-by-monte-carlo[^"<>&]*"', patrol)  # greedy_mc
