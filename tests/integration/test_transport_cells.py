"""The time step's CFL number counts only the cells a step's transport needs it for
(granflow.model.Model.transport_cells, granflow.physics.transport.cfl_number with ``cells``).

Checked against the transport itself: the velocity on a face beside no cell that holds anything
can be replaced by anything (here 1e3 times a random field) without changing the transported
grains, indicator or fluxes by one bit; with the indicator surface, trace material in that fast
air (c = 1e-7, left out of the CFL number) is carried with phi >= 0, 0 <= c <= 1 and the grain
mass to round-off; the threshold surface's one-cell ring is needed (without it the second SSP-RK2
stage moves grains through a replaced face).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import maximum_filter

from granflow.cases import CASES
from granflow.config import CaseConfig
from granflow.physics.transport import POSITIVITY_CFL, cfl_number, stable_dt

N = 24
AMBIENT_SCALE = 1.0e3
"""Factor of the replacement velocity on the faces outside the transport cells."""


def lagree(surface: str = "indicator", advection: str = "consistent"):
    """The Lagree column at N^2 (a = 1.42): its Simulation (model, initial state)."""
    cfg = CaseConfig.from_dict({
        "case": {"name": "lagree_column"}, "grid": {"nx": N, "nz": N}, "time": {"dt_max": 0.01},
        "numerics": {"surface": surface, "advection": advection},
        "output": {"figures": False}})
    return CASES.get("lagree_column").setup(cfg)


def faces_touching(g, cells) -> np.ndarray:
    """Flat mask of the velocity unknowns on a face of at least one cell of ``cells``."""
    cu = np.zeros(g.xface_shape, dtype=bool)
    cw = np.zeros(g.zface_shape, dtype=bool)
    cu[:-1] |= cells
    cu[1:] |= cells
    cw[:, :-1] |= cells
    cw[:, 1:] |= cells
    if g.periodic_x:
        cu[0] |= cu[-1]
        cu[-1] |= cu[0]
    return g.pack_velocity(cu.astype(float), cw.astype(float)) > 0.0


def moved(model, state, vel, dt):
    out = model.transport(state.phi, vel, dt, state.c)
    return [out.phi, out.flux_x, out.flux_z] + ([] if state.c is None else [out.c])


def holding(g, state) -> np.ndarray:
    """Cells with anything to move (grains or material)."""
    cells = np.asarray(state.phi).reshape(g.cell_shape) > 0.0
    if state.c is not None:
        cells |= np.asarray(state.c).reshape(g.cell_shape) > 0.0
    return cells


def ring(cells) -> np.ndarray:
    return maximum_filter(cells, size=3, mode="constant")


@pytest.mark.parametrize("surface", ["indicator", "threshold"])
@pytest.mark.parametrize("seed", range(3))
def test_faces_beside_no_grains_do_not_matter(surface, seed):
    sim = lagree(surface)
    model, state, g = sim.model, sim.state, sim.model.grid
    rng = np.random.default_rng(seed)
    cells = model.transport_cells(state.phi, state.c)
    assert cells.any() and not cells.all()
    reach = holding(g, state) if surface == "indicator" else ring(holding(g, state))
    assert np.array_equal(cells, reach)  # no trace material in the initial column
    inside = faces_touching(g, cells)
    vel = rng.uniform(-1.0, 1.0, g.n_unknowns)
    fast = np.where(inside, vel, AMBIENT_SCALE * rng.uniform(-1.0, 1.0, g.n_unknowns))
    dt = stable_dt(g, vel, POSITIVITY_CFL, cells)
    assert stable_dt(g, fast, POSITIVITY_CFL, cells) == dt
    assert cfl_number(g, fast, dt) > 100 * POSITIVITY_CFL  # the whole-grid rule would cut dt
    a, b = moved(model, state, vel, dt), moved(model, state, fast, dt)
    for x, y in zip(a, b):
        assert np.array_equal(x, y)
    assert a[0].min() >= -1e-15
    if state.c is not None:
        assert a[3].min() >= 0.0 and a[3].max() <= 1.0


@pytest.mark.parametrize("seed", range(3))
def test_trace_material_in_a_fast_ambient_stays_bounded(seed):
    sim = lagree()
    model, state, g = sim.model, sim.state, sim.model.grid
    rng = np.random.default_rng(seed)
    c = np.asarray(state.c).reshape(g.cell_shape).copy()
    phi = np.asarray(state.phi).reshape(g.cell_shape).copy()
    trace = (c == 0.0) & (rng.random(g.cell_shape) < 0.3)
    c[trace] = 1e-7 * rng.random(int(trace.sum()))
    phi[trace] = 0.55 * c[trace]
    state.c, state.phi = c, phi
    cells = model.transport_cells(phi, c)
    assert not (cells & trace).any()
    inside = faces_touching(g, cells)
    vel = rng.uniform(-1.0, 1.0, g.n_unknowns)
    vel = np.where(inside, vel, AMBIENT_SCALE * rng.uniform(-1.0, 1.0, g.n_unknowns))
    dt = stable_dt(g, vel, POSITIVITY_CFL, cells)
    assert cfl_number(g, vel, dt, ring(trace)) > 100  # the trace cells move at CFL >> 1/2
    out = model.transport(phi, vel, dt, c)
    assert out.phi.min() >= 0.0 and out.c.min() >= 0.0 and out.c.max() <= 1.0
    assert out.phi.max() <= model.material.phi_max * (1 + 1e-12)
    assert abs(out.phi.sum() - phi.sum()) <= 1e-13 * phi.sum()


def test_the_threshold_surface_needs_the_ring():
    """Two SSP-RK2 stages: the grains' own cells alone are not enough (the replaced faces beside
    a cell the first stage fills change the result)."""
    sim = lagree("threshold")
    model, state, g = sim.model, sim.state, sim.model.grid
    rng = np.random.default_rng(7)
    grains = np.asarray(state.phi).reshape(g.cell_shape) > 0.0
    assert model.transport_cells(state.phi, state.c).sum() > grains.sum()
    vel = rng.uniform(-1.0, 1.0, g.n_unknowns)
    fast = np.where(faces_touching(g, grains), vel, AMBIENT_SCALE * rng.uniform(-1.0, 1.0, g.n_unknowns))
    dt = stable_dt(g, vel, POSITIVITY_CFL, grains)
    assert not np.array_equal(moved(model, state, vel, dt)[0], moved(model, state, fast, dt)[0])


def test_the_upwind_advection_counts_every_cell():
    """v1's (u . grad) u moves the ambient's momentum too."""
    sim = lagree("threshold", "upwind")
    assert sim.model.transport_cells(sim.state.phi, sim.state.c) is None


def test_the_time_step_ignores_a_fast_ambient():
    sim = lagree()
    model, state, g = sim.model, sim.state, sim.model.grid
    rng = np.random.default_rng(11)
    cells = model.transport_cells(state.phi, state.c)
    inside = faces_touching(g, cells)
    state.vel[:] = np.where(inside, 5.0, 0.0) * rng.uniform(-1.0, 1.0, g.n_unknowns)
    dt = sim.time_step()
    assert dt == pytest.approx(sim.cfl * stable_dt(g, state.vel, 1.0, cells), rel=1e-15)
    assert dt < sim.dt_max  # CFL-bound
    state.vel[~inside] = 50.0  # an ambient jet
    assert sim.cfl * stable_dt(g, state.vel, 1.0) < dt / 5  # the whole-grid rule's dt
    assert sim.time_step() == dt
