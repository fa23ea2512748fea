"""The compiled transport step (granflow.physics.transport_kernel, Numba) against its NumPy
reference (transport.advect_numpy): same scheme, same operations in the same order, so the
fields must agree to round-off; measured identical (0.0) on every case here, tolerance 1e-15
relative for the fields and 1e-12 for the held-back volume (a sum in another order)."""
from __future__ import annotations

import numpy as np
import pytest

from granflow.grid import Grid
from granflow.physics.transport import advect, advect_numpy, cfl_number
from granflow.physics.transport_kernel import kernel_available

pytestmark = pytest.mark.skipif(not kernel_available(), reason="Numba not installed")

PHI_MAX = 0.6
FIELD_RTOL = 1e-15
HELD_RTOL = 1e-12


def agree(grid, phi, vel, dt, phi_max):
    a = advect(grid, phi, vel, dt, phi_max)
    b = advect_numpy(grid, phi, vel, dt, phi_max)
    for x, y in ((a.phi, b.phi), (a.flux_x, b.flux_x), (a.flux_z, b.flux_z)):
        assert x.shape == y.shape
        np.testing.assert_allclose(x, y, rtol=0, atol=FIELD_RTOL * max(np.abs(y).max(), 1e-300))
    assert a.held_back == pytest.approx(b.held_back, rel=HELD_RTOL, abs=1e-300)
    return a, b


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("phi_max", [None, PHI_MAX])
@pytest.mark.parametrize("seed", range(4))
def test_random_fields_agree(periodic, phi_max, seed):
    rng = np.random.default_rng(seed)
    g = Grid(nx=int(rng.integers(3, 40)), nz=int(rng.integers(3, 30)), Lx=0.4, Lz=0.2, periodic_x=periodic)
    phi = np.clip(rng.uniform(-0.3, 0.8, g.cell_shape), 0.0, PHI_MAX)
    vel = rng.normal(0.0, 1.0, g.n_unknowns)
    dt = 0.45 / cfl_number(g, vel, 1.0)  # CFL 0.45
    a, _ = agree(g, phi, vel, dt, phi_max)
    if phi_max is not None:
        assert a.held_back > 0.0  # the limiter acted
        assert a.phi.max() <= PHI_MAX * (1 + 1e-12)


def test_converging_flow_into_a_full_column_needs_many_limiter_passes():
    """Flow converging on a wall through a chain of full cells: each limiter pass settles one
    more donor (transport.MAX_LIMITER_PASSES), the worst case for the pass loop."""
    g = Grid(nx=40, nz=4, Lx=0.4, Lz=0.04)
    phi = np.full(g.cell_shape, PHI_MAX)
    phi[:20] = 0.3
    u = np.zeros(g.xface_shape)
    u[1:-1] = 1.0  # everything moves towards the east wall
    vel = g.pack_velocity(u, np.zeros(g.zface_shape))
    a, b = agree(g, phi, vel, 0.004, PHI_MAX)
    assert a.held_back > 0.0
    assert abs(a.phi.sum() - phi.sum()) <= 1e-13 * phi.sum()  # conservative


def test_degenerate_inputs_agree():
    g = Grid(nx=5, nz=3, Lx=1.0, Lz=0.6)
    agree(g, np.zeros(g.cell_shape), np.zeros(g.n_unknowns), 0.1, PHI_MAX)  # nothing, at rest
    agree(g, np.full(g.cell_shape, PHI_MAX), np.ones(g.n_unknowns) * 0.5, 0.1, PHI_MAX)  # full box
