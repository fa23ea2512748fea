"""The isochoric interface band (Model(isochoric_interface=1), docs/solver.md "Free surface"):
partial cells next to the ambient stop following the closure's dilatancy law, so that a dry
deposit comes to rest instead of carrying a perpetual surface film.

The band belongs to the v1 threshold surface (the indicator surface of scheme v2, the default
since 180fbc3, does not use ``isochoric_interface``): its test pins ``surface="threshold",
advection="upwind"``. The matching v2 property -- the same deposit comes to rest under the
defaults -- is checked by ``test_indicator_surface_brings_the_dry_deposit_to_rest``.

Measured on this 20 x 8 collapse (5 cm DP column, 0.8 s): phi-weighted rms speed of the granular
faces 4.2e-3 m/s with the band against 2.09e-2 m/s without (re-measured with the v1 schemes
pinned, 3 Dec 2026); with the band the front (one-cell
deposit threshold) stays at 0.08 m from t = 0.4 s (through ``granflow run``, without the band it
flickers between 0.08 and 0.13 m as the surface film feeds the toe).
"""
from __future__ import annotations

import numpy as np
import pytest

from granflow import diagnostics as dg
from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.model import Model
from granflow.rheology import make_closure
from granflow.simulation import Simulation, TimeInterval
from _scripts import ROOT  # the repository (tests/ holds tiers)

PHI_MAX = 0.6


def rms_speed(model, state) -> float:
    phi_f = model.ops.cell_to_face @ state.phi.ravel()
    faces = phi_f >= model.ambient.phi_c
    return float(np.sqrt(np.sum(phi_f[faces] * state.vel[faces] ** 2) / np.sum(phi_f[faces])))


V1 = dict(surface="threshold", advection="upwind", picard={"max_sweeps": 4})
"""The schemes the band belongs to, with the Picard cap of v1 (4; the default is 10 since
session 12): with 10 sweeps this one-cell front reaches 0.09 m at 0.4-0.5 s and settles back to
0.08 m from 0.6 s (a one-cell retreat of the threshold front as the film settles)."""


def collapse(isochoric: int | None, stop_time: float = 0.8):
    """The 20 x 8 collapse with the v1 schemes and ``isochoric_interface=isochoric``, or with
    the defaults (scheme v2) if ``isochoric`` is None."""
    g = Grid(nx=20, nz=8, Lx=0.2, Lz=0.075)
    X, Z = g.cell_coords()
    options = {} if isochoric is None else dict(V1, isochoric_interface=isochoric)
    model = Model(g, make_closure("drucker_prager", material={"d": 70e-6}, delta_deg=26.74), **options)
    phi0 = np.where((X < 0.05) & (Z < 0.05), PHI_MAX, 0.0)
    sim = Simulation(model, model.initial_state(phi0), stop_time=stop_time)
    fronts = []
    sim.add_callback(lambda s: fronts.append(dg.front_position(g, s.state.phi, PHI_MAX, g.dz)),
                     TimeInterval(0.1))
    sim.run()
    return model, sim, np.array(fronts), dg.mass(g, phi0)


def test_isochoric_band_brings_the_dry_deposit_to_rest():
    """v1 schemes pinned (threshold surface, upwind advection): the band is a v1 device."""
    runs = {iso: collapse(iso) for iso in (0, 1)}
    rms = {iso: rms_speed(m, s.state) for iso, (m, s, _, _) in runs.items()}
    model, sim, fronts, m0 = runs[1]
    print(f"\nrms speed at 0.8 s: band {rms[1]:.2e} m/s, closure everywhere {rms[0]:.2e} m/s; "
          f"fronts with the band {fronts}")
    assert rms[1] <= 0.4 * rms[0]                       # measured 0.20
    assert rms[1] <= 2.0 * 10 * model.eps * model.grid.Lz  # twice the default rest speed 3.75e-3
    assert np.ptp(fronts[len(fronts) // 2:]) == 0.0     # the front has stopped
    assert fronts[-1] > 0.05 + model.grid.dx            # ... after spreading
    assert abs(dg.mass(model.grid, sim.state.phi) + sim.totals.clipped_mass - m0) <= 1e-12 * m0


def test_indicator_surface_brings_the_dry_deposit_to_rest():
    """Scheme v2 (the defaults: indicator surface, consistent advection), no band: the same
    collapse is at rest by 0.6 s. Measured: rms speed 7.7e-5 m/s at 0.6 s (7.6e-5 at 0.8 s; v1
    with the band 4.2e-3 at 0.8 s), the front at 0.09 m from t = 0.2 s, no clipped or added mass, no rejected step."""
    model, sim, fronts, m0 = collapse(None, stop_time=0.6)
    rms = rms_speed(model, sim.state)
    print(f"\nv2: rms speed at 0.6 s {rms:.2e} m/s; fronts {fronts}")
    assert model.indicator and sim.n_rejected == 0
    assert rms <= 0.1 * 10 * model.eps * model.grid.Lz   # a tenth of the default rest speed
    assert np.ptp(fronts[len(fronts) // 2:]) == 0.0
    assert fronts[-1] > 0.05 + model.grid.dx
    tot = sim.totals
    assert abs(dg.mass(model.grid, sim.state.phi) + tot.clipped_mass - tot.added_mass - m0) <= 1e-12 * m0


@pytest.mark.parametrize("bad", [-1, 3, 1.5, True])
def test_isochoric_band_width_is_checked(bad):
    with pytest.raises(GranflowInputError, match="isochoric_interface"):
        Model(Grid(nx=4, nz=3, Lx=1.0, Lz=1.0), make_closure("mu_i"), isochoric_interface=bad)


def test_run_ends_once_at_rest(tmp_path):
    """``time.stop_at_rest``: the run ends (status completed) once the rms granular speed has
    stayed below ``output.rest_speed`` (here 1e-2 m/s) for that long (measured: rest at
    t = 0.425 s, end at 0.475 s instead of stop_time = 1 s)."""
    import json

    from granflow.cli import main

    example = ROOT / "examples" / "column_collapse_dry.toml"
    small = ["setup.H0=0.05", "setup.L0=0.05", "grid.Lx=0.2", "grid.Lz=0.075", "grid.nx=20",
             "grid.nz=8", "time.stop_time=1.0", "time.stop_at_rest=0.05", "output.rest_speed=0.01"]
    out = tmp_path / "run"
    argv = ["run", str(example), "--out", str(out), "--quiet"]
    for item in small:
        argv += ["--set", item]
    assert main(argv) == 0
    s = json.loads((out / "summary.json").read_text())
    print(f"\nt_rest {s['t_rest']}, t_final {s['t_final']}")
    assert s["status"] == "completed" and s["stopped_at_rest"] is True
    assert s["t_rest"] is not None and s["t_final"] < 1.0
    assert s["t_final"] - s["t_rest"] == pytest.approx(0.05, abs=1.5e-3)  # one dt_max = 1e-3
