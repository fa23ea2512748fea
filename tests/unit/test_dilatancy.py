"""AP treatment of the stiff dilatancy relaxation: homogeneous sheared layer (verification ladder 9a).

References: the exact logistic solution for Drucker-Prager (granflow.verification.sheared_layer,
written from the ODE, not from the stepper), SciPy's Radau integrator for the other closures, and
finite differences for dR/dphi.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from granflow.physics.dilatancy import (
    LayerScheme,
    ap_factor,
    ddiv_rate_dphi,
    homogeneous_layer,
    homogeneous_layer_step,
)
from granflow.rheology import CLOSURES, make_closure
from granflow.verification.sheared_layer import drucker_prager_layer, drucker_prager_rate

P, S = 1000.0, 20.0  # Pa, 1/s: I ~ 2e-3 for 80 um grains
PAPER = [n for n in CLOSURES.names() if not CLOSURES.get(n).reference]


def dp_exact(c, t, phi0):
    m = c.material
    return drucker_prager_layer(t, phi0, P, S, sin_delta=c.sin_delta, d=m.d, rho_s=m.rho_s,
                                phi_max=m.phi_max, delta_phi=m.delta_phi, c_I=m.c_I)


def phi_eq(c):
    return float(c.equilibrium.phi_eq(c.material.inertial_number(S, P)))


def test_dp_ap_factor_is_the_design_note_formula():
    c = make_closure("drucker_prager", delta_deg=25.0)
    m = c.material
    lam = 1.0 / (m.c_I * m.delta_phi * m.d * np.sqrt(m.rho_s))
    phi, dt = 0.58, 1e-3
    expected = 1.0 / (1.0 + dt * phi * 2 * lam * np.sin(np.radians(25.0)) * np.sqrt(P))
    assert np.isclose(ap_factor(c, phi, P, 0.0, dt), expected, rtol=1e-13)


@pytest.mark.parametrize("name", PAPER + ["roux_radjai"])
def test_ddiv_rate_dphi_matches_finite_difference(name):
    c = make_closure(name)
    phi = np.array([0.55, 0.58, 0.595])
    h = 1e-7
    fd = (c.div_rate(phi + h, P, S) - c.div_rate(phi - h, P, S)) / (2 * h)
    assert np.allclose(ddiv_rate_dphi(c, phi, P, S), fd, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("phi0", [0.52, 0.5995])  # compaction from loose, dilation from dense
def test_dp_layer_converges_first_order_to_logistic(phi0):
    c = make_closure("drucker_prager")
    rate = drucker_prager_rate(P, S, sin_delta=c.sin_delta, d=c.material.d, rho_s=c.material.rho_s,
                               phi_max=0.6, delta_phi=0.2, c_I=2.0)
    t_end = 3.0 / rate
    errs = []
    for n in (100, 200, 400, 800):
        t, phi = homogeneous_layer(c, phi0, P, S, t_end / n, t_end)
        errs.append(np.max(np.abs(phi - dp_exact(c, t, phi0))))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all((orders > 0.9) & (orders < 1.1)), (errs, orders)
    assert errs[-1] < 2e-3 * abs(phi0 - phi_eq(c))


@pytest.mark.parametrize("rate_dt", [10.0, 100.0, 1e4])
@pytest.mark.parametrize("phi0", [0.50, 0.5999])
def test_dp_large_steps_land_on_phi_eq_without_overshoot(rate_dt, phi0):
    c = make_closure("drucker_prager")
    rate = drucker_prager_rate(P, S, sin_delta=c.sin_delta, d=c.material.d, rho_s=c.material.rho_s,
                               phi_max=0.6, delta_phi=0.2, c_I=2.0)
    peq = phi_eq(c)
    phi = phi0
    for _ in range(5):
        new = float(homogeneous_layer_step(c, phi, P, S, rate_dt / rate))
        assert (new - peq) * (phi0 - peq) >= -1e-15, "crossed phi_eq"
        assert abs(new - peq) <= abs(phi - peq) * 1.0000001
        assert new <= c.material.phi_max
        phi = new
    # Exact for DP: each step divides the distance to phi_eq by 1 + dt phi^n beta (>= 1 + rate_dt phi0/phi_eq).
    assert abs(phi - peq) <= abs(phi0 - peq) / (1 + rate_dt * min(phi0, peq) / peq) + 1e-15


@pytest.mark.parametrize("name", PAPER)
@pytest.mark.parametrize("phi0", [0.54, 0.5999])
def test_every_paper_closure_relaxes_monotonically_with_huge_steps(name, phi0):
    """Backward Euler (exact scalar solve) is monotone for every closure at rate*dt = 1000."""
    c = make_closure(name)
    peq = phi_eq(c)
    rate = abs(float(ddiv_rate_dphi(c, peq, P, S))) * peq
    assert rate > 0
    phi = phi0
    for _ in range(20):
        new = float(homogeneous_layer_step(c, phi, P, S, 1e3 / rate, LayerScheme.BACKWARD_EULER))
        assert np.isfinite(new)
        assert (new - peq) * (phi0 - peq) >= -1e-12, f"{name}: overshoot past phi_eq"
        assert new <= c.material.phi_max + 1e-15
        phi = new
    assert abs(phi - peq) < 1e-6 * abs(phi0 - peq) + 1e-12


@pytest.mark.parametrize("name", PAPER)
def test_small_steps_follow_an_independent_ode_solver(name):
    c = make_closure(name)
    phi0 = 0.57
    peq = phi_eq(c)
    rate = abs(float(ddiv_rate_dphi(c, peq, P, S))) * peq
    t_end = 2.0 / rate
    ref = solve_ivp(lambda t, y: -y * c.div_rate(y, P, S), (0, t_end), [phi0], method="Radau",
                    rtol=1e-11, atol=1e-13, dense_output=True)
    errs = []
    for n in (200, 400):
        t, phi = homogeneous_layer(c, phi0, P, S, t_end / n, t_end, LayerScheme.BACKWARD_EULER)
        errs.append(np.max(np.abs(phi - ref.sol(t)[0])))
    assert errs[1] < 0.6 * errs[0]
    assert errs[1] < 5e-3 * abs(phi0 - peq)


@pytest.mark.parametrize("name", ["drucker_prager_dilatancy", "mu_i_dilatancy"])
def test_linearised_ap_factor_is_not_enough_for_dilatancy_angle_closures(name):
    """Documents a trap for the solver: with psi closures far below equilibrium (where Z < 0), the
    linearised AP factor at rate*dt = 1000 jumps past phi_eq and phi_max in one step."""
    c = make_closure(name)
    peq = phi_eq(c)
    rate = abs(float(ddiv_rate_dphi(c, peq, P, S))) * peq
    with np.errstate(all="ignore"):
        new = float(homogeneous_layer_step(c, 0.54, P, S, 1e3 / rate, LayerScheme.AP_LINEARISED))
    assert new > c.material.phi_max
