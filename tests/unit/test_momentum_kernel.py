"""The compiled momentum flux divergence (granflow.physics.momentum_kernel, Numba) against its
NumPy reference (momentum_transport._divergence_numpy): same scheme, same floating-point operations
in the same order, so ``A`` must be identical (asserted with np.array_equal) -- on random face
fluxes and velocities, walls and periodic in x, MUSCL and first-order face values, the minmod,
Basilisk's minmod2 and the MC slopes, whole grid and material window."""
from __future__ import annotations

import numpy as np
import pytest

import granflow.physics.momentum_transport as mt
from granflow.grid import Grid
from granflow.physics.momentum_kernel import kernel_available

pytestmark = pytest.mark.skipif(not kernel_available(), reason="Numba not installed")

THETAS = (mt.MINMOD_THETA, 1.3, mt.MC_THETA)


def random_fields(rng, g: Grid):
    """Velocities and solid fluxes with zeros on the walls (and fx[nx] = fx[0] if periodic),
    a quarter of the fluxes exactly zero (the ``flux > 0`` branch at 0)."""
    nx, nz = g.cell_shape
    fx = rng.normal(size=(nx + 1, nz))
    fz = rng.normal(size=(nx, nz + 1))
    fx[rng.random(fx.shape) < 0.25] = 0.0
    fz[rng.random(fz.shape) < 0.25] = 0.0
    fz[:, 0] = fz[:, -1] = 0.0
    if g.periodic_x:
        fx[-1] = fx[0]
    else:
        fx[0] = fx[-1] = 0.0
    return rng.normal(size=g.n_unknowns), fx, fz


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("second_order", [True, False])
@pytest.mark.parametrize("theta", THETAS)
def test_compiled_divergence_equals_numpy(periodic, second_order, theta):
    rng = np.random.default_rng(7)
    for nx, nz in ((2, 2), (5, 3), (17, 11)):
        g = Grid(nx, nz, Lx=nx * 0.1, Lz=nz * 0.07, periodic_x=periodic)
        vel, fx, fz = random_fields(rng, g)
        u, w = g.unpack_velocity(vel)
        args = (u, w, fx, fz, g.dx, g.dz, periodic, second_order, theta)
        a_c, b_c = mt._divergence(*args)
        a_n, b_n = mt._divergence_numpy(*args)
        assert a_c.shape == a_n.shape and b_c.shape == b_n.shape
        assert np.array_equal(a_c, a_n) and np.array_equal(b_c, b_n), (nx, nz)


def test_windowed_divergence_equals_whole_grid():
    """Fluxes that vanish outside a window with a 3-cell margin: the windowed ``A`` (the kernel on
    sub-arrays) is the whole-grid one, bit for bit, and the kernel agrees with NumPy on both."""
    rng = np.random.default_rng(3)
    g = Grid(24, 16, Lx=2.4, Lz=1.6)
    vel, fx, fz = random_fields(rng, g)
    xs, zs = slice(5, 15), slice(0, 9)
    mask_x = np.zeros_like(fx, dtype=bool)
    mask_x[xs.start + 3:xs.stop - 3 + 1, zs.start:zs.stop - 3] = True
    mask_z = np.zeros_like(fz, dtype=bool)
    mask_z[xs.start + 3:xs.stop - 3, zs.start:zs.stop - 3 + 1] = True
    fx, fz = np.where(mask_x, fx, 0.0), np.where(mask_z, fz, 0.0)
    whole = mt.momentum_flux_divergence(g, fx, fz, vel)
    windowed = mt.momentum_flux_divergence(g, fx, fz, vel, window=(xs, zs))
    assert np.any(whole != 0.0)
    assert np.array_equal(whole, windowed)
    u, w = g.unpack_velocity(vel)
    ref = np.concatenate([x.ravel() for x in mt._divergence_numpy(u, w, fx, fz, g.dx, g.dz, False,
                                                                   True, mt.MC_THETA)])
    assert np.array_equal(whole, ref)


@pytest.mark.parametrize("periodic", [False, True])
def test_compiled_dual_mass_divergence_equals_sparse_product(periodic):
    """``div_dual F`` of the kernel is ``cell_to_face @ flux_divergence`` bit for bit."""
    from granflow.operators import Operators
    from granflow.physics.transport import flux_divergence

    rng = np.random.default_rng(11)
    for nx, nz in ((2, 2), (6, 4), (19, 13)):
        g = Grid(nx, nz, Lx=nx * 0.1, Lz=nz * 0.07, periodic_x=periodic)
        ops = Operators.build(g)
        _, fx, fz = random_fields(rng, g)
        ref = ops.cell_to_face @ flux_divergence(g, fx, fz).ravel()
        out = mt.dual_mass_divergence(ops, fx, fz)
        assert out.shape == ref.shape
        assert np.array_equal(out, ref), (nx, nz)
