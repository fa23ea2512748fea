"""Steady flow down an infinite incline (issue 3 items 9c, 9d; MODEL.md §7; NUMERICS.md §11 item 3):
a granular layer on a grid periodic in x under the tilted gravity g (sin theta, -cos theta), no-slip
base, pressureless ambient above, mu(I) closure with its dilatancy law (MODEL.md §3).

Exact solution, written here from MODEL.md (never from granflow): in a steady uniform layer the
stress ratio is tan(theta) at every depth, so mu(I_theta) = tan(theta) with
mu(I) = mu1 + (mu2 - mu1)/(1 + I0/I), i.e. I_theta = I0 (tan(theta) - mu1)/(mu2 - tan(theta));
div u = 0 needs f = 0, i.e. phi = phi_eq(I_theta) = phi_max - delta_phi I_theta (uniform);
p = phi rho_s g cos(theta) (h - z); and I = c_I d |S| / sqrt(p/rho_s) with |S| = |du/dz|/2 in
simple shear gives du/dz = (2 I_theta/(c_I d)) sqrt(phi g cos(theta) (h - z)), the Bagnold profile

    u(z) = (4 I_theta / (3 c_I d)) sqrt(phi g cos(theta)) [h^(3/2) - (h - z)^(3/2)],

i.e. (2 I/(3d)) ... for the literature's c_I = 2 and (4 I/(3d)) ... for the paper's c_I = 1
(NUMERICS.md §11 writes the latter). The layer thickness h is fixed by the mass:
h = h0 phi0 / phi_eq(I_theta). With a base gas overpressure p_f = beta x lithostatic (9d),
p = (1 - beta) x lithostatic, so mu(I) = tan(theta)/(1 - beta) and g -> (1 - beta) g in the
square root.

Numerical set-up (shared by all cases): h0 = 1 cm, d = 0.5 mm (u_s ~ 0.4 m/s), theta = 25 deg
(I_theta = 0.135, phi_eq = 0.573), nx = 4 columns of 25 cm (uniform flow: the x extent only sets
the advective CFL), nz cells over h0 plus 2-3 ambient cells, granflow.simulation.Simulation with
dt_max = 0.05 s to t = 12 s (relaxation time ~2 s; the surface velocity then changes by <= 1e-3
relative over the last 2 s). Model options and why (each measured, see
validation/inclined_plane/README.md):

* ``delta_p = 1e-3`` Pa: the sqrt(p) offset enters I; the top cell's p is ~3 Pa at nz = 20;
* ``ambient.eta_a = 1e-4`` Pa s: the background viscosity of dense cells carries a stress
  eta_a du/dz that the yield stress no longer carries; mu(I) is so flat (I mu'/mu = 0.12) that the
  default 1e-3 Pa s lowers I, hence u, by ~1 %;
* ``interface_packing = False``: with phi_loc the two top cells are evaluated at the bulk packing,
  and since their discrete I exceeds I_eq(phi_loc) they dilate without end (u_s +50 % by 2 s);
* ``gravity_blend_velocity = 0.01`` m/s: with the default eps Lz ~ 6e-5 m/s the weight of the
  surface z-face flips between its two upwind values every step and pumps grains into the
  ambient (no steady state).
"""
from __future__ import annotations

import numpy as np
import pytest

from granflow.grid import Grid
from granflow.model import Model
from granflow.rheology import make_closure
from granflow.simulation import Simulation, TimeInterval

G = 9.81
RHO_S = 2500.0
PHI_MAX = 0.6
DELTA_PHI = 0.2
D = 5e-4
MU1, MU2, I0 = np.tan(np.radians(21.0)), np.tan(np.radians(33.0)), 0.3
THETA = np.radians(25.0)
H0 = 0.01
NX, LX = 4, 1.0
T_END = 12.0
DT_MAX = 0.05
RECORD = 1.0                 # s between recorded surface velocities
OPTIONS = {"delta_p": 1e-3, "ambient": {"eta_a": 1e-4}, "interface_packing": False,
           "gravity_blend_velocity": 0.01, "isochoric_interface": 0}  # the top cells must dilate
STEADY_TOL = 1e-3            # relative change of u_s over the last 2 s


# --- exact solution (MODEL.md §3, §7) ---------------------------------------------------------
def inertial_number(mu: float) -> float:
    """I with mu1 + (mu2 - mu1)/(1 + I0/I) = mu."""
    assert MU1 < mu < MU2
    return I0 * (mu - MU1) / (MU2 - mu)


