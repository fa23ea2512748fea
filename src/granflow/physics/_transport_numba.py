"""The Numba functions of :mod:`granflow.physics.transport_kernel` (imported on first use, so that
``import granflow`` does not import Numba; module-level so that ``cache=True`` can store them)."""
from __future__ import annotations

import numpy as np
from numba import njit

HALF = 0.5


@njit(cache=True)
def minmod(a, b):
    """sign(a) min(|a|, |b|) if a b > 0, else 0 (as ``transport.minmod``)."""
    if a * b > 0.0:
        return (1.0 if a > 0.0 else -1.0) * min(abs(a), abs(b))
    return 0.0


@njit(cache=True)
def fluxes(phi, u, w, periodic, fx, fz):
    """MUSCL-minmod upwind fluxes into ``fx`` (nx+1, nz), ``fz`` (nx, nz+1) (walls: 0)."""
    nx, nz = phi.shape
    sx = np.zeros((nx, nz))
    sz = np.zeros((nx, nz))
    for i in range(nx):
        for j in range(nz):
            if periodic:
                back = phi[i, j] - phi[(i - 1) % nx, j]
                fwd = phi[(i + 1) % nx, j] - phi[i, j]
            else:
                back = phi[i, j] - phi[i - 1, j] if i > 0 else 0.0
                fwd = phi[i + 1, j] - phi[i, j] if i < nx - 1 else 0.0
            sx[i, j] = minmod(back, fwd)
            back = phi[i, j] - phi[i, j - 1] if j > 0 else 0.0
            fwd = phi[i, j + 1] - phi[i, j] if j < nz - 1 else 0.0
            sz[i, j] = minmod(back, fwd)
    first = 0 if periodic else 1
    for i in range(first, nx):  # x-face i between cells i - 1 (mod nx) and i
        im = (i - 1) % nx
        for j in range(nz):
            ui = u[i, j]
            if ui > 0.0:
                fx[i, j] = ui * (phi[im, j] + HALF * sx[im, j])
            else:
                fx[i, j] = ui * (phi[i, j] - HALF * sx[i, j])
    if periodic:
        for j in range(nz):
            fx[nx, j] = fx[0, j]
    for i in range(nx):
        for j in range(1, nz):
            wj = w[i, j]
            if wj > 0.0:
                fz[i, j] = wj * (phi[i, j - 1] + HALF * sz[i, j - 1])
            else:
                fz[i, j] = wj * (phi[i, j] - HALF * sz[i, j])


@njit(cache=True)
def stage(phi, fx, fz, dt, dx, dz, out):
    """``out = phi - dt div F``."""
    nx, nz = phi.shape
    for i in range(nx):
        for j in range(nz):
            out[i, j] = phi[i, j] - dt * ((fx[i + 1, j] - fx[i, j]) / dx + (fz[i, j + 1] - fz[i, j]) / dz)


@njit(cache=True)
def scale_fluxes(fx, fz, r, periodic, by_donor):
    """Multiply every interior face flux by the factor ``r`` (nx, nz) of the cell it leaves
    (``by_donor``: an outflow limiter) or of the cell it enters (an inflow limiter), in place; the
    periodic image column ``fx[nx]`` is kept equal to ``fx[0]``."""
    nx, nz = r.shape
    first = 0 if periodic else 1
    for i in range(first, nx):
        im = (i - 1) % nx
        for j in range(nz):
            if by_donor:
                fx[i, j] *= r[im, j] if fx[i, j] > 0.0 else r[i, j]
            else:
                fx[i, j] *= r[i, j] if fx[i, j] > 0.0 else r[im, j]
    if periodic:
        for j in range(nz):
            fx[nx, j] = fx[0, j]
    for i in range(nx):
        for j in range(1, nz):
            if by_donor:
                fz[i, j] *= r[i, j - 1] if fz[i, j] > 0.0 else r[i, j]
            else:
                fz[i, j] *= r[i, j] if fz[i, j] > 0.0 else r[i, j - 1]


@njit(cache=True)
def limit(phi, fx, fz, dt, dx, dz, phi_max, cap, periodic, max_passes):
    """The passes of ``limit_to_upper_bound`` on ``fx``, ``fz`` in place."""
    nx, nz = phi.shape
    excess = np.empty((nx, nz))
    r = np.empty((nx, nz))
    cx, cz = dt / dx, dt / dz
    for _ in range(max_passes):
        stage(phi, fx, fz, dt, dx, dz, excess)
        any_over = False
        for i in range(nx):
            for j in range(nz):
                excess[i, j] = excess[i, j] - phi_max
                if excess[i, j] > cap - phi_max:
                    any_over = True
        if not any_over:
            break
        for i in range(nx):
            for j in range(nz):
                e = excess[i, j]
                if e > cap - phi_max:
                    inflow = (cx * (max(fx[i, j], 0.0) + max(-fx[i + 1, j], 0.0))
                              + cz * (max(fz[i, j], 0.0) + max(-fz[i, j + 1], 0.0)))
                    r[i, j] = 1.0 - (e / inflow if inflow > e else 1.0)
                else:
                    r[i, j] = 1.0
        scale_fluxes(fx, fz, r, periodic, False)


@njit(cache=True)
def advect(phi, u, w, dt, dx, dz, phi_max, bounded, cap, periodic, max_passes):
    """One SSP-RK2 step of d_t phi + div(phi u) = 0 (paper eq. syst1b) with frozen face
    velocities ``u`` (nx+1, nz), ``w`` (nx, nz+1) [m s^-1], ``phi`` [-], ``dt`` [s], ``dx``, ``dz``
    [m]; the flux limiter keeps ``phi <= phi_max`` if ``bounded``. Returns the new phi, the
    time-averaged fluxes [m s^-1] and the held-back volume [m^2] (``transport.advect_numpy``)."""
    nx, nz = phi.shape
    fx0 = np.zeros((nx + 1, nz))
    fz0 = np.zeros((nx, nz + 1))
    fluxes(phi, u, w, periodic, fx0, fz0)
    held = 0.0
    ncol = nx if periodic else nx + 1
    if bounded:
        gx, gz = fx0.copy(), fz0.copy()
        limit(phi, fx0, fz0, dt, dx, dz, phi_max, cap, periodic, max_passes)
        held += HALF * dt * (dz * np.sum(np.abs(gx[:ncol] - fx0[:ncol])) + dx * np.sum(np.abs(gz - fz0)))
    phi1 = np.empty((nx, nz))
    stage(phi, fx0, fz0, dt, dx, dz, phi1)
    fx1 = np.zeros((nx + 1, nz))
    fz1 = np.zeros((nx, nz + 1))
    fluxes(phi1, u, w, periodic, fx1, fz1)
    if bounded:
        gx, gz = fx1.copy(), fz1.copy()
        limit(phi1, fx1, fz1, dt, dx, dz, phi_max, cap, periodic, max_passes)
        held += HALF * dt * (dz * np.sum(np.abs(gx[:ncol] - fx1[:ncol])) + dx * np.sum(np.abs(gz - fz1)))
    fx = HALF * (fx0 + fx1)
    fz = HALF * (fz0 + fz1)
    out = np.empty((nx, nz))
    stage(phi, fx, fz, dt, dx, dz, out)
    return out, fx, fz, held
