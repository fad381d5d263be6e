"""MkDocs hook: the site's TeX rendered to MathML when the site is built (no script, no network).

``pymdownx.arithmatex`` (``generic: true``) marks every formula of a page, the docs pages'
``$...$`` / ``$$...$$`` and the docstrings' ``:math:`` / ``.. math::`` (rewritten by
``rst_docstrings.py``) alike, as ``<span class="arithmatex">\\(...\\)</span>`` or
``<div class="arithmatex">\\[...\\]</div>``. This hook replaces each of them by MathML
(``latex2mathml``, pure Python), which browsers render natively: the built site loads no
math script from anywhere, and a formula reads the same offline, behind a firewall or
from a ``file://`` copy of the site.

* an inline formula becomes ``<math class="lpb-math" display="inline">``, in the page
  and in its table of contents (a heading's formula would show there as ``\\(v^*\\)``);
* a display formula becomes ``<div class="lpb-math-display"><math display="block">``;
  ``docs/stylesheets/lpbounds.css`` lets that container scroll sideways, so an equation
  wider than the page scrolls instead of being clipped.

latex2mathml writes the delimiter of a sized delimiter (``\\big``, ``\\Big``, ``\\bigg``,
``\\Bigg`` and their ``l``/``r``/``m`` forms) as its TeX: ``\\Big\\{`` came out as
``<mo minsize="1.623em">\\{</mo>``, which a browser shows as the two characters ``\\{``.
:func:`to_mathml` replaces every such delimiter by its character (latex2mathml's own table,
the one ``\\left`` uses) and marks it stretchy, so it is drawn at the size asked for.

A formula the converter cannot read, or reads only partly (an unknown command kept as
text, an ``&`` alignment outside a matrix, any backslash left in the MathML's text), fails
the build with the page and the TeX: a formula that would show as raw TeX is an error, as
in ``mkdocs build --strict``.
"""

from __future__ import annotations

import html
import re
from typing import Any

from mkdocs.exceptions import PluginError

#: arithmatex's generic output: the TeX is HTML-escaped and holds no tags
MARKED = re.compile(r'<(?P<tag>span|div) class="arithmatex">(?P<tex>.*?)</(?P=tag)>', re.S)
#: an inline formula in a table-of-contents title (the heading's text, markup stripped)
TOC_TEX = re.compile(r"\\\((?P<tex>.+?)\\\)")
#: what latex2mathml leaves of TeX it did not read: any backslash in the MathML's text (a
#: command it does not know, ``<mi>\name</mi>``; an escaped delimiter, ``<mo>\{</mo>``;
#: every character it does know is written as an entity, ``\backslash`` as ``&#x0005C;``),
#: or an alignment ``&`` as an identifier
UNREAD = re.compile(r"<(m[a-z]+)\b[^>]*>(?:[^<]*\\[^<]*|&amp;|&)</\1>")
#: a sized delimiter (``\Big\{``): an ``<mo>`` with a ``minsize`` holding the delimiter's TeX
SIZED = re.compile(r"<mo (?P<attrs>[^>]*\bminsize=[^>]*)>(?P<tex>\\[^<]+)</mo>")


def _strip(tex: str, inline: bool) -> str:
    """The TeX inside arithmatex's ``\\(...\\)`` or ``\\[...\\]`` (or ``$...$``) wrapper."""
    tex = tex.strip()
    pairs = [("\\(", "\\)"), ("$", "$")] if inline else [("\\[", "\\]"), ("$$", "$$")]
    for left, right in pairs:
        if tex.startswith(left) and tex.endswith(right):
            return tex[len(left) : len(tex) - len(right)].strip()
    return tex


def _sized(m: re.Match[str]) -> str:
    """A sized delimiter's ``<mo>`` with its character in place of its TeX."""
    from latex2mathml.symbols_parser import convert_symbol

    code = convert_symbol(m["tex"])
    if code is None:  # not a delimiter latex2mathml knows: left for UNREAD to report
        return m.group(0)
    attrs = m["attrs"] if "stretchy=" in m["attrs"] else f'stretchy="true" {m["attrs"]}'
    return f"<mo {attrs}>&#x{code};</mo>"


def to_mathml(tex: str, *, display: bool) -> str:
    """MathML for one formula; ``ValueError`` naming the TeX if it cannot be read whole.

    Parameters
    ----------
    tex : str
        The formula, without its ``$`` / ``\\(`` delimiters.
    display : bool
        A display (block) formula rather than an inline one.

    Returns
    -------
    str
        A ``<math>`` element.
    """
    from latex2mathml.converter import convert

    try:
        out = convert(tex, display="block" if display else "inline")
    except Exception as err:  # latex2mathml raises several kinds for unreadable TeX
        raise ValueError(f"cannot convert {tex!r} to MathML: {type(err).__name__} {err}") from err
    out = SIZED.sub(_sized, out)
    bad = UNREAD.search(out)
    if bad:
        raise ValueError(f"cannot convert {tex!r} to MathML: {bad.group(0)!r} left as text")
    cls = "lpb-math" if not display else "lpb-math lpb-math-block"
    return out.replace("<math ", f'<math class="{cls}" ', 1)


def render(text: str, where: str = "page") -> str:
    """``text`` (HTML) with every arithmatex formula replaced by MathML.

    Parameters
    ----------
    text : str
        HTML produced by Python-Markdown with ``pymdownx.arithmatex`` (generic mode).
    where : str
        What to name in an error (the page's source path).

    Returns
    -------
    str
        The same HTML, each formula as MathML; display formulas in a scrolling container.
    """

    def one(m: re.Match[str]) -> str:
        display = m["tag"] == "div"
        tex = _strip(html.unescape(m["tex"]), inline=not display)
        try:
            math = to_mathml(tex, display=display)
        except ValueError as err:
            raise PluginError(f"{where}: {err}") from err
        if display:
            return f'<div class="lpb-math-display">{math}</div>'
        return math

    return MARKED.sub(one, text)


def _toc(items: Any, where: str) -> None:
    """The titles of ``items`` (a page's table of contents) with their formulas as MathML."""

    def one(m: re.Match[str]) -> str:
        try:
            return to_mathml(html.unescape(m["tex"]), display=False)
        except ValueError as err:
            raise PluginError(f"{where} (table of contents): {err}") from err

    for item in items:
        item.title = TOC_TEX.sub(one, item.title)
        _toc(item.children, where)


def on_page_content(html_text: str, page: Any, config: Any, files: Any) -> str:
    """Every page's content, the API pages' docstrings included, with its math as MathML."""
    _toc(page.toc, page.file.src_uri)
    return render(html_text, page.file.src_uri)
