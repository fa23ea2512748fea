"""Equilibrium (critical-state) laws phi_eq(I) and their inverses I_eq(phi).

References: the paper's eq. phi(I) and the remark after it (Schaeffer et al. 2019, Robinson et al.
2023, Breard et al. 2022), written below in SymPy; I_eq is obtained by SymPy's ``solve`` of
phi = phi_eq(I), derivatives by SymPy ``diff`` and by central finite differences.

Tolerances: formulas rtol 1e-12 (float64 evaluation of closed forms); inverse round trips
I_eq(phi_eq(I)) = I rtol 1e-9 for I >= 1e-4 (phi_max - phi_eq ~ delta_phi I carries the absolute
round-off eps phi_max, i.e. a relative error eps phi_max / (delta_phi I) ~ 3e-12 at I = 1e-4, times
the exponent 1/a ~ 1.2 of Robinson's law); finite differences rtol 1e-6 (relative step 1e-6).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp

from granflow import EQUILIBRIUM_LAWS, GranflowInputError, Material
from granflow.rheology import make_equilibrium

Isym, phisym = sp.symbols("I phi", positive=True)
MATERIAL = Material(phi_max=0.61, delta_phi=0.22)
R = sp.Rational


PM, DPHI, AA, aa = sp.symbols("phi_max delta_phi A a", positive=True)
_SYMBOLIC = {
    # The paper's eq. phi(I) and the remark after it, with symbolic parameters.
    "linear": PM - DPHI * Isym,
    "schaeffer": PM - DPHI / (1 + 1 / Isym),
    "robinson": PM - AA * Isym**aa,
    "breard": PM / (1 + Isym),
}


def _values(law) -> dict:
    return {sym: R(getattr(law, str(sym))) for sym in (PM, DPHI, AA, aa) if hasattr(law, str(sym))}


def _paper_phi_eq(name: str, law) -> sp.Expr:
    """phi_eq(I) as printed in the paper, with the law's parameter values."""
    if name not in _SYMBOLIC:
        pytest.fail(f"equilibrium law {name!r} has no reference in tests/unit/test_equilibrium.py")
    return _SYMBOLIC[name].subs(_values(law))


def _paper_I_eq(name: str, law) -> sp.Expr:
    """The root I of phi = phi_eq(I), solved by SymPy with symbolic parameters."""
    sols = sp.solve(sp.Eq(phisym, _SYMBOLIC[name]), Isym)
    assert len(sols) == 1, sols
    return sols[0].subs(_values(law))


LAWS = EQUILIBRIUM_LAWS.names()
# Physical range: phi in (phi_max - 0.9 delta_phi, phi_max) keeps Schaeffer's I_eq finite.
PHI = np.linspace(MATERIAL.phi_max - 0.9 * MATERIAL.delta_phi, MATERIAL.phi_max - 1e-3, 23)
I_GRID = np.logspace(-4, 1, 31)


def law_of(name):
    return make_equilibrium(name, MATERIAL)


@pytest.fixture(params=LAWS)
def case(request):
    name = request.param
    law = law_of(name)
    phi_eq = _paper_phi_eq(name, law)
    return name, law, phi_eq


def _np(expr, sym):
    return sp.lambdify(sym, expr, modules="numpy")


def test_phi_eq_against_paper(case):
    _, law, phi_eq = case
    np.testing.assert_allclose(law.phi_eq(I_GRID), _np(phi_eq, Isym)(I_GRID), rtol=1e-12)
    np.testing.assert_allclose(law.dphi_eq_dI(I_GRID), _np(sp.diff(phi_eq, Isym), Isym)(I_GRID), rtol=1e-12)


def test_I_eq_against_paper(case):
    name, law, _ = case
    I_eq = _paper_I_eq(name, law)
    np.testing.assert_allclose(law.I_eq(PHI), _np(I_eq, phisym)(PHI), rtol=1e-11)
    np.testing.assert_allclose(law.dI_eq_dphi(PHI), _np(sp.diff(I_eq, phisym), phisym)(PHI), rtol=1e-11)


def test_formula_attribute_matches_paper(case):
    """The human-readable ``formula`` of the law is the paper's expression."""
    _, law, phi_eq = case
    names = {k: R(v) for k, v in law.model_dump().items()}
    expr = sp.sympify(law.formula, locals={"I": Isym, **{k: sp.Symbol(k) for k in names}})
    expr = expr.subs({sp.Symbol(k): v for k, v in names.items()})
    assert sp.simplify(expr - phi_eq) == 0


def test_round_trips(case):
    _, law, _ = case
    np.testing.assert_allclose(law.I_eq(law.phi_eq(I_GRID)), I_GRID, rtol=1e-9)
    np.testing.assert_allclose(law.phi_eq(law.I_eq(PHI)), PHI, rtol=1e-14)


