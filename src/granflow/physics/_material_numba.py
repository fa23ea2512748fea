"""The Numba functions of :mod:`granflow.physics.material_kernel` (imported on first use, so that
``import granflow`` does not import Numba; module-level so that ``cache=True`` can store them).
Each mirrors a NumPy function of :mod:`granflow.physics.material` or
:mod:`granflow.physics.interface_capturing`, with the same floating-point operations in the same
order."""
from __future__ import annotations

import numpy as np
from numba import njit

from granflow.physics._transport_numba import limit, minmod, scale_fluxes

HALF = 0.5
TINY = np.finfo(np.float64).tiny
EPS = np.finfo(np.float64).eps


@njit(cache=True)
def _near(i, n, k, periodic):
    """Index of the cell ``k`` steps from ``i`` (``material._shifted``: wrapped, or the wall cell)."""
    if periodic:
        return (i + k) % n
    return min(max(i + k, 0), n - 1)


@njit(cache=True)
def interface_normal(c, periodic, nxn, nzn):
    """Youngs' normal into ``nxn``, ``nzn`` (``material.interface_normal``)."""
    nx, nz = c.shape
    cx = np.empty((nx, nz))
    cz = np.empty((nx, nz))
    for i in range(nx):
        ip, im = _near(i, nx, 1, periodic), _near(i, nx, -1, periodic)
        for j in range(nz):
            jp, jm = _near(j, nz, 1, False), _near(j, nz, -1, False)
            cx[i, j] = c[ip, j] - c[im, j]
            cz[i, j] = c[i, jp] - c[i, jm]
    for i in range(nx):
        ip, im = _near(i, nx, 1, periodic), _near(i, nx, -1, periodic)
        for j in range(nz):
            jp, jm = _near(j, nz, 1, False), _near(j, nz, -1, False)
            nxn[i, j] = -(cx[i, jp] + 2.0 * cx[i, j] + cx[i, jm])
            nzn[i, j] = -(cz[ip, j] + 2.0 * cz[i, j] + cz[im, j])


@njit(cache=True)
def donor_acceptor_fraction(c_d, c_a, c_u, along, courant):
    """``material.donor_acceptor_fraction`` of one face."""
    if not along:
        return min(max(c_d, 0.0), 1.0)
    safe = max(courant, TINY)
    if c_a >= c_u:
        v = min(courant, c_d) / safe if courant > 0 else min(c_d / EPS, 1.0)
    else:
        if courant > 0:
            v = max(courant - (1.0 - c_d), 0.0) / safe
        else:
            v = 1.0 if c_d >= 1.0 else 0.0
    return min(max(v, 0.0), 1.0)


@njit(cache=True)
def volume_fluxes(c, u, w, dt, dx, dz, periodic, fx, fz):
    """Donor-acceptor volume fluxes into ``fx``, ``fz`` (zero-initialised; ``material.volume_fluxes``)."""
    nx, nz = c.shape
    nxn = np.empty((nx, nz))
    nzn = np.empty((nx, nz))
    interface_normal(c, periodic, nxn, nzn)
    first = 0 if periodic else 1
    for i in range(first, nx):  # x-face i between cells i - 1 (mod nx) and i
        lo, hi = (i - 1) % nx, i
        lo2, hi2 = _near(i, nx, -2, periodic), _near(i, nx, 1, periodic)
        for j in range(nz):
            ui = u[i, j]
            if ui > 0.0:
                c_d, c_a, c_u = c[lo, j], c[hi, j], c[lo2, j]
                along = abs(nxn[lo, j]) >= abs(nzn[lo, j])
            else:
                c_d, c_a, c_u = c[hi, j], c[lo, j], c[hi2, j]
                along = abs(nxn[hi, j]) >= abs(nzn[hi, j])
            fx[i, j] = donor_acceptor_fraction(c_d, c_a, c_u, along, abs(ui) * dt / dx) * ui
    if periodic:
        for j in range(nz):
            fx[nx, j] = fx[0, j]
    for i in range(nx):
        for j in range(1, nz):  # z-face j between cells j - 1 and j
            wj = w[i, j]
            lo2, hi2 = _near(j, nz, -2, False), _near(j, nz, 1, False)
            if wj > 0.0:
                c_d, c_a, c_u = c[i, j - 1], c[i, j], c[i, lo2]
                along = abs(nzn[i, j - 1]) > abs(nxn[i, j - 1])
            else:
                c_d, c_a, c_u = c[i, j], c[i, j - 1], c[i, hi2]
                along = abs(nzn[i, j]) > abs(nxn[i, j])
            fz[i, j] = donor_acceptor_fraction(c_d, c_a, c_u, along, abs(wj) * dt / dz) * wj


