"""Symbolic derivation of f from Z (paper eq. f-general) against the paper's closed forms.

Checks: Table 1 (Z = 1, I, I^n with symbolic and numeric n), eq. f-DP, eqs. F-mu(I)/syst4mu(I)
(numerically at many points, 30-digit mpmath), C1 and f(I_eq) = 0 for the two dilatancy-angle
closures (eqs. psi and psi:mu(I)), the parser's rejections, and the generic closure against mu_i.
"""
from __future__ import annotations

import mpmath
import numpy as np
import pytest
import sympy as sp

from granflow import GranflowInputError
from granflow.rheology import derive_dilatancy, make_closure, parse_yield_function
from granflow.rheology.derive import I, I_eq, c1_residual, phi

R = sp.Rational
n_sym = sp.Symbol("n", positive=True)
delta = sp.Symbol("delta", positive=True)
mu1, mu2, I0 = sp.symbols("mu1 mu2 I0", positive=True)


def table1_f(n) -> sp.Expr:
    """Table 1: f = (2 - n)/(2(n + 1)) (I^n - I_eq^(n+1)/I)."""
    return (2 - n) / (2 * (n + 1)) * (I**n - I_eq ** (n + 1) / I)


def is_zero(expr) -> bool:
    return sp.simplify(sp.expand(expr)) == 0


def test_table1_constant():
    d = derive_dilatancy(sp.Integer(1))
    assert is_zero(d.f - (1 - I_eq / I))
    assert d.I1 == 0


def test_table1_linear():
    d = derive_dilatancy(I)
    assert is_zero(d.f - R(1, 4) * (I - I_eq**2 / I))


def test_table1_symbolic_n():
    d = derive_dilatancy(I**n_sym)
    assert is_zero(d.f - table1_f(n_sym))


@pytest.mark.parametrize("n", [R(-1, 2), R(0), R(1, 3), R(1, 2), R(1), R(3, 2), R(2), R(3), R(5)])
def test_table1_numeric_n(n):
    d = derive_dilatancy(I**n)
    assert is_zero(d.f - table1_f(n))
    if n == 2:
        assert is_zero(d.f)  # Remark rem-viscous3: Z = I^2 is purely viscous, f = 0


def test_split_A_B_and_W_definition():
    """f = A - B/I, A = W = (3/(2I)) int_0^I Z - Z/2, B = I_eq W(I_eq) (eq. f-general)."""
    Z = R(2, 5) + R(1, 5) * I + phi * sp.sqrt(I)
    d = derive_dilatancy(Z, simplify=False)
    W = R(3, 2) / I * sp.integrate(Z.subs(I, sp.Symbol("J", positive=True)),
                                   (sp.Symbol("J", positive=True), 0, I)) - Z / 2
    assert is_zero(d.A - W)
    assert is_zero(d.B - I_eq * W.subs(I, I_eq))
    assert is_zero(d.f - (d.A - d.B / I))


def test_drucker_prager_f():
    """eq. f-DP: f = sin(delta)(1 - I_eq/I)."""
    d = derive_dilatancy(sp.sin(delta))
    assert is_zero(d.f - sp.sin(delta) * (1 - I_eq / I))


def _paper_F(m1, m2, i0, x):
    """eq. F-mu(I) (mpmath)."""
    y = x / i0
    return m2 + (m2 - m1) / 2 * (1 / (1 + y) - 3 * mpmath.log1p(y) / y)


@pytest.mark.parametrize("params", [(R(38, 100), R(64, 100), R(3, 10)), (R(32, 100), R(60, 100), R(4, 10))])
def test_mu_i_f_matches_paper_F(params):
    m1, m2, i0 = params
    Z = m1 + (m2 - m1) / (1 + i0 / I)
    d = derive_dilatancy(Z, simplify=False)
    fn = sp.lambdify((I, I_eq), d.f, modules="mpmath")
    with mpmath.workdps(30):
        for Iv in ["1e-6", "1e-3", "0.05", "0.3", "1.7", "40"]:
            for Ieqv in ["1e-4", "0.02", "0.45", "3"]:
                Iv_, Ie_ = mpmath.mpf(Iv), mpmath.mpf(Ieqv)
                ref = _paper_F(m1, m2, i0, Iv_) - Ie_ / Iv_ * _paper_F(m1, m2, i0, Ie_)
                # the derivation's expression has a log difference cancelling at small I:
                # with 30 digits the absolute error is ~1e-30/I.
                assert abs(fn(Iv_, Ie_) - ref) < mpmath.mpf("1e-20"), (Iv, Ieqv)


def test_mu_i_symbolic_W_is_paper_F():
    """W of the derivation equals F(I) = (3/(2I)) M(I) - mu/2 with the symbolic parameters."""
    Z = mu1 + (mu2 - mu1) / (1 + I0 / I)
    d = derive_dilatancy(Z, simplify=False)
    F = mu2 + (mu2 - mu1) / 2 * (1 / (1 + I / I0) - 3 * sp.log(1 + I / I0) / (I / I0))
    diff = d.W - F
    for vals in [{mu1: R(2, 5), mu2: R(3, 5), I0: R(3, 10), I: R(1, 7)},
                 {mu1: R(1, 3), mu2: 1, I0: 2, I: 5}]:
        assert abs(sp.N(diff.subs(vals), 40)) < 1e-35


def _dp_dilatancy_pair():
    s, c = sp.sin(delta), sp.cos(delta)
    beta = 2 * (1 - c) / (2 + c)
    psi = s / (1 - c) * (1 - (I_eq / I) ** beta)  # eq. psi
    return s + c * psi, psi  # eqs. Z1, f1


