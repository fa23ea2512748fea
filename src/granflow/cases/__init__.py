"""Cases: one ``setup(config) -> Simulation`` per case, in the :data:`CASES` registry
(STYLE.md idiom 5), called by ``granflow run``, the examples and the tests alike. Every module of
this package is a case module, found and imported by :func:`discover`: the registry, the runner and
the shared set-up helpers are in :mod:`granflow.casekit` (adding a case is one file, see
docs/cases.md).

>>> from granflow.cases import CASES
>>> CASES.names()
['column_collapse', 'defluidisation_column', 'inclined_layer', 'lagree_column', 'sheared_layer', 'static_layer']
"""
from collections.abc import Iterable

from granflow.casekit.registry import CASES, Case, CaseRegistry
from granflow.registry import alias_modules, discover_modules

MOVED = ("common", "headlines", "memory", "options", "preparation", "registry", "restart", "runner",
         "step_clock", "sweep_member")
"""Modules that were in this package until issue 18 and are in :mod:`granflow.casekit` now: the
old paths ``granflow.cases.<module>`` still import them (the same module objects)."""
alias_modules(__name__, {name: f"granflow.casekit.{name}" for name in MOVED})


def discover(paths: Iterable[str] = ()) -> list[str]:
    """Import the case modules (registering their cases); returns their names, sorted.

    ``paths``: extra directories whose modules are case modules too (they become
    ``granflow.cases.<name>``); run once at import with none.
    """
    return discover_modules(__name__, __path__, paths=paths)


discover()

__all__ = ["CASES", "MOVED", "Case", "CaseRegistry", "discover"]
