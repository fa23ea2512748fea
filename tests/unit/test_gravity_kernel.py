"""The compiled gravity weight (granflow.physics.gravity_kernel, Numba) against its NumPy
reference (model_gravity.gravity_weights_numpy): the same floating-point operations in the same
order, so the force and the drag must be identical (asserted with np.array_equal) -- on random
inputs with resting faces (vel = 0, and -0.0), faces slower and faster than the blend velocity
u_b (and at u_b exactly), both signs of the drag, and on the steps of a real collapse."""
from __future__ import annotations

import numpy as np
import pytest

import granflow.model_gravity as MG
from granflow.physics.gravity_kernel import gravity_weights_compiled, kernel_available

from _kernels import kernel_and_reference_runs  # noqa: E402  (tests/ holds tiers)

pytestmark = pytest.mark.skipif(not kernel_available(), reason="Numba not installed")


def random_inputs(rng, n, n_u, u_b):
    """Velocities of both signs around ``u_b`` (a third at rest), fractions and fluxes whose
    upwind fraction lies above or below the centred one (both drag signs)."""
    vel = rng.normal(0.0, 1.0, n) * u_b * rng.choice([0.1, 1.0, 10.0], n)
    vel[rng.random(n) < 0.3] = 0.0
    vel[rng.random(n) < 0.02] = -0.0
    vel[rng.random(n) < 0.02] = u_b * rng.choice([-1.0, 1.0])
    centred = rng.uniform(0.0, 0.6, n)
    centred[rng.random(n) < 0.1] = 0.0
    flux = rng.uniform(0.0, 0.6, n) * vel
    flux[rng.random(n) < 0.05] = 0.0
    return centred, flux, vel


def agree(centred, flux, vel, gx, gz, n_u, rho_s, u_b):
    gvec = np.empty(vel.size)
    gvec[:n_u], gvec[n_u:] = gx, gz
    a = gravity_weights_compiled(centred, flux, vel, gx, gz, n_u, rho_s, u_b)
    b = MG.gravity_weights_numpy(centred, flux, vel, gvec, rho_s, u_b)
    for x, y in zip(a, b):
        assert x.shape == y.shape and x.dtype == y.dtype
        assert np.array_equal(x, y, equal_nan=True), np.nanmax(np.abs(x - y))
        assert np.array_equal(np.signbit(x), np.signbit(y))  # and the signs of the zeros
    return a


@pytest.mark.parametrize("seed", range(8))
def test_random_inputs_agree(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(10, 5000))
    n_u = int(rng.integers(0, n + 1))
    u_b = float(rng.uniform(1e-4, 0.1))
    gx, gz = float(rng.normal()), -float(rng.uniform(0.5, 10.0))
    force, drag = agree(*random_inputs(rng, n, n_u, u_b), gx, gz, n_u, float(rng.uniform(1.0, 3000.0)), u_b)
    assert np.all(drag >= 0.0)
    assert np.any(drag > 0.0) and np.any(force != 0.0)


def test_the_draws_cover_every_branch():
    """Implicit faces, explicit slow faces with a negative drag rate, saturated faces and resting
    faces all occur in the draws of test_random_inputs_agree (counted on the NumPy reference's
    intermediates)."""
    seen = {"implicit": 0, "anti": 0, "saturated": 0, "rest": 0}
    for seed in range(8):
        rng = np.random.default_rng(seed)
        n = int(rng.integers(10, 5000))
        n_u = int(rng.integers(0, n + 1))
        u_b = float(rng.uniform(1e-4, 0.1))
        gx, gz = float(rng.normal()), -float(rng.uniform(0.5, 10.0))
        centred, flux, vel = random_inputs(rng, n, n_u, u_b)
        gvec = np.where(np.arange(n) < n_u, gx, gz)
        moving = vel != 0.0
        upwind = np.where(moving, flux / np.where(moving, vel, 1.0), centred)
        rate = -gvec * (upwind - centred) * np.sign(vel)
        slow = np.abs(vel) < u_b
        seen["implicit"] += np.count_nonzero(slow & (rate > 0))
        seen["anti"] += np.count_nonzero(slow & moving & (rate < 0))
        seen["saturated"] += np.count_nonzero(~slow)
        seen["rest"] += np.count_nonzero(~moving)
    assert all(k > 0 for k in seen.values()), seen


def test_degenerate_inputs_agree():
    """Empty vectors, all at rest, zero gravity, non-finite entries (NaN propagates alike), and
    non-contiguous or non-float64 inputs (converted)."""
    rng = np.random.default_rng(1)
    agree(np.zeros(0), np.zeros(0), np.zeros(0), 0.0, -9.81, 0, 1500.0, 0.01)
    z = np.zeros(7)
    agree(z + 0.3, z, z, 0.0, -9.81, 3, 1500.0, 0.01)
    centred, flux, vel = random_inputs(rng, 100, 40, 0.01)
    agree(centred, flux, vel, 0.0, 0.0, 40, 1500.0, 0.01)
    vel[[3, 5]] = np.nan
    flux[7] = np.inf
    agree(centred, flux, vel, 0.3, -9.81, 40, 1500.0, 0.01)
    big = random_inputs(rng, 200, 100, 0.01)
    agree(*(a[::2] for a in big), 0.3, -9.81, 50, 1500.0, 0.01)
    agree(centred.astype(np.float32), flux, vel, 0.3, -9.81, 40, 1500.0, 0.01)


def test_model_steps_use_the_kernel_and_match_numpy(monkeypatch):
    """A short Lagree collapse (consistent gravity) calls the kernel once a step and gives the
    same fields, bit for bit, as the same run with the NumPy reference forced."""
    fast, _, calls = kernel_and_reference_runs(monkeypatch, MG, "gravity_weights_compiled")
    assert fast.model.consistent_gravity
    assert calls >= len(fast.reports) > 0
    assert np.abs(fast.state.vel).max() > 0


def test_mismatched_lengths_are_refused():
    """The kernel does not check its indices: arrays of unequal length or ``n_u`` beyond them
    are refused before it runs."""
    a = np.zeros(10)
    with pytest.raises(ValueError, match="unknowns"):
        gravity_weights_compiled(a, np.zeros(11), a, 0.0, -9.81, 5, 2500.0, 1e-3)
    with pytest.raises(ValueError, match="n_u"):
        gravity_weights_compiled(a, a, a, 0.0, -9.81, 11, 2500.0, 1e-3)
