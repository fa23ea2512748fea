"""Cases: one ``setup(config) -> Simulation`` per case, in the :data:`CASES` registry
(STYLE.md idiom 5), called by ``granflow run``, the examples and the tests alike.

>>> from granflow.cases import CASES
>>> CASES.names()
['column_collapse', 'defluidisation_column', 'inclined_layer', 'lagree_column', 'sheared_layer', 'static_layer']
"""
from granflow.cases import (  # noqa: F401  (each module registers its case)
    column_collapse,
    defluidisation_column,
    inclined_layer,
    lagree_column,
    sheared_layer,
    static_layer,
)
from granflow.cases.registry import CASES, Case, CaseRegistry

__all__ = ["CASES", "Case", "CaseRegistry"]
