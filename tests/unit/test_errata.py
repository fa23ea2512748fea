"""Errata and pitfalls of MODEL.md §6 as tests: each item re-derived independently (SymPy or closed
form written here), then checked against granflow where granflow implements it.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from granflow import Material
from granflow.rheology import make_closure

R = sp.Rational


# ---------------------------------------------------------------------------------------------
# 1. Ideal-gas state law (paper eqs. ideal-gas0, ideal-gas, Q->H, H(p))
# ---------------------------------------------------------------------------------------------
x, rho0, patm, pf = sp.symbols("x rho_f0 p_atm p_f", positive=True)
Q_CORRECT = patm * (x / rho0 - 1)
Q_PRINTED = patm * (1 - x / rho0)  # eq. ideal-gas0 as printed
RHO_OF_PF = rho0 * (1 + pf / patm)  # eq. ideal-gas
H_PAPER = patm * x / rho0 * (sp.log(x / rho0) - 1)  # eq. H(p), first form


def test_erratum1_state_law_sign():
    """p_f = Q(rho_f(p_f)) holds for Q = p_atm(rho/rho0 - 1), not for the printed eq. ideal-gas0."""
    assert sp.simplify(Q_CORRECT.subs(x, RHO_OF_PF) - pf) == 0
    assert sp.simplify(Q_PRINTED.subs(x, RHO_OF_PF) + pf) == 0  # the printed law gives -p_f


def test_erratum1_H_solves_the_energy_ode():
    """x H' - H = Q (eq. before Q->H). The paper's H satisfies it with the corrected Q up to the
    additive constant p_atm (the integration constant c2 the paper shows to be immaterial),
    and x H'' = Q' exactly; with the printed Q the residual is not even constant."""
    lhs = x * sp.diff(H_PAPER, x) - H_PAPER
    assert sp.simplify(lhs - Q_CORRECT) == patm
    assert sp.simplify(x * sp.diff(H_PAPER, x, 2) - sp.diff(Q_CORRECT, x)) == 0
    assert sp.diff(sp.simplify(lhs - Q_PRINTED), x) != 0
    # eq. Q->H with the corrected Q, c1 = rho0 and c2 = -p_atm gives exactly the paper's H
    z = sp.Symbol("zeta", positive=True)
    H_from_Q = x * sp.integrate(Q_CORRECT.subs(x, z) / z**2, (z, rho0, x)) - patm
    assert sp.simplify(H_from_Q - H_PAPER) == 0


def test_erratum1_H_in_terms_of_pf():
    """The second form of eq. H(p): (p_atm + p_f)(ln(1 + p_f/p_atm) - 1), with rho = rho(p_f)."""
    second = (patm + pf) * (sp.log(1 + pf / patm) - 1)
    assert sp.simplify(H_PAPER.subs(x, RHO_OF_PF) - second) == 0


# ---------------------------------------------------------------------------------------------
# 2. Expansion coefficient near equilibrium (paper §6.3, text after eq. f-general)
# ---------------------------------------------------------------------------------------------
Isym = sp.Symbol("I", positive=True)
MAT = dict(phi_max=0.61, delta_phi=0.22)


def _a_correct(Z: sp.Expr) -> sp.Expr:
    """a = d_I(I W)/(delta_phi I) = (Z - (I/2) dZ/dI)/(delta_phi I)."""
    return (Z - Isym / 2 * sp.diff(Z, Isym)) / (R(MAT["delta_phi"]) * Isym)


def _a_paper(Z: sp.Expr) -> sp.Expr:
    """a = W/(delta_phi I), W = (3/(2I)) int_0^I Z - Z/2 (as printed)."""
    J = sp.Symbol("J", positive=True)
    W = R(3, 2) * sp.integrate(Z.subs(Isym, J), (J, 0, Isym)) / Isym - Z / 2
    return W / (R(MAT["delta_phi"]) * Isym)


def test_erratum2_identity():
    """d_I(I W) = Z - (I/2) dZ/dI for any Z (here a generic polynomial)."""
    c0, c1, c2 = sp.symbols("c0 c1 c2")
    Z = c0 + c1 * Isym + c2 * Isym**2
    J = sp.Symbol("J", positive=True)
    W = R(3, 2) * sp.integrate(Z.subs(Isym, J), (J, 0, Isym)) / Isym - Z / 2
    assert sp.simplify(sp.diff(Isym * W, Isym) - (Z - Isym / 2 * sp.diff(Z, Isym))) == 0


MU = dict(mu1=0.38, mu2=0.64, I0=0.3)


