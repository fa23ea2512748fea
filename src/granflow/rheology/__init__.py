"""Closures (Z, f) of the paper (Section 6) in a registry; see :func:`make_closure`.

>>> from granflow.rheology import CLOSURES
>>> "mu_i" in CLOSURES
True
"""
from granflow.rheology.base import CLOSURES, Closure, make_closure, make_equilibrium
from granflow.rheology import drucker_prager, generic, mu_i, power_law, references  # noqa: F401  (register)
from granflow.rheology.references import YieldLaw

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
    "YieldLaw",
    "derive_dilatancy",
    "make_closure",
    "make_equilibrium",
    "parse_yield_function",
]
