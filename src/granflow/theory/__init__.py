"""Theory toolkit: derivation of f from Z (:func:`derive_dilatancy`), condition checks (C1-C3,
dissipation, equilibrium, Z >= 0: :func:`check`), the Barker et al. (2015) window of
incompressible mu(I) (:mod:`granflow.theory.barker`), the dispersion relation of the linearised
model (:mod:`granflow.theory.dispersion`) and the homogeneous fluidisation of an injected bed
(:mod:`granflow.theory.fluidisation`).

The public names are imported on first use (:mod:`granflow._lazy`), so that a run that only needs
:mod:`granflow.theory.fluidisation` does not import SymPy."""
from granflow._lazy import lazy_attributes

_NAMES = {"Derivation": "granflow.rheology.derive", "c1_residual": "granflow.rheology.derive",
          "derive_dilatancy": "granflow.rheology.derive", "CheckReport": "granflow.theory.conditions",
          "check": "granflow.theory.conditions", "condition_map": "granflow.theory.conditions"}
__getattr__, __dir__ = lazy_attributes(__name__, globals(), _NAMES)

__all__ = ["CheckReport", "Derivation", "c1_residual", "check", "condition_map", "derive_dilatancy"]
