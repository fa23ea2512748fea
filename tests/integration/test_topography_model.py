"""The solver on a topography (issue 14 item 3): the Model with solid cells below a base profile.

* A column on a floor raised by K cells must be the same run as in the box K cells shorter: the
  fields agree to round-off once the Picard loop is converged tightly (its default stopping test
  scales with the number of unknowns and the box height, which differ between the two boxes), and
  the solid stays empty with zero velocity on every face that is not open.
* A column on a staircase slope conserves its grain mass to round-off, keeps 0 <= phi <= phi_max
  and c in [0, 1] without clipping, moves no grain into the rock, and its energy budget closes as
  on the flat base.
* Unsupported combinations are refused by name, and grains placed inside the rock are an error.
"""
from __future__ import annotations

import numpy as np
import pytest

from granflow import diagnostics as dg
from granflow.casekit import common
from granflow.cases import CASES
from granflow.cases import lagree_column as lc
from granflow.config import CaseConfig
from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.topography import Topography

N = 24
K = 3
TIGHT = {"tol": 1e-11, "max_sweeps": 80}


def lagree(picard=None, walls=None, inflow=None, **numerics):
    cfg = CaseConfig.from_dict({"case": {"name": "lagree_column"}, "grid": {"nx": N, "nz": N},
                                "numerics": {"picard": picard or TIGHT, **numerics},
                                "walls": walls or {}, "inflow": inflow or {}, "output": {"figures": False}})
    return cfg, CASES.get("lagree_column").setup(cfg)


def lagree_model(cfg, grid, topography, **kw):
    """The lagree_column case's Model on another grid, with a topography."""
    used = lc.numerics_used(cfg)
    return common.make_model(cfg, grid=grid, closure=lc.closure(cfg), gravity=(0.0, -lc.GRAVITY),
                             ambient={**cfg.numerics.ambient.model_dump(), "rho_a": used["rho_a"],
                                      "eta_a": used["eta_a"]},
                             delta_p=used["delta_p"], topography=topography, **kw)


def raised(cfg, sim):
    g = sim.model.grid
    tall = Grid(nx=g.nx, nz=g.nz + K, Lx=g.Lx, Lz=g.Lz + K * g.dz, z0=-K * g.dz)
    model = lagree_model(cfg, tall, Topography(x=[0.0], z=[0.0]))
    phi = np.zeros(tall.cell_shape)
    phi[:, K:] = sim.state.phi
    state = model.initial_state(phi)
    assert np.array_equal(state.c[:, K:], sim.state.c)
    return model, state


@pytest.mark.parametrize("walls, inflow", [
    ({}, {}), ({"bottom": "coulomb", "base_friction_deg": 10.0}, {}),
    ({}, {"side": "bottom", "lower": 2.0, "upper": 2.5, "speed": 0.3}),
    ({}, {"side": "west", "lower": 1.2, "upper": 1.6, "speed": 0.3})],
    ids=["no_slip", "coulomb", "base_source", "west_source"])
def test_raised_floor_is_the_shorter_box(walls, inflow):
    """The base friction (the wall pressure and strain rate of the lowest fluid cells, and on a
    Coulomb base the cap of its nodes) and a source of grains (on the base or the west wall)
    act on the raised floor as on the box's base."""
    if inflow:  # the spans are given in the shorter box's z (the west source)
        inflow = dict(inflow)
    cfg, sim = lagree(walls=walls, inflow=inflow)
    model, state = raised(cfg, sim)
    box, s0 = sim.model, sim.state
    assert model.base_index.tolist() == [K] * N
    open_faces = model.ops.open_faces
    for _ in range(3):
        assert box.advance(s0, 0.01).status.name == "OK"
        assert model.advance(state, 0.01).status.name == "OK"
        assert np.abs(state.phi[:, K:] - s0.phi).max() < 1e-11
        assert np.abs(state.c[:, K:] - s0.c).max() < 1e-11
        assert np.abs(state.vel[open_faces] - s0.vel).max() < 1e-9
        assert np.abs(state.p[:, K:] - s0.p).max() < 1e-8 * np.abs(s0.p).max()
        assert np.all(state.phi[:, :K] == 0.0) and np.all(state.c[:, :K] == 0.0)
        assert np.all(state.vel[~open_faces] == 0.0)


def slope_run(steps: int = 12, dt: float = 0.01):
    """The Lagree column (a = 1.42) on a 20 degree staircase that meets a flat run-out at x = 2."""
    cfg, sim = lagree(picard={})
    g0 = sim.model.grid
    drop = 2.0 * np.tan(np.radians(20.0))
    g = Grid(nx=N, nz=N, Lx=g0.Lx, Lz=g0.Lz + drop)
    topo = Topography(x=[0.0, 2.0], z=[drop, 0.0])
    model = lagree_model(cfg, g, topo)
    base = model.base_index
    phi = np.zeros(g.cell_shape)
    H0, L0 = 1.0, 1.0 / 1.42
    for i in range(g.nx):
        if g.xc[i] < L0:
            zb = g.z0 + base[i] * g.dz
            phi[i] = model.material.phi_max * ((g.zc > zb) & (g.zc < zb + H0))
    state = model.initial_state(phi)
    mass0 = state.phi.sum()
    budget = dg.EnergyBudget.start(model, state)
    reports = []
    for _ in range(steps):
        reports.append(model.advance(state, dt))
        budget.record(reports[-1], state)
    return model, state, mass0, reports, budget


def test_column_on_a_staircase_slope_keeps_mass_bounds_and_rock_empty():
    model, state, mass0, reports, budget = slope_run()
    assert all(r.status.name in ("OK", "NOT_CONVERGED") for r in reports)
    assert abs(state.phi.sum() - mass0) <= 1e-12 * mass0
    assert state.phi.min() >= 0.0 and state.phi.max() <= model.material.phi_max * (1 + 1e-12)
    assert state.c.min() >= 0.0 and state.c.max() <= 1.0
    assert all(r.clipped_mass == 0.0 for r in reports)
    assert np.all(state.phi[model.solid] == 0.0) and np.all(state.c[model.solid] == 0.0)
    assert np.all(state.vel[~model.ops.open_faces] == 0.0)
    assert np.abs(state.vel).max() > 0.0  # it flows
    # the energy budget: potential energy released, and its residual is exactly the sum of the
    # numerical terms (the split of docs/solver.md), as on the flat base
    assert budget.released > 0.0
    assert abs(budget.residual - sum(budget.numerical.values())) <= 1e-9 * budget.released


def test_unsupported_options_are_named():
    cfg, sim = lagree()
    g = sim.model.grid
    topo = Topography(x=[0.0, 1.0], z=[0.5, 0.0])
    with pytest.raises(GranflowInputError, match="advection = 'upwind'"):
        lagree_model(cfg, g, topo, advection="upwind")
    with pytest.raises(GranflowInputError, match="linear_solver = 'amg'"):
        lagree_model(cfg, g, topo, linear_solver="amg")
    with pytest.raises(GranflowInputError, match="surface = 'threshold'"):
        lagree_model(cfg, g, topo, surface="threshold")
    model = lagree_model(cfg, g, topo)
    with pytest.raises(GranflowInputError, match=r"phi != 0 in the solid cell \(0, 0\)"):
        model.initial_state(np.full(g.cell_shape, 0.5))
