"""Implicit pore-gas-pressure block (granflow.physics.pore_pressure) and the defluidising-column
series (granflow.verification.defluidisation); MODEL.md §2, §5, §7; NUMERICS.md §8, §9, §11 item 1.

Independent references used here (never numbers produced by the code under test):
* the Carman-Kozeny mobility and the diffusivity c = p_atm kappa/(1-phi), written out below;
* the Fourier coefficients by adaptive quadrature of (2/H) int p0 cos(k_n z) and the series checked
  against the PDE by finite differences; the basal half-life by a root-find on a series written here;
* the closed-form steady states under base injection (linear profile, U_mf carries the bed weight);
* the discrete energy identity of backward Euler, derived by hand (module docstring).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from granflow import GranflowInputError, Material
from granflow.grid import Grid
from granflow.operators import Operators
from granflow.physics.pore_pressure import (
    GasEnergy,
    GasLaw,
    PorePressureStep,
    coupling_block,
    darcy_dissipation,
    face_permeability,
    gas_energy,
    gas_operator,
    step_static,
    transport_divergence,
)
from granflow.verification import defluidisation as dfl

MAT = Material(d=70e-6)          # glass beads in air, defaults otherwise
H = 0.1                          # bed height [m]
PHI = 0.6                        # = phi_max: rigid, dense bed
G = 9.81
A_LITHO = 0.9 * PHI * MAT.rho_s * G * H     # basal p_f0 = 0.9 x lithostatic [Pa]
PROFILES = [dfl.InitialProfile.LITHOSTATIC, dfl.InitialProfile.UNIFORM]


def kappa_ref(phi: float) -> float:
    """Carman-Kozeny d^2 (1-phi)^3 / (150 eta_f phi^2) (paper eq. beta), written here."""
    return MAT.d**2 * (1 - phi) ** 3 / (150 * MAT.eta_f * phi**2)


C_REF = MAT.p_atm * kappa_ref(PHI) / (1 - PHI)     # diffusivity [m^2/s] (MODEL.md §6.7)
TAU1 = 4 * H**2 / (math.pi**2 * C_REF)             # ~0.0496 s


def column(nz: int, nx: int = 2, Lz: float = H) -> tuple[Grid, Operators, np.ndarray]:
    g = Grid(nx=nx, nz=nz, Lx=nx * Lz / nz, Lz=Lz)
    return g, Operators.build(g), np.full(g.cell_shape, PHI)


def march(profile, nz: int, dt: float, times, nx: int = 2, gas="linear", amplitude=A_LITHO):
    """Rigid open-top column; returns p_f(nx, nz) at each of ``times`` (multiples of dt)."""
    g, ops, phi = column(nz, nx)
    p = dfl.initial_profile(profile, g.cell_coords()[1], H, amplitude)
    step = PorePressureStep(g, MAT, ops, gas=gas, open_top=True)
    marks = {int(round(t / dt)): t for t in times}
    out = []
    for n in range(1, max(marks) + 1):
        p = step(p, phi, dt)
        if n in marks:
            out.append(p.copy())
    return g, np.array(out)


# --- the series -------------------------------------------------------------------------------
@pytest.mark.parametrize("profile", PROFILES)
def test_closed_form_coefficients_match_quadrature(profile):
    p0 = (lambda z: A_LITHO) if profile is dfl.InitialProfile.UNIFORM else (lambda z: A_LITHO * (H - z) / H)
    k = (2 * np.arange(12) + 1) * np.pi / (2 * H)
    ref = [2 / H * quad(lambda z: p0(z) * math.cos(kn * z), 0, H, limit=200)[0] for kn in k]
    np.testing.assert_allclose(dfl.coefficients(profile, H, A_LITHO, 12), ref, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("profile", PROFILES)
def test_series_solves_the_pde_and_boundary_conditions(profile):
    z, t, hz, ht = 0.037, 0.3 * TAU1, 1e-4, 1e-6
    p = lambda zz, tt: float(dfl.pressure(zz, tt, H, C_REF, profile, A_LITHO))  # noqa: E731
    p_t = (p(z, t + ht) - p(z, t - ht)) / (2 * ht)
    p_zz = (p(z + hz, t) - 2 * p(z, t) + p(z - hz, t)) / hz**2
    assert p_t == pytest.approx(C_REF * p_zz, rel=1e-5)
    assert abs(p(H, t)) < 1e-9 * A_LITHO                                   # open top
    assert abs(p(hz, t) - p(0.0, t)) < 1e-6 * A_LITHO                      # dp/dz(0) = 0 (even)
    # small t: the series returns to the initial profile away from the incompatible corners
    assert p(0.5 * H, 1e-6 * TAU1) == pytest.approx(float(dfl.initial_profile(profile, 0.5 * H, H, A_LITHO)),
                                                     rel=1e-6)


def test_basal_half_life_lithostatic_is_0_4854_tau1():
    """MODEL.md §7: t_1/2 = 0.4854 tau_1, tau_1 = 4H^2/(pi^2 c); root-find on a series written here."""
    m = 2 * np.arange(5000) + 1

    def basal_ratio(s):  # p(0,t)/p(0,0) = sum 8/(pi^2 m^2) exp(-m^2 t/tau_1), lithostatic
        return float(np.sum(8 / (np.pi**2 * m**2) * np.exp(-(m**2) * s))) - 0.5

    s_half = brentq(basal_ratio, 1e-3, 2.0, xtol=1e-13)
    assert round(s_half, 4) == 0.4854
    assert dfl.basal_half_life(H, C_REF) / TAU1 == pytest.approx(s_half, rel=1e-9)
    assert dfl.first_time_constant(H, C_REF) == pytest.approx(TAU1, rel=1e-14)
    # uniform profile: p(0,t)/A = (4/pi) sum (-1)^n/m exp(-m^2 t/tau_1)
    sign = np.where(np.arange(m.size) % 2 == 0, 1.0, -1.0)
    s_unif = brentq(lambda s: float(np.sum(4 / np.pi * sign / m * np.exp(-(m**2) * s))) - 0.5, 0.1, 3.0,
                    xtol=1e-13)
    assert dfl.basal_half_life(H, C_REF, "uniform") / TAU1 == pytest.approx(s_unif, rel=1e-9)


# --- static column against the series ---------------------------------------------------------
SAMPLE_TIMES = np.array([0.1, 0.25, 0.5, 1.0]) * TAU1


@pytest.mark.parametrize("profile", PROFILES)
def test_static_column_basal_pressure_matches_series(profile):
    """nx = 3, nz = 40 (dz = 2.5 mm), dt = tau_1/160: |p_num - p_series| < 2.5e-3 p_f0 at the bottom
    cell centre z = dz/2, t = 0.1 .. 1 tau_1 (measured 1.8e-3: the backward-Euler error dominates)."""
    assert float(MAT.gas_diffusivity(PHI)) == pytest.approx(C_REF, rel=1e-12)
    g, p = march(profile, nz=40, dt=TAU1 / 160, times=SAMPLE_TIMES, nx=3)
    np.testing.assert_allclose(p, np.repeat(p[:, :1, :], 3, axis=1), rtol=1e-12)  # 1-D: x-uniform
    series = dfl.pressure(g.zc[0], SAMPLE_TIMES, H, C_REF, profile, A_LITHO)
    err = np.abs(p[:, 0, 0] - series) / A_LITHO
    assert err.max() < 2.5e-3, err
    assert np.all(np.diff(p[:, 0, 0]) < 0)       # the base drains monotonically


@pytest.mark.parametrize("profile", PROFILES)
def test_first_order_in_dt(profile):
    """At fine dz (nz = 200) the error at t = 0.5, 1 tau_1 halves with dt (ratio 1.8 .. 2.2)."""
    times = SAMPLE_TIMES[2:]
    errs = []
    for n_per_tau in (40, 80, 160):
        g, p = march(profile, nz=200, dt=TAU1 / n_per_tau, times=times)
        errs.append(np.abs(p[:, 0, 0] - dfl.pressure(g.zc[0], times, H, C_REF, profile, A_LITHO)))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 1.8) & (ratios < 2.2)), ratios


@pytest.mark.parametrize("profile", PROFILES)
def test_second_order_in_dz(profile):
    """Time error removed by Richardson extrapolation 2 p(dt/2) - p(dt) (dt = tau_1/400); the
    remaining error at t = 0.5, 1 tau_1 drops by 3.5 .. 4.5 when dz halves (nz = 10, 20, 40)."""
    times = SAMPLE_TIMES[2:]
    errs = []
    for nz in (10, 20, 40):
        g, p1 = march(profile, nz, TAU1 / 400, times)
        _, p2 = march(profile, nz, TAU1 / 800, times)
        extrap = 2 * p2[:, 0, 0] - p1[:, 0, 0]
        errs.append(np.abs(extrap - dfl.pressure(g.zc[0], times, H, C_REF, profile, A_LITHO)))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 3.5) & (ratios < 4.5)), ratios


def test_ambient_cells_act_as_an_open_top_at_the_bed_surface():
    """Box 0.125 m high, bed 0.1 m, phi = 0 and p_f = 0 (Dirichlet) above: with harmonic-mean kappa
    the result equals the open-top column of height H to < 1e-5 p_f0."""
    dt, nsteps = TAU1 / 40, 20
    g, ops, _ = column(25, Lz=0.125)
    bed = g.cell_coords()[1] < H
    phi = np.where(bed, PHI, 0.0)
    p = dfl.initial_profile("lithostatic", g.cell_coords()[1], H, A_LITHO)
    step = PorePressureStep(g, MAT, ops, dirichlet=~bed)
    for _ in range(nsteps):
        p = step(p, phi, dt)
    assert np.all(p[~bed] == 0.0)
    _, ref = march("lithostatic", 20, dt, [nsteps * dt])
    assert np.abs(p[:, :20] - ref[0]).max() < 1e-5 * A_LITHO


# --- energy -----------------------------------------------------------------------------------
def test_discrete_energy_identity_is_exact_for_the_linear_scheme():
    """(E^{n+1} - E^n)/dt + D^{n+1} + sum (1-phi)(dp)^2/(2 p_atm dt) dV = sum U_inj p_base dx with
    E = sum (1-phi) p^2/(2 p_atm) dV: exact (rtol 1e-10) for non-uniform phi, ambient Dirichlet cells,
    open top and base injection."""
    rng = np.random.default_rng(3)
    g = Grid(nx=4, nz=12, Lx=0.02, Lz=0.06)
    ops = Operators.build(g)
    phi = rng.uniform(0.45, 0.6, g.cell_shape)
    ambient = np.zeros(g.cell_shape, dtype=bool)
    ambient[1:3, 9:] = True
    phi[ambient] = 0.0
    p0 = np.where(ambient, 0.0, rng.uniform(0, 2000, g.cell_shape))
    u_inj, dt = np.array([1e-3, 2e-3, 0.0, 5e-4]), 2e-3
    p1 = step_static(g, phi, p0, dt, MAT, ops, dirichlet=ambient, open_top=True, injection=u_inj)
    dV = g.dx * g.dz
    energy = lambda p: np.sum((1 - phi) * p**2 / (2 * MAT.p_atm)) * dV  # noqa: E731
    assert gas_energy(g, phi, p1, MAT, GasEnergy.QUADRATIC) == pytest.approx(energy(p1), rel=1e-14)
    D = darcy_dissipation(g, ops, phi, p1, MAT, open_top=True)
    lhs = (energy(p1) - energy(p0)) / dt + D + np.sum((1 - phi) * (p1 - p0) ** 2) / (2 * MAT.p_atm * dt) * dV
    rhs = np.sum(u_inj * p1[:, 0]) * g.dx
    assert lhs == pytest.approx(rhs, rel=1e-10, abs=1e-10 * D)
    # injection only adds pressure (M-matrix): compare with the same step without it
    no_inj = step_static(g, phi, p0, dt, MAT, ops, dirichlet=ambient, open_top=True)
    assert np.all(p1 - no_inj >= -1e-9) and np.all((p1 - no_inj)[:, 0][u_inj > 0] > 0)


@pytest.mark.parametrize(("gas", "weighted"), [("nonlinear", False), ("linear", True)])
def test_log_energy_balance_holds_to_order_dt(gas, weighted):
    """LOG gas energy E_1 decreases every step; r = E_1(tau_1) - E_1(0) + int D dt (rectangle rule,
    D at t^{n+1}) is < 0 (backward Euler dissipates), |r|/(E_1(0)-E_1(tau_1)) < 3.5 % at dt = tau_1/20
    and halves (ratio 1.8 .. 2.2) with dt, for the two exact pairings of the module table. p_f0 = 20 kPa
    so that the O(p_f/p_atm) mismatch of the wrong pairing (checked last) is visible."""
    amplitude = 2e4

    def residual(n_steps, gas, weighted):
        g, ops, phi = column(40)
        p = dfl.initial_profile("lithostatic", g.cell_coords()[1], H, amplitude)
        step = PorePressureStep(g, MAT, ops, gas=gas, open_top=True)
        e0 = gas_energy(g, phi, p, MAT)
        energies, dissipated = [e0], 0.0
        for _ in range(n_steps):
            p = step(p, phi, TAU1 / n_steps)
            energies.append(gas_energy(g, phi, p, MAT))
            dissipated += TAU1 / n_steps * darcy_dissipation(g, ops, phi, p, MAT, open_top=True,
                                                             weighted=weighted)
        assert np.all(np.diff(energies) < 0)
        return (energies[-1] - e0 + dissipated) / (e0 - energies[-1])

    r = np.array([residual(n, gas, weighted) for n in (20, 40, 80)])
    assert np.all(r < 0) and abs(r[0]) < 0.035, r
    assert np.all((r[:-1] / r[1:] > 1.8) & (r[:-1] / r[1:] < 2.2)), r
    if gas == "linear":   # wrong pairing (LOG energy, unweighted D): does not converge, creates energy
        assert residual(80, "linear", False) > 0.03


# --- injection --------------------------------------------------------------------------------
def test_injection_steady_state_is_the_exact_linear_profile():
    """Open top, dt = inf: p_f = U_inj (H - z)/kappa at every cell centre (exact for the scheme);
    U_inj = U_mf = kappa phi rho_s g gives -dp_f/dz = phi rho_s g, the lithostatic profile."""
    g, ops, phi = column(16, nx=3)
    u_mf = kappa_ref(PHI) * PHI * MAT.rho_s * G
    block = gas_operator(g, ops, phi, math.inf, MAT, open_top=True, injection=np.full(3, u_mf))
    p = np.linalg.solve(block.matrix.toarray(), block.rhs).reshape(g.cell_shape)
    z = g.cell_coords()[1]
    np.testing.assert_allclose(p, u_mf * (H - z) / kappa_ref(PHI), rtol=1e-10)
    np.testing.assert_allclose(p, PHI * MAT.rho_s * G * (H - z), rtol=1e-10)
    assert 3e-3 < u_mf < 1e-2  # NUMERICS.md §1.1: 3.5 - 9.6 mm/s for 60-80 um beads


def test_injection_raises_pore_pressure_towards_the_steady_state():
    g, ops, phi = column(16)
    u_inj = 2e-3
    step = PorePressureStep(g, MAT, ops, open_top=True, injection=u_inj)
    p, basal = np.zeros(g.cell_shape), []
    for _ in range(100):   # backward-Euler decay of the slowest mode: 1.2^-100 ~ 1e-8
        p = step(p, phi, TAU1 / 5)
        basal.append(p[0, 0])
    assert np.all(np.diff(basal) > 0)
    assert basal[-1] == pytest.approx(u_inj * (H - g.zc[0]) / kappa_ref(PHI), rel=1e-6)
    assert step.n_factorisations == 1


# --- non-linear variant -----------------------------------------------------------------------
def test_nonlinear_reduces_to_linear_for_small_overpressure():
    """|p_nl - p_lin|/p_f0 = O(p_f0/p_atm): below p_f0/p_atm, and x10 when p_f0 is x10 (8 .. 12);
    the non-linear diffusivity kappa (p_atm + p_f) is larger, so the base drains faster: p_nl < p_lin
    there (near the top the extra flux makes p_nl slightly larger)."""
    times = [0.25 * TAU1, 0.5 * TAU1]
    rel = []
    for amplitude in (1e3, 1e4):
        _, lin = march("lithostatic", 20, TAU1 / 40, times, amplitude=amplitude)
        _, nl = march("lithostatic", 20, TAU1 / 40, times, gas="nonlinear", amplitude=amplitude)
        assert np.all(nl[:, :, 0] < lin[:, :, 0])
        rel.append(np.abs(nl - lin).max() / amplitude)
        assert rel[-1] < amplitude / MAT.p_atm
    assert 8 < rel[1] / rel[0] < 12, rel


def test_nonlinear_refactorises_linear_reuses():
    g, ops, phi = column(8)
    p = np.full(g.cell_shape, 500.0)
    lin = PorePressureStep(g, MAT, ops, open_top=True)
    nl = PorePressureStep(g, MAT, ops, gas=GasLaw.NONLINEAR, open_top=True)
    for _ in range(3):
        lin(p, phi, 1e-3)
        nl(p, phi, 1e-3)
    assert (lin.n_factorisations, nl.n_factorisations) == (1, 3)
    lin(p, phi, 2e-3)
    lin(p, np.full(g.cell_shape, 0.55), 2e-3)
    assert lin.n_factorisations == 3


# --- building blocks --------------------------------------------------------------------------
def test_face_permeability_is_the_harmonic_mean_and_clips_phi():
    g = Grid(nx=2, nz=2, Lx=1.0, Lz=1.0)
    ops = Operators.build(g)
    phi = np.array([[0.5, 0.0], [0.7, 0.55]])   # 0 -> 1e-3, 0.7 -> phi_max
    kf, ktop = face_permeability(g, ops, phi, MAT)
    k = {0.5: kappa_ref(0.5), 0.0: kappa_ref(1e-3), 0.7: kappa_ref(0.6), 0.55: kappa_ref(0.55)}
    hm = lambda a, b: 2 * a * b / (a + b)  # noqa: E731
    # velocity order: x-faces (between (0,j) and (1,j)), then z-faces (between (i,0) and (i,1))
    np.testing.assert_allclose(kf, [hm(k[0.5], k[0.7]), hm(k[0.0], k[0.55]),
                                    hm(k[0.5], k[0.0]), hm(k[0.7], k[0.55])], rtol=1e-13)
    np.testing.assert_allclose(ktop, [k[0.0], k[0.55]], rtol=1e-13)


def test_transport_divergence_upwind_and_conservative():
    rng = np.random.default_rng(0)
    g = Grid(nx=5, nz=4, Lx=1.0, Lz=0.8)
    ops = Operators.build(g)
    vel = rng.normal(size=g.n_unknowns)
    phi = rng.uniform(0.4, 0.6, g.cell_shape)
    p = rng.uniform(0, 1e3, g.cell_shape)
    div = transport_divergence(g, ops, phi, p, vel)
    assert abs(div.sum()) < 1e-10 * np.abs(div).sum()           # closed box: no net flux
    q = 0.4 * 700.0                                              # uniform (1-phi) p_f: div(q u) = q div u
    np.testing.assert_allclose(transport_divergence(g, ops, np.full(g.cell_shape, 0.6),
                                                    np.full(g.cell_shape, 700.0), vel),
                               q * (ops.div @ vel), rtol=1e-12, atol=1e-9)
    u, w = g.unpack_velocity(vel)   # hand upwind flux through the east face of cell (0, 0)
    qc = (1 - phi) * p
    east = u[1, 0] * (qc[0, 0] if u[1, 0] > 0 else qc[1, 0])
    north = w[0, 1] * (qc[0, 0] if w[0, 1] > 0 else qc[0, 1])
    assert div[0] == pytest.approx(east / g.dx + north / g.dz, rel=1e-12)


def test_coupling_block_is_p_atm_div_with_dirichlet_rows_zero():
    g = Grid(nx=3, nz=3, Lx=1.0, Lz=1.0)
    ops = Operators.build(g)
    mask = np.zeros(g.cell_shape, dtype=bool)
    mask[:, 2] = True
    c = coupling_block(ops, MAT, mask).toarray()
    ref = MAT.p_atm * ops.div.toarray()
    ref[mask.ravel()] = 0.0
    np.testing.assert_array_equal(c, ref)


def test_log_energy_density_is_paper_H_plus_p_atm():
    g = Grid(nx=2, nz=2, Lx=1.0, Lz=1.0)
    p = np.array([[0.0, 1e3], [5e4, -2e4]])
    pa = MAT.p_atm
    H_paper = (pa + p) * (np.log(1 + p / pa) - 1)          # paper eq. H(p)
    ref = np.sum((1 - PHI) * (H_paper + pa)) * g.dx * g.dz
    assert gas_energy(g, np.full((2, 2), PHI), p, MAT) == pytest.approx(ref, rel=1e-12)


# --- bad input --------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["neg_dt", "nan_dt", "phi_shape", "p_shape", "phi_range", "mask_dtype",
                                  "inj_shape", "gas", "nl_no_p", "steady_singular", "p_below_vacuum"])
def test_bad_input_raises(case):
    g, ops, phi = column(4)
    p = np.zeros(g.cell_shape)
    step = PorePressureStep(g, MAT, ops, open_top=True)
    calls = {
        "neg_dt": lambda: step(p, phi, -1e-3),
        "nan_dt": lambda: step(p, phi, float("nan")),
        "phi_shape": lambda: step(p, phi[:, :3], 1e-3),
        "p_shape": lambda: step(p.T, phi, 1e-3),
        "phi_range": lambda: step(p, phi + 0.5, 1e-3),
        "mask_dtype": lambda: PorePressureStep(g, MAT, ops, dirichlet=np.zeros(g.cell_shape)),
        "inj_shape": lambda: PorePressureStep(g, MAT, ops, injection=[1e-3]),
        "gas": lambda: PorePressureStep(g, MAT, ops, gas="ideal"),
        "nl_no_p": lambda: gas_operator(g, ops, phi, 1e-3, MAT, gas="nonlinear"),
        "steady_singular": lambda: gas_operator(g, ops, phi, math.inf, MAT),
        "p_below_vacuum": lambda: PorePressureStep(g, MAT, ops, gas="nonlinear")(p - 2e5, phi, 1e-3),
    }
    with pytest.raises(GranflowInputError):
        calls[case]()
    with pytest.raises(GranflowInputError):
        dfl.pressure(0.0, -1.0, H, C_REF)


def test_validation_script_smoke():
    """validation/defluidisation/run.py at its coarsest level (quick): the README table's first row."""
    from _scripts import load_script

    mod = load_script("validation/defluidisation/run.py", "defluidisation_run")
    res = mod.run(10, quick=True)
    for profile in PROFILES:
        assert res[profile.value]["err"] < 5e-3          # README: 3.4e-3 (lith.), 3.7e-3 (unif.)
    assert abs(res["lithostatic"]["half_life"] - 0.4854) < 5e-3   # README: 0.4884


