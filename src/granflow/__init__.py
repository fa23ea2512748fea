"""granflow: dense granular flows fluidised by pore-gas pressure (Chupin & Dubois model).

Public API: :class:`Material`, the closure registry and :func:`make_closure`, the equilibrium
laws, and the theory toolkit in :mod:`granflow.theory`.
"""
from granflow.equilibrium import EQUILIBRIUM_LAWS, EquilibriumLaw
from granflow.errors import GranflowError, GranflowInputError
from granflow.materials import InertialConvention, Material
from granflow.rheology import CLOSURES, Closure, derive_dilatancy, make_closure

__version__ = "0.1.0.dev0"

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
