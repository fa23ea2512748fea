"""Inflow (source) boundary (issue 14 item 2; granflow.physics.inflow): a prescribed supply of
grains through part of the west wall or of the base, with an outflow wall a sustained current.

Independent references: the supplied volume phi_in speed span t plus the first fill of the source
cells (the supply's definition, computed here); the mass identity M + M_out = M0 + M_in (exact
sums); the run without a source, which a source that is off must reproduce bit for bit; the
steady discharge of a current fed for long enough, out = in; the exact identity "numerical terms
sum to the residual" of the energy budget.
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
from granflow.model import Model, StepStatus
from granflow.physics.inflow import Source
from granflow.physics.pore_pressure import GasLaw
from granflow.rheology import make_closure
from granflow.simulation import Simulation

from _scripts import ROOT  # noqa: E402

PHI_MAX = 0.6
SPLIT_TOL = 1e-7
"""The energy split is exact but for round-off; the penalty lambda ~ 1e12 kg m^-3 s^-1 of the
source's faces multiplies the round-off of u_in - u (measured: 1e-9 of 0.44 J/m of source work)."""
MATERIAL = dict(d=70e-6, rho_s=2500.0, phi_max=PHI_MAX)


def _closure():
    return make_closure("drucker_prager", material=MATERIAL, delta_deg=26.74)


def _gravity(deg: float) -> tuple[float, float]:
    return 9.81 * np.sin(np.deg2rad(deg)), -9.81 * np.cos(np.deg2rad(deg))


def _run(source: Source | None, slope: float = 15.0, stop: float = 0.15, east: str = "free_slip",
         nx: int = 30, gas=None, phi0=None):
    g = Grid(nx=nx, nz=10, Lx=0.01 * nx, Lz=0.1)
    model = Model(g, _closure(), gravity=_gravity(slope), source=source, bcs=VelocityBCs(east=east), gas=gas)
    sim = Simulation(model, model.initial_state(np.zeros(g.cell_shape) if phi0 is None else phi0), stop_time=stop)
    sim.run()
    return model, sim


@pytest.mark.parametrize("side", ["west", "bottom"])
def test_the_supply_is_the_prescribed_flux_and_mass_is_booked(side):
    src = Source(side=side, lower=0.0, upper=0.03, phi=0.55, speed=0.3)
    model, sim = _run(src)
    g = model.grid
    mask, target = src.faces(g)
    assert np.count_nonzero(target[mask]) == 3                      # three cells, their faces at speed
    assert np.allclose(sim.state.vel[mask], target[mask], rtol=0, atol=1e-5 * src.speed)
    supplied = sum(r.inflow.volume for r in sim.reports)
    first_fill = 3 * src.phi * g.cell_volume
    expected = first_fill + src.phi * src.speed * 0.03 * sim.state.t
    print(f"\n{side}: supplied {supplied:.4e} m^2, expected {expected:.4e} m^2")
    assert supplied == pytest.approx(expected, rel=0.02)
    assert sim.totals.inflow_mass == pytest.approx(supplied, rel=1e-14)
    assert abs(dg.mass(g, sim.state.phi) - supplied) <= 1e-12 * supplied
    b = sim.budget
    assert b.source_work > 0 and b.inflow_mechanical > 0
    assert np.isclose(sum(b.numerical.values()), b.residual, rtol=0, atol=SPLIT_TOL * b.source_work)
    assert sim.state.phi.min() >= 0.0 and sim.state.phi.max() <= PHI_MAX


def test_a_source_that_is_off_changes_nothing_and_stops_on_time():
    g = Grid(nx=30, nz=10, Lx=0.3, Lz=0.1)
    X, Z = g.cell_coords()
    pile = np.where((X < 0.05) & (Z < 0.04), PHI_MAX, 0.0)
    _, plain = _run(None, stop=0.05, phi0=pile)
    _, later = _run(Source(side="west", lower=0.0, upper=0.03, phi=0.55, speed=0.3, start=0.2),
                    stop=0.05, phi0=pile)
    assert np.array_equal(plain.state.phi, later.state.phi) and np.array_equal(plain.state.vel, later.state.vel)
    assert later.totals.inflow_mass == 0.0
    _, short = _run(Source(side="west", lower=0.0, upper=0.03, phi=0.55, speed=0.3, stop=0.05), stop=0.1)
    fed = [r.inflow.volume for r in short.reports]
    on = [r.inflow.volume for r, t in zip(short.reports, np.cumsum([r.dt for r in short.reports])) if t > 0.051]
    assert sum(fed) > 0 and on and max(np.abs(on)) == 0.0