def _robinson_pair():
    def G(x):
        y = x / I0
        return 2 * mu1 / 3 * sp.log(y) + (mu2 - mu1) / 3 * (1 / (1 + y) + 2 * sp.log(1 + y))

    mu = mu1 + (mu2 - mu1) / (1 + I0 / I)
    psi = G(I) - G(I_eq)  # eq. psi:mu(I)
    return mu + psi, psi  # eqs. eq:86, eq:87


@pytest.mark.parametrize("pair", [_dp_dilatancy_pair, _robinson_pair], ids=["drucker_prager_dilatancy",
                                                                              "mu_i_dilatancy"])
def test_dilatancy_angle_closures_satisfy_C1_and_equilibrium(pair):
    Z, f = pair()
    assert c1_residual(Z, f) == 0
    assert sp.simplify(f.subs(I, I_eq)) == 0


def test_c1_residual_detects_roux_radjai():
    a, phi_max, dphi = sp.symbols("a phi_max delta_phi", positive=True)
    Z = sp.sin(delta)
    f = a * (phi - (phi_max - dphi * I))
    assert c1_residual(Z, f) != 0


def test_non_integrable_at_zero_uses_I1_equal_1():
    """Z = 1/I is not integrable at 0: the derivation takes I1 = 1 (which drops out of f)."""
    d = derive_dilatancy("1/I")
    assert d.I1 == 1
    assert c1_residual(d.Z, d.f) == 0
    assert sp.simplify(d.f.subs(I, I_eq)) == 0
    # f = (3/(2I)) ln(I/I_eq), by hand
    fn = sp.lambdify((I, I_eq), d.f)
    assert fn(2.0, 0.5) == pytest.approx(3 / 4 * np.log(4.0), rel=1e-13)


# ---------------------------------------------------------------------------------------------
# parser
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("text", [
    "", "   ", "0.4 +", "0.4 + * I", "x + I", "mu*I", "__import__('os')", "lambda: 1", "I; 1",
    "import os", "(I", "I = 2",
])
def test_parse_rejects(text):
    with pytest.raises(GranflowInputError):
        parse_yield_function(text)


@pytest.mark.parametrize("text", [None, 3, 0.4])
def test_parse_rejects_non_strings(text):
    with pytest.raises(GranflowInputError):
        parse_yield_function(text)


@pytest.mark.parametrize("text,expected", [
    ("0.4 + 0.2*I", R(2, 5) + R(1, 5) * I),
    ("0.4 + 0.2*I^2", R(2, 5) + R(1, 5) * I**2),
    ("ln(I) + sqrt(phi)", sp.log(I) + sp.sqrt(phi)),
    ("tan(pi/6) + exp(-I)", sp.tan(sp.pi / 6) + sp.exp(-I)),
])
def test_parse_accepts(text, expected):
    expr = parse_yield_function(text)
    assert expr.free_symbols <= {phi, I}
    assert abs(sp.N((expr - expected).subs({I: R(3, 7), phi: R(5, 9)}))) < 1e-14


# ---------------------------------------------------------------------------------------------
# generic closure with a mu(I) expression == mu_i closure
# ---------------------------------------------------------------------------------------------
MATERIAL = dict(phi_max=0.61, delta_phi=0.22, d=1e-4, rho_s=2600.0)


@pytest.fixture(scope="module")
def pair():
    g = make_closure("generic", material=MATERIAL, expression="0.38 + 0.26*I/(I + 0.3)")
    m = make_closure("mu_i", material=MATERIAL, mu1=0.38, mu2=0.64, I0=0.3)
    return g, m


def test_generic_mu_expression_matches_mu_i(pair):
    """Z, f, derivatives at I in [1e-4, 1e2]: rtol 1e-10. (The generic W contains
    log(I + I0) - log(I0) divided by I: absolute error ~1e-17/I, 1e-13 at I = 1e-4.)"""
    g, m = pair
    phi_, Iv = (a.ravel() for a in np.meshgrid([0.45, 0.55, 0.6], np.logspace(-4, 2, 13)))
    p = np.full_like(phi_, 1e3)
    for q in ("Z", "dZ_dI", "dZ_dphi"):
        np.testing.assert_allclose(getattr(g, q)(phi_, Iv), getattr(m, q)(phi_, Iv), rtol=1e-10, atol=1e-14,
                                   err_msg=q)
    for q in ("f", "df_dI", "df_dphi", "df_dp"):
        np.testing.assert_allclose(getattr(g, q)(phi_, p, Iv), getattr(m, q)(phi_, p, Iv), rtol=1e-10,
                                   atol=1e-12, err_msg=q)


def test_generic_mu_expression_div_rate_matches_mu_i(pair):
    g, m = pair
    phi_, p, S = (a.ravel() for a in np.meshgrid([0.45, 0.55, 0.6], [0.0, 10.0, 1e3, 1e5],
                                                  [0.0, 1e-6, 1e-2, 1.0, 1e2, 1e4]))
    dg, dm = g.div_rate(phi_, p, S), m.div_rate(phi_, p, S)
    assert np.all(np.isfinite(dg))
    # scale of the rate: sqrt(p/rho_s)/d + |S| [s^-1]
    scale = np.sqrt(p / 2600.0) / 1e-4 + S
    np.testing.assert_allclose(dg, dm, rtol=1e-10, atol=1e-12 * np.max(scale))
    np.testing.assert_allclose(g.dissipation_density(phi_, p, S), m.dissipation_density(phi_, p, S),
                               rtol=1e-9, atol=1e-12 * np.max(scale * p))
