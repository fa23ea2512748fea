"""Conservative transport of the solid fraction, paper eq. syst1b ``d_t phi + div(phi u) = 0``
(NUMERICS.md §2, §6).

Scheme: finite volumes on the MAC grid with the face velocities frozen over the step; face values
of phi by MUSCL reconstruction with the minmod limiter (Sweby 1984) from the upwind side; SSP-RK2
(Heun; Shu & Osher 1988) in time. The walls carry no flux (closed box), so the total mass
``sum phi dV`` is conserved to round-off by construction.

Bounds. With the CFL number of :func:`cfl_number` (per cell,
``dt (max(|u_w|, |u_e|)/dx + max(|w_s|, |w_n|)/dz)``) at most 1/2, each forward-Euler stage is a
convex-type update that keeps ``phi >= 0`` (a minmod face value is at most 3/2 of the cell value
and the two face values of a cell in one direction sum to twice the cell value), hence SSP-RK2
too. The upper bound ``phi <= phi_max`` is *not* a property of the transport alone (the velocity
is divergent; [CD] Theorem th4 obtains it from the dilatancy law). With ``phi_max`` given,
:func:`advect` keeps it by limiting, in each forward-Euler stage, the fluxes that enter a cell the
stage would fill above ``phi_max`` (:func:`limit_to_upper_bound`; the solid they would have carried
stays in the donor cell, so mass is still conserved to round-off, and the amount held back is
reported). Anything left above ``phi_max`` is measured, clipped and reported
(:func:`clip_to_bounds`, NUMERICS.md §6). Limiting only lowers inflows, so ``phi >= 0`` still
holds: a cell's outflow alone is at most its content at CFL <= 1/2.

Periodic in x (``grid.periodic_x``): the x stencils wrap (slopes and upwind values of the face
between cells nx - 1 and 0), every x-face carries a flux and the image column ``fx[nx] = fx[0]``
keeps :func:`flux_divergence` a plain difference; the mass is conserved to round-off as well.
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from granflow.grid import Grid
from granflow.physics.interface_capturing import JUMP_FRACTION, face_states, limit_to_lower_bound
from granflow.physics.transport_kernel import advect_compiled, kernel_available

HALF = 0.5
POSITIVITY_CFL = 0.5
"""Largest CFL number (:func:`cfl_number`) for which the scheme provably keeps phi >= 0."""


def face_velocities(grid: Grid, vel) -> tuple[np.ndarray, np.ndarray]:
    """Full face arrays ``u (nx+1, nz)``, ``w (nx, nz+1)`` [m s^-1], zero on the walls."""
    return grid.unpack_velocity(vel)


def minmod(a, b):
    """minmod(a, b) = sign(a) min(|a|, |b|) if a b > 0, else 0."""
    return np.where(a * b > 0.0, np.sign(a) * np.minimum(np.abs(a), np.abs(b)), 0.0)


def _limited_slopes(phi: np.ndarray, axis: int, periodic: bool = False) -> np.ndarray:
    """Minmod slope (per cell, in cell units) along ``axis``; zero in the first and last cells
    (zero-gradient ghost cells at the walls), or wrapped if ``periodic``."""
    if periodic:
        return minmod(phi - np.roll(phi, 1, axis=axis), np.roll(phi, -1, axis=axis) - phi)
    d = np.diff(phi, axis=axis)
    zero = np.zeros_like(np.take(d, [0], axis=axis))
    back = np.concatenate([zero, d], axis=axis)   # phi_i - phi_{i-1}
    fwd = np.concatenate([d, zero], axis=axis)    # phi_{i+1} - phi_i
    return minmod(back, fwd)


def muscl_fluxes(grid: Grid, phi, u: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Face fluxes ``phi_f u`` [m s^-1] with MUSCL-minmod upwind face values.

    Parameters
    ----------
    grid : Grid
    phi : ndarray, (nx, nz)
        Solid fraction [-].
    u, w : ndarray
        Full face velocities, shapes ``(nx+1, nz)`` and ``(nx, nz+1)`` [m s^-1].

    Returns
    -------
    fx : ndarray, (nx+1, nz)
        Flux through the x-faces (zero on the walls; periodic: ``fx[nx] = fx[0]``).
    fz : ndarray, (nx, nz+1)
        Flux through the z-faces (zero on the walls).
    """
    phi = np.asarray(phi, dtype=float)
    fx = np.zeros(grid.xface_shape)
    fz = np.zeros(grid.zface_shape)
    sx = _limited_slopes(phi, 0, grid.periodic_x)
    if grid.periodic_x:  # x-face i between cells i-1 (mod nx) and i
        left = np.roll(phi + HALF * sx, 1, axis=0)
        right = phi - HALF * sx
    else:
        left = phi[:-1, :] + HALF * sx[:-1, :]   # value at face i+1/2 from cell i
        right = phi[1:, :] - HALF * sx[1:, :]    # ... from cell i+1
    cols = grid.u_columns
    ui = u[cols, :]
    fx[cols, :] = np.where(ui > 0.0, ui * left, ui * right)
    if grid.periodic_x:
        fx[-1, :] = fx[0, :]
    sz = _limited_slopes(phi, 1)
    below = phi[:, :-1] + HALF * sz[:, :-1]
    above = phi[:, 1:] - HALF * sz[:, 1:]
    wi = w[:, 1:-1]
    fz[:, 1:-1] = np.where(wi > 0.0, wi * below, wi * above)
    return fx, fz


