"""Mass-consistent, conservative momentum transport on the MAC grid (scheme v2, issue 12).

The inertia of paper eq. syst3b, ``phi rho_s (d_t u + u . grad u)``, is written in conservation
form with the solid's own mass flux,

    d_t (m u) + div(rho_s F (x) u) = forces,      d_t m + div(rho_s F) = 0,        (1)

where ``F = phi u`` [m s^-1] is the volume flux of the solid that the phi transport of the step
uses (:func:`granflow.physics.transport.advect`: the SSP-RK2 time-averaged MUSCL fluxes, so
``phi^{n+1} = phi^n - dt div F``), in the spirit of the mass-momentum consistent VOF schemes of
Rudman (1998, Int. J. Numer. Meth. Fluids 28, 357) and Vaudor et al. (2017, Comput. Fluids 152,
204), written here on the staggered grid:

* the momentum control volume of a velocity unknown is the face's dual cell (half of each
  neighbouring cell); its mass is ``m = rho_s phi_f``, ``phi_f = (phi_L + phi_R)/2``
  (``Operators.cell_to_face``), plus a constant ambient floor ``rho_a`` that is not transported;
* the mass flux through a dual-cell face is the mean of the two solid fluxes it straddles
  (the two x-face fluxes of a cell for a dual face at the cell centre, the two fluxes of the
  adjacent faces for a dual face at a node), so that the dual-cell mass obeys (1) *exactly*:
  ``div_dual F = cell_to_face(div F)`` (:func:`dual_mass_divergence`);
* the transported velocity on a dual face is its upwind MUSCL value (second order where
  smooth, first order at extrema and walls), by the sign of the dual mass flux, with the
  generalised minmod slope ``minmod(theta dq_-, (dq_- + dq_+)/2, theta dq_+)`` (van Leer 1979;
  ``theta = 1`` minmod, ``theta = 2`` monotonized central, the default: TVD for ``1 <= theta
  <= 2``; Basilisk's ``minmod2`` takes 1.3). The larger ``theta``, the less the upwinding
  dissipates (validation/energy: the advection term of the dry 40 x 16 column is -5.1 % of the
  released energy with minmod and -3.5 % with MC).

With the momentum balance discretised as ``(m^{n+1} u^{n+1} - m^n u^n)/dt + rho_s A(F, u^n) =
...`` (:func:`momentum_flux_divergence` gives ``A``), the update is, for first-order face values,
a convex combination of neighbouring velocities (bounded, no new extrema), and multiplying by
``u^{n+1}`` splits the kinetic-energy change exactly into the work of the forces, the
backward-Euler term ``m^n |u^{n+1} - u^n|^2 / 2`` and the advection term
``rho_s dt sum [u^{n+1} . A - |u^{n+1}|^2 div_dual F / 2] dV`` (:func:`advection_energy_rate`),
which vanishes for centred face values and is the upwinding's numerical dissipation otherwise.

The divergence is a compiled loop when Numba is installed
(:mod:`granflow.physics.momentum_kernel`), else the NumPy reference :func:`_divergence_numpy`
(whole-array operations); the two agree bit for bit (tests/unit/test_momentum_kernel.py).
"""
from __future__ import annotations

import numpy as np

from granflow.grid import Grid
from granflow.physics.momentum_kernel import (
    divergence_compiled,
    dual_mass_divergence_compiled,
    kernel_available,
)
from granflow.physics.transport import plane_flux_divergence

HALF = 0.5
MINMOD_THETA = 1.0
"""``theta`` of the plain minmod slope (the most dissipative TVD limiter)."""
MC_THETA = 2.0
"""``theta`` of the monotonized-central slope, the default (the least dissipative of the
generalised minmod family that stays TVD)."""


def _limited(a, b, theta: float):
    """Generalised minmod of the one-sided differences ``a``, ``b``:
    ``minmod(theta a, (a + b)/2, theta b)`` (0 at an extremum)."""
    mag = np.minimum(np.minimum(theta * np.abs(a), theta * np.abs(b)), HALF * np.abs(a + b))
    return np.where(a * b > 0.0, np.sign(a) * mag, 0.0)


def _slopes(q: np.ndarray, axis: int, periodic: bool, theta: float = MC_THETA) -> np.ndarray:
    """Limited slope of ``q`` along ``axis`` (:func:`_limited`; zero at the first and last
    points unless periodic)."""
    if periodic:
        return _limited(q - np.roll(q, 1, axis=axis), np.roll(q, -1, axis=axis) - q, theta)
    d = np.diff(q, axis=axis)
    zero = np.zeros_like(np.take(d, [0], axis=axis))
    return _limited(np.concatenate([zero, d], axis=axis), np.concatenate([d, zero], axis=axis), theta)


