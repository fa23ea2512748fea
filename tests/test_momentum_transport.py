"""Mass-consistent momentum transport (granflow.physics.momentum_transport, scheme v2).

Checks against properties that hold independently of the implementation: a uniform velocity is
translated unchanged when mass and momentum move with the same fluxes (Rudman 1998's test of
consistency); the momentum flux is conservative (telescoping sums: total x-momentum unchanged in a
channel periodic in x); the first-order energy term equals the closed form
``1/2 sum |F| (u_R - u_L)^2`` of upwinding; and the consistent Model keeps the grains' mass and
closes its kinetic-energy budget with an inertia-transport term at the Picard tolerance.
"""
from __future__ import annotations

import numpy as np
import pytest

from granflow.grid import Grid
from granflow.operators import Operators
from granflow.physics import momentum_transport as mt
from granflow.physics.transport import advect


def _random_state(grid: Grid, rng, w_zero: bool = False):
    phi = 0.6 * rng.random(grid.cell_shape)
    u = rng.normal(size=grid.xface_shape)
    w = np.zeros(grid.zface_shape) if w_zero else rng.normal(size=grid.zface_shape)
    vel = grid.pack_velocity(u, w)
    return phi, grid.unpack_velocity(vel), vel


@pytest.mark.parametrize("second_order", [True, False])
def test_uniform_velocity_is_translated_unchanged_with_consistent_mass(second_order):
    g = Grid(nx=16, nz=6, Lx=1.0, Lz=0.4, periodic_x=True)
    rng = np.random.default_rng(3)
    phi = 0.6 * rng.random(g.cell_shape)
    U = 0.7
    u = np.full(g.xface_shape, U)
    vel = g.pack_velocity(u, np.zeros(g.zface_shape))
    dt = 0.2 * g.dx / U
    moved = advect(g, phi, vel, dt, 0.6)
    ops = Operators.build(g)
    rho_s, rho_a = 2500.0, 2.0
    m_n = rho_s * (ops.cell_to_face @ phi.ravel()) + rho_a
    m_1 = rho_s * (ops.cell_to_face @ moved.phi.ravel()) + rho_a
    A = mt.momentum_flux_divergence(g, moved.flux_x, moved.flux_z, vel, second_order)
    new = (m_n * vel - dt * rho_s * A) / m_1
    u_new, w_new = g.unpack_velocity(new)
    assert np.max(np.abs(u_new - U)) < 1e-13 * U   # measured ~1e-16
    assert np.max(np.abs(w_new)) == 0.0


def test_dual_mass_update_equals_the_face_mean_of_the_transported_phi():
    g = Grid(nx=9, nz=7, Lx=0.9, Lz=0.7)
    rng = np.random.default_rng(5)
    phi, _, vel = _random_state(g, rng)
    dt = 0.05 * g.dx / np.max(np.abs(vel))
    moved = advect(g, phi, vel, dt)
    ops = Operators.build(g)
    lhs = ops.cell_to_face @ moved.phi.ravel()
    rhs = ops.cell_to_face @ phi.ravel() - dt * mt.dual_mass_divergence(ops, moved.flux_x, moved.flux_z)
    assert np.max(np.abs(lhs - rhs)) < 1e-14


@pytest.mark.parametrize("second_order", [True, False])
def test_momentum_flux_is_conservative_in_a_periodic_channel(second_order):
    g = Grid(nx=12, nz=8, Lx=1.2, Lz=0.8, periodic_x=True)
    rng = np.random.default_rng(11)
    phi, _, vel = _random_state(g, rng)
    dt = 0.05 * g.dx / np.max(np.abs(vel))
    moved = advect(g, phi, vel, dt)
    A = mt.momentum_flux_divergence(g, moved.flux_x, moved.flux_z, vel, second_order)
    a_u = A[g.u_slice]
    # x-momentum: periodic in x, no mass flux through the walls: the sum telescopes to zero
    assert abs(a_u.sum()) < 1e-12 * np.abs(a_u).sum()


