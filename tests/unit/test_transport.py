"""phi transport (paper eq. syst1b): MUSCL-minmod + SSP-RK2 (granflow.physics.transport).

References are independent: exact translated profiles (closed form), sums written here, the
discrete potential energy computed from the transported field.
"""
from __future__ import annotations

import numpy as np
import pytest

from granflow.grid import Grid
from granflow.physics.transport import (
    POSITIVITY_CFL,
    advect,
    cfl_number,
    clip_to_bounds,
    flux_face_fraction,
    stable_dt,
)

RNG_SEED = 20240607
PHI_MAX = 0.6


def random_velocity(g: Grid, rng) -> np.ndarray:
    """A strongly divergent random field: every interior face value uniform in [-1, 1] m/s."""
    return rng.uniform(-1.0, 1.0, g.n_unknowns)


def test_mass_is_conserved_to_round_off_and_phi_stays_non_negative():
    rng = np.random.default_rng(RNG_SEED)
    g = Grid(nx=24, nz=17, Lx=0.24, Lz=0.17)
    phi = rng.uniform(0.0, PHI_MAX, g.cell_shape)
    phi[rng.uniform(size=g.cell_shape) < 0.3] = 0.0  # empty cells next to full ones
    m0 = phi.sum()
    for _ in range(40):
        vel = random_velocity(g, rng)
        dt = stable_dt(g, vel, POSITIVITY_CFL)  # at the positivity limit
        assert np.isclose(cfl_number(g, vel, dt), POSITIVITY_CFL, rtol=1e-12)
        phi = advect(g, phi, vel, dt).phi
        assert phi.min() >= -1e-15, "positivity lost at CFL 1/2"
    # 40 steps of 2 stages: round-off only (|phi| <= O(1), 408 cells).
    assert abs(phi.sum() - m0) <= 1e-12 * m0


def test_positivity_limit_is_not_vacuous():
    """Above the stated CFL limit the same random fields do produce negative phi."""
    rng = np.random.default_rng(RNG_SEED)
    g = Grid(nx=24, nz=17, Lx=0.24, Lz=0.17)
    phi = rng.uniform(0.0, PHI_MAX, g.cell_shape)
    phi[rng.uniform(size=g.cell_shape) < 0.3] = 0.0
    worst = 0.0
    for _ in range(10):
        vel = random_velocity(g, rng)
        worst = min(worst, float(advect(g, phi, vel, stable_dt(g, vel, 4 * POSITIVITY_CFL)).phi.min()))
    assert worst < -1e-3


def test_cfl_number_closed_form():
    g = Grid(nx=4, nz=3, Lx=0.4, Lz=0.6)  # dx = 0.1, dz = 0.2
    u = np.zeros(g.xface_shape)
    w = np.zeros(g.zface_shape)
    u[2, 1] = -2.0    # cells (1,1) and (2,1)
    w[2, 2] = 3.0     # cells (2,1) and (2,2)
    vel = g.pack_velocity(u, w)
    # cell (2,1): 2/0.1 + 3/0.2 = 35 s^-1
    assert np.isclose(cfl_number(g, vel, 0.01), 0.35, rtol=1e-14)
    assert np.isclose(stable_dt(g, vel, 0.35), 0.01, rtol=1e-14)
    assert stable_dt(g, np.zeros(g.n_unknowns), 0.3) == np.inf


def _bump(x, centre, radius):
    """cos^4 bump of compact support (C^3), peak 1 at ``centre``."""
    s = np.clip(np.abs(x - centre) / radius, 0.0, 1.0)
    return np.where(s < 1.0, np.cos(0.5 * np.pi * s) ** 4, 0.0)