def _upwind(flux, lo, hi, s_lo, s_hi, second_order: bool):
    """Upwind value on a dual face between points ``lo`` and ``hi`` (MUSCL if ``second_order``)."""
    if not second_order:
        return np.where(flux > 0.0, lo, hi)
    return np.where(flux > 0.0, lo + HALF * s_lo, hi - HALF * s_hi)


def tread_filled(grid: Grid, u: np.ndarray, base) -> np.ndarray:
    """The x-face velocities ``u`` (nx+1, nz) with the faces buried under a topography's tread
    (:mod:`granflow.topography`; ``base`` the lowest fluid cell of each column) set to the
    lowest open face above them: the z-slope of the first fluid row is then 0, the box's rule at
    its base (:func:`_slopes`), so a raised floor transports momentum as the box's base does. No
    flux crosses a tread (its z-faces are walls), so the filled values are never carried."""
    base = np.asarray(base, dtype=np.int64)
    u = np.array(u, dtype=float)
    if grid.periodic_x:
        cols, left, right = np.arange(grid.nx), np.roll(base, 1), base
    else:
        cols, left, right = np.arange(1, grid.nx), base[:-1], base[1:]
    top = np.minimum(np.maximum(left, right), grid.nz - 1)
    below = np.arange(grid.nz)[None, :] < np.minimum(left, right)[:, None]
    u[cols] = np.where(below, u[cols, top][:, None], u[cols])
    if grid.periodic_x:
        u[-1] = u[0]
    return u


def momentum_flux_divergence(grid: Grid, fx: np.ndarray, fz: np.ndarray, vel,
                             second_order: bool = True, window=None,
                             theta: float = MC_THETA, base=None) -> np.ndarray:
    """``A = div_dual(F (x) u~)`` at the velocity unknowns [m s^-2] (module docstring, eq. 1).

    Parameters
    ----------
    grid : Grid
    fx, fz : ndarray
        Solid volume fluxes ``phi u`` on the x-faces ``(nx+1, nz)`` and z-faces ``(nx, nz+1)``
        [m s^-1] (zero on the walls; periodic: ``fx[nx] = fx[0]``), e.g. ``TransportResult.flux_x``.
    vel : ndarray, (n_unknowns,)
        Velocity transported [m s^-1].
    second_order : bool
        MUSCL face values (default) or first-order upwind ones.
    window : tuple of slice, optional
        Cell ranges (x, z) outside which the fluxes vanish with a margin of at least 3 cells
        (:func:`granflow.physics.material.material_window` of the transported material): ``A``
        is computed there only (0 elsewhere; the same values, bit for bit: every stencil of a
        face with a flux stays inside).
    theta : float
        Slope limiter parameter, 1 (minmod) to 2 (monotonized central, default); module docstring.
    base : int array (nx,), optional
        The lowest fluid cell of each column above a topography (:func:`tread_filled`).

    Returns
    -------
    ndarray, (n_unknowns,)
        ``rho_s A`` is the momentum flux divergence [N m^-3].
    """
    u, w = grid.unpack_velocity(vel)
    if base is not None:
        u = tread_filled(grid, u, base)
    if window is None:
        a_u, b = _divergence(u, w, fx, fz, grid.dx, grid.dz, grid.periodic_x, second_order, theta)
        return np.concatenate([a_u.ravel(), b.ravel()])
    xs, zs = window
    per = grid.periodic_x
    xf = slice(0, grid.nx + 1) if per else slice(xs.start, xs.stop + 1)
    zf = slice(zs.start, zs.stop + 1)
    a_sub, b_sub = _divergence(u[xf, zs], w[xs, zf], fx[xf, zs], fz[xs, zf], grid.dx, grid.dz, per,
                               second_order, theta)
    a_u = np.zeros((grid.nx if per else grid.nx - 1, grid.nz))
    b = np.zeros((grid.nx, grid.nz - 1))
    a_u[slice(0, grid.nx) if per else slice(xs.start, xs.stop - 1), zs] = a_sub
    b[xs, slice(zs.start, zs.stop - 1)] = b_sub
    return np.concatenate([a_u.ravel(), b.ravel()])