def sharp_fluxes(grid: Grid, phi, u: np.ndarray, w: np.ndarray,
                 min_jump: float) -> tuple[np.ndarray, np.ndarray]:
    """Face fluxes ``phi_f u`` [m s^-1] with MUSCL-THINC-BVD upwind face values
    (:mod:`granflow.physics.interface_capturing`; THINC where neighbours differ by more than
    ``min_jump``); otherwise the arguments and shapes of :func:`muscl_fluxes`."""
    phi = np.asarray(phi, dtype=float)
    fx = np.zeros(grid.xface_shape)
    fz = np.zeros(grid.zface_shape)
    lo_x, hi_x = face_states(phi, 0, grid.periodic_x, min_jump)
    if grid.periodic_x:  # x-face i between cells i-1 (mod nx) and i
        left, right = np.roll(hi_x, 1, axis=0), lo_x
    else:
        left, right = hi_x[:-1, :], lo_x[1:, :]
    cols = grid.u_columns
    ui = u[cols, :]
    fx[cols, :] = np.where(ui > 0.0, ui * left, ui * right)
    if grid.periodic_x:
        fx[-1, :] = fx[0, :]
    lo_z, hi_z = face_states(phi, 1, False, min_jump)
    wi = w[:, 1:-1]
    fz[:, 1:-1] = np.where(wi > 0.0, wi * hi_z[:, :-1], wi * lo_z[:, 1:])
    return fx, fz


class PhiScheme(str, Enum):
    """Face values of the phi transport (``numerics.phi_transport``)."""

    MUSCL = "muscl"
    """MUSCL-minmod (v1; compiled kernel when Numba is installed)."""
    SHARP = "sharp"
    """MUSCL-THINC-BVD: THINC's smoothed step where it lowers the boundary variation (the free
    surface stays within 1-2 cells), MUSCL-minmod elsewhere; outflows limited for phi >= 0
    (:mod:`granflow.physics.interface_capturing`)."""


def flux_divergence(grid: Grid, fx: np.ndarray, fz: np.ndarray) -> np.ndarray:
    """Cell divergence of face fluxes, ``(fx_e - fx_w)/dx + (fz_n - fz_s)/dz``, shape (nx, nz); on
    an axisymmetric grid (``grid.radial``, :class:`granflow.grid.RadialMetric`)
    ``(r_e fx_e - r_w fx_w)/(r_c dx) + (fz_n - fz_s)/dz`` (the outflow per cell volume)."""
    rad = getattr(grid, "radial", None)
    if rad is None:
        return plane_flux_divergence(grid, fx, fz)
    return np.diff(rad.faces * fx, axis=0) / (grid.dx * rad.cells) + np.diff(fz, axis=1) / grid.dz