def bagnold(z, h: float, c_I: float, beta: float = 0.0, theta: float = THETA):
    """Bagnold velocity [m/s] at height z of a layer of thickness h (module docstring)."""
    I = inertial_number(np.tan(theta) / (1.0 - beta))
    phi = PHI_MAX - DELTA_PHI * I
    scale = 4.0 * I / (3.0 * c_I * D) * np.sqrt((1.0 - beta) * phi * G * np.cos(theta))
    return scale * (h**1.5 - np.clip(h - np.asarray(z), 0.0, None) ** 1.5)


@pytest.mark.parametrize("beta, theta_deg", [(0.0, 25.0), (0.15, 22.0)])
def test_the_package_bagnold_layer_is_this_derivation(beta, theta_deg):
    """granflow.verification.bagnold (used by the inclined_layer case and
    validation/inclined_plane) against the derivation above, below and above the surface."""
    from granflow.verification.bagnold import BagnoldLayer, steady_inertial_number

    theta, h, c_I = np.radians(theta_deg), 0.012, 2.0
    mu = np.tan(theta) / (1.0 - beta)
    I = steady_inertial_number(mu, MU1, MU2, I0)
    assert I == pytest.approx(inertial_number(mu), rel=1e-15)
    layer = BagnoldLayer(theta=theta, beta=beta, I=I, phi=PHI_MAX - DELTA_PHI * I, h=h, c_I=c_I, d=D, g=G)
    z = np.linspace(0.0, 1.5 * h, 31)
    np.testing.assert_allclose(layer.velocity(z), bagnold(z, h, c_I, beta, theta), rtol=1e-14, atol=0.0)
    assert layer.surface_velocity == pytest.approx(float(bagnold(h, h, c_I, beta, theta)), rel=1e-14)


def phi_eq(beta: float = 0.0, theta: float = THETA) -> float:
    return PHI_MAX - DELTA_PHI * inertial_number(np.tan(theta) / (1.0 - beta))


# --- runs ------------------------------------------------------------------------------------
def flow(nz: int, c_I: float = 2.0, from_rest: bool = False, beta: float = 0.0,
         theta: float = THETA, closure: str = "mu_i", t_end: float = T_END, dt_max: float = DT_MAX,
         **options):
    """Run the periodic layer to t_end; returns (model, state, h, u_s history)."""
    phi_flow = phi_eq(beta, theta) if closure == "mu_i" else PHI_MAX
    phi0 = PHI_MAX if from_rest else phi_flow
    h = H0 * phi0 / phi_flow
    n_amb = 3 if from_rest else 2
    dz = H0 / nz
    g = Grid(nx=NX, nz=nz + n_amb, Lx=LX, Lz=dz * (nz + n_amb), periodic_x=True)
    mat = {"d": D, "rho_s": RHO_S, "phi_max": PHI_MAX, "delta_phi": DELTA_PHI, "c_I": c_I}
    params = {"mu1": MU1, "mu2": MU2, "I0": I0} if closure == "mu_i" else {"delta_deg": 26.74}
    clo = make_closure(closure, material=mat, **params)
    gas = {}
    if beta:
        kappa = D**2 * (1 - phi0) ** 3 / (150 * clo.material.eta_f * phi0**2)   # Carman-Kozeny
        gas = {"gas": "linear", "U_inj": beta * kappa * phi0 * RHO_S * G * np.cos(theta)}
    model = Model(g, clo, gravity=(G * np.sin(theta), -G * np.cos(theta)), **{**OPTIONS, **gas, **options})
    Z = g.cell_coords()[1]
    phi = np.where(Z < H0, phi0, 0.0)
    state = model.initial_state(phi, p_f=beta * model.lithostatic_pressure(phi))
    if not from_rest:
        Zu = g.xface_coords()[1]
        state.vel = g.pack_velocity(bagnold(Zu, h, c_I, beta, theta), np.zeros(g.zface_shape))
    history = []
    sim = Simulation(model, state, stop_time=t_end, dt_max=dt_max)
    sim.add_callback(lambda s: history.append(surface_velocity(g, s.state)), TimeInterval(RECORD))
    sim.run()
    return model, sim.state, h, np.array(history)


def surface_velocity(g: Grid, state) -> float:
    """u in the top row of x-faces: the stress-free ambient moves with the free surface."""
    return float(g.unpack_velocity(state.vel)[0][0, -1])


def relative_drift(history) -> float:
    return abs(history[-1] - history[-3]) / abs(history[-1])


