"""Fluidised against dry column collapses (issue 4 item 3; validation/fluidised_vs_dry).

References, none produced by the code under test:
* Roche (2012, Bull. Volcanol. 74:1807): initially fluidised columns of fine glass beads run out
  about twice as far as dry ones; Roche et al. (2002, GRL 29:1803): the run-out depends only
  weakly on the initial degree of fluidisation;
* dry collapses (Lajeunesse et al. 2005, Lube et al. 2005): (L_inf - L0)/L0 = lambda_1 a with
  lambda_1 = 1.2-2.2 for a <~ 3 (MODEL.md §7);
* the lithostatic pressure phi0 rho_s g (H0 - dz/2) of the bottom cell and the Fourier series of a
  static rigid column (granflow.verification.defluidisation, itself checked in
  tests/integration/test_pore_pressure.py);
* the displaced solid fraction (solid beyond x = L0) is computed here from phi.

The CI smoke test runs the example files at 16 x 6 cells to t = 0.2 s; the slow test reruns the
README's a = 1 rows at the examples' resolution (dx = dz = 1 cm; ~2 min).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from _scripts import load_script

from granflow.cases import CASES
from granflow.config import load_case
from granflow.verification import defluidisation as dfl

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLES = ROOT / "examples"
SMOKE_GRID = ("grid.nx=16", "grid.nz=6", "grid.Lx=0.4", "time.stop_time=0.2", "output.probes_x=[]")
"""16 x 6 cells of 2.5 cm on a 0.4 x 0.15 m box (the dry example's; the flagship's is 0.7 m long),
0.2 s of flow (~1.5 s per run)."""
L0 = 0.1
"""Column half-width of the example files [m]."""
LAMBDA1 = (1.2, 2.2)
"""Dry run-out / L0 per unit aspect ratio in the experiments (MODEL.md §7)."""
P_ATM, ETA_F, D_GRAIN, PHI_RIGID = 101300.0, 1.8e-5, 70e-6, 0.6  # Pa, Pa s, m, -
C_RIGID = P_ATM * D_GRAIN**2 * (1 - PHI_RIGID) ** 2 / (150 * ETA_F * PHI_RIGID**2)
"""Gas diffusivity p_atm kappa / (1 - phi) of the rigid bed, Carman-Kozeny (paper eq. beta) [m^2/s]."""
ROCHE_RATIO = (1.5, 3.0)
"""Accepted band for the fluidised / dry run-out ratio (Roche 2012: about 2)."""


def _displaced_fraction(case_file: str, *extra: str) -> float:
    """Fraction of the solid volume beyond x = L0 at the end of a smoke run."""
    cfg = load_case(EXAMPLES / case_file, [*SMOKE_GRID, *extra])
    sim = CASES.get("column_collapse").setup(cfg)
    sim.run()
    phi = sim.state.phi
    x = sim.model.grid.cell_coords()[0]
    return float(phi[x > L0].sum() / phi.sum())


def test_smoke_fluidised_column_spreads_faster_than_dry_and_expansion_is_what_matters():
    """At the same time (0.2 s, 16 x 6), the expanded fluidised column (phi0 = 0.58, b0 = 0.9) has
    moved much more solid out of its initial footprint than the dry one, while the same pore
    pressure in a non-expanded bed (phi0 = 0.6) gains nothing (README: the expansion, not b0,
    sets the fluidised run-out). The fronts differ by one 2.5 cm cell only (0.200 against 0.175 m,
    measured), too coarse to assert; the displaced fraction is continuous.

    Default numerics (scheme v2), measured: dry 0.267, fluidised 0.502 (ratio 1.88), packed 0.313
    (1.17); the packed gain is 0.20 of the expanded one (session 13, base friction at the wall's
    strain rate: 0.243, 0.457 (1.88), 0.289 (1.19), 0.21). The earlier bound packed <= 1.15 dry
    (from a measured 0.84 with v1) was a coarse-grid value of v1: v1 now gives 1.01 at 16 x 6 and
    1.16 at 32 x 12 (v2 1.21), and the README's run-outs to rest give the packed bed 1.13-1.40 x
    the dry one (v1, 1 and 0.5 cm). So the packed bed is held to the slow test's 1.35 and, for
    "expansion is what matters", to less than half the expanded bed's gain."""
    dry = _displaced_fraction("column_collapse_dry.toml")                        # measured 0.267
    fluidised = _displaced_fraction("column_collapse_fluidised.toml")            # measured 0.502
    packed = _displaced_fraction("column_collapse_fluidised.toml", "setup.phi0=0.6")  # measured 0.313
    assert fluidised >= 1.3 * dry      # measured ratio 1.88
    assert packed <= 1.35 * dry        # measured ratio 1.17
    assert packed - dry <= 0.5 * (fluidised - dry)  # measured 0.20


