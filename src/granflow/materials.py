"""Physical parameters of the grains and the gas, and the inertial-number convention.

Source: MODEL.md §1 and the paper's eqs ``def:I`` (inertial number) and ``beta``/``darcy``
(Carman-Kozeny permeability).
"""
from __future__ import annotations

from enum import Enum

import numpy as np
from pydantic import Field

from granflow.params import Params


class InertialConvention(float, Enum):
    """Factor c_I in I = c_I d |S| / sqrt(p / rho_s).

    In simple shear |S| = |gamma_dot| / 2, so the paper's I (c_I = 1) is half the I of
    GDR MiDi / Jop et al. / Barker et al., in which the literature's mu(I) and phi(I) parameters
    (I0 = 0.3, Delta_phi = 0.2, ...) are defined. C1-C3 are invariant under I -> c I; I_eq,
    lambda and F-tilde are not.
    """

    LITERATURE = 2.0
    """I = d gamma_dot / sqrt(p/rho_s) in simple shear (GDR MiDi 2004, Jop et al. 2006). Default."""
    PAPER = 1.0
    """I = d |S| / sqrt(p/rho_s) exactly as in the paper (eq. def:I)."""


class Material(Params):
    """Grains, gas and packing parameters (SI units).

    Attributes
    ----------
    d : float
        Grain diameter [m]. Default 80e-6 (Roche's glass beads: 45-90 um).
    rho_s : float
        Grain (solid) density [kg m^-3]. Default 2500 (glass).
    eta_f : float
        Gas dynamic viscosity [Pa s]. Default 1.8e-5 (air).
    p_atm : float
        Atmospheric (reference) pressure [Pa]. Default 1.013e5.
    rho_f0 : float
        Gas density at p_atm [kg m^-3]. Default 1.0 (the paper's value).
    phi_max : float
        Maximum (random close) packing fraction [-], phi_eq(0). Default 0.6.
    delta_phi : float
        Slope of the linear equilibrium law phi_eq(I) = phi_max - delta_phi I [-]. Default 0.2.
    c_I : float
        Inertial-number convention factor (see :class:`InertialConvention`). Default 2.
    """

    d: float = Field(80e-6, gt=0, lt=1, description="grain diameter [m]")
    rho_s: float = Field(2500.0, gt=0, description="grain density [kg m^-3]")
    eta_f: float = Field(1.8e-5, gt=0, description="gas dynamic viscosity [Pa s]")
    p_atm: float = Field(1.013e5, gt=0, description="atmospheric pressure [Pa]")
    rho_f0: float = Field(1.0, gt=0, description="gas density at p_atm [kg m^-3]")
    phi_max: float = Field(0.6, gt=0, lt=1, description="maximum packing fraction [-]")
    delta_phi: float = Field(0.2, gt=0, lt=1, description="slope of phi_eq(I) [-]")
    c_I: float = Field(
        float(InertialConvention.LITERATURE), gt=0,
        description="inertial-number convention factor c_I in I = c_I d|S|/sqrt(p/rho_s) [-]",
    )

    def inertial_number(self, S, p):
        """Inertial number I = c_I d |S| / sqrt(p / rho_s) [-] (paper eq. def:I times c_I).

        Parameters
        ----------
        S : array_like
            Deviatoric strain-rate norm |S| [s^-1], |S|^2 = S:S/2.
        p : array_like
            Granular pressure [Pa], >= 0.

        Returns
        -------
        ndarray
            I, with I = 0 where |S| = 0 (also at p = 0) and I = inf where p <= 0 < |S|; NaN in
            either input gives NaN (so that NaN checks downstream see it).
        """
        S = np.asarray(S, dtype=float)
        p = np.asarray(p, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            I = self.c_I * self.d * S * np.sqrt(self.rho_s) / np.sqrt(p)
        I = np.where(S <= 0, 0.0, np.where(p <= 0, np.inf, I))
        return np.where(np.isnan(S) | np.isnan(p), np.nan, I)

    def shear_rate_scale(self, p):
        """sqrt(p/rho_s)/(c_I d) [s^-1]: the |S| at which I = 1, so that I = |S| / scale."""
        return np.sqrt(np.asarray(p, dtype=float) / self.rho_s) / (self.c_I * self.d)

    @property
    def inertial_scale(self) -> float:
        """c_I d sqrt(rho_s) [kg^1/2 m^-1/2]: I = inertial_scale |S| / sqrt(p) (paper eq. def:I times
        c_I), the denominator of the dilatancy law's pressure term 2 B(phi) sqrt(p)/(c_I d sqrt(rho_s))
        (:meth:`granflow.rheology.base.Closure.compaction_coefficient`)."""
        return self.c_I * self.d * np.sqrt(self.rho_s)

    def permeability(self, phi):
        """Carman-Kozeny mobility kappa(phi) = d^2 (1-phi)^3 / (150 eta_f phi^2) [m^2 Pa^-1 s^-1].

        Paper eqs ``beta`` and ``darcy``: kappa = (1-phi)^2 / beta(phi).
        """
        phi = np.asarray(phi, dtype=float)
        return self.d**2 * (1.0 - phi) ** 3 / (150.0 * self.eta_f * phi**2)

    def gas_diffusivity(self, phi):
        """Pore-pressure diffusivity D = p_atm kappa(phi) / (1 - phi) [m^2 s^-1] (MODEL.md §6.7)."""
        phi = np.asarray(phi, dtype=float)
        return self.p_atm * self.permeability(phi) / (1.0 - phi)