V1 = {"advection": "upwind", "surface": "threshold"}
"""Scheme v1, pinned where a test checks a property of its threshold surface."""
MODEL_FLOOR = 2e-3
"""Grid-independent part of the u_s error [-] from the model parameters of OPTIONS: the
background viscosity eta_a = 1e-4 Pa s lowers u_s by 1.2e-3 (measured with v2: -1.17e-2 for
eta_a = 1e-3 at nz = 20 and 40, linear in eta_a), and a further +8e-4 remains at eta_a = 1e-5
(nz = 20, 40); together -3.6e-4 at nz = 20 and 40, -8.2e-4 at nz = 80."""


@pytest.fixture(scope="module")
def ladder():
    """Runs from the Bagnold state at nz = 10, 20, 40, default numerics (scheme v2) (~2 s)."""
    return {nz: flow(nz) for nz in (10, 20, 40)}


@pytest.fixture(scope="module")
def ladder_v1():
    """The same ladder with scheme v1 pinned (~3 s)."""
    return {nz: flow(nz, **V1) for nz in (10, 20, 40)}


def _surface_errors(ladder) -> np.ndarray:
    errs = []
    for nz, (model, state, h, hist) in ladder.items():
        assert relative_drift(hist) <= STEADY_TOL, (nz, hist[-3:])
        errs.append(surface_velocity(model.grid, state) / float(bagnold(h, h, 2.0)) - 1.0)
    return np.array(errs)


# --- 9c: dry mu(I) layer ---------------------------------------------------------------------
def test_surface_velocity_converges_to_bagnold(ladder):
    """Default numerics (scheme v2, sharp indicator surface with p = 0 at the reconstructed
    surface, the base's friction at the wall's pressure and strain rate): u_s relative error
    measured +1.03e-2, +4.6e-3, +1.8e-3 at nz = 10, 20, 40 (session 13; orders 1.16, 1.32): first
    order, from the base's one-sided wall gradient, above the MODEL_FLOOR of the model parameters.
    (With the bottom cell's mean strain rate, before, -6.4e-3, -3.6e-4, -3.6e-4: two first-order
    errors of opposite sign cancelled from nz = 20 on.) Required: |err| <= 2.5e-2 at nz = 40 as for
    v1, order >= 0.6 on both halvings, |err| <= 5 MODEL_FLOOR at nz = 40; each run steady to 1e-3."""
    errs = _surface_errors(ladder)
    orders = np.log2(np.abs(errs[:-1]) / np.abs(errs[1:]))
    print(f"\nsurface velocity errors {errs}, orders {orders}")
    assert abs(errs[-1]) <= 2.5e-2
    assert np.all(orders >= 0.6), orders
    assert abs(errs[-1]) <= 5 * MODEL_FLOOR, errs


def test_v1_surface_velocity_converges_to_bagnold_at_first_order(ladder_v1):
    """Scheme v1 pinned (upwind, threshold surface): u_s relative error measured +7.2e-2,
    +3.3e-2, +1.8e-2 at nz = 10, 20, 40 (first order: the partial surface cell, whose grains are
    sheared along x but whose weight is only half carried by p, adds a surcharge;
    validation/inclined_plane/README.md). Required: |err| <= 2.5e-2 at nz = 40, decreasing,
    observed order >= 0.6 on both halvings; each run steady to 1e-3."""
    errs = _surface_errors(ladder_v1)
    orders = np.log2(np.abs(errs[:-1]) / np.abs(errs[1:]))
    print(f"\nv1 surface velocity errors {errs}, orders {orders}")
    assert abs(errs[-1]) <= 2.5e-2
    assert np.all(orders >= 0.6), orders


