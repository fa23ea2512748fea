"""Exact solution of the homogeneous sheared layer with the Drucker-Prager closure (MODEL.md §7,
NUMERICS.md §11 item 2).

Under imposed |S| and p, mass (syst1b) and dilatancy (syst4DP) give the logistic equation
    dphi/dt = -phi div u = beta phi (phi_eq - phi),
    beta = 2 lambda sin(delta) sqrt(p),  lambda = 1/(c_I delta_phi d sqrt(rho_s)),
    phi_eq = phi_max - delta_phi I,
whose solution is phi(t) = phi_eq / (1 + (phi_eq/phi0 - 1) exp(-beta phi_eq t)).
"""
from __future__ import annotations

import numpy as np


def drucker_prager_layer(t, phi0: float, p: float, S: float, *, sin_delta: float, d: float, rho_s: float,
                         phi_max: float, delta_phi: float, c_I: float):
    """phi(t) [-] of the homogeneous DP layer (t in s, p in Pa, S = |S| in s^-1)."""
    lam = 1.0 / (c_I * delta_phi * d * np.sqrt(rho_s))
    beta = 2.0 * lam * sin_delta * np.sqrt(p)
    I = c_I * d * S / np.sqrt(p / rho_s)
    phi_eq = phi_max - delta_phi * I
    return phi_eq / (1.0 + (phi_eq / phi0 - 1.0) * np.exp(-beta * phi_eq * np.asarray(t, dtype=float)))


def drucker_prager_rate(p: float, S: float, *, sin_delta: float, d: float, rho_s: float, phi_max: float,
                        delta_phi: float, c_I: float) -> float:
    """Relaxation rate beta phi_eq [s^-1] of the logistic solution."""
    lam = 1.0 / (c_I * delta_phi * d * np.sqrt(rho_s))
    I = c_I * d * S / np.sqrt(p / rho_s)
    return 2.0 * lam * sin_delta * np.sqrt(p) * (phi_max - delta_phi * I)