def _load_run():
    return load_script("validation/fluidised_vs_dry/run.py", "validation_fluidised_vs_dry_run")


@pytest.mark.slow
def test_runout_ratio_at_the_examples_resolution(tmp_path):
    """README's central claim, a = 1, dx = dz = 1 cm, runs to rest (~2 min).

    Measured (validation/fluidised_vs_dry/results.json): run-out / L0 dry 1.50, b0 = 0.9 and
    phi0 = 0.58 2.80 (ratio 1.87), b0 = 0 and phi0 = 0.58 2.70 (1.80), b0 = 0.9 and phi0 = 0.6
    1.70 (1.13); basal p_f / p_lith0 under the column at t = 0.1 s: 0.69 (expanded), 0.03 (not
    expanded) against 0.10 for a static rigid column (series).
    """
    run = _load_run()
    a, dx = 1.0, run.DX_COARSE
    states = ("dry", "b0.9_phi0.58", "b0.0_phi0.58", "b0.9_phi0.60")
    r = {s: run.run_one(a, s, dx, tmp_path / s) for s in states}
    for s in states:
        assert r[s]["status"] == "completed" and r[s]["stopped_at_rest"], s
        assert r[s]["east_wall_clear"], s
    ratio = {s: r[s]["runout_m"] / r["dry"]["runout_m"] for s in states}
    assert LAMBDA1[0] * a <= r["dry"]["runout_over_L0"] <= LAMBDA1[1] * a           # measured 1.50
    assert ROCHE_RATIO[0] <= ratio["b0.9_phi0.58"] <= ROCHE_RATIO[1]                # measured 1.87
    assert abs(ratio["b0.0_phi0.58"] - ratio["b0.9_phi0.58"]) <= 0.2               # measured 0.07
    assert ratio["b0.9_phi0.60"] <= 1.35                                             # measured 1.13

    # basal probes: the initial state is b0 x lithostatic exactly, then the expanded bed keeps
    # (regenerates) its pore pressure while the non-expanded bed loses it faster than a rigid one.
    for s, b0 in (("b0.9_phi0.58", 0.9), ("b0.9_phi0.60", 0.9)):
        p_lith0 = r[s]["phi0"] * run.RHO_S * run.G * (run.H0 - dx / 2)
        pf = np.asarray(r[s]["probe_p_f_Pa"])[:, 0] / p_lith0
        assert pf[0] == pytest.approx(b0, abs=1e-9)                                 # measured exact
        r[s]["pf_01"] = float(np.interp(0.1, r[s]["t_s"], pf))
    rigid = float(run.rigid_column_pf(np.array([0.1]), 0.9, 0.6, dx)[0])            # 0.102
    assert rigid == pytest.approx(0.9 * float(dfl.pressure(dx / 2, 0.1, run.H0, C_RIGID))
                                  / (1 - dx / (2 * run.H0)), rel=1e-9)
    assert r["b0.9_phi0.58"]["pf_01"] >= 0.5                                        # measured 0.69
    assert r["b0.9_phi0.60"]["pf_01"] <= rigid                                      # measured 0.03


def _load_convergence():
    return load_script("validation/fluidised_vs_dry/convergence.py", "fluidised_convergence")


def test_convergence_script_smoke_and_ratio_arithmetic(tmp_path):
    """validation/fluidised_vs_dry/convergence.py: one tiny run through its own path (6 cells over
    H0, 5 steps) records what the analysis needs; the analysis of a hand-made two-state record
    gives the per-level ratios and the propagated uncertainty written out here."""
    conv = _load_convergence()
    rec = conv.run_single(1.0, "b0.9_phi0.58", 0, max_steps=5, workdir=tmp_path, datadir=tmp_path,
                          results_path=tmp_path / "r.json", n=6.0)
    assert rec["steps"] == 5 and rec["b0"] == pytest.approx(0.9) and rec["phi0"] == pytest.approx(0.58)
    assert rec["east_wall_clear"] and rec["lid_clear"] and (tmp_path / f"{conv.key(1.0, 'b0.9_phi0.58', 0)}.npz").exists()
    # analysis on made-up numbers: fluidised 3.0, 2.8, 2.7 and dry 1.5, 1.45, 1.42 at ratio sqrt 2
    fl, dr = (3.0, 2.8, 2.7), (1.5, 1.45, 1.42)
    common = dict(status="completed", east_wall_clear=True, lid_clear=True, stopped_at_rest=True, prep_wall_s=0.0,
                  wall_s=1.0, t_rest=0.5, steps=10)
    runs = {f"f{k}": dict(common, a=1.0, state="b0.9_phi0.58", level=k, N=14 * 2 ** (k / 2),
                          toe={"relative": v}, **{"thr0.05": {"relative": v}}) for k, v in enumerate(fl)}
    dry = {f"d{k}": dict(common, a=1.0, level=k, toe={"relative": v}, **{"thr0.05": {"relative": v}})
           for k, v in enumerate(dr)}
    row = conv.analyse({"runs": runs}, {"runs": dry})[0]
    assert row["ratio_per_level"] == pytest.approx([f / d for f, d in zip(fl, dr)])
    r = math.sqrt(2.0)
    p_f = math.log((3.0 - 2.8) / (2.8 - 2.7)) / math.log(r)            # observed order, fluidised
    f_inf = 2.7 + (2.7 - 2.8) / (r**p_f - 1)
    p_d = math.log((1.5 - 1.45) / (1.45 - 1.42)) / math.log(r)
    d_inf = 1.42 + (1.42 - 1.45) / (r**p_d - 1)
    assert row["estimate_fluidised"]["value"] == pytest.approx(f_inf)
    assert row["ratio"]["value"] == pytest.approx(f_inf / d_inf)
    sig = 1.25 * abs(f_inf - 2.7) / f_inf + 1.25 * abs(d_inf - 1.42) / d_inf   # GCI, relative, added
    assert row["ratio"]["uncertainty"] == pytest.approx(f_inf / d_inf * sig)
    # oscillatory levels: the finest value, +- half the range (Stern et al. 2001)
    osc = conv.estimate([2.16, 2.23, 2.09], r)
    assert osc["value"] == 2.09 and osc["uncertainty"] == pytest.approx(0.07)