def test_profile_packing_and_pressure_at_the_finest_level(ladder):
    """nz = 40: u(z) within 3 % of u_s of the Bagnold profile at every x-face of the layer
    (measured 1.8 %); phi = phi_eq(I_theta) = 0.5730: median within 5e-4 (measured -3.4e-4), every
    cell of the lower 3/4 within 1e-3 (measured 6.5e-4; the surface cells are looser); p within
    1 % of p_base of phi rho_s g cos(theta) (h - z) (measured 0.07 %); the flow is uniform in x
    (1e-10) and w vanishes (|w| <= 1e-6 u_s in the layer)."""
    model, state, h, _ = ladder[40]
    g = model.grid
    nz = 40
    u, w = g.unpack_velocity(state.vel)
    zc = g.zc[:nz]
    u_s = float(bagnold(h, h, 2.0))
    assert np.abs(u[:, :nz] - bagnold(zc, h, 2.0)).max() <= 3e-2 * u_s
    assert np.abs(u - u[:1]).max() <= 1e-10 * u_s and np.abs(state.phi - state.phi[:1]).max() <= 1e-10
    assert np.abs(w[:, :nz]).max() <= 1e-6 * u_s
    p_exact = phi_eq() * RHO_S * G * np.cos(THETA) * (h - zc)
    print(f"\nnz = 40: max |u - Bagnold| / u_s = {np.abs(u[:, :nz] - bagnold(zc, h, 2.0)).max() / u_s:.2e}, "
          f"median phi - phi_eq = {np.median(state.phi[:, :nz]) - phi_eq():+.2e}, max over the lower "
          f"3/4 {np.abs(state.phi[:, :30] - phi_eq()).max():.2e}, max |p - p_exact| / p_base = "
          f"{np.abs(state.p[:, :nz] - p_exact).max() / p_exact[0]:.2e}")
    assert abs(np.median(state.phi[:, :nz]) - phi_eq()) <= 5e-4
    assert np.abs(state.phi[:, :30] - phi_eq()).max() <= 1e-3
    assert np.abs(state.p[:, :nz] - p_exact).max() <= 1e-2 * p_exact[0]


def test_layer_at_phi_max_dilates_to_phi_eq_and_reaches_bagnold():
    """From rest at phi_max (above phi_eq(I_theta)): the shear dilates the layer to phi_eq(I_theta)
    (bulk median within 5e-4; measured 0.57269 vs 0.57298), its surface rises to
    h = h0 phi_max/phi_eq (4.7 %), and the steady surface velocity is Bagnold's for that h within
    3 % (measured +1.7 %), nz = 20."""
    model, state, h, hist = flow(20, from_rest=True)
    assert relative_drift(hist) <= STEADY_TOL
    layer = state.phi[:, :18]
    assert abs(np.median(layer) - phi_eq()) <= 5e-4
    mass_height = state.phi.sum(axis=1).mean() * model.grid.dz / phi_eq()
    assert mass_height == pytest.approx(h, rel=1e-12)
    err = surface_velocity(model.grid, state) / float(bagnold(h, h, 2.0)) - 1.0
    print(f"\nfrom rest: median phi {np.median(layer):.5f} (phi_eq {phi_eq():.5f}), u_s error {err:+.3e}")
    assert abs(err) <= 3e-2


def test_the_inertial_number_convention_is_caught(ladder):
    """Same flow with c_I = 1 (the paper's I): I_theta and phi_eq are unchanged, so the shear rate
    doubles and u_s must be twice the c_I = 2 value (measured ratio 1.991; required 2 within 2 %).
    Compared with the c_I = 2 Bagnold formula, the c_I = 1 run is off by ~100 % -- far outside the
    3 % tolerance of the check above -- and the c_I = 1 formula matches it (within 3.5 %). The
    NUMERICS.md §11 formula (4 I/(3d), i.e. c_I = 1) would likewise be off by 2 on a c_I = 2 run."""
    model2, state2, h, _ = ladder[20]
    model1, state1, _, hist = flow(20, c_I=1.0)
    assert relative_drift(hist) <= STEADY_TOL
    u1, u2 = surface_velocity(model1.grid, state1), surface_velocity(model2.grid, state2)
    print(f"\nc_I = 1: u_s = {u1:.4f} m/s, c_I = 2: {u2:.4f} m/s, ratio {u1 / u2:.4f}")
    assert u1 / u2 == pytest.approx(2.0, rel=2e-2)
    assert abs(u1 / float(bagnold(h, h, 2.0)) - 1.0) >= 0.9
    assert abs(u1 / float(bagnold(h, h, 1.0)) - 1.0) <= 3.5e-2
    assert abs(u2 / float(bagnold(h, h, 1.0)) - 1.0) >= 0.45


