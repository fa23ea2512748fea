"""Condition checker (granflow.theory.conditions) against independent closed forms and SymPy.

Every expected number below is computed here from the paper's formulas (Section 6, MODEL.md §3-4),
never taken from the code under test. Tolerances are stated at each assertion; the checker's
boundaries are bisected to ~5e-11 in ln I, so 1e-6 relative is a loose bound.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import brentq

from granflow.errors import GranflowInputError
from granflow.rheology import CLOSURES, make_closure
from granflow.theory.conditions import check, condition_map
from _closure_checks import assert_c1_and_equilibrium

CONDITION_NAMES = ("C1", "C2", "C2_strict", "C3", "dissipation", "equilibrium", "Z_nonnegative")
BOUNDARY_RTOL = 1e-6  # detected boundary vs closed form (the brief asks 1e-5)
MU1, MU2, I0 = math.tan(math.radians(21.0)), math.tan(math.radians(33.0)), 0.3  # defaults (paper §6.2)
PHI_MAX, DELTA_PHI = 0.6, 0.2  # default Material / linear law (paper eq. phi(I))

NON_REFERENCE = [n for n in CLOSURES.names() if not CLOSURES.get(n).reference]
REFERENCE = [n for n in CLOSURES.names() if CLOSURES.get(n).reference]


# ---- independent formulas (paper Section 6) ----------------------------------------------------
def mu_indep(I):
    """Paper eq. mu(I): mu1 + (mu2 - mu1)/(1 + I0/I)."""
    return MU1 + (MU2 - MU1) / (1.0 + I0 / I)


def G_indep(I):
    """Paper eq. psi:mu(I): G(I) = (2 mu1/3) ln(I/I0) + (mu2 - mu1)/3 (1/(1+I/I0) + 2 ln(1+I/I0))."""
    x = I / I0
    return 2.0 * MU1 / 3.0 * math.log(x) + (MU2 - MU1) / 3.0 * (1.0 / (1.0 + x) + 2.0 * math.log(1.0 + x))


def dG_indep(I):
    """dG/dI from the C1 ODE of the paper: psi' = 2 mu/(3I) - mu'/3."""
    dmu = (MU2 - MU1) * I0 / (I + I0) ** 2
    return 2.0 * mu_indep(I) / (3.0 * I) - dmu / 3.0


def failing_regions(report, name, kind="grid"):
    return [r for r in report.conditions[name].fails_where if r["kind"] == kind]


# ---- registry-wide -------------------------------------------------------------------------------
@pytest.mark.parametrize("name", NON_REFERENCE)
def test_non_reference_closures_pass_c1_and_equilibrium(name):
    assert_c1_and_equilibrium(make_closure(name))


@pytest.mark.parametrize("name", REFERENCE)
def test_reference_closures_are_flagged_and_fail_c1(name):
    rep = check(make_closure(name))
    assert rep.reference is True and rep.to_dict()["reference"] is True
    assert not rep.conditions["C1"].passed


def test_roux_radjai_c1_residual_matches_sympy():
    """f = a(phi - phi_eq(I)), phi_eq = phi_max - dphi I, Z = mu(I): SymPy residual on the same grid."""
    closure = make_closure("roux_radjai")
    rep = check(closure)
    c1 = rep.conditions["C1"]
    assert not c1.passed and c1.fails_where
    phi, I = sp.symbols("phi I", positive=True)
    a = sp.Float(closure.a)
    Z = sp.Float(MU1) + sp.Float(MU2 - MU1) / (1 + sp.Float(I0) / I)
    f = a * (phi - (sp.Float(PHI_MAX) - sp.Float(DELTA_PHI) * I))
    terms = [Z, -I / 2 * sp.diff(Z, I), -f, -I * sp.diff(f, I)]
    rel = sp.Abs(sum(terms)) / sum(sp.Abs(t) for t in terms)
    w = c1.worst_point
    expected = float(rel.subs({phi: w["phi"], I: w["I"]}).evalf(30))
    assert c1.worst_value == pytest.approx(expected, rel=1e-8)
    # ... and it is the maximum of the SymPy residual over the report's own grid (ratio rows + jammed).
    rel_np = sp.lambdify((phi, I), rel, "numpy")
    g = rep.grid
    r = np.logspace(np.log10(g["I_ratio_range"][0]), np.log10(g["I_ratio_range"][1]), g["n_ratio"])
    vals = [rel_np(ph, (PHI_MAX - ph) / DELTA_PHI * r).max() for ph in g["phi"] if ph < PHI_MAX]
    vals.append(rel_np(PHI_MAX, np.logspace(-6, 2, g["n_jammed"])).max())
    assert c1.worst_value == pytest.approx(max(vals), rel=1e-8)


def test_roux_radjai_dissipation_boundary():
    """Z - f = mu(I) - a dphi (I - I_eq) < 0 beyond the root of mu(I) = a dphi (I - I_eq)."""
    closure = make_closure("roux_radjai")
    rep = check(closure)
    regions = rep.conditions["dissipation"].fails_where
    assert regions and all(reg["open_above"] and not reg["open_below"] for reg in regions)
    for reg in regions:
        for b in reg["boundaries"]:
            Ieq = (PHI_MAX - b["phi"]) / DELTA_PHI
            root = brentq(lambda x: mu_indep(x) - closure.a * DELTA_PHI * (x - Ieq), max(Ieq, 1e-9), 1e4,
                          xtol=1e-15, rtol=1e-14)
            assert b["I_interval"][0] == pytest.approx(root, rel=BOUNDARY_RTOL)


# ---- Drucker-Prager with dilatancy angle (paper §6.4.1) ------------------------------------------
@pytest.mark.parametrize("delta_deg", [30.0, 20.0])
def test_dp_dilatancy_z_negative_boundary(delta_deg):
    """Z = sin d + cos d K (1 - r^-b), K = sin d/(1 - cos d): Z < 0 iff r < cos(d)^(1/b)."""
    rep = check(make_closure("drucker_prager_dilatancy", delta_deg=delta_deg))
    c = math.cos(math.radians(delta_deg))
    beta = 2 * (1 - c) / (2 + c)
    r_star = c ** (1 / beta)
    if delta_deg == 30.0:
        assert 1 / r_star == pytest.approx(4.66, abs=0.01)  # MODEL.md §6.4
    zn = rep.conditions["Z_nonnegative"]
    assert not zn.passed and zn.worst_value < 0
    (reg,) = failing_regions(rep, "Z_nonnegative")
    assert reg["open_below"] and not reg["open_above"]
    assert reg["r_interval"][1] == pytest.approx(r_star, rel=BOUNDARY_RTOL)
    for b in reg["boundaries"]:
        assert b["r_interval"][1] == pytest.approx(r_star, rel=BOUNDARY_RTOL)
        assert b["I_interval"][1] == pytest.approx(r_star * b["I_eq"], rel=BOUNDARY_RTOL)
    # C2: Z + I Z_I = sin d + cos d K (1 - (1 - b) r^-b) < 0 iff r < (cos d (1 - b))^(1/b).
    (reg2,) = failing_regions(rep, "C2")
    assert reg2["r_interval"][1] == pytest.approx((c * (1 - beta)) ** (1 / beta), rel=BOUNDARY_RTOL)
    # Everything else holds on phi < phi_max (Z - f = sin d r^-b >= 0, df/dI > 0).
    for name in ("C1", "dissipation", "equilibrium", "C2_strict", "C3"):
        assert not failing_regions(rep, name), name


def test_dp_dilatancy_c1_residual_sympy_zero():
    """Independent SymPy check that the paper's psi (eq. psi) satisfies C1 exactly."""
    d, I, Ieq = sp.symbols("delta I I_eq", positive=True)
    beta = 2 * (1 - sp.cos(d)) / (2 + sp.cos(d))
    psi = sp.sin(d) / (1 - sp.cos(d)) * (1 - (Ieq / I) ** beta)
    Z = sp.sin(d) + sp.cos(d) * psi
    assert sp.simplify(Z - I / 2 * sp.diff(Z, I) - (psi + I * sp.diff(psi, I))) == 0


