"""The AMG saddle-point solver inside the time step (Model(linear_solver="amg")) reproduces the
reference sparse-LU path on the tiny dry and fluidised collapses (same scheme, only the linear
solve differs: FGMRES to rtol 1e-8 against SuperLU); scheme v2, the defaults."""
from __future__ import annotations

import numpy as np
import pytest

import granflow.model as gm
from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.model import AUTO_AMG_UNKNOWNS, Model
from granflow.rheology import make_closure
from granflow.simulation import Simulation

PHI_MAX = 0.6
STOP = 0.03


def run(linear_solver: str, gas: str | None):
    g = Grid(nx=40, nz=15, Lx=0.4, Lz=0.15)
    closure = make_closure("drucker_prager", material={"d": 70e-6}, delta_deg=26.74)
    # the AMG works on the whole grid: compare on the same scheme (no velocity band)
    model = Model(g, closure, gas=gas, linear_solver=linear_solver, ambient={"velocity_band": 0})
    X, Z = g.cell_coords()
    phi0 = np.where((X < 0.1) & (Z < 0.1), PHI_MAX if gas is None else 0.58, 0.0)
    p_f0 = 0.0 if gas is None else 0.9 * model.lithostatic_pressure(phi0)
    sim = Simulation(model, model.initial_state(phi0, p_f=p_f0), stop_time=STOP)
    sim.run()
    return sim


@pytest.mark.parametrize("gas", [None, "linear"])
def test_amg_path_matches_direct(gas):
    """30 steps (0.03 s) with the defaults (scheme v2). Measured 3 Dec 2026, max differences AMG -
    direct: phi 4.3e-8 (dry and linear), u 4.6e-6 (dry) / 2.7e-6 (linear) of max|u|, p 2.6e-7 /
    1.8e-7 of max p, p_f 1.4e-7 of max p_f (v1: phi 4e-9, u 2e-7). They are the FGMRES tolerance
    carried through the steps, not a different path: with rtol 1e-10 instead of the default 1e-8
    (dry) they drop 100-fold (u 3.8e-8, phi 2.0e-10), growing smoothly step by step with the same
    sweeps and active sets; v2's transport (donor-acceptor fractions, limiters) amplifies a
    solver error more than v1's. Bounds: phi 2e-7, u 2e-5 max|u|, p and p_f 2e-6."""
    ref, amg = run("direct", gas), run("amg", gas)
    assert amg.state.step == ref.state.step and amg.n_rejected == ref.n_rejected == 0
    np.testing.assert_allclose(amg.state.phi, ref.state.phi, rtol=0, atol=2e-7)  # measured 4.3e-8
    scale = np.abs(ref.state.vel).max()
    assert scale > 1e-3  # the column is moving
    np.testing.assert_allclose(amg.state.vel, ref.state.vel, rtol=0, atol=2e-5 * scale)  # measured 4.6e-6
    np.testing.assert_allclose(amg.state.p, ref.state.p, rtol=0, atol=2e-6 * np.abs(ref.state.p).max())
    if gas:
        np.testing.assert_allclose(amg.state.p_f, ref.state.p_f, rtol=0, atol=2e-6 * np.abs(ref.state.p_f).max())


def test_unknown_linear_solver_is_rejected():
    g = Grid(nx=4, nz=3, Lx=1.0, Lz=1.0)
    with pytest.raises(GranflowInputError, match="nope"):
        Model(g, make_closure("mu_i"), linear_solver="nope")


def test_amg_path_reports_krylov_iterations():
    sim = run("amg", None)
    assert sim.totals.linear_iterations >= sim.totals.picard_iterations  # >= 1 Krylov step per solve
    assert run("direct", None).totals.linear_iterations == 0


@pytest.mark.parametrize(("nx", "nz", "expected"), [(40, 15, "direct"), (120, 60, "amg")])
def test_auto_picks_the_solver_by_size(nx, nz, expected, monkeypatch):
    """Without the optional PARDISO (tests/integration/test_pardiso.py covers "auto" with it)."""
    monkeypatch.setattr(gm, "pardiso_available", lambda: False)
    g = Grid(nx=nx, nz=nz, Lx=0.4, Lz=0.15)
    unknowns = g.n_unknowns + g.n_cells
    assert (unknowns >= AUTO_AMG_UNKNOWNS) == (expected == "amg")
    no_band = {"velocity_band": 0}  # the size rule applies to the whole-grid systems
    assert Model(g, make_closure("mu_i"), linear_solver="auto", ambient=no_band).linear_solver_name == expected
    # with the velocity band (default) the systems are those of the band: direct up to a size
    assert Model(g, make_closure("mu_i"), linear_solver="auto").linear_solver_name == "direct"
    big = Grid(nx=320, nz=320, Lx=1.0, Lz=1.0)
    assert big.n_unknowns + big.n_cells >= gm.AUTO_BANDED_DIRECT_UNKNOWNS
    assert Model(big, make_closure("mu_i"), linear_solver="auto").linear_solver_name == "amg"


def test_case_file_selects_the_linear_solver_and_periodic_grid():
    from granflow.cases.common import make_model
    from granflow.config import CaseConfig

    cfg = CaseConfig.from_dict({"case": {"name": "static_layer"}, "grid": {"nx": 8, "nz": 4, "periodic_x": True},
                                "numerics": {"linear_solver": "amg"}})
    model = make_model(cfg)
    assert model.linear_solver_name == "amg" and model.grid.periodic_x
    # a tilted periodic layer (an infinite incline) starts to flow: AMG and LU agree on the first step
    g = model.grid
    phi = np.where(g.cell_coords()[1] < 0.05, PHI_MAX, 0.0)
    states = []
    for solver in ("amg", "direct"):
        m = Model(g, make_closure("mu_i"), gravity=(9.81 * np.sin(0.5), -9.81 * np.cos(0.5)), linear_solver=solver)
        state = m.initial_state(phi)
        assert not m.advance(state, 1e-3).failed
        states.append(state)
    assert np.abs(states[1].vel).max() > 1e-4
    np.testing.assert_allclose(states[0].vel, states[1].vel, rtol=0, atol=1e-5 * np.abs(states[1].vel).max())
    with pytest.raises(GranflowInputError, match="numerics.linear_solver"):
        CaseConfig.from_dict({"case": {"name": "static_layer"}, "numerics": {"linear_solver": "lu"}})