def test_phi_eq_at_rest_is_phi_max(case):
    _, law, _ = case
    assert law.phi_eq(0.0) == law.phi_max == MATERIAL.phi_max
    assert law.I_eq(law.phi_max) == 0.0


def test_monotonic_and_negative_slopes(case):
    _, law, _ = case
    assert np.all(np.diff(law.phi_eq(I_GRID)) < 0)
    assert np.all(np.diff(law.I_eq(PHI)) < 0)
    assert np.all(law.dphi_eq_dI(I_GRID) < 0)
    assert np.all(law.dI_eq_dphi(PHI) < 0)
    assert np.all(law.I_eq(PHI) > 0)


def test_derivatives_by_finite_differences(case):
    _, law, _ = case
    # phi_eq ~ phi_max >> its change: step 1e-4 I (truncation ~1e-8 relative), round-off
    # ~ eps phi_max / h, allowed with a 50x margin.
    h = 1e-4 * I_GRID
    fd = (law.phi_eq(I_GRID + h) - law.phi_eq(I_GRID - h)) / (2 * h)
    atol = 50 * np.finfo(float).eps * law.phi_max / h
    np.testing.assert_array_less(np.abs(law.dphi_eq_dI(I_GRID) - fd), 1e-6 * np.abs(fd) + atol)
    h = 1e-6 * PHI
    fd = (law.I_eq(PHI + h) - law.I_eq(PHI - h)) / (2 * h)
    # round-off: eps I_eq / h ~ 2e-10 relative to I_eq/phi; the slope is >= I_eq/phi here.
    np.testing.assert_allclose(law.dI_eq_dphi(PHI), fd, rtol=1e-6)


def test_derivatives_are_reciprocal(case):
    _, law, _ = case
    Iv = law.I_eq(PHI)
    np.testing.assert_allclose(law.dI_eq_dphi(PHI) * law.dphi_eq_dI(Iv), 1.0, rtol=1e-10)


def test_above_phi_max(case):
    """Module convention: linear law extrapolated linearly; the others clip I_eq at 0 there."""
    name, law, _ = case
    phi = np.array([law.phi_max, law.phi_max + 0.01, law.phi_max + 0.03])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Iv, dI = law.I_eq(phi), law.dI_eq_dphi(phi)
    if name == "linear":
        np.testing.assert_allclose(Iv, (law.phi_max - phi) / law.delta_phi, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(dI, -1.0 / law.delta_phi)
    else:
        np.testing.assert_array_equal(Iv, 0.0)
        np.testing.assert_array_equal(dI[1:], 0.0)


def test_extreme_inputs_no_warning_no_nan(case):
    """phi = 0 (an empty cell) and I in {0, inf}: no warning, no NaN."""
    _, law, _ = case
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vals = [law.I_eq(np.array([0.0, 0.05])), law.dI_eq_dphi(np.array([0.0, 0.05])),
                law.phi_eq(np.array([0.0, np.inf])), law.dphi_eq_dI(np.array([1.0, np.inf]))]
    for v in vals:
        assert not np.any(np.isnan(v)), (law.name, vals)
    assert np.all(law.I_eq(np.array([0.0, 0.05])) > 0)


def test_schaeffer_infinite_below_its_minimum():
    law = law_of("schaeffer")
    assert law.I_eq(law.phi_max - law.delta_phi - 0.01) == np.inf
    assert law.phi_eq(np.inf) == pytest.approx(law.phi_max - law.delta_phi, rel=1e-15)


def test_breard_and_robinson_values():
    """Hand values: Breard phi_eq(1) = phi_max/2; Robinson phi_eq(1) = phi_max - 0.1305."""
    assert law_of("breard").phi_eq(1.0) == pytest.approx(MATERIAL.phi_max / 2, rel=1e-15)
    rob = law_of("robinson")
    assert (rob.A, rob.a) == (0.1305, 0.8156)
    assert rob.phi_eq(1.0) == pytest.approx(MATERIAL.phi_max - 0.1305, rel=1e-15)


def test_delta_phi_taken_from_material():
    for name in ("linear", "schaeffer"):
        assert law_of(name).delta_phi == MATERIAL.delta_phi


@pytest.mark.parametrize("name,params,key", [
    ("linear", {"slope": 0.2}, "slope"),
    ("linear", {"delta_phi": -0.2}, "delta_phi"),
    ("robinson", {"a": 0.0}, "a"),
    ("breard", {"delta_phi": 0.2}, "delta_phi"),
    ("schaeffer", {"phi_max": 0.5}, "phi_max"),
])
def test_bad_parameters(name, params, key):
    with pytest.raises(GranflowInputError, match=key):
        make_equilibrium(name, MATERIAL, params)


def test_unknown_law():
    with pytest.raises(GranflowInputError, match="quadratic"):
        make_equilibrium("quadratic", MATERIAL)
