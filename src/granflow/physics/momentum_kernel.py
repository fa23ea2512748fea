"""Compiled (Numba) kernel of the momentum flux divergence of the consistent transport (scheme v2,
issue 12), :func:`granflow.physics.momentum_transport._divergence`, and of the dual-cell mass
divergence :func:`granflow.physics.momentum_transport.dual_mass_divergence`.

The same scheme as the NumPy reference
:func:`granflow.physics.momentum_transport._divergence_numpy` (module docstring there: the dual
mass fluxes, the upwind MUSCL face values with the generalised minmod slope) written as loops over
the dual faces, with the same floating-point operations in the same order, so the two agree bit
for bit (tests/unit/test_momentum_kernel.py). Why: the consistent transport evaluates it at every Picard
sweep; in NumPy (about 30 whole-array temporaries per call) it was ~6 % of the Lagree column's v2
CPU time at 128^2 (benchmarks/README.md).

Numba is imported on first use (``import granflow`` stays light); the compiled function is cached
on disk (``cache=True``).
"""
from __future__ import annotations

import numpy as np

from granflow.physics.lazy_kernel import LazyKernel

_KERNEL = LazyKernel("granflow.physics._momentum_numba", "divergence")
_DUAL = LazyKernel("granflow.physics._momentum_numba", "dual_mass_divergence")


def kernel_available() -> bool:
    """True if Numba imports (the compiled kernel is then used); asked once."""
    return _KERNEL.available()


def divergence_compiled(u, w, fx, fz, dx: float, dz: float, per: bool, second_order: bool,
                        theta: float):
    """``(a_u, b)`` of ``momentum_transport._divergence_numpy`` (same arguments and result)."""
    def f64(a):
        return np.ascontiguousarray(a, dtype=np.float64)

    return _KERNEL.get()(f64(u), f64(w), f64(fx), f64(fz), float(dx), float(dz), bool(per),
                         bool(second_order), float(theta))


def dual_mass_divergence_compiled(fx, fz, dx: float, dz: float, per: bool) -> np.ndarray:
    """``momentum_transport.dual_mass_divergence`` (``cell_to_face @ flux_divergence``)."""
    return _DUAL.get()(np.ascontiguousarray(fx, dtype=np.float64),
                       np.ascontiguousarray(fz, dtype=np.float64), float(dx), float(dz), bool(per))
