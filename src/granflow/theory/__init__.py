"""Theory toolkit: derivation of f from Z (:func:`derive_dilatancy`), condition checks (C1-C3,
dissipation, equilibrium, Z >= 0: :func:`check`), the Barker et al. (2015) window of
incompressible mu(I) (:mod:`granflow.theory.barker`) and the dispersion relation of the linearised
model (:mod:`granflow.theory.dispersion`)."""
from granflow.rheology.derive import Derivation, c1_residual, derive_dilatancy
from granflow.theory.conditions import CheckReport, check, condition_map

__all__ = ["CheckReport", "Derivation", "c1_residual", "check", "condition_map", "derive_dilatancy"]
