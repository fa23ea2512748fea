"""The gravity force of a step and its weights (module docstring of :mod:`granflow.model`, step 1;
NUMERICS.md §9 for the energy-consistent weight), as a mixin of :class:`granflow.model.Model` (it
reads the model's grid, material, gravity, ``consistent_gravity``, blend velocity, surface and
:meth:`~granflow.model.Model.face_fraction` / :meth:`~granflow.model.Model.transport_fluxes`).
"""
from __future__ import annotations

import numpy as np

from granflow.physics.gravity_kernel import gravity_weights_compiled, kernel_available


def gravity_weights_numpy(centred, flux, vel, gvec, rho_s: float, u_b: float) -> tuple[np.ndarray, np.ndarray]:
    """``(force, drag)`` of :meth:`GravityWeights.gravity_split` from the centred fraction, the
    packed solid flux and the velocity at the unknowns, the gravity vector ``gvec`` there, ``rho_s``
    and the blend velocity ``u_b``: the NumPy reference of
    :func:`granflow.physics.gravity_kernel.gravity_weights_compiled` (equal bit for bit,
    tests/unit/test_gravity_kernel.py)."""
    moving = vel != 0.0
    upwind = np.where(moving, flux / np.where(moving, vel, 1.0), centred)
    phi_f = centred + (upwind - centred) * np.minimum(1.0, np.abs(vel) / u_b)
    drag = -rho_s * gvec * (upwind - centred) * np.sign(vel) / u_b
    implicit = (np.abs(vel) < u_b) & (drag > 0.0)
    return rho_s * gvec * np.where(implicit, centred, phi_f), np.where(implicit, drag, 0.0)


class GravityWeights:
    """Gravity of :class:`granflow.model.Model` (a mixin; not used alone)."""

    def blend_velocity(self, dt: float) -> float:
        """Blend velocity ``u_b`` of the step's gravity weight [m s^-1] (:meth:`gravity_split`):
        ``numerics.gravity_blend_velocity`` if set, else the creep scale ``eps Lz`` (threshold
        surface) or ``|g| dt``, the speed gravity gives in one step (indicator surface), so that
        the implicit drag rate ``|g| dphi / u_b`` stays below ``1/dt``: a stiffer drag holds back
        the slow compaction of a fluidised surface (measured: a 25 deg fluidised chute at 20 cells
        drifts 1.4 % per 2 s with u_b = 1e-3 m/s and is steady with |g| dt), and ``eps Lz`` would
        make the flow depend on the height of the ambient above it."""
        if self._blend_set or not self.indicator:
            return self.gravity_blend_velocity
        return float(np.hypot(*self.gravity)) * dt

    def gravity_split(self, phi, vel, dt: float, c=None, fluxes=None, phi_f=None) -> tuple[np.ndarray, np.ndarray]:
        """Gravity force of the step as ``f_0 - drag * u^{n+1}`` [N m^-3], ``drag >= 0``
        [kg m^-3 s^-1].

        The energy-consistent weight (the face fraction of the step's solid flux; v1:
        :func:`granflow.physics.transport.flux_face_fraction`) on a face slower than the blend
        velocity ``u_b`` (:meth:`blend_velocity`) is linear in the face velocity,
        ``phi_f = c + s (w_up - c) u/u_b``
        (``c`` centred, ``w_up`` the upwind flux fraction for the direction ``s`` of ``u^n``). Where
        ``-g s (w_up - c) > 0`` (e.g. a bed surface: lighter downstream) this is a drag of rate
        ``~|g|/u_b`` (v1's ``u_b = eps Lz``, Lz = 0.15 m: 1.3e4 s^-1; v2's ``|g| dt``: ~1/dt).
        Explicit, it is stable only for
        ``|g| dt/u_b < 2``; the yield viscosity hides that in a dense pile, but where it vanishes
        (``p -> 0``, a fluidised bed) a surface at rest oscillates with growing amplitude.
        So that part is implicit (``drag`` joins the mass matrix); the rest (saturated
        faces ``|u^n| >= u_b``, anti-damping faces, or ``consistent_gravity=False``) is explicit.
        ``fluxes``: :meth:`transport_fluxes` of ``(phi, vel, dt, c)`` if already known; ``phi_f``
        the :meth:`dual_mean` of ``phi`` if known.
        """
        g = self.grid
        rho_s = self.material.rho_s
        phi = np.asarray(phi, dtype=float).reshape(g.cell_shape)
        vel = np.asarray(vel, dtype=float)
        centred = self.face_fraction(phi, c, phi_f)
        if self.consistent_gravity:
            flux = g.pack_velocity(*(self.transport_fluxes(phi, vel, dt, c) if fluxes is None else fluxes))
            u_b = self.blend_velocity(dt)
            if kernel_available():  # the same operations in one pass (physics.gravity_kernel)
                return gravity_weights_compiled(centred, flux, vel, *self.gravity, g.n_u, rho_s, u_b)
        gvec = np.empty(g.n_unknowns)
        gvec[g.u_slice], gvec[g.w_slice] = self.gravity
        if not self.consistent_gravity:
            return rho_s * gvec * centred, np.zeros(g.n_unknowns)
        return gravity_weights_numpy(centred, flux, vel, gvec, rho_s, u_b)
