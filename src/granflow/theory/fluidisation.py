"""Homogeneous fluidisation of a bed by a gas injected through its base, in the model's own terms.

Source: the model's Darcy law (paper eqs ``darcy`` and ``beta``; docs/model.md §1-2): the gas flux
relative to the grains is ``q = -kappa(phi) grad p_f`` with the Carman-Kozeny MOBILITY

    kappa(phi) = d^2 (1 - phi)^3 / (150 eta_f phi^2)                       [m^2 Pa^-1 s^-1]

(:meth:`granflow.materials.Material.permeability`), and the momentum equation (``syst3b``)
``phi rho_s Du/Dt = phi rho_s g - grad p + div tau - grad p_f`` has NO gas buoyancy (the gas
density is neglected, rho_f/rho_s ~ 4e-4), so the textbook ``(rho_s - rho_f)`` is ``rho_s`` here.

Steady homogeneous bed under a superficial injection velocity U [m s^-1] (upwards, linear gas law
``gas.law = "linear"``, for which q is uniform in a bed at rest): the grains at rest, the granular
pressure p = 0 (the gas carries the whole weight), ``-dp_f/dz = phi rho_s |g_z|`` and ``q = U``:

    U = kappa(phi) phi rho_s |g_z| = d^2 (1 - phi)^3 rho_s |g_z| / (150 eta_f phi)    (balance)

* the **minimum fluidisation velocity** of a bed at packing phi0 is the left-hand side at phi0,
  ``U_mf = kappa(phi0) phi0 rho_s |g_z|`` (:func:`minimum_fluidisation_velocity`);
* for U > U_mf(phi0) the bed expands to the root phi_e(U) < phi0 of the balance
  (:func:`homogeneous_packing`), in closed form (Cardano): with ``x = 1 - phi`` the balance is the
  cubic ``x^3 + a x - a = 0``, ``a = 150 eta_f U / (d^2 rho_s |g_z|)`` [-], which has exactly one
  real root since ``(1 - phi)^3 / phi`` decreases strictly on (0, 1):

      x = cbrt(a/2 + sqrt(a^2/4 + a^3/27)) + cbrt(a/2 - sqrt(a^2/4 + a^3/27));

* for U <= U_mf(phi0) the bed does not expand: it stays at phi0 at rest, the grains carrying the
  fraction 1 - U/U_mf of the weight (the model has no cohesion, and a static bed below phi_max
  keeps its packing, docs/model.md §3 eq. ``syst4DP``), so :func:`expanded_packing` returns phi0.

How the expansion happens (:func:`kinematic_wave_speed`, :func:`expansion_time`): without inertia
and with p = 0 the grain velocity of a layer at packing phi is ``w = U - U_mf(phi)`` (the mixture
volume flux is U, the gas one relative to the grains is U_mf(phi)), so phi obeys the continuity
(kinematic-wave) equation ``d_t phi + d_z (phi (U - U_mf(phi))) = 0`` (Kynch 1952; Wallis 1969).
A bed released at phi0 under U > U_mf(phi0) rises as a plug at ``w0 = U - U_mf(phi0)`` while a
fluidisation front (a shock, from the base where w = 0) climbs at
``s = phi0 w0 / (phi0 - phi_e)``; the bed is steady when the front reaches the surface, at

    t_s = H0 (phi0/phi_e - 1) / w0                                                  [s]

independent of any numerical parameter (3.6 s for a 10 cm bed of 70 um beads at 1.3 U_mf).

The reverse, **defluidisation of an expanded bed** (:func:`consolidation_time`): a bed at rest at
phi0 < phi_max, its weight carried by the gas (p = 0), with the supply stopped (U = 0) over an
impermeable base. Each layer settles at ``w = -U_mf(phi0)``; a compaction front (a shock between
the packed bed at phi_max, at rest, and the suspension) climbs from the base at
``s = phi0 U_mf(phi0) / (phi_max - phi0)`` while the surface falls at U_mf(phi0); they meet at

    t_c = H0 (phi_max - phi0) / (phi_max U_mf(phi0))                                [s]

In the packed layer the gas is at rest relative to the grains, so p_f is uniform there and the
basal pore pressure is the weight of the grains still in suspension: with the grain volume
phi_max s t already packed, ``p_f(0, t) = p_f(0, 0) (1 - t/t_c)`` -- a linear decay, not the
exponential of pore-pressure diffusion, lasting t_c, proportional to H0 (diffusion: H0^2). This is
the incompressible-gas limit: the storage term of the gas equation (``syst2b``; the gas expands as
p_f falls) slows it by a relative amount of order
``(1 - phi0) (p_f(0, 0)/p_atm) phi_max/(phi_max - phi0)`` (validation/roche/README.md,
"Defluidisation", measured).
"""
from __future__ import annotations

import math
import numbers

from granflow.errors import GranflowInputError

__all__ = ["minimum_fluidisation_velocity", "homogeneous_packing", "expanded_packing",
           "kinematic_wave_speed", "expansion_time", "consolidation_time", "CARMAN_KOZENY_CONSTANT"]

CARMAN_KOZENY_CONSTANT = 150.0
"""The 150 of the Carman-Kozeny (Ergun viscous) permeability, paper eq. ``beta`` [-]; must equal
the constant of :meth:`granflow.materials.Material.permeability` (tested)."""
CUBIC_TERMS = (2.0, 4.0, 27.0)
"""Cardano's constants of the depressed cubic x^3 + a x - a = 0: ``a/2 +- sqrt(a^2/4 + a^3/27)`` [-]."""


