"""Cases: one ``setup(config) -> Simulation`` per case, in the :data:`CASES` registry
(STYLE.md idiom 5), called by ``granflow run``, the examples and the tests alike. Every module of
this package is a case module, found and imported by :func:`discover`: the registry, the runner and
the shared set-up helpers are in :mod:`granflow.casekit` (adding a case is one file, see
docs/cases.md).

>>> from granflow.cases import CASES
>>> CASES.names()
['column_collapse', 'defluidisation_column', 'inclined_layer', 'lagree_column', 'sheared_layer', 'static_layer']
"""
import os
from collections.abc import Iterable
from pathlib import Path

from granflow.casekit.registry import CASES, Case, CaseRegistry
from granflow.errors import GranflowInputError
from granflow.registry import alias_modules, discover_modules

CASES_PATH_ENV = "GRANFLOW_CASES_PATH"
"""Environment variable: directories (separated by ``os.pathsep``, ":" on Linux) whose modules
are case modules too, imported with granflow's own -- so that ``granflow run``, ``--restart`` and
``granflow list cases`` (and the local workers of ``granflow sweep``, which inherit the
environment) know a case kept outside the package (docs/cases.md, "Writing a new case in Python")."""

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


def environment_paths() -> list[str]:
    """The directories of :data:`CASES_PATH_ENV` (empty entries skipped); a GranflowInputError
    naming the variable for an entry that is not a directory."""
    out = []
    for entry in os.environ.get(CASES_PATH_ENV, "").split(os.pathsep):
        if not entry.strip():
            continue
        folder = Path(entry).expanduser()
        if not folder.is_dir():
            raise GranflowInputError(f"{CASES_PATH_ENV}: {entry!r} is not a directory")
        out.append(str(folder.resolve()))
    return out


discover(environment_paths())

__all__ = ["CASES", "CASES_PATH_ENV", "MOVED", "Case", "CaseRegistry", "discover", "environment_paths"]