def test_a_steep_sustained_current_reaches_a_steady_discharge():
    """A supply on a 30 deg slope (steeper than the friction angle) through an outflow box: after
    the transient (the front leaves at 0.2 s; measured 3 Dec 2026: out/in 0.89 at 0.6 s, 0.99 at
    1.1 s, 0.99995 from 1.3 s), the discharge out of the box equals the supply."""
    src = Source(side="west", lower=0.0, upper=0.02, phi=0.55, speed=0.4)
    model, sim = _run(src, slope=30.0, stop=1.5, east="outflow", nx=20)
    g = model.grid
    t = np.cumsum([r.dt for r in sim.reports])
    late = t > 1.3
    out_rate = sum(r.outflow.volume for r, k in zip(sim.reports, late) if k) / (t[-1] - t[~late][-1])
    in_rate = sum(r.inflow.volume for r, k in zip(sim.reports, late) if k) / (t[-1] - t[~late][-1])
    print(f"\nsteady current: in {in_rate:.4e} m^2/s, out {out_rate:.4e} m^2/s, supply {src.flux(g):.4e}")
    assert in_rate == pytest.approx(src.phi * src.speed * 0.02, rel=1e-6)   # two 1 cm cells
    assert out_rate == pytest.approx(in_rate, rel=1e-3)                       # measured 5e-5
    held = dg.mass(g, sim.state.phi)
    assert abs(held + sim.totals.outflow_mass - sim.totals.inflow_mass) <= 1e-12 * sim.totals.inflow_mass
    b = sim.budget
    assert np.isclose(sum(b.numerical.values()), b.residual, rtol=0, atol=SPLIT_TOL * b.source_work)


def test_a_span_that_is_not_cell_aligned_supplies_its_cells():
    """[0, 0.025] on 1 cm cells holds three cell centres (0.005, 0.015, 0.025): the supply is
    phi speed 3 dz, not phi speed 0.025."""
    src = Source(side="west", lower=0.0, upper=0.025, phi=0.55, speed=0.3)
    model, sim = _run(src, stop=0.1)
    g = model.grid
    assert src.flux(g) == pytest.approx(0.55 * 0.3 * 0.03, rel=1e-14)
    supplied = sum(r.inflow.volume for r in sim.reports) - 3 * src.phi * g.cell_volume   # less the first fill
    assert supplied / sim.state.t == pytest.approx(src.flux(g), rel=0.02)


@pytest.mark.parametrize("advection", ["upwind", "muscl"])
def test_the_energy_split_holds_with_the_v1_momentum_schemes(advection):
    src = Source(side="west", lower=0.0, upper=0.03, phi=0.55, speed=0.3)
    g = Grid(nx=20, nz=8, Lx=0.2, Lz=0.08)
    model = Model(g, _closure(), gravity=_gravity(15.0), source=src, advection=advection)
    sim = Simulation(model, model.initial_state(np.zeros(g.cell_shape)), stop_time=0.05)
    sim.run()
    b = sim.budget
    assert np.isclose(sum(b.numerical.values()), b.residual, rtol=0, atol=SPLIT_TOL * b.source_work)


def test_a_supply_into_a_gas_model_keeps_the_gas_books():
    """The source's cells hold gas at atmospheric pressure (no gas row): p_f = 0 there, and the
    gas budget's terms still sum to its residual."""
    src = Source(side="west", lower=0.0, upper=0.03, phi=0.55, speed=0.3)
    g = Grid(nx=30, nz=10, Lx=0.3, Lz=0.1)
    X, Z = g.cell_coords()
    bed = np.where((X > 0.05) & (X < 0.15) & (Z < 0.04), PHI_MAX, 0.0)
    model, sim = _run(src, stop=0.05, gas=GasLaw.LINEAR, phi0=bed)
    b = sim.budget
    assert np.all(sim.state.p_f[0, :3] == 0.0)
    assert np.isclose(sum(b.numerical.values()), b.residual, rtol=0, atol=SPLIT_TOL * b.source_work)
    assert np.isclose(b.residual_gas, sum(v for k, v in b.numerical.items() if k.startswith("gas_")),
                      rtol=1e-8, atol=1e-12)


def test_a_failed_step_leaves_the_state_alone():
    """The refill is part of the step: a step that fails leaves phi, c and p_f as they were
    (the retry then books the refill once)."""
    src = Source(side="west", lower=0.0, upper=0.03, phi=0.55, speed=0.3, start=0.0)
    g = Grid(nx=10, nz=6, Lx=0.1, Lz=0.06)
    model = Model(g, _closure(), source=src, gas=GasLaw.LINEAR)
    X, Z = g.cell_coords()
    state = model.initial_state(np.where((X > 0.03) & (Z < 0.03), PHI_MAX, 0.0))
    state.p_f = np.where(X > 0.03, 50.0, 0.0) * (Z < 0.03)
    state.c = model.material_of(state.phi)
    kept = [a.copy() for a in (state.phi, state.c, state.p_f, state.vel)]
    report = model.advance(state, 1.0)           # CFL 3: fails
    assert report.status is StepStatus.FAILED
    for a, b in zip(kept, (state.phi, state.c, state.p_f, state.vel)):
        assert np.array_equal(a, b)
    assert state.t == 0.0 and state.step == 0


