"""Reference closures kept for comparison: Roux-Radjai and incompressible (MODEL.md §3).

Both violate the paper's theory on purpose: Roux-Radjai's f = a (phi - phi_eq(I)) (eq.
roux_radjai / f-RR) violates C1 (ill-posed); incompressible f = 0 is the classical isochoric model,
well posed for mu(I) only in a window of I (Barker et al. 2015) and never for Drucker-Prager.
"""
from __future__ import annotations

from enum import Enum
from typing import ClassVar

import numpy as np
from pydantic import Field, model_validator

from granflow.rheology.base import CLOSURES, Closure, _arr
from granflow.rheology.functions import dmu_dI, mu_of_I


class YieldLaw(str, Enum):
    """Yield function of a reference closure."""

    MU_I = "mu_i"
    """Z = mu(I) = mu1 + (mu2 - mu1)/(1 + I0/I)."""
    DRUCKER_PRAGER = "drucker_prager"
    """Z = sin(delta)."""


class SelectableYield(Closure):
    """Mixin: Z = mu(I) or sin(delta), chosen by ``yield_law``.

    Attributes
    ----------
    yield_law : {"mu_i", "drucker_prager"}
        Default "mu_i".
    mu1, mu2, I0 : float
        mu(I) parameters [-] (used when yield_law = "mu_i").
    delta_deg : float
        Friction angle [deg] (used when yield_law = "drucker_prager").
    """

    reference: ClassVar[bool] = True
    yield_law: YieldLaw = Field(YieldLaw.MU_I, description="yield function: mu_i or drucker_prager")
    mu1: float = Field(float(np.tan(np.radians(21.0))), gt=0, description="mu(0) [-]")
    mu2: float = Field(float(np.tan(np.radians(33.0))), gt=0, description="mu(inf) [-]")
    I0: float = Field(0.3, gt=0, description="inertial-number scale of mu(I) [-]")
    delta_deg: float = Field(25.0, gt=0, lt=90, description="internal friction angle [deg]")

    @model_validator(mode="after")
    def _ordered(self):
        if self.yield_law is YieldLaw.MU_I and not self.mu2 > self.mu1:
            raise ValueError(f"mu2 = {self.mu2} must exceed mu1 = {self.mu1}")
        return self

    def Z(self, phi, I):
        I = np.broadcast_to(_arr(I), np.broadcast(_arr(phi), _arr(I)).shape)
        if self.yield_law is YieldLaw.MU_I:
            return mu_of_I(I, self.mu1, self.mu2, self.I0)
        return np.full(I.shape, float(np.sin(np.radians(self.delta_deg))))

    def dZ_dI(self, phi, I):
        I = np.broadcast_to(_arr(I), np.broadcast(_arr(phi), _arr(I)).shape)
        if self.yield_law is YieldLaw.MU_I:
            return dmu_dI(I, self.mu1, self.mu2, self.I0)
        return np.zeros(I.shape)

    def dZ_dphi(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)


@CLOSURES.register("roux_radjai")
class RouxRadjai(SelectableYield):
    """f = a (phi - phi_eq(I)) (Roux & Radjai 1998; paper eq. roux_radjai). Violates C1.

    Attributes
    ----------
    a : float
        Dilatancy constant [-]. Default 1.
    """

    summary: ClassVar[str] = "reference: f = a (phi - phi_eq(I)); violates C1"
    source: ClassVar[str] = "roux_radjai, f-RR"
    a: float = Field(1.0, gt=0, description="dilatancy constant a [-]")

    def A(self, phi, I):
        return self.a * (_arr(phi) - self.equilibrium.phi_eq(I))

    def dA_dI(self, phi, I):
        return -self.a * self.equilibrium.dphi_eq_dI(I) + np.zeros_like(_arr(phi))

    def dA_dphi(self, phi, I):
        return np.full(np.broadcast(_arr(phi), _arr(I)).shape, self.a)


@CLOSURES.register("incompressible")
class Incompressible(SelectableYield):
    """f = 0: the classical isochoric model (div u = 0) with a mu(I) or Drucker-Prager yield."""

    summary: ClassVar[str] = "reference: f = 0 (isochoric), Z = mu(I) or sin(delta)"
    source: ClassVar[str] = "def:tau with div u = 0"
    isochoric: ClassVar[bool] = True

    def A(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    dA_dI = A
    dA_dphi = A
