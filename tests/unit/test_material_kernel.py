"""The compiled fluxes of the material-indicator transport (granflow.physics.material_kernel,
Numba) against their NumPy reference (material._fluxes_numpy): same scheme, same floating-point
operations in the same order, so the volume and solid fluxes must be identical (measured: bit
for bit on every case here, asserted with np.array_equal); the held-back volume is a sum taken
in another order (pairwise in NumPy), tolerance 1e-12 relative."""
from __future__ import annotations

import numpy as np
import pytest

import granflow.physics.material as M
from granflow.grid import Grid
from granflow.physics.material_kernel import kernel_available
from granflow.physics.transport import cfl_number, face_velocities

from _kernels import kernel_and_reference_runs, lagree_collapse  # noqa: E402  (tests/ holds tiers)

pytestmark = pytest.mark.skipif(not kernel_available(), reason="Numba not installed")

PHI_MAX = 0.6
HELD_RTOL = 1e-12
CFL = 0.45
"""Below the scheme's CFL 1/2."""


def random_material(rng, g, p_empty=0.3, p_full=0.4):
    """Partial, full and empty cells, packings 0.3-0.6 inside the material."""
    c = np.where(rng.random(g.cell_shape) < p_empty, 0.0, rng.random(g.cell_shape))
    c[rng.random(g.cell_shape) < p_full] = 1.0
    return c, c * rng.uniform(0.3, PHI_MAX, g.cell_shape)


def random_velocity(rng, g):
    vel = rng.normal(0.0, 1.0, g.n_unknowns)
    return vel, CFL / cfl_number(g, vel, 1.0)


def agree(g, c, phi, vel, dt):
    """Compiled and NumPy ``_fluxes`` on the whole grid: fluxes identical, held to round-off."""
    u, w = face_velocities(g, vel)
    a = M._fluxes(g, c, phi, u, w, dt, PHI_MAX)
    b = M._fluxes_numpy(g, c, phi, u, w, dt, PHI_MAX)
    for x, y in zip(a[0] + a[1], b[0] + b[1]):
        assert x.shape == y.shape
        assert np.array_equal(x, y), np.abs(x - y).max()
    assert a[2] == pytest.approx(b[2], rel=HELD_RTOL, abs=1e-300)
    return a, b


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("seed", range(6))
def test_random_material_fields_agree(periodic, seed):
    rng = np.random.default_rng(seed)
    g = Grid(nx=int(rng.integers(3, 40)), nz=int(rng.integers(3, 30)), Lx=0.4, Lz=0.2, periodic_x=periodic)
    c, phi = random_material(rng, g)
    vel, dt = random_velocity(rng, g)
    agree(g, c, phi, vel, dt)


def test_every_limiter_acts_in_the_random_draws(monkeypatch):
    """The draws of test_random_material_fields_agree reach the overfill correction and both
    limiters (else the agreement would not cover them): counted on the NumPy reference."""
    calls = {"overfill": 0, "lower": 0, "upper": 0}
    over, lower, upper = M.overfill_correction, M.limit_to_lower_bound, M.limit_to_upper_bound

    def spy(name, f, changed):
        def wrapped(*args):
            out = f(*args)
            calls[name] += changed(args, out)
            return out
        return wrapped

    def moved(args, out, k):
        return int(any(not np.array_equal(a, b) for a, b in zip(args[k:k + 2], out[:2])))

    monkeypatch.setattr(M, "overfill_correction", spy("overfill", over, lambda a, o: moved(a, o, 2)))
    monkeypatch.setattr(M, "limit_to_lower_bound", spy("lower", lower, lambda a, o: moved(a, o, 1)))
    monkeypatch.setattr(M, "limit_to_upper_bound", spy("upper", upper, lambda a, o: int(o[2] > 0)))
    for periodic in (False, True):
        for seed in range(6):
            rng = np.random.default_rng(seed)
            g = Grid(nx=int(rng.integers(3, 40)), nz=int(rng.integers(3, 30)), Lx=0.4, Lz=0.2,
                     periodic_x=periodic)
            c, phi = random_material(rng, g)
            vel, dt = random_velocity(rng, g)
            M._fluxes_numpy(g, c, phi, *face_velocities(g, vel), dt, PHI_MAX)
    assert all(n > 0 for n in calls.values()), calls


