"""MkDocs hook: pages written by other parts of the project that may not exist yet.

``docs/benchmarks.md`` (written by the benchmark scripts) and ``docs/nlp.md`` (the NLP's
measured runs) are linked from the site. Until a file is there, a placeholder page says
so, so that ``mkdocs build --strict`` checks every other link without failing on these.
Once the real file exists this hook does nothing.
"""

from __future__ import annotations

from mkdocs.structure.files import File

PLACEHOLDERS = {
    "benchmarks.md": (
        "# Benchmarks\n\nThis page is written by the scripts in `benchmarks/` "
        "(`python benchmarks/<script>.py`); it has not been generated in this checkout.\n"
    ),
    "nlp.md": (
        "# NLP: measured runs\n\nThe measured rounds, cuts, times and final gaps of the NLP's "
        "methods are recorded here by the NLP's benchmark; not generated in this checkout.\n"
    ),
}


def on_files(files, config):
    for name, text in PLACEHOLDERS.items():
        if files.get_file_from_path(name) is None:
            files.append(File.generated(config, name, content=text))
    return files
