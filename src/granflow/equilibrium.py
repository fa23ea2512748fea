"""Equilibrium (critical-state) laws phi_eq(I) and their inverses I_eq(phi).

Source: paper eqs ``phi(I)`` and ``I(phi)`` (linear law) and the remark after them (Schaeffer et al.
2019, Robinson et al. 2023, Breard et al. 2022). MODEL.md §1. All quantities are dimensionless;
I follows the material's inertial-number convention (the parameters below are those of the
convention in which they were fitted: the literature's, c_I = 2, unless stated otherwise).

For phi > phi_max (outside the physical range) the linear law is extrapolated linearly (as in the
paper's proof of Theorem th4); the other laws return I_eq(phi_max) = 0, which keeps the sign
property "phi >= phi_max implies I >= I_eq" used by Theorem th4.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import Field

from granflow.params import Params
from granflow.registry import Registry


class EquilibriumLaw(Params):
    """Base class: a decreasing law phi_eq(I) with phi_eq(0) = phi_max.

    Attributes
    ----------
    phi_max : float
        Packing fraction at I = 0 [-].
    """

    name: ClassVar[str]
    formula: ClassVar[str] = ""
    phi_max: float = Field(0.6, gt=0, lt=1, description="packing fraction at I = 0 [-]")

    def phi_eq(self, I):
        """Equilibrium packing fraction at inertial number I [-]."""
        raise NotImplementedError

    def I_eq(self, phi):
        """Equilibrium inertial number at packing fraction phi [-] (inverse of phi_eq)."""
        raise NotImplementedError

    def dI_eq_dphi(self, phi):
        """Derivative dI_eq/dphi [-] (negative in the physical range)."""
        raise NotImplementedError

    def dphi_eq_dI(self, I):
        """Derivative dphi_eq/dI [-]."""
        raise NotImplementedError


EQUILIBRIUM_LAWS: Registry[EquilibriumLaw] = Registry("equilibrium law")


def _gap(law: EquilibriumLaw, phi):
    """phi_max - phi, clipped at 0 (used by the non-linear laws)."""
    return np.maximum(law.phi_max - np.asarray(phi, dtype=float), 0.0)


@EQUILIBRIUM_LAWS.register("linear")
class LinearEquilibrium(EquilibriumLaw):
    """phi_eq(I) = phi_max - delta_phi I (paper eq. phi(I); Forterre & Pouliquen 2008).

    Attributes
    ----------
    delta_phi : float
        Slope [-]; default 0.2.
    """

    formula: ClassVar[str] = "phi_max - delta_phi*I"
    delta_phi: float = Field(0.2, gt=0, lt=1, description="slope of phi_eq(I) [-]")

    def phi_eq(self, I):
        return self.phi_max - self.delta_phi * np.asarray(I, dtype=float)

    def I_eq(self, phi):
        return (self.phi_max - np.asarray(phi, dtype=float)) / self.delta_phi

    def dI_eq_dphi(self, phi):
        return np.full_like(np.asarray(phi, dtype=float), -1.0 / self.delta_phi)

    def dphi_eq_dI(self, I):
        return np.full_like(np.asarray(I, dtype=float), -self.delta_phi)


@EQUILIBRIUM_LAWS.register("schaeffer")
class SchaefferEquilibrium(EquilibriumLaw):
    """phi_eq(I) = phi_max - delta_phi / (1 + 1/I) (Schaeffer et al. 2019, p. 929).

    I_eq = x / (delta_phi - x) with x = phi_max - phi; infinite for phi <= phi_max - delta_phi.
    """

    formula: ClassVar[str] = "phi_max - delta_phi/(1 + 1/I)"
    delta_phi: float = Field(0.2, gt=0, lt=1, description="phi_max - phi_eq(inf) [-]")

    def phi_eq(self, I):
        I = np.asarray(I, dtype=float)
        with np.errstate(invalid="ignore"):
            return self.phi_max - self.delta_phi * np.where(np.isinf(I), 1.0, I / (1.0 + I))

    def I_eq(self, phi):
        x = _gap(self, phi)
        with np.errstate(divide="ignore"):
            return np.where(x < self.delta_phi, x / np.maximum(self.delta_phi - x, 0.0), np.inf)

    def dI_eq_dphi(self, phi):
        x = _gap(self, phi)
        with np.errstate(divide="ignore"):
            d = -self.delta_phi / np.maximum(self.delta_phi - x, 0.0) ** 2
        return np.where(np.asarray(phi) < self.phi_max, d, 0.0)

    def dphi_eq_dI(self, I):
        I = np.asarray(I, dtype=float)
        return -self.delta_phi / (1.0 + I) ** 2


@EQUILIBRIUM_LAWS.register("robinson")
class RobinsonEquilibrium(EquilibriumLaw):
    """phi_eq(I) = phi_max - A I^a (Robinson et al. 2023, p. 3): A = 0.1305, a = 0.8156."""

    formula: ClassVar[str] = "phi_max - A*I**a"
    A: float = Field(0.1305, gt=0, description="prefactor [-]")
    a: float = Field(0.8156, gt=0, description="exponent [-]")

    def phi_eq(self, I):
        return self.phi_max - self.A * np.asarray(I, dtype=float) ** self.a

    def I_eq(self, phi):
        return (_gap(self, phi) / self.A) ** (1.0 / self.a)

    def dI_eq_dphi(self, phi):
        x = _gap(self, phi)
        with np.errstate(divide="ignore"):
            d = -(1.0 / (self.a * self.A)) * (x / self.A) ** (1.0 / self.a - 1.0)
        return np.where(np.asarray(phi) < self.phi_max, d, 0.0)

    def dphi_eq_dI(self, I):
        I = np.asarray(I, dtype=float)
        with np.errstate(divide="ignore"):
            return -self.A * self.a * I ** (self.a - 1.0)


@EQUILIBRIUM_LAWS.register("breard")
class BreardEquilibrium(EquilibriumLaw):
    """phi_eq(I) = phi_max / (1 + I) (Breard et al. 2022, p. 10)."""

    formula: ClassVar[str] = "phi_max/(1 + I)"

    def phi_eq(self, I):
        return self.phi_max / (1.0 + np.asarray(I, dtype=float))

    def I_eq(self, phi):
        """phi_max/phi - 1; inf at phi = 0 (an empty cell), 0 for phi >= phi_max."""
        phi = np.minimum(np.asarray(phi, dtype=float), self.phi_max)
        with np.errstate(divide="ignore"):
            return self.phi_max / phi - 1.0

    def dI_eq_dphi(self, phi):
        phi = np.asarray(phi, dtype=float)
        with np.errstate(divide="ignore"):
            return np.where(phi < self.phi_max, -self.phi_max / phi**2, 0.0)

    def dphi_eq_dI(self, I):
        return -self.phi_max / (1.0 + np.asarray(I, dtype=float)) ** 2
