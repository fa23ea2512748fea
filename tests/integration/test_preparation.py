"""Gas-injection preparation of ``column_collapse`` (granflow.cases.preparation; issue 4 item 1 b).

Independent references, written here (never values produced by the code under test):
* Darcy's law with the Carman-Kozeny permeability k = d^2 (1-phi)^3 / (150 phi^2) [m^2] and the gas
  viscosity eta_f: q = -(k/eta_f) grad p_f (paper eqs darcy, beta; MODEL.md §1-2). Minimum
  fluidisation when the gas gradient carries the weight (no buoyancy in the model's momentum
  equation): U_mf = (k/eta_f) phi rho_s g cos(slope);
* the steady profile of a uniform bed under base injection U, impermeable base, p_f = 0 at the
  surface: p_f = U eta_f (H - z)/k, hence basal p_f / lithostatic = U/U_mf at the cell centres;
* the lithostatic pressure phi rho_s g (H - z).
Tiny grids: dx = dz = 1 cm, a 2-cell-wide, 4-cell-high bed (gas time tau_1 = 7.9 ms).
"""
from __future__ import annotations

import json
import math

import netCDF4
import numpy as np
import pytest

from granflow.cases import CASES
from granflow.cases import preparation as prep
from granflow.cli import ExitCode, main
from granflow.config import CaseConfig
from granflow.errors import GranflowInputError
from granflow.output import ordered

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLE = ROOT / "examples" / "column_collapse_injected.toml"

D = 70e-6           # grain diameter [m]
RHO_S = 2500.0      # [kg m^-3]
ETA_F = 1.8e-5      # air viscosity [Pa s]
PHI = 0.6           # packing of the poured bed = phi_max [-]
G = 9.81            # [m s^-2]
H0 = 0.04           # bed height, 4 cells [m]
L0 = 0.02           # reservoir width, 2 cells [m]
DZ = 0.01           # cell size [m]


def darcy_u_mf(phi: float, g_normal: float = G) -> float:
    """U_mf from Darcy's law, written out: k/eta_f * phi rho_s g [m s^-1]."""
    k = D**2 * (1 - phi) ** 3 / (150 * phi**2)   # Carman-Kozeny permeability [m^2]
    return k / ETA_F * phi * RHO_S * g_normal


def case(**setup) -> dict:
    base_setup = {"H0": H0, "L0": L0, "preparation": "injection", "prep_max_time": 0.3}
    base_setup.update(setup)
    return {"case": {"name": "column_collapse"}, "setup": base_setup,
            "material": {"d": D, "rho_s": RHO_S, "eta_f": ETA_F, "phi_max": PHI},
            "closure": {"name": "drucker_prager", "delta_deg": 26.74},
            "gas": {"law": "linear"},
            "grid": {"nx": 6, "nz": 6, "Lx": 0.06, "Lz": 0.06},
            "time": {"stop_time": 0.003, "dt_max": 1e-3}}


def config(**setup) -> CaseConfig:
    return CaseConfig.from_dict(case(**setup))


# --- (1) U_mf ---------------------------------------------------------------------------------
def test_minimum_fluidisation_velocity_matches_darcy_by_hand():
    """U_mf = k/eta_f phi rho_s g: 4.7476e-3 m/s for 70 um beads at phi = 0.6 (hand value, from
    k = 5.8074e-12 m^2); with a 10 deg slope only g cos(slope) is carried by the gas."""
    assert darcy_u_mf(PHI) == pytest.approx(4.7476e-3, rel=1e-4)
    mat = config().make_closure().material
    assert prep.minimum_fluidisation_velocity(mat, PHI, -G) == pytest.approx(darcy_u_mf(PHI), rel=1e-12)
    assert prep.minimum_fluidisation_velocity(mat, 0.55, G) == pytest.approx(darcy_u_mf(0.55), rel=1e-12)
    data = case(U_prep_over_Umf=0.7)
    data["gravity"] = {"slope_deg": 10.0}
    U_prep, U_mf = prep.injection_velocity(CaseConfig.from_dict(data))
    assert U_mf == pytest.approx(darcy_u_mf(PHI, G * math.cos(math.radians(10.0))), rel=1e-12)
    assert U_prep == pytest.approx(0.7 * U_mf, rel=1e-15)


