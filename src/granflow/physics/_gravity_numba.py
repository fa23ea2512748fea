"""The Numba function of :mod:`granflow.physics.gravity_kernel` (imported on first use, so that
``import granflow`` does not import Numba; module-level so that ``cache=True`` can store it).
It mirrors :func:`granflow.model_gravity.gravity_weights_numpy` with the same floating-point
operations in the same order."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _sign(v):
    """``np.sign`` of one value (NaN stays NaN)."""
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return v * 0.0 if v != v else 0.0


@njit(cache=True)
def gravity_weights(centred, flux, vel, gx, gz, n_u, rho_s, u_b):
    """``(force, drag)`` of ``gravity_weights_numpy`` with ``gvec = gx`` on the first ``n_u``
    unknowns and ``gz`` on the rest, in one pass over the unknowns."""
    n = vel.size
    force = np.empty(n)
    drag_out = np.empty(n)
    for k in range(n):
        v = vel[k]
        cen = centred[k]
        gk = gx if k < n_u else gz
        upwind = flux[k] / v if v != 0.0 else cen
        a = abs(v)
        r = a / u_b
        if not r >= 1.0:  # np.minimum(1.0, r): NaN propagates
            blend = r
        else:
            blend = 1.0
        d_up = upwind - cen
        phi_f = cen + d_up * blend
        drag = -rho_s * gk * d_up * _sign(v) / u_b
        if a < u_b and drag > 0.0:
            force[k] = rho_s * gk * cen
            drag_out[k] = drag
        else:
            force[k] = rho_s * gk * phi_f
            drag_out[k] = 0.0
    return force, drag_out