def _mu_sym():
    return R(MU["mu1"]) + (R(MU["mu2"]) - R(MU["mu1"])) / (1 + R(MU["I0"]) / Isym)


@pytest.mark.parametrize("I_val", [0.02, 0.1, 0.3, 1.0])
@pytest.mark.parametrize("name", ["mu_i", "drucker_prager", "power_law"])
def test_erratum2_against_finite_difference(name, I_val):
    """df/dphi at phi = phi_eq(I) by central differences on the closure's f equals the corrected a;
    the printed W/(delta_phi I) agrees for Drucker-Prager only."""
    if name == "mu_i":
        c, Z = make_closure("mu_i", material=MAT, **MU), _mu_sym()
    elif name == "drucker_prager":
        c, Z = make_closure("drucker_prager", material=MAT, delta_deg=25.0), sp.sin(sp.pi * 25 / 180)
    else:
        c = make_closure("power_law", material=MAT, exponents=(0.0, 1.0), coefficients=(0.4, 0.2))
        Z = R(2, 5) + R(1, 5) * Isym
    phi_eq = MAT["phi_max"] - MAT["delta_phi"] * I_val
    h = 1e-6
    fd = (c.f(phi_eq + h, 1e3, I_val) - c.f(phi_eq - h, 1e3, I_val)) / (2 * h)
    a_ok = float(_a_correct(Z).subs(Isym, R(I_val)))
    a_printed = float(_a_paper(Z).subs(Isym, R(I_val)))
    # FD error: (h/gap)^2 curvature + eps |f|/h ~ 1e-9 relative
    assert fd == pytest.approx(a_ok, rel=1e-6)
    if name == "drucker_prager":
        assert a_printed == pytest.approx(a_ok, rel=1e-12)
    else:  # distinguishable: 1000 times the finite-difference tolerance
        assert abs(a_printed - a_ok) > 1e-3 * abs(a_ok)
        assert fd != pytest.approx(a_printed, rel=1e-3)


def test_paper_remarks_on_a_for_dilatancy_angle_closures():
    """Confirmations (not errata): a = 2 sin(delta)/((2 + cos delta) delta_phi I) (DP + psi) and
    a = G'(I)/delta_phi (Robinson), against finite differences of the closures' f."""
    I_val, h = 0.2, 1e-6
    phi_eq = MAT["phi_max"] - MAT["delta_phi"] * I_val
    dp = make_closure("drucker_prager_dilatancy", material=MAT, delta_deg=30.0)
    s, co = math.sin(math.radians(30)), math.cos(math.radians(30))
    fd = (dp.f(phi_eq + h, 1e3, I_val) - dp.f(phi_eq - h, 1e3, I_val)) / (2 * h)
    assert fd == pytest.approx(2 * s / ((2 + co) * MAT["delta_phi"] * I_val), rel=1e-6)
    rob = make_closure("mu_i_dilatancy", material=MAT, **MU)
    x_ = I_val / MU["I0"]
    dG = 2 * MU["mu1"] / (3 * I_val) + (MU["mu2"] - MU["mu1"]) / (3 * MU["I0"]) * (
        -1 / (1 + x_) ** 2 + 2 / (1 + x_))
    fd = (rob.f(phi_eq + h, 1e3, I_val) - rob.f(phi_eq - h, 1e3, I_val)) / (2 * h)
    assert fd == pytest.approx(dG / MAT["delta_phi"], rel=1e-6)


# ---------------------------------------------------------------------------------------------
# 3. Table 1, dissipation column
# ---------------------------------------------------------------------------------------------
n, Ieq, p, S, d, rho, cI = sp.symbols("n I_eq p S d rho_s c_I", positive=True)


def _table1_f(nn):
    return (2 - nn) / (2 * (nn + 1)) * (Isym**nn - Ieq ** (nn + 1) / Isym)


def _correct_column(nn, I_expr=Isym):
    return (3 * nn / (nn + 1)) * I_expr**nn * p * S + (2 - nn) / (nn + 1) * Ieq ** (nn + 1) * p ** R(3, 2) / (
        cI * d * sp.sqrt(rho))


def _printed_general_row(nn, I_expr=Isym):
    """Paper's row I^n (first term read as I^n p|S|, c_I = 1 as in the paper)."""
    return (3 * nn / (2 * (nn + 1))) * I_expr**nn * p * S + (2 - nn) / (2 * (nn + 1)) * Ieq ** (nn + 1) * p * sp.sqrt(
        p) / (d * sp.sqrt(rho))


