"""Closures (Z, f) of the paper (Section 6) in a registry; see :func:`make_closure`.

>>> from granflow.rheology import CLOSURES
>>> "mu_i" in CLOSURES
True
"""
from granflow.rheology.base import CLOSURES, Closure, make_closure, make_equilibrium
from granflow.rheology import drucker_prager, generic, mu_i, power_law, references  # noqa: F401  (register)
from granflow.rheology.derive import Derivation, derive_dilatancy, parse_yield_function
from granflow.rheology.references import YieldLaw

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