@pytest.mark.parametrize("axis", [0, 1])
def test_second_order_on_a_translated_smooth_profile(axis):
    """L1 error of a translated cos^4 bump (exact solution: the shifted profile).

    Observed orders (stated): ~1.5-1.7 globally (minmod clips the slope at the peak, a
    first-order region of shrinking width), -> 2 away from the extremum (1.66, 1.84, 1.91 on
    50 -> 400 cells). Asserted: global order > 1.35 on every refinement and > 1.8 away from the
    peak on the finest pair; first-order upwind would give ~1.
    """
    U, T, centre, radius, amp = 1.0, 0.3, 0.3, 0.15, 0.5
    errs, errs_away = [], []
    for n in (50, 100, 200, 400):
        thin = 2.0 / n
        g = Grid(nx=n, nz=2, Lx=1.0, Lz=thin) if axis == 0 else Grid(nx=2, nz=n, Lx=thin, Lz=1.0)
        u, w = np.zeros(g.xface_shape), np.zeros(g.zface_shape)
        if axis == 0:
            u[1:-1, :] = U
        else:
            w[:, 1:-1] = U
        vel = g.pack_velocity(u, w)
        x = g.xc if axis == 0 else g.zc
        h = 1.0 / n
        steps = int(round(T / (0.25 * h)))
        dt = T / steps
        prof = amp * _bump(x, centre, radius)
        phi = np.repeat(prof[:, None], 2, axis=1) if axis == 0 else np.repeat(prof[None, :], 2, axis=0)
        for _ in range(steps):
            phi = advect(g, phi, vel, dt).phi
        num = phi[:, 0] if axis == 0 else phi[0, :]
        err = np.abs(num - amp * _bump(x, centre + U * T, radius))
        errs.append(err.sum() * h)
        away = np.abs(x - (centre + U * T)) > 0.05
        errs_away.append(err[away].sum() * h)
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    orders_away = np.log2(np.array(errs_away[:-1]) / np.array(errs_away[1:]))
    assert np.all(orders > 1.35), orders
    assert orders_away[-1] > 1.8, orders_away


def test_clipping_report():
    g = Grid(nx=3, nz=2, Lx=0.3, Lz=0.2)
    phi = np.array([[0.62, 0.6], [-0.01, 0.3], [0.65, 0.0]])
    out, rep = clip_to_bounds(phi, PHI_MAX, g.cell_volume)
    assert out.max() == PHI_MAX and out.min() == 0.0
    assert np.isclose(rep.clipped_mass, (0.02 + 0.05) * 0.01, rtol=1e-12)
    assert np.isclose(rep.added_mass, 0.01 * 0.01, rtol=1e-12)
    assert rep.max_before == 0.65 and rep.min_before == -0.01 and rep.n_clipped == 3


def test_flux_face_fraction_makes_gravity_work_equal_the_potential_energy_change():
    """sum_f phi_f* rho_s g_f u_f dV dt == -(E_p^{n+1} - E_p^n) for fast faces (energy-consistent
    gravity), with E_p computed directly from the transported field."""
    rng = np.random.default_rng(RNG_SEED + 1)
    g = Grid(nx=12, nz=10, Lx=0.12, Lz=0.1)
    phi = rng.uniform(0.0, PHI_MAX, g.cell_shape)
    vel = rng.uniform(-1.0, 1.0, g.n_unknowns)
    vel[np.abs(vel) < 0.05] = 0.05  # every face faster than u_ref
    dt = stable_dt(g, vel, 0.3)
    gx, gz, rho_s = 2.0, -9.81, 2500.0
    phi_f = flux_face_fraction(g, phi, vel, dt, u_ref=1e-3)
    gvec = np.r_[np.full(g.n_u, gx), np.full(g.n_w, gz)]
    work = float(np.sum(phi_f * rho_s * gvec * vel)) * g.cell_volume * dt
    X, Z = g.cell_coords()
    new = advect(g, phi, vel, dt).phi
    e_p = lambda f: -rho_s * g.cell_volume * float(np.sum(f * (gx * X + gz * Z)))  # noqa: E731
    assert np.isclose(work, -(e_p(new) - e_p(phi)), rtol=1e-12, atol=1e-14)


