"""Cases: one ``setup(config) -> Simulation`` per case, in the :data:`CASES` registry
(STYLE.md idiom 5), called by ``granflow run``, the examples and the tests alike.

>>> from granflow.cases import CASES
>>> CASES.names()
['column_collapse', 'static_layer']
"""
from granflow.cases import column_collapse, static_layer  # noqa: F401  (register)
from granflow.cases import defluidisation_column  # noqa: F401  (register)
from granflow.cases import sheared_layer  # noqa: F401  (register)
from granflow.cases import inclined_layer  # noqa: F401  (register)
from granflow.cases.registry import CASES, Case, CaseRegistry

__all__ = ["CASES", "Case", "CaseRegistry"]
