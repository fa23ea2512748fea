"""Friction on a no-slip base at the wall pressure (``numerics.base_friction = "wall"``,
granflow.step.base_node_viscosity, granflow.physics.momentum.base_pressure).

Checked against the analytic lithostatic pressure of a uniform layer and against the closure
evaluated by hand: the base nodes' viscosity is ``Z(phi, I) p_wall / (2 sqrt(|S|^2 + eps^2))``
with ``p_wall = phi rho_s g (H - 0)`` -- the weight of the whole layer, also for a film thinner
than one cell, where the centre pressure carries half of it.
"""
import numpy as np
import pytest

from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.model import Model
from granflow.model_options import VISCOUS_ADDITION_FACTOR, BaseFriction
from granflow.physics.momentum import base_pressure
from granflow.physics.wall_friction import base_strain_rate_norm
from granflow.rheology import make_closure
from granflow.step import base_node_viscosity

G = 9.81


def test_base_pressure_is_the_weight_to_the_wall():
    rho_s, phi, dz, H = 2500.0, 0.6, 0.01, 0.05
    p_centre = phi * rho_s * G * (H - dz / 2)
    assert base_pressure(p_centre, phi, rho_s, G, dz) == pytest.approx(phi * rho_s * G * H, rel=1e-14)
    # gas carrying a fraction beta of the weight: only the rest is added
    beta = 0.3
    p_w = base_pressure(p_centre, phi, rho_s, G, dz, dpf_dz=-beta * phi * rho_s * G)
    assert p_w == pytest.approx(p_centre + (1 - beta) * phi * rho_s * G * dz / 2, rel=1e-14)
    # never below the centre pressure, never negative
    assert base_pressure(-5.0, phi, rho_s, G, dz, dpf_dz=-2 * phi * rho_s * G) == 0.0


def _sheared_layer(n_material: float, nz: int = 8):
    """A uniform layer over ``n_material`` cells (fractional: a thin top cell) in simple shear."""
    g = Grid(nx=4, nz=nz, Lx=0.04, Lz=0.01 * nz, periodic_x=True)
    model = Model(g, make_closure("mu_i"), surface="indicator", advection="consistent")
    phi_in = model.material.phi_max
    c = np.clip(n_material - np.arange(nz), 0.0, 1.0)[None, :].repeat(g.nx, axis=0)
    st = model.initial_state(phi_in * c)
    gamma = 2.0
    u = np.zeros(g.xface_shape)
    X, Z = g.xface_coords()
    u[:] = gamma * np.minimum(Z, n_material * g.dz)
    vel = g.pack_velocity(u, np.zeros(g.zface_shape))
    return g, model, st, vel, phi_in * n_material * g.dz


@pytest.mark.parametrize("n_material", [0.3, 1.0, 2.5, 6.0])
def test_base_nodes_carry_the_whole_weight(n_material):
    g, model, st, vel, load = _sheared_layer(n_material)
    dense = model.dense(st.phi, st.c)
    p = model.lithostatic_pressure(st.phi, st.c).ravel()
    if n_material < 0.5:  # a thin cell: its friction pressure is the mid-material one
        p = np.where(np.ravel(st.c) > 0, model.material.rho_s * G * st.phi.ravel() * g.dz / 2, 0.0)
    S = model.ops.strain_rate_norm(vel)
    dt = 1e-3
    coef = model.coefficients(st.phi.ravel(), p, S, dt, dense)
    eta_n = model.ops.cell_to_node @ coef.eta_c
    out = base_node_viscosity(model, st.phi.ravel(), dense, p, st.p_f, S, dt, coef.eta_c, eta_n)
    # independent evaluation at the base: the closure at the analytic wall pressure
    p_wall = model.material.rho_s * G * load
    S0 = S.reshape(g.cell_shape)[0, 0]
    phi0 = st.phi[0, 0]
    I = model.material.inertial_number(np.sqrt(S0 ** 2 + model.eps ** 2), np.hypot(p_wall, model.delta_p))
    Z = model.closure.Z(np.array(phi0), np.array(I))
    expected = (Z * p_wall / (2 * np.sqrt(S0 ** 2 + model.eps ** 2))
                + VISCOUS_ADDITION_FACTOR * model.closure.eta_visc + model.background_viscosity)
    base = out.reshape(g.node_shape)[:, 0]
    assert np.allclose(base, expected, rtol=1e-10)
    # the centre pressure is short by half a cell of weight: the test tells the two apart
    centre = eta_n.reshape(g.node_shape)[:, 0]
    short = min(n_material, 1.0) / 2 / n_material
    assert np.all(centre < base * (1 - 0.5 * short))
    # the interior nodes are untouched
    assert np.array_equal(out.reshape(g.node_shape)[:, 1:], eta_n.reshape(g.node_shape)[:, 1:])