# ---- power law Z = I^3 (Table 1, Remark rem-viscous3) --------------------------------------------
def test_power_law_cubic_dissipation_boundary():
    # Independent derivation: integrate C1, d(I f)/dI = Z - I Z'/2, with f(I_eq) = 0.
    I, J, Ieq = sp.symbols("I J I_eq", positive=True)
    Z = I**3
    f = sp.integrate((Z - I / 2 * sp.diff(Z, I)).subs(I, J), (J, Ieq, I)) / I
    assert sp.simplify((Z - f) - (sp.Rational(9, 8) * I**3 - Ieq**4 / (8 * I))) == 0
    r_star = float(sp.solve(sp.Eq((Z - f).subs(I, sp.Symbol("r", positive=True) * Ieq), 0),
                            sp.Symbol("r", positive=True))[0])
    assert r_star == pytest.approx(3**-0.5, rel=1e-15)

    rep = check(make_closure("power_law", exponents=(3.0,), coefficients=(1.0,)))
    (reg,) = failing_regions(rep, "dissipation")
    assert reg["open_below"] and not reg["open_above"]
    assert reg["r_interval"][1] == pytest.approx(r_star, rel=BOUNDARY_RTOL)
    for b in reg["boundaries"]:
        assert b["r_interval"][1] == pytest.approx(r_star, rel=BOUNDARY_RTOL)
    # f = -(I^4 - I_eq^4)/(8 I) has the wrong sign on both sides, df/dI < 0: C3 and equilibrium fail
    # at every grid point (except r = 1 exactly); C1 holds (f was built from it).
    assert sp.simplify(sp.diff(f, I) + (3 * I**2 + Ieq**4 / I**2) / 8) == 0
    assert not rep.conditions["C3"].passed
    assert all(r["covers_grid"] for r in rep.conditions["C3"].fails_where)
    eq_regions = failing_regions(rep, "equilibrium")
    assert any(r["r_interval"][1] == pytest.approx(1.0, rel=1e-9) for r in eq_regions)
    assert any(r["r_interval"][0] == pytest.approx(1.0, rel=1e-9) and r["open_above"] for r in eq_regions)
    assert rep.conditions["C1"].passed