# --- (2) below U_mf: Darcy profile, bed at rest --------------------------------------------------
def test_below_u_mf_the_bed_rests_with_the_linear_darcy_profile():
    """U = 0.5 U_mf, linear gas law: steady p_f = U eta_f (H0 - z)/k in the bed (tolerance 2e-3 of
    the basal lithostatic pressure; measured 4.0e-4, set by the 1e-3 steady criterion), grains at
    rest (|u| <= 1e-9 m/s, measured 1e-18), phi unchanged, p + p_f = lithostatic, basal
    p_f/lithostatic = 0.5 within 2e-3 (measured 0.4996), steady after 60 steps (0.06 s)."""
    ratio = 0.5
    result = prep.prepare(config(U_prep_over_Umf=ratio))
    st, g = result.state, result.model.grid
    k = D**2 * (1 - PHI) ** 3 / (150 * PHI**2)
    U = ratio * darcy_u_mf(PHI)
    bed = g.zc < H0
    p_ref = U * ETA_F * (H0 - g.zc[bed]) / k
    lith_base = PHI * RHO_S * G * (H0 - g.zc[0])
    err = np.abs(st.p_f[:, bed] - p_ref[None, :]).max() / lith_base
    height, phi_mean, basal = result.bed_profile()
    print(f"\nbelow U_mf: t = {st.t:.4f} s ({st.step} steps), steady = {result.steady}, "
          f"max|p_f - Darcy|/p_lith = {err:.2e}, basal ratio = {basal:.5f}, "
          f"max speed = {result.max_speed:.1e} m/s, height = {height:.6f} m, phi = {phi_mean:.6f}")
    assert result.steady and st.t < 0.3
    assert err <= 2e-3
    assert basal == pytest.approx(ratio, abs=2e-3)
    assert result.max_speed <= 1e-9
    assert np.all(st.p_f[:, ~bed] == 0.0)
    assert np.abs(st.phi[:, bed] - PHI).max() <= 1e-12
    assert height == pytest.approx(H0, rel=1e-9) and phi_mean == pytest.approx(PHI, rel=1e-9)
    # the gas carries half the weight, the grains the rest: p + p_f = lithostatic
    total = st.p[:, bed] + st.p_f[:, bed]
    assert np.abs(total - PHI * RHO_S * G * (H0 - g.zc[bed])[None, :]).max() <= 1e-6 * lith_base


# --- (3) at U_mf: fluidised -----------------------------------------------------------------------
def test_at_u_mf_the_basal_pore_pressure_reaches_lithostatic():
    """U = U_mf, linear gas law: basal p_f/lithostatic = 1 within 2e-3 (measured 0.99956 when the
    steady criterion stops it at 0.065 s), the granular pressure nearly vanishes (p <= 2e-3
    lithostatic, measured 4.4e-4) and the bed stays at rest (<= 1e-9 m/s, measured 8.5e-15)."""
    result = prep.prepare(config(U_prep_over_Umf=1.0))
    st = result.state
    _, _, basal = result.bed_profile()
    lith_base = PHI * RHO_S * G * (H0 - DZ / 2)
    print(f"\nat U_mf: t = {st.t:.4f} s, steady = {result.steady}, basal ratio = {basal:.5f}, "
          f"max p / p_lith = {st.p.max() / lith_base:.2e}, speed = {result.max_speed:.1e} m/s")
    assert result.steady
    assert basal == pytest.approx(1.0, abs=2e-3)
    assert st.p.max() <= 2e-3 * lith_base
    assert result.max_speed <= 1e-9


def test_over_fluidised_preparation_stops_at_the_maximum_time_and_says_so():
    """U = 1.5 U_mf lifts and expands the bed for t_s = 1.40 s (the fluidisation front,
    granflow.theory.fluidisation.expansion_time; tests/validation_smoke/test_expansion.py); stopped at 0.04 s the
    preparation ends at prep_max_time, never later, and reports steady = False with the bed rising
    (speed > 1e-6 m/s, measured 1.7e-3; basal p_f/lithostatic 1.14)."""
    result = prep.prepare(config(U_prep_over_Umf=1.5, prep_max_time=0.04))
    assert result.state.t == pytest.approx(0.04, rel=1e-12)
    assert not result.steady
    assert result.max_speed > 1e-6


# --- released state and injection after the gate opens ----------------------------------------------
@pytest.mark.parametrize("keep, expected", [("none", [0, 0, 0, 0, 0, 0]), ("reservoir", [1, 1, 0, 0, 0, 0]),
                                            ("base", [1, 1, 1, 1, 1, 1])])
def test_released_state_and_injection_after_the_gate_opens(keep, expected):
    """The prepared fields fill the columns x < L0, ambient and p_f = 0 beyond; the collapse model
    injects U_prep where keep_injection says (per column), nowhere by default."""
    cfg = config(U_prep_over_Umf=0.8, prep_max_time=0.005, keep_injection=keep)
    sim = CASES.get("column_collapse").setup(cfg)
    result = sim.preparation
    n = 2
    for name in ("phi", "p", "p_f"):
        np.testing.assert_array_equal(getattr(sim.state, name)[:n], getattr(result.state, name))
        assert not getattr(sim.state, name)[n:].any()
    assert not sim.state.vel.any()
    np.testing.assert_allclose(sim.model.gas_coupling.injection,
                               np.array(expected) * 0.8 * darcy_u_mf(PHI), rtol=1e-12)
    diag = CASES.get("column_collapse").diagnostics(sim, cfg)
    assert diag["keep_injection"] == keep and diag["prep_steady"] is False


