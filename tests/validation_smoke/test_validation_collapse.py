"""validation/lagree_column and validation/well_posedness (issue 4 item 3): the analysis tools
against closed forms, the run machinery on tiny grids, and (slow) the measured claims.

Independent references: a linear deposit h(x) whose threshold crossing is known in closed form;
Richardson extrapolation of sequences with a known limit and order; a power law with a known
exponent; the Barker et al. (2015) window recomputed here from its criterion
4 nu^2 - 4 nu + mu^2 (1 - nu/2)^2 = 0 (nu = I mu'/mu) with a root finder, not with granflow's
barker module; checkerboard / total variation / band width of fields built here; the same column
in the paper's 5 x 5 box and in the cut box used by the validation (the claim that the ambient
above the column carries nothing).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from _scripts import load_script
from scipy.optimize import brentq

from granflow.cli import main as cli_main

A = 1.42
MU_S, DELTA_MU, I0 = 0.32, 0.28, 0.4
"""Lagree et al. (2011) mu(I) parameters (c_I = 2)."""
BOX_LEVEL, BOX_STEPS = 32, 20
"""The box check in CI: 32 cells per 5 H0, 20 steps of 0.01 (t = 0.2)."""


def _load(rel: str, name: str):
    return load_script(rel, name, cached=True)


@pytest.fixture(scope="module")
def lc():
    return _load("validation/lagree_column/run.py", "validation_lagree_column_run")


@pytest.fixture(scope="module")
def wp():
    return _load("validation/well_posedness/run.py", "validation_well_posedness_run")


# --- analysis tools against closed forms ---------------------------------------------------------
def test_linear_front_is_exact_on_a_linear_deposit(lc):
    """h = 1 - x/2 at the cell centres: h = thr at x = 2 (1 - thr) exactly."""
    x = (np.arange(40) + 0.5) * 0.1
    h = np.clip(1.0 - x / 2.0, 0.0, None)
    for thr in (0.05, 0.1, 0.33):
        assert lc.linear_front(x, h, thr) == pytest.approx(2.0 * (1.0 - thr), abs=1e-12)
    assert math.isnan(lc.linear_front(x, np.zeros_like(x), 0.05))


def test_toe_front_extrapolates_the_toe_to_h_zero(lc):
    """granflow.diagnostics.toe_front (lagree_column's toe front): a toe h = 0.4 - x/5 from 0.15
    down to 0.05 ends where the line reaches 0, x = 2, whatever lies after the toe; no toe or a
    rising one gives nan."""
    from granflow import diagnostics as dg

    x = (np.arange(40) + 0.5) * 0.05
    h = np.where(x < 1.25, 0.3, np.clip(0.4 - x / 5.0, 0.0, None))
    h[x > 1.8] = 0.01  # a thin sheet below the window, beyond the toe: not fitted
    assert dg.toe_front(x, h, (0.05, 0.15)) == pytest.approx(2.0, abs=1e-12)
    assert lc.toe_front(x, h) == dg.toe_front(x, h, lc.TOE_WINDOW)
    assert math.isnan(dg.toe_front(x, np.full_like(x, 0.1), (0.05, 0.15)))
    assert math.isnan(dg.toe_front(x, x / 10.0, (0.05, 0.15)))  # increasing: no falling toe


def test_richardson_recovers_known_limits(lc):
    f = [2.0 + 0.5 * hh**1.5 for hh in (4.0, 2.0, 1.0)]  # limit 2, order 1.5
    r = lc.richardson(f)
    assert r["method"] == "3-level Richardson"
    assert r["order"] == pytest.approx(1.5, rel=1e-12) and r["value"] == pytest.approx(2.0, rel=1e-12)
    r2 = lc.richardson([1.0 + 0.2, 1.0 + 0.1])  # first order, two levels: exact
    assert r2["value"] == pytest.approx(1.0, rel=1e-12) and r2["uncertainty"] == pytest.approx(0.3, rel=1e-12)
    r3 = lc.richardson([1.0, 1.2, 1.1])  # not monotone: first-order fallback, safety factor 3
    assert r3["method"] == "1st-order fallback" and r3["value"] == pytest.approx(1.0, rel=1e-12)


def test_power_fit_recovers_the_exponent(lc):
    a = np.array([0.5, 1.42, 3.0, 6.26])
    f = lc.power_fit(a, 1.7 * a**0.8)
    assert f["exponent"] == pytest.approx(0.8, rel=1e-10) and f["prefactor"] == pytest.approx(1.7, rel=1e-10)


def _barker_roots() -> tuple[float, float]:
    """Roots of Barker's criterion for the Lagree mu(I), computed here."""
    def mu(i):
        return MU_S + DELTA_MU * i / (I0 + i)

    def crit(i):
        nu = i * DELTA_MU * I0 / (I0 + i) ** 2 / mu(i)
        return 4 * nu**2 - 4 * nu + mu(i) ** 2 * (1 - nu / 2) ** 2

    i_star = I0  # nu is largest at I ~ I0, where the criterion is negative (well posed)
    assert crit(i_star) < 0
    return brentq(crit, 1e-8, i_star, xtol=1e-14), brentq(crit, i_star, 1e3, xtol=1e-14)


def test_barker_window_of_the_lagree_parameters(wp, capsys):
    """The window used by the well-posedness analysis = the roots computed here = the CLI's."""
    lo, hi = _barker_roots()
    win = wp.window()
    assert win["I_low"] == pytest.approx(lo, rel=1e-8) and win["I_high"] == pytest.approx(hi, rel=1e-8)
    assert cli_main(["stability", "window", "--mu1", "0.32", "--mu2", "0.6", "--I0", "0.4", "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    assert cli["I_low"] == pytest.approx(lo, rel=1e-8)  # measured 0.013631
    assert cli["I_high"] == pytest.approx(hi, rel=1e-8)  # measured 1.8101


def test_field_measures_on_fields_built_here(wp):
    nx, nz, dx = 20, 12, 0.05
    x, z = (np.arange(nx) + 0.5) * dx, (np.arange(nz) + 0.5) * dx
    X, Z = np.meshgrid(x, z, indexing="ij")
    mask = np.ones((nx, nz), dtype=bool)
    lith = 1.0 - Z
    assert wp.checkerboard(lith + 0.3 * X, mask) == pytest.approx(0.0, abs=1e-14)  # affine: zero
    sign = (-1.0) ** (np.arange(nx)[:, None] + np.arange(nz)[None, :])
    assert wp.checkerboard(lith + 0.01 * sign, mask) == pytest.approx(0.01, rel=1e-12)
    # |p_z| = 1 on the nx (nz - 1) interior z-faces, over the area nx nz dx^2
    tv = wp.total_variation(lith, mask, dx, dx) / (nx * nz * dx * dx)
    assert tv == pytest.approx((nz - 1) / nz, rel=1e-12)
    # a Gaussian band exp(-(x - x0)^2 / (2 s^2)): full width at half maximum 2 sqrt(2 ln 2) s
    s, x0 = 0.12, 0.6
    S = np.exp(-((X - x0) ** 2) / (2 * s**2))
    width = wp.band_width(x, z, S, mask, 0.3)
    fwhm = 2 * math.sqrt(2 * math.log(2)) * s
    assert width == pytest.approx(fwhm, rel=0.03)  # measured +0.8 % (2.4 cells per s)


# --- machinery on tiny grids ---------------------------------------------------------------------
@pytest.fixture(scope="module")
def box_pair(lc, tmp_path_factory):
    """a = 1.42, incompressible, 32 cells per 5 H0, 20 steps, cut box and paper box (~3 s)."""
    tmp = tmp_path_factory.mktemp("box")
    recs = {box: lc.run_one(A, "incompressible", BOX_LEVEL, box, workdir=tmp, datadir=tmp,
                            max_steps=BOX_STEPS) for box in ("reduced", "paper")}
    arrays = {box: lc.load_arrays(lc.tag(A, "incompressible", BOX_LEVEL, box), tmp) for box in recs}
    return recs, arrays


def test_quick_run_records_and_saves_everything(box_pair, lc):
    recs, arrays = box_pair
    r, arr = recs["reduced"], arrays["reduced"]
    assert r["status"] == "completed" and r["steps"] == BOX_STEPS and (r["nx"], r["nz"]) == (32, 8)
    assert r["t_final"] == pytest.approx(0.2, rel=1e-9)
    assert abs(r["mass_rel_error"]) < 1e-12  # measured 2.6e-16
    assert set(arr) >= {"t", "x", "h", "ke", "field_t", "phi", "p", "S", "u", "w"}
    assert arr["h"][0][:4] == pytest.approx([1, 1, 1, 1])  # the column: 4.5 cells of h = H0
    # the deposit conserves the column's volume: sum h dx = H0 L0
    assert float(arr["h"][-1].sum() * lc.PAPER_BOX / BOX_LEVEL) == pytest.approx(1 / A, rel=1e-6)  # 1.3e-8
    assert r["thr0.05"]["relative"] == pytest.approx((r["thr0.05"]["x_f"] - 1 / A) * A, rel=1e-12)


def test_the_cut_box_does_not_change_the_collapse(box_pair):
    """The ambient above the column carries nothing: 5 x 1.25 and 5 x 5 boxes give the same flow
    (measured at t = 0.2: kinetic energy 1.0e-3 apart relative, h(x) 7.9e-5 H0; at t = 8,
    validation/lagree_column/README.md: peak kinetic energy 0.6 %)."""
    _, arrays = box_pair
    a, b = arrays["reduced"], arrays["paper"]
    assert abs(a["ke"][-1] - b["ke"][-1]) / b["ke"][-1] < 1e-2
    assert np.max(np.abs(a["h"] - b["h"])) < 1e-3


def test_well_posedness_measures_on_a_tiny_run(box_pair, wp, lc):
    """At t = 0.2 on 32 x 8 the pipeline runs; the column is still nearly lithostatic, |dp/dz| =
    rho g = 1, so the total variation of p per unit bulk area is (rows - 1)/rows = 2/3 for its
    3-row bulk (measured 0.65); no dense cell is above the Barker window (I_max measured 0.17) and
    the p checkerboard is small (measured 7.4e-3 rho g H0)."""
    _, arrays = box_pair
    arr = arrays["reduced"]
    m = wp.metrics(arr, 0, arr["x"], arr["z"], wp.window())
    assert m["tv_p"] == pytest.approx(2 / 3, rel=0.1)
    assert m["frac_above_window"] == 0.0 and m["I_max"] < 0.5
    assert m["chk_p"] < 0.02


# --- slow: the claims of the READMEs (each fixture runs the solver for 1-4 min) -----------------
SLOW_ASPECTS = (0.5, 1.42, 3.0, 6.26)
LAMBDA1_BAND = (1.2, 2.2)
"""Published planar band of (L_inf - L0)/(L0 a) for a <~ 3 (Lube et al. 2005; Lajeunesse et al. 2005)."""
LAMBDA2_BAND = (1.9, 3.9)
"""Published band of (L_inf - L0)/(L0 a^(2/3)) above (MODEL.md §7)."""


SLOW_BOX_LEVEL = 64
"""The slow box check: 64 cells per 5 H0 (at 32 the two boxes differ by 0.020 H0 with the defaults
of session 25, by <= 2.4e-3 with the converged loop before; at 64 by 2e-4: validation/lagree_column)."""


@pytest.fixture(scope="module")
def slow_runs(lc, tmp_path_factory):
    """Incompressible, cut box: a = 0.5, 1.42, 3, 6.26 at 64 and at 128, to rest (~2 min on the
    2-core machine with the session-25 defaults)."""
    tmp = tmp_path_factory.mktemp("slow")
    runs = {(a, n): lc.run_one(a, "incompressible", n, workdir=tmp, datadir=tmp)
            for a in SLOW_ASPECTS for n in (64, 128)}
    arrays = {k: lc.load_arrays(lc.tag(k[0], "incompressible", k[1]), tmp) for k in runs}
    return runs, arrays


@pytest.mark.slow
def test_lagree_deposit_converges_and_rests(slow_runs, lc):
    """a = 1.42: at rest (rms speed < 0.01 for one time unit) before t = 6 at 64 and 128 (measured
    t_rest 4.06 and 4.35, session 25); deposits h(x) at t = 1, 2, 4 and at rest within 0.05 H0
    between 64 and 128; the toe run-out of the two levels, extrapolated at first order, in the
    planar band lambda1 = 1.2-2.2 (3.247 and 2.979 per level); the 0.1 H0 front (the bulk) moves by
    less than 2 % between the levels (measured 2.038 -> 2.027, 0.5 %). The 0.05 H0 front sits on
    the deposit's thin tail (h 0.04-0.06 H0) and moves by 5.7 % (2.716 -> 2.560; 3.7 % with the
    converged loop before session 25): not asserted, a quantity not yet converged at these levels."""
    runs, arrays = slow_runs
    coarse, fine = runs[(A, 64)], runs[(A, 128)]
    for r in (coarse, fine):
        assert r["stopped_at_rest"] and r["t_rest"] < 6.0
    a64, a128 = arrays[(A, 64)], arrays[(A, 128)]
    for tp in (*lc.PROFILE_TIMES, None):
        k1 = -1 if tp is None else int(np.argmin(np.abs(a64["t"] - tp)))
        k2 = -1 if tp is None else int(np.argmin(np.abs(a128["t"] - tp)))
        h_fine_on_coarse = a128["h"][k2].reshape(-1, 2).mean(axis=1)
        assert np.max(np.abs(a64["h"][k1] - h_fine_on_coarse)) < 0.05
    est = lc.richardson([coarse["toe"]["relative"], fine["toe"]["relative"]])
    assert LAMBDA1_BAND[0] <= est["value"] / A <= LAMBDA1_BAND[1]
    assert abs(fine["thr0.1"]["relative"] / coarse["thr0.1"]["relative"] - 1) < 0.02


@pytest.mark.slow
def test_lagree_runout_against_aspect_ratio(slow_runs, lc):
    """128 cells per 5 H0, toe run-out: lambda1 = rel/a in 1.2-2.2 for a = 0.5, 1.42 (measured 2.14,
    2.10, session 25); lambda2 = rel/a^(2/3) in 1.9-3.9 for a = 3, 6.26 (measured 2.59, 2.59);
    fitted exponent over a = 0.5-6.26 in 0.65-0.9 (measured 0.83; Balmforth & Kerswell 2005: 0.9 +-
    0.1). At 64 cells the toes run longer (lambda1 2.36 and 2.29: above the band since session 13,
    the thin sheet ahead of the deposit not resolved), so the claim is made at 128."""
    runs, _ = slow_runs
    rel = {a: runs[(a, 128)]["toe"]["relative"] for a in SLOW_ASPECTS}
    for a in (0.5, 1.42):
        assert LAMBDA1_BAND[0] <= rel[a] / a <= LAMBDA1_BAND[1]
    for a in (3.0, 6.26):
        assert LAMBDA2_BAND[0] <= rel[a] / a ** (2 / 3) <= LAMBDA2_BAND[1]
    fit = lc.power_fit(list(rel), list(rel.values()))
    assert 0.65 <= fit["exponent"] <= 0.9


@pytest.mark.slow
def test_cut_box_matches_the_paper_box_to_rest(lc, tmp_path):
    """64 cells per 5 H0 (SLOW_BOX_LEVEL), both models, to t = 8: fronts at t = 1, 2, 4 within
    0.005 H0 (measured 2e-4 H0, incompressible, session 25) and peak kinetic energy within 1 %
    between the 5 x 5 box and the 5 x 1.25 box (~1 min)."""
    for model in lc.MODELS:
        recs = {box: lc.run_one(A, model, SLOW_BOX_LEVEL, box, workdir=tmp_path, datadir=tmp_path)
                for box in ("reduced", "paper")}
        fa, fb = recs["reduced"]["thr0.05"]["front_at"], recs["paper"]["thr0.05"]["front_at"]
        assert max(abs(fa[k] - fb[k]) for k in fa) < 0.005
        assert abs(recs["reduced"]["ke_peak"] / recs["paper"]["ke_peak"] - 1) < 0.01


@pytest.mark.slow
def test_well_posedness_no_grid_scale_features_at_64_and_128(lc, wp, tmp_path):
    """t = 0.5, both models, 64 and 128 cells per 5 H0 (~1 min): max |S| away from the base
    (z >= 0.25 H0) grows by less than 30 % (measured x1.15 incompressible, x0.90 mu_i); the p
    checkerboard there falls by more than 2 (measured 3.9, 3.7: a smooth p); the band bounding the
    static wedge keeps its width (z = 0.2 H0: measured 0.53 -> 0.58 and 0.47 -> 0.58 H0, i.e. 7 ->
    15 cells); no dense cell above the Barker window (I_max 1.03, 1.21 < 1.81). The largest |S|
    sits in the basal layer under the front and grows about like 1/dx in both models (x1.74,
    x1.84): a no-slip boundary layer the grids do not resolve, not a difference between them."""
    win = wp.window()
    for model in lc.MODELS:
        m = {}
        for n in (64, 128):
            lc.run_one(A, model, n, workdir=tmp_path, datadir=tmp_path, stop_time=wp.EXTRA_TIME,
                       keep_fields=True)
            m[n] = wp.analyse_run(lc.tag(A, model, n), tmp_path, win)["0.5"]
        assert m[128]["S_max_interior"] / m[64]["S_max_interior"] < 1.3
        assert m[64]["chk_p_interior"] / m[128]["chk_p_interior"] > 2.0
        assert abs(m[128]["band"]["0.2"] / m[64]["band"]["0.2"] - 1) < 0.3
        assert m[128]["I_max"] < win["I_high"]
        assert m[128]["S_max_bulk"] / m[64]["S_max_bulk"] > 1.5


def test_mass_quantile_front_of_a_triangular_deposit():
    """h = H (1 - x/L) on [0, L]: the volume left of x is H (x - x^2 / 2L), so the q-quantile is
    x_q = L (1 - sqrt(1 - q)) (analytic); column-averaged h on 400 columns gives it to 1e-4 L, and
    a sheet of 0.1 % of the volume beyond L moves x_0.99 by less than it moves x_0.9999."""
    from granflow.diagnostics import mass_quantile_front

    L, H, n = 2.0, 0.5, 400
    edges = np.linspace(0.0, 1.5 * L, int(1.5 * n) + 1)
    a, b = edges[:-1], edges[1:]
    vol = lambda x: H * (np.minimum(x, L) - np.minimum(x, L) ** 2 / (2 * L))  # noqa: E731
    h = (vol(b) - vol(a)) / (b - a)                     # exact column means
    for q in (0.5, 0.9, 0.99, 0.999):
        assert abs(mass_quantile_front(edges, h, q) - L * (1 - np.sqrt(1 - q))) <= 1e-4 * L
    sheet = h.copy()
    beyond = a >= L
    sheet[beyond] = 1e-3 * H * L / 2 / (beyond.sum() * (b - a)[0])
    shift = {q: mass_quantile_front(edges, sheet, q) - mass_quantile_front(edges, h, q) for q in (0.99, 0.9999)}
    assert 0 < shift[0.99] < shift[0.9999]
    assert np.isnan(mass_quantile_front(edges, np.zeros_like(h), 0.5))
    with pytest.raises(ValueError):
        mass_quantile_front(edges, h, 0.0)