def _divergence(u, w, fx, fz, dx: float, dz: float, per: bool, second_order: bool, theta: float):
    """The compiled kernel (:mod:`granflow.physics.momentum_kernel`) when Numba is installed,
    else :func:`_divergence_numpy` (same arguments and result)."""
    if not kernel_available():
        return _divergence_numpy(u, w, fx, fz, dx, dz, per, second_order, theta)
    return divergence_compiled(u, w, fx, fz, dx, dz, per, second_order, theta)


def _divergence_numpy(u, w, fx, fz, dx: float, dz: float, per: bool, second_order: bool, theta: float):
    """NumPy reference of :func:`_divergence`: the x- and z-momentum parts of
    :func:`momentum_flux_divergence` on whole face arrays
    ``u (n+1, m)``, ``w (n, m+1)`` (walls at the array edges unless ``per`` in x); returns the
    interior-face arrays ``(a_u, b)``."""
    if per:
        u, fx = u[:-1], fx[:-1]
    # --- x-momentum (faces of u_columns) ---------------------------------------------------------
    # along x: dual faces at the cell centres, between x-faces c and c+1
    fcx = HALF * (fx + np.roll(fx, -1, axis=0)) if per else HALF * (fx[:-1] + fx[1:])
    su = _slopes(u, 0, per, theta)
    if per:
        val = _upwind(fcx, u, np.roll(u, -1, axis=0), su, np.roll(su, -1, axis=0), second_order)
        gx = fcx * val
        ax = (gx - np.roll(gx, 1, axis=0)) / dx
    else:
        val = _upwind(fcx, u[:-1], u[1:], su[:-1], su[1:], second_order)
        gx = fcx * val
        ax = np.diff(gx, axis=0) / dx                           # faces 1 .. nx-1
    # along z: dual faces at the interior nodes (between rows j and j+1), walls carry no flux
    left = np.roll(fz, 1, axis=0) if per else fz[:-1]            # cell k-1 of x-face k
    right = fz if per else fz[1:]
    fnz = HALF * (left[:, 1:-1] + right[:, 1:-1])                # (n_xfaces, nz-1)
    uc = u if per else u[1:-1]
    suz = _slopes(uc, 1, False, theta)
    gz = fnz * _upwind(fnz, uc[:, :-1], uc[:, 1:], suz[:, :-1], suz[:, 1:], second_order)
    az = np.diff(np.pad(gz, ((0, 0), (1, 1))), axis=1) / dz
    a_u = ax + az
    # --- z-momentum (interior z-faces) -----------------------------------------------------------
    fcz = HALF * (fz[:, :-1] + fz[:, 1:])                       # dual faces at cell centres
    swz = _slopes(w, 1, False, theta)
    gzw = fcz * _upwind(fcz, w[:, :-1], w[:, 1:], swz[:, :-1], swz[:, 1:], second_order)
    bz = np.diff(gzw, axis=1) / dz                              # faces 1 .. nz-1
    wi = w[:, 1:-1]
    swx = _slopes(wi, 0, per, theta)
    fex = HALF * (fx[:, :-1] + fx[:, 1:])                       # x-face k at w-row j (n, nz-1)
    if per:  # x-face k between cells k-1 (mod nx) and k
        gxw = fex * _upwind(fex, np.roll(wi, 1, axis=0), wi, np.roll(swx, 1, axis=0), swx, second_order)
        bx = (np.roll(gxw, -1, axis=0) - gxw) / dx
    else:
        inner = fex[1:-1]
        gxw = inner * _upwind(inner, wi[:-1], wi[1:], swx[:-1], swx[1:], second_order)
        bx = np.diff(np.pad(gxw, ((1, 1), (0, 0))), axis=0) / dx
    return a_u, bx + bz


def dual_mass_divergence(ops, fx: np.ndarray, fz: np.ndarray) -> np.ndarray:
    """``div_dual F = cell_to_face(div F)`` at the velocity unknowns [s^-1]: the rate of change of
    the dual-cell solid fraction, ``phi_f^{n+1} = phi_f^n - dt div_dual F`` (module docstring).
    :func:`momentum_flux_divergence` of a uniform velocity ``U`` along a periodic direction equals
    ``U div_dual F`` (tested): the dual mass fluxes are the ones this identity implies. A compiled
    loop when Numba is installed (the same products and sums, bit for bit), else the sparse product.
    Axisymmetric: given the r-weighted fluxes ``(2 pi r_f fx, 2 pi r_c fz)`` it returns the
    r-weighted rate (the dual cell's volume is ``2 pi r dx dz``, ``r`` the unknown's radius:
    divide by :attr:`granflow.grid.Grid.unknown_metric`), as :func:`momentum_flux_divergence`
    does; :func:`axisymmetric_transport`."""
    if kernel_available():
        return dual_mass_divergence_compiled(fx, fz, ops.grid.dx, ops.grid.dz, ops.grid.periodic_x)
    return ops.cell_to_face @ plane_flux_divergence(ops.grid, fx, fz).ravel()


