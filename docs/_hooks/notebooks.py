"""MkDocs hook: the notebooks of ``docs/notebooks/`` executed and shown with their outputs.

The notebooks are kept as text, in jupytext's percent format (``docs/notebooks/*.py``:
``# %%`` starts a code cell, ``# %% [markdown]`` a Markdown cell), so they diff and
review like code. At every build this hook

1. reads each one with jupytext and executes it with nbclient in a fresh Python kernel
   (ipykernel, the interpreter running mkdocs), in a temporary folder, two at a time;
   a cell that raises fails the build, naming the notebook and the cell;
2. turns the executed notebook into a Markdown page, ``notebooks/<name>.md``: Markdown
   cells as they are (their ``$...$`` math goes through the site's math rendering), code
   cells as ``python`` blocks, each followed by its outputs: printed text, rich HTML
   (pandas tables), figures (PNG files beside the page);
3. adds the executed notebook, ``notebooks/<name>.ipynb``, for download; the ``.py``
   source is copied as it is.

A notebook that needs an optional package names it in its header
(``lpbounds: requires: [gymnasium]`` under ``jupyter:``); without it the notebook is not
executed and its page says so (the code is shown, without outputs).

``tests/project/test_notebooks.py`` executes every notebook with :func:`execute_all` too, so a
notebook that fails fails the test suite as well as the build. An executed notebook is
kept on disk (``$LPBOUNDS_NOTEBOOK_CACHE``, default ``~/.cache/lpbounds-docs/notebooks``;
``off`` keeps none) under a key of its text, the contents of the lpbounds sources and the
versions of Python and of the packages the notebooks use, so a rebuild re-executes only
the notebooks whose key changed.
"""

from __future__ import annotations

import asyncio
import base64
import hashlib
import html
import importlib.metadata
import importlib.util
import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

#: the folder of docs/ holding the notebooks, and the pages generated from them
FOLDER = "notebooks"
#: seconds one cell may run (the notebooks' cells take seconds)
CELL_TIMEOUT = 600
#: notebooks executed at once (one kernel each; the machines have 2 cores)
PARALLEL = max(1, min(2, os.cpu_count() or 1))
ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
#: packages whose version is part of an executed notebook's cache key
KEY_PACKAGES = (
    "numpy", "scipy", "matplotlib", "pandas", "highspy", "cvxpy", "clarabel",
    "gymnasium", "ipykernel", "nbclient", "jupytext",
)  # fmt: skip


def _kernel_env() -> dict[str, str]:
    env = dict(os.environ)
    # ipykernel's debugger warns on stderr about frozen modules at every start
    env.setdefault("PYDEVD_DISABLE_FILE_VALIDATION", "1")
    env.pop("MPLBACKEND", None)  # the kernel's own inline backend draws the figures
    return env


def _client(nb: Any, workdir: str) -> Any:
    from nbclient import NotebookClient
    from traitlets.config import Config

    # IPC sockets in the notebook's own temporary folder: nothing listens on a network
    # port while the notebook runs (and the kernel does not warn that TCP is unencrypted)
    config = Config({"KernelManager": {"transport": "ipc", "ip": os.path.join(workdir, "k")}})
    return NotebookClient(
        nb,
        config=config,
        kernel_name="python3",
        timeout=CELL_TIMEOUT,
        allow_errors=False,
        resources={"metadata": {"path": workdir}},
    )


def read(path: Path) -> Any:
    """The notebook at ``path`` (jupytext percent format) as an ``nbformat`` notebook."""
    import jupytext

    return jupytext.read(path, fmt="py:percent")


async def _execute_async(path: Path, sem: asyncio.Semaphore) -> Any:
    async with sem:
        nb = read(path)
        with tempfile.TemporaryDirectory(prefix=f"nb-{path.stem}-") as workdir:
            await _client(nb, workdir).async_execute(env=_kernel_env())
        return nb


def execute_all(paths: list[Path], *, return_exceptions: bool = False) -> list[Any]:
    """Execute the notebooks at ``paths`` (``PARALLEL`` at a time) and return them.

    Parameters
    ----------
    paths : list of Path
        Notebooks in jupytext's percent format.
    return_exceptions : bool
        Return the exception a notebook raised in its place, instead of raising the first.

    Returns
    -------
    list of nbformat.NotebookNode
        The executed notebooks, in the order of ``paths``, with their outputs.

    Raises
    ------
    nbclient.exceptions.CellExecutionError
        When a cell raises (the message has the cell and the traceback).
    """

    async def run() -> list[Any]:
        sem = asyncio.Semaphore(PARALLEL)
        jobs = (_execute_async(p, sem) for p in paths)
        return list(await asyncio.gather(*jobs, return_exceptions=return_exceptions))

    return asyncio.run(run())


