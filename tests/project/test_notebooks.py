"""The notebooks of ``docs/notebooks/`` execute, and a notebook that fails fails the suite.

Each notebook is a jupytext percent-format script; it is read with jupytext and executed
with nbclient in a fresh kernel by the docs build's own hook (``docs/_hooks/notebooks.py``,
two at a time), the same code the site's build runs. The notebooks assert the claims they
make (a bound that does not hold, an LP optimum that is not the fixed point of its rows),
so a wrong number raises inside a cell and fails its test here. A notebook that needs an
optional package it lacks (``lpbounds: requires:`` in its header) is skipped, naming it.
The executed notebooks are also kept in the hook's cache, so a docs build in the same run
does not execute them again.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
FOLDER = ROOT / "docs" / "notebooks"
NOTEBOOKS = sorted(FOLDER.glob("*.py"))
REASON = "the notebooks need jupytext, nbclient and ipykernel: pip install -e '.[test]'"

for _name in ("jupytext", "nbclient", "ipykernel"):
    pytest.importorskip(_name, reason=REASON)


def _hook() -> Any:
    spec = importlib.util.spec_from_file_location(
        "lpbounds_docs_notebooks", ROOT / "docs" / "_hooks" / "notebooks.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


HOOK = _hook()

#: a notebook whose assert fails: executed with the others, it must come back as an error
FAILING = """# %% [markdown]
# # A notebook whose claim is false

# %%
value = sum(range(4))
assert value == 7, f"the sum is {value}"
"""


@pytest.fixture(scope="module")
def executed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Every runnable notebook and the failing one, executed in one batch (by stem)."""
    failing = tmp_path_factory.mktemp("nb") / "false_claim.py"
    failing.write_text(FAILING)
    runnable = [p for p in NOTEBOOKS if not HOOK.missing(HOOK.read(p))]
    paths = [*runnable, failing]
    results = HOOK.execute_all(paths, return_exceptions=True)
    library = HOOK.library_digest()
    for path, nb in zip(runnable, results[: len(runnable)], strict=True):
        if not isinstance(nb, BaseException):
            HOOK.store(path, nb, HOOK.cache_key(path, library))
    return {p.stem: nb for p, nb in zip(paths, results, strict=True)}


def test_the_teaching_notebooks_are_there():
    names = {p.stem for p in NOTEBOOKS}
    expected = {
        "theorem1_cost_independence", "theorem2_no_lifting", "lemma2_surrogate",
        "nlp_bracket", "patrol_bounds", "gymnasium_frozenlake", "exact_theorem1",
    }  # fmt: skip
    assert expected <= names, expected - names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_asserts_its_claims(path):
    nb = HOOK.read(path)
    code = "\n".join(c.source for c in nb.cells if c.cell_type == "code")
    assert code.count("assert ") >= 2, f"{path.name} checks nothing it shows"
    assert nb.cells[0].cell_type == "markdown" and nb.cells[0].source.startswith("# ")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_executes(path, executed):
    absent = HOOK.missing(HOOK.read(path))
    if absent:
        pytest.skip(f"{path.name} needs {', '.join(absent)}, not installed")
    nb = executed[path.stem]
    if isinstance(nb, BaseException):
        pytest.fail(f"{path.name} failed:\n{HOOK.ANSI.sub('', str(nb))[-3000:]}")
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o["output_type"] == "error"]
    assert any(o["output_type"] == "stream" for o in outputs), "prints nothing"
    figures = [o for o in outputs if "image/png" in o.get("data", {})]
    assert figures, f"{path.name} draws no figure"


def test_a_failing_notebook_is_reported(executed):
    err = executed["false_claim"]
    assert isinstance(err, Exception), "a notebook whose assert fails was not reported"
    assert "the sum is 6" in HOOK.ANSI.sub("", str(err))


#: the README's commands for the notebooks (its "Notebooks" paragraph)
OPEN = 'pip install -e ".[notebooks]" && jupyter lab docs/notebooks'
RUN = "jupytext --execute --to ipynb docs/notebooks/*.py"


def test_the_notebooks_extra_opens_and_runs_them():
    """One extra installs what the README's commands need; CI runs them in a fresh venv."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib  # type: ignore[no-redef]

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = {
        re.split(r"[<>=!~\[; ]", req, maxsplit=1)[0].lower()
        for req in project["optional-dependencies"]["notebooks"]
    }
    # jupytext reads the .py files; --execute runs them with nbconvert (without it: "nbconvert
    # is required"); jupyterlab opens them (jupytext's lab extension); ipykernel is the
    # kernel; nbclient runs them in the docs build; gymnasium for the Gymnasium notebook
    need = {"jupytext", "nbconvert", "jupyterlab", "ipykernel", "nbclient", "gymnasium"}
    assert need <= names, need - names
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert OPEN in readme and RUN in readme
    ci = (ROOT / ".ci" / "run").read_text()
    assert 'pip install -q -e ".[notebooks]"' in ci and RUN in ci


def test_page_of_a_notebook_shows_its_outputs(executed):
    nb = executed["theorem1_cost_independence"]
    if isinstance(nb, BaseException):
        pytest.skip("the notebook failed (reported by test_notebook_executes)")
    text, images = HOOK.to_markdown(nb, "theorem1_cost_independence")
    assert text.startswith("# Theorem 1")
    assert "A notebook, executed when this site was built" in text
    assert '<div class="nb-output">' in text and "v* =" in text  # printed text
    assert images and all(data.startswith(b"\x89PNG") for data in images.values())
    for name in images:
        assert f"]({name})" in text


def test_page_of_a_notebook_without_its_package(tmp_path):
    path = tmp_path / "needs_missing.py"
    path.write_text(
        "# ---\n# jupyter:\n#   lpbounds:\n#     requires:\n#     - no_such_package_lpb\n# ---\n\n"
        "# %% [markdown]\n# # Needs a package\n\n# %%\nimport no_such_package_lpb\n"
    )
    nb = HOOK.read(path)
    assert HOOK.missing(nb) == ["no_such_package_lpb"]
    text, images = HOOK.to_markdown(nb, path.stem)
    assert "Not executed when this site was built" in text and "`no_such_package_lpb`" in text
    assert "import no_such_package_lpb" in text and not images