def plane_flux_divergence(grid, fx: np.ndarray, fz: np.ndarray) -> np.ndarray:
    """``(fx_e - fx_w)/dx + (fz_n - fz_s)/dz`` whatever the geometry (r-weighted fluxes give the
    r-weighted divergence)."""
    return np.diff(fx, axis=0) / grid.dx + np.diff(fz, axis=1) / grid.dz


def face_rates(grid, dt: float):
    """``dt`` times the area of the west, east and of each z-face of a cell over its volume,
    ``(a_w, a_e, a_z)`` [-]: the part of a cell a unit flux empties through that face in a step.
    ``dt/dx, dt/dx, dt/dz`` in a plane; axisymmetric, ``a_w = dt r_w/(r_c dx)``,
    ``a_e = dt r_e/(r_c dx)`` (column vectors, ``a_w = 0`` on the axis)."""
    cx, cz = dt / grid.dx, dt / grid.dz
    rad = getattr(grid, "radial", None)
    if rad is None:
        return cx, cx, cz
    return cx * rad.faces[:-1] / rad.cells, cx * rad.faces[1:] / rad.cells, cz


def cfl_number(grid: Grid, vel, dt: float, cells=None) -> float:
    """Largest cell CFL number ``dt (max(|u_w|,|u_e|)/dx + max(|w_s|,|w_n|)/dz)`` [-], over every
    cell or, with ``cells`` (bool, (nx, nz)), over those cells only (0 if there are none).

    :data:`POSITIVITY_CFL` (1/2) is the positivity limit of the MUSCL-minmod SSP-RK2 update. A
    transport can only move what is in a cell through that cell's faces, so the bound needs the
    cells that hold (or, within the step, can receive and pass on) something to move:
    :meth:`granflow.model.Model.transport_cells` gives them.
    """
    u, w = face_velocities(grid, vel)
    if getattr(grid, "radial", None) is not None:  # the face areas over the cell volume (face_rates)
        a_w, a_e, a_z = face_rates(grid, 1.0)
        rate = (np.maximum(np.abs(u[:-1, :]) * np.maximum(a_w, 1.0 / grid.dx),
                           np.abs(u[1:, :]) * a_e) + np.maximum(np.abs(w[:, :-1]), np.abs(w[:, 1:])) * a_z)
    else:  # max(|u_w|, |u_e|)/dx + max(|w_s|, |w_n|)/dz, each |.| taken once, in place
        au, aw = np.abs(u), np.abs(w)
        rate = np.maximum(au[:-1, :], au[1:, :])
        rate /= grid.dx
        cz = np.maximum(aw[:, :-1], aw[:, 1:])
        cz /= grid.dz
        rate += cz
    if cells is not None:
        rate = rate[np.asarray(cells, dtype=bool).reshape(grid.cell_shape)]
    return float(dt * np.max(rate)) if rate.size else 0.0


def stable_dt(grid: Grid, vel, cfl: float, cells=None) -> float:
    """Largest dt with :func:`cfl_number` ``<= cfl`` (over ``cells`` if given; ``inf`` when
    nothing there moves) [s]."""
    rate = cfl_number(grid, vel, 1.0, cells)
    return float(cfl / rate) if rate > 0 else float("inf")


@dataclass(frozen=True)
class TransportResult:
    """Outcome of :func:`advect`.

    Attributes
    ----------
    phi : ndarray, (nx, nz)
        Transported solid fraction (not clipped) [-].
    flux_x, flux_z : ndarray
        Time-averaged face fluxes of the step (the mass fluxes of SSP-RK2, ``(F^0 + F^1)/2``),
        shapes ``(nx+1, nz)`` and ``(nx, nz+1)`` [m s^-1]: ``phi - phi^n = -dt div(F)``.
    """

    phi: np.ndarray
    flux_x: np.ndarray
    flux_z: np.ndarray
    held_back: float = 0.0
    """Solid volume per unit width [m^2] that the upper-bound limiter kept in donor cells
    (0 without ``phi_max`` or when it did not act)."""


