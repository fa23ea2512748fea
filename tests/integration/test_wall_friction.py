"""Coulomb friction on the base (``walls.bottom = "coulomb"``, granflow.physics.wall_friction).

Analytic reference: a rigid layer of thickness H on a base of friction coefficient mu_w, tilted at
theta, under gravity g. The basal stress is mu_w times the layer's normal load when it slides, so

    mu_w < tan(theta):  du/dt = g (sin(theta) - mu_w cos(theta)),  u uniform over the layer;
    mu_w > tan(theta):  at rest (the base carries tan(theta) < mu_w of the load).

The layer stays rigid when the interior is stronger than the base: Drucker-Prager, Z = sin(26.74
deg) = 0.45 > mu_w (but for the regularisation's creep, bounded analytically below). Tolerances: the light ambient's inertia (rho_a = 2 kg m^-3 over the 1500 kg
m^-3 of the layer) slows the layer by 0.13 %; measured at 8 cells over H, 100 steps of 1 ms:
-0.05 % (mu_w = tan 8 deg, theta = 15 deg). With one solve per step (ONE_SOLVE) -0.22 % and -0.34 %
(22 deg on tan 15 deg): its first step is iterated (granflow.predictor.sweep_cap); solved once from
rest the base held the block for ~5 steps, -5.2 % and -7.3 %.
"""
import math

import numpy as np
import pytest

from granflow.config import CaseConfig
from granflow.casekit.common import make_model
from granflow.errors import GranflowInputError
from granflow.grid import Grid, VelocityBCs
from granflow.model import Model, StepStatus
from granflow.physics import wall_friction as wf
from granflow.rheology import make_closure

G = 9.81
H, NZ = 0.02, 16  # layer 2 cm on 8 cells, box twice as tall
DT, STEPS = 1e-3, 100
ACCEL_RTOL = 5e-3
"""Relative tolerance on the sliding speed (ambient inertia 0.13 %, measured 0.05 %)."""
ONE_SOLVE = {"max_sweeps": 1, "predictor": "extrapolated"}
"""One solve per step (docs/solver.md, "One solve per step")."""
Z_INTERIOR = math.sin(math.radians(26.74))
"""The layer's yield stress ratio (Drucker-Prager sin(delta))."""