def test_erratum3_symbolic():
    I_of_S = cI * d * S / sp.sqrt(p / rho)
    integrand = 2 * (Isym**n - _table1_f(n)) * p * S
    assert sp.simplify((integrand - _correct_column(n)).subs(Isym, I_of_S)) == 0
    # The printed general row is exactly half of it (with c_I = 1) ...
    ratio = sp.simplify((integrand / _printed_general_row(n)).subs(Isym, I_of_S).subs(cI, 1))
    assert ratio == 2
    # ... and contradicts the paper's own n = 0 row, 2 I_eq p sqrt(p)/(d sqrt(rho_s)), which
    # the corrected column reproduces.
    row0 = 2 * Ieq * p * sp.sqrt(p) / (d * sp.sqrt(rho))
    assert sp.simplify(_correct_column(0).subs(cI, 1) - row0) == 0
    assert sp.simplify(_printed_general_row(0) - row0) != 0


@pytest.mark.parametrize("nn", [0.0, 0.5, 1.0, 3.0])
@pytest.mark.parametrize("c_I", [1.0, 2.0])
def test_erratum3_against_power_law_dissipation(nn, c_I):
    mat = Material(d=1e-4, rho_s=2600.0, phi_max=0.61, delta_phi=0.22, c_I=c_I)
    c = make_closure("power_law", material=mat, exponents=(nn,), coefficients=(1.0,))
    phi_ = np.array([0.45, 0.55, 0.6])
    pv = np.array([30.0, 1e3, 5e4])
    Sv = np.array([0.0, 0.7, 200.0])
    P_, S_, PHI_ = (a.ravel() for a in np.meshgrid(pv, Sv, phi_))
    I_ = c_I * mat.d * S_ / np.sqrt(P_ / mat.rho_s)
    Ieq_ = (mat.phi_max - PHI_) / mat.delta_phi
    expected = (3 * nn / (nn + 1)) * I_**nn * P_ * S_ + (2 - nn) / (nn + 1) * Ieq_ ** (nn + 1) * P_**1.5 / (
        c_I * mat.d * math.sqrt(mat.rho_s))
    if nn == 0:
        expected = np.where(S_ > 0, expected, (2 - nn) / (nn + 1) * Ieq_ * P_**1.5 / (c_I * mat.d * math.sqrt(mat.rho_s)))
    np.testing.assert_allclose(c.dissipation_density(PHI_, P_, S_), expected, rtol=1e-10)


# ---------------------------------------------------------------------------------------------
# 4. Dilatancy-angle closure: Z < 0 for I < I_eq / cos(delta)^(-1/beta)
# ---------------------------------------------------------------------------------------------
def test_erratum4_negative_yield_threshold():
    delta = math.radians(30.0)
    beta = 2 * (1 - math.cos(delta)) / (2 + math.cos(delta))
    ratio = math.cos(delta) ** (-1 / beta)  # Z = 0 <=> (I_eq/I)^beta = 1/cos(delta)
    assert ratio == pytest.approx(4.66, abs=0.01)
    c = make_closure("drucker_prager_dilatancy", material=MAT, delta_deg=30.0)
    phi_ = 0.55
    Ieq_ = (MAT["phi_max"] - phi_) / MAT["delta_phi"]
    I_star = Ieq_ / ratio
    assert abs(float(c.Z(phi_, I_star))) < 1e-12
    assert float(c.Z(phi_, I_star * (1 - 1e-6))) < 0 < float(c.Z(phi_, I_star * (1 + 1e-6)))
    Iv = np.logspace(-3, 0, 50) * Ieq_
    np.testing.assert_array_equal(c.Z(phi_, Iv) < 0, Iv < I_star)


def test_erratum4_robinson_negative_yield_at_small_I():
    c = make_closure("mu_i_dilatancy", material=MAT, **MU)
    phi_ = 0.55
    Ieq_ = (MAT["phi_max"] - phi_) / MAT["delta_phi"]
    assert float(c.Z(phi_, 1e-4 * Ieq_)) < 0 < float(c.Z(phi_, Ieq_))