def _fence(code: str, lang: str) -> str:
    ticks = "```"
    while ticks in code:
        ticks += "`"
    return f"{ticks}{lang}\n{code.rstrip()}\n{ticks}"


def _text_block(text: str, kind: str) -> str:
    body = html.escape(ANSI.sub("", text).rstrip("\n"))
    return f'<div class="nb-output"><pre class="nb-{kind}"><code>{body}</code></pre></div>'


def _rich(data: dict[str, Any], stem: str, name: str, images: dict[str, bytes]) -> str:
    """One ``execute_result`` / ``display_data`` output as Markdown or HTML."""
    for mime, ext in (("image/png", "png"), ("image/jpeg", "jpg")):
        if mime in data:
            file = f"{stem}/{name}.{ext}"
            images[file] = base64.b64decode(data[mime])
            return f"![Output of {name.replace('-', ' ')}]({file}){{ .nb-figure }}"
    if "image/svg+xml" in data:
        file = f"{stem}/{name}.svg"
        images[file] = str(data["image/svg+xml"]).encode()
        return f"![Output of {name.replace('-', ' ')}]({file}){{ .nb-figure }}"
    if "text/html" in data:
        body = re.sub(r"\n\s*\n", "\n", str(data["text/html"]).strip())
        return f'<div class="nb-output nb-html">\n{body}\n</div>'
    if "text/markdown" in data:
        return str(data["text/markdown"])
    return _text_block(str(data.get("text/plain", "")), "result")


def _outputs(outputs: list[Any], stem: str, cell: int, images: dict[str, bytes]) -> list[str]:
    parts: list[str] = []
    streams: dict[str, str] = {}

    def flush() -> None:
        for kind in ("stdout", "stderr"):
            if streams.get(kind):
                parts.append(_text_block(streams[kind], kind))
        streams.clear()

    for k, out in enumerate(outputs):
        if out["output_type"] == "stream":
            streams[out["name"]] = streams.get(out["name"], "") + out["text"]
            continue
        flush()
        if out["output_type"] in ("execute_result", "display_data"):
            parts.append(_rich(out["data"], stem, f"cell-{cell}-output-{k}", images))
        elif out["output_type"] == "error":  # only with allow_errors, never here
            parts.append(_text_block("\n".join(out["traceback"]), "stderr"))
    flush()
    return parts


def missing(nb: Any) -> list[str]:
    """The packages a notebook's header requires (``lpbounds: requires:``) that are absent."""
    needs = nb.metadata.get("lpbounds", {}).get("requires", [])
    return [name for name in needs if importlib.util.find_spec(name) is None]


def _banner(stem: str, absent: list[str]) -> str:
    links = f"[as text (.py)]({stem}.py)"
    if absent:
        names = ", ".join(f"`{name}`" for name in absent)
        return (
            '!!! warning "Not executed when this site was built"\n'
            f"    This notebook needs {names}, which the build's Python did not have, so "
            "its code is shown without outputs. Install it (`pip install "
            f'"lpbounds[notebooks]"`) and run the notebook, downloaded {links}.'
        )
    return (
        '!!! info "A notebook, executed when this site was built"\n'
        f"    This page is `docs/notebooks/{stem}.py`, a notebook kept as text (jupytext's "
        "percent format). Building the site executed it; every output below is from that "
        f"run. Download it [executed (.ipynb)]({stem}.ipynb) or {links}; "
        '`pip install "lpbounds[notebooks]"` installs what opens either (`jupyter lab`; '
        "a `.py`: right-click, Open With, Notebook) and runs them "
        "(`jupytext --execute --to ipynb`)."
    )


def to_markdown(nb: Any, stem: str) -> tuple[str, dict[str, bytes]]:
    """An executed notebook as a Markdown page, and the figure files it links to.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        An executed notebook (or one not executed, when :func:`missing` names a package:
        its page says so and shows the code alone).
    stem : str
        Its name (the page is ``notebooks/<stem>.md``; figures go to
        ``notebooks/<stem>/cell-<k>-output-<j>.png``).

    Returns
    -------
    tuple of (str, dict of str to bytes)
        The page's Markdown, and the figures (path relative to ``notebooks/`` -> bytes).
    """
    images: dict[str, bytes] = {}
    parts: list[str] = []
    banner = _banner(stem, missing(nb))
    for k, cell in enumerate(nb.cells):
        source = cell.source.strip("\n")
        if cell.cell_type == "markdown":
            parts.append(source)
            if k == 0:
                parts.append(banner)
        elif cell.cell_type == "code" and source.strip():
            parts.append(_fence(source, "python"))
            parts += _outputs(cell.get("outputs", []), stem, k, images)
    if not nb.cells or nb.cells[0].cell_type != "markdown":
        parts.insert(0, banner)
    return "\n\n".join(parts) + "\n", images


