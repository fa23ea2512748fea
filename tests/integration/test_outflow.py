"""Outflow east wall (issue 14 item 2; granflow.physics.outflow): grains leave the box through
an absorbing last column, their volume and energy counted in the budgets.

Independent references: the mass identity M(t) + M_out(t) = M(0) (exact sums); the closed box
with a free-slip east wall, which the outflow box must reproduce bit for bit until grains reach
its last column (the solve is the same); the potential energy -rho_s sum phi (g . x) dV, the
face inertia and the LOG gas energy (1 - phi)[(p_atm + p) ln(1 + p/p_atm) - p] written out here;
the exact identity "numerical terms sum to the residual" of the energy budget.
"""
from __future__ import annotations

import json

import netCDF4
import numpy as np
import pytest

from granflow import diagnostics as dg
from granflow.cli import ExitCode, main
from granflow.errors import GranflowInputError
from granflow.grid import Grid, VelocityBCs
from granflow.model import Model
from granflow.physics import outflow
from granflow.physics.pore_pressure import GasLaw
from granflow.rheology import make_closure
from granflow.simulation import IterationInterval, Simulation

from _scripts import ROOT  # noqa: E402

PHI_MAX = 0.6
MATERIAL = dict(d=70e-6, rho_s=2500.0, phi_max=PHI_MAX)
SLOPE = np.deg2rad(20.0)
GRAVITY = (9.81 * np.sin(SLOPE), -9.81 * np.cos(SLOPE))


def _model(east: str, gas=None) -> Model:
    closure = make_closure("drucker_prager", material=MATERIAL, delta_deg=26.74)
    return Model(Grid(nx=24, nz=8, Lx=0.24, Lz=0.08), closure, gravity=GRAVITY,
                 bcs=VelocityBCs(east=east), gas=gas)


def _column(model: Model) -> np.ndarray:
    X, Z = model.grid.cell_coords()
    return np.where((X < 0.06) & (Z < 0.05), PHI_MAX, 0.0)


@pytest.fixture(scope="module")
def runs():
    """A 6 x 5 cm column on a 20 deg slope in a 24 cm box, 0.35 s: with an outflow and a
    free-slip east wall; the first step at which grains reach the last column."""
    out = {}
    for east in ("outflow", "free_slip"):
        model = _model(east)
        sim = Simulation(model, model.initial_state(_column(model)), stop_time=0.35)
        states = []
        sim.add_callback(lambda s: states.append((s.state.phi.copy(), s.state.vel.copy())),
                         IterationInterval(1), name="record")
        sim.run()
        out[east] = (model, sim, states)
    return out


def test_mass_out_plus_mass_held_is_the_initial_mass(runs):
    model, sim, states = runs["outflow"]
    g = model.grid
    m0 = dg.mass(g, _column(model))
    out = sum(r.outflow.volume for r in sim.reports)
    held = dg.mass(g, sim.state.phi)
    clipped = sum(r.clipped_mass - r.added_mass for r in sim.reports)
    print(f"\noutflow: {out / m0:.3f} of the mass left, {held / m0:.3f} held, clip {clipped / m0:.1e}")
    assert out / m0 > 0.1                               # a real outflow (0.14), not a trace
    assert sim.totals.outflow_mass == pytest.approx(out, rel=1e-14)
    assert abs(held + out + clipped - m0) <= 1e-12 * m0
    assert all(np.all(phi[-1, :] == 0.0) for phi, _ in states)   # the column is emptied every step
    assert sim.state.phi.min() >= 0.0 and sim.state.phi.max() <= PHI_MAX


def test_the_box_is_the_free_slip_box_until_grains_reach_the_last_column(runs):
    _, sim_o, states_o = runs["outflow"]
    _, _, states_w = runs["free_slip"]
    assert len(states_o) == len(sim_o.reports) + 1          # states[0]: the initial state
    first = 1 + next(k for k, r in enumerate(sim_o.reports) if r.outflow.volume > 0)
    assert first > 10
    for k in range(first):
        assert np.array_equal(states_o[k][0], states_w[k][0]) and np.array_equal(states_o[k][1], states_w[k][1])
    assert not np.array_equal(states_o[first][0], states_w[first][0])
    # behind the wall the grains pile up; through the outflow they leave
    assert dg.mass(runs["free_slip"][0].grid, runs["free_slip"][1].state.phi) > dg.mass(
        runs["outflow"][0].grid, sim_o.state.phi)


def test_energy_budget_counts_the_outflow_and_still_splits_exactly(runs):
    _, sim, _ = runs["outflow"]
    b = sim.budget
    assert np.isclose(sum(b.numerical.values()), b.residual, rtol=1e-10, atol=1e-12 * b.released)
    # what left did so from the last column (centre x_e), somewhere in 0 < z < Lz: its potential
    # energy per unit volume, -rho_s (g_x x_e + g_z z), lies between those of z = 0 and z = Lz
    g = runs["outflow"][0].grid
    v_out = sum(r.outflow.volume for r in sim.reports)
    e_out = sum(r.outflow.potential for r in sim.reports) / v_out
    low = -2500.0 * GRAVITY[0] * g.xc[-1]
    assert low < e_out < low - 2500.0 * GRAVITY[1] * g.Lz
    assert b.released > 0
    closed = runs["free_slip"][1].budget
    print(f"\nresidual/released: outflow {b.relative_residual:+.3f}, closed {closed.relative_residual:+.3f}")
    assert abs(b.relative_residual) < 0.5