def test_flux_face_fraction_at_rest_is_the_centred_mean():
    g = Grid(nx=3, nz=3, Lx=0.3, Lz=0.3)
    phi = np.arange(9.0).reshape(3, 3) / 10
    f = flux_face_fraction(g, phi, np.zeros(g.n_unknowns), 1e-3, u_ref=1e-3)
    u_faces = 0.5 * (phi[:-1, :] + phi[1:, :])
    w_faces = 0.5 * (phi[:, :-1] + phi[:, 1:])
    assert np.allclose(f, np.r_[u_faces.ravel(), w_faces.ravel()], rtol=0, atol=1e-15)


@pytest.mark.parametrize("periodic", [False, True])
def test_upper_bound_limiter_keeps_phi_max_conserves_mass_and_positivity(periodic):
    """Random strongly divergent fields on a packed random field: without ``phi_max`` the
    transport overshoots phi_max (the check is not vacuous); with it, every step stays within
    [0, phi_max] (to 1e-12 relative), the mass is conserved to round-off and the held-back
    volume is reported (> 0)."""
    rng = np.random.default_rng(RNG_SEED + 1)
    g = Grid(nx=20, nz=12, Lx=0.2, Lz=0.12, periodic_x=periodic)
    phi0 = rng.uniform(0.45, PHI_MAX, g.cell_shape)
    phi0[rng.uniform(size=g.cell_shape) < 0.2] = 0.0
    free_max, phi, held = 0.0, phi0.copy(), 0.0
    for _ in range(30):
        vel = random_velocity(g, rng)
        dt = stable_dt(g, vel, POSITIVITY_CFL)
        free_max = max(free_max, float(advect(g, phi, vel, dt).phi.max()))
        out = advect(g, phi, vel, dt, PHI_MAX)
        phi, held = out.phi, held + out.held_back
        assert phi.max() <= PHI_MAX * (1 + 1e-12) and phi.min() >= -1e-15
    assert free_max > PHI_MAX * 1.05  # unlimited transport of the same fields overshoots
    assert held > 0.0
    assert abs(phi.sum() - phi0.sum()) <= 1e-12 * phi0.sum()


def test_upper_bound_limiter_is_inactive_below_the_bound():
    """A translation of a profile below phi_max: the limited and unlimited steps are identical."""
    g = Grid(nx=16, nz=4, Lx=1.0, Lz=0.25)
    X, _ = g.cell_coords()
    phi = 0.5 * np.exp(-((X - 0.4) / 0.1) ** 2)
    u = np.zeros(g.xface_shape)
    u[1:-1] = 1.0
    vel = g.pack_velocity(u, np.zeros(g.zface_shape))
    free, lim = advect(g, phi, vel, 0.02), advect(g, phi, vel, 0.02, PHI_MAX)
    assert np.array_equal(free.phi, lim.phi) and lim.held_back == 0.0


def test_upper_bound_limiter_settles_a_long_chain_of_full_cells():
    """A column of 150 full cells pushed onto the base (w = -1 everywhere inside): each limiter
    pass settles one more donor, so the pass cap must grow with the grid (review finding: with a
    fixed 100 passes two cells stayed 10 % above phi_max)."""
    g = Grid(nx=2, nz=150, Lx=0.02, Lz=1.5)
    phi = np.full(g.cell_shape, PHI_MAX)
    w = np.zeros(g.zface_shape)
    w[:, 1:-1] = -1.0
    vel = g.pack_velocity(np.zeros(g.xface_shape), w)
    out = advect(g, phi, vel, 0.2 * g.dz, PHI_MAX)
    assert out.phi.max() <= PHI_MAX * (1 + 1e-12)
    assert abs(out.phi.sum() - phi.sum()) <= 1e-12 * phi.sum()
