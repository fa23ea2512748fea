"""Dry solver v1 (granflow.model / simulation / diagnostics): static states, tilted layer,
tiny column collapse, every paper closure.

Independent references: lithostatic pressure phi rho_s g (H - z) written here; the creep scale
eps H of the regularisation (NUMERICS.md §4, §11.4); the infinite-slope Coulomb acceleration
g (sin(theta) - Z cos(theta)); sparse matrices assembled here from the operators; exact sums.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from granflow import diagnostics as dg
from granflow.grid import Grid
from granflow.model import Model, StepReport, StepStatus
from granflow.operators import Operators
from granflow.physics import momentum as mom
from granflow.rheology import CLOSURES, make_closure
from granflow.simulation import Simulation, StepFailure, TimeInterval
from granflow.step_retry import retry_factor
from granflow.state import State

G = 9.81
RHO_S = 2500.0
PHI_MAX = 0.6
D = 70e-6
DELTA_DEG = 26.74  # sin(delta) = 0.45
MATERIAL = dict(d=D, rho_s=RHO_S, phi_max=PHI_MAX)
PAPER_CLOSURES = [n for n in CLOSURES.names() if not CLOSURES.get(n).reference]


def closure(name: str, **params):
    if name == "drucker_prager" and not params:
        params = dict(delta_deg=DELTA_DEG)
    return make_closure(name, material=MATERIAL, **params)


def material_faces(model: Model, phi) -> np.ndarray:
    """Velocity unknowns whose centred solid fraction is granular (>= phi_c)."""
    return model.ops.cell_to_face @ np.ravel(phi) >= model.ambient.phi_c


# --------------------------------------------------------------------------------------------
# Assembly
# --------------------------------------------------------------------------------------------
def test_fast_saddle_assembly_matches_the_operator_products():
    rng = np.random.default_rng(3)
    g = Grid(nx=7, nz=5, Lx=0.7, Lz=0.5)
    model = Model(g, closure("drucker_prager"))
    ops = model.ops
    eta_c = rng.uniform(0.0, 1e4, g.n_cells)
    eta_n = rng.uniform(0.0, 1e4, g.n_nodes)
    rho_dt = rng.uniform(1e3, 1e6, g.n_unknowns)
    active = rng.uniform(size=g.n_cells) < 0.6
    C = rng.uniform(0.0, 1.0, g.n_cells)
    V = ops.ec.T @ sp.diags(eta_c) @ ops.ec + ops.en.T @ sp.diags(ops.node_weights * eta_n) @ ops.en
    A = sp.diags(rho_dt) + V
    Ga = ops.grad[:, np.flatnonzero(active)]
    K = sp.bmat([[A, Ga], [Ga.T, sp.diags(-C[active])]]).toarray()
    asm = model.assembler
    K_fast = asm.saddle(asm.velocity_data(rho_dt, eta_c, eta_n), active, C).toarray()
    assert np.allclose(K_fast, K, rtol=1e-12, atol=1e-9 * np.abs(K).max())


def test_bordered_system_appends_a_velocity_coupled_block():
    """Extension point for p_f: [[K, [B; 0]], [[R, 0], M]] with blocks placed by hand here."""
    rng = np.random.default_rng(4)
    g = Grid(nx=4, nz=3, Lx=0.4, Lz=0.3)
    asm = Model(g, closure("drucker_prager")).assembler
    active = np.array([True, False] * (g.n_cells // 2))
    K = asm.saddle(asm.velocity_data(np.ones(g.n_unknowns), np.ones(g.n_cells), np.ones(g.n_nodes)),
                   active, np.ones(g.n_cells))
    k = 5
    B, R, M = (sp.random(*shape, density=0.5, random_state=rng) for shape in
               ((g.n_unknowns, k), (k, g.n_unknowns), (k, k)))
    big = asm.bordered(K, B, R, M).toarray()
    n, m = g.n_unknowns, int(active.sum())
    assert big.shape == (n + m + k, n + m + k)
    assert np.array_equal(big[:n + m, :n + m], K.toarray())
    assert np.array_equal(big[:n, n + m:], B.toarray()) and not big[n:n + m, n + m:].any()
    assert np.array_equal(big[n + m:, :n], R.toarray()) and not big[n + m:, n:n + m].any()
    assert np.array_equal(big[n + m:, n + m:], M.toarray())


@pytest.mark.parametrize("scheme, order", [("upwind", 1.0), ("muscl", 2.0)])
def test_momentum_advection_order_on_a_smooth_monotone_field(scheme, order):
    """(u . grad) u for u = 1 + x^2/2 + 0.3 z^2, w = 0.5 + 0.2 x + 0.4 z^2 (monotone, positive:
    no limiter clipping) against the closed form, max error >= 3 cells from the walls, 16 -> 128
    cells. Observed orders: upwind 0.85, 0.92, 0.96; MUSCL 1.81, 1.91, 1.96."""
    errs = []
    for n in (16, 32, 64, 128):
        g = Grid(nx=n, nz=n, Lx=1.0, Lz=1.0)
        ops = Operators.build(g)
        Xu, Zu = g.xface_coords()
        Xw, Zw = g.zface_coords()
        U = lambda x, z: 1 + 0.5 * x**2 + 0.3 * z**2  # noqa: E731
        W = lambda x, z: 0.5 + 0.2 * x + 0.4 * z**2  # noqa: E731
        a = mom.momentum_advection(ops, g.pack_velocity(U(Xu, Zu), W(Xw, Zw)), scheme)
        ref_u = (U(Xu, Zu) * Xu + W(Xu, Zu) * 0.6 * Zu)[1:-1, :]
        ref_w = (U(Xw, Zw) * 0.2 + W(Xw, Zw) * 0.8 * Zw)[:, 1:-1]
        e_u = np.abs(a[g.u_slice].reshape(ref_u.shape) - ref_u)[3:-3, 3:-3]
        e_w = np.abs(a[g.w_slice].reshape(ref_w.shape) - ref_w)[3:-3, 3:-3]
        errs.append(max(e_u.max(), e_w.max()))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - order) < 0.2), orders


# --------------------------------------------------------------------------------------------
# Static states
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["drucker_prager", "mu_i"])
def test_static_layer_stays_at_rest_with_lithostatic_pressure(name):
    """Uniform layer phi = phi_max, H = 7 cells, no-slip base, started with p = 0 (the solver
    must find the pressure). Discrete hydrostatics: Grad p = phi_f rho_s g_z on z-faces with
    phi_f = phi_max inside, phi_max/2 on the face to the ambient (p = 0), so
    p_j = phi rho_s g (H - z_j) exactly at the cell centres (derivation: telescoping sum from
    the top face). Bounds: |p - p_lith| <= 1e-9 max p (solver round-off, condition number
    ~1e10), max|u| <= 1e-3 eps H (the exact discrete solution is u = 0), mass and phi to 1e-12."""
    g = Grid(nx=6, nz=10, Lx=0.06, Lz=0.1)
    model = Model(g, closure(name))
    H = 0.07
    X, Z = g.cell_coords()
    phi = np.where(Z < H, PHI_MAX, 0.0)
    state = State.at_rest(g, phi)
    for _ in range(5):
        report = model.advance(state, 1e-3)
        assert report.status is StepStatus.OK, report.message
    p_lith = np.where(Z < H, PHI_MAX * RHO_S * G * (H - Z), 0.0)
    assert np.max(np.abs(state.p - p_lith)) <= 1e-9 * p_lith.max()
    assert np.max(np.abs(state.vel)) <= 1e-3 * model.eps * H
    assert abs(dg.mass(g, state.phi) - dg.mass(g, phi)) <= 1e-12 * dg.mass(g, phi)
    assert np.max(np.abs(state.phi - phi)) <= 1e-12
    assert np.allclose(model.lithostatic_pressure(phi), p_lith, rtol=1e-13, atol=1e-9)


@pytest.mark.parametrize("name, slope_deg", [("drucker_prager", 20.0), ("mu_i", 15.0)])
def test_heap_below_the_friction_angle_creeps_at_the_regularisation_level(name, slope_deg):
    """Wedge (partial cells at its surface) of slope < friction angle (DP: delta = 26.7 deg,
    critical slope >= atan(sin delta) = 24.2 deg; mu(I): mu1 = tan 21 deg) resting on a
    2-cell layer, 20 x 9 cells. Granular faces creep at speed <= 1.25 eps H and the creep is
    proportional to eps (5x smaller eps -> ratio in [4, 6]), i.e. it is the regularisation.

    The box is 9 cm high so that the DP wedge (top H = 8.5 cm) does not touch the closed lid;
    in the former 8 cm box its two first columns were full up to the lid, and under scheme v2
    (the defaults) those lid cells change their active set over the first step's Picard sweeps
    (11 changes, 10 sweeps to converge; the default 4 fail at dt = 1e-3 and 5e-4 with increments
    0.89 and 0.66) -- material pressed against a closed lid at p ~ 0 is not what this test is
    about (open point, reported). Measured (3 Dec 2026, eps = 1e-3 / 5e-3): DP max speed
    1.09 / 1.08 eps H under v2, at the z-face below the summit's thin surface cell (c = 0.32,
    friction at its mid-material pressure), 0.90 eps H under v1 at the same face; mu(I) 0.89
    eps H (v2); ratios 4.99 - 5.00; no rejected step. (Session 25, one solve per step by
    default: DP 1.089 / 1.094 eps H, mu(I) 0.890, ratios 5.023 (DP) and 4.999 (mu(I)).)"""
    g = Grid(nx=20, nz=9, Lx=0.2, Lz=0.09)
    X, Z = g.cell_coords()
    top, tail = 0.085 if slope_deg > 16 else 0.07, 0.02
    surface = np.maximum(top - X * np.tan(np.radians(slope_deg)), tail)
    phi = PHI_MAX * np.clip((surface - (Z - 0.5 * g.dz)) / g.dz, 0.0, 1.0)
    speeds = []
    for eps in (5e-3, 1e-3):
        model = Model(g, closure(name), eps=eps)
        sim = Simulation(model, model.initial_state(phi), stop_time=0.05).run()
        assert sim.n_rejected == 0
        speeds.append(np.max(np.abs(sim.state.vel[material_faces(model, sim.state.phi)])))
        assert speeds[-1] <= 1.25 * eps * top, (eps, speeds[-1])
    assert 4.0 <= speeds[0] / speeds[1] <= 6.0, speeds


def _long_layer(theta_deg: float, eps: float = 5e-3):
    """2 cm layer in a 0.4 m x 3 cm box (80 x 6 cells) under gravity tilted by theta."""
    g = Grid(nx=80, nz=6, Lx=0.4, Lz=0.03)
    th = np.radians(theta_deg)
    model = Model(g, closure("drucker_prager"), gravity=(G * np.sin(th), -G * np.cos(th)), eps=eps)
    X, Z = g.cell_coords()
    return model, model.initial_state(np.where(Z < 0.02, PHI_MAX, 0.0))


def test_tilted_layer_above_the_friction_angle_accelerates():
    """theta = 35 deg > delta: E_k grows every step. Over 0.01 -> 0.02 s, at mid-length, the
    phi-weighted mean velocity of the column grows at 0.3 to 1.0 times the infinite-slope Coulomb
    plug acceleration a_ref = g (sin theta - sin(delta) cos theta) = 2.0 m/s^2 (depth-averaged
    momentum balance with a basal friction >= sin(delta) p; the box walls, the no-slip base and
    the dilatancy slow it down), and the velocity of the top cell at 0.3 to 1.25 a_ref.

    The top cell is not bounded by a_ref itself: a discretisation error at the free surface may
    have either sign. Measured (3 Dec 2026) mean / top: scheme v2 (defaults) 0.79 / 1.15 a_ref,
    v1 (threshold, upwind) 0.53 / 0.67 (v1's pressure near the surface is 1.5 - 2.7x
    lithostatic, v2's within 5 %). On the infinite (periodic) slope v2's top-cell rate converges
    to a_ref from above with the grid, 1.19 / 1.15 / 1.08 a_ref at dz = 5 / 2.5 / 1.25 mm (mean
    0.81 / 0.86 / 0.91). (The former bound, top cell <= a_ref with the rate over 0.011 -> 0.02 s
    divided by 0.01 s, measured 1.04 a_ref under v2; the time of the sample is now used.)"""
    model, state = _long_layer(35.0)
    sim = Simulation(model, state, stop_time=0.02)
    e_k, u_top, u_mean, t = [], [], [], []
    g = model.grid
    i = g.nx // 2
    while not sim.done():
        sim.step()
        e_k.append(sim.budget.e_k)
        u, _ = g.unpack_velocity(sim.state.vel)
        phi_f = 0.5 * (sim.state.phi[i - 1, :] + sim.state.phi[i, :])
        u_top.append(u[i, 3])
        u_mean.append(float(np.sum(phi_f * u[i, :]) / np.sum(phi_f)))
        t.append(sim.state.t)
    assert np.all(np.diff(e_k) > 0)
    a_ref = G * (np.sin(np.radians(35.0)) - np.sin(np.radians(DELTA_DEG)) * np.cos(np.radians(35.0)))
    k = int(np.argmin(np.abs(np.array(t) - 0.01)))
    a_top = (u_top[-1] - u_top[k]) / (t[-1] - t[k])
    a_mean = (u_mean[-1] - u_mean[k]) / (t[-1] - t[k])
    print(f"\ntilted layer: a_mean/a_ref = {a_mean / a_ref:.3f}, a_top/a_ref = {a_top / a_ref:.3f}")
    assert 0.3 * a_ref <= a_mean <= a_ref, (a_mean, a_ref)
    assert 0.3 * a_ref <= a_top <= 1.25 * a_ref, (a_top, a_ref)


def test_tilted_layer_below_the_friction_angle_creeps():
    model, state = _long_layer(15.0)
    sim = Simulation(model, state, stop_time=0.02).run()
    assert np.max(np.abs(sim.state.vel)) <= 3.0 * model.eps * 0.02


# --------------------------------------------------------------------------------------------
# Tiny dry column collapse
# --------------------------------------------------------------------------------------------
def collapse_model(clo, nx: int = 40, nz: int = 15) -> Model:
    return Model(Grid(nx=nx, nz=nz, Lx=0.4, Lz=0.15), clo)


def column(model: Model, phi0: float = PHI_MAX) -> np.ndarray:
    X, Z = model.grid.cell_coords()
    return np.where((X < 0.1) & (Z < 0.1), phi0, 0.0)


@pytest.fixture(scope="module")
def collapse():
    """10 x 10 cm DP column, 40 x 15 cells, 0.3 s; front and E_k every 0.05 s."""
    model = collapse_model(closure("drucker_prager"))
    phi0 = column(model)
    sim = Simulation(model, model.initial_state(phi0), stop_time=0.3)
    history = []

    def record(s):
        history.append((s.state.t, dg.front_position(model.grid, s.state.phi, PHI_MAX, 0.005),
                        s.budget.e_k))

    sim.add_callback(record, TimeInterval(0.05))
    e_k = []
    sim.add_callback(lambda s: e_k.append(s.budget.e_k), TimeInterval(0.005))
    sim.run()
    return model, phi0, sim, np.array(history), np.array(e_k)


def test_collapse_runs_conserves_mass_and_respects_bounds(collapse):
    """Mass to 1e-10 with the clipped and added masses counted, bounds after the clip.

    Under the v1 MUSCL transport no phi < 0 ever occurred (``added == 0`` exactly). The v2
    indicator transport (default since 180fbc3) carries the grains with the MUSCL face value of
    the packing phi/c times the volume flux; a cell emptied of material in one step can then
    send out slightly more grains than it holds. Measured on this run (3 Dec 2026): one such cell
    (c = 9.85e-4, phi = 5.71e-4 -> c = 0, phi = -4.53e-6, a face packing 0.585 against its own
    0.580), the other 15 events round-off (-4e-22); added mass 4.53e-10 m^2 = 7.6e-8 of the
    total. Bound: added <= 1e-6 of the total, min phi before the clip >= -1e-5."""
    model, phi0, sim, _, _ = collapse
    g = model.grid
    clipped = sum(r.clipped_mass for r in sim.reports)
    added = sum(r.added_mass for r in sim.reports)
    m0 = dg.mass(g, phi0)
    mass_err = (dg.mass(g, sim.state.phi) + clipped - added - m0) / m0
    max_before = max(r.max_phi_before_clip for r in sim.reports)
    print(f"\ncollapse: steps={sim.state.step} rejected={sim.n_rejected} mass err (transport)="
          f"{mass_err:.2e} clipped mass={clipped / m0:.2e} of total, max phi before clip={max_before:.5f}")
    assert sim.n_rejected == 0
    assert abs(mass_err) <= 1e-10
    assert clipped / m0 <= 1e-2
    assert added / m0 <= 1e-6
    assert min(r.min_phi_before_clip for r in sim.reports) >= -1e-5
    assert sim.state.phi.min() >= 0.0 and sim.state.phi.max() <= PHI_MAX
    assert max_before <= PHI_MAX * (1 + model.phi_tolerance)


def test_collapse_front_advances_and_slows_down(collapse):
    model, _, _, history, e_k = collapse
    t, front, _ = history.T
    print("\nfront (h > 5 mm): " + ", ".join(f"t={a:.2f}s {b:.3f}m" for a, b in zip(t, front)))
    print(f"E_k peak {e_k.max():.3e} J/m, final {e_k[-1]:.3e} J/m")
    assert front[0] == pytest.approx(0.1)
    assert front[-1] >= 0.1 + 5 * model.grid.dx
    assert np.all(np.diff(front) >= 0)
    steps = np.rint(np.diff(front) / model.grid.dx)  # the front moves by whole cells
    # the front slows down: its last advance is below its fastest (measured with the v2 defaults,
    # 3 Dec 2026: 1, 2, 3, 4, 3, 3 cells per interval; with the minmod momentum limiter and the
    # reconstructed gravity weight 1, 2, 3, 4, 4, 2)
    assert steps[-1] < steps.max()
    assert e_k[-1] <= 0.35 * e_k.max()           # kinetic energy decays


def test_collapse_energy_budget(collapse):
    """err = E_k + E_p - (E_k + E_p)(0) + int D dt; reported, |err| < released energy; its
    decomposition into the four numerical terms is an exact identity (diagnostics docstring)."""
    _, _, sim, _, _ = collapse
    b = sim.budget
    parts = ", ".join(f"{k} {v / b.released:+.3f}" for k, v in b.numerical.items())
    print(f"\nenergy: released {b.released:.4f} J/m, dissipated {b.dissipated:.4f} J/m, "
          f"err/released = {b.relative_residual:+.3f} ({parts})")
    assert np.isfinite(b.residual) and b.released > 0
    assert abs(b.relative_residual) < 1.0
    assert np.isclose(sum(b.numerical.values()), b.residual, rtol=1e-8, atol=1e-10 * b.released)


#: Closures that cannot run the collapse, and why (MODEL.md §6.4): reported, not special-cased.
ILL_POSED_HERE = {
    "drucker_prager_dilatancy": "Z = sin(delta) + cos(delta) psi < 0 where I << I_eq (static, "
                                "slightly loose regions); Picard then diverges",
    "mu_i_dilatancy": "psi = G(I) - G(I_eq) is +inf at phi = phi_max (Z = inf) and -> -inf for "
                      "I << I_eq (Z < 0)",
}


@pytest.mark.parametrize("name", PAPER_CLOSURES)
def test_every_paper_closure_takes_steps_of_the_collapse(name):
    """Five steps of the tiny collapse (column at phi_max, and slightly loose at 0.59) for every
    non-reference closure of the registry, with no closure-specific code in the solver.
    Closures in ILL_POSED_HERE must have their trouble *reported* (a StepFailure naming Z or the
    Picard divergence, or cells with Z < 0 counted in the step reports), never NaN."""
    clo = closure(name)
    for phi0 in (PHI_MAX, 0.59):
        # the Picard loop: its divergence is one way the trouble is reported (one solve per
        # step has no loop to diverge; the theory toolkit's checks C1-C3 say it beforehand)
        model = Model(Grid(nx=40, nz=15, Lx=0.4, Lz=0.15), clo, picard={"max_sweeps": 10, "predictor": "previous"})
        sim = Simulation(model, model.initial_state(column(model, phi0)), stop_time=1.0,
                         max_steps=5, max_retries=1)
        failure = ""
        try:
            sim.run()
        except StepFailure as err:
            failure = str(err)
        n_neg = max((r.n_negative_Z for r in sim.reports), default=0)
        print(f"\n{name} phi0={phi0}: steps={sim.state.step} max cells with Z<0={n_neg} {failure[:160]}")
        assert sim.state.is_finite()
        if name in ILL_POSED_HERE:
            assert ("'Z'" in failure or "Picard" in failure) if failure else n_neg > 0
        else:
            assert not failure and sim.state.step == 5 and n_neg == 0
            assert np.max(np.abs(sim.state.vel)) > 0.0


@pytest.mark.parametrize("advection", ["consistent", "upwind"])
def test_diagnostics_closed_forms(advection):
    """Mass, potential and kinetic energy, deposit thickness and front of hand-built fields.
    The kinetic energy uses the model's face inertia: ``phi_f rho_s + rho_a`` with the
    consistent transport (scheme v2, default), ``max(phi_f rho_s, rho_a)`` with the v1 upwind."""
    g = Grid(nx=10, nz=5, Lx=1.0, Lz=0.5)                   # dx = dz = 0.1
    model = Model(g, closure("drucker_prager"), gravity=(0.0, -G), advection=advection)
    X, Z = g.cell_coords()
    H, L = 0.3, 0.4
    phi = np.where((Z < H) & (X < L), PHI_MAX, 0.0)
    phi[6, 0] = 0.3                                          # a thin deposit up to x = 0.7
    state = State.at_rest(g, phi)
    assert np.isclose(dg.mass(g, phi), PHI_MAX * H * L + 0.3 * 0.01, rtol=1e-14)
    e_p = PHI_MAX * RHO_S * G * L * H**2 / 2 + 0.3 * RHO_S * G * 0.05 * 0.01
    assert np.isclose(dg.potential_energy(model, state), e_p, rtol=1e-12)
    h = dg.deposit_thickness(g, phi, PHI_MAX)
    assert np.allclose(h[:4], H) and np.isclose(h[6], 0.05) and h[5] == 0.0
    assert dg.front_position(g, phi, PHI_MAX, 0.01) == pytest.approx(0.7)
    assert dg.front_position(g, phi, PHI_MAX, 0.1) == pytest.approx(0.4)
    assert np.isnan(dg.front_position(g, phi, PHI_MAX, 1.0))
    u = np.zeros(g.xface_shape)
    u[1:4, :3] = 2.0                                          # faces inside the block
    state.vel = g.pack_velocity(u, np.zeros(g.zface_shape))
    rho_a = model.ambient.rho_a
    assert 0.0 < rho_a < PHI_MAX * RHO_S
    rho_f = PHI_MAX * RHO_S + (rho_a if advection == "consistent" else 0.0)
    assert np.isclose(dg.kinetic_energy(model, state), 0.5 * rho_f * 4.0 * 9 * 0.01, rtol=1e-12)


# --------------------------------------------------------------------------------------------
# Simulation machinery
# --------------------------------------------------------------------------------------------
class _FlakyModel(Model):
    """Fails every step longer than dt_ok (tests the retry)."""

    dt_ok = 2.6e-4

    def advance(self, state, dt):
        if dt > self.dt_ok:
            return StepReport(status=StepStatus.FAILED, dt=dt, message="too long")
        return super().advance(state, dt)


def test_failed_steps_are_retried_with_half_dt():
    g = Grid(nx=4, nz=4, Lx=0.04, Lz=0.04)
    model = _FlakyModel(g, closure("drucker_prager"))
    sim = Simulation(model, model.initial_state(np.where(g.cell_coords()[1] < 0.02, PHI_MAX, 0.0)),
                     stop_time=1e-3, dt_max=1e-3)
    report = sim.step()
    assert report.dt == pytest.approx(2.5e-4) and sim.n_rejected == 2
    model.dt_ok = 1e-9
    with pytest.raises(StepFailure):
        sim.step()
    assert sim.state.t == pytest.approx(2.5e-4)  # the failed step left the state untouched


class _CFLModel(Model):
    """Fails, as the transport stage does, every step whose ``u^{n+1}`` would have the CFL number
    ``rate * dt`` above 1/2 (``rate`` [1/s] independent of dt: the retry's premise)."""

    rate = 2400.0
    tried: list

    def advance(self, state, dt):
        self.tried.append(dt)
        cfl = self.rate * dt
        if cfl > 0.5:
            return StepReport(status=StepStatus.FAILED, dt=dt, message="CFL", cfl=cfl)
        return super().advance(state, dt)


def test_a_cfl_failure_is_retried_with_the_dt_of_its_cfl_number():
    """dt_1 = dt_0 * 0.9 * 0.5 / c (simulation.retry_factor), not dt_0 / 2: with c = 2400 * 1e-3
    = 2.4 the retry's dt is 1e-3 * 0.45 / 2.4 = 1.875e-4, CFL 0.45 (accepted at once)."""
    g = Grid(nx=4, nz=4, Lx=0.04, Lz=0.04)
    model = _CFLModel(g, closure("drucker_prager"))
    model.tried = []
    sim = Simulation(model, model.initial_state(np.where(g.cell_coords()[1] < 0.02, PHI_MAX, 0.0)),
                     stop_time=1e-3, dt_max=1e-3)
    report = sim.step()
    assert model.tried == [pytest.approx(1e-3), pytest.approx(1.875e-4, rel=1e-12)]
    assert report.dt == pytest.approx(1.875e-4, rel=1e-12) and sim.n_rejected == 1
    # a barely failing step loses 10 %, not half; a diverging one (c = 1e6) at most 90 %
    fail = {c: StepReport(status=StepStatus.FAILED, dt=1.0, cfl=c) for c in (0.52, 1e6)}
    assert retry_factor(fail[0.52]) == pytest.approx(0.45 / 0.52) and retry_factor(fail[1e6]) == 0.1
    assert retry_factor(StepReport(status=StepStatus.FAILED, dt=1.0, message="NaN")) == 0.5


def test_nan_state_is_rejected():
    g = Grid(nx=4, nz=4, Lx=0.04, Lz=0.04)
    model = Model(g, closure("drucker_prager"))
    state = model.initial_state(np.full(g.cell_shape, PHI_MAX))
    state.p[0, 0] = np.nan
    with pytest.raises(StepFailure):
        Simulation(model, state, stop_time=1e-3).run()
