"""mu(I) closures: the paper's stabilised mu(I) (§6.2) and Robinson's mu(I) with dilatancy (§6.4.2).

Z = mu(I), f = F(I) - (I_eq/I) F(I_eq)              (eqs. mu(I), F-mu(I), syst4mu(I))
Z = mu(I) + psi, f = psi, psi = G(I) - G(I_eq)       (eqs. eq:86, eq:87, psi:mu(I))
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import Field, model_validator

from granflow.rheology.base import CLOSURES, Closure, _arr
from granflow.rheology.functions import F_mu, dF_mu, dmu_dI, mu_of_I, robinson_dG, robinson_G, robinson_h


class MuIYield(Closure):
    """Mixin holding the mu(I) parameters (defaults: glass beads, Forterre & Pouliquen 2008).

    Attributes
    ----------
    mu1 : float
        Static friction coefficient mu(0) [-]. Default tan(21 deg).
    mu2 : float
        Limiting friction coefficient mu(inf) [-]. Default tan(33 deg).
    I0 : float
        Inertial-number scale [-], in the material's convention. Default 0.3.
    """

    mu1: float = Field(float(np.tan(np.radians(21.0))), gt=0, description="mu(0) [-]")
    mu2: float = Field(float(np.tan(np.radians(33.0))), gt=0, description="mu(inf) [-]")
    I0: float = Field(0.3, gt=0, description="inertial-number scale of mu(I) [-]")

    @model_validator(mode="after")
    def _ordered(self):
        if not self.mu2 > self.mu1:
            raise ValueError(f"mu2 = {self.mu2} must exceed mu1 = {self.mu1}")
        return self

    def mu(self, I):
        """Friction coefficient mu(I) [-] (eq. mu(I))."""
        return mu_of_I(I, self.mu1, self.mu2, self.I0)

    def dmu(self, I):
        return dmu_dI(I, self.mu1, self.mu2, self.I0)


@CLOSURES.register("mu_i")
class MuI(MuIYield):
    """mu(I) rheology with the stabilising divergence law (paper §6.2).

    div u = 2 F(I)|S| - 2 F~(phi) sqrt(p), F~ = I_eq F(I_eq)/(c_I d sqrt(rho_s)).
    """

    summary: ClassVar[str] = "Z = mu(I), f = F(I) - (I_eq/I) F(I_eq)"
    source: ClassVar[str] = "mu(I), F-mu(I), syst4mu(I)"

    def Z(self, phi, I):
        return self.mu(np.broadcast_to(_arr(I), np.broadcast(_arr(phi), _arr(I)).shape))

    def dZ_dI(self, phi, I):
        return self.dmu(np.broadcast_to(_arr(I), np.broadcast(_arr(phi), _arr(I)).shape))

    def dZ_dphi(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    def F(self, I):
        """F(I) = (3/(2I)) int_0^I mu - mu/2 [-] (eq. F-mu(I))."""
        return F_mu(I, self.mu1, self.mu2, self.I0)

    def dF(self, I):
        return dF_mu(I, self.mu1, self.mu2, self.I0)

    def A(self, phi, I):
        return self.F(np.broadcast_to(_arr(I), np.broadcast(_arr(phi), _arr(I)).shape))

    def dA_dI(self, phi, I):
        return self.dF(np.broadcast_to(_arr(I), np.broadcast(_arr(phi), _arr(I)).shape))

    def dA_dphi(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    def B(self, phi):
        Ieq = self.I_eq(phi)
        return Ieq * self.F(Ieq)

    def dB_dphi(self, phi):
        Ieq = self.I_eq(phi)
        return (self.F(Ieq) + Ieq * self.dF(Ieq)) * self.equilibrium.dI_eq_dphi(phi)


@CLOSURES.register("mu_i_dilatancy")
class MuIDilatancy(MuIYield):
    """mu(I) with Robinson et al.'s dilatancy angle, chosen to satisfy C1 (paper §6.4.2).

    Z = mu(I) + psi, f = psi = G(I) - G(I_eq(phi)). psi -> -inf as I -> 0 (so Z < 0 for
    I << I_eq) and psi = +inf at phi = phi_max (I_eq = 0) for any I > 0: the checker reports
    both.
    """

    summary: ClassVar[str] = "Z = mu(I) + psi, f = psi = G(I) - G(I_eq) (Robinson)"
    source: ClassVar[str] = "eq:86, eq:87, psi:mu(I)"

    def G(self, I):
        return robinson_G(I, self.mu1, self.mu2, self.I0)

    def dG(self, I):
        return robinson_dG(I, self.mu1, self.mu2, self.I0)

    def psi(self, phi, I):
        """Dilatancy angle psi = G(I) - G(I_eq) [rad] (eq. psi:mu(I))."""
        with np.errstate(invalid="ignore"):
            return self.G(I) - self.G(self.I_eq(phi))

    def Z(self, phi, I):
        return self.mu(I) + self.psi(phi, I)

    def dZ_dI(self, phi, I):
        return self.dmu(I) + self.dG(I) + np.zeros_like(_arr(phi))

    def dZ_dphi(self, phi, I):
        return self.dA_dphi(phi, I)

    A = psi

    def dA_dI(self, phi, I):
        return self.dG(I) + np.zeros_like(_arr(phi))

    def dA_dphi(self, phi, I):
        with np.errstate(invalid="ignore"):
            return -self.dG(self.I_eq(phi)) * self.equilibrium.dI_eq_dphi(phi) + np.zeros_like(_arr(I))

    def div_rate(self, phi, p, S):
        """2|S| psi with psi = (2 mu1/3) ln(I/I_eq) + (mu2 - mu1)/3 (h(I/I0) - h(I_eq/I0)) [s^-1]:
        0 at |S| = 0 (|S| ln|S| -> 0), +inf where |S| > 0 and p = 0 or I_eq = 0."""
        phi, p, S = _arr(phi), _arr(p), _arr(S)
        Ieq = np.maximum(self.I_eq(phi), 0.0)
        I = self.material.inertial_number(S, p)
        finite = (S > 0) & (p > 0) & (Ieq > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            log_ratio = np.log(np.where(finite, I, 1.0)) - np.log(np.where(finite, Ieq, 1.0))
            psi = (2.0 * self.mu1 / 3.0) * log_ratio + (self.mu2 - self.mu1) / 3.0 * (
                robinson_h(np.where(finite, I, 0.0) / self.I0) - robinson_h(np.where(finite, Ieq, 0.0) / self.I0)
            )
        out = np.where(finite, 2.0 * S * psi, np.where(S > 0, np.inf, 0.0))
        return np.where(np.isnan(S) | np.isnan(p) | np.isnan(Ieq), np.nan, out)

    def dissipation_density(self, phi, p, S):
        """2 (Z - f) p |S| + 2 eta_visc |S|^2 with Z - f = mu(I) exactly (paper §6.4.2) [W m^-3];
        finite also where psi is infinite (I_eq = 0 or inf)."""
        phi, p, S = _arr(phi), _arr(p), _arr(S)
        I = self.material.inertial_number(S, p)
        yield_part = np.where((S <= 0) | (p <= 0), 0.0, 2.0 * self.mu(I) * p * S)
        return yield_part + 2.0 * self.eta_visc * S**2 + np.zeros_like(phi)
