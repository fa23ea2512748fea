"""Linear stability about uniform simple shear (granflow.theory.dispersion).

Independent references used here:
* a SymPy linearisation of the nonlinear equations syst1b-syst4b written out below (plane-wave
  perturbation of every field, d/d(epsilon) at 0), solved by eliminating p_hat and calling
  numpy's standard eigensolver — checks the finite-k assembly;
* the finite-k eigenvalues at large k — check the leading-order problem (MODEL.md §8);
* closed forms derived by hand: the incompressible eigenvalue
  Lambda = eta/(2 phi rho_s) ((1-nu) s^2 - b s + nu)/(b s - 1), s = sin 2 theta, b = mu (1 - nu/2);
  the Drucker-Prager compaction mode lambda -> 2|S| phi f_phi s/(sin(delta) - s) as k -> inf; the
  DP + viscosity maximum -eta_visc/(2 phi rho_s); the gas mode -p_atm kappa/(1 - phi);
* central finite differences of the closures' Z and f for the C1 check.
Tolerances are stated at each assertion; "scale" is eta/(phi rho_s) [m^2/s].
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp

from granflow.errors import GranflowInputError
from granflow.rheology import make_closure
from granflow.theory.dispersion import (
    GasLaw,
    base_state,
    dispersion_eigenvalues,
    growth_curve,
    growth_rate,
    leading_order_eigenvalues,
    leading_order_matrix,
    leading_order_max_growth,
    most_unstable,
)

I_REF = 1e-2
P_REF = 1e3  # Pa
RHO_S = 2500.0


def _phi_eq(c, I):
    return float(c.equilibrium.phi_eq(I))


# ---- independent SymPy linearisation of syst1b-syst4b ------------------------------------------
@pytest.fixture(scope="module")
def sympy_pencil():
    """Lambdified (A, B) of lambda B x = A x, x = (Phi, U, W, P, Pf), from the nonlinear equations
    with Z and f replaced by their first-order Taylor polynomials about the base state (only first
    derivatives enter a linearisation). Evaluated at x = z = t = 0, where u0 = 0 (no Doppler term).
    """
    x, z, t, eps, lam = sp.symbols("x z t epsilon lambda")
    Ph, Uh, Wh, Pp, Pf = sp.symbols("Phi U W P Pf")
    phi0, p0, gd, rho, cI, d, kap0, patm, k = sp.symbols("phi0 p0 gd rho cI d kap0 patm k", positive=True)
    Z0, Zphi, ZI, f0, fphi, fp, fI, etav, kap1, pf0, th, nl = sp.symbols(
        "Z0 Zphi ZI f0 fphi fp fI etav kap1 pf0 th nl", real=True)
    E = sp.exp(sp.I * k * (x * sp.cos(th) + z * sp.sin(th)) + lam * t)
    phi = phi0 + eps * Ph * E
    vel = (gd * z + eps * Uh * E, eps * Wh * E)
    p = p0 + eps * Pp * E
    pf = pf0 + eps * Pf * E
    X = (x, z)
    G = sp.Matrix(2, 2, lambda i, j: sp.diff(vel[i], X[j]))
    div = G[0, 0] + G[1, 1]
    S = (G + G.T) / 2 - div / 2 * sp.eye(2)
    Snorm = sp.sqrt(sum(S[i, j] ** 2 for i in range(2) for j in range(2)) / 2)
    I_ = cI * d * Snorm * sp.sqrt(rho / p)
    I0 = cI * d * (gd / 2) * sp.sqrt(rho / p0)
    Z = Z0 + Zphi * (phi - phi0) + ZI * (I_ - I0)
    f = f0 + fphi * (phi - phi0) + fp * (p - p0) + fI * (I_ - I0)
    tau = Z * p * S / Snorm + etav * S
    K = (kap0 + kap1 * (phi - phi0)) * (patm + nl * pf)   # nl = 0: syst2b, nl = 1: nonlinear law
    u, w = vel
    R = [
        sp.diff(phi, t) + sp.diff(phi * u, x) + sp.diff(phi * w, z),
        *[phi * rho * (sp.diff(vel[i], t) + u * sp.diff(vel[i], x) + w * sp.diff(vel[i], z))
          + sp.diff(p, X[i]) + sp.diff(pf, X[i]) - sum(sp.diff(tau[i, j], X[j]) for j in range(2))
          for i in range(2)],
        div - 2 * Snorm * f,
        sp.diff((1 - phi) * pf, t) + sp.diff((1 - phi) * pf * u, x) + sp.diff((1 - phi) * pf * w, z)
        + patm * div - sum(sp.diff(K * sp.diff(pf, X[j]), X[j]) for j in range(2)),
    ]
    lin = [sp.expand(sp.diff(r, eps).subs(eps, 0).subs({x: 0, z: 0, t: 0})) for r in R]
    unknowns = [Ph, Uh, Wh, Pp, Pf]
    full = sp.Matrix([[sp.diff(row, v) for v in unknowns] for row in lin])
    B = full.applyfunc(lambda e: sp.diff(e, lam))
    A = -(full - B * lam).applyfunc(sp.expand)
    params = (phi0, p0, gd, rho, cI, d, Z0, Zphi, ZI, f0, fphi, fp, fI, etav, kap0, kap1, patm, pf0, nl, k, th)
    return sp.lambdify(params, A, "numpy"), sp.lambdify(params, B, "numpy")


def _sympy_eigenvalues(pencil, closure, phi, p, I, k, theta, p_f, gas):
    fA, fB = pencil
    m = closure.material
    S = I * np.sqrt(p / m.rho_s) / (m.c_I * m.d)
    kappa = m.d**2 * (1 - phi) ** 3 / (150 * m.eta_f * phi**2)   # Carman-Kozeny, eq. beta/kappa
    vals = (phi, p, 2 * S, m.rho_s, m.c_I, m.d, float(closure.Z(phi, I)), float(closure.dZ_dphi(phi, I)),
            float(closure.dZ_dI(phi, I)), float(closure.f(phi, p, I)), float(closure.df_dphi(phi, p, I)),
            float(closure.df_dp(phi, p, I)), float(closure.df_dI(phi, p, I)), closure.eta_visc, kappa,
            123.0, m.p_atm, p_f, 1.0 if gas == "nonlinear" else 0.0, k, theta)
    A = np.array(fA(*vals), dtype=complex)
    B = np.array(fB(*vals), dtype=complex)
    constraint, pressure, others = 3, 3, [0, 1, 2, 4]
    # eliminate p_hat with the constraint row (Gamma != 0), then a standard eigenproblem
    A_red = A[np.ix_(others, others)] - np.outer(A[others, pressure], A[constraint, others]) / A[constraint, pressure]
    return np.linalg.eigvals(np.linalg.solve(B[np.ix_(others, others)], A_red))


@pytest.mark.parametrize("name, params, gas, p_f", [
    ("mu_i", {"eta_visc": 0.5}, "linear", 3e4),
    ("roux_radjai", {}, "nonlinear", 3e4),
    ("drucker_prager_dilatancy", {}, "linear", 0.0),
    ("mu_i_dilatancy", {}, "nonlinear", 1e4),
    ("drucker_prager", {}, "linear", 0.0),
])
def test_finite_k_matches_sympy_linearisation(sympy_pencil, name, params, gas, p_f):
    c = make_closure(name, **params)
    I, p = 0.02, 2e3
    phi = _phi_eq(c, I) - 0.003          # off equilibrium: f != 0, every coefficient active
    for k in (10.0, 1e3, 1e5):
        for theta in (0.3, 1.3, 2.5):
            ref = _sympy_eigenvalues(sympy_pencil, c, phi, p, I, k, theta, p_f, gas)
            got = dispersion_eigenvalues(c, phi, p, I, k, theta, p_f=p_f, gas=gas)
            assert got.size == ref.size == 4
            for v in ref:   # every reference eigenvalue is matched to 1e-7 relative (or 1e-7 1/s)
                assert np.min(np.abs(got - v)) <= 1e-7 * max(abs(v), 1.0), (k, theta, v, got)


# ---- finite k -> leading order ----------------------------------------------------------------
K_SEQUENCE = (1e4, 1e5, 1e6, 1e7, 1e8)   # 1/m, d = 80 um


@pytest.mark.parametrize("name", ["mu_i", "drucker_prager_dilatancy", "roux_radjai", "incompressible"])
@pytest.mark.parametrize("gas, p_f", [("none", 0.0), ("linear", 2e4)])
def test_finite_k_converges_to_leading_order(name, gas, p_f):
    c = make_closure(name)
    phi = _phi_eq(c, I_REF)
    st = base_state(c, phi, P_REF, I_REF, p_f, gas)
    scale = st.eta / (phi * RHO_S)
    for theta in (0.3, 1.0, 2.2):
        Lam = leading_order_eigenvalues(c, phi, P_REF, I_REF, theta, p_f=p_f, gas=gas)
        errors = []
        for k in K_SEQUENCE:
            lam = dispersion_eigenvalues(c, phi, P_REF, I_REF, k, theta, p_f=p_f, gas=gas) / k**2
            assert lam.size == Lam.size + 1          # + the O(1) compaction (phi) mode
            errors.append(max(np.min(np.abs(lam - L)) for L in Lam) / scale)
            # the extra mode is O(1) (|lambda| < 1e5 1/s here, at every k): lambda / k^2 -> 0
            extra = lam[np.argmax([np.min(np.abs(L - Lam)) for L in lam])]
            assert abs(extra) * k**2 < 1e5
        assert errors[-1] < 1e-8, errors
        # decreasing until the round-off floor (1e-9 of scale; RR has |Lambda| ~ 1e3 scale)
        assert all(b <= a or b < 1e-9 for a, b in zip(errors, errors[1:])), errors


def test_roux_radjai_growth_scales_as_k_squared():
    c = make_closure("roux_radjai")
    phi = _phi_eq(c, I_REF)
    lo = leading_order_max_growth(c, phi, P_REF, I_REF)
    assert lo.growth > 0
    ratios = [growth_rate(c, phi, P_REF, I_REF, k, lo.theta) / k**2 / lo.growth for k in (1e5, 1e6, 1e7)]
    assert abs(ratios[-1] - 1) < 1e-6
    assert abs(ratios[0] - 1) > abs(ratios[1] - 1) > abs(ratios[2] - 1)


# ---- leading order: boundedness ---------------------------------------------------------------
PAPER_CASES = [
    ("drucker_prager", {}),
    ("mu_i", {}),
    ("drucker_prager_dilatancy", {}),
    ("mu_i_dilatancy", {}),
    ("power_law", {}),
    ("generic", {}),
    ("generic", {"expression": "0.38 + 0.27*I/(I + 0.3) + 0.2*(0.6 - phi)"}),
]


@pytest.mark.parametrize("name, params", PAPER_CASES)
def test_paper_closures_bounded_growth(name, params):
    c = make_closure(name, **params)
    for I in (1e-3, 1e-2, 0.1, 0.5):
        for dphi in (0.0, -0.01, 0.002):         # on and off equilibrium
            phi = _phi_eq(c, I) + dphi
            if not (0 < phi < c.material.phi_max) or c.Z(phi, I) <= 0:
                continue                          # dilatancy closures: only their Z > 0 range
            r = leading_order_max_growth(c, phi, P_REF, I, n_theta=120)
            assert r.growth <= 1e-10 * r.scale, (I, dphi, r.growth / r.scale)


@pytest.mark.parametrize("params, I_values", [
    ({}, (1e-4, 1e-3, 1e-2)),
    ({"yield_law": "drucker_prager"}, (1e-4, 1e-2, 0.1, 1.0)),
    ({"a": 100.0}, (0.1, 1.0)),
])
def test_roux_radjai_unbounded_growth(params, I_values):
    c = make_closure("roux_radjai", **params)
    for I in I_values:
        r = leading_order_max_growth(c, _phi_eq(c, I), P_REF, I, n_theta=120)
        assert r.growth > 1e-4 * r.scale, I


def test_roux_radjai_mu_i_well_posed_window():
    """Violating C1 is not sufficient for ill-posedness: with the mu(I) yield and a = 1,
    Roux-Radjai is well posed at leading order for intermediate I (roughly Barker's window),
    ill posed below it (previous test)."""
    c = make_closure("roux_radjai")
    for I in (0.1, 0.3):
        r = leading_order_max_growth(c, _phi_eq(c, I), P_REF, I, n_theta=120)
        assert r.growth < -1e-3 * r.scale, I


def test_incompressible_closed_form():
    """Hand-derived single eigenvalue of the constrained problem (module docstring)."""
    mu1, mu2, i0 = 0.38, 0.64, 0.3
    for yield_law in ("mu_i", "drucker_prager"):
        c = make_closure("incompressible", yield_law=yield_law, mu1=mu1, mu2=mu2, I0=i0, delta_deg=25.0)
        for I in (1e-3, 0.05, 2.0):
            if yield_law == "mu_i":
                mu = mu1 + (mu2 - mu1) * I / (I + i0)
                nu = I * (mu2 - mu1) * i0 / (I + i0) ** 2 / mu
            else:
                mu, nu = np.sin(np.radians(25.0)), 0.0
            S = I * np.sqrt(P_REF / RHO_S) / (2.0 * 80e-6)
            eta, b, phi = mu * P_REF / S, mu * (1 - nu / 2), 0.58
            for theta in np.linspace(0.05, 3.1, 13):
                s = np.sin(2 * theta)
                expected = eta / (2 * phi * RHO_S) * ((1 - nu) * s**2 - b * s + nu) / (b * s - 1)
                got = leading_order_eigenvalues(c, phi, P_REF, I, theta, gas="none")
                assert got.size == 1
                assert got[0].real == pytest.approx(expected, rel=1e-10, abs=1e-14 * eta / (phi * RHO_S))


def test_drucker_prager_marginal_along_coulomb_direction():
    delta = 25.0
    c = make_closure("drucker_prager", delta_deg=delta)
    phi = _phi_eq(c, I_REF)
    r = leading_order_max_growth(c, phi, P_REF, I_REF, gas="none")
    assert abs(r.growth) <= 1e-10 * r.scale
    assert np.sin(2 * r.theta) == pytest.approx(np.sin(np.radians(delta)), abs=1e-6)
    th, g = np.array(r.thetas), np.array(r.growths)
    coulomb = np.array([np.radians(delta) / 2, np.pi / 2 - np.radians(delta) / 2])
    far = np.min(np.abs(th[:, None] - coulomb[None, :]), axis=1) > 0.01
    assert np.all(g[far] < -1e-6 * r.scale)
    # viscous addition: strictly negative; the max is exactly -eta_visc/(2 phi rho_s) (u along m)
    for eta_visc in (0.1, 1.0):
        cv = make_closure("drucker_prager", delta_deg=delta, eta_visc=eta_visc)
        rv = leading_order_max_growth(cv, phi, P_REF, I_REF, gas="none")
        assert rv.growth == pytest.approx(-eta_visc / (2 * phi * RHO_S), rel=1e-8)
        assert np.all(np.array(rv.growths) < 0)


def test_drucker_prager_compaction_mode_closed_form():
    """k -> inf limit of the O(1) mode: lambda = 2|S| phi f_phi s/(sin(delta) - s), with
    f_phi = sin(delta)/(delta_phi I) for the linear equilibrium law (u_hat along m, p_hat = 0)."""
    delta = 25.0
    c = make_closure("drucker_prager", delta_deg=delta)
    phi = _phi_eq(c, I_REF)
    sd = np.sin(np.radians(delta))
    S = I_REF * np.sqrt(P_REF / RHO_S) / (2.0 * 80e-6)
    f_phi = sd / (0.2 * I_REF)
    for theta in (0.1, 0.6, 1.2, 1.4, 2.0, 2.8):
        s = np.sin(2 * theta)
        expected = 2 * S * phi * f_phi * s / (sd - s)
        lam = dispersion_eigenvalues(c, phi, P_REF, I_REF, 1e7, theta, gas="none")
        assert np.min(np.abs(lam - expected)) <= 1e-3 * abs(expected), (theta, expected, lam)


def _max_near(c, phi, k, theta_c, side):
    """Max growth over theta = theta_c + side * 10**q, q in [-9, -0.5] (fine log grid)."""
    offsets = np.logspace(-9, -0.5, 300)
    return max(growth_rate(c, phi, P_REF, I_REF, k, theta_c + side * o, gas="none") for o in offsets)


def test_drucker_prager_finite_k_growth_unbounded_viscosity_bounds_it():
    """Plain DP is marginal at leading order and the O(1) compaction mode is unbounded near the
    Coulomb direction: the finite-k maximum grows like k^(2/3) (ill posed, weakly). A viscous
    addition makes the maximum independent of k."""
    delta = 25.0
    theta_c = np.pi / 2 - np.radians(delta) / 2       # sin 2 theta = sin delta, unstable side above
    c = make_closure("drucker_prager", delta_deg=delta)
    phi = _phi_eq(c, I_REF)
    g = [_max_near(c, phi, k, theta_c, +1) for k in (1e6, 1e7, 1e8)]
    for a, b in zip(g, g[1:]):
        assert 0.8 * 10 ** (2 / 3) < b / a < 1.2 * 10 ** (2 / 3), g
    cv = make_closure("drucker_prager", delta_deg=delta, eta_visc=1.0)
    gv = [_max_near(cv, phi, k, theta_c, +1) for k in (1e6, 1e7, 1e8)]
    assert abs(gv[2] - gv[1]) < 1e-4 * abs(gv[1])


def test_mu_i_bounded_but_positive_finite_k_growth():
    """Well posed (growth bounded in k) but linearly unstable: the O(1) compaction mode grows at a
    rate of order 2|S| phi f_phi, independent of k at large k, much faster than gamma_dot."""
    c = make_closure("mu_i")
    phi = _phi_eq(c, I_REF)
    thetas = np.linspace(0, np.pi, 180, endpoint=False)
    g = growth_curve(c, phi, P_REF, I_REF, [1e6, 1e7, 1e8], thetas).as_array().max(axis=0)
    gamma_dot = 2 * I_REF * np.sqrt(P_REF / RHO_S) / (2.0 * 80e-6)
    assert np.all(g > 10 * gamma_dot)
    assert abs(g[2] - g[1]) < 1e-4 * g[1]


# ---- gas (Theorem th3) ------------------------------------------------------------------------
def test_leading_order_gas_mode_is_decoupled():
    """th3: the gas block is triangular; its eigenvalue is -p_atm kappa/(1 - phi) (times
    1 + p_f0/p_atm for the nonlinear law)."""
    c = make_closure("mu_i")
    phi = _phi_eq(c, I_REF)
    m = c.material
    kappa = m.d**2 * (1 - phi) ** 3 / (150 * m.eta_f * phi**2)
    c_gas = m.p_atm * kappa / (1 - phi)
    for theta in (0.2, 1.1, 2.9):
        dry = np.sort(leading_order_eigenvalues(c, phi, P_REF, I_REF, theta, gas="none").real)
        for gas, p_f, factor in (("linear", 0.0, 1.0), ("linear", 5e4, 1.0), ("nonlinear", 5e4, 1 + 5e4 / m.p_atm)):
            wet = leading_order_eigenvalues(c, phi, P_REF, I_REF, theta, p_f=p_f, gas=gas)
            np.testing.assert_allclose(np.sort(wet.real), np.sort(np.r_[dry, -c_gas * factor]), rtol=1e-10)
            assert np.all(np.abs(wet.imag) <= 1e-12 * c_gas)


def test_gas_changes_finite_k_growth():
    """What is true at finite k: the gas coupling (p_atm/kappa, a drag on dilatational motion)
    and p_f0 change the maximum growth rate at small and moderate k, in either direction, and not
    at large k (as th3 says at leading order)."""
    c = make_closure("mu_i")
    phi = _phi_eq(c, I_REF)
    thetas = np.linspace(0, np.pi, 180, endpoint=False)
    ks = [1.0, 1e4, 1e7]

    def max_growth(gas, p_f):
        return growth_curve(c, phi, P_REF, I_REF, ks, thetas, p_f=p_f, gas=gas).as_array().max(axis=0)

    dry, wet, wet_pf = max_growth("none", 0.0), max_growth("linear", 0.0), max_growth("linear", 5e4)
    assert dry[0] < wet[0] < wet_pf[0] and wet[0] > 1.05 * dry[0]      # k = 1: gas destabilises
    assert dry[1] > wet[1] > wet_pf[1]                                   # k = 1e4: gas stabilises
    assert wet_pf[2] == pytest.approx(dry[2], rel=1e-6)                  # k = 1e7: no effect


# ---- C1 and the structure of M ----------------------------------------------------------------
def _fd(fun, x, h):
    return (fun(x + h) - fun(x - h)) / (2 * h)


@pytest.mark.parametrize("name, params, expect_c1", [
    *[(n, p, True) for n, p in PAPER_CASES],
    ("roux_radjai", {}, False),
    ("roux_radjai", {"yield_law": "drucker_prager"}, False),
])
def test_C1_makes_second_term_symmetric_nsd(name, params, expect_c1):
    c = make_closure(name, **params)
    I = I_REF
    phi = _phi_eq(c, I) - 0.004
    h = 1e-6 * I
    dZ = _fd(lambda i: float(c.Z(phi, i)), I, h)
    df = _fd(lambda i: float(c.f(phi, P_REF, i)), I, h)
    c1_residual = (float(c.Z(phi, I)) - I / 2 * dZ) - (float(c.f(phi, P_REF, I)) + I * df)
    assert (abs(c1_residual) < 1e-6) == expect_c1, c1_residual
    st = base_state(c, phi, P_REF, I, gas="none")
    asymmetries = []
    for theta in (0.1, 0.7, 1.6, 2.4):
        M1, M2 = leading_order_matrix(st, theta)
        norm = np.linalg.norm(M2)
        asym = np.linalg.norm(M2 - M2.T) / norm
        asymmetries.append(asym)
        if expect_c1:
            assert asym < 1e-8
            assert np.max(np.linalg.eigvalsh((M2 + M2.T) / 2)) <= 1e-10 * norm
        else:
            assert asym > 1e-3
        # (M1 + M2)/(phi rho_s) has the eigenvalues of the leading-order pencil
        ev = np.sort_complex(np.linalg.eigvals(M1 + M2) / (phi * RHO_S))
        ref = np.sort_complex(leading_order_eigenvalues(c, phi, P_REF, I, theta, gas="none"))
        np.testing.assert_allclose(ev, ref, rtol=1e-8, atol=1e-12 * abs(st.eta) / (phi * RHO_S))
    if not expect_c1:
        assert max(asymmetries) > 0.3


# ---- API --------------------------------------------------------------------------------------
def test_results_are_json_ready_and_most_unstable():
    c = make_closure("drucker_prager", eta_visc=1.0)
    phi = _phi_eq(c, I_REF)
    lo = leading_order_max_growth(c, phi, P_REF, I_REF, gas=GasLaw.NONLINEAR, p_f=1e4)
    curve = growth_curve(c, phi, P_REF, I_REF, [1.0, 100.0], [0.0, 1.0])
    mu = most_unstable(c, phi, P_REF, I_REF, k_values=np.logspace(0, 6, 13), thetas=np.linspace(0, 3, 31))
    for obj in (lo, curve, mu):
        json.dumps(obj.to_dict())
    assert curve.as_array().shape == (2, 2)
    assert not mu.at_largest_k and mu.k < 1e3      # DP + viscosity: max growth at small k
    rr = make_closure("roux_radjai")
    mr = most_unstable(rr, _phi_eq(rr, I_REF), P_REF, I_REF, k_values=np.logspace(0, 6, 7),
                       thetas=np.linspace(0, 3, 31))
    assert mr.at_largest_k and mr.growth > 0


def test_input_errors():
    c = make_closure("mu_i")
    with pytest.raises(GranflowInputError):
        dispersion_eigenvalues(c, 0.59, P_REF, I_REF, 0.0, 0.3)
    with pytest.raises(GranflowInputError):
        leading_order_eigenvalues(c, 0.59, P_REF, -1.0, 0.3)
    with pytest.raises(ValueError):
        growth_rate(c, 0.59, P_REF, I_REF, 1.0, 0.3, gas="ideal")