def _layer(theta_deg: float, bottom: str, mu_w: float | None, picard: dict | None = None):
    th = math.radians(theta_deg)
    g = Grid(nx=4, nz=NZ, Lx=0.01, Lz=2 * H, periodic_x=True)
    model = Model(g, make_closure("drucker_prager", delta_deg=26.74),
                  gravity=(G * math.sin(th), -G * math.cos(th)), bcs=VelocityBCs(bottom=bottom),
                  wall_friction=mu_w, picard=picard)
    phi = np.zeros(g.cell_shape)
    phi[:, : NZ // 2] = model.material.phi_max
    return g, model, model.initial_state(phi)


def _run(theta_deg: float, bottom: str, mu_w: float | None, picard: dict | None = None) -> np.ndarray:
    """u on the x-faces of the layer after STEPS steps [m s^-1]."""
    g, model, st = _layer(theta_deg, bottom, mu_w, picard)
    for _ in range(STEPS):
        assert model.advance(st, DT).status is not StepStatus.FAILED
    u, _ = g.unpack_velocity(st.vel)
    return u[:-1, : NZ // 2]


@pytest.mark.parametrize("picard", [None, ONE_SOLVE], ids=["iterated", "one_solve"])
@pytest.mark.parametrize("theta_deg, delta_w", [(15.0, 8.0), (22.0, 15.0)])
def test_sliding_block_accelerates_at_g_sin_minus_mu_cos(theta_deg, delta_w, picard):
    th, mu_w = math.radians(theta_deg), math.tan(math.radians(delta_w))
    u = _run(theta_deg, "coulomb", mu_w, picard)
    expected = G * (math.sin(th) - mu_w * math.cos(th)) * STEPS * DT
    assert u.mean() == pytest.approx(expected, rel=ACCEL_RTOL)
    # rigid but for the regularisation's creep: at the basal stress ratio r = mu_w / Z the regularised
    # yield law 2 eta |S| = Z p gives the shear rate 2 eps r / sqrt(1 - r^2), at most over H
    r = mu_w / Z_INTERIOR
    _, model, _ = _layer(theta_deg, "coulomb", mu_w)
    creep = 2 * model.eps * r / math.sqrt(1 - r * r) * H
    assert (u.max() - u.min()) < creep < 2e-3 * expected


@pytest.mark.parametrize("picard", [None, ONE_SOLVE], ids=["iterated", "one_solve"])
def test_block_held_by_a_rough_base_stays_at_rest(picard):
    """mu_w = tan 20 deg > tan 15 deg: only the model's creep (speeds below eps Lz), as on a
    no-slip base (within 5 %); the sliding block of the same slope reaches 0.12 m/s."""
    coulomb = _run(15.0, "coulomb", math.tan(math.radians(20.0)), picard)
    no_slip = _run(15.0, "no_slip", None, picard)
    _, model, _ = _layer(15.0, "no_slip", None)
    assert np.abs(coulomb).max() < model.eps * model.grid.Lz
    assert np.abs(coulomb).max() == pytest.approx(np.abs(no_slip).max(), rel=0.05)


def test_base_viscosity_is_capped_at_the_coulomb_stress():
    """The base nodes' stress ``eta_n (en u)`` is min(interior, mu_w p_wall) (regularised), with
    p_wall the analytic weight of the layer; the interior nodes are untouched."""
    g, model, st = _layer(0.0, "coulomb", 0.2)
    gamma = 3.0
    u = np.zeros(g.xface_shape)
    _, Z = g.xface_coords()
    u[:] = gamma * np.minimum(Z, H)
    vel = g.pack_velocity(u, np.zeros(g.zface_shape))
    p_wall = model.material.phi_max * model.material.rho_s * G * H
    for eta_interior in (1e-3, 1e3):  # weaker than the cap (kept) / stronger (capped)
        eta_n = np.full(g.n_nodes, eta_interior)
        out, share = wf.coulomb_base_viscosity(model, st.phi.ravel(), st.p.ravel(), st.p_f.ravel(),
                                               vel, eta_n)
        gamma_w = gamma  # 2 u_1 / dz with u_1 = gamma dz / 2
        cap = 0.2 * p_wall / math.sqrt(gamma_w ** 2 + (2 * model.eps) ** 2)
        base = out.reshape(g.node_shape)[:, 0]
        assert np.allclose(base, min(eta_interior, cap), rtol=1e-12)
        assert np.allclose(share, min(1.0, cap / eta_interior), rtol=1e-12)
        assert np.array_equal(out.reshape(g.node_shape)[:, 1:], eta_n.reshape(g.node_shape)[:, 1:])
    stress = wf.base_shear_stress(model, vel, out)
    assert np.allclose(stress, 0.2 * p_wall, rtol=1e-5)


def test_slip_is_not_a_deformation_of_the_bottom_cells():
    """A plug sliding at u_1: with share 0 the bottom cells see no shear; share 1 is the no-slip
    strain rate."""
    g, model, _ = _layer(0.0, "coulomb", 0.2)
    vel = g.pack_velocity(np.full(g.xface_shape, 0.1), np.zeros(g.zface_shape))
    nodes, _ = model.base_node_rows
    slip = wf.strain_rate_norm(model, vel, np.zeros(int(nodes.sum())))
    assert np.all(slip == 0.0)
    full = wf.strain_rate_norm(model, vel, np.ones(int(nodes.sum())))
    assert np.array_equal(full, model.ops.strain_rate_norm(vel))


def _config(walls: dict) -> CaseConfig:
    return CaseConfig.from_dict({"case": {"name": "column_collapse"}, "walls": walls})


def test_config_keys_and_refusals():
    model = make_model(_config({"bottom": "coulomb", "base_friction_deg": 15.0}))
    assert model.wall_friction == pytest.approx(math.tan(math.radians(15.0)), rel=1e-15)
    assert make_model(_config({})).wall_friction is None
    for walls, key in (({"bottom": "coulomb"}, "walls.base_friction_deg"),
                       ({"base_friction_deg": 10.0}, "walls.base_friction_deg"),
                       ({"bottom": "coulomb", "base_friction_deg": 95.0}, "base_friction_deg"),
                       ({"west": "coulomb"}, "walls.west")):
        with pytest.raises(GranflowInputError, match=key):
            _config(walls)
    g = Grid(nx=4, nz=4, Lx=1.0, Lz=1.0)
    closure = make_closure("drucker_prager")
    with pytest.raises(GranflowInputError, match="wall_friction"):
        Model(g, closure, bcs=VelocityBCs(bottom="coulomb"))
    with pytest.raises(GranflowInputError, match="coulomb"):
        Model(g, closure, wall_friction=0.3)
    with pytest.raises(GranflowInputError, match="wall_friction"):
        Model(g, closure, bcs=VelocityBCs(bottom="coulomb"), wall_friction=-0.1)
    with pytest.raises(GranflowInputError, match="base condition"):
        VelocityBCs(top="coulomb")


def test_a_fluidised_base_carries_no_friction():
    """Gas carrying a fraction beta of the weight (p_f = beta p_lith, p = (1 - beta) p_lith): the
    wall pressure, hence the Coulomb cap, is (1 - beta) of the dry one; 0 when fully fluidised."""
    g, model, st = _layer(0.0, "coulomb", 0.3)
    p_lith = model.lithostatic_pressure(st.phi, st.c).ravel()
    vel = g.pack_velocity(np.full(g.xface_shape, 0.1), np.zeros(g.zface_shape))
    eta_n = np.full(g.n_nodes, 1e6)
    caps = []
    for beta in (0.0, 0.5, 1.0):
        out, _ = wf.coulomb_base_viscosity(model, st.phi.ravel(), (1 - beta) * p_lith, beta * p_lith, vel, eta_n)
        caps.append(out.reshape(g.node_shape)[:, 0])
    assert np.all(caps[0] > 0)
    assert np.allclose(caps[1], 0.5 * caps[0], rtol=1e-10)
    assert np.allclose(caps[2], 0.0, atol=1e-12 * caps[0].max())
