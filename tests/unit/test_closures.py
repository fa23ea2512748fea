"""Independent verification of every registered closure (Z, f) (paper Section 6, MODEL.md §3-§4).

Every test taking ``closure_case`` runs for every closure of ``CLOSURES`` and several parameter sets
(see ``conftest.py``). Reference values come from SymPy expressions written from the paper and
evaluated with mpmath at 40 digits, or from finite differences / closed-form limits; never from
numbers produced by the code under test.

Tolerances (float64 library against exact references):
* values and analytic derivatives: rtol 1e-10, plus an absolute floor 1e-12 (1 + |Z| + |f|)
  (divided by I for the I-derivatives) for the points where f = A - B/I cancels near I = I_eq
  (round-off there is ~1e-16 (|A| + |B/I|));
* limits (|S| = 0, p = 0) from the reference at I = 1e-30 / 1e1000 with 80 digits; absolute floor
  1e-12 of the rate scale 2 sqrt(p)/(c_I d sqrt(rho_s));
* central finite differences with relative step h/x = 1e-6: truncation ~ (h/x)^2 = 1e-12,
  round-off ~ eps |F| / h = 2.2e-10 |F|/x, hence rtol 1e-6 and atol 1e-8 |F|/x (45x margin);
* divergence law against 2|S| f of the same library: rtol 1e-12 (away from f = 0).
"""
from __future__ import annotations

import math
import warnings
from contextlib import contextmanager

import mpmath
import numpy as np
import pytest
import sympy as sp
from conftest import (
    CLOSURE_CASES,
    PHI,
    TAN21,
    TAN33,
    TEST_MATERIAL,
    AtPZero,
    I,
    P,
    mp_eval,
)

from granflow import EQUILIBRIUM_LAWS, GranflowInputError, Material
from granflow.rheology import make_closure
from granflow.rheology.functions import F_mu, dF_mu

RTOL_EXACT = 1e-10
ATOL_FLOOR = 1e-12
RTOL_FD = 1e-6
FD_STEP = 1e-6
ATOL_FD = 1e-8
RTOL_SELF = 1e-12

PHI_MAX = TEST_MATERIAL["phi_max"]
DELTA_PHI = TEST_MATERIAL["delta_phi"]
PHI_GRID = np.array([0.40, 0.50, 0.57, 0.605])
P_GRID = np.array([50.0, 2.0e4])
I_GRID = np.logspace(-4, 1.5, 9)


def ieq_test(phi):
    """Linear law, written here: I_eq = (phi_max - phi)/delta_phi."""
    return (PHI_MAX - np.asarray(phi)) / DELTA_PHI


def inertial_test(S, p, mat=TEST_MATERIAL):
    """I = c_I d |S| / sqrt(p/rho_s), written here."""
    return mat["c_I"] * mat["d"] * np.asarray(S) / np.sqrt(np.asarray(p) / mat["rho_s"])


def shear_for(I_val, p, mat=TEST_MATERIAL):
    """|S| giving inertial number I at pressure p."""
    return np.asarray(I_val) * np.sqrt(np.asarray(p) / mat["rho_s"]) / (mat["c_I"] * mat["d"])


def value_grid():
    """(phi, p, I) points: a log grid of I plus I = I_eq and I = I_eq (1 +- 1e-3), p alternating."""
    pts = []
    for phi in PHI_GRID:
        ieq = float(ieq_test(phi))
        for k, Iv in enumerate([*I_GRID, ieq, ieq * (1 - 1e-3), ieq * (1 + 1e-3)]):
            pts.append((phi, P_GRID[k % P_GRID.size], Iv))  # f does not depend on p at fixed I
    return tuple(np.array(c) for c in zip(*pts))


