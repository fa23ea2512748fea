"""The pore-gas law: which pore-pressure equation the model carries (MODEL.md §2), shared by the
solver (:mod:`granflow.physics.pore_pressure`, :class:`granflow.model.Model`), the case files
(``[gas] law``) and the linear-stability analysis (:mod:`granflow.theory.dispersion`)."""
from __future__ import annotations

from enum import Enum


class GasLaw(str, Enum):
    """Pore-gas equation."""

    NONE = "none"
    """Dry model: no gas unknown, p_f = 0."""
    LINEAR = "linear"
    """Paper eq. syst2b / pressure-diffusion: diffusion ``p_atm div(kappa grad p_f)``."""
    NONLINEAR = "nonlinear"
    """Paper eq. pressure-diffusion-nonlinear: ``div(kappa (p_atm + p_f) grad p_f)`` (lagged in the
    solver)."""
