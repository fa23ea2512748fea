"""Transport of the material indicator and of the grains inside it (scheme v2, issue 12;
``numerics.surface = "indicator"``).

Two fields on the cells: the **material fraction** ``c`` in [0, 1] (the volume fraction of the cell
that the granular material occupies, a volume-of-fluid indicator) and the **solid fraction**
``phi`` (grain volume per cell volume, the field of paper eq. syst1b, as everywhere else in
granflow). The packing *inside* the material is ``psi = phi / c`` (the paper's phi, which the
closure and the dilatancy law see); a cell with ``c > C_MIN`` is material, with its weight, its
pressure and its strength, however little of it is filled.

Equations. The material moves with the granular velocity and dilates with it, and the grains move
with the material:

    d_t c + div(c u) = c div u,        d_t phi + div(phi u) = 0   (eq. syst1b),

so that ``D_t psi = -psi div u`` inside the material (eq. syst1b in Lagrangian form). In the
ambient (``c = 0``) the source vanishes and the velocity's divergence is not constrained.

Scheme (finite volumes, face velocities frozen over the step, one forward-Euler step: the
donor-acceptor fractions are geometric, and the average of two Runge-Kutta stages would smear the
surface they keep sharp; the MUSCL-minmod packing is TVD under forward Euler for CFL <= 1/2):

* volume fluxes ``F_c = c_f u`` with donor-acceptor fractions ``c_f`` (:func:`volume_fluxes`,
  Hirt & Nichols 1981 with Youngs' normal: a geometric, one-dimensional reconstruction per face,
  so a full cell that draws material from a partial one receives material, not ambient, and a
  surface stays within one or two cells), outflows limited so that ``c >= 0``;
* solid fluxes ``F_phi = psi_f F_c``: the grains cross a face inside the material volume that
  crosses it, with ``psi_f`` the upwind MUSCL-minmod value of ``psi`` (slopes taken only between
  material cells). So ``phi`` is conserved to round-off (a flux form); the outflows of a cell
  are scaled so that it never loses more grains than it holds (the MUSCL ``psi_f`` can exceed
  the donor's ``psi``: a draining cell's last grains would otherwise leave it at ``phi < 0``,
  measured -3e-10 in a fluidised collapse);
* ``c* = (c - dt div F_c) / (1 - dt div u)`` in the cells with a dilatancy row (``c >= C_ROW``;
  the source implicit: a full cell stays exactly full, ``1 - dt div u`` over ``1 - dt div u``;
  in a partial one, with the velocity linear across the cell, the surface moves at the velocity
  at its height); in a thin cell (``c < C_ROW``) the ambient share of the cell takes up the
  cell's divergence, so the source uses the material's own rate, the closure's dilatancy law at
  the cell's friction pressure (``dilation``), or none;
  a partial cell's remaining room is passed on when inflow overfills it
  (:func:`overfill_correction`).

Bounds. The solid fluxes are limited so that ``phi <= phi_max``
(:func:`granflow.physics.transport.limit_to_upper_bound`). The indicator is then made consistent
with the grains it holds, ``phi / phi_max <= c <= 1`` (the material occupies at least the volume
its grains fill at the largest packing), ``c = 0`` where no grains are left; that adjustment
changes the material *volume*, never the grain mass, and is reported
(:attr:`MaterialTransport.adjusted_volume`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granflow.grid import Grid
from granflow.physics.interface_capturing import limit_to_lower_bound
from granflow.physics.material_kernel import fluxes_compiled, kernel_available
from granflow.physics.material_surface import (  # noqa: F401  (re-exported: the reconstructed surface)
    C_FULL,
    C_MIN,
    C_ROW,
    PHI_EMPTY,
    THETA_MIN,
    face_solid_fraction,
    material_fraction,
    packing,
    surface_distance,
    surface_lithostatic,
)
from granflow.physics.transport import (
    BOUND_RTOL,
    HALF,
    face_velocities,
    face_rates,
    flux_divergence,
    limit_to_upper_bound,
    limiter_passes,
    minmod,
)

MIN_DILATION_FACTOR = 0.5
"""Floor of ``1 - dt div u`` in the implicit source (a cell cannot more than double its material
volume in a stage; only reached by a cell that became material in the stage)."""


@dataclass(frozen=True)
class MaterialTransport:
    """Outcome of :func:`advect_material`.

    Attributes
    ----------
    c : ndarray, (nx, nz)
        Material fraction at t^{n+1} [-].
    phi : ndarray, (nx, nz)
        Solid fraction at t^{n+1} [-] (not clipped: ``phi - phi^n = -dt div F``).
    flux_x, flux_z : ndarray
        Time-averaged solid fluxes of the step [m s^-1] (as
        :class:`granflow.physics.transport.TransportResult`).
    held_back : float
        Solid volume per unit width [m^2] that the upper-bound limiter kept in donor cells.
    adjusted_volume : float
        Material volume per unit width [m^2] added or removed by the consistency bounds
        ``phi/phi_max <= c <= 1`` (absolute sum; no grain mass moves).
    """

    c: np.ndarray
    phi: np.ndarray
    flux_x: np.ndarray
    flux_z: np.ndarray
    held_back: float = 0.0
    adjusted_volume: float = 0.0


def _material_slopes(q: np.ndarray, material: np.ndarray, axis: int, periodic: bool) -> np.ndarray:
    """Minmod slopes of ``q`` along ``axis``, zero where a neighbour (or the cell) is not material
    and at the walls."""
    if periodic:
        lo, hi = np.roll(q, 1, axis=axis), np.roll(q, -1, axis=axis)
        m_lo, m_hi = np.roll(material, 1, axis=axis), np.roll(material, -1, axis=axis)
        slope = minmod(q - lo, hi - q)
    else:
        d = np.diff(q, axis=axis)
        zero = np.zeros_like(np.take(d, [0], axis=axis))
        slope = minmod(np.concatenate([zero, d], axis=axis), np.concatenate([d, zero], axis=axis))
        edge = np.zeros_like(np.take(material, [0], axis=axis))
        n = q.shape[axis]
        m_lo = np.concatenate([edge, np.take(material, np.arange(n - 1), axis=axis)], axis=axis)
        m_hi = np.concatenate([np.take(material, np.arange(1, n), axis=axis), edge], axis=axis)
    return np.where(material & m_lo & m_hi, slope, 0.0)


def solid_fluxes(grid: Grid, psi, material, fcx, fcz) -> tuple[np.ndarray, np.ndarray]:
    """``psi_f F_c`` on every face [m s^-1]: ``psi_f`` the upwind MUSCL-minmod face value of the
    packing (slopes between material cells only), upwind by the sign of the volume flux."""
    psi = np.asarray(psi, dtype=float)
    sx = _material_slopes(psi, material, 0, grid.periodic_x)
    sz = _material_slopes(psi, material, 1, False)
    hi_x, lo_x = psi + HALF * sx, psi - HALF * sx
    hi_z, lo_z = psi + HALF * sz, psi - HALF * sz
    gx, gz = np.zeros_like(fcx), np.zeros_like(fcz)
    if grid.periodic_x:  # x-face i between cells i-1 (mod nx) and i; fcx[nx] is the image
        left, right = np.roll(hi_x, 1, axis=0), lo_x
        f = fcx[:-1, :]
        gx[:-1, :] = np.where(f > 0.0, f * left, f * right)
        gx[-1, :] = gx[0, :]
    else:
        f = fcx[1:-1, :]
        gx[1:-1, :] = np.where(f > 0.0, f * hi_x[:-1, :], f * lo_x[1:, :])
    f = fcz[:, 1:-1]
    gz[:, 1:-1] = np.where(f > 0.0, f * hi_z[:, :-1], f * lo_z[:, 1:])
    return gx, gz


def consistent_bounds(c, phi, phi_max: float, cell_volume: float,
                      psi_min: float = 0.0) -> tuple[np.ndarray, float]:
    """``c`` made consistent with the grains it holds (module docstring, "Bounds"): returns the
    adjusted ``c`` and the material volume changed [m^2 per unit width; m^3 with the cells'
    volumes of an axisymmetric grid as ``cell_volume``]. ``psi_min`` > 0: the
    loosest packing of the material, ``c <= phi / psi_min`` (a material volume with almost no
    grains -- a thin cell dilated at the closure's rate under a vanishing pressure -- would
    otherwise carry a pressure row at a packing far below the dense regime)."""
    c = np.asarray(c, dtype=float)
    phi = np.asarray(phi, dtype=float)
    upper = np.minimum(np.maximum(phi, 0.0) / psi_min, 1.0) if psi_min > 0 else 1.0
    new = np.clip(c, np.maximum(phi, 0.0) / phi_max, upper)
    new = np.where(phi > PHI_EMPTY, new, 0.0)
    if np.ndim(cell_volume):  # the cells' volumes (axisymmetric)
        return new, float(np.sum(cell_volume * np.abs(new - c)))
    return new, cell_volume * float(np.sum(np.abs(new - c)))


def _shifted(q: np.ndarray, k: int, axis: int, periodic: bool) -> np.ndarray:
    """``q`` at the cell ``k`` steps along ``axis`` (``q_{i+k}``); beyond a wall, the wall cell."""
    if periodic:
        return np.roll(q, -k, axis=axis)
    n = q.shape[axis]
    if k == 0:
        return q
    m = min(abs(k), n)  # slices and copies only: the values of np.take(q, clip(i + k, 0, n - 1))
    if axis == 0:
        if k > 0:
            return np.concatenate([q[m:], np.repeat(q[-1:], m, axis=0)])
        return np.concatenate([np.repeat(q[:1], m, axis=0), q[:n - m]])
    if k > 0:
        return np.concatenate([q[:, m:], np.repeat(q[:, -1:], m, axis=1)], axis=1)
    return np.concatenate([np.repeat(q[:, :1], m, axis=1), q[:, :n - m]], axis=1)


def interface_normal(c: np.ndarray, periodic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Youngs' normal ``(n_x, n_z)`` (unnormalised, ``-grad c`` from the 3 x 3 stencil with
    weights 1, 2, 1; Youngs 1982) in grid-index units."""
    cx = _shifted(c, 1, 0, periodic) - _shifted(c, -1, 0, periodic)
    cz = _shifted(c, 1, 1, False) - _shifted(c, -1, 1, False)
    nx = -(_shifted(cx, 1, 1, False) + 2.0 * cx + _shifted(cx, -1, 1, False))
    nz = -(_shifted(cz, 1, 0, periodic) + 2.0 * cz + _shifted(cz, -1, 0, periodic))
    return nx, nz


