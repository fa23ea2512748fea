"""Compiled (Numba) kernel of the energy-consistent gravity weight of a step, the tail of
:meth:`granflow.model_gravity.GravityWeights.gravity_split` (NUMERICS.md §9).

The same operations as the NumPy reference :func:`granflow.model_gravity.gravity_weights_numpy`
(the upwind flux fraction ``F/u`` of the moving faces, its blend with the centred fraction below
the blend velocity ``u_b``, the drag rate and the choice of the implicit faces), written as one
loop over the velocity unknowns with the same floating-point operations in the same order, so
the force and the drag agree bit for bit (tests/unit/test_gravity_kernel.py). Why: in NumPy the
tail makes about 15 whole-array temporaries, 4.2 ms a call at 256^2 (130 560 unknowns, one call a
step; timeit, best of 7, on the shared 2-core host); the loop makes only the two returned arrays,
0.07 ms.

Numba is imported on first use (``import granflow`` stays light); the compiled function is cached
on disk (``cache=True``).
"""
from __future__ import annotations

import numpy as np

from granflow.physics.lazy_kernel import LazyKernel

_KERNEL = LazyKernel("granflow.physics._gravity_numba", "gravity_weights")


def kernel_available() -> bool:
    """True if Numba imports (the compiled kernel is then used by ``gravity_split``); asked once."""
    return _KERNEL.available()


def gravity_weights_compiled(centred, flux, vel, gx: float, gz: float, n_u: int, rho_s: float,
                             u_b: float) -> tuple[np.ndarray, np.ndarray]:
    """``(force, drag)`` of ``model_gravity.gravity_weights_numpy`` with the gravity vector
    ``gx`` on the first ``n_u`` unknowns (the u faces) and ``gz`` on the others."""
    def f64(a):
        return np.ascontiguousarray(a, dtype=np.float64).ravel()

    centred, flux, vel = f64(centred), f64(flux), f64(vel)
    if not centred.size == flux.size == vel.size or not 0 <= n_u <= vel.size:  # unchecked in the kernel
        raise ValueError(f"gravity weights: arrays of {centred.size}, {flux.size}, {vel.size} unknowns, "
                         f"n_u = {n_u}")
    return _KERNEL.get()(centred, flux, vel, float(gx), float(gz), int(n_u),
                         float(rho_s), float(u_b))