@njit(cache=True)
def overfill_correction(c, fx, fz, u, w, dt, dx, dz, periodic):
    """``material.overfill_correction`` in place on ``fx``, ``fz``."""
    nx, nz = c.shape
    excess = np.empty((nx, nz))
    any_excess = False
    for i in range(nx):
        for j in range(nz):
            e = max(c[i, j] - dt * ((fx[i + 1, j] - fx[i, j]) / dx + (fz[i, j + 1] - fz[i, j]) / dz) - 1.0, 0.0)
            excess[i, j] = e
            if e > 0.0:
                any_excess = True
    if not any_excess:
        return
    cx, cz = dt / dx, dt / dz
    add_e = np.empty((nx, nz))
    add_w = np.empty((nx, nz))
    add_n = np.empty((nx, nz))
    add_s = np.empty((nx, nz))
    for i in range(nx):
        for j in range(nz):
            se = cx * max(u[i + 1, j] - fx[i + 1, j], 0.0) if u[i + 1, j] > 0 else 0.0
            sw = cx * max(fx[i, j] - u[i, j], 0.0) if u[i, j] < 0 else 0.0
            sn = cz * max(w[i, j + 1] - fz[i, j + 1], 0.0) if w[i, j + 1] > 0 else 0.0
            ss = cz * max(fz[i, j] - w[i, j], 0.0) if w[i, j] < 0 else 0.0
            total = se + sw + sn + ss
            share = min(excess[i, j], total) / total if total > 0 else 0.0
            add_e[i, j] = share * se / cx
            add_w[i, j] = share * sw / cx
            add_n[i, j] = share * sn / cz
            add_s[i, j] = share * ss / cz
    for i in range(nx):  # fx[1:] += add_e, then fx[:-1] -= add_w (NumPy's order)
        for j in range(nz):
            fx[i + 1, j] += add_e[i, j]
    for i in range(nx):
        for j in range(nz):
            fx[i, j] -= add_w[i, j]
    if periodic:  # fx[0] and the image fx[nx] are one face: both get both increments
        for j in range(nz):
            fx[0, j] += add_e[nx - 1, j]
            fx[nx, j] -= add_w[0, j]
    for i in range(nx):
        for j in range(nz):
            fz[i, j + 1] += add_n[i, j]
        for j in range(nz):
            fz[i, j] -= add_s[i, j]


@njit(cache=True)
def limit_to_lower_bound(q, fx, fz, dt, dx, dz, periodic):
    """``interface_capturing.limit_to_lower_bound`` in place on ``fx``, ``fz``."""
    nx, nz = q.shape
    cx, cz = dt / dx, dt / dz
    r = np.ones((nx, nz))
    any_over = False
    for i in range(nx):
        for j in range(nz):
            out = (cx * (max(fx[i + 1, j], 0.0) + max(-fx[i, j], 0.0))
                   + cz * (max(fz[i, j + 1], 0.0) + max(-fz[i, j], 0.0)))
            if out > max(q[i, j], 0.0):  # as the NumPy reference (q = -1e-20 with no outflow)
                any_over = True
                r[i, j] = max(q[i, j], 0.0) / out
    if any_over:
        scale_fluxes(fx, fz, r, periodic, True)


@njit(cache=True)
def _material_slope(q, m, i, n, lo, hi, periodic):
    """Minmod slope of cell ``i`` between material cells (``material._material_slopes``), from the
    cell's value ``q``, material flag ``m`` and neighbour values/flags ``lo``, ``hi`` (tuples)."""
    if periodic:
        back, fwd = q - lo[0], hi[0] - q
        ok = m and lo[1] and hi[1]
    else:
        back = q - lo[0] if i > 0 else 0.0
        fwd = hi[0] - q if i < n - 1 else 0.0
        ok = m and i > 0 and i < n - 1 and lo[1] and hi[1]
    return minmod(back, fwd) if ok else 0.0