@contextmanager
def strict_fp():
    """Turn every floating-point warning (and any other warning) into an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with np.errstate(all="raise"):
            yield


_REF_CACHE: dict[int, dict[str, sp.Expr]] = {}


def ref_exprs(case) -> dict[str, sp.Expr]:
    """Reference Z, f and their partial derivatives (SymPy diff of the paper's formulas)."""
    if id(case) not in _REF_CACHE:
        Z, f = case.ref
        _REF_CACHE[id(case)] = {
            "Z": Z, "f": f,
            "dZ_dI": sp.diff(Z, I), "dZ_dphi": sp.diff(Z, PHI),
            "df_dI": sp.diff(f, I), "df_dp": sp.diff(f, P), "df_dphi": sp.diff(f, PHI),
        }
    return _REF_CACHE[id(case)]


def call(closure, quantity, phi, p, Iv):
    fn = getattr(closure, quantity)
    return np.asarray(fn(phi, Iv) if quantity.startswith("dZ") or quantity == "Z" else fn(phi, p, Iv))


# ---------------------------------------------------------------------------------------------
# (a) values and analytic derivatives against the paper's formulas
# ---------------------------------------------------------------------------------------------
QUANTITIES = ["Z", "f", "dZ_dI", "df_dI", "df_dp", "dZ_dphi", "df_dphi"]


@pytest.mark.parametrize("quantity", QUANTITIES)
def test_against_paper_formula(closure_case, quantity):
    phi, p, Iv = value_grid()
    refs = ref_exprs(closure_case)
    expected = mp_eval(refs[quantity], phi, p, Iv)
    scale = 1.0 + np.abs(mp_eval(refs["Z"], phi, p, Iv)) + np.abs(mp_eval(refs["f"], phi, p, Iv))
    if quantity.startswith("d") and quantity.endswith("_dI"):
        scale = scale / Iv
    actual = call(closure_case.closure, quantity, phi, p, Iv)
    assert actual.shape == phi.shape
    err = np.abs(actual - expected)
    bad = err > RTOL_EXACT * np.abs(expected) + ATOL_FLOOR * scale
    assert not bad.any(), (
        f"{quantity}: worst at phi={phi[bad][0]}, I={Iv[bad][0]}: got {actual[bad][0]!r}, "
        f"expected {expected[bad][0]!r}"
    )


def test_I_eq_is_linear_law(closure_case):
    np.testing.assert_allclose(closure_case.closure.I_eq(PHI_GRID), ieq_test(PHI_GRID), rtol=1e-14)


# ---------------------------------------------------------------------------------------------
# (a') finite differences of the analytic derivatives, for every equilibrium law
# ---------------------------------------------------------------------------------------------
FD_PHI = np.array([0.45, 0.52, 0.58])
FD_I = np.array([1e-3, 0.05, 0.3, 2.0])
FD_P = 3.0e3


def central(fun, x):
    h = FD_STEP * np.abs(x)
    fp, fm = fun(x + h), fun(x - h)
    return (fp - fm) / (2 * h), np.maximum(np.abs(fp), np.abs(fm)) / np.abs(x)


@pytest.mark.parametrize("law", EQUILIBRIUM_LAWS.names())
def test_derivatives_finite_difference(closure_case, law):
    c = closure_case.build(equilibrium=law)
    phi, Iv = (a.ravel() for a in np.meshgrid(FD_PHI, FD_I))
    p = np.full_like(phi, FD_P)
    checks = {
        "dZ_dI": central(lambda x: c.Z(phi, x), Iv),
        "df_dI": central(lambda x: c.f(phi, p, x), Iv),
        "df_dp": central(lambda x: c.f(phi, x, Iv), p),
        "dZ_dphi": central(lambda x: c.Z(x, Iv), phi),
        "df_dphi": central(lambda x: c.f(x, p, Iv), phi),
    }
    for name, (fd, mag) in checks.items():
        analytic = call(c, name, phi, p, Iv)
        err = np.abs(analytic - fd)
        bad = err > RTOL_FD * np.abs(fd) + ATOL_FD * mag
        assert not bad.any(), f"{name} ({law}): analytic {analytic[bad]} vs FD {fd[bad]}"


# ---------------------------------------------------------------------------------------------
# (b) the stiff-safe divergence law
# ---------------------------------------------------------------------------------------------
DIV_PHI = np.array([0.45, 0.55, 0.60])
DIV_P = np.array([30.0, 1.0e3, 5.0e4])
DIV_RATIO = np.array([0.2, 0.6, 1.7, 6.0])  # I / I_eq, away from f = 0


@pytest.mark.parametrize("c_I", [1.0, 2.0])
def test_div_rate_regular(closure_case, c_I):
    mat = {**TEST_MATERIAL, "c_I": c_I}
    c = closure_case.build(c_I=c_I)
    phi, p, ratio = (a.ravel() for a in np.meshgrid(DIV_PHI, DIV_P, DIV_RATIO))
    Iv = ratio * ieq_test(phi)
    S = shear_for(Iv, p, mat)
    Iv = inertial_test(S, p, mat)
    with strict_fp():
        div = c.div_rate(phi, p, S)
        self_consistent = 2 * S * c.f(phi, p, Iv)
    np.testing.assert_allclose(div, self_consistent, rtol=RTOL_SELF, atol=1e-300)
    expected = 2 * S * mp_eval(closure_case.ref[1], phi, p, Iv)
    np.testing.assert_allclose(div, expected, rtol=RTOL_EXACT, atol=1e-300)


def _lim_I_f_at_zero(case, phi, p):
    """lim_{I->0} I f(phi, I), from the reference evaluated at I = 1e-30 with 80 digits."""
    return mp_eval(I * case.ref[1], phi, p, "1e-30", dps=80)


@pytest.mark.parametrize("c_I", [1.0, 2.0])
def test_div_rate_at_rest(closure_case, c_I):
    """|S| = 0: div u = lim 2|S| f = -2 sqrt(p)/(c_I d sqrt(rho_s)) lim_{I->0} (I f); no NaN."""
    mat = {**TEST_MATERIAL, "c_I": c_I}
    c = closure_case.build(c_I=c_I)
    phi, p = (a.ravel() for a in np.meshgrid(DIV_PHI, [0.0, *DIV_P]))
    with strict_fp():
        div = c.div_rate(phi, p, np.zeros_like(phi))
    assert np.all(np.isfinite(div))
    lim = _lim_I_f_at_zero(closure_case, phi, np.where(p > 0, p, 1.0))
    rate_scale = 2 * np.sqrt(p) / (mat["c_I"] * mat["d"] * math.sqrt(mat["rho_s"]))  # [s^-1]
    expected = rate_scale * lim
    # atol: 1e-12 of the rate scale (the limit taken at I = 1e-30 is off by < 1e-20 of it).
    np.testing.assert_allclose(div, expected, rtol=RTOL_EXACT, atol=1e-12 * np.max(rate_scale))


def test_div_rate_zero_pressure(closure_case):
    """p = 0 < |S| (I = inf): 2|S| f(I -> inf); +-inf only where f is unbounded (declared by hand)."""
    c = closure_case.closure
    phi = DIV_PHI
    S = np.full_like(phi, 3.0)
    with strict_fp():
        div = c.div_rate(phi, np.zeros_like(phi), S)
    assert not np.any(np.isnan(div))
    if closure_case.at_p_zero == AtPZero.FINITE:
        expected = 2 * S * mp_eval(closure_case.ref[1], phi, 1.0, "1e1000", dps=80)
        np.testing.assert_allclose(div, expected, rtol=RTOL_EXACT, atol=1e-300)
    else:
        sign = 1.0 if closure_case.at_p_zero == AtPZero.PLUS_INF else -1.0
        assert np.all(div == sign * np.inf), div


def test_div_rate_at_rest_and_zero_pressure(closure_case):
    c = closure_case.closure
    with strict_fp():
        div = c.div_rate(DIV_PHI, np.zeros(3), np.zeros(3))
    np.testing.assert_array_equal(div, 0.0)


@pytest.mark.parametrize("delta_deg", [21.0, 30.0])
@pytest.mark.parametrize("c_I", [1.0, 2.0])
def test_drucker_prager_static_compaction_closed_form(delta_deg, c_I):
    """eq. syst4DP: div u = 2 sin(delta)|S| - 2 lambda sin(delta)(phi_max - phi) sqrt(p),
    lambda = 1/(c_I delta_phi d sqrt(rho_s)) (c_I = 1: the paper's lambda)."""
    mat = {**TEST_MATERIAL, "c_I": c_I}
    c = make_closure("drucker_prager", material=mat, delta_deg=delta_deg)
    phi, p, S = (a.ravel() for a in np.meshgrid(DIV_PHI, DIV_P, [0.0, 0.5, 40.0]))
    lam = 1.0 / (c_I * mat["delta_phi"] * mat["d"] * math.sqrt(mat["rho_s"]))
    s = math.sin(math.radians(delta_deg))
    expected = 2 * s * S - 2 * lam * s * (mat["phi_max"] - phi) * np.sqrt(p)
    np.testing.assert_allclose(c.div_rate(phi, p, S), expected, rtol=1e-12)
    G = 2 * lam * s * (mat["phi_max"] - phi)
    np.testing.assert_allclose(c.compaction_coefficient(phi), G, rtol=1e-12)


def test_c_I_convention_halves_dp_compaction():
    phi, p = 0.55, 1.0e3
    rates = [make_closure("drucker_prager", material={**TEST_MATERIAL, "c_I": cI}).div_rate(phi, p, 0.0)
             for cI in (1.0, 2.0)]
    assert rates[0] < 0
    assert rates[1] == pytest.approx(rates[0] / 2, rel=1e-14)


# ---------------------------------------------------------------------------------------------
# (c) the mu(I) function F(I) (eq. F-mu(I))
# ---------------------------------------------------------------------------------------------
MU_PARAMS = [(0.38, 0.64, 0.3), (TAN21, TAN33, 0.3), (0.32, 0.60, 0.4)]
X_GRID = np.logspace(-12, 3, 61)


def _F_mp(x, mu1, mu2):
    x = mpmath.mpf(x)
    return mu2 + (mu2 - mu1) / 2 * (1 / (1 + x) - 3 * mpmath.log1p(x) / x)


def _dF_mp(x, mu1, mu2, I0):
    return mpmath.diff(lambda y: _F_mp(y / I0, mu1, mu2), x * I0)


@pytest.mark.parametrize("mu1,mu2,I0", MU_PARAMS)
def test_F_limits_and_small_I(mu1, mu2, I0):
    with strict_fp():
        ends = F_mu(np.array([0.0, np.inf]), mu1, mu2, I0)
        F = F_mu(X_GRID * I0, mu1, mu2, I0)
        dF = dF_mu(X_GRID * I0, mu1, mu2, I0)
        c = make_closure("mu_i", mu1=mu1, mu2=mu2, I0=I0)
        Fc = c.F(X_GRID * I0)
    np.testing.assert_allclose(ends, [mu1, mu2], rtol=1e-15)
    with mpmath.workdps(50):
        F_ref = np.array([float(_F_mp(x, mu1, mu2)) for x in X_GRID])
        dF_ref = np.array([float(_dF_mp(x, mu1, mu2, I0)) for x in X_GRID])
    # F ~ mu1..mu2 has no cancellation left in a correct implementation: rtol 1e-13.
    np.testing.assert_allclose(F, F_ref, rtol=1e-13)
    np.testing.assert_allclose(Fc, F_ref, rtol=1e-13)
    # F' by the direct formula loses ~3 eps/x relative to H' ~ 1/2 just above the series switch
    # (x = 1e-2): ~1e-13. rtol 1e-11.
    np.testing.assert_allclose(dF, dF_ref, rtol=1e-11)
    assert F_mu(1e-300, mu1, mu2, I0) == pytest.approx(mu1, rel=1e-15)


def test_mu_i_f_small_I_no_cancellation():
    """f at I/I0 down to 1e-12 against mpmath (B/I dominates; relative accuracy kept)."""
    mu1, mu2, I0 = TAN21, TAN33, 0.3
    c = make_closure("mu_i", material=TEST_MATERIAL, mu1=mu1, mu2=mu2, I0=I0)
    phi = 0.55
    ieq = float(ieq_test(phi))
    Iv = X_GRID[X_GRID < 1e2] * I0
    with strict_fp():
        f = c.f(phi, 1e3, Iv)
    with mpmath.workdps(50):
        ref = np.array([float(_F_mp(i / I0, mu1, mu2) - mpmath.mpf(ieq) / i * _F_mp(ieq / I0, mu1, mu2))
                        for i in Iv])
    np.testing.assert_allclose(f, ref, rtol=1e-12, atol=1e-14)


# ---------------------------------------------------------------------------------------------
# (d) C1
# ---------------------------------------------------------------------------------------------
C1_RATIO = np.logspace(-3, 3, 25)


def _c1_relative(c, phi, Iv):
    p = np.full_like(Iv, 1.0e3)
    Z, dZ = c.Z(phi, Iv), c.dZ_dI(phi, Iv)
    f, df = c.f(phi, p, Iv), c.df_dI(phi, p, Iv)
    res = Z - Iv / 2 * dZ - (f + Iv * df)
    return np.abs(res) / (np.abs(Z) + np.abs(Iv * dZ / 2) + np.abs(f) + np.abs(Iv * df))


@pytest.mark.parametrize("law", EQUILIBRIUM_LAWS.names())
def test_C1(closure_case, law):
    """C1: Z - (I/2) dZ/dI = f + I df/dI, for every non-reference closure; violated by the
    references (Roux-Radjai and incompressible)."""
    c = closure_case.build(equilibrium=law)
    phi = np.repeat([0.45, 0.55, 0.60], C1_RATIO.size)
    Iv = np.tile(C1_RATIO, 3) * c.equilibrium.I_eq(phi)
    rel = _c1_relative(c, phi, Iv)
    if closure_case.is_reference:
        assert np.max(rel) > 1e-2
    else:
        assert np.max(rel) < 1e-9


def test_C1_reference_formulas(closure_case):
    """The paper's formulas themselves: SymPy residual of C1 is 0 (to 30 digits) for the paper's
    closures and clearly non-zero for Roux-Radjai and incompressible."""
    Z, f = closure_case.ref
    res = Z - I / 2 * sp.diff(Z, I) - (f + I * sp.diff(f, I))
    phi, Iv = (a.ravel() for a in np.meshgrid([0.45, 0.55, 0.60], [1e-3, 0.1, 1.0, 10.0]))
    val = mp_eval(res, phi, 1.0e3, Iv)
    if closure_case.is_reference:
        assert np.max(np.abs(val)) > 1e-2
        assert sp.simplify(res) != 0
    else:
        assert np.max(np.abs(val)) < 1e-25 * (1 + np.max(np.abs(mp_eval(Z, phi, 1.0, Iv)))) or np.max(
            np.abs(val)) < 1e-20


def test_roux_radjai_C1_residual_closed_form():
    """Roux-Radjai with Drucker-Prager yield: residual = sin(delta) - a(phi - phi_max + 2 delta_phi I)."""
    a, delta = 2.0, 28.0
    c = make_closure("roux_radjai", material=TEST_MATERIAL, yield_law="drucker_prager", delta_deg=delta, a=a)
    phi, Iv = 0.55, np.array([0.01, 0.1, 1.0])
    res = c.Z(phi, Iv) - Iv / 2 * c.dZ_dI(phi, Iv) - (c.f(phi, 1e3, Iv) + Iv * c.df_dI(phi, 1e3, Iv))
    expected = math.sin(math.radians(delta)) - a * (phi - PHI_MAX + 2 * DELTA_PHI * Iv)
    np.testing.assert_allclose(res, expected, rtol=1e-12)
    assert np.all(np.abs(expected) > 0.1)


# ---------------------------------------------------------------------------------------------
# (e) dissipation density
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("eta_visc", [0.0, 0.05])
def test_dissipation_density(closure_case, eta_visc):
    c = closure_case.build(eta_visc=eta_visc)
    phi, p, ratio = (a.ravel() for a in np.meshgrid(DIV_PHI, DIV_P, [0.05, 0.6, 1.0, 1.7, 6.0]))
    S = shear_for(ratio * ieq_test(phi), p)
    Iv = inertial_test(S, p)
    Zr = mp_eval(closure_case.ref[0], phi, p, Iv)
    fr = mp_eval(closure_case.ref[1], phi, p, Iv)
    expected = 2 * (Zr - fr) * p * S + 2 * eta_visc * S**2
    with strict_fp():
        got = c.dissipation_density(phi, p, S)
    atol = 1e-12 * 2 * p * S * (np.abs(Zr) + np.abs(fr) + 1)
    bad = np.abs(got - expected) > RTOL_EXACT * np.abs(expected) + atol
    assert not bad.any(), (got[bad], expected[bad])


def test_dissipation_viscous_only_at_p_zero():
    c = make_closure("drucker_prager", material=TEST_MATERIAL, eta_visc=0.1)
    with strict_fp():
        d = c.dissipation_density(0.55, 0.0, 4.0)
    assert d == pytest.approx(2 * 0.1 * 16.0, rel=1e-14)


# ---------------------------------------------------------------------------------------------
# (f) parameter validation
# ---------------------------------------------------------------------------------------------
BAD_INPUT = [
    ("mu_i", dict(mu3=0.5), "mu3"),
    ("mu_i", dict(material={"d": -1e-6}), "d"),
    ("mu_i", dict(mu1=0.6, mu2=0.4), "mu2"),
    ("mu_i_dilatancy", dict(mu1=0.6, mu2=0.6), "mu2"),
    ("roux_radjai", dict(yield_law="mu_i", mu1=0.6, mu2=0.4), "mu2"),
    ("drucker_prager", dict(delta_deg=95.0), "delta_deg"),
    ("drucker_prager", dict(delta_deg=-5.0), "delta_deg"),
    ("drucker_prager_dilatancy", dict(delta_deg=0.0), "delta_deg"),
    ("drucker_prager_dilatancy", dict(delta_deg=90.0), "delta_deg"),
    ("power_law", dict(exponents=(-1.0,), coefficients=(1.0,)), "exponents"),
    ("power_law", dict(exponents=(0.0, -1.5), coefficients=(1.0, 1.0)), "exponents"),
    ("power_law", dict(exponents=(0.0, 1.0), coefficients=(1.0,)), "coefficients"),
    ("generic", dict(expression="0.4 + * I"), "expression"),
    ("generic", dict(expression="0.4 + q*I"), "expression"),
    ("generic", dict(expression=""), "expression"),
    ("roux_radjai", dict(yield_law="coulomb"), "yield_law"),
    ("roux_radjai", dict(a=-1.0), "a"),
    ("mu_i", dict(equilibrium="robinson", equilibrium_params={"A": -1.0}), "A"),
    ("mu_i", dict(equilibrium="breard", equilibrium_params={"delta_phi": 0.1}), "delta_phi"),
]


@pytest.mark.parametrize("name,kwargs,key", BAD_INPUT, ids=[f"{n}-{k}" for n, _, k in BAD_INPUT])
def test_bad_parameters_raise_naming_the_key(name, kwargs, key):
    with pytest.raises(GranflowInputError) as info:
        make_closure(name, **kwargs)
    msg = str(info.value)
    # The key must be named by the message itself, not merely appear in the echoed input.
    stated = " ".join(part.split(" (got ")[0] for part in msg.split("; "))
    assert key in stated.replace("(value)", ""), msg


def test_unknown_closure_and_law_names():
    with pytest.raises(GranflowInputError, match="mu_j"):
        make_closure("mu_j")
    with pytest.raises(GranflowInputError, match="linaer"):
        make_closure("mu_i", equilibrium="linaer")


def test_material_and_equilibrium_phi_max_must_agree():
    with pytest.raises(GranflowInputError, match="phi_max"):
        make_closure("mu_i", equilibrium_params={"phi_max": 0.55})
    assert make_closure("mu_i", material=Material(phi_max=0.62)).equilibrium.phi_max == 0.62


def test_every_registered_closure_has_cases():
    from granflow.rheology import CLOSURES

    assert {c.name for c in CLOSURE_CASES} == set(CLOSURES.names())


# ---------------------------------------------------------------------------------------------
# robustness: every law, extreme states (empty cell, phi >= phi_max, rest, zero pressure)
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("law", EQUILIBRIUM_LAWS.names())
def test_div_rate_and_dissipation_never_nan(closure_case, law):
    """div_rate and dissipation_density at phi in {0, 0.3, phi_max, phi_max + 0.02}, p in {0, 1e3},
    |S| in {0, 1}: no NaN, no warning (+-inf allowed where I_eq or f is infinite); both are 0 at
    p = |S| = 0 and the dissipation is >= 0."""
    c = closure_case.build(equilibrium=law)
    phi, p, S = (a.ravel() for a in np.meshgrid([0.0, 0.3, PHI_MAX, PHI_MAX + 0.02], [0.0, 1e3], [0.0, 1.0]))
    with strict_fp():
        div = c.div_rate(phi, p, S)
        dis = c.dissipation_density(phi, p, S)
    assert not np.any(np.isnan(div)) and not np.any(np.isnan(dis))
    rest = (p == 0) & (S == 0)
    np.testing.assert_array_equal(div[rest], 0.0)
    np.testing.assert_array_equal(dis[rest], 0.0)


@pytest.mark.parametrize("mu1,mu2,I0", MU_PARAMS)
def test_mu_of_I_limits(mu1, mu2, I0):
    from granflow.rheology.functions import mu_of_I

    with strict_fp():
        vals = mu_of_I(np.array([0.0, I0, np.inf]), mu1, mu2, I0)
    np.testing.assert_allclose(vals, [mu1, (mu1 + mu2) / 2, mu2], rtol=1e-15)


def test_nan_propagates(closure_case):
    """A NaN pressure or shear rate gives NaN (never a finite number hiding it from NaN checks); so
    does a NaN packing fraction in the divergence law, for every closure whose f depends on phi."""
    c = closure_case.closure
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for args in [(0.5, np.nan, 1.0), (0.5, 1e3, np.nan)]:
            assert np.isnan(c.div_rate(*args)), args
            assert np.isnan(c.dissipation_density(*args)), args
        if closure_case.name != "incompressible":
            assert np.isnan(c.div_rate(np.nan, 1e3, 1.0))


def test_dp_dilatancy_at_phi_max_and_rest_is_finite():
    """Regression (found by the solver): at phi = phi_max and I = 0, I_eq/I was 0/0. With I_eq = 0
    the dilatancy angle is psi = sin(delta)/(1 - cos(delta)) for every I > 0; the same value is
    taken at I = 0."""
    c = make_closure("drucker_prager_dilatancy", delta_deg=30.0)
    d = np.radians(30.0)
    K = np.sin(d) / (1 - np.cos(d))
    phi_max = c.material.phi_max
    assert np.isclose(float(c.psi(phi_max, 0.0)), K, rtol=1e-14)
    assert np.isclose(float(c.Z(phi_max, 0.0)), np.sin(d) + np.cos(d) * K, rtol=1e-14)
    assert np.isnan(float(c.psi(phi_max, np.nan)))


@pytest.mark.parametrize("x", [0.0, 1e-9, 1e-4, 3e-3, 9.999e-3, 1e-2, 1.0001e-2, 0.1, 1.0, 37.0, 1e6])
def test_H_and_dH_against_sympy_across_the_series_switch(x):
    """functions.H, H' (series below SERIES_SWITCH, closed form above) against SymPy's closed form
    at 30 digits (its limit at x = 0): 1e-12 absolute (H ~ 1; just above the switch the closed form
    of H' cancels terms of size 3/x^2 = 3e4, measured error 2.7e-14). A wrong series coefficient
    of x^0 .. x^7 shows (the x^2 one by 2.4e-5); one of x^8 is below 1e-16 at the switch."""
    from granflow.rheology.functions import H, dH

    X = sp.Symbol("x", positive=True)
    h = 1 / (1 + X) - 3 * sp.log(1 + X) / X
    ref = (sp.limit(h, X, 0), sp.limit(sp.diff(h, X), X, 0)) if x == 0.0 else (
        h.subs(X, sp.Rational(repr(x))).evalf(30), sp.diff(h, X).subs(X, sp.Rational(repr(x))).evalf(30))
    assert abs(float(H(x)) - float(ref[0])) <= 1e-12
    assert abs(float(dH(x)) - float(ref[1])) <= 1e-12
