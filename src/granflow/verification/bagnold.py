"""The exact steady state of a uniform mu(I) layer on an infinite incline: the Bagnold profile
(MODEL.md §3, §7; GDR MiDi 2004, Eur. Phys. J. E 14, 341; Jop, Forterre & Pouliquen 2006, Nature
441, 727), dry or with a base gas over-pressure carrying ``beta`` of the weight.

The stress ratio of a steady uniform layer is tan(theta) at every depth and the gas carries beta of
the weight, so ``mu(I_theta) = tan(theta)/(1 - beta)``; with mu(I) = mu1 + (mu2 - mu1)/(1 + I0/I)

    I_theta = I0 (mu - mu1)/(mu2 - mu)                          (needs mu1 < mu < mu2),

``phi = phi_eq(I_theta)`` is uniform, ``p = (1 - beta) phi rho_s g cos(theta) (h - z)``, and with
``I = c_I d |S|/sqrt(p/rho_s)``, ``|S| = |du/dz|/2``,

    u(z) = (4 I_theta/(3 c_I d)) sqrt((1 - beta) phi g cos(theta)) [h^(3/2) - (h - z)^(3/2)].

The one definition used by the ``inclined_layer`` case (:mod:`granflow.cases.inclined_layer`) and
validation/inclined_plane/run.py; tests/integration/test_inclined_plane.py derives it independently and checks
this module against its derivation. SI units, angles in rad.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

BAGNOLD_EXPONENT = 1.5
"""u ~ h^(3/2) - (h - z)^(3/2): |S| ~ sqrt(p) ~ sqrt(h - z) integrated over z."""
BAGNOLD_NUMERATOR, BAGNOLD_DENOMINATOR = 4.0, 3.0
"""The prefactor 4/3 = 2 (from |S| = |du/dz|/2) x 2/3 (from integrating sqrt(h - z))."""


def steady_inertial_number(mu: float, mu1: float, mu2: float, I0: float) -> float:
    """I [-] with ``mu(I) = mu1 + (mu2 - mu1)/(1 + I0/I) = mu``: ``I0 (mu - mu1)/(mu2 - mu)``
    (meaningful for mu1 < mu < mu2; the caller checks)."""
    return I0 * (mu - mu1) / (mu2 - mu)


@dataclass(frozen=True)
class BagnoldLayer:
    """The steady state of the layer (module docstring).

    Attributes
    ----------
    theta : float
        Slope [rad].
    beta : float
        Fraction of the weight carried by the gas [-].
    I, phi : float
        I_theta [-] and phi_eq(I_theta) [-].
    h : float
        Layer thickness [m].
    c_I, d : float
        Inertial-number coefficient [-] and grain diameter [m].
    g : float
        Magnitude of gravity [m s^-2].
    """

    theta: float
    beta: float
    I: float
    phi: float
    h: float
    c_I: float
    d: float
    g: float

    def velocity(self, z) -> np.ndarray:
        """u(z) [m s^-1] at heights z [m]; constant (= u_s) above the surface."""
        scale = (BAGNOLD_NUMERATOR * self.I / (BAGNOLD_DENOMINATOR * self.c_I * self.d)
                 * math.sqrt((1.0 - self.beta) * self.phi * self.g * math.cos(self.theta)))
        depth = np.clip(self.h - np.asarray(z, dtype=float), 0.0, None)
        return scale * (self.h ** BAGNOLD_EXPONENT - depth ** BAGNOLD_EXPONENT)

    @property
    def surface_velocity(self) -> float:
        """u_s = u(h) [m s^-1]."""
        return float(self.velocity(self.h))
