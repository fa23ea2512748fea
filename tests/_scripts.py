"""Loading the repository's scripts (validation/*/run.py, benchmarks/*.py, docs/*.py) in tests.

They are not importable modules (no package), so tests load them from their path. One loader
for every test file, instead of one copy per file.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def load_script(rel: str, name: str | None = None, *, cached: bool = False) -> ModuleType:
    """Execute ``ROOT/rel`` as a module and return it.

    ``name`` defaults to ``rel`` with ``/`` and ``.`` replaced by ``_``; the module is registered
    in ``sys.modules`` under it (dataclasses resolve annotations there). ``cached=True`` returns
    the module already registered under that name (scripts that are slow to import, or whose
    module-level state the test file shares); otherwise it is executed afresh.
    """
    name = name or rel.replace("/", "_").replace(".", "_")
    if cached and name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / rel)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod
