"""Fourier-series solution of the 1-D defluidising column (MODEL.md §7, NUMERICS.md §9, §11 item 1).

A rigid bed (``u = 0``) of height ``H`` at uniform packing ``phi`` with an impermeable base and an
open top obeys the linear pore-pressure equation (paper eq. syst2b with ``u = 0``)

    dp/dt = c d2p/dz2,   0 < z < H,   c = p_atm kappa(phi) / (1 - phi)   [m^2 s^-1],
    dp/dz = 0 at z = 0 (impermeable base),   p = 0 at z = H (open top),   p(z, 0) = p0(z).

Separation of variables gives

    p(z, t) = sum_n a_n cos(k_n z) exp(-c k_n^2 t),   k_n = (2n + 1) pi / (2H),
    a_n = (2/H) int_0^H p0(z) cos(k_n z) dz,

with, in closed form (integration by parts, ``sin(k_n H) = (-1)^n``, ``cos(k_n H) = 0``):

* uniform ``p0 = A``:                    ``a_n = 2 A (-1)^n / (H k_n)``;
* lithostatic ``p0 = b (H - z)``:         ``a_n = 2 b / (H k_n^2)``  (NUMERICS.md §9, ``A = b``).

The slowest mode decays with the time constant ``tau_1 = 1/(c k_0^2) = 4 H^2 / (pi^2 c)`` [s].
The basal pressure halves at ``t_1/2 = 0.4854 tau_1`` for the lithostatic profile (MODEL.md §7)
and at ``0.9345 tau_1`` for the uniform one; :func:`basal_half_life` finds them by root-finding.
"""
from __future__ import annotations

import math
from enum import Enum

import numpy as np

from granflow.errors import GranflowInputError

DECAY_EXPONENT_CUTOFF = 50.0
"""Terms with ``c k_n^2 t`` above this are dropped (``exp(-50) ~ 2e-22`` of the leading term)."""

MAX_TERMS = 200_000
"""Upper bound on the number of series terms (reached only for t/tau_1 < ~1e-9)."""

HALF = 0.5


class InitialProfile(Enum):
    """Initial pore-pressure profile ``p0(z)`` with a closed-form series."""

    UNIFORM = "uniform"
    """``p0(z) = amplitude`` [Pa] (``amplitude`` is the basal and bulk value)."""
    LITHOSTATIC = "lithostatic"
    """``p0(z) = amplitude * (H - z) / H`` [Pa]: linear, ``amplitude`` is the basal value
    (``b = amplitude / H`` [Pa m^-1]; e.g. ``amplitude = 0.9 phi rho_s g H``)."""


def _positive(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise GranflowInputError(f"{name} must be a real number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0.0):
        raise GranflowInputError(f"{name} must be finite and > 0, got {value!r}")
    return v


def wavenumbers(H: float, n_terms: int) -> np.ndarray:
    """``k_n = (2n + 1) pi / (2H)`` [m^-1], ``n = 0 .. n_terms - 1``."""
    H = _positive("H", H)
    return (2.0 * np.arange(n_terms) + 1.0) * np.pi / (2.0 * H)


def first_time_constant(H: float, c: float) -> float:
    """``tau_1 = 4 H^2 / (pi^2 c)`` [s], the e-folding time of the slowest mode (MODEL.md §7).

    Parameters
    ----------
    H : float
        Bed height [m].
    c : float
        Pore-pressure diffusivity ``p_atm kappa / (1 - phi)`` [m^2 s^-1].
    """
    return 4.0 * _positive("H", H) ** 2 / (math.pi**2 * _positive("c", c))


def coefficients(profile: InitialProfile | str, H: float, amplitude: float,
                 n_terms: int) -> np.ndarray:
    """Closed-form Fourier coefficients ``a_n`` [Pa] of :class:`InitialProfile` ``profile``.

    Parameters
    ----------
    profile : InitialProfile or str
    H : float
        Bed height [m].
    amplitude : float
        Basal initial pressure ``p0(0)`` [Pa].
    n_terms : int
        Number of terms.

    Returns
    -------
    ndarray, (n_terms,)
        Uniform: ``2 A (-1)^n / (H k_n)``; lithostatic: ``2 b / (H k_n^2)`` with ``b = A / H``.
    """
    profile = _profile(profile)
    k = wavenumbers(H, n_terms)
    if profile is InitialProfile.UNIFORM:
        sign = np.where(np.arange(n_terms) % 2 == 0, 1.0, -1.0)
        return 2.0 * amplitude * sign / (H * k)
    return 2.0 * (amplitude / H) / (H * k**2)


def coefficients_quadrature(p0, H: float, n_terms: int) -> np.ndarray:
    """``a_n = (2/H) int_0^H p0(z) cos(k_n z) dz`` by adaptive quadrature, for any profile.

    Parameters
    ----------
    p0 : callable
        ``p0(z)`` [Pa], scalar in, scalar out.
    H : float
        Bed height [m].
    n_terms : int

    Returns
    -------
    ndarray, (n_terms,)
    """
    from scipy.integrate import quad

    k = wavenumbers(H, n_terms)
    return np.array([2.0 / H * quad(p0, 0.0, H, weight="cos", wvar=kn)[0] for kn in k])


def initial_profile(profile: InitialProfile | str, z, H: float, amplitude: float) -> np.ndarray:
    """``p0(z)`` [Pa] of ``profile`` at heights ``z`` [m] (0 outside ``[0, H)``)."""
    profile = _profile(profile)
    z = np.asarray(z, dtype=float)
    inside = (z >= 0.0) & (z < H)
    shape = np.ones_like(z) if profile is InitialProfile.UNIFORM else (H - z) / H
    return np.where(inside, amplitude * shape, 0.0)


def n_terms_needed(H: float, c: float, t_min: float) -> int:
    """Number of terms after which ``c k_n^2 t_min >`` :data:`DECAY_EXPONENT_CUTOFF`.

    The neglected tail is then below ``exp(-50)`` times the first coefficient (both closed-form
    coefficient sequences decrease in magnitude).
    """
    t_min = _positive("t_min", t_min)
    k_needed = math.sqrt(DECAY_EXPONENT_CUTOFF / (_positive("c", c) * t_min))
    n = math.ceil(k_needed * 2.0 * H / math.pi)
    if n > MAX_TERMS:
        raise GranflowInputError(
            f"t_min = {t_min:g} s is too small for the series (needs {n} > {MAX_TERMS} terms)"
        )
    return max(n, 1)


def pressure(z, t, H: float, c: float, profile: InitialProfile | str = InitialProfile.LITHOSTATIC,
             amplitude: float = 1.0, n_terms: int | None = None) -> np.ndarray:
    """Pore pressure ``p(z, t)`` [Pa] of the defluidising column (series above).

    Parameters
    ----------
    z : array_like
        Heights [m] in ``[0, H]``.
    t : array_like
        Times [s], ``>= 0``; broadcast against ``z``. At ``t = 0`` the initial profile is returned
        (the series converges to it only slowly there).
    H : float
        Bed height [m].
    c : float
        Diffusivity [m^2 s^-1].
    profile : InitialProfile or str
    amplitude : float
        Basal initial pressure [Pa].
    n_terms : int, optional
        Number of terms; default enough for a truncation error ``< exp(-50) a_0`` at the smallest
        positive ``t`` (:func:`n_terms_needed`).

    Returns
    -------
    ndarray
        ``p`` with the broadcast shape of ``z`` and ``t``.

    Examples
    --------
    >>> H, c = 0.1, 0.08
    >>> round(float(pressure(0.0, 0.0, H, c, amplitude=1000.0)), 6)
    1000.0
    >>> tau = first_time_constant(H, c)
    >>> round(float(pressure(0.0, 0.4854 * tau, H, c, amplitude=1000.0)), 1)
    500.0
    """
    profile = _profile(profile)
    H, c = _positive("H", H), _positive("c", c)
    z, t = np.broadcast_arrays(np.asarray(z, dtype=float), np.asarray(t, dtype=float))
    if np.any(t < 0.0) or not np.all(np.isfinite(t)):
        raise GranflowInputError("pressure: t must be finite and >= 0")
    if np.any(z < 0.0) or np.any(z > H):
        raise GranflowInputError("pressure: z must lie in [0, H]")
    out = initial_profile(profile, z, H, amplitude)
    late = t > 0.0
    if np.any(late):
        n = n_terms if n_terms is not None else n_terms_needed(H, c, float(t[late].min()))
        k = wavenumbers(H, n)
        a = coefficients(profile, H, amplitude, n)
        zl, tl = z[late][:, None], t[late][:, None]
        out = np.array(out, dtype=float)
        out[late] = np.sum(a * np.cos(k * zl) * np.exp(-c * k**2 * tl), axis=1)
    return out


def basal_pressure(t, H: float, c: float, profile: InitialProfile | str = InitialProfile.LITHOSTATIC,
                   amplitude: float = 1.0) -> np.ndarray:
    """Basal pressure ``p(0, t)`` [Pa] (see :func:`pressure`)."""
    return pressure(0.0, t, H, c, profile, amplitude)


def basal_half_life(H: float, c: float,
                    profile: InitialProfile | str = InitialProfile.LITHOSTATIC) -> float:
    """Time [s] at which the basal pressure has fallen to half its initial value.

    Root of ``p(0, t) = p(0, 0)/2`` (Brent's method on the series). In units of
    ``tau_1 = 4H^2/(pi^2 c)``: 0.4854 (lithostatic, MODEL.md §7), 0.9345 (uniform).
    """
    tau = first_time_constant(H, c)

    def excess(s: float) -> float:
        return float(basal_pressure(s * tau, H, c, profile)) - HALF

    upper = 1.0
    while excess(upper) > 0.0:  # the basal pressure decreases monotonically to 0
        upper *= 2.0
    lower = 1e-6
    from scipy.optimize import brentq  # here: not in every run's start-up (0.16 s)

    return brentq(excess, lower, upper, xtol=1e-14, rtol=1e-13) * tau


def _profile(profile) -> InitialProfile:
    try:
        return InitialProfile(profile)
    except ValueError:
        allowed = ", ".join(repr(p.value) for p in InitialProfile)
        raise GranflowInputError(f"unknown initial profile {profile!r}; expected one of {allowed}") from None
