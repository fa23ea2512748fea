"""Drucker-Prager closures: plain (Section ssec-DP1) and with a dilatancy angle (Section 6.4.1).

Z = sin(delta) with f = sin(delta)(1 - I_eq/I)                       (eqs. f-DP, syst4DP)
Z = sin(delta) + cos(delta) psi, f = psi,
psi = sin(delta)/(1 - cos(delta)) (1 - (I_eq/I)^beta),
beta = 2(1 - cos(delta))/(2 + cos(delta))                             (eqs. Z1, f1, psi)
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import Field

from granflow.rheology.base import CLOSURES, Closure, _arr



MIN_DILATANCY_DELTA_DEG = 1e-3
"""Smallest friction angle of :class:`DruckerPragerDilatancy` [deg]: psi divides by 1 - cos(delta),
which is 0 in double precision below ~1e-6 deg (``delta_deg = 1e-300`` raised ZeroDivisionError)."""

class DruckerPragerYield(Closure):
    """Mixin holding the internal friction angle.

    Attributes
    ----------
    delta_deg : float
        Internal friction angle delta [degrees], 0 < delta < 90. Default 25.
    """

    delta_deg: float = Field(25.0, gt=0, lt=90, description="internal friction angle [deg]")

    @property
    def sin_delta(self) -> float:
        return float(np.sin(np.radians(self.delta_deg)))

    @property
    def cos_delta(self) -> float:
        return float(np.cos(np.radians(self.delta_deg)))


@CLOSURES.register("drucker_prager")
class DruckerPrager(DruckerPragerYield):
    """Drucker-Prager yield with the stabilising divergence law (paper §6.1).

    Z = sin(delta), f = sin(delta)(1 - I_eq(phi)/I); div u = 2 sin(delta)|S|
    - 2 lambda sin(delta)(phi_max - phi) sqrt(p) with lambda = 1/(c_I delta_phi d sqrt(rho_s))
    for the linear equilibrium law (eq. syst4DP with the c_I convention).
    """

    summary: ClassVar[str] = "Z = sin(delta), f = sin(delta)(1 - I_eq/I)"
    source: ClassVar[str] = "f-DP, syst4DP"

    def Z(self, phi, I):
        return np.full(np.broadcast(_arr(phi), _arr(I)).shape, self.sin_delta)

    def dZ_dI(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    dZ_dphi = dZ_dI

    def A(self, phi, I):
        return np.full(np.broadcast(_arr(phi), _arr(I)).shape, self.sin_delta)

    def dA_dI(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    dA_dphi = dA_dI

    def B(self, phi):
        return self.sin_delta * self.I_eq(phi)

    def dB_dphi(self, phi):
        return self.sin_delta * self.equilibrium.dI_eq_dphi(phi)


@CLOSURES.register("drucker_prager_dilatancy")
class DruckerPragerDilatancy(DruckerPragerYield):
    """Drucker-Prager with a dilatancy angle psi chosen to satisfy C1 (paper §6.4.1, eq. psi).

    Z = sin(delta) + cos(delta) psi, f = psi. Note (MODEL.md §6.4): Z < 0 when
    I_eq/I > cos(delta)^(-1/beta) (about 4.66 at delta = 30 deg), where the closure stops being
    well posed. For phi > phi_max, I_eq is clipped at 0.
    """

    summary: ClassVar[str] = "Z = sin(delta) + cos(delta) psi, f = psi (dilatancy angle)"
    source: ClassVar[str] = "Z1, f1, psi"
    delta_deg: float = Field(30.0, ge=MIN_DILATANCY_DELTA_DEG, lt=90,
                             description="internal friction angle [deg]")

    @property
    def beta(self) -> float:
        """Exponent beta = 2(1 - cos delta)/(2 + cos delta) [-]."""
        c = self.cos_delta
        return 2.0 * (1.0 - c) / (2.0 + c)

    @property
    def _K(self) -> float:
        return self.sin_delta / (1.0 - self.cos_delta)

    def _ratio(self, phi, I):
        """I_eq/I, taken as 0 where I_eq = 0 (phi >= phi_max), also at I = 0 (limit I_eq -> 0 first)."""
        Ieq = np.maximum(self.I_eq(phi), 0.0)
        I = _arr(I)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where((Ieq == 0) & ~np.isnan(I), 0.0, Ieq / I)

    def psi(self, phi, I):
        """Dilatancy angle psi(phi, I) [rad] (eq. psi)."""
        with np.errstate(over="ignore"):
            return self._K * (1.0 - self._ratio(phi, I) ** self.beta)

    def Z(self, phi, I):
        return self.sin_delta + self.cos_delta * self.psi(phi, I)

    def dZ_dI(self, phi, I):
        return self.cos_delta * self.dA_dI(phi, I)

    def dZ_dphi(self, phi, I):
        return self.cos_delta * self.dA_dphi(phi, I)

    def A(self, phi, I):
        return self.psi(phi, I)

    def dA_dI(self, phi, I):
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return self._K * self.beta * self._ratio(phi, I) ** self.beta / _arr(I)

    def dA_dphi(self, phi, I):
        """d psi/d phi [-]; 0 where I_eq is clipped at 0 (phi >= phi_max: right derivative)."""
        Ieq = np.maximum(self.I_eq(phi), 0.0)
        dIeq = self.equilibrium.dI_eq_dphi(phi)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            d = -self._K * self.beta * Ieq ** (self.beta - 1.0) * dIeq / _arr(I) ** self.beta
        return np.where(Ieq == 0, 0.0, d)

    def _compaction_part(self, phi, p, S):
        """X = |S|^(1-beta) q^beta = |S| (I_eq/I)^beta, q = I_eq sqrt(p/rho_s)/(c_I d) [s^-1];
        0 at |S| = 0 or p = 0 (also where I_eq = inf), +inf where I_eq = inf < |S| p."""
        phi, p, S = _arr(phi), _arr(p), _arr(S)
        Ieq = np.maximum(self.I_eq(phi), 0.0)
        b = self.beta
        with np.errstate(invalid="ignore", over="ignore"):
            q = np.where(p <= 0, 0.0, Ieq * self.material.shear_rate_scale(np.maximum(p, 0.0)))
            return np.where((S <= 0) | (q == 0), 0.0, np.maximum(S, 0.0) ** (1.0 - b) * q**b)

    def div_rate(self, phi, p, S):
        """2|S| psi in closed form: 2K(|S| - |S|^(1-beta) q^beta), q = I_eq sqrt(p/rho_s)/(c_I d),
        finite at |S| = 0 and p = 0 [s^-1]."""
        return 2.0 * self._K * (_arr(S) - self._compaction_part(phi, p, S))

    def dissipation_density(self, phi, p, S):
        """2 (Z - f) p |S| + 2 eta_visc |S|^2 with Z - f = sin(delta) (I_eq/I)^beta (paper, §6.4.1):
        2 sin(delta) p |S|^(1-beta) q^beta + 2 eta_visc |S|^2 [W m^-3], finite everywhere."""
        p, S = _arr(p), _arr(S)
        return 2.0 * self.sin_delta * np.maximum(p, 0.0) * self._compaction_part(phi, p, S) \
            + 2.0 * self.eta_visc * S**2