def test_bad_sources_are_refused_with_the_key():
    clo = _closure()
    with pytest.raises(GranflowInputError, match="periodic"):
        Model(Grid(nx=4, nz=3, Lx=1.0, Lz=1.0, periodic_x=True), clo,
              source=Source(side="west", lower=0.0, upper=0.5, phi=0.5, speed=0.1))
    with pytest.raises(GranflowInputError, match="inflow.phi"):
        Model(Grid(nx=4, nz=3, Lx=1.0, Lz=1.0), clo, source=Source(side="west", lower=0.0, upper=0.5,
                                                                  phi=0.7, speed=0.1))
    with pytest.raises(GranflowInputError, match="beyond the west side"):
        Model(Grid(nx=4, nz=4, Lx=1.0, Lz=1.0), clo, source=Source(side="west", lower=0.0, upper=1.5,
                                                                  phi=0.5, speed=0.1))
    with pytest.raises(GranflowInputError, match="no cell centre"):
        Model(Grid(nx=4, nz=4, Lx=1.0, Lz=1.0), clo, source=Source(side="bottom", lower=0.0, upper=0.1,
                                                                  phi=0.5, speed=0.1))
    with pytest.raises(GranflowInputError, match="speed"):
        Source(side="west", lower=0.0, upper=0.5, phi=0.5, speed=0.0)


@pytest.mark.parametrize("sets, key", [
    (["inflow.speed=0.2"], "inflow.speed is set but inflow.side is"),
    (["inflow.side=west", "inflow.speed=0.2"], "needs inflow.upper"),
    (["inflow.side=west", "inflow.upper=0.02"], "needs inflow.speed"),
    (["inflow.side=west", "inflow.upper=0.02", "inflow.speed=0.2", "inflow.phi=0.7"], "inflow.phi"),
    (["inflow.side=bottom", "inflow.upper=0.3", "inflow.speed=0.2", "inflow.lower=0.35"], "inflow.lower"),
    (["inflow.side=west", "inflow.upper=0.02", "inflow.speed=0.2", "inflow.start=5"], "inflow.start"),
])
def test_case_file_errors_name_the_key(tmp_path, capsys, sets, key):
    argv = ["run", str(ROOT / "examples" / "column_collapse_dry.toml"), "--out", str(tmp_path / "x"), "--quiet"]
    for item in sets:
        argv += ["--set", item]
    assert main(argv) != ExitCode.OK
    assert key in capsys.readouterr().err


def test_stop_at_rest_waits_for_a_delayed_source(tmp_path, capsys):
    """The column is at rest by 0.5 s; a source that starts at 0.6 s must still run."""
    argv = ["run", str(ROOT / "examples" / "column_collapse_dry.toml"), "--out", str(tmp_path / "d"), "--quiet",
            "--set", "grid.nx=20", "--set", "grid.nz=8", "--set", "output.figures=false",
            "--set", "inflow.side=west", "--set", "inflow.upper=0.03", "--set", "inflow.speed=0.2",
            "--set", "inflow.start=0.6", "--set", "inflow.stop=0.65", "--set", "time.stop_time=1.0"]
    assert main(argv) == ExitCode.OK, capsys.readouterr().err
    s = json.loads((tmp_path / "d" / "summary.json").read_text())
    assert s["t_final"] > 0.65 and s["inflow_mass"] > 0.0


def test_the_example_case_books_the_supply_and_restarts_bit_identically(tmp_path, capsys):
    """summary and output.nc (inflow_volume, the run total) of the example on a small grid; a
    restart from t = 0.1 s ends where the straight run ends."""
    args = ["--quiet", "--set", "output.figures=false", "--set", "grid.nx=25", "--set", "grid.Lx=0.25",
            "--set", "grid.nz=8", "--set", "grid.Lz=0.08", "--set", "output.interval=0.05"]
    case = str(ROOT / "examples" / "sustained_current.toml")
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert main(["run", case, "--out", str(straight), *args, "--set", "time.stop_time=0.15"]) == ExitCode.OK
    s = json.loads((straight / "summary.json").read_text())
    assert s["inflow_mass"] > 0.5 and abs(s["mass_rel_error"]) < 1e-12
    assert s["energy"]["source_work"] > 0 and s["energy"]["inflow"] > 0
    with netCDF4.Dataset(straight / "output.nc") as ds:
        vol = ds["inflow_volume"][:]
        assert ds["inflow_volume"].units == "m2" and np.all(np.diff(vol) > 0)
        assert vol[-1] == pytest.approx(s["inflow_mass"] * 0.03 * 0.03 * 0.55, rel=1e-12)
    assert main(["run", case, "--out", str(split), *args, "--set", "time.stop_time=0.1"]) == ExitCode.OK
    assert main(["run", case, "--out", str(split), *args, "--set", "time.stop_time=0.15",
                 "--restart", str(split)]) == ExitCode.OK
    r = json.loads((split / "summary.json").read_text())
    assert r["inflow_mass"] == s["inflow_mass"] and r["energy"] == s["energy"]
    capsys.readouterr()
