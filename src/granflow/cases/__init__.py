"""Cases: one ``setup(config) -> Simulation`` per case, in the :data:`CASES` registry
(STYLE.md idiom 5), called by ``granflow run``, the examples and the tests alike. Each case module
of this package is found and imported by :func:`discover`; the others are in :data:`INFRASTRUCTURE`.

>>> from granflow.cases import CASES
>>> CASES.names()
['column_collapse', 'defluidisation_column', 'inclined_layer', 'lagree_column', 'sheared_layer', 'static_layer']
"""
from collections.abc import Iterable

from granflow.cases.registry import CASES, Case, CaseRegistry
from granflow.registry import discover_modules

#: The modules of this package that define no case (registry, runner, shared set-up helpers,
#: restarts, sweeps, ...): not imported here, so ``import granflow.cases`` stays light. Every other
#: module is a case module (adding a case is one file, see docs/cases.md).
INFRASTRUCTURE = ("common", "headlines", "memory", "options", "preparation", "registry",
                  "restart", "runner", "step_clock", "sweep_member")


def discover(paths: Iterable[str] = ()) -> list[str]:
    """Import the case modules (registering their cases); returns their names, sorted.

    ``paths``: extra directories whose modules are case modules too (they become
    ``granflow.cases.<name>``); run once at import with none.
    """
    return discover_modules(__name__, __path__, INFRASTRUCTURE, paths)


discover()

__all__ = ["CASES", "INFRASTRUCTURE", "Case", "CaseRegistry", "discover"]