# --- (4) through granflow run -----------------------------------------------------------------------
def test_injected_example_runs_and_reports_the_preparation(tmp_path, capsys):
    """The shipped example on a 6 x 6 grid (reservoir 2 cells): exit 0, summary.json holds the
    preparation; output.nc starts from the prepared state (the Darcy profile of U = 0.5 U_mf in
    x < L0, within 2e-3 of the basal lithostatic pressure; p_f = 0 beyond)."""
    out = tmp_path / "inj"
    sets = {"grid.nx": 6, "grid.nz": 6, "grid.Lx": 0.06, "grid.Lz": 0.06, "setup.H0": H0,
            "setup.L0": L0, "setup.U_prep_over_Umf": 0.5, "time.stop_time": 0.003,
            "output.interval": 0.001, "output.figures": "false"}
    argv = ["run", str(EXAMPLE), "--out", str(out), "--quiet"]
    for key, value in sets.items():
        argv += ["--set", f"{key}={value}"]
    code = main(argv)
    err = capsys.readouterr().err
    assert code == ExitCode.OK, err
    s = json.loads((out / "summary.json").read_text())
    d = s["case_diagnostics"]
    for key in ("prep_time_s", "prep_steps", "prep_steady", "prep_bed_height_m", "prep_phi_mean",
                "prep_basal_pf_over_lithostatic", "U_prep_m_s", "U_mf_m_s", "U_prep_over_Umf"):
        assert key in d, key
    assert d["preparation"] == "injection" and d["prep_steady"] is True and d["prep_steps"] > 0
    assert d["U_mf_m_s"] == pytest.approx(darcy_u_mf(PHI), rel=1e-12)
    assert d["U_prep_over_Umf"] == pytest.approx(0.5, rel=1e-12)
    assert d["prep_basal_pf_over_lithostatic"] == pytest.approx(0.5, abs=2e-3)
    assert d["prep_bed_height_m"] == pytest.approx(H0, rel=1e-9)
    with netCDF4.Dataset(out / "output.nc") as ds:
        z = np.asarray(ds["z"][:])
        p_f0 = ordered(ds["p_f"])[0]  # (x, z)
    k = D**2 * (1 - PHI) ** 3 / (150 * PHI**2)
    ref = 0.5 * darcy_u_mf(PHI) * ETA_F * (H0 - z[z < H0]) / k
    assert np.abs(p_f0[:2, z < H0] - ref[None, :]).max() <= 2e-3 * PHI * RHO_S * G * H0
    assert not p_f0[2:].any()


# --- (5) bad input ------------------------------------------------------------------------------------
@pytest.mark.parametrize("change, key", [
    ({"gas": {"law": "none"}}, "setup.preparation"),
    ({"setup": {"preparation": "none", "keep_injection": "base"}}, "setup.keep_injection"),
    ({"setup": {"preparation": "none", "U_prep_over_Umf": 1.0}}, "setup.U_prep_over_Umf"),
    ({"setup": {"L0": 0.025}}, "setup.L0"),
    ({"setup": {"L0": 0.01}}, "setup.L0"),
    ({"setup": {"b0": 0.5}}, "setup.b0"),
    ({"gas": {"law": "linear", "U_inj": 1e-3}}, "gas.U_inj"),
])
def test_bad_preparation_input_names_the_key(change, key):
    data = case()
    for section, values in change.items():
        data[section] = {**data[section], **values}
    with pytest.raises(GranflowInputError, match=key.replace(".", r"\.")):
        CaseConfig.from_dict(data)


def test_injection_with_gas_law_none_exits_2_naming_setup_preparation(tmp_path, capsys):
    code = main(["run", str(EXAMPLE), "--out", str(tmp_path / "x"), "--quiet", "--set", 'gas.law="none"'])
    err = capsys.readouterr().err
    assert code == ExitCode.BAD_INPUT and "setup.preparation" in err and "gas.law" in err
    assert not (tmp_path / "x" / "output.nc").exists()


def test_the_axisymmetric_reservoir_prepares_as_the_plane_one():
    """The injection through the whole base of a uniform reservoir gives the same p_f in every
    column, so the (r, z) reservoir (a cylinder of radius L0, every row weighted by its ring) must
    reach the plane reservoir's state: the same steps, p_f to 1e-9 relative, at rest."""
    plane = prep.prepare(config(U_prep_over_Umf=0.5))
    d = case(U_prep_over_Umf=0.5)
    d["grid"]["geometry"] = "axisymmetric"
    axi = prep.prepare(CaseConfig.from_dict(d))
    assert axi.model.grid.axisymmetric and axi.state.step == plane.state.step
    assert np.allclose(axi.state.p_f, plane.state.p_f, rtol=1e-9, atol=1e-9 * plane.state.p_f.max())
    assert axi.max_speed <= 1e-9