@njit(cache=True)
def solid_fluxes(c, phi, fcx, fcz, c_min, periodic, gx, gz):
    """``psi_f F_c`` into ``gx``, ``gz`` (zero-initialised; ``material.solid_fluxes`` of
    ``packing(c, phi)`` and ``c > c_min``)."""
    nx, nz = c.shape
    psi = np.empty((nx, nz))
    mat = np.empty((nx, nz), dtype=np.bool_)
    for i in range(nx):
        for j in range(nz):
            mat[i, j] = c[i, j] > c_min
            psi[i, j] = phi[i, j] / c[i, j] if mat[i, j] else 0.0
    hi_x = np.empty((nx, nz))
    lo_x = np.empty((nx, nz))
    hi_z = np.empty((nx, nz))
    lo_z = np.empty((nx, nz))
    for i in range(nx):
        ip, im = _near(i, nx, 1, periodic), _near(i, nx, -1, periodic)
        for j in range(nz):
            jp, jm = _near(j, nz, 1, False), _near(j, nz, -1, False)
            sx = _material_slope(psi[i, j], mat[i, j], i, nx, (psi[im, j], mat[im, j]),
                                 (psi[ip, j], mat[ip, j]), periodic)
            sz = _material_slope(psi[i, j], mat[i, j], j, nz, (psi[i, jm], mat[i, jm]),
                                 (psi[i, jp], mat[i, jp]), False)
            hi_x[i, j], lo_x[i, j] = psi[i, j] + HALF * sx, psi[i, j] - HALF * sx
            hi_z[i, j], lo_z[i, j] = psi[i, j] + HALF * sz, psi[i, j] - HALF * sz
    first = 0 if periodic else 1
    for i in range(first, nx):  # x-face i between cells i - 1 (mod nx) and i
        im = (i - 1) % nx
        for j in range(nz):
            f = fcx[i, j]
            gx[i, j] = f * hi_x[im, j] if f > 0.0 else f * lo_x[i, j]
    if periodic:
        for j in range(nz):
            gx[nx, j] = gx[0, j]
    for i in range(nx):
        for j in range(1, nz):
            f = fcz[i, j]
            gz[i, j] = f * hi_z[i, j - 1] if f > 0.0 else f * lo_z[i, j]


@njit(cache=True)
def fluxes(c, c_rec, phi, u, w, dt, dx, dz, phi_max, cap, c_min, periodic, max_passes):
    """The volume and solid fluxes of a stage, ``(fcx, fcz, gx, gz, held)`` (``material._fluxes``:
    donor-acceptor volume fluxes with Youngs' normal, read from ``c_rec`` (``c`` with the solid
    cells of a topography filled, ``material.solid_filled``), the overfill correction, ``c >= 0``;
    MUSCL packing fluxes, ``phi >= 0``, ``phi <= phi_max``)."""
    nx, nz = c.shape
    fcx = np.zeros((nx + 1, nz))
    fcz = np.zeros((nx, nz + 1))
    volume_fluxes(c_rec, u, w, dt, dx, dz, periodic, fcx, fcz)
    overfill_correction(c, fcx, fcz, u, w, dt, dx, dz, periodic)
    limit_to_lower_bound(c, fcx, fcz, dt, dx, dz, periodic)
    gx = np.zeros((nx + 1, nz))
    gz = np.zeros((nx, nz + 1))
    solid_fluxes(c, phi, fcx, fcz, c_min, periodic, gx, gz)
    limit_to_lower_bound(phi, gx, gz, dt, dx, dz, periodic)
    hx, hz = gx.copy(), gz.copy()
    limit(phi, gx, gz, dt, dx, dz, phi_max, cap, periodic, max_passes)
    ncol = nx if periodic else nx + 1
    held = dt * (dz * np.sum(np.abs(hx[:ncol] - gx[:ncol])) + dx * np.sum(np.abs(hz - gz)))
    return fcx, fcz, gx, gz, held