MAX_LIMITER_PASSES = 100
"""Least number of passes of :func:`limit_to_upper_bound` allowed (each settles the cells above the
bound; lowering their inflows can push a donor over, which the next pass settles, so a chain of
full cells needs one pass per cell: the cap is at least nx + nz). Anything left above the bound
is caught by :func:`clip_to_bounds` and reported (or fails the step beyond its tolerance)."""
BOUND_RTOL = 1e-12
"""Relative excess over ``phi_max`` that the limiter leaves alone (round-off)."""


def limit_to_upper_bound(grid: Grid, phi, fx, fz, dt: float, phi_max: float):
    """Fluxes of one forward-Euler stage ``phi - dt div F`` limited so that no cell exceeds
    ``phi_max`` (a flux-limiting step in the spirit of Zalesak's FCT, with the bound as the only
    constraint).

    Each pass scales every flux *entering* a cell that would end above ``phi_max`` by
    ``r = 1 - excess / inflow`` (that cell then ends at ``phi_max``); this lowers the donors'
    outflow, so the passes repeat until no cell is above the bound (``phi <= phi_max`` at the
    start of the stage is assumed). Fluxes only shrink, so it terminates.

    Returns
    -------
    fx, fz : ndarray
        Limited fluxes (same shapes; periodic image column kept).
    held_back : float
        ``dt sum |F - F_lim| * face length`` [m^2 per unit width].
    """
    fx0, fz0 = fx, fz
    fx, fz = fx.copy(), fz.copy()
    cap = phi_max * (1.0 + BOUND_RTOL)
    rad = getattr(grid, "radial", None)
    for _ in range(limiter_passes(grid)):  # a pass settles one more donor
        excess = phi - dt * flux_divergence(grid, fx, fz) - phi_max
        if not np.any(excess > cap - phi_max):
            break
        if rad is None:
            cx, cz = dt / grid.dx, dt / grid.dz
            inflow = (cx * (np.maximum(fx[:-1, :], 0.0) + np.maximum(-fx[1:, :], 0.0))
                      + cz * (np.maximum(fz[:, :-1], 0.0) + np.maximum(-fz[:, 1:], 0.0)))
        else:
            a_w, a_e, cz = face_rates(grid, dt)
            inflow = (a_w * np.maximum(fx[:-1, :], 0.0) + a_e * np.maximum(-fx[1:, :], 0.0)
                      + cz * (np.maximum(fz[:, :-1], 0.0) + np.maximum(-fz[:, 1:], 0.0)))
        over = excess > cap - phi_max
        enough = over & (inflow > excess)  # else every inflow goes (r = 0)
        ratio = np.divide(excess, inflow, out=np.ones_like(excess), where=enough)
        r = np.where(over, 1.0 - ratio, 1.0)
        if grid.periodic_x:  # x-face i between cells i-1 (mod nx) and i; fx[nx] is the image
            fx[:-1, :] *= np.where(fx[:-1, :] > 0.0, r, np.roll(r, 1, axis=0))
            fx[-1, :] = fx[0, :]
        else:
            fx[1:-1, :] *= np.where(fx[1:-1, :] > 0.0, r[1:, :], r[:-1, :])
        fz[:, 1:-1] *= np.where(fz[:, 1:-1] > 0.0, r[:, 1:], r[:, :-1])
    ncol = grid.nx if grid.periodic_x else grid.nx + 1
    if rad is not None:  # through the faces' areas [m^3]
        held = dt * (grid.dz * float(np.sum(rad.faces * np.abs(fx0 - fx)))
                     + grid.dx * float(np.sum(rad.cells * np.abs(fz0 - fz))))
        return fx, fz, held
    held = dt * (grid.dz * float(np.sum(np.abs(fx0[:ncol] - fx[:ncol])))
                 + grid.dx * float(np.sum(np.abs(fz0 - fz))))
    return fx, fz, held


