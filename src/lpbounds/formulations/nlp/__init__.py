"""The disjunctive NLP of Section 4 (lower bounds) and the cutting planes that solve it.

:mod:`~lpbounds.formulations.nlp.problem` holds the model class, :mod:`~.results` its
results, :mod:`~.stop` the reasons a method stops (:class:`StopReason`),
:mod:`~lpbounds.formulations.nlp.cuts` the general cutting-plane loop and its LPs, and
:mod:`~lpbounds.formulations.nlp.monotone` the monotone cuts of the patrol's NLP. Imports
run one way: ``problem`` imports ``cuts`` and ``monotone``, ``monotone`` imports ``cuts``;
neither imports ``problem`` (they read the NLP passed to them through its public
attributes).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..._lazy import attach

if TYPE_CHECKING:  # what type checkers see; at run time see __getattr__
    from .problem import METHOD_KEYWORDS, NLP, NLPMILP, NLPIteration, NLPResult
    from .stop import StopReason

#: public name -> the submodule that defines it (imported on first access, PEP 562)
_LAZY: dict[str, str] = {
    "METHOD_KEYWORDS": "problem",
    "NLP": "problem",
    "NLPMILP": "problem",
    "NLPIteration": "problem",
    "NLPResult": "problem",
    "StopReason": "stop",
}

__all__ = ["METHOD_KEYWORDS", "NLP", "NLPMILP", "NLPIteration", "NLPResult", "StopReason"]

__getattr__, __dir__ = attach(__name__, _LAZY)
