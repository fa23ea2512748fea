"""What the validation scripts (``validation/*/run.py``) share: loading a sibling script as a
module (``dry_runout`` uses ``lagree_column``'s fronts and fits, ``fluidised_vs_dry/convergence``
uses ``dry_runout``, ``well_posedness`` reads ``lagree_column``'s runs) and reading and writing a
study's JSON results file. The scripts are not a package, so a script is loaded from its path;
tests/_scripts.py loads them the same way.

The shape of a validation script (issue 18 item 5): ``run(resolution, quick=False)`` runs one level
(``resolution`` is the script's level parameter: cells over the layer, an index into its list of
levels, a time step, as its docstring says) and ``main(argv)`` parses ``--quick``, a smoke run of
seconds that CI runs (tests/validation_smoke/).
"""
from __future__ import annotations

import copy
import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

SCRIPT_PREFIX = "validation"
"""Prefix of the module name a script is registered under (``validation_lagree_column_run``)."""
JSON_INDENT = 1
"""Indentation of the results files (one level per line, diff-friendly)."""


def script_name(path: str | Path) -> str:
    """``.../validation/lagree_column/run.py`` -> ``validation_lagree_column_run``."""
    p = Path(path)
    return f"{SCRIPT_PREFIX}_{p.parent.name}_{p.stem}"


def load_script(path: str | Path, name: str | None = None, *, cached: bool = True) -> ModuleType:
    """Execute the script at ``path`` as a module registered in ``sys.modules`` as ``name``
    (default :func:`script_name`; dataclasses resolve their annotations there) and return it.
    ``cached=True`` returns the module already registered under that name, so the scripts that
    load the same sibling share one copy of it."""
    name = name or script_name(path)
    if cached and name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, Path(path))
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def load_json(path: str | Path, default: Any) -> Any:
    """The parsed JSON file at ``path``, or a deep copy of ``default`` if it does not exist."""
    p = Path(path)
    return json.loads(p.read_text()) if p.exists() else copy.deepcopy(default)


def save_json(data: Any, path: str | Path, *, fallback=None) -> None:
    """Write ``data`` to ``path`` as JSON, keys sorted, :data:`JSON_INDENT`, trailing newline;
    ``fallback`` converts what JSON cannot hold (``json.dumps(default=...)``, e.g. ``float`` for
    NumPy scalars)."""
    Path(path).write_text(json.dumps(data, indent=JSON_INDENT, sort_keys=True, default=fallback) + "\n")
