"""The pore-gas law and its compressibility: which pore-pressure equation the model carries
(docs/model.md §2), shared by the solver (:mod:`granflow.physics.pore_pressure`,
:class:`granflow.model.Model`), the case files (``[gas] law``, ``[gas] compressibility``) and the
linear-stability analysis (:mod:`granflow.theory.dispersion`, isothermal)."""
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


AIR_HEAT_CAPACITY_RATIO = 1.4
"""gamma = c_p/c_v of air (a diatomic ideal gas, 7/5) [-]: the polytropic index of an adiabatic gas."""


class GasCompressibility(str, Enum):
    """How the pore gas's density follows its pressure (``[gas] compressibility``; docs/model.md §2).

    The state law, linearised about p_atm, is ``rho_f = rho_f0 (1 + p_f/(n p_atm))`` with the
    polytropic index n [-]: n = 1 for the paper's isothermal ideal gas (eq. ``ideal-gas``),
    n = gamma for an adiabatic one (Poisson's law ``p rho_f^-gamma = const``). Carried through the
    gas mass balance exactly as the paper derives syst2b, it divides the storage terms by n:

        (1/n) [d_t((1 - phi) p_f) + div((1 - phi) p_f u)] + p_atm div u = p_atm div(kappa grad p_f)   [Pa s^-1]

    so the pore-pressure diffusivity is ``D = n p_atm kappa(phi)/(1 - phi)`` [m^2 s^-1] (n times
    faster decay of every diffusive mode); the coupling ``p_atm div u``, the Darcy flux and the
    injection condition ``-kappa dp_f/dz = U_inj`` are unchanged. Only with the linear law: the
    non-linear law (eq. ``pressure-diffusion-nonlinear``) is the isothermal state law itself."""

    ISOTHERMAL = "isothermal"
    """n = 1: the paper's gas equation syst2b (default)."""
    ADIABATIC = "adiabatic"
    """n = :data:`AIR_HEAT_CAPACITY_RATIO`: an adiabatic (isentropic) gas, D 1.4 times larger."""

    @property
    def polytropic_index(self) -> float:
        """n of the state law [-] (1 or :data:`AIR_HEAT_CAPACITY_RATIO`)."""
        return 1.0 if self is GasCompressibility.ISOTHERMAL else AIR_HEAT_CAPACITY_RATIO