@pytest.mark.parametrize("n_material", [0.3, 1.0, 2.5, 6.0])
def test_base_shear_stress_is_the_yield_stress_at_the_wall(n_material):
    """With the velocity (as the Picard sweep passes it) the base nodes' viscosity is evaluated at
    the wall's own strain rate, ``|S_xz| = u_1 / dz`` with the no-slip ghost (``gamma/2`` of the
    simple shear when the film covers the first velocity, ``gamma n`` for a film of n < 1/2
    cell), so the basal stress ``2 eta S_xz`` is ``Z(I_wall) p_wall`` to the regularisation, for
    any thickness; the cell-centre strain rate (4-node mean: a film one cell thick with a
    stress-free top has ``|S|^2 = 5 gamma^2 / 32``) would not give it."""
    g, model, st, vel, load = _sheared_layer(n_material)
    gamma = 2.0
    s_w = gamma * min(n_material, 0.5)  # u_1 / dz, u_1 = gamma min(h, dz / 2)
    S_wall = base_strain_rate_norm(model.ops, vel)
    assert np.allclose(S_wall, s_w, rtol=1e-12)
    # the bottom-row operators the sweep uses give the same values, bit for bit
    assert np.array_equal(base_strain_rate_norm(model.ops, vel, model.base_strain_rows), S_wall)
    dense = model.dense(st.phi, st.c)
    p = model.lithostatic_pressure(st.phi, st.c).ravel()
    if n_material < 0.5:
        p = np.where(np.ravel(st.c) > 0, model.material.rho_s * G * st.phi.ravel() * g.dz / 2, 0.0)
    S = model.ops.strain_rate_norm(vel)
    dt = 1e-3
    coef = model.coefficients(st.phi.ravel(), p, S, dt, dense)
    eta_n = model.ops.cell_to_node @ coef.eta_c
    out = base_node_viscosity(model, st.phi.ravel(), dense, p, st.p_f, S, dt, coef.eta_c, eta_n, vel=vel)
    p_wall = model.material.rho_s * G * load
    I = model.material.inertial_number(np.sqrt(s_w ** 2 + model.eps ** 2), np.hypot(p_wall, model.delta_p))
    Z = float(model.closure.Z(np.array(st.phi[0, 0]), np.array(I)))
    stress = 2 * out.reshape(g.node_shape)[:, 0] * s_w
    extra = 2 * (VISCOUS_ADDITION_FACTOR * model.closure.eta_visc + model.background_viscosity) * s_w
    reg = s_w / np.sqrt(s_w ** 2 + model.eps ** 2)  # the regularisation, 1 - O(eps^2/S^2)
    assert np.allclose(stress - extra, Z * p_wall * reg, rtol=1e-10)
    if n_material == 1.0:  # the centre strain rate is not the wall's
        assert S.reshape(g.cell_shape)[0, 0] == pytest.approx(np.sqrt(5 / 32) * gamma, rel=1e-12)


def test_option_defaults_and_refusal():
    """Scheme v2 defaults (surface = "indicator"): friction at the wall pressure; the v1
    threshold surface keeps the centre pressure unless told otherwise."""
    g = Grid(nx=4, nz=4, Lx=0.04, Lz=0.04)
    dp = make_closure("drucker_prager")
    assert Model(g, dp).surface.value == "indicator"
    assert Model(g, dp).base_friction is BaseFriction.WALL
    assert Model(g, dp, surface="indicator").base_friction is BaseFriction.WALL
    assert Model(g, dp, surface="threshold").base_friction is BaseFriction.CENTRE
    assert Model(g, dp, surface="threshold", base_friction="wall").base_friction is BaseFriction.WALL
    assert Model(g, dp, surface="indicator", base_friction="centre").base_friction is BaseFriction.CENTRE
    with pytest.raises(GranflowInputError, match="base_friction"):
        Model(g, dp, base_friction="floor")


def test_bottom_row_strain_rate_matches_the_whole_grid_one_on_random_velocities():
    """The Picard sweep's bottom-row operators (Model.base_strain_rows) against the whole-grid
    ec/en products, bit for bit, on a random velocity field with a no-slip base."""
    g = Grid(nx=12, nz=7, Lx=0.12, Lz=0.07)
    model = Model(g, make_closure("mu_i"))
    vel = np.random.default_rng(3).normal(size=g.n_unknowns)
    whole = base_strain_rate_norm(model.ops, vel)
    assert whole.shape == (g.nx,)
    assert np.array_equal(base_strain_rate_norm(model.ops, vel, model.base_strain_rows), whole)