def _positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value) or value <= 0:
        raise GranflowInputError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def _packing(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0.0 < value < 1.0:
        raise GranflowInputError(f"{name} must be a packing fraction in (0, 1), got {value!r}")
    return float(value)


def _gravity(g_z) -> float:
    if isinstance(g_z, bool) or not isinstance(g_z, numbers.Real) or not math.isfinite(g_z) or g_z == 0:
        raise GranflowInputError(f"g_z must be a finite, non-zero gravity [m s^-2], got {g_z!r}")
    return abs(float(g_z))


def minimum_fluidisation_velocity(material, phi: float, g_z: float) -> float:
    """``U_mf = kappa(phi) phi rho_s |g_z|`` [m s^-1] (module docstring, eq. "balance").

    Parameters
    ----------
    material : Material
        d [m], eta_f [Pa s], rho_s [kg m^-3].
    phi : float
        Packing of the bed [-].
    g_z : float
        Gravity normal to the base [m s^-2] (sign ignored).
    """
    return float(material.permeability(phi)) * phi * material.rho_s * abs(g_z)


def homogeneous_packing(material, U: float, g_z: float) -> float:
    """The packing phi_e [-] at which the gas flux ``U`` [m s^-1] carries a homogeneous bed:
    the root of ``kappa(phi) phi rho_s |g_z| = U`` (module docstring, eq. "balance"), Cardano's
    closed form. Strictly decreasing in U; ``homogeneous_packing(m, U_mf(phi0), g) = phi0``.

    Raises
    ------
    GranflowInputError
        Naming ``U`` (not finite and > 0) or ``g_z`` (not finite and non-zero).
    """
    U = _positive("U", U)
    g = _gravity(g_z)
    a = CARMAN_KOZENY_CONSTANT * material.eta_f * U / (material.d**2 * material.rho_s * g)
    half, quarter, cube = CUBIC_TERMS
    root = math.sqrt(a * a / quarter + a**3 / cube)
    x = math.cbrt(a / half + root) + math.cbrt(a / half - root)
    return 1.0 - x


def expanded_packing(material, phi0: float, ratio: float, g_z: float) -> float:
    """Steady packing [-] of a bed poured at ``phi0`` under the injection ``ratio`` x U_mf(phi0):
    phi0 for ``ratio <= 1`` (no expansion below minimum fluidisation), else
    :func:`homogeneous_packing` at ``U = ratio U_mf(phi0)``.

    Raises
    ------
    GranflowInputError
        Naming ``phi0`` (not in (0, 1)) or ``ratio`` (not finite and > 0).
    """
    phi0, ratio = _packing("phi0", phi0), _positive("ratio (U/U_mf)", ratio)
    if ratio <= 1.0:
        return phi0
    return homogeneous_packing(material, ratio * minimum_fluidisation_velocity(material, phi0, g_z), g_z)


def kinematic_wave_speed(material, phi: float, g_z: float) -> float:
    """Speed [m s^-1] of the continuity waves of a homogeneously fluidised bed at packing phi,
    ``c = -phi dU_mf/dphi = U_mf(phi) (1 + 3 phi/(1 - phi))`` (module docstring; Wallis 1969):
    the speed at which packing perturbations cross the bed, upwards (26 mm/s for 70 um beads at
    phi = 0.6)."""
    phi = _packing("phi", phi)
    return minimum_fluidisation_velocity(material, phi, g_z) * (1.0 + 3.0 * phi / (1.0 - phi))


def expansion_time(material, phi0: float, height: float, ratio: float, g_z: float) -> float:
    """Time [s] for a bed of ``height`` [m] poured at ``phi0`` [-] to reach its steady expansion
    under ``ratio`` x U_mf(phi0): ``t_s = H0 (phi0/phi_e - 1) / (U - U_mf(phi0))`` (module
    docstring: the fluidisation front reaches the rising surface); 0 for ``ratio <= 1``."""
    height = _positive("height", height)
    phi_e = expanded_packing(material, phi0, ratio, g_z)
    if ratio <= 1.0:
        return 0.0
    u_mf = minimum_fluidisation_velocity(material, phi0, g_z)
    return height * (phi0 / phi_e - 1.0) / ((ratio - 1.0) * u_mf)


def consolidation_time(material, phi0: float, height: float, g_z: float) -> float:
    """Time [s] for an expanded bed of ``height`` [m] at packing ``phi0`` [-], its weight carried by
    the gas and the supply stopped, to settle to ``material.phi_max`` (module docstring,
    defluidisation; Kynch 1952): ``t_c = H0 (phi_max - phi0) / (phi_max U_mf(phi0))``, the basal
    pore pressure falling linearly to 0 over t_c in the incompressible-gas limit; 0 for
    ``phi0 >= phi_max`` (nothing settles: the pressure diffuses).

    Raises
    ------
    GranflowInputError
        Naming ``phi0`` (not in (0, 1)) or ``height`` (not finite and > 0).
    """
    phi0, height = _packing("phi0", phi0), _positive("height", height)
    if phi0 >= material.phi_max:
        return 0.0
    u_mf = minimum_fluidisation_velocity(material, phi0, g_z)
    return height * (material.phi_max - phi0) / (material.phi_max * u_mf)