def library_digest() -> str:
    """A digest of the lpbounds sources' contents, Python's and the key packages' versions."""
    spec = importlib.util.find_spec("lpbounds")
    roots = list(spec.submodule_search_locations or []) if spec else []
    h = hashlib.sha256(sys.version.encode())
    for name in KEY_PACKAGES:
        try:
            h.update(f"{name}={importlib.metadata.version(name)}\n".encode())
        except importlib.metadata.PackageNotFoundError:
            h.update(f"{name} absent\n".encode())
    for root in roots:
        for p in sorted(Path(root).rglob("*")):
            if p.suffix in (".py", ".toml") and p.is_file():
                h.update(f"{p.relative_to(root)}\n".encode() + p.read_bytes())
    return h.hexdigest()


def cache_dir() -> Path | None:
    """Where executed notebooks are kept (``$LPBOUNDS_NOTEBOOK_CACHE``; None: ``off``)."""
    where = os.environ.get("LPBOUNDS_NOTEBOOK_CACHE", "")
    if where.lower() == "off":
        return None
    if where:
        return Path(where)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "lpbounds-docs" / "notebooks"


def cache_key(path: Path, library: str | None = None) -> str:
    """The key of an executed notebook: its text and :func:`library_digest`."""
    lib = library_digest() if library is None else library
    return hashlib.sha256(path.read_bytes() + lib.encode()).hexdigest()[:32]


def store(path: Path, nb: Any, key: str) -> None:
    """Keep an executed notebook under ``key``, replacing older ones of the same name."""
    import nbformat

    folder = cache_dir()
    if folder is None:
        return
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob(f"{path.stem}-*.ipynb"):
        old.unlink(missing_ok=True)
    tmp = folder / f".{path.stem}-{key}.{os.getpid()}.tmp"
    tmp.write_text(nbformat.writes(nb))
    tmp.replace(folder / f"{path.stem}-{key}.ipynb")


def _cached(path: Path, key: str) -> Any:
    import nbformat

    folder = cache_dir()
    file = None if folder is None else folder / f"{path.stem}-{key}.ipynb"
    if file is None or not file.exists():
        return None
    try:
        return nbformat.reads(file.read_text(), as_version=4)
    except Exception:  # a damaged entry is executed again
        return None


def _executed(paths: list[Path]) -> list[Any]:
    """The notebooks, executed or from the cache; those whose requirements are absent, read."""
    from mkdocs.exceptions import PluginError
    from nbclient.exceptions import CellExecutionError

    lib = library_digest()
    keys = [cache_key(p, lib) for p in paths]
    out = [_cached(p, key) for p, key in zip(paths, keys, strict=True)]
    todo = []
    for k, p in enumerate(paths):
        if out[k] is None:
            nb = read(p)
            if missing(nb):
                out[k] = nb
            else:
                todo.append(k)
    try:
        done = execute_all([paths[k] for k in todo])
    except CellExecutionError as err:
        raise PluginError(
            f"a notebook in docs/{FOLDER}/ failed:\n{ANSI.sub('', str(err))}"
        ) from err
    for k, nb in zip(todo, done, strict=True):
        store(paths[k], nb, keys[k])
        out[k] = nb
    return out


def _put(files: Any, file: Any) -> None:
    """Add ``file`` to the site, in place of a file of the same name."""
    old = files.get_file_from_path(file.src_uri)
    if old is not None:
        files.remove(old)
    files.append(file)


def on_files(files: Any, config: Any) -> Any:
    """Add one page, one ``.ipynb`` and its figures for every ``docs/notebooks/*.py``."""
    import nbformat
    from mkdocs.structure.files import File

    sources = sorted(
        (f for f in files if re.fullmatch(rf"{FOLDER}/[^/]+\.py", f.src_uri)),
        key=lambda f: f.src_uri,
    )
    paths = [Path(f.abs_src_path) for f in sources if f.abs_src_path]
    # an .ipynb beside the .py (left by `jupytext --execute --to ipynb`) is not published:
    # the site's notebooks are the ones this build executed
    for f in [f for f in files if re.fullmatch(rf"{FOLDER}/[^/]+\.ipynb", f.src_uri)]:
        files.remove(f)
    for path, nb in zip(paths, _executed(paths), strict=True):
        text, images = to_markdown(nb, path.stem)
        _put(files, File.generated(config, f"{FOLDER}/{path.stem}.md", content=text))
        if not missing(nb):
            ipynb = nbformat.writes(nb)
            _put(files, File.generated(config, f"{FOLDER}/{path.stem}.ipynb", content=ipynb))
        for name, data in images.items():
            _put(files, File.generated(config, f"{FOLDER}/{name}", content=data))
    return files