def test_one_gas_law_enum_for_solver_theory_and_case_files():
    """The solver, the dispersion analysis and the case files share granflow.gas.GasLaw; "none"
    is the dry model for Model and an error for the gas block."""
    from granflow.config import CaseConfig
    from granflow.errors import GranflowInputError
    from granflow.gas import GasLaw
    from granflow.grid import Grid
    from granflow.model import Model
    from granflow.operators import Operators
    from granflow.physics import pore_pressure
    from granflow.physics.coupling import GasCoupling
    from granflow.rheology import make_closure
    from granflow.theory import dispersion

    assert pore_pressure.GasLaw is GasLaw and dispersion.GasLaw is GasLaw
    cfg_laws = CaseConfig.model_fields["gas"].annotation.model_fields["law"].annotation.__args__
    assert set(cfg_laws) == {law.value for law in GasLaw}
    g = Grid(nx=4, nz=3, Lx=1.0, Lz=1.0)
    assert Model(g, make_closure("mu_i"), gas="none").gas is None
    with pytest.raises(GranflowInputError, match="none"):
        GasCoupling(g, Operators.build(g), make_closure("mu_i").material, "none")


@pytest.mark.parametrize("open_top", [False, True])
def test_gas_operator_equals_the_sparse_product_formula(open_top):
    """The fixed-pattern assembly of gas_operator against its definition written with scipy.sparse
    products here: diag((1-phi)/dt) + grad^T diag(K_f) grad (+ top term), Dirichlet rows/columns
    replaced by the mean diagonal of the other cells; 1e-12 relative."""
    import scipy.sparse as sp

    from granflow.physics.pore_pressure import face_permeability, gas_operator

    g = Grid(nx=9, nz=7, Lx=0.09, Lz=0.07)
    ops = Operators.build(g)
    mat = Material(d=70e-6, rho_s=2500.0, phi_max=0.6, eta_f=1.8e-5)
    rng = np.random.default_rng(5)
    phi = 0.45 + 0.15 * rng.random(g.n_cells)
    mask = rng.random(g.n_cells) < 0.3
    dt = 1e-3
    block = gas_operator(g, ops, phi, dt, mat, dirichlet=mask.reshape(g.cell_shape), open_top=open_top)
    kappa_f, kappa_top = face_permeability(g, ops, phi, mat)
    ref = sp.diags((1 - phi) / dt) + ops.grad.T @ sp.diags(mat.p_atm * kappa_f) @ ops.grad
    if open_top:
        top = np.zeros(g.n_cells)
        top.reshape(g.cell_shape)[:, -1] = 2.0 * mat.p_atm * kappa_top / g.dz**2
        ref = ref + sp.diags(top)
    keep = sp.diags((~mask).astype(float))
    scale = ref.diagonal()[~mask].mean()
    ref = (keep @ ref @ keep + sp.diags(mask * scale)).toarray()
    assert np.abs(block.matrix.toarray() - ref).max() <= 1e-12 * np.abs(ref).max()
