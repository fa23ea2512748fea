"""Loading the repository's scripts (validation/*/run.py, benchmarks/*.py, docs/*.py) in tests.

They are not importable modules (no package), so tests load them from their path. One loader
for every test file and for the scripts themselves (granflow.verification.scripts).
"""
from __future__ import annotations

from pathlib import Path
from types import ModuleType

from granflow.verification import scripts

ROOT = Path(__file__).resolve().parents[1]


def load_script(rel: str, name: str | None = None, *, cached: bool = False) -> ModuleType:
    """Execute ``ROOT/rel`` as a module and return it (:func:`granflow.verification.scripts.load_script`,
    the loader the validation scripts use for each other).

    ``name`` defaults to ``rel`` with ``/`` and ``.`` replaced by ``_``; the module is registered
    in ``sys.modules`` under it (dataclasses resolve annotations there). ``cached=True`` returns
    the module already registered under that name (scripts that are slow to import, or whose
    module-level state the test file shares); otherwise it is executed afresh.
    """
    return scripts.load_script(ROOT / rel, name or rel.replace("/", "_").replace(".", "_"), cached=cached)
