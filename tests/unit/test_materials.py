"""Material: permeability (Carman-Kozeny, paper eqs beta / darcy), gas diffusivity (MODEL.md §6.7),
the inertial-number convention (paper eq. def:I times c_I) and validation.

References are the formulas written out here; tolerances rtol 1e-13 (a few float64 operations).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from pydantic import ValidationError

from granflow import GranflowInputError, InertialConvention, Material
from granflow.params import build

PHI = np.linspace(0.3, 0.64, 18)


def test_defaults_are_model_md_table():
    m = Material()
    assert (m.d, m.rho_s, m.eta_f, m.p_atm, m.rho_f0) == (80e-6, 2500.0, 1.8e-5, 1.013e5, 1.0)
    assert (m.phi_max, m.delta_phi, m.c_I) == (0.6, 0.2, 2.0)
    assert InertialConvention.LITERATURE == 2.0 and InertialConvention.PAPER == 1.0


@pytest.mark.parametrize("d,eta_f", [(80e-6, 1.8e-5), (45e-6, 1.8e-5), (1e-3, 1.0e-3)])
def test_permeability_carman_kozeny(d, eta_f):
    """kappa = d^2 (1-phi)^3 / (150 eta_f phi^2) = (1-phi)^2 / beta(phi), beta = 150 eta_f phi^2/(d^2 (1-phi))."""
    m = Material(d=d, eta_f=eta_f)
    beta = 150 * eta_f * PHI**2 / (d**2 * (1 - PHI))
    np.testing.assert_allclose(m.permeability(PHI), (1 - PHI) ** 2 / beta, rtol=1e-13)
    assert np.all(np.diff(m.permeability(PHI)) < 0)


def test_gas_diffusivity_glass_beads():
    """MODEL.md §6.7: D = p_atm kappa/(1-phi) ~ 0.16 m^2/s for 80 um beads at phi = 0.55.

    By hand: kappa = (80e-6)^2 0.45^3 / (150 1.8e-5 0.55^2) = 7.1405e-7 m^2/(Pa s),
    D = 1.013e5 * 7.1405e-7 / 0.45 = 0.16074 m^2/s."""
    m = Material()
    kappa = (80e-6) ** 2 * 0.45**3 / (150 * 1.8e-5 * 0.55**2)
    D_ref = 1.013e5 * kappa / 0.45
    assert D_ref == pytest.approx(0.16074, rel=1e-4)
    assert float(m.gas_diffusivity(0.55)) == pytest.approx(D_ref, rel=1e-13)
    assert float(m.gas_diffusivity(0.55)) == pytest.approx(0.16, rel=0.01)
    np.testing.assert_allclose(m.gas_diffusivity(PHI), m.p_atm * m.permeability(PHI) / (1 - PHI), rtol=1e-14)


@pytest.mark.parametrize("c_I", [1.0, 2.0, 3.5])
def test_inertial_number_definition(c_I):
    m = Material(c_I=c_I, d=1e-4, rho_s=2600.0)
    S = np.array([1e-3, 0.7, 25.0, 400.0])
    p = np.array([1.0, 50.0, 1e3, 1e5])
    expected = c_I * 1e-4 * S / np.sqrt(p / 2600.0)
    np.testing.assert_allclose(m.inertial_number(S, p), expected, rtol=1e-13)
    # shear_rate_scale is the |S| at which I = 1
    np.testing.assert_allclose(m.inertial_number(m.shear_rate_scale(p), p), 1.0, rtol=1e-13)


def test_paper_convention_is_half_the_literature():
    """In simple shear |S| = gamma_dot/2: c_I = 1 (paper) gives half the I of c_I = 2 (GDR MiDi)."""
    S, p = np.array([0.3, 12.0]), np.array([200.0, 4e3])
    lit = Material(c_I=float(InertialConvention.LITERATURE)).inertial_number(S, p)
    paper = Material(c_I=float(InertialConvention.PAPER)).inertial_number(S, p)
    np.testing.assert_allclose(paper, lit / 2, rtol=1e-15)
    # GDR MiDi: I = gamma_dot d / sqrt(p/rho_s) with gamma_dot = 2|S|
    m = Material()
    np.testing.assert_allclose(lit, (2 * S) * m.d / np.sqrt(p / m.rho_s), rtol=1e-14)


def test_inertial_number_edge_cases():
    m = Material()
    S = np.array([0.0, 0.0, 1.0, 2.0])
    p = np.array([0.0, 1e3, 0.0, 1e3])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with np.errstate(all="raise"):
            I = m.inertial_number(S, p)
    assert I[0] == 0.0 and I[1] == 0.0  # |S| = 0: I = 0 (also at p = 0)
    assert I[2] == np.inf  # p = 0 < |S|
    assert np.isfinite(I[3]) and I[3] > 0
    assert m.inertial_number(0.0, 0.0).shape == ()
    assert m.shear_rate_scale(0.0) == 0.0


def test_inertial_number_scalar_and_broadcast():
    m = Material()
    out = m.inertial_number(np.ones((3, 1)), np.full((1, 4), 1e3))
    assert out.shape == (3, 4)
    assert float(m.inertial_number(1.0, 1e3)) == pytest.approx(2 * 80e-6 / math.sqrt(1e3 / 2500.0), rel=1e-14)


@pytest.mark.parametrize("key,value", [
    ("d", -1e-6), ("d", 0.0), ("rho_s", 0.0), ("eta_f", -1.0), ("p_atm", 0.0), ("rho_f0", -1.0),
    ("phi_max", 1.2), ("phi_max", 0.0), ("delta_phi", 0.0), ("c_I", 0.0), ("grain_size", 1e-4),
])
def test_invalid_material_names_the_key(key, value):
    with pytest.raises(GranflowInputError, match=key):
        build(Material, {key: value}, context="material")


def test_material_is_frozen():
    m = Material()
    with pytest.raises(ValidationError):
        m.d = 1e-3  # type: ignore[misc]


def test_inertial_number_propagates_nan():
    m = Material()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        out = m.inertial_number(np.array([np.nan, 1.0, np.nan]), np.array([1e3, np.nan, 0.0]))
    assert np.all(np.isnan(out))
    assert m.inertial_number(1.0, -5.0) == np.inf  # p <= 0 < |S|
