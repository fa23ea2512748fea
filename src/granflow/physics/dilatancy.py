"""The dilatancy law div u = 2|S| f(phi, p, I) (paper eq. syst4b) with the asymptotic-preserving
(AP) treatment of its stiff relaxation (NUMERICS.md §5.2, MODEL.md §6.6).

Writing the stiff-safe law as div u = R(phi; p, |S|) (``Closure.div_rate``), an explicit update
phi^{n+1} = phi^n (1 - dt R(phi^n)) overshoots phi_max once dt * phi dR/dphi >> 1 (relaxation rates
1e3-1e5 s^-1). Evaluating R at the packing predicted by the Lagrangian update,
R(phi^{n+1}) ~ R(phi^n) - dR/dphi dt phi^n R, gives

    div u = fac * R(phi^n),      fac = 1 / (1 + dt phi^n dR/dphi),

with dR/dphi = 2|S| dA/dphi - dG/dphi sqrt(p) >= 0 (G the compaction coefficient). For
Drucker-Prager this is NUMERICS.md's fac = 1/(1 + dt phi 2 lambda sin(delta) sqrt(p)), and the
update lands on phi_eq(I) without overshoot for any dt:
phi^{n+1} - phi_eq = (phi^n - phi_eq) / (1 + dt phi^n dR/dphi).
"""
from __future__ import annotations

import numpy as np

from enum import Enum

from granflow.errors import GranflowInputError


class LayerScheme(str, Enum):
    """Time discretisation of the homogeneous layer's mass equation phi' = -phi R(phi)."""

    AP_LINEARISED = "ap_linearised"
    """phi^{n+1} = phi^n (1 - dt fac R(phi^n)): the solver's constraint-row form. Exact landing for
    Drucker-Prager (R affine in phi); for strongly non-linear R (dilatancy-angle closures far from
    equilibrium) it can overshoot phi_eq and even phi_max at large dt."""
    BACKWARD_EULER = "backward_euler"
    """phi^{n+1} = phi^n (1 - dt R(phi^{n+1})), solved exactly (bracketed root): monotone, lands
    between phi^n and phi_eq(I) for every dt and every closure with R increasing in phi."""


def ddiv_rate_dphi(closure, phi, p, S):
    """dR/dphi at fixed (p, |S|) of the stiff-safe divergence law [s^-1] (derivative of
    ``closure.div_rate``), finite at |S| = 0: 2|S| dA/dphi - (dG/dphi) sqrt(p),
    G = 2 B(phi)/(c_I d sqrt(rho_s))."""
    phi, p, S = (np.asarray(x, dtype=float) for x in (phi, p, S))
    m = closure.material
    I = m.inertial_number(S, p)
    with np.errstate(all="ignore"):
        shear = np.where(S > 0, 2.0 * S * closure.dA_dphi(phi, I), 0.0)
    dG = 2.0 * closure.dB_dphi(phi) / m.inertial_scale
    return shear - dG * np.sqrt(np.maximum(p, 0.0))


def ap_factor(closure, phi, p, S, dt: float):
    """AP factor fac = 1 / (1 + dt phi max(dR/dphi, 0)) [-] (NUMERICS.md §5.2, generalised to any
    closure). Negative dR/dphi (not produced by the paper's closures) is not amplified."""
    if not dt >= 0:
        raise GranflowInputError(f"dt must be >= 0 (got {dt})")
    return 1.0 / (1.0 + dt * np.asarray(phi, dtype=float) * np.maximum(ddiv_rate_dphi(closure, phi, p, S), 0.0))


def ap_div_rate(closure, phi, p, S, dt: float):
    """AP divergence law fac * R(phi^n) [s^-1]: the div u imposed over a step of length dt."""
    return ap_factor(closure, phi, p, S, dt) * closure.div_rate(phi, p, S)


def _backward_euler_scalar(closure, phi_n: float, p: float, S: float, dt: float) -> float:
    phi_eq = float(closure.equilibrium.phi_eq(closure.material.inertial_number(S, p)))
    if phi_n == phi_eq:
        return phi_n
    lo, hi = sorted((phi_n, phi_eq))

    def g(x: float) -> float:
        if x == phi_eq:  # R(phi_eq) = 0 exactly; its round-off (~1e-13) times a huge dt could
            return phi_eq - phi_n  # exceed |phi_n - phi_eq| and hide the sign change
        with np.errstate(all="ignore"):
            return x - phi_n + dt * phi_n * float(closure.div_rate(x, p, S))

    glo, ghi = g(lo), g(hi)
    if not (np.isfinite(glo) and np.isfinite(ghi)) or glo * ghi > 0:
        raise GranflowInputError(
            f"{closure.name}: backward-Euler root not bracketed between phi^n = {phi_n} and phi_eq = {phi_eq}"
        )
    if glo == 0.0:
        return lo
    if ghi == 0.0:
        return hi
    from scipy.optimize import brentq  # here: scipy.optimize is 0.16 s of every run's start-up

    return brentq(g, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps)


def homogeneous_layer_step(closure, phi, p, S, dt: float, scheme: LayerScheme = LayerScheme.AP_LINEARISED):
    """One step of a homogeneous layer under imposed |S| [s^-1] and p [Pa] (mass eq. syst1b in
    Lagrangian form, dilatancy eq. syst4b), with the given :class:`LayerScheme`."""
    scheme = LayerScheme(scheme)
    if scheme is LayerScheme.AP_LINEARISED:
        return np.asarray(phi, dtype=float) * (1.0 - dt * ap_div_rate(closure, phi, p, S, dt))
    phi_b, p_b, S_b = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (phi, p, S)))
    out = np.array([_backward_euler_scalar(closure, float(a), float(b), float(c), dt)
                    for a, b, c in zip(phi_b.ravel(), p_b.ravel(), S_b.ravel())])
    return out.reshape(phi_b.shape)


def homogeneous_layer(closure, phi0: float, p: float, S: float, dt: float, t_end: float,
                      scheme: LayerScheme = LayerScheme.AP_LINEARISED):
    """Integrate the homogeneous sheared layer from phi0 to t_end with steps dt (last step shortened).

    Returns
    -------
    t, phi : ndarray
        Times [s] and packing fractions [-], including t = 0.
    """
    if not (dt > 0 and t_end >= 0):
        raise GranflowInputError(f"need dt > 0 and t_end >= 0 (got dt={dt}, t_end={t_end})")
    ts, phis = [0.0], [float(phi0)]
    t, phi = 0.0, float(phi0)
    while t < t_end * (1 - 1e-14):
        h = min(dt, t_end - t)
        phi = float(homogeneous_layer_step(closure, phi, p, S, h, scheme))
        t += h
        ts.append(t)
        phis.append(phi)
    return np.array(ts), np.array(phis)
