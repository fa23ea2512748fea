"""PEP 562 lazy attributes for package ``__init__`` modules: public names imported from their
defining submodule on first access, so that importing a package (and ``granflow --help``) does
not import NumPy, SciPy, pydantic or SymPy until a name is used."""
from __future__ import annotations

import importlib
from typing import Callable


def lazy_attributes(package: str, namespace: dict, names: dict[str, str]) -> tuple[Callable, Callable]:
    """``(__getattr__, __dir__)`` for the module ``package`` whose globals are ``namespace``:
    ``names`` maps each public name to the module that defines it; a resolved name is cached in
    ``namespace``."""

    def __getattr__(name: str):
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(names))

    return __getattr__, __dir__
