"""The house: the layer map of docs/architecture.md holds for every import in src.

Every module's imports are parsed (module level and inside functions; imports under
``if TYPE_CHECKING:`` are excluded, they never run). The tests fail on an import cycle,
on an import from a higher layer into a lower one, on a module that belongs to no layer
of the map, on a module that reaches another module's underscore names, and on a second
module constructing ``highspy.Highs``.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src"
PKG = SRC / "lpbounds"
MAP = ROOT / "docs" / "architecture.md"


def _modules() -> dict[str, Path]:
    mods = {}
    for f in PKG.rglob("*.py"):
        rel = f.relative_to(SRC).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        mods[".".join(parts)] = f
    return mods


MODULES = _modules()
PACKAGES = {n for n, f in MODULES.items() if f.name == "__init__.py"}


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If):
            t = node.test
            if (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
                isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
            ):
                for sub in node.body:
                    skip.update(id(n) for n in ast.walk(sub))
    return skip


def _resolve(module: str, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = module if module in PACKAGES else module.rsplit(".", 1)[0]
    parts = base.split(".")
    base = ".".join(parts[: len(parts) - node.level + 1])
    return f"{base}.{node.module}" if node.module else base


def _owner(name: str) -> str | None:
    """The module of lpbounds that ``name`` (a dotted import target) lives in."""
    while name and name not in MODULES:
        name = name.rsplit(".", 1)[0] if "." in name else ""
    return name or None


def imports() -> dict[str, set[str]]:
    """module -> the lpbounds modules it imports (a package's own submodules included)."""
    edges: dict[str, set[str]] = {m: set() for m in MODULES}
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text(), str(path))
        skip = _type_checking_nodes(tree)
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            targets: list[str] = []
            if isinstance(node, ast.ImportFrom):
                base = _resolve(module, node)
                if base.split(".")[0] == "lpbounds":
                    targets = [f"{base}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names if a.name.split(".")[0] == "lpbounds"]
            for t in targets:
                owner = _owner(t)
                if owner and owner != module:
                    edges[module].add(owner)
    return edges


def layer_map() -> list[tuple[int, str, list[str]]]:
    """(number, name, module prefixes) per row of the table in docs/architecture.md."""
    rows = []
    for line in MAP.read_text().splitlines():
        m = re.match(r"^\|\s*(\d+)\s*\|\s*([^|]+?)\s*\|([^|]*)\|", line)
        if m:
            prefixes = re.findall(r"`(lpbounds[\w.]*)`", m.group(3))
            rows.append((int(m.group(1)), m.group(2), prefixes))
    return rows


def layer_of(module: str, rows: list[tuple[int, str, list[str]]]) -> int | None:
    best, best_len = None, -1
    for number, _, prefixes in rows:
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best_len:
                best, best_len = number, len(p)
    return best


def test_the_map_has_layers_in_order():
    rows = layer_map()
    assert len(rows) >= 8, "docs/architecture.md lost its layer table"
    assert [r[0] for r in rows] == sorted(r[0] for r in rows)
    assert all(r[2] for r in rows), "a layer without modules"


def test_every_module_is_in_a_layer():
    rows = layer_map()
    missing = sorted(m for m in MODULES if layer_of(m, rows) is None)
    assert missing == []


def test_no_import_runs_up_a_layer():
    rows = layer_map()
    up = []
    for module, targets in imports().items():
        mine = layer_of(module, rows)
        for t in targets:
            theirs = layer_of(t, rows)
            if mine is not None and theirs is not None and theirs > mine:
                up.append(f"{module} (layer {mine}) imports {t} (layer {theirs})")
    assert up == []


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle():
    # a package's __init__ re-exporting its own submodules is not a cycle: drop the edges
    # from a package to the modules inside it
    edges = {
        m: {t for t in ts if not (m in PACKAGES and t.startswith(m + "."))}
        for m, ts in imports().items()
    }
    assert _cycles(edges) == []


def test_cycle_finder_finds_a_cycle():
    """The check above could fail: a two-module cycle and a three-module one are found."""
    edges = {"a": {"b"}, "b": {"a"}, "c": {"d"}, "d": {"e"}, "e": {"c"}, "f": {"a"}}
    assert sorted(_cycles(edges)) == [["a", "b"], ["c", "d", "e"]]


def _private_uses(module: str, path: Path) -> list[str]:
    """Underscore names of other lpbounds modules imported or reached as attributes."""
    tree = ast.parse(path.read_text(), str(path))
    found = []
    aliases: dict[str, str] = {}  # local name -> lpbounds module it names
    external: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = _resolve(module, node)
            if base.split(".")[0] != "lpbounds":
                continue
            for a in node.names:
                full = f"{base}.{a.name}"
                if full in MODULES:
                    aliases[a.asname or a.name] = full
                elif a.name.startswith("_") and not a.name.startswith("__"):
                    if _owner(base) != module:
                        found.append(f"{module}:{node.lineno} imports {base}.{a.name}")
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name in MODULES and a.asname:
                    aliases[a.asname] = a.name
                elif a.name.split(".")[0] != "lpbounds":
                    # a module of the standard library or a dependency: its underscore
                    # names used as documented API (argparse._SubParsersAction in
                    # annotations) are not lpbounds' private state
                    external.add(a.asname or a.name.split(".")[0])
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            v = node.value
            if isinstance(v, ast.Name) and v.id in aliases and aliases[v.id] != module:
                found.append(f"{module}:{node.lineno} {v.id}.{node.attr}")
            elif not (isinstance(v, ast.Name) and v.id in ("self", "cls")) and not (
                isinstance(v, ast.Call) and isinstance(v.func, ast.Name) and v.func.id == "super"
            ):
                if node.attr in _ALLOWED_ATTRS or (isinstance(v, ast.Name) and v.id in external):
                    continue
                if (module, node.attr) in _ALLOWED_PLACES:
                    continue
                if isinstance(v, ast.Name) and v.id in aliases:
                    continue
                found.append(f"{module}:{node.lineno} .{node.attr}")
    return found


#: underscore attributes that are documented API of the standard library or a dependency
_ALLOWED_ATTRS = frozenset({"_replace", "_asdict", "_fields", "_make", "_exit", "_getframe"})

#: (module, attribute) of a dependency's internals read on purpose, each in one function
#: (none today: the last, numba's cache index, left with the numba kernels of the rows)
_ALLOWED_PLACES: frozenset[tuple[str, str]] = frozenset()


def test_no_private_access_across_modules():
    found = []
    for module, path in sorted(MODULES.items()):
        found += _private_uses(module, path)
    assert found == []


def test_private_scan_finds_private_access(tmp_path):
    """The scan above could fail: it sees an imported private name and a private attribute."""
    bad = tmp_path / "bad.py"
    bad.write_text(
        "from lpbounds.model.mdp import _private\ndef f(rows):\n    return rows._vec(1)\n"
    )
    assert len(_private_uses("lpbounds.bad", bad)) == 2


def test_one_module_constructs_highs():
    makers = []
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and node.attr == "Highs":
                v = node.value
                if isinstance(v, ast.Name) and v.id in ("highspy", "_highspy"):
                    makers.append(module)
                    break
    assert makers == ["lpbounds.formulations.highs"]


#: the longest a subpackage's ``__init__.py`` may be: a docstring and its re-exports
INIT_MAX_LINES = 150


def test_package_inits_are_tables_of_contents():
    """No package of lpbounds but the top-level facade keeps its implementation in its
    ``__init__.py`` (issue 37): every other one is a table of contents."""
    long = {
        name: n
        for name, path in MODULES.items()
        if path.name == "__init__.py"
        and name != "lpbounds"
        and (n := len(path.read_text().splitlines())) > INIT_MAX_LINES
    }
    assert long == {}


#: a file the "Where is X" table names, with an optional ``::name`` it must define
_WHERE_PATH = re.compile(r"`([\w.-]+(?:/[\w.-]+)*\.(?:py|pyi|c|h|md|toml))(?:::(\w+))?`")


def where_table(text: str) -> list[tuple[str, list[tuple[str, str | None]]]]:
    """(question, [(path, name or None), ...]) per row of the "Where is X" table."""
    section = re.split(r"^## Where is X\s*$", text, maxsplit=1, flags=re.M)[1]
    section = re.split(r"^## ", section, maxsplit=1, flags=re.M)[0]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 2 or not cells[0].endswith("?"):
            continue
        rows.append((cells[0], [(m[1], m[2] or None) for m in _WHERE_PATH.finditer(cells[1])]))
    return rows


def where_missing(rows: list[tuple[str, list[tuple[str, str | None]]]], root: Path) -> list[str]:
    """The files the table names that do not exist, and the names they do not define."""
    missing = []
    for _, places in rows:
        for rel, name in places:
            path = root / rel
            if not path.is_file():
                missing.append(rel)
            elif name and not re.search(
                rf"^\s*(?:(?:async\s+)?def |class )?{name}\b\s*[(:=]", path.read_text(), re.M
            ):
                missing.append(f"{rel}::{name}")
    return missing


def test_where_table_answers_ten_questions_with_files_that_exist():
    rows = where_table(MAP.read_text())
    assert len(rows) >= 10, "docs/architecture.md lost questions of its 'Where is X' table"
    assert [q for q, places in rows if not places] == [], "a question without a file"
    assert where_missing(rows, ROOT) == []


def test_where_scan_finds_a_missing_file_and_a_missing_name(tmp_path):
    """The check above could fail: a file that is not there and a name a file lacks."""
    (tmp_path / "here.py").write_text("def present():\n    pass\n")
    text = (
        "## Where is X\n\n| question | the file |\n|---|---|\n"
        "| Where is A? | `here.py::present` and `gone.py` |\n"
        "| Where is B? | `here.py::absent` |\n"
    )
    rows = where_table(text)
    assert [q for q, _ in rows] == ["Where is A?", "Where is B?"]
    assert where_missing(rows, tmp_path) == ["gone.py", "here.py::absent"]


def folder_table(text: str) -> dict[str, str]:
    """Folder -> layer name, from the table under '## Where the tests are'."""
    section = text.split("## Where the tests are", 1)[1].split("\n## ", 1)[0]
    return {
        m[1]: m[2].strip() for m in re.finditer(r"^\|\s*`tests/(\w+)`\s*\|([^|]+)\|", section, re.M)
    }


def test_tests_mirror_the_layers():
    """Every test module is in a folder of the table, each folder of a layer of the map."""
    table = folder_table(MAP.read_text())
    layers = {name for _, name, _ in layer_map()}
    assert {layer for layer in table.values() if layer != "(none)"} == layers
    tests = ROOT / "tests"
    folders = {p.name for p in tests.iterdir() if p.is_dir() and (p / "__init__.py").is_file()}
    assert folders == set(table), "a tests/ folder missing from the table, or one not there"
    assert sorted(p.name for p in tests.glob("test_*.py")) == [], "a test module at the top"
