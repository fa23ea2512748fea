"""The Numba function of :mod:`granflow.physics.momentum_kernel` (imported on first use, so that
``import granflow`` does not import Numba; module-level so that ``cache=True`` can store it).
It mirrors :func:`granflow.physics.momentum_transport._divergence_numpy` face by face, with the
same floating-point operations in the same order."""
from __future__ import annotations

import numpy as np
from numba import njit

HALF = 0.5


@njit(cache=True)
def _limited(a, b, theta):
    """``momentum_transport._limited`` of two numbers."""
    if a * b > 0.0:
        mag = min(min(theta * abs(a), theta * abs(b)), HALF * abs(a + b))
        return mag if a > 0.0 else -mag
    return 0.0


@njit(cache=True)
def _upwind(flux, lo, hi, s_lo, s_hi, second_order):
    """``momentum_transport._upwind`` of one dual face."""
    if flux > 0.0:
        return lo + HALF * s_lo if second_order else lo
    return hi - HALF * s_hi if second_order else hi


@njit(cache=True)
def _slope(q, i, j, axis, periodic, theta):
    """``momentum_transport._slopes(q, axis, periodic, theta)[i, j]``."""
    n = q.shape[axis]
    if axis == 0:
        if periodic:
            return _limited(q[i, j] - q[(i - 1) % n, j], q[(i + 1) % n, j] - q[i, j], theta)
        a = q[i, j] - q[i - 1, j] if i > 0 else 0.0
        b = q[i + 1, j] - q[i, j] if i < n - 1 else 0.0
        return _limited(a, b, theta)
    if periodic:
        return _limited(q[i, j] - q[i, (j - 1) % n], q[i, (j + 1) % n] - q[i, j], theta)
    a = q[i, j] - q[i, j - 1] if j > 0 else 0.0
    b = q[i, j + 1] - q[i, j] if j < n - 1 else 0.0
    return _limited(a, b, theta)


@njit(cache=True)
def _slopes(q, axis, periodic, theta, second_order):
    """``momentum_transport._slopes(q, axis, periodic, theta)`` (zeros for first-order values,
    which do not use them)."""
    n0, n1 = q.shape
    s = np.zeros((n0, n1))
    if second_order:
        for i in range(n0):
            for j in range(n1):
                s[i, j] = _slope(q, i, j, axis, periodic, theta)
    return s


@njit(cache=True)
def divergence(u, w, fx, fz, dx, dz, per, second_order, theta):
    """``(a_u, b)`` of ``momentum_transport._divergence_numpy`` (same arguments; ``u``, ``fx``
    ``(n+1, m)``, ``w``, ``fz`` ``(n, m+1)``)."""
    n = w.shape[0]
    m = u.shape[1]
    nu = n if per else n - 1                    # x-momentum rows (interior x-faces)
    off = 0 if per else 1                       # column of u of x-momentum row 0
    uu = u[:n] if per else u[:n + 1]            # periodic: the last x-face repeats the first
    # --- x-momentum, along x: dual faces at the cell centres ---------------------------------
    su = _slopes(uu, 0, per, theta, second_order)
    gx = np.empty((n, m))
    for i in range(n):
        ip = (i + 1) % n if per else i + 1
        for j in range(m):
            f = HALF * (fx[i, j] + fx[ip, j])
            gx[i, j] = f * _upwind(f, uu[i, j], uu[ip, j], su[i, j], su[ip, j], second_order)
    # --- x-momentum, along z: dual faces at the interior nodes -------------------------------
    uc = uu[off:off + nu]
    suz = _slopes(uc, 1, False, theta, second_order)
    gz = np.zeros((nu, m + 1))                  # padded: columns 0 and m are the walls
    for k in range(nu):
        kl = (k - 1) % n if per else k          # cells left and right of the x-face of row k
        kr = k if per else k + 1
        for j in range(1, m):
            f = HALF * (fz[kl, j] + fz[kr, j])
            gz[k, j] = f * _upwind(f, uc[k, j - 1], uc[k, j], suz[k, j - 1], suz[k, j], second_order)
    a_u = np.empty((nu, m))
    for k in range(nu):
        kx = k if per else k + 1
        km = (k - 1) % n if per else k
        for j in range(m):
            a_u[k, j] = (gx[kx, j] - gx[km, j]) / dx + (gz[k, j + 1] - gz[k, j]) / dz
    # --- z-momentum, along z: dual faces at the cell centres ---------------------------------
    swz = _slopes(w, 1, False, theta, second_order)
    gzw = np.empty((n, m))
    for i in range(n):
        for j in range(m):
            f = HALF * (fz[i, j] + fz[i, j + 1])
            gzw[i, j] = f * _upwind(f, w[i, j], w[i, j + 1], swz[i, j], swz[i, j + 1], second_order)
    # --- z-momentum, along x: dual faces at the x-faces --------------------------------------
    wi = w[:, 1:m]
    swx = _slopes(wi, 0, per, theta, second_order)
    gxw = np.zeros((n + 1, m - 1))              # x-face k; walls (non-periodic) carry no flux
    for k in range(0 if per else 1, n):
        kl = (k - 1) % n if per else k - 1
        for j in range(m - 1):
            f = HALF * (fx[k, j] + fx[k, j + 1])
            gxw[k, j] = f * _upwind(f, wi[kl, j], wi[k, j], swx[kl, j], swx[k, j], second_order)
    b = np.empty((n, m - 1))
    for i in range(n):
        ip = (i + 1) % n if per else i + 1
        for j in range(m - 1):
            b[i, j] = (gxw[ip, j] - gxw[i, j]) / dx + (gzw[i, j + 1] - gzw[i, j]) / dz
    return a_u, b


@njit(cache=True)
def dual_mass_divergence(fx, fz, dx, dz, per):
    """``momentum_transport.dual_mass_divergence``: ``cell_to_face @ flux_divergence(fx, fz)``, the
    mean of the two cells' divergences either side of each velocity unknown, in the unknowns'
    order (interior x-faces, then interior z-faces, each C-ordered)."""
    n, m = fz.shape[0], fx.shape[1]
    d = np.empty((n, m))
    for i in range(n):
        for j in range(m):
            d[i, j] = (fx[i + 1, j] - fx[i, j]) / dx + (fz[i, j + 1] - fz[i, j]) / dz
    nu = n if per else n - 1
    off = 0 if per else 1
    out = np.empty(nu * m + n * (m - 1))
    for k in range(nu):
        right = k + off
        left = (right - 1) % n
        for j in range(m):
            out[k * m + j] = HALF * d[left, j] + HALF * d[right, j]
    base = nu * m
    for i in range(n):
        for j in range(m - 1):
            out[base + i * (m - 1) + j] = HALF * d[i, j] + HALF * d[i, j + 1]
    return out
