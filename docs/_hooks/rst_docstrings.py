"""A griffe extension: the reStructuredText bits of lpbounds' numpydoc docstrings, rendered.

lpbounds writes numpydoc docstrings (read by ``help()``, IDEs and numpydoc tools) with
Sphinx roles and directives; mkdocstrings renders docstrings as Markdown, where those
showed as raw text. Once the package is loaded (so every name can be resolved in its
scope), this rewrites each docstring for the site only:

* ``:class:`~a.b.C``` (and ``:meth:``, ``:func:``, ``:mod:``, ``:data:``, ``:attr:``,
  ``:exc:``, ``:obj:``, ``:const:``; ``title <target>`` forms too) becomes a
  cross-reference to the object's page when the target resolves to an lpbounds object
  (an *optional* autoref: a target the site does not render shows as code, it does not
  fail ``mkdocs build --strict``), and code otherwise; ``~`` keeps the last component;
* ``.. math::`` blocks become ``$$ ... $$`` (pymdownx.arithmatex, MathJax) and
  ``:math:`x``` becomes ``$x$``;
* ``.. note::`` / ``.. warning::`` (and the other admonitions) become ``!!! note``;
* an inline literal that wraps a line (````a >= b\n   >= c````) is joined onto one line:
  Markdown reads its second line as a new line of the text, where a leading ``>`` starts a
  quote, ``#`` a heading and ``-`` a list, and the literal came out torn and mangled;
* a line of text that starts with ``>`` (``> 0.`` in a parameter's description) keeps it
  as text: reStructuredText has no ``>`` quotes, Markdown would start one (doctest
  ``>>>`` lines and ``::`` literal blocks are left alone);
* a role in a section title (a line underlined with ``---``) becomes plain code: griffe
  turns the title into an HTML ``class`` too, where a cross-reference's markup would be
  pasted as escaped text.

``tests/project/test_docs.py`` builds the site and fails on any raw role or directive left.
Configured in ``mkdocs.yml`` under the python handler's ``extensions``.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(
    r":(?:py:)?(?P<role>class|meth|func|mod|data|attr|exc|obj|const|ref|math):"
    r"`(?P<body>[^`]+)`"
)
#: the delimiter of a ````double-backtick```` literal
DOUBLE_BACKTICK = re.compile(r"(?<!`)``(?!`)")
#: a line of text that Markdown would read as a block quote (not a doctest prompt)
QUOTE_START = re.compile(r"^(?P<indent>[ \t]*)>(?!>>)")
DIRECTIVE = re.compile(r"^(?P<indent>[ \t]*)\.\. (?P<name>[a-z-]+)::[ \t]*(?P<rest>.*)$")
ADMONITIONS = {
    "note", "warning", "seealso", "important", "tip", "caution", "danger", "attention",
    "hint", "error",
}  # fmt: skip


def _lookup(obj: griffe.Object, target: str) -> str | None:
    """The canonical path of ``target`` seen from ``obj``, or None outside lpbounds."""
    target = target.lstrip(".")
    if not target:
        return None
    head, _, tail = target.partition(".")
    try:
        base = obj.resolve(head)
    except Exception:  # griffe raises several kinds; any means "not found"
        base = head
    path = f"{base}.{tail}" if tail else base
    try:
        found = obj.modules_collection.get_member(path)
    except Exception:  # not a loaded object
        return None
    try:
        return str(found.canonical_path)
    except Exception:  # an alias whose target is outside the package
        return None


def _role(obj: griffe.Object, match: re.Match[str]) -> str:
    role, body = match["role"], match["body"].strip()
    if role == "math":
        return f"${body}$"
    titled = re.fullmatch(r"(?P<title>.+?)\s*<(?P<target>[^>]+)>", body)
    if titled:
        title, target = titled["title"], titled["target"]
    else:
        target = body.lstrip("!")
        title = target[1:].rsplit(".", 1)[-1] if target.startswith("~") else target
    target = target.lstrip("~")
    path = _lookup(obj, target)
    if path is None or not path.startswith("lpbounds"):
        return f"`{title}`"
    return f'<autoref identifier="{path}" optional><code>{title}</code></autoref>'


def _block(lines: list[str], start: int, indent: str) -> tuple[list[str], int]:
    """The body of a directive starting after line ``start``: lines indented deeper than
    ``indent`` (and blank lines between them); returns (body, index after it)."""
    body: list[str] = []
    k = start + 1
    while k < len(lines):
        ln = lines[k]
        if ln.strip() and not (ln.startswith(indent) and len(ln) - len(ln.lstrip()) > len(indent)):
            break
        body.append(ln)
        k += 1
    while body and not body[-1].strip():
        body.pop()
        k -= 1
    return body, k


def _dedent(body: list[str]) -> list[str]:
    width = min((len(ln) - len(ln.lstrip()) for ln in body if ln.strip()), default=0)
    return [ln[width:] for ln in body]


def _directives(text: str) -> str:
    lines = text.split("\n")
    out: list[str] = []
    k = 0
    while k < len(lines):
        m = DIRECTIVE.match(lines[k])
        if not m or (m["name"] != "math" and m["name"] not in ADMONITIONS):
            out.append(lines[k])
            k += 1
            continue
        indent = m["indent"]
        body, k = _block(lines, k, indent)
        content = [ln for ln in _dedent(body) if not ln.strip().startswith(":label:")]
        if m["rest"].strip():
            content = [m["rest"].strip(), *content]
        if out and out[-1].strip():
            out.append("")
        if m["name"] == "math":
            out += [
                f"{indent}$$",
                *(f"{indent}{ln}" for ln in content if ln.strip()),
                f"{indent}$$",
            ]
        else:
            kind = "note" if m["name"] == "seealso" else m["name"]
            out.append(f"{indent}!!! {kind}")
            out += [f"{indent}    {ln}" if ln.strip() else "" for ln in content]
        out.append("")
    return "\n".join(out)


def _join_literals(text: str) -> str:
    """Every inline literal of ``text`` that wraps a line, on one line.

    The delimiters are paired in order within each paragraph (blocks between blank
    lines), as Markdown pairs them; only the inside of a pair is touched.
    """
    out = []
    for para in re.split(r"(\n[ \t]*\n)", text):
        marks = [m.start() for m in DOUBLE_BACKTICK.finditer(para)]
        pieces, last = [], 0
        for start, end in zip(marks[0::2], marks[1::2], strict=False):  # an odd mark: unpaired
            body = para[start + 2 : end]
            pieces += [para[last:start], "``", re.sub(r"[ \t]*\n[ \t]*", " ", body), "``"]
            last = end + 2
        out.append("".join(pieces) + para[last:])
    return "".join(out)


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def _escape_quotes(text: str) -> str:
    """``text`` with a leading ``>`` of each line of text escaped (see the module docstring).

    A line ending in ``::`` opens a literal block: the lines after it that are blank or
    indented deeper are code and are left as they are.
    """
    out, block = [], None  # block: the indent of the line that opened a literal block
    for line in text.split("\n"):
        if block is not None and (not line.strip() or _indent(line) > block):
            out.append(line)
            continue
        block = _indent(line) if line.rstrip().endswith("::") else None
        out.append(QUOTE_START.sub(lambda m: m["indent"] + "\\>", line, count=1))
    return "\n".join(out)


def _plain_role(match: re.Match[str]) -> str:
    body = match["body"].strip()
    if match["role"] == "math":
        return f"${body}$"
    titled = re.fullmatch(r"(?P<title>.+?)\s*<(?P<target>[^>]+)>", body)
    name = titled["title"] if titled else body.lstrip("!")
    return f"`{name[1:].rsplit('.', 1)[-1] if name.startswith('~') else name}`"


def _titles(text: str) -> str:
    """``text`` with the roles of its section titles (lines over a ``---`` line) plain."""
    lines = text.split("\n")
    for k in range(len(lines) - 1):
        if re.fullmatch(r"[ \t]*-{3,}[ \t]*", lines[k + 1]) and lines[k].strip():
            lines[k] = ROLE.sub(_plain_role, lines[k])
    return "\n".join(lines)


def rewrite(obj: griffe.Object, text: str) -> str:
    """The docstring ``text`` of ``obj`` with its roles and directives in Markdown."""
    text = _titles(_escape_quotes(_join_literals(text)))
    return ROLE.sub(lambda m: _role(obj, m), _directives(text))


def _walk(obj: Any, seen: set[int]) -> None:
    if id(obj) in seen or getattr(obj, "is_alias", False):
        return
    seen.add(id(obj))
    if obj.docstring is not None:
        obj.docstring.value = rewrite(obj, obj.docstring.value)
    for member in obj.members.values():
        _walk(member, seen)


class RstDocstrings(griffe.Extension):
    """Rewrite every docstring of a loaded package (see the module docstring)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        _walk(pkg, set())