# ---- Drucker-Prager, mu(I), Robinson --------------------------------------------------------------
def test_drucker_prager_c2_relaxed_vs_strict():
    rep = check(make_closure("drucker_prager", delta_deg=30.0))
    assert rep.conditions["C2"].passed
    assert rep.conditions["C2"].worst_value == pytest.approx(math.sin(math.radians(30.0)), rel=1e-14)
    s = rep.conditions["C2_strict"]
    assert not s.passed and s.worst_value == 0.0  # dZ/dI = 0
    assert s.fails_where and all(r["covers_grid"] for r in s.fails_where)
    assert s.note and "dZ/dI" in s.note
    # On phi < phi_max everything else holds; at phi = phi_max (I_eq = 0) f = sin(d) does not
    # depend on I, so I df/dI = 0 and the strict C3 fails there only.
    rep_open = check(make_closure("drucker_prager", delta_deg=30.0), jammed=False)
    assert rep_open.failed() == ["C2_strict"]
    c3 = rep.conditions["C3"]
    assert not c3.passed
    assert all(r["phi_range"] == [PHI_MAX, PHI_MAX] for r in c3.fails_where)


def test_mu_i_passes_everything():
    rep = check(make_closure("mu_i"))
    assert rep.passed and rep.failed() == []
    assert not rep.not_finite
    # min of Z is mu(I) at the smallest I of the grid (jammed row, I = 1e-6): closed form.
    assert rep.conditions["Z_nonnegative"].worst_value == pytest.approx(mu_indep(1e-6), rel=1e-12)


def test_mu_i_dilatancy_fails_z_and_c2_at_small_ratio():
    """Z = mu(I) + G(I) - G(I_eq) (Robinson, eq. psi:mu(I)). Z is increasing in I, so Z < 0 below
    a single root I_z < I_eq; Z + I Z_I = mu + psi + I mu' + I psi' < 0 below a root I_2 < I_z."""
    rep = check(make_closure("mu_i_dilatancy"))
    assert set(rep.failed()) == {"Z_nonnegative", "C2"}
    for name, fun in (
        ("Z_nonnegative", lambda x, Ieq: mu_indep(x) + G_indep(x) - G_indep(Ieq)),
        ("C2", lambda x, Ieq: mu_indep(x) + G_indep(x) - G_indep(Ieq)
         + x * ((MU2 - MU1) * I0 / (x + I0) ** 2 + dG_indep(x))),
    ):
        (reg,) = failing_regions(rep, name)
        assert reg["open_below"] and not reg["open_above"]
        assert len({b["phi"] for b in reg["boundaries"]}) == len(rep.grid["phi"]) - 1  # every phi < phi_max
        for b in reg["boundaries"]:
            Ieq = (PHI_MAX - b["phi"]) / DELTA_PHI
            root = brentq(lambda x: fun(x, Ieq), 1e-12 * Ieq, Ieq, xtol=1e-300, rtol=1e-14)
            assert b["I_interval"][1] == pytest.approx(root, rel=BOUNDARY_RTOL)
            assert b["r_interval"][1] == pytest.approx(root / Ieq, rel=BOUNDARY_RTOL)
    # psi = G(I) - G(0) = +inf at phi = phi_max: reported as not finite, not as a failure.
    assert rep.not_finite and all(r["phi_range"] == [PHI_MAX, PHI_MAX] for r in rep.not_finite)
    assert rep.conditions["dissipation"].n_not_finite > 0


