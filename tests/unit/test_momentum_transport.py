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


@pytest.mark.parametrize("theta", [mt.MINMOD_THETA, 1.3, mt.MC_THETA])
def test_limited_slope_is_the_generalised_minmod(theta):
    """``_limited`` against the textbook definition written out case by case (van Leer 1979):
    0 at an extremum, else the smallest in magnitude of theta a, (a + b)/2, theta b; theta = 1 is
    minmod(a, b), theta = 2 the monotonized-central slope."""
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=500), rng.normal(size=500)
    a[:20] = 0.0
    ref = np.array([0.0 if x * y <= 0 else min((theta * x, 0.5 * (x + y), theta * y), key=abs)
                    for x, y in zip(a, b)])
    assert np.array_equal(mt._limited(a, b, theta), ref)
    if theta == mt.MINMOD_THETA:
        mm = np.where(a * b > 0, np.sign(a) * np.minimum(np.abs(a), np.abs(b)), 0.0)
        assert np.array_equal(mt._limited(a, b, theta), mm)


def _carry_step_and_spike(theta: float, steps: int = 100):
    """A velocity step and a spike carried by a uniform solid flux 0.5 m/s in a channel periodic
    in x at CFL 0.4 (``u^{n+1} = u^n - dt A / phi``, phi = 0.5): (initial, final) velocities."""
    g = Grid(nx=40, nz=2, Lx=1.0, Lz=0.05, periodic_x=True)
    u = np.zeros(g.xface_shape)
    u[5:15] = 1.0
    u[25] = 2.0
    u[-1] = u[0]
    fx, fz = np.full(g.xface_shape, 0.5), np.zeros(g.zface_shape)
    dt = 0.4 * g.dx
    vel0 = g.pack_velocity(u, np.zeros(g.zface_shape))
    vel = vel0
    for _ in range(steps):
        vel = vel - dt * mt.momentum_flux_divergence(g, fx, fz, vel, theta=theta) / 0.5
    return vel0, vel


@pytest.mark.parametrize("theta", [mt.MINMOD_THETA, 1.3, mt.MC_THETA])
def test_limited_face_values_create_no_new_extrema(theta):
    """TVD for 1 <= theta <= 2: the step and the spike stay within their initial bounds."""
    vel0, vel = _carry_step_and_spike(theta)
    assert vel.min() >= vel0.min() - 1e-12 and vel.max() <= vel0.max() + 1e-12


def test_less_limited_slopes_dissipate_less():
    """The kinetic energy left after the 100 steps grows with theta (minmod < 1.3 < MC): the
    reason for the MC default (validation/energy)."""
    energy = [float(v @ v) for v in (_carry_step_and_spike(t)[1] for t in (1.0, 1.3, 2.0))]
    assert energy[0] < energy[1] < energy[2]


def test_model_and_case_refuse_a_theta_outside_the_tvd_range():
    from granflow.config import CaseConfig
    from granflow.errors import GranflowInputError
    from granflow.model import Model
    from granflow.rheology import make_closure

    g = Grid(nx=4, nz=4, Lx=0.1, Lz=0.1)
    with pytest.raises(GranflowInputError, match="momentum_theta"):
        Model(g, make_closure("drucker_prager"), momentum_theta=2.5)
    with pytest.raises(Exception, match="momentum_theta"):
        CaseConfig.from_dict({"case": {"name": "column_collapse"}, "numerics": {"momentum_theta": 0.5}})
