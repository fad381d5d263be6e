"""Default arguments shared by the library and the command line, in a module that imports
nothing, so that ``lpbounds SUBCOMMAND --help`` can show them without loading the modules
that use them (:mod:`lpbounds.studies.compare`, :mod:`lpbounds.patrol.reproduce`: numpy, cvxpy,
matplotlib). Import them from those modules."""

from __future__ import annotations

#: The package's version (``lpbounds.__version__``), here so that every layer can record it
#: without importing the package facade.
VERSION = "0.1.0"

#: The default study: the teaching instance and two seeded random sizes.
DEFAULT_INSTANCES: tuple[str, ...] = ("garnet:100:10:1", "garnet-small", "garnet:600:60:2")
#: Formulations of the default study.
DEFAULT_FORMULATIONS: tuple[str, ...] = ("ELP", "RLP")

#: The reproduction's model, output folder and Monte Carlo seeds.
DEFAULT_MODEL = "models/patrol-paper.toml"
DEFAULT_OUT = "out/reproduce"
DEFAULT_SEEDS: tuple[int, ...] = (1, 2, 3, 4, 5)

#: Shifts (seconds) of a study's shifted geometric means of time: Mittelmann's 10 s, and
#: 0.01 s, which separates solvers on sub-second solves (lpbounds.studies.report).
DEFAULT_SHIFTS: tuple[float, ...] = (10.0, 0.01)