def test_absorb_against_the_formulas_written_out_here():
    gas = GasLaw.LINEAR
    model = _model("outflow", gas=gas)
    g = model.grid
    rng = np.random.default_rng(5)
    phi = rng.uniform(0.0, PHI_MAX, g.cell_shape)
    c = np.clip(phi / PHI_MAX + 0.05, 0.0, 1.0)
    vel = rng.normal(size=g.n_unknowns)
    p_f = rng.uniform(0.0, 2e3, g.n_cells)
    phi2, c2, pf2, got = outflow.absorb(model, phi, c, vel, p_f)
    dV = g.cell_volume
    assert np.all(phi2[-1] == 0) and np.all(c2[-1] == 0) and np.all(pf2.reshape(g.cell_shape)[-1] == 0)
    assert np.array_equal(phi2[:-1], phi[:-1]) and np.array_equal(c2[:-1], c[:-1])
    assert got.volume == pytest.approx(phi[-1].sum() * dV, rel=1e-14)
    x_e, z = g.xc[-1], g.zc
    e_p = -2500.0 * dV * np.sum(phi[-1] * (GRAVITY[0] * x_e + GRAVITY[1] * z))
    assert got.potential == pytest.approx(e_p, rel=1e-13)
    rho = lambda f: model.inertia_density(f)  # noqa: E731  (the model's face inertia)
    assert got.kinetic == pytest.approx(0.5 * dV * np.sum((rho(phi) - rho(phi2)) * vel**2), rel=1e-12)
    pa = model.material.p_atm
    p = p_f.reshape(g.cell_shape)[-1]
    psi = phi[-1] / c[-1]
    e_1 = np.sum((1 - psi) * ((pa + p) * np.log1p(p / pa) - p)) * dV
    assert got.gas == pytest.approx(e_1, rel=1e-10)
    empty = phi.copy()
    empty[-1] = 0.0
    c0 = c.copy()
    c0[-1] = 0.0
    same = outflow.absorb(model, empty, c0, vel, p_f)
    assert same[0] is empty and same[3] is outflow.NOTHING


def test_outflow_is_an_east_wall_condition_only():
    with pytest.raises(GranflowInputError, match="east-wall condition only.*'west'"):
        VelocityBCs(west="outflow")
    with pytest.raises(GranflowInputError, match="periodic"):
        Model(Grid(nx=4, nz=3, Lx=1.0, Lz=1.0, periodic_x=True),
              make_closure("drucker_prager", material=MATERIAL, delta_deg=26.74), bcs=VelocityBCs(east="outflow"))


ARGS = ["--quiet", "--set", "grid.nx=12", "--set", "grid.nz=6", "--set", "grid.Lx=0.15", "--set", "grid.Lz=0.15",
        "--set", "output.figures=false", "--set", "walls.east=outflow"]


def test_a_run_through_the_outflow_says_so_and_survives_a_restart(tmp_path, capsys):
    """summary (outflow_mass, mass_rel_error, wall_contact, warning), output.nc flags; a restart
    from t = 0.2 s continues the outflow totals bit-identically with the straight run."""
    case = str(ROOT / "examples" / "column_collapse_dry.toml")
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert main(["run", case, "--out", str(straight), *ARGS, "--set", "time.stop_time=0.3"]) == ExitCode.OK
    s = json.loads((straight / "summary.json").read_text())
    assert 0.05 < s["outflow_mass"] < 1.0
    assert abs(s["mass_rel_error"]) < 1e-12
    assert "east_outflow" in s["wall_contact"] and "east_wall" not in s["wall_contact"]
    assert any("left the box through the east outflow" in w for w in s["warnings"])
    assert "granflow: warning: grains left the box" in capsys.readouterr().err
    with netCDF4.Dataset(straight / "output.nc") as ds:
        assert ds.getncattr("reached_east_outflow") == 1 and ds.getncattr("reached_east_wall") == 0
        gone = ds["outflow_volume"][:]        # the column held 0.1 x 0.1 m at phi 0.6
        assert ds["outflow_volume"].units == "m2" and np.all(np.diff(gone) >= 0)
        assert gone[-1] == pytest.approx(s["outflow_mass"] * 0.006, rel=1e-12)
        assert "inflow_volume" not in ds.variables
    assert main(["run", case, "--out", str(split), *ARGS, "--set", "time.stop_time=0.2"]) == ExitCode.OK
    assert main(["run", case, "--out", str(split), *ARGS, "--set", "time.stop_time=0.3",
                 "--restart", str(split)]) == ExitCode.OK
    r = json.loads((split / "summary.json").read_text())
    assert r["outflow_mass"] == s["outflow_mass"] and r["energy"] == s["energy"]
    assert r["wall_contact"] == s["wall_contact"]


def test_bad_wall_condition_names_the_key(tmp_path, capsys):
    case = str(ROOT / "examples" / "column_collapse_dry.toml")
    code = main(["run", case, "--out", str(tmp_path / "x"), "--quiet", "--set", "walls.west=outflow"])
    assert code != ExitCode.OK
    assert "walls.west" in capsys.readouterr().err