@pytest.mark.slow
def test_converged_study_coarsest_level_reproduces_and_is_in_the_roche_band(tmp_path):
    """Slow (~1 min): the coarsest level of convergence.py at a = 1 (b0 = 0.9, phi0 = 0.58, 14 cells
    over H0) rerun here; its thr0.05 ratio to the dry study's level-0 run-out is in Roche's band
    (measured with the defaults switched in session 25 and the study's dt_max 0.25 ms, 6 Dec 2026:
    4.049 / 2.317 = 1.75; 1.86 with the converged loop at 1 ms, v1 2.16), and so is the central
    value of the README's converged ratio (convergence.json: 1.73 +- 0.63). Its uncertainty is
    wider than the band: 1.73 - 0.63 falls
    below 1.5 (it did since session 13's 1.74 +- 0.66), so only the value is asserted, and the
    interval must at least overlap the band."""
    conv = _load_convergence()
    rec = conv.run_single(1.0, "b0.9_phi0.58", 0, workdir=tmp_path, datadir=tmp_path, results_path=tmp_path / "r.json")
    assert rec["stopped_at_rest"] and rec["east_wall_clear"] and rec["lid_clear"]
    dry = conv.DR.load_results()["runs"][conv.DR.key(1.0, 0)]
    ratio = rec["thr0.05"]["relative"] / dry["thr0.05"]["relative"]
    assert ROCHE_RATIO[0] <= ratio <= ROCHE_RATIO[1]
    stored = json.loads((ROOT / "validation" / "fluidised_vs_dry" / "convergence.json").read_text())
    row = next(r for r in stored["analysis"]["thr0.05"] if r["a"] == 1.0 and r["state"] == "b0.9_phi0.58")
    assert ROCHE_RATIO[0] <= row["ratio"]["value"] <= ROCHE_RATIO[1]
    assert row["ratio"]["value"] - row["ratio"]["uncertainty"] <= ROCHE_RATIO[1]
    assert row["ratio"]["value"] + row["ratio"]["uncertainty"] >= ROCHE_RATIO[0]


def test_stored_fronts_follow_the_one_front_definition():
    """Issue 16 item 5: the stored final fronts are granflow.diagnostics.front_from_thickness
    ("edge") of the stored deposit, and the sensitivity table's sub-cell fronts ("linear") are
    reproduced by the same function (so the scripts carry no front definition of their own)."""
    from granflow import diagnostics as dg

    vfd = _load_run()
    stored = json.loads((ROOT / "validation" / "fluidised_vs_dry" / "results.json").read_text())
    threshold = stored["meta"]["front_threshold_m"]
    for name, r in stored["runs"].items():
        x, h = np.asarray(r["x_m"]), np.asarray(r["h_final_m"])
        edges = np.concatenate([x - 0.5 * r["dx_m"], x[-1:] + 0.5 * r["dx_m"]])
        assert dg.front_from_thickness(edges, h, threshold) == pytest.approx(r["front_final_m"], abs=1e-9), name
    again = vfd.sensitivity(stored["runs"])
    for name, by_thr in stored["front_definition"].items():
        for thr, row in by_thr.items():
            assert again[name][thr]["runout_over_L0"] == pytest.approx(row["runout_over_L0"], rel=1e-9)
