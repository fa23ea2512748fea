"""granflow: dense granular flows fluidised by pore-gas pressure (Chupin & Dubois model).

Public API: :class:`Material`, the closure registry and :func:`make_closure`, the equilibrium
laws, and the theory toolkit in :mod:`granflow.theory`.
"""
from granflow.errors import GranflowError, GranflowInputError

__version__ = "0.1.0.dev0"

#: Public names imported on first access (PEP 562), so that ``import granflow`` and the
#: ``granflow`` command's start-up do not import NumPy, pydantic and SymPy until they are used.
_LAZY = {
    "CLOSURES": "granflow.rheology",
    "Closure": "granflow.rheology",
    "derive_dilatancy": "granflow.rheology",
    "make_closure": "granflow.rheology",
    "EQUILIBRIUM_LAWS": "granflow.equilibrium",
    "EquilibriumLaw": "granflow.equilibrium",
    "InertialConvention": "granflow.materials",
    "Material": "granflow.materials",
}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

__all__ = [
    "CLOSURES",
    "EQUILIBRIUM_LAWS",
    "Closure",
    "EquilibriumLaw",
    "GranflowError",
    "GranflowInputError",
    "InertialConvention",
    "Material",
    "__version__",
    "derive_dilatancy",
    "make_closure",
]