DRAIN_FRACTION = 0.25
"""A dual cell left with less than this fraction of its grains by a step is *draining*
(:func:`draining`). The strict bound of the MUSCL update is 1/2 (:func:`draining`); 1/2 also fixed
the thin axisymmetric column but moved the one-solve Lagree 128^2 front at t = 4 one cell
(2.656 -> 2.695 H0; deposit L1 against the tol 1e-4 loop 5.45e-3, 5.09e-3 without the bound);
1/4 keeps it (2.656, L1 4.87e-3) and still fixes the column (1/10 as well: 2.656, 4.67e-3).
Measured 2026-12-06, session 22."""


def draining(phi_f, div_dual, dt: float) -> np.ndarray:
    """The velocity unknowns whose dual cell keeps less than :data:`DRAIN_FRACTION` of its solid,
    ``phi_f - dt div_dual F < DRAIN_FRACTION phi_f`` (bool, shape of ``phi_f``; ``div_dual`` per
    unit volume, as :func:`granflow.step.consistent_inertia` has it).

    The MUSCL update is not bounded there: a dual cell that only loses mass gets
    ``u^{n+1} = u^n + (dt F_out / m^{n+1}) (u^n - u_face)``, with ``|u_face - u^n|`` at most the
    jump to a neighbour (``theta <= 2``) and ``dt F_out / m^{n+1} = m^n / m^{n+1} - 1``: above 1,
    i.e. when it keeps less than half its mass, the update can leave the neighbours' range (by
    up to 3 jumps at the 1/4 kept here), without bound as the cell empties (a velocity created from the difference of two nearly equal
    momenta). First-order face values keep it a convex combination whatever the drain. One solve
    per step (``numerics.picard.max_sweeps = 1``) transports these cells at first order
    (docs/solver.md, "One solve per step": its lagged fluxes drain the dual cells above a
    falling surface further than the step's own transport)."""
    phi_f = np.asarray(phi_f, dtype=float)
    return phi_f - dt * np.asarray(div_dual, dtype=float) < DRAIN_FRACTION * phi_f


def advection_energy_rate(rho_s: float, cell_volume: float, A: np.ndarray, div_dual: np.ndarray,
                          vel_new) -> float:
    """Numerical power of the transport term [W m^-1]:
    ``rho_s dV sum [u . A - |u|^2 div_dual F / 2]`` at ``u = u^{n+1}`` (module docstring);
    zero for centred face values, >= 0 (dissipation) for first-order upwind ones."""
    vel_new = np.asarray(vel_new, dtype=float)
    return rho_s * cell_volume * float(vel_new @ A - HALF * (vel_new * vel_new) @ div_dual)


def axisymmetric_transport(ops, fx: np.ndarray, fz: np.ndarray, vel, **kwargs) -> tuple[np.ndarray, np.ndarray]:
    """``(A_w, div_dual_w)``: :func:`momentum_flux_divergence` and :func:`dual_mass_divergence` of an
    axisymmetric grid, both times the circumference ``2 pi r`` of each velocity unknown
    (:attr:`granflow.grid.Grid.unknown_metric`) [m^2 s^-2, m s^-1].

    The momentum of a u face's dual cell (half of each neighbouring cell, volume ``2 pi r_f dx
    dz`` on a uniform grid) changes by the fluxes through its faces: at the cell centres
    ``(G_k + G_{k+1})/2`` with ``G = 2 pi r_f fx`` the fluxes through the x-faces' areas, at the
    nodes the mean of the z-fluxes ``2 pi r_c fz`` of the two cells; a w face's dual cell sits in
    one column. These are exactly the plane formulas applied to the r-weighted fluxes, so the
    dual-cell mass obeys the discrete conservation law as in the plane case, and the radial
    momentum needs no extra term (no swirl: ``d_t(rho u) + (1/r) d_r(r rho u u) + d_z(rho u w)``).
    ``kwargs`` go to :func:`momentum_flux_divergence`."""
    rad = ops.grid.radial
    gx, gz = rad.faces * fx, rad.cells * fz
    return momentum_flux_divergence(ops.grid, gx, gz, vel, **kwargs), dual_mass_divergence(ops, gx, gz)
