"""Compiled (Numba) kernel of one transport step, :func:`granflow.physics.transport.advect`.

The same scheme as the NumPy reference :func:`granflow.physics.transport.advect_numpy` (paper eq.
syst1b; MUSCL-minmod face values, SSP-RK2, the upper-bound flux limiter of
:func:`~granflow.physics.transport.limit_to_upper_bound` in each stage), written as loops over
faces and cells with the same floating-point operations in the same order, so the two agree to
round-off (tests/unit/test_transport_kernel.py: identical fields on the cases tested). Why: at the
Lagree column's 128^2 the NumPy step took 1.7 ms (two per time step, one for the
energy-consistent gravity weight), 10-15 % of the whole step once the linear systems were cut to
the velocity band; the kernel takes ~0.2 ms (benchmarks/README.md).

Numba is imported on first use (``import granflow`` stays light); compiled functions are cached
on disk (``cache=True``).
"""
from __future__ import annotations

import numpy as np

from granflow.physics.lazy_kernel import LazyKernel

_KERNEL = LazyKernel("granflow.physics._transport_numba", "advect")


def kernel_available() -> bool:
    """True if Numba imports (the compiled kernel is then used by ``advect``); asked once."""
    return _KERNEL.available()


def advect_compiled(phi: np.ndarray, u: np.ndarray, w: np.ndarray, dt: float, dx: float, dz: float,
                    phi_max: float | None, cap: float, periodic: bool, max_passes: int):
    """``(phi_new, flux_x, flux_z, held_back)`` of one step (see ``transport.advect``)."""
    return _KERNEL.get()(np.ascontiguousarray(phi, dtype=np.float64), np.ascontiguousarray(u, dtype=np.float64),
                      np.ascontiguousarray(w, dtype=np.float64), float(dt), float(dx), float(dz),
                      0.0 if phi_max is None else float(phi_max), phi_max is not None, float(cap),
                      bool(periodic), int(max_passes))