def donor_acceptor_fraction(c_d, c_a, c_u, along, courant):
    """Material fraction of the volume that crosses a face in a stage (Hirt & Nichols 1981,
    J. Comput. Phys. 39, 201; one-dimensional geometric (SLIC) reconstruction):

    * interface across the flow (``along``: the normal is mostly along it): the donor's material
      sits beside its fuller neighbour; towards the acceptor (``c_a >= c_u``) the first
      ``min(courant, c_d)`` of the swept width is material, away from it only
      ``max(0, courant - (1 - c_d))``;
    * interface along the flow: the donor's own fraction ``c_d`` (exact for a sliding layer).

    ``courant = |u| dt / h`` per face; returns ``c_f`` in [0, 1] (``c_f u`` the volume flux)."""
    safe = np.maximum(courant, np.finfo(float).tiny)
    near = np.where(courant > 0, np.minimum(courant, c_d) / safe, np.minimum(c_d / np.finfo(float).eps, 1.0))
    far = np.where(courant > 0, np.maximum(courant - (1.0 - c_d), 0.0) / safe, np.where(c_d >= 1.0, 1.0, 0.0))
    cross = np.where(c_a >= c_u, near, far)
    return np.clip(np.where(along, cross, c_d), 0.0, 1.0)


def volume_fluxes(grid: Grid, c, u, w, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Volume fluxes ``c_f u`` [m s^-1] of the material on every face (walls: 0), with the
    donor-acceptor fractions of :func:`donor_acceptor_fraction` and Youngs' normal of the donor."""
    c = np.asarray(c, dtype=float)
    per = grid.periodic_x
    nx, nz = interface_normal(c, per)
    fx, fz = np.zeros(grid.xface_shape), np.zeros(grid.zface_shape)
    # x-faces: face i between cells i-1 and i (periodic: i-1 mod nx; image column fx[nx] = fx[0])
    lo = [np.roll(q, 1, axis=0) for q in (c, nx, nz)] if per else [q[:-1] for q in (c, nx, nz)]
    hi = [c, nx, nz] if per else [q[1:] for q in (c, nx, nz)]
    lo2 = np.roll(c, 2, axis=0) if per else _shifted(c, -1, 0, False)[:-1]
    hi2 = np.roll(c, -1, axis=0) if per else _shifted(c, 1, 0, False)[1:]
    ui = u[:-1] if per else u[1:-1]
    pos = ui > 0.0
    c_d = np.where(pos, lo[0], hi[0])
    c_a = np.where(pos, hi[0], lo[0])
    c_u = np.where(pos, lo2, hi2)
    n_along = np.abs(np.where(pos, lo[1], hi[1])) >= np.abs(np.where(pos, lo[2], hi[2]))
    frac = donor_acceptor_fraction(c_d, c_a, c_u, n_along, np.abs(ui) * dt / grid.dx)
    if per:
        fx[:-1] = frac * ui
        fx[-1] = fx[0]
    else:
        fx[1:-1] = frac * ui
    # z-faces: face j between cells j-1 and j
    wi = w[:, 1:-1]
    pos = wi > 0.0
    below, above = c[:, :-1], c[:, 1:]
    below2 = _shifted(c, -1, 1, False)[:, :-1]
    above2 = _shifted(c, 1, 1, False)[:, 1:]
    c_d = np.where(pos, below, above)
    c_a = np.where(pos, above, below)
    c_u = np.where(pos, below2, above2)
    n_along = (np.abs(np.where(pos, nz[:, :-1], nz[:, 1:])) > np.abs(np.where(pos, nx[:, :-1], nx[:, 1:])))
    fz[:, 1:-1] = donor_acceptor_fraction(c_d, c_a, c_u, n_along, np.abs(wi) * dt / grid.dz) * wi
    return fx, fz


def overfill_correction(grid: Grid, c, fx, fz, u, w, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Volume fluxes with the overfill of partial cells passed on downstream.

    A partial cell's material can grow within a stage by more than the room left in it (what
    enters through one face pushes its material across the cell); the donor-acceptor fraction of
    its outflow faces, taken from the cell at the start of the stage, does not see that. The
    excess ``c - dt div F - 1 > 0`` leaves through the cell's outflow faces, shared in proportion
    to their spare capacity ``(1 - c_f) |u| dt / h`` and at most that (fluxes only grow where
    the velocity leaves the cell, so the other bounds are kept). Returns ``(fx, fz)`` (copies)."""
    fx, fz = fx.copy(), fz.copy()
    excess = np.maximum(c - dt * flux_divergence(grid, fx, fz) - 1.0, 0.0)
    if not np.any(excess > 0.0):
        return fx, fz
    cx = dt / grid.dx
    cw, ce, cz = face_rates(grid, dt)  # dt/dx, dt/dx, dt/dz in a plane
    spare_e = np.where(u[1:] > 0, ce * np.maximum(u[1:] - fx[1:], 0.0), 0.0)
    spare_w = np.where(u[:-1] < 0, cw * np.maximum(fx[:-1] - u[:-1], 0.0), 0.0)
    spare_n = np.where(w[:, 1:] > 0, cz * np.maximum(w[:, 1:] - fz[:, 1:], 0.0), 0.0)
    spare_s = np.where(w[:, :-1] < 0, cz * np.maximum(fz[:, :-1] - w[:, :-1], 0.0), 0.0)
    total = spare_e + spare_w + spare_n + spare_s
    share = np.divide(np.minimum(excess, total), total, out=np.zeros_like(total), where=total > 0)
    if getattr(grid, "radial", None) is None:
        add_e, add_w = share * spare_e / cx, share * spare_w / cx
    else:  # the axis face has no area (and u = 0): nothing to add there
        add_e = np.divide(share * spare_e, ce, out=np.zeros_like(spare_e), where=spare_e > 0)
        add_w = np.divide(share * spare_w, cw, out=np.zeros_like(spare_w), where=spare_w > 0)
    fx[1:] += add_e
    fx[:-1] -= add_w
    if grid.periodic_x:  # fx[0] and the image fx[nx] are one face: both get both increments
        fx[0] += add_e[-1]
        fx[-1] -= add_w[0]
    fz[:, 1:] += share * spare_n / cz
    fz[:, :-1] -= share * spare_s / cz
    return fx, fz


def solid_filled(c, solid) -> np.ndarray:
    """``c`` with the solid cells of a topography (bool (nx, nz), the lowest cells of each column,
    :mod:`granflow.topography`; None: none) set to the column's lowest fluid cell: the field the
    reconstruction of :func:`volume_fluxes` reads. Below a flat piece of base this is the box's
    own rule beyond a wall (the wall cell repeated, :func:`_shifted`), so a layer on a raised
    floor is carried exactly as on the box's base; beside a step's side the solid reads the
    column's base value (first order). Every flux through a face beside a solid cell is zero
    (u = 0 there), so the fill moves no material."""
    if solid is None:
        return c
    c = np.asarray(c, dtype=float)
    solid = np.asarray(solid, dtype=bool).reshape(c.shape)
    base = np.minimum(solid.sum(axis=1), c.shape[1] - 1)
    return np.where(solid, c[np.arange(c.shape[0]), base][:, None], c)


def _fluxes(grid: Grid, c, phi, u, w, dt: float, phi_max: float, c_rec=None):
    """The volume and solid fluxes of a stage: ``(F_c, F_phi, held)`` (they do not depend on the
    dilatation, which only changes the material volume afterwards); ``c_rec`` the field the volume
    fluxes' reconstruction reads (:func:`solid_filled`; default ``c``). The compiled kernel
    (:mod:`granflow.physics.material_kernel`) when Numba is installed, else the NumPy reference
    :func:`_fluxes_numpy` (same arguments and result; equal bit for bit on the cases tested, the
    held-back volume to round-off: a sum in another order)."""
    if not kernel_available() or getattr(grid, "radial", None) is not None:  # the kernel is plane
        return _fluxes_numpy(grid, c, phi, u, w, dt, phi_max, c_rec)
    return fluxes_compiled(c, phi, u, w, dt, grid.dx, grid.dz, phi_max,
                           phi_max * (1.0 + BOUND_RTOL), C_MIN, grid.periodic_x, limiter_passes(grid), c_rec)


def _fluxes_numpy(grid: Grid, c, phi, u, w, dt: float, phi_max: float, c_rec=None):
    """NumPy reference of :func:`_fluxes`: donor-acceptor volume fluxes, overfill correction,
    ``c >= 0``; MUSCL packing fluxes, ``phi >= 0``, ``phi <= phi_max``."""
    c_rec = c if c_rec is None else c_rec
    fcx, fcz = overfill_correction(grid, c, *volume_fluxes(grid, c_rec, u, w, dt), u, w, dt)
    rad = getattr(grid, "radial", None)
    fcx, fcz = limit_to_lower_bound(c, fcx, fcz, dt, grid.dx, grid.dz, grid.periodic_x, rad)
    gx, gz = solid_fluxes(grid, packing(c, phi), c > C_MIN, fcx, fcz)
    # a MUSCL psi_f above the donor's psi can take more grains than a draining cell holds
    gx, gz = limit_to_lower_bound(phi, gx, gz, dt, grid.dx, grid.dz, grid.periodic_x, rad)
    gx, gz, held = limit_to_upper_bound(grid, phi, gx, gz, dt, phi_max)
    return (fcx, fcz), (gx, gz), held


def _stage(grid: Grid, c, phi, u, w, div_u, dt: float, phi_max: float, dilation=None, c_rec=None):
    """One forward-Euler stage: ``(c*, phi*, F_c, F_phi, held)`` (module docstring)."""
    material, rows = c > C_MIN, c >= C_ROW   # rows: the cells with a dilatancy row
    (fcx, fcz), (gx, gz), held = _fluxes(grid, c, phi, u, w, dt, phi_max, c_rec)
    c_new = c - dt * flux_divergence(grid, fcx, fcz)
    factor = np.maximum(1.0 - dt * div_u, MIN_DILATION_FACTOR)
    dilating = rows
    if dilation is not None:  # thin cells dilate at the closure's rate
        thin = material & ~rows
        factor = np.where(thin, np.maximum(1.0 - dt * dilation, MIN_DILATION_FACTOR), factor)
        dilating = rows | thin
    c_new = np.where(dilating, c_new / factor, c_new)
    return c_new, phi - dt * flux_divergence(grid, gx, gz), (gx, gz), held


WINDOW_MARGIN = 4
"""Empty cells kept around the material by :func:`material_window` [cells]: the reach of the
stencils of one stage (Youngs' normal of a donor's upwind neighbour: 2 cells; the MUSCL slopes:
1) plus one, so that every face of the window's edge has an empty donor (zero flux) on both sides."""
WINDOW_FRACTION = 0.5
"""A window larger than this fraction of the grid is not worth cutting: the whole grid is used."""


@dataclass(frozen=True)
class _Window:
    """The geometry a stage needs (the attributes of :class:`granflow.grid.Grid` it reads) of a
    closed sub-box of the grid with the same dx, dz."""

    nx: int
    nz: int
    dx: float
    dz: float
    periodic_x: bool
    radial: object = None
    """The :class:`granflow.grid.RadialMetric` of the window's rows (axisymmetric), else None."""

    @property
    def cell_shape(self) -> tuple[int, int]:
        return (self.nx, self.nz)

    @property
    def xface_shape(self) -> tuple[int, int]:
        return (self.nx + 1, self.nz)

    @property
    def zface_shape(self) -> tuple[int, int]:
        return (self.nx, self.nz + 1)

    @property
    def cell_volume(self) -> float:
        return self.dx * self.dz

    @property
    def cell_volumes(self):
        """As :attr:`granflow.grid.Grid.cell_volumes` (a scalar in a plane)."""
        return self.cell_volume if self.radial is None else self.cell_volume * self.radial.cells


def material_window(grid: Grid, c, phi) -> tuple[slice, slice] | None:
    """Index ranges (x, z) of the cells within :data:`WINDOW_MARGIN` of any cell holding material
    or grains (``c > 0`` or ``phi != 0``), or None when that box is more than
    :data:`WINDOW_FRACTION` of the grid (or the grid is empty). Periodic in x: the whole x range.
    Outside it every field is exactly 0 before and after a stage, and the faces of its edge carry
    no flux, so a stage on the window gives the same fields, bit for bit, at the cost of the
    window (a column collapse fills a few % of its box)."""
    occupied = (np.asarray(c) > 0.0) | (np.asarray(phi) != 0.0)
    cols, rows = np.flatnonzero(occupied.any(axis=1)), np.flatnonzero(occupied.any(axis=0))
    if cols.size == 0:
        return None
    m = WINDOW_MARGIN
    xs = (slice(0, grid.nx) if grid.periodic_x
          else slice(max(int(cols[0]) - m, 0), min(int(cols[-1]) + 1 + m, grid.nx)))
    zs = slice(max(int(rows[0]) - m, 0), min(int(rows[-1]) + 1 + m, grid.nz))
    if (xs.stop - xs.start) * (zs.stop - zs.start) > WINDOW_FRACTION * grid.nx * grid.nz:
        return None
    return xs, zs


def _advect(geom, c, phi, u, w, dt: float, phi_max: float, dilation, psi_min: float, c_rec=None):
    """:func:`advect_material` on whole face arrays of ``geom`` (a Grid or a :class:`_Window`)."""
    div_u = flux_divergence(geom, u, w)
    c1, phi_new, fluxes, held = _stage(geom, c, phi, u, w, div_u, dt, phi_max, dilation, c_rec)
    c_new, adjusted = consistent_bounds(c1, phi_new, phi_max, geom.cell_volume if geom.radial is None else geom.cell_volumes, psi_min)
    return c_new, phi_new, fluxes, held, adjusted


def _window_geometry(grid: Grid, win: tuple[slice, slice]) -> tuple:
    """``(_Window, x-face slice, z-face slice)`` of the cell ranges ``win``."""
    xs, zs = win
    xf = slice(0, grid.nx + 1) if grid.periodic_x else slice(xs.start, xs.stop + 1)
    rad = grid.radial
    sub = _Window(nx=xs.stop - xs.start, nz=zs.stop - zs.start, dx=grid.dx, dz=grid.dz,
                  periodic_x=grid.periodic_x,
                  radial=None if rad is None else type(rad)(faces=rad.faces[xf], cells=rad.cells[xs]))
    return sub, xf, slice(zs.start, zs.stop + 1)


def material_solid_fluxes(grid: Grid, c, phi, vel, dt: float, phi_max: float,
                          window: tuple | None | str = "auto", solid=None) -> tuple:
    """The solid fluxes ``(flux_x, flux_z)`` [m s^-1] that :func:`advect_material` with the same
    arguments returns (bit for bit; on the :func:`material_window`), without the rest of the step:
    what the consistent momentum transport needs at every Picard sweep. ``window``: the
    :func:`material_window` of ``(c, phi)`` if already known (None: the whole grid), else
    ``"auto"`` to compute it; ``solid`` the solid cells of a topography (:func:`solid_filled`)."""
    c = np.asarray(c, dtype=float)
    phi = np.asarray(phi, dtype=float)
    u, w = face_velocities(grid, vel)
    c_rec = solid_filled(c, solid)
    win = material_window(grid, c, phi) if isinstance(window, str) else window
    if win is None:
        return _fluxes(grid, c, phi, u, w, dt, phi_max, c_rec)[1]
    xs, zs = win
    sub, xf, zf = _window_geometry(grid, win)
    gx1, gz1 = _fluxes(sub, c[xs, zs], phi[xs, zs], u[xf, zs], w[xs, zf], dt, phi_max, c_rec[xs, zs])[1]
    gx, gz = np.zeros(grid.xface_shape), np.zeros(grid.zface_shape)
    gx[xf, zs], gz[xs, zf] = gx1, gz1
    return gx, gz


def advect_material(grid: Grid, c, phi, vel, dt: float, phi_max: float, dilation=None,
                    psi_min: float = 0.0, solid=None) -> MaterialTransport:
    """One step of the material indicator and the grains (module docstring) with the
    frozen face velocities ``vel`` [m s^-1], ``dt`` [s] (CFL <= 1/2); ``dilation`` (nx, nz)
    [s^-1], optional: the dilatation rate of the material in the thin cells (the closure's
    law at their friction pressure), else they are carried without dilating; ``psi_min`` the
    loosest packing of the material (:func:`consistent_bounds`); ``solid`` the solid cells of a
    topography (bool (nx, nz); the reconstruction reads them as :func:`solid_filled`).

    Examples
    --------
    A full, translated slab stays full and keeps its grains:

    >>> from granflow.grid import Grid
    >>> g = Grid(nx=8, nz=2, Lx=1.0, Lz=0.25)
    >>> u = np.zeros(g.xface_shape); u[1:-1] = 1.0
    >>> vel = g.pack_velocity(u, np.zeros(g.zface_shape))
    >>> c = np.zeros(g.cell_shape); c[2:4] = 1.0
    >>> out = advect_material(g, c, 0.55 * c, vel, 0.05, 0.6)
    >>> bool(np.isclose(out.phi.sum(), 0.55 * c.sum(), rtol=0, atol=1e-14)), float(out.c.max()) <= 1.0
    (True, True)
    """
    c = np.asarray(c, dtype=float)
    phi = np.asarray(phi, dtype=float)
    u, w = face_velocities(grid, vel)
    if dilation is not None:
        dilation = np.asarray(dilation, dtype=float).reshape(grid.cell_shape)
    c_rec = solid_filled(c, solid)
    win = material_window(grid, c, phi)
    if win is None:
        c_new, phi_new, (gx, gz), held, adjusted = _advect(grid, c, phi, u, w, dt, phi_max, dilation,
                                                           psi_min, c_rec)
    else:  # the same arithmetic on the window only (material_window)
        xs, zs = win
        sub, xf, zf = _window_geometry(grid, win)
        c1, phi1, (gx1, gz1), held, adjusted = _advect(
            sub, c[xs, zs], phi[xs, zs], u[xf, zs], w[xs, zf], dt, phi_max,
            None if dilation is None else dilation[xs, zs], psi_min, c_rec[xs, zs])
        c_new, phi_new = np.zeros_like(c), np.zeros_like(phi)
        gx, gz = np.zeros(grid.xface_shape), np.zeros(grid.zface_shape)
        c_new[xs, zs], phi_new[xs, zs] = c1, phi1
        gx[xf, zs], gz[xs, zf] = gx1, gz1
    return MaterialTransport(c=c_new, phi=phi_new, flux_x=gx, flux_z=gz,
                             held_back=held, adjusted_volume=adjusted)
