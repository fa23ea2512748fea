"""``gas.compressibility`` (issue 13 item 4): the paper's isothermal gas (default) or an adiabatic
one (gamma = 1.4), i.e. the storage terms of the gas equation divided by the polytropic index n,
so that the pore-pressure diffusivity is D = n p_atm kappa/(1 - phi).

Independent references, written here: the first diffusive mode of a rigid column with an
impermeable base and p_f = 0 at its top, p_f = cos(pi z/(2H)) exp(-t/tau_1),
tau_1 = 4 H^2/(pi^2 D) (Carslaw & Jaeger; docs/model.md §7), with D written out from Carman-Kozeny;
and the Fourier series of the defluidising column with that D.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla

from granflow import GranflowInputError, Material
from granflow.config import load_case
from granflow.gas import AIR_HEAT_CAPACITY_RATIO, GasCompressibility
from granflow.grid import Grid
from granflow.operators import Operators
from granflow.physics.pore_pressure import PorePressureStep, gas_energy, gas_operator
from test_ladder_cases import EXAMPLES, run_example

MAT = Material(d=70e-6)
PHI, H, GAMMA = 0.6, 0.1, 1.4


def diffusivity(n: float) -> float:
    kappa = MAT.d**2 * (1 - PHI) ** 3 / (150 * MAT.eta_f * PHI**2)
    return n * MAT.p_atm * kappa / (1 - PHI)


def first_mode_rate(compressibility: str, nz: int = 40, steps: int = 400) -> tuple[float, float]:
    """(measured, analytic) decay rate [s^-1] of the first mode in a rigid open-top column."""
    n = 1.0 if compressibility == "isothermal" else GAMMA
    g = Grid(nx=2, nz=nz, Lx=2 * H / nz, Lz=H)
    phi = np.full(g.cell_shape, PHI)
    step = PorePressureStep(g, MAT, Operators.build(g), open_top=True, compressibility=compressibility)
    rate = math.pi**2 * diffusivity(n) / (4 * H**2)
    dt = 0.5 / rate / steps
    p0 = np.cos(math.pi * g.zc / (2 * H))[None, :].repeat(2, axis=0)
    p = p0.copy()
    for _ in range(steps):
        p = step(p, phi, dt)
    return -math.log(p[0, 0] / p0[0, 0]) / (steps * dt), rate


def test_gamma_is_air_and_the_default_is_isothermal():
    assert AIR_HEAT_CAPACITY_RATIO == GAMMA
    assert GasCompressibility("isothermal").polytropic_index == 1.0
    assert GasCompressibility("adiabatic").polytropic_index == GAMMA
    cfg = load_case(EXAMPLES / "defluidisation_column.toml")
    assert cfg.gas.compressibility == "isothermal"


@pytest.mark.parametrize("compressibility", ["isothermal", "adiabatic"])
def test_first_mode_decays_at_the_analytic_rate(compressibility):
    """nz = 40, dt = tau_1/800: measured rate within 1e-3 of pi^2 D/(4 H^2), D = n p_atm kappa/(1-phi)
    (measured -7.5e-4 for both: backward Euler and the dz^2 error of the discrete mode)."""
    measured, analytic = first_mode_rate(compressibility)
    print(f"\n{compressibility}: rate {measured:.6f} vs {analytic:.6f} 1/s ({measured / analytic - 1:+.2e})")
    assert measured == pytest.approx(analytic, rel=1e-3)


def test_decay_rates_scale_exactly_by_gamma():
    """The slowest generalised eigenvalue of (diffusion, capacity) of the assembled gas matrix is
    gamma times larger adiabatic (to round-off), and the time-stepped rates are in that ratio
    to the time-discretisation error (dt lambda / 2 = 6e-4 here)."""
    g = Grid(nx=2, nz=30, Lx=2 * H / 30, Lz=H)
    ops, phi = Operators.build(g), np.full(g.cell_shape, PHI)
    lam = {}
    for comp in ("isothermal", "adiabatic"):
        steady = gas_operator(g, ops, phi, math.inf, MAT, open_top=True, compressibility=comp).matrix.toarray()
        timed = gas_operator(g, ops, phi, 1.0, MAT, open_top=True, compressibility=comp).matrix.toarray()
        capacity = timed - steady      # diag((1 - phi)/n) for dt = 1 s
        lam[comp] = sla.eigh(steady, capacity, eigvals_only=True)[0]
    assert lam["adiabatic"] / lam["isothermal"] == pytest.approx(GAMMA, rel=1e-12)
    iso, ad = first_mode_rate("isothermal")[0], first_mode_rate("adiabatic")[0]
    assert ad / iso == pytest.approx(GAMMA, rel=1e-3)


def test_gas_energy_of_the_adiabatic_gas_is_gamma_times_smaller():
    g = Grid(nx=2, nz=4, Lx=0.02, Lz=0.04)
    p = np.linspace(0.0, 500.0, g.n_cells).reshape(g.cell_shape)
    phi = np.full(g.cell_shape, PHI)
    iso = gas_energy(g, phi, p, MAT)
    assert gas_energy(g, phi, p, MAT, polytropic=GAMMA) == pytest.approx(iso / GAMMA, rel=1e-14)


def test_defluidisation_case_adiabatic_half_life_is_gamma_times_shorter(tmp_path):
    """The full solver (defluidisation_column example, nz = 6): adiabatic with dt, stop time and
    output interval divided by gamma is the isothermal run with time divided by gamma, so the
    basal half-life is 1/gamma of the isothermal one (to 1e-9); both follow their Fourier series
    (D 1.4 times larger adiabatic) within the isothermal test's 6e-3 p_f0 and 2 % half-life; the
    energy budget closes as well (|residual| < 5 % of the released gas energy)."""
    common = ["grid.nz=6"]
    iso, _ = run_example("defluidisation_column", tmp_path / "iso", *common, "time.stop_time=0.05",
                         "time.dt_max=1e-3", "output.interval=0.005")
    ad, _ = run_example("defluidisation_column", tmp_path / "ad", *common, "gas.compressibility=adiabatic",
                        f"time.stop_time={0.05 / GAMMA!r}", f"time.dt_max={1e-3 / GAMMA!r}",
                        f"output.interval={0.005 / GAMMA!r}")
    di, da = iso["case_diagnostics"], ad["case_diagnostics"]
    assert da["gas_compressibility"] == "adiabatic" and di["gas_compressibility"] == "isothermal"
    assert da["D_m2_s"] == pytest.approx(diffusivity(GAMMA), rel=1e-12)
    assert di["D_m2_s"] == pytest.approx(diffusivity(1.0), rel=1e-12)
    print(f"\nhalf-lives: isothermal {di['half_life_s']:.6f} s, adiabatic {da['half_life_s']:.6f} s, "
          f"ratio {di['half_life_s'] / da['half_life_s']:.9f}")
    assert di["half_life_s"] / da["half_life_s"] == pytest.approx(GAMMA, rel=1e-9)
    for d in (di, da):
        assert d["max_error_rel"] <= 6e-3 and d["rigid"]
        assert d["half_life_tau_1"] == pytest.approx(0.4854, rel=2e-2)
    assert abs(ad["energy_residual_rel"]) < 0.05


@pytest.mark.parametrize("sets, key", [
    (["gas.compressibility=polytropic"], "gas.compressibility"),
    (["gas.law=nonlinear", "gas.compressibility=adiabatic"], "gas.compressibility"),
])
def test_bad_compressibility_names_the_key(sets, key):
    with pytest.raises(GranflowInputError, match=key):
        load_case(EXAMPLES / "defluidisation_column.toml", sets)


def test_adiabatic_dry_or_nonlinear_is_rejected_by_the_solver_pieces():
    g = Grid(nx=2, nz=4, Lx=0.02, Lz=0.04)
    with pytest.raises(GranflowInputError, match="gas.compressibility"):
        PorePressureStep(g, MAT, gas="nonlinear", compressibility="adiabatic")
    with pytest.raises(GranflowInputError, match="GasCompressibility"):
        PorePressureStep(g, MAT, compressibility="polytropic")
    with pytest.raises(GranflowInputError, match="gas.compressibility"):
        load_case(EXAMPLES / "column_collapse_dry.toml", ["gas.compressibility=adiabatic"])