def advect(grid: Grid, phi, vel, dt: float, phi_max: float | None = None,
           scheme: PhiScheme = PhiScheme.MUSCL) -> TransportResult:
    """One SSP-RK2 step of ``d_t phi + div(phi u) = 0`` with frozen velocity (eq. syst1b): for
    MUSCL the compiled kernel (:mod:`granflow.physics.transport_kernel`) when Numba is installed,
    else the NumPy reference :func:`advect_numpy` (same arguments and result, equal to
    round-off); the sharp scheme (:class:`PhiScheme`) runs in NumPy."""
    if scheme is not PhiScheme.MUSCL or not kernel_available() or getattr(grid, "radial", None) is not None:
        return advect_numpy(grid, phi, vel, dt, phi_max, scheme)  # (the kernel is plane)
    u, w = face_velocities(grid, vel)
    out, fx, fz, held = advect_compiled(phi, u, w, dt, grid.dx, grid.dz, phi_max,
                                        (phi_max or 0.0) * (1.0 + BOUND_RTOL), grid.periodic_x,
                                        limiter_passes(grid))
    return TransportResult(phi=out, flux_x=fx, flux_z=fz, held_back=float(held))


def limiter_passes(grid: Grid) -> int:
    """Cap on the passes of :func:`limit_to_upper_bound` (:data:`MAX_LIMITER_PASSES`)."""
    return max(MAX_LIMITER_PASSES, grid.nx + grid.nz)


def advect_numpy(grid: Grid, phi, vel, dt: float, phi_max: float | None = None,
                 scheme: PhiScheme = PhiScheme.MUSCL) -> TransportResult:
    """One SSP-RK2 step of ``d_t phi + div(phi u) = 0`` with frozen velocity (eq. syst1b); the
    NumPy reference of :func:`advect`.

    Parameters
    ----------
    grid : Grid
    phi : ndarray, (nx, nz)
        Solid fraction at t^n [-].
    vel : ndarray, (n_unknowns,)
        Face velocities, held fixed over the step [m s^-1].
    dt : float
        Time step [s]; keep :func:`cfl_number` <= 1/2 for positivity.
    phi_max : float, optional
        Upper bound kept by :func:`limit_to_upper_bound` in both stages (the result of SSP-RK2 is
        a convex combination of the two bounded stages); None: no limiting.
    scheme : PhiScheme
        Face values: MUSCL-minmod (default) or the sharp MUSCL-THINC-BVD, whose outflows are
        also limited for ``phi >= 0`` (:func:`~granflow.physics.interface_capturing.limit_to_lower_bound`).

    Returns
    -------
    TransportResult

    Examples
    --------
    >>> from granflow.grid import Grid
    >>> g = Grid(nx=8, nz=2, Lx=1.0, Lz=0.25)
    >>> u = np.zeros(g.xface_shape); u[1:-1] = 1.0
    >>> vel = g.pack_velocity(u, np.zeros(g.zface_shape))
    >>> phi = np.zeros(g.cell_shape); phi[2:4] = 0.5
    >>> out = advect(g, phi, vel, 0.05)
    >>> bool(np.isclose(out.phi.sum(), phi.sum(), rtol=0, atol=1e-15))
    True
    """
    phi = np.asarray(phi, dtype=float)
    u, w = face_velocities(grid, vel)
    sharp = PhiScheme(scheme) is PhiScheme.SHARP
    if sharp:
        jump = JUMP_FRACTION * (phi_max if phi_max is not None else float(np.max(phi)))
        fluxes = lambda g, q, u_, w_: sharp_fluxes(g, q, u_, w_, jump)  # noqa: E731
    else:
        fluxes = muscl_fluxes
    fx0, fz0 = fluxes(grid, phi, u, w)
    if sharp:
        fx0, fz0 = limit_to_lower_bound(phi, fx0, fz0, dt, grid.dx, grid.dz, grid.periodic_x, grid.radial)
    held = 0.0
    if phi_max is not None:
        fx0, fz0, h0 = limit_to_upper_bound(grid, phi, fx0, fz0, dt, phi_max)
        held += HALF * h0
    phi1 = phi - dt * flux_divergence(grid, fx0, fz0)
    fx1, fz1 = fluxes(grid, phi1, u, w)
    if sharp:
        fx1, fz1 = limit_to_lower_bound(phi1, fx1, fz1, dt, grid.dx, grid.dz, grid.periodic_x, grid.radial)
    if phi_max is not None:
        fx1, fz1, h1 = limit_to_upper_bound(grid, phi1, fx1, fz1, dt, phi_max)
        held += HALF * h1
    fx, fz = HALF * (fx0 + fx1), HALF * (fz0 + fz1)
    return TransportResult(phi=phi - dt * flux_divergence(grid, fx, fz), flux_x=fx, flux_z=fz,
                           held_back=held)


