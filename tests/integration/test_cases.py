"""The case registry: every case builds a runnable Simulation; the case options reach the model;
initial states against closed forms (cell fractions of a rectangle, lithostatic pressure
phi rho_s g (H - z) written here, MODEL.md §2 at rest)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr

from granflow.cases import CASES
from granflow.cli import ExitCode, main
from granflow.config import CaseConfig
from granflow.grid import VelocityBC
from granflow.simulation import Simulation

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
SMALL = {"grid": {"nx": 16, "nz": 6, "Lx": 0.4, "Lz": 0.15}, "time": {"stop_time": 0.003}}
STEPS = 3


def config(name: str, **sections) -> CaseConfig:
    data = {"case": {"name": name}, **SMALL}
    data.update(sections)
    return CaseConfig.from_dict(data)


@pytest.mark.parametrize("name", CASES.names())
def test_every_registered_case_builds_and_runs(name):
    """Parametrised over the registry: a new case is tested the day it is registered."""
    cfg = config(name)
    sim = CASES.get(name).setup(cfg)
    assert isinstance(sim, Simulation)
    assert (sim.model.grid.nx, sim.model.grid.nz) == (16, 6)
    sim.run()
    assert sim.state.step == STEPS and sim.state.t == pytest.approx(0.003, rel=1e-12)
    assert sim.state.is_finite()
    assert isinstance(CASES.get(name).diagnostics(sim, cfg), dict)
    assert CASES.get(name).summary


def test_case_options_reach_the_model_and_the_simulation():
    cfg = config("column_collapse",
                 closure={"name": "mu_i", "mu1": 0.4},
                 material={"d": 1e-4, "rho_s": 2600.0},
                 gravity={"g": 9.0, "slope_deg": 10.0},
                 walls={"bottom": "free_slip", "west": "no_slip"},
                 numerics={"eps": 2e-3, "advection": "muscl", "picard": {"max_sweeps": 7},
                           "ambient": {"phi_c": 0.25}},
                 time={"stop_time": 0.2, "cfl": 0.2, "dt_max": 5e-4, "max_retries": 3})
    sim = CASES.get("column_collapse").setup(cfg)
    m = sim.model
    assert m.closure.name == "mu_i" and m.closure.mu1 == 0.4
    assert m.material.d == 1e-4 and m.material.rho_s == 2600.0
    th = math.radians(10.0)
    assert m.gravity == pytest.approx((9.0 * math.sin(th), -9.0 * math.cos(th)), rel=1e-15)
    assert m.ops.bcs.bottom is VelocityBC.FREE_SLIP and m.ops.bcs.west is VelocityBC.NO_SLIP
    assert m.eps == 2e-3 and m.advection.value == "muscl"
    assert m.picard.max_sweeps == 7 and m.ambient.phi_c == 0.25
    assert (sim.stop_time, sim.cfl, sim.dt_max, sim.max_retries) == (0.2, 0.2, 5e-4, 3)


def test_column_fills_cut_cells_by_their_covered_area():
    """H0 = 2.4 cells, L0 = 1.5 cells of 25 mm: fractions 1, 0.5 (x) and 1, 1, 0.4 (z)."""
    cfg = config("column_collapse", setup={"H0": 0.06, "L0": 0.0375, "phi0": 0.55})
    phi = CASES.get("column_collapse").setup(cfg).state.phi
    expected = np.zeros((16, 6))
    expected[0, :3] = 0.55 * np.array([1.0, 1.0, 0.4])
    expected[1, :3] = 0.55 * 0.5 * np.array([1.0, 1.0, 0.4])
    np.testing.assert_allclose(phi, expected, rtol=1e-13, atol=1e-15)
    assert phi.sum() * 0.025 * 0.025 == pytest.approx(0.55 * 0.06 * 0.0375, rel=1e-13)


def test_column_initial_pressure_is_lithostatic():
    """Whole-cell column (H0 = 4 cells): p = phi0 rho_s g (H0 - z) at the cell centres."""
    cfg = config("column_collapse", setup={"H0": 0.1, "L0": 0.1})
    st = CASES.get("column_collapse").setup(cfg).state
    z = (np.arange(6) + 0.5) * 0.025
    p_ref = np.where(z < 0.1, 0.6 * 2500.0 * 9.81 * (0.1 - z), 0.0)
    np.testing.assert_allclose(st.p[:4], np.tile(p_ref, (4, 1)), rtol=1e-12, atol=1e-9)
    assert not st.p[4:].any() and not st.p_f.any() and not st.vel.any()


def test_static_layer_case_keeps_rest_and_lithostatic_pressure(tmp_path, capsys):
    """The example file through the CLI: 7 whole cells of phi_max, mu(I), 50 steps. Bounds as in
    tests/integration/test_solver_dry.py: |p - phi rho_s g (H - z)| <= 1e-9 max p in the layer (solver
    round-off), speeds <= 1e-3 eps H (the exact discrete solution is at rest)."""
    out = tmp_path / "static"
    code = main(["run", str(ROOT / "examples" / "static_layer.toml"), "--out", str(out), "--quiet"])
    capsys.readouterr()
    assert code == ExitCode.OK
    H, eps = 0.07, 5e-3
    with xr.open_dataset(out / "output.nc") as ds:
        z = ds["z"].values
        p_ref = np.where(z < H, 0.6 * 2500.0 * 9.81 * (H - z), 0.0)
        last = ds.isel(time=-1)
        assert float(ds["time"][-1]) == pytest.approx(0.05, abs=1e-12)
        assert np.max(np.abs(last["p"].transpose("x", "z").values - p_ref[None, :])) <= 1e-9 * p_ref.max()
        assert np.max(np.hypot(last["u"].values, last["w"].values)) <= 1e-3 * eps * H
    s = json.loads((out / "summary.json").read_text())
    assert s["case_diagnostics"]["pressure_rel_error"] <= 1e-9
    assert s["t_rest"] == 0.0 and s["runout_m"] == 0.0
    assert s["final_height_at_wall"] == pytest.approx(H, rel=1e-12)


def test_fluidised_column_starts_at_b0_times_lithostatic(tmp_path, capsys):
    """b0 = 0.5 with [gas]: p_f(t = 0) = b0 phi0 rho_s g (H0 - z) in the column."""
    out = tmp_path / "fl"
    argv = ["run", str(ROOT / "examples" / "column_collapse_dry.toml"), "--out", str(out), "--quiet",
            "--set", "grid.nx=16", "--set", "grid.nz=6", "--set", "time.stop_time=0.003",
            "--set", "setup.b0=0.5", "--set", 'gas.law="linear"']
    code = main(argv)
    err = capsys.readouterr().err
    assert code == ExitCode.OK, err
    with xr.open_dataset(out / "output.nc") as ds:
        z = ds["z"].values
        p_f0 = ds["p_f"].isel(time=0).transpose("x", "z").values
    ref = 0.5 * 0.6 * 2500.0 * 9.81 * (0.1 - z[z < 0.1])
    np.testing.assert_allclose(p_f0[:4, z < 0.1], np.tile(ref, (4, 1)), rtol=1e-12)
    assert not p_f0[4:].any()