def test_drucker_prager_layer_below_the_friction_angle_stays_at_rest():
    """DP (delta = 26.7 deg, static slope limit atan(sin delta) = 24.2 deg) at theta = 15 deg on the
    periodic plane, from rest, 0.05 s in steps of 1 ms: the velocity of the granular faces stays
    at the regularisation level, <= 2 eps h (measured 1.4 eps h: the creep of the regularised
    yield stress), proportional to eps (5x smaller eps -> ratio in [4, 6]). (Ambient faces are
    excluded: a 5e-5 trace of grains above the bed falls there.)"""
    speeds = []
    theta = np.radians(15.0)
    for eps in (5e-3, 1e-3):
        model, state, h, _ = flow(10, from_rest=True, closure="drucker_prager", theta=theta,
                                  t_end=0.05, dt_max=1e-3, eps=eps)
        granular = model.ops.cell_to_face @ state.phi.ravel() >= model.ambient.phi_c
        speeds.append(np.abs(state.vel[granular]).max())
        assert speeds[-1] <= 2 * eps * h
    assert 4.0 <= speeds[0] / speeds[1] <= 6.0, speeds


# --- 9d: fluidised chute ---------------------------------------------------------------------
def test_fluidised_chute_follows_bagnold_with_the_reduced_friction():
    """theta = 22 deg, base gas injection U = beta U_mf, U_mf = kappa phi rho_s g cos(theta)
    (Carman-Kozeny, written here), p_f = 0 above the bed: the steady p_f = U (h - z)/kappa =
    beta x lithostatic, so mu(I) = tan(theta)/(1 - beta) (beta = 0.15: I = 0.158 instead of 0.025
    dry). nz = 20: p_f within 5 % of beta max(p_lith) below the top 4 cells (measured 0.4 %);
    u_s within 3 % of the fluidised Bagnold velocity (measured +0.37 %) and > 5x the dry one
    (0.442 vs 0.077 m/s)."""
    beta, theta = 0.15, np.radians(22.0)
    model, state, h, hist = flow(20, beta=beta, theta=theta)
    assert relative_drift(hist) <= STEADY_TOL
    zc = model.grid.zc[:16]
    p_lith = phi_eq(beta, theta) * RHO_S * G * np.cos(theta) * (h - zc)
    assert np.abs(state.p_f[:, :16] - beta * p_lith).max() <= 0.05 * beta * p_lith.max()
    u_s = surface_velocity(model.grid, state)
    err = u_s / float(bagnold(h, h, 2.0, beta, theta)) - 1.0
    dry = float(bagnold(h, h, 2.0, 0.0, theta))
    print(f"\nfluidised chute: u_s error {err:+.3e}, u_s {u_s:.4f} m/s, dry Bagnold {dry:.4f} m/s")
    assert abs(err) <= 3e-2
    assert u_s >= 5 * dry


# --- the validation script (smoke run, STYLE.md idiom 11) -------------------------------------
def test_validation_script_quick_run():
    """validation/inclined_plane/run.py at its coarsest level (nz = 10, 3 s): runs, and its own
    exact solution agrees with the one written here (1e-12) for both c_I, dry and fluidised."""
    from _scripts import load_script

    mod = load_script("validation/inclined_plane/run.py", "inclined_plane_run")
    z = np.linspace(0.0, H0, 7)
    for c_I in (1.0, 2.0):
        for beta, deg in ((0.0, 25.0), (0.15, 22.0)):
            ref = bagnold(z, H0, c_I, beta, np.radians(deg))
            np.testing.assert_allclose(mod.bagnold(z, c_I, deg, beta), ref, rtol=1e-12, atol=0)
    out = mod.run(10, quick=True)
    assert not out["failure"] and out["steps"] > 0
    assert all(np.isfinite(out[k]) for k in ("err_us", "err_profile", "dphi", "err_p"))


@pytest.mark.parametrize("theta, beta, cells", [(22.0, 0.0, 40), (25.0, 0.15, 20)])
def test_from_rest_with_default_numerics_is_steady_on_bagnold(theta, beta, cells):
    """Issue 12 acceptance 2 (two of the README's twelve from-rest runs): the inclined_layer case
    released from rest at phi_max with no numerics options becomes steady (drift < 1e-3 over the
    last 2 s) within 2 % of Bagnold's u_s (analytic). 22 deg dry at 40 cells is the most sensitive
    (d ln I / d ln mu ~ 22; measured +0.46 % in session 25, drift 1.7e-10; it was -2.7 % with the
    u = 0 band edge); 25 deg
    fluidised at 20 cells measured -0.59 %, drift 8.6e-7 (-3.3 % with the dense background
    viscosity 1e-3 Pa s)."""
    from _scripts import load_script

    mod = load_script("validation/inclined_plane/run.py", "inclined_plane_run")
    r = mod.from_rest(cells, theta, beta)
    assert abs(r["err_us"]) < 2e-2, r
    assert r["drift"] < 1e-3, r