def test_erratum5_plain_dp_marginal_and_viscosity_stabilises():
    """Item 5: plain DP has zero leading-order growth along the Coulomb direction sin 2theta = sin delta,
    and a viscous addition makes every direction strictly stable (max = -eta_visc/(2 phi rho_s), the
    closed form of the isotropic viscous block). Detailed tests: tests/unit/test_dispersion.py."""
    from granflow.theory.dispersion import leading_order_growth, leading_order_max_growth

    delta = np.radians(25.0)
    theta_c = 0.5 * np.arcsin(np.sin(delta))
    c = make_closure("drucker_prager", delta_deg=25.0)
    I, p = 1e-2, 1e3
    phi_ = float(c.equilibrium.phi_eq(I))
    lead = leading_order_max_growth(c, phi_, p, I)
    assert abs(leading_order_growth(c, phi_, p, I, theta_c)) < 1e-10 * lead.scale
    assert leading_order_growth(c, phi_, p, I, theta_c + 0.2) < -1e-4 * lead.scale
    eta_v = 0.5
    cv = make_closure("drucker_prager", delta_deg=25.0, eta_visc=eta_v)
    lead_v = leading_order_max_growth(cv, phi_, p, I)
    assert np.isclose(lead_v.growth, -eta_v / (2 * phi_ * cv.material.rho_s), rtol=1e-6)


# ---------------------------------------------------------------------------------------------
# 6. Stiffness: static compaction rate of Drucker-Prager
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("c_I", [1.0, 2.0])
def test_erratum6_static_compaction_rate(c_I):
    """|div u| at |S| = 0 = 2 lambda sin(delta)(phi_max - phi) sqrt(p), lambda = 1/(c_I delta_phi d
    sqrt(rho_s)): default glass beads (d = 80 um, rho_s = 2500, phi_max = 0.6, delta_phi = 0.2),
    delta = 25 deg, p = 1 kPa, phi = 0.58: 334 s^-1 (c_I = 2) or 668 s^-1 (c_I = 1)."""
    d_, rho_s, phi_max, dphi = 80e-6, 2500.0, 0.6, 0.2
    lam = 1.0 / (c_I * dphi * d_ * math.sqrt(rho_s))
    rate = 2 * lam * math.sin(math.radians(25.0)) * (phi_max - 0.58) * math.sqrt(1e3)
    assert 100 < rate < 1000  # "hundreds of s^-1"
    assert rate == pytest.approx(334.1 * 2 / c_I, rel=1e-3)
    c = make_closure("drucker_prager", material={"c_I": c_I}, delta_deg=25.0)
    assert float(c.div_rate(0.58, 1e3, 0.0)) == pytest.approx(-rate, rel=1e-12)
    # relaxation time of the static region: d / sqrt(p/rho_s) = 126 us (MODEL.md quotes ~50 us),
    # the package's 1/(c_I x shear-rate scale) at 1 kPa
    scale = float(c.material.shear_rate_scale(1e3))
    assert 1.0 / (c_I * scale) == pytest.approx(1.26e-4, rel=1e-2)


# ---------------------------------------------------------------------------------------------
# 7. Pore-pressure diffusivity
# ---------------------------------------------------------------------------------------------
def test_erratum7_gas_diffusivity():
    """D = p_atm kappa/(1-phi), kappa = d^2(1-phi)^3/(150 eta_f phi^2): 0.1607 m^2/s at 80 um, 0.55."""
    d_, eta, phi_, patm_ = 80e-6, 1.8e-5, 0.55, 1.013e5
    D = patm_ * d_**2 * (1 - phi_) ** 2 / (150 * eta * phi_**2)
    assert D == pytest.approx(0.16, rel=0.1)
    D_pkg = float(Material().gas_diffusivity(phi_))
    assert D_pkg == pytest.approx(D, rel=1e-12)
    # explicit diffusion limit dt < dx^2/(2D) at dx = 1 mm: ~3e-6 s
    dx, explicit_limit = 1e-3, 3.1e-6
    assert dx**2 / (2 * D_pkg) == pytest.approx(explicit_limit, rel=0.02)
    # ... which the package's implicit pore-pressure step does not have: a checkerboard at 100x
    # that limit decays monotonically (explicit Euler would amplify it by |1 - 8 D dt/dx^2| >> 1)
    from granflow.grid import Grid
    from granflow.physics.pore_pressure import step_static

    n, factor = 8, 100.0
    grid = Grid(nx=n, nz=n, Lx=n * dx, Lz=n * dx)
    phi = np.full(grid.cell_shape, phi_)
    i, j = np.indices(grid.cell_shape)
    p = 100.0 * (-1.0) ** (i + j)
    dt = factor * dx**2 / (2 * D_pkg)
    assert abs(1.0 - 8.0 * D_pkg * dt / dx**2) > 1.0
    amplitudes = [float(np.abs(p).max())]
    for _ in range(3):
        p = step_static(grid, phi, p, dt, Material())
        amplitudes.append(float(np.abs(p).max()))
    assert np.all(np.isfinite(p)) and all(b < a for a, b in zip(amplitudes, amplitudes[1:]))
