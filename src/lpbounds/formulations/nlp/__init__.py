"""The disjunctive NLP of Section 4 (lower bounds) and the cutting planes that solve it.

:mod:`~lpbounds.formulations.nlp.problem` holds the model class, :mod:`~.results` its
results, :mod:`~.stop` the reasons a method stops (:class:`StopReason`),
:mod:`~lpbounds.formulations.nlp.cuts` the general cutting-plane loop and its LPs, and
:mod:`~lpbounds.formulations.nlp.monotone` the monotone cuts of the patrol's NLP. Imports
run one way: ``problem`` imports ``cuts`` and ``monotone``, ``monotone`` imports ``cuts``;
neither imports ``problem`` (they read the NLP passed to them through its public
attributes).
"""

from .problem import METHOD_KEYWORDS, NLP, NLPMILP, NLPIteration, NLPResult
from .stop import StopReason

__all__ = ["METHOD_KEYWORDS", "NLP", "NLPMILP", "NLPIteration", "NLPResult", "StopReason"]