# ---- incompressible reference -------------------------------------------------------------------
@pytest.mark.parametrize("yield_law", ["mu_i", "drucker_prager"])
def test_incompressible_fails_equilibrium_and_c3(yield_law):
    rep = check(make_closure("incompressible", yield_law=yield_law))
    eq, c3 = rep.conditions["equilibrium"], rep.conditions["C3"]
    assert not eq.passed and "f = 0" in eq.note
    assert eq.extra["max_abs_f_at_eq"] == 0.0  # f(I_eq) = 0 itself holds
    assert not c3.passed and c3.worst_value == 0.0 and c3.note
    # C1: Z - I Z'/2 = 0 would be required; it is mu - I mu'/2 > 0 (or sin d).
    assert not rep.conditions["C1"].passed
    d = rep.to_dict()["conditions"]
    assert d["equilibrium"]["note"] and d["C3"]["note"]


# ---- report format, map, inputs ------------------------------------------------------------------
@pytest.mark.parametrize("name", CLOSURES.names())
def test_to_dict_round_trips_and_table_lists_conditions(name):
    rep = check(make_closure(name))
    d = rep.to_dict()
    text = json.dumps(d, allow_nan=False)
    assert json.loads(text) == d
    assert d["closure"] == name and isinstance(d["parameters"], dict)
    assert set(d["conditions"]) == set(CONDITION_NAMES)
    for key, c in d["conditions"].items():
        assert isinstance(c["pass"], bool) and isinstance(c["fails_where"], list)
        assert ("max_residual" if key == "C1" else "min_margin") in c
        assert c["pass"] == (not c["fails_where"])
    table = rep.summary_table()
    assert all(n in table for n in CONDITION_NAMES) and "\x1b" not in table


def test_condition_map_matches_closed_forms():
    closure = make_closure("drucker_prager_dilatancy", delta_deg=30.0)
    c = math.cos(math.radians(30.0))
    beta = 2 * (1 - c) / (2 + c)
    phi = np.linspace(0.45, 0.59, 5)
    I = np.logspace(-5, 1, 50)
    maps = condition_map(closure, phi, I, 1e3)
    assert set(maps) == set(CONDITION_NAMES)
    assert all(m.shape == (5, 50) and m.dtype == bool for m in maps.values())
    r = I[None, :] / ((PHI_MAX - phi[:, None]) / DELTA_PHI)
    np.testing.assert_array_equal(maps["Z_nonnegative"], r >= c ** (1 / beta))
    np.testing.assert_array_equal(maps["C2"], r >= (c * (1 - beta)) ** (1 / beta))
    assert maps["C1"].all() and maps["dissipation"].all() and maps["equilibrium"].all()
    mu = condition_map(make_closure("mu_i"), phi, I, 1e3, with_finite=True)
    assert all(v.all() for v in mu.values())


def test_check_rejects_bad_grids():
    closure = make_closure("mu_i")
    with pytest.raises(GranflowInputError, match="phi_values"):
        check(closure, phi_values=[0.7])
    with pytest.raises(GranflowInputError, match="p_values"):
        check(closure, p_values=[-1.0])
    with pytest.raises(GranflowInputError, match="I_ratio_range"):
        check(closure, I_ratio_range=(10.0, 1.0))


def test_user_grid_and_pressure_independence():
    """f depends on p only through I for every closure of the paper, so verdicts are p-independent:
    each boundary is reported once with the full p range."""
    rep = check(make_closure("drucker_prager_dilatancy", delta_deg=25.0), phi_values=[0.5, 0.55],
                p_values=[10.0, 1e4], n_ratio=61, jammed=False)
    assert rep.grid["phi"] == [0.5, 0.55] and rep.grid["jammed_I_range"] is None
    (reg,) = failing_regions(rep, "Z_nonnegative")
    assert [b["p_range"] for b in reg["boundaries"]] == [[10.0, 1e4], [10.0, 1e4]]
    c = math.cos(math.radians(25.0))
    assert reg["r_interval"][1] == pytest.approx(c ** ((2 + c) / (2 * (1 - c))), rel=BOUNDARY_RTOL)