def flux_face_fraction(grid: Grid, phi, vel, dt: float, u_ref: float,
                       phi_max: float | None = None, scheme: PhiScheme = PhiScheme.MUSCL) -> np.ndarray:
    """Solid fraction seen by the mass flux of :func:`advect` at the velocity unknowns [-].

    ``phi_f = F_f / u_f`` with ``F`` the time-averaged SSP-RK2 flux of a step with velocity ``vel``
    (the upwind MUSCL value, corrected by the second stage), blended with the centred mean
    ``(phi_L + phi_R)/2`` on slow faces: ``phi_f = c + (F/u - c) min(1, |u|/u_ref)``. Using it in the
    gravity force ``phi_f rho_s g`` makes the gravity work equal the potential-energy change of the
    transport on faces faster than ``u_ref`` (energy-consistent gravity, NUMERICS.md §7.2, §9),
    while a fluid at rest keeps the centred weight (exact discrete hydrostatics).

    Parameters
    ----------
    grid : Grid
    phi : ndarray, (nx, nz)
    vel : ndarray, (n_unknowns,)
        Face velocities of the step [m s^-1].
    dt : float
        Time step [s].
    u_ref : float
        Blending velocity [m s^-1] (> 0).
    phi_max : float, optional
        Upper bound of the transport (:func:`advect`).
    scheme : PhiScheme
        Face values of the transport (:func:`advect`).
    """
    phi = np.asarray(phi, dtype=float)
    out = advect(grid, phi, vel, dt, phi_max, scheme)
    flux = grid.pack_velocity(out.flux_x, out.flux_z)
    cx = (HALF * (np.roll(phi, 1, axis=0) + phi) if grid.periodic_x
          else HALF * (phi[:-1, :] + phi[1:, :]))
    cz = HALF * (phi[:, :-1] + phi[:, 1:])
    centred = np.concatenate([cx.ravel(), cz.ravel()])
    vel = np.asarray(vel, dtype=float)
    moving = np.abs(vel) > 0.0
    upwind = np.where(moving, flux / np.where(moving, vel, 1.0), centred)
    weight = np.minimum(1.0, np.abs(vel) / u_ref)
    return centred + (upwind - centred) * weight


@dataclass(frozen=True)
class BoundReport:
    """What :func:`clip_to_bounds` found and changed.

    Attributes
    ----------
    max_before, min_before : float
        Extremes of phi before clipping [-].
    clipped_mass : float
        Mass removed where phi > phi_max, ``sum (phi - phi_max)^+ dV`` [m^2 per unit width].
    added_mass : float
        Mass added where phi < 0, ``sum (-phi)^+ dV`` [m^2 per unit width].
    n_clipped : int
        Number of cells changed.
    """

    max_before: float
    min_before: float
    clipped_mass: float
    added_mass: float
    n_clipped: int


def _volume(excess, cell_volume) -> float:
    """``sum excess dV``: ``cell_volume`` a scalar (plane) or the cells' volumes (axisymmetric)."""
    if np.ndim(cell_volume) == 0:
        return float(excess.sum() * cell_volume)
    return float(np.sum(excess * cell_volume))


def clip_to_bounds(phi: np.ndarray, phi_max: float, cell_volume: float) -> tuple[np.ndarray, BoundReport]:
    """Clip phi to ``[0, phi_max]`` and report the mass removed/added (NUMERICS.md §6).

    Returns
    -------
    phi_clipped : ndarray
    report : BoundReport
    """
    over = np.maximum(phi - phi_max, 0.0)
    under = np.maximum(-phi, 0.0)
    report = BoundReport(
        max_before=float(np.max(phi)),
        min_before=float(np.min(phi)),
        clipped_mass=_volume(over, cell_volume),
        added_mass=_volume(under, cell_volume),
        n_clipped=int(np.count_nonzero(over) + np.count_nonzero(under)),
    )
    return np.clip(phi, 0.0, phi_max), report