@pytest.mark.parametrize("periodic", [True, False])
def test_first_order_energy_term_is_the_upwind_dissipation(periodic):
    """For u^{n+1} = u^n and first-order values each dual face contributes ``|F| (u_R - u_L)^2 / 2``
    (wall values 0): summed here face by face from the flux arrays, independently of the operator."""
    g = Grid(nx=7, nz=5, Lx=0.7, Lz=0.5, periodic_x=periodic)
    rng = np.random.default_rng(2)
    phi, (u, w), vel = _random_state(g, rng)
    dt = 0.05 * g.dx / np.max(np.abs(vel))
    moved = advect(g, phi, vel, dt)
    fx, fz = (moved.flux_x[:-1] if periodic else moved.flux_x), moved.flux_z
    ops = Operators.build(g)
    A = mt.momentum_flux_divergence(g, moved.flux_x, moved.flux_z, vel, second_order=False)
    rate = mt.advection_energy_rate(1.0, 1.0, A, mt.dual_mass_divergence(ops, moved.flux_x, moved.flux_z), vel)
    nx, nz = g.nx, g.nz
    uq = u[:-1] if periodic else u
    nf = nx if periodic else nx + 1      # distinct x-faces
    inner = range(nx) if periodic else range(1, nx)
    ref = 0.0
    for i in range(nx):          # u dual faces at cell centres (between x-faces i, i+1)
        for j in range(nz):
            F = 0.5 * (fx[i, j] + fx[(i + 1) % nf, j])
            ref += 0.5 * abs(F) * (uq[(i + 1) % nf, j] - uq[i, j]) ** 2 / g.dx
    for k in inner:              # u dual faces at interior nodes (rows j, j+1)
        for j in range(nz - 1):
            F = 0.5 * (fz[(k - 1) % nx, j + 1] + fz[k, j + 1])
            ref += 0.5 * abs(F) * (uq[k, j + 1] - uq[k, j]) ** 2 / g.dz
    for i in range(nx):          # w dual faces at cell centres (between z-faces j, j+1)
        for j in range(nz):
            F = 0.5 * (fz[i, j] + fz[i, j + 1])
            ref += 0.5 * abs(F) * (w[i, j + 1] - w[i, j]) ** 2 / g.dz
    for k in inner:              # w dual faces on x-face k (cells k-1, k), interior rows
        for j in range(1, nz):
            F = 0.5 * (fx[k, j - 1] + fx[k, j])
            ref += 0.5 * abs(F) * (w[k, j] - w[(k - 1) % nx, j]) ** 2 / g.dx
    assert rate == pytest.approx(ref, rel=1e-12)
    assert rate > 0.0


@pytest.mark.parametrize("periodic", [False, True])
def test_windowed_flux_divergence_is_the_whole_grid_one(periodic):
    """A block of material in the middle of a grid with a random velocity everywhere: its
    indicator transport's fluxes vanish beyond material_window, and momentum_flux_divergence on
    that window equals the whole-grid result bit for bit (zero outside), closed and periodic in x."""
    from granflow.physics.material import advect_material, material_window

    rng = np.random.default_rng(7)
    g = Grid(nx=40, nz=30, Lx=0.4, Lz=0.3, periodic_x=periodic)
    c = np.zeros(g.cell_shape)
    c[12:22, 3:11] = 1.0
    c[22, 3:9] = 0.4
    phi = 0.55 * c
    vel = g.pack_velocity(0.05 * rng.normal(size=g.xface_shape), 0.05 * rng.normal(size=g.zface_shape))
    moved = advect_material(g, c, phi, vel, 0.02, 0.6)
    win = material_window(g, c, phi)
    assert win is not None
    whole = mt.momentum_flux_divergence(g, moved.flux_x, moved.flux_z, vel)
    cut = mt.momentum_flux_divergence(g, moved.flux_x, moved.flux_z, vel, window=win)
    assert np.abs(whole).max() > 0
    assert np.array_equal(whole, cut)
