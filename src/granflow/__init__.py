"""granflow: dense granular flows fluidised by pore-gas pressure (Chupin & Dubois model).

Public API: :class:`Material`, the closure registry and :func:`make_closure`, the equilibrium
laws, and the theory toolkit in :mod:`granflow.theory`.
"""
from granflow.errors import GranflowError, GranflowInputError

__version__ = "0.1.0.dev0"

from granflow._lazy import lazy_attributes

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

__getattr__, __dir__ = lazy_attributes(__name__, globals(), _LAZY)

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
