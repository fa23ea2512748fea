"""Homogeneous expansion of an injected bed (granflow.theory.fluidisation; issue 13 item 1).

Independent references, written here: the balance of the model's Darcy drag and the bed's weight
(no buoyancy in the model's momentum equation, docs/model.md §1-2),
d^2 (1-phi)^3 / (150 eta_f phi^2) * phi rho_s g = U, solved with SymPy (exact rational
arithmetic, then a numeric root to 30 digits); the limits U = U_mf(phi0) -> phi0 and phi
decreasing with U; the kinematic-wave (shock) expansion time of a bed released at phi0.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from granflow.errors import GranflowInputError
from granflow.materials import Material
from granflow.theory import fluidisation as fl

D, RHO_S, ETA_F, G = 70e-6, 2500.0, 1.8e-5, 9.81
MAT = Material(d=D, rho_s=RHO_S, eta_f=ETA_F)


def sympy_packing(U: float) -> float:
    """Root in (0, 1) of the drag/weight balance, by SymPy (independent of the closed form)."""
    phi = sp.symbols("phi", positive=True)
    d, rho, eta, g, u = (sp.Rational(str(v)) for v in (D, RHO_S, ETA_F, G, U))
    balance = d**2 * (1 - phi) ** 3 / (150 * eta * phi**2) * phi * rho * g - u
    roots = [r for r in sp.Poly(sp.numer(sp.together(balance)), phi).nroots(n=30)
             if r.is_real and 0 < r < 1]
    assert len(roots) == 1
    return float(roots[0])


def test_u_mf_is_the_balance_at_phi0_written_out():
    """U_mf = d^2 (1-phi)^3 rho_s g / (150 eta_f phi): 4.7476e-3 m/s at phi = 0.6 (hand value)."""
    by_hand = D**2 * 0.4**3 * RHO_S * G / (150 * ETA_F * 0.6)
    assert by_hand == pytest.approx(4.7476e-3, rel=1e-4)
    assert fl.minimum_fluidisation_velocity(MAT, 0.6, -G) == pytest.approx(by_hand, rel=1e-13)
    # the constant is the one of Material.permeability
    assert MAT.permeability(0.5) == pytest.approx(D**2 * 0.5**3 / (fl.CARMAN_KOZENY_CONSTANT * ETA_F * 0.25),
                                                  rel=1e-14)


@pytest.mark.parametrize("ratio", [0.3, 1.0, 1.1, 1.3, 1.6, 3.0, 20.0])
def test_closed_form_matches_sympy_root_of_the_balance(ratio):
    U = ratio * fl.minimum_fluidisation_velocity(MAT, 0.6, G)
    assert fl.homogeneous_packing(MAT, U, -G) == pytest.approx(sympy_packing(U), abs=1e-12)


def test_limits_u_mf_gives_the_poured_packing_and_phi_decreases_with_u():
    for phi0 in (0.45, 0.55, 0.6):
        u_mf = fl.minimum_fluidisation_velocity(MAT, phi0, G)
        assert fl.homogeneous_packing(MAT, u_mf, G) == pytest.approx(phi0, abs=1e-13)
        assert fl.expanded_packing(MAT, phi0, 1.0, G) == phi0
        assert fl.expanded_packing(MAT, phi0, 0.5, G) == phi0  # no expansion below U_mf
    ratios = np.linspace(1.0, 10.0, 200)
    phis = np.array([fl.expanded_packing(MAT, 0.6, r, G) for r in ratios])
    assert np.all(np.diff(phis) < 0) and phis[0] == 0.6
    # the values the issue quotes: phi ~ 0.570 at 1.3 U_mf
    assert fl.expanded_packing(MAT, 0.6, 1.3, G) == pytest.approx(0.5707, abs=1e-4)


def test_kinematic_wave_speed_is_minus_phi_du_mf_dphi():
    phi, h = 0.57, 1e-6
    dudphi = (fl.minimum_fluidisation_velocity(MAT, phi + h, G)
              - fl.minimum_fluidisation_velocity(MAT, phi - h, G)) / (2 * h)
    assert fl.kinematic_wave_speed(MAT, phi, G) == pytest.approx(-phi * dudphi, rel=1e-7)


def test_expansion_time_is_the_shock_reaching_the_rising_surface():
    """Top at H0 + w0 t, front at s t with s = phi0 w0/(phi0 - phi_e): they meet at t_s."""
    phi0, H0, ratio = 0.6, 0.1, 1.3
    u_mf = fl.minimum_fluidisation_velocity(MAT, phi0, G)
    phi_e = sympy_packing(ratio * u_mf)
    w0 = (ratio - 1) * u_mf
    s = phi0 * w0 / (phi0 - phi_e)
    assert fl.expansion_time(MAT, phi0, H0, ratio, G) == pytest.approx(H0 / (s - w0), rel=1e-10)
    assert 3.0 < H0 / (s - w0) < 4.0
    assert fl.expansion_time(MAT, phi0, H0, 0.9, G) == 0.0


def kynch_settling(phi0: float, H0: float, n: int, t_end: float) -> tuple[float, float]:
    """Independent check of :func:`fl.consolidation_time`: a first-order finite-volume solution of
    the continuity-wave equation d_t phi + d_z (phi w(phi)) = 0 over a closed base, w = -U_mf(phi)
    written out (Carman-Kozeny), each face's downward transfer limited by the room left below
    (phi <= phi_max) and the content above. Returns (packed thickness, grains still in
    suspension) [m] at ``t_end``."""
    phi_max, dz = MAT.phi_max, H0 / n
    phi = np.full(n + n // 4, 0.0)
    phi[:n] = phi0
    u_mf = lambda f: D**2 * (1 - f) ** 3 * RHO_S * G / (150 * ETA_F * np.maximum(f, 1e-12))  # noqa: E731
    dt = 0.2 * dz / (3 * D**2 * RHO_S * G / (150 * ETA_F))  # the largest wave speed 3 U_mf(0) phi
    t = 0.0
    while t < t_end:
        step = min(dt, t_end - t)
        above = phi[1:]
        down = np.minimum.reduce([above * u_mf(above) * step, (phi_max - phi[:-1]) * dz, above * dz])
        down = np.maximum(down, 0.0)
        phi[:-1] += down / dz
        phi[1:] -= down / dz
        t += step
    packed = np.argmax(phi < phi_max * (1 - 1e-9)) * dz
    return packed, float(phi.sum() * dz) - phi_max * packed


def test_consolidation_time_is_the_compaction_front_meeting_the_falling_surface():
    """Front at s t, s = phi0 U_mf/(phi_max - phi0); the suspended grains, phi0 H0 (1 - t/t_c):
    against a finite-volume solution of the settling (an independent computation)."""
    phi0, H0 = 0.585, 0.1
    t_c = fl.consolidation_time(MAT, phi0, H0, G)
    u_mf = fl.minimum_fluidisation_velocity(MAT, phi0, G)
    assert t_c == pytest.approx(H0 / (phi0 * u_mf / (MAT.phi_max - phi0) + u_mf), rel=1e-12)
    assert 0.4 < t_c < 0.5
    for frac in (0.25, 0.5):
        packed, suspended = kynch_settling(phi0, H0, 800, frac * t_c)
        assert packed == pytest.approx(phi0 * u_mf / (MAT.phi_max - phi0) * frac * t_c, rel=0.02)
        assert suspended == pytest.approx(phi0 * H0 * (1 - frac), rel=0.02)
    assert fl.consolidation_time(MAT, 0.6, H0, G) == 0.0
    assert fl.consolidation_time(MAT, 0.57, 2 * H0, G) == pytest.approx(2 * fl.consolidation_time(MAT, 0.57, H0, G))


@pytest.mark.parametrize("call, key", [
    (lambda: fl.consolidation_time(MAT, 0.57, -0.1, G), "height"),
    (lambda: fl.consolidation_time(MAT, 1.5, 0.1, G), "phi0"),
    (lambda: fl.homogeneous_packing(MAT, 0.0, G), "U"),
    (lambda: fl.homogeneous_packing(MAT, math.nan, G), "U"),
    (lambda: fl.homogeneous_packing(MAT, 1e-3, 0.0), "g_z"),
    (lambda: fl.expanded_packing(MAT, 1.2, 1.3, G), "phi0"),
    (lambda: fl.expanded_packing(MAT, 0.6, -1.0, G), "ratio"),
    (lambda: fl.expansion_time(MAT, 0.6, 0.0, 1.3, G), "height"),
])
def test_bad_input_names_the_argument(call, key):
    with pytest.raises(GranflowInputError, match=key):
        call()
