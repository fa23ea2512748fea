"""Closures (Z, f) of the paper (Section 6) in a registry; see :func:`make_closure`.

Adding a closure is one file: every module of this package is a closure module, imported here
(:func:`discover`) so that its ``@CLOSURES.register`` classes are registered, except the modules
named in :data:`INFRASTRUCTURE` (see docs/closures.md).

>>> from granflow.rheology import CLOSURES
>>> "mu_i" in CLOSURES
True
"""
from collections.abc import Iterable

from granflow.registry import discover_modules
from granflow.rheology.base import CLOSURES, Closure, make_closure, make_equilibrium

#: The modules of this package that define no closure (the interface, the SymPy derivation, the
#: shared functions mu(I), G(I), ..., the generator of docs/closures.md); every other module is a
#: closure module.
INFRASTRUCTURE = ("base", "derive", "docs", "functions")


def discover(paths: Iterable[str] = ()) -> list[str]:
    """Import the closure modules (registering their closures); returns their names, sorted.

    ``paths``: extra directories whose modules are closure modules too (they become
    ``granflow.rheology.<name>``); run once at import with none.
    """
    return discover_modules(__name__, __path__, INFRASTRUCTURE, paths)


discover()

from granflow.rheology.references import YieldLaw  # noqa: E402  (a closure module, discovered)

#: Names of :mod:`granflow.rheology.derive`, imported on first access: it imports SymPy
#: (~0.2 s), which only the generic closure and ``granflow derive`` need.
_DERIVE = ("Derivation", "derive_dilatancy", "parse_yield_function")


def __getattr__(name: str):
    if name in _DERIVE:
        from granflow.rheology import derive

        return getattr(derive, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "CLOSURES",
    "Closure",
    "Derivation",
    "INFRASTRUCTURE",
    "YieldLaw",
    "derive_dilatancy",
    "discover",
    "make_closure",
    "make_equilibrium",
    "parse_yield_function",
]
