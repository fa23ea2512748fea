"""Compiled (Numba) kernel of the fluxes of one stage of the material-indicator transport (scheme
v2, issue 12), :func:`granflow.physics.material._fluxes`.

The same scheme as the NumPy reference :func:`granflow.physics.material._fluxes_numpy`: the
donor-acceptor volume fluxes (Hirt & Nichols 1981 with Youngs' normal), the overfill correction of
partial cells, the outflow limiter for ``c >= 0``, the upwind MUSCL-minmod packing fluxes
``psi_f F_c`` (slopes between material cells), the outflow limiter for ``phi >= 0`` and the
upper-bound limiter for ``phi <= phi_max`` -- written as loops over faces and cells with the same
floating-point operations in the same order, so the fluxes agree bit for bit
(tests/unit/test_material_kernel.py). Why: the consistent momentum transport needs the solid fluxes at
every Picard sweep (:func:`granflow.physics.material.material_solid_fluxes`); in NumPy they were
~8 % of the Lagree column's v2 CPU time at 128^2 (benchmarks/README.md).

Numba is imported on first use (``import granflow`` stays light); compiled functions are cached
on disk (``cache=True``).
"""
from __future__ import annotations

import numpy as np

from granflow.physics.lazy_kernel import LazyKernel

_KERNEL = LazyKernel("granflow.physics._material_numba", "fluxes")


def kernel_available() -> bool:
    """True if Numba imports (the compiled kernel is then used by ``material._fluxes``); asked once."""
    return _KERNEL.available()


def fluxes_compiled(c: np.ndarray, phi: np.ndarray, u: np.ndarray, w: np.ndarray, dt: float,
                    dx: float, dz: float, phi_max: float, cap: float, c_min: float, periodic: bool,
                    max_passes: int, c_rec: np.ndarray | None = None):
    """``((fcx, fcz), (gx, gz), held)`` of one stage (see ``material._fluxes_numpy``; ``c_rec`` the
    field the volume fluxes' reconstruction reads, default ``c``)."""
    def f64(a):
        return np.ascontiguousarray(a, dtype=np.float64)

    fcx, fcz, gx, gz, held = _KERNEL.get()(f64(c), f64(c if c_rec is None else c_rec), f64(phi), f64(u), f64(w), float(dt), float(dx),
                                        float(dz), float(phi_max), float(cap), float(c_min),
                                        bool(periodic), int(max_passes))
    return (fcx, fcz), (gx, gz), float(held)