@pytest.mark.parametrize("periodic", [False, True])
def test_windowed_solid_fluxes_agree(periodic, monkeypatch):
    """material_solid_fluxes (on its material window, and on the whole grid) with the kernel
    against forced NumPy: identical; a block of material with a partial surface and thin cells."""
    rng = np.random.default_rng(7)
    g = Grid(nx=48, nz=32, Lx=0.48, Lz=0.32, periodic_x=periodic)
    c = np.zeros(g.cell_shape)
    c[14:26, 0:9] = 1.0
    c[14:26, 9] = rng.random(12)
    c[26, 0:5] = 0.07
    phi = c * rng.uniform(0.45, 0.59, g.cell_shape)
    vel, dt = random_velocity(rng, g)
    assert M.material_window(g, c, phi) is not None
    compiled = [M.material_solid_fluxes(g, c, phi, vel, dt, PHI_MAX, win) for win in ("auto", None)]
    monkeypatch.setattr(M, "kernel_available", lambda: False)
    reference = [M.material_solid_fluxes(g, c, phi, vel, dt, PHI_MAX, win) for win in ("auto", None)]
    for a, b in zip(compiled, reference):
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert np.abs(compiled[0][0]).max() > 0


def test_degenerate_inputs_agree():
    g = Grid(nx=5, nz=3, Lx=1.0, Lz=0.6)
    agree(g, np.zeros(g.cell_shape), np.zeros(g.cell_shape), np.zeros(g.n_unknowns), 0.1)
    full = np.ones(g.cell_shape)
    agree(g, full, 0.55 * full, 0.1 * np.ones(g.n_unknowns), 0.1)
    narrow = Grid(nx=2, nz=4, Lx=0.2, Lz=0.4, periodic_x=True)  # the periodic wrap onto itself
    rng = np.random.default_rng(2)
    c, phi = random_material(rng, narrow)
    agree(narrow, c, phi, *random_velocity(rng, narrow))


def test_a_real_collapse_step_agrees():
    """The state of a Lagree column collapse (v2) after a few steps: its fluxes at its velocity."""
    sim = lagree_collapse(0.3)
    sim.run()
    g, st = sim.model.grid, sim.state
    c, phi = np.asarray(st.c).reshape(g.cell_shape), np.asarray(st.phi).reshape(g.cell_shape)
    assert np.any((c > M.C_MIN) & (c < M.C_FULL)) and np.abs(st.vel).max() > 0
    dt = CFL / cfl_number(g, st.vel, 1.0)
    agree(g, c, phi, st.vel, dt)
    win = M.material_window(g, c, phi)
    if win is not None:
        sub, xf, zf = M._window_geometry(g, win)
        u, w = face_velocities(g, st.vel)
        xs, zs = win
        a = M._fluxes(sub, c[xs, zs], phi[xs, zs], u[xf, zs], w[xs, zf], dt, PHI_MAX)
        b = M._fluxes_numpy(sub, c[xs, zs], phi[xs, zs], u[xf, zs], w[xs, zf], dt, PHI_MAX)
        assert all(np.array_equal(x, y) for x, y in zip(a[0] + a[1], b[0] + b[1]))


def test_model_steps_use_the_kernel_and_match_numpy(monkeypatch):
    """A short Lagree collapse (v2: indicator surface, consistent momentum transport) calls the
    compiled fluxes at every Picard sweep, and gives the same fields, bit for bit, as the same run
    with the NumPy reference forced."""
    fast, _, calls = kernel_and_reference_runs(monkeypatch, M, "fluxes_compiled")
    assert calls >= fast.totals.picard_iterations > 0
