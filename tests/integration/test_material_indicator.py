"""The material indicator transport (granflow.physics.material, numerics.surface = "indicator"):
grain mass to round-off, bounds, a full region stays exactly full, a sliding layer keeps its
fraction, the surface stays sharp, and the Model/State plumbing (checkpoint of c, c from phi for a state without it)."""
import numpy as np
import pytest

from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.physics.material import (
    C_FULL,
    advect_material,
    donor_acceptor_fraction,
    material_fraction,
    packing,
)


def _uniform(g, u0=0.0, w0=0.0):
    u = np.zeros(g.xface_shape)
    w = np.zeros(g.zface_shape)
    u[1:-1] = u0
    w[:, 1:-1] = w0
    if g.periodic_x:
        u[:] = u0
    return g.pack_velocity(u, w)


def test_donor_acceptor_fraction_cases():
    # across the flow, towards a fuller acceptor: the swept width is material while the donor has it
    assert donor_acceptor_fraction(np.array(0.3), np.array(1.0), np.array(0.0), True, 0.1) == 1.0
    assert donor_acceptor_fraction(np.array(0.05), np.array(1.0), np.array(0.0), True, 0.1) == pytest.approx(0.5)
    # away from the acceptor: nothing until the swept width reaches the material
    assert donor_acceptor_fraction(np.array(0.3), np.array(0.0), np.array(1.0), True, 0.1) == 0.0
    assert donor_acceptor_fraction(np.array(0.95), np.array(0.0), np.array(1.0), True, 0.1) == pytest.approx(0.5)
    # along the flow: the donor's own fraction
    assert donor_acceptor_fraction(np.array(0.3), np.array(0.3), np.array(0.3), False, 0.1) == pytest.approx(0.3)


def test_translated_slab_mass_bounds_and_sharpness():
    g = Grid(nx=64, nz=4, Lx=1.0, Lz=4 / 64, periodic_x=True)
    c = np.zeros(g.cell_shape)
    c[10:20] = 1.0
    c[20] = 0.4
    phi = 0.55 * c
    vel = _uniform(g, u0=1.0)
    dt = 0.3 * g.dx
    mass0 = phi.sum()
    for _ in range(400):  # ~ 2 box lengths
        out = advect_material(g, c, phi, vel, dt, 0.6)
        c, phi = out.c, out.phi
    assert abs(phi.sum() - mass0) <= 1e-12 * mass0
    assert c.min() >= 0.0 and c.max() <= 1.0
    assert phi.min() >= -1e-15 and phi.max() <= 0.6 * (1 + 1e-12)
    row = c[:, 0]
    partial = np.count_nonzero((row > 1e-6) & (row < C_FULL))
    assert partial <= 2, f"surface spread over {partial} partial cells"
    inside = packing(c, phi)[c > 0.5]
    assert np.allclose(inside, 0.55, atol=1e-12)


def test_full_region_stays_full_under_uniform_dilation():
    # a box full of material with w = a z (div u = a): c stays exactly 1, phi drops as 1/(1 + a dt)-ish
    g = Grid(nx=3, nz=10, Lx=0.3, Lz=1.0)
    u = np.zeros(g.xface_shape)
    w = np.zeros(g.zface_shape)
    a = 0.1
    w[:, 1:-1] = a * g.dz * np.arange(1, g.nz)
    vel = g.pack_velocity(u, w)
    c = np.ones(g.cell_shape)
    c[:, -1] = 0.0  # room for the material to rise
    phi = 0.58 * c
    out = advect_material(g, c, phi, vel, 0.01, 0.6)
    assert np.all(out.c[:, :-2] == 1.0)
    assert out.phi.sum() == pytest.approx(phi.sum(), rel=1e-13)


def test_sliding_layer_keeps_its_fraction():
    # a half-filled row sliding along x (interface along the flow) keeps c = 0.5 exactly
    g = Grid(nx=16, nz=3, Lx=1.0, Lz=3 / 16, periodic_x=True)
    c = np.zeros(g.cell_shape)
    c[:, 0] = 1.0
    c[:, 1] = 0.5
    phi = 0.57 * c
    out = advect_material(g, c, phi, _uniform(g, u0=0.5), 0.2 * g.dx / 0.5, 0.6)
    assert np.allclose(out.c[:, 1], 0.5, atol=1e-14)
    assert np.allclose(out.phi, phi, atol=1e-14)


def test_material_fraction_of_a_cut_column():
    phi = np.array([[0.6, 0.6, 0.3, 0.0]])
    c = material_fraction(phi, np.full_like(phi, 0.6))
    assert np.allclose(c, [[1.0, 1.0, 0.5, 0.0]])


def test_model_state_carries_c_and_a_state_without_it_gets_material_of_phi():
    """Model.initial_state carries c; a State built without c (State.at_rest) gets
    c = model.material_of(phi) at its first advance (scheme v2 default; it used to be refused)
    and then runs bit for bit like the state of Model.initial_state with the same p."""
    from granflow.model import Model
    from granflow.rheology import make_closure
    from granflow.state import State

    g = Grid(nx=6, nz=6, Lx=0.06, Lz=0.06)
    model = Model(g, make_closure("drucker_prager"), surface="indicator", advection="consistent")
    phi = np.zeros(g.cell_shape)
    phi[:3, :3] = 0.6
    phi[:3, 3] = 0.3
    st = model.initial_state(phi)
    assert np.allclose(st.c[:3, 3], 0.5) and np.all(st.c[:3, :3] == 1.0) and np.all(st.c[3:] == 0.0)
    copy = st.copy()
    assert copy.c is not st.c and np.array_equal(copy.c, st.c)
    bare = State.at_rest(g, phi, p=st.p.copy())
    assert bare.c is None
    for _ in range(3):
        report = model.advance(st, 1e-4)
        assert report.status.value != "failed"
        report = model.advance(bare, 1e-4)
        assert report.status.value != "failed"
        assert bare.c is not None
    assert st.phi.sum() == pytest.approx(phi.sum(), rel=1e-12)
    assert np.max(np.abs(st.vel)) > 0.0                       # the column is collapsing
    for name in ("phi", "c", "p", "vel"):
        assert np.array_equal(getattr(bare, name), getattr(st, name)), name
    # the threshold surface (v1) carries no c and leaves it None
    v1 = Model(g, make_closure("drucker_prager"), surface="threshold", advection="upwind")
    st1 = State.at_rest(g, phi)
    assert v1.advance(st1, 1e-4).status.value != "failed" and st1.c is None
    with pytest.raises(GranflowInputError, match="surface"):
        Model(g, make_closure("drucker_prager"), surface="vof")


@pytest.mark.parametrize("c_top", [0.2, 0.5, 0.75, 1.0])
def test_reconstructed_weights_put_p_zero_at_the_surface(c_top):
    # A column of full cells under one partial cell: the discrete hydrostatic pressure of the
    # reconstructed face weights (Grad p = f_g on the z-faces, p = 0 in thin and empty cells) is
    # rho_s psi |g| (z_s - z_c) at every cell centre below the surface z_s -- computed here by
    # integrating the face weights independently of surface_lithostatic.
    from granflow.physics.material import C_ROW, face_solid_fraction, surface_lithostatic

    nz, dz, psi, weight = 8, 0.1, 0.57, 2500.0 * 9.81 * 0.1
    c = np.zeros((1, nz))
    c[0, :5] = 1.0
    c[0, 5] = c_top
    phi = psi * c
    f = face_solid_fraction(c, phi)[0]            # interior faces 1 .. nz-1
    p = np.zeros(nz)
    rows = np.flatnonzero(c[0] >= C_ROW)
    for j in rows[::-1]:                          # from the top row cell down
        p[j] = (p[j + 1] if j + 1 in rows else 0.0) + weight * f[j]
    z_c = (np.arange(nz) + 0.5) * dz
    z_s = (5 + c_top) * dz
    exact = 2500.0 * 9.81 * psi * (z_s - z_c)
    assert np.allclose(p[rows], exact[rows], rtol=1e-12)
    lith = surface_lithostatic(c, phi, weight)[0]
    assert np.allclose(lith[rows], exact[rows], rtol=1e-12)
    # the column's grains are all weighed: faces + the wall faces' halves
    assert f.sum() + psi * 0.5 == pytest.approx(phi.sum(), rel=1e-12)


def test_inclined_layer_from_rest_becomes_steady_on_bagnold(tmp_path):
    # Issue 12 acceptance 2 (smoke, 25 deg, 20 cells over h): a mu(I) layer released from rest at
    # phi_max with the default numerics and the indicator surface dilates to phi_eq(I_theta) and
    # becomes steady on Bagnold's surface velocity (analytic, cases/inclined_layer.py).
    from granflow.cases import CASES
    from granflow.cases.inclined_layer import bagnold, surface_velocity
    from granflow.config import load_case

    case = tmp_path / "rest.toml"
    case.write_text("""
[case]
name = "inclined_layer"
[setup]
h0 = 0.01
start = "rest"
[material]
d = 5e-4
rho_s = 2500.0
phi_max = 0.6
delta_phi = 0.2
[closure]
name = "mu_i"
[gravity]
slope_deg = 25.0
[numerics]
surface = "indicator"
[grid]
periodic_x = true
nx = 4
nz = 26
Lx = 1.0
Lz = 0.013
[time]
stop_time = 12.0
dt_max = 0.05
""")
    cfg = load_case(case)
    sim = CASES.get("inclined_layer").setup(cfg)
    record = []
    while sim.state.t < 12.0 - 1e-9:
        sim.step()
        record.append((sim.state.t, surface_velocity(sim)))
    t, u = np.array(record).T
    ref = bagnold(cfg).surface_velocity
    assert abs(u[-1] / ref - 1.0) < 0.02, (u[-1], ref)
    late = u[t >= t[-1] - 2.0]
    assert np.ptp(late) / u[-1] < 1e-3, "not steady over the last 2 s"
    assert sim.state.phi.sum() == pytest.approx(0.6 * 20 * 4, rel=1e-12)


def test_material_never_looser_than_psi_min():
    # consistent_bounds: phi/phi_max <= c <= min(phi/psi_min, 1); the grains are never touched
    from granflow.physics.material import consistent_bounds

    c = np.array([[0.9, 0.9, 0.2, 1e-3]])
    phi = np.array([[0.54, 0.06, 0.15, 0.0]])
    new, moved = consistent_bounds(c, phi, 0.6, 1.0, psi_min=0.3)
    assert np.allclose(new, [[0.9, 0.2, 0.25, 0.0]])
    assert moved == pytest.approx(0.7 + 0.05 + 1e-3)
    assert np.all(packing(new, phi)[new > 0] >= 0.3 - 1e-15)


@pytest.mark.parametrize("periodic", [False, True])
def test_windowed_material_stage_is_the_whole_grid_one(periodic, monkeypatch):
    """advect_material on material_window (default) against the whole grid
    (WINDOW_FRACTION = 0: never cut): same c, phi and fluxes bit for bit, with a partial
    surface, a thin cell's dilation and a random velocity everywhere."""
    import granflow.physics.material as M

    rng = np.random.default_rng(3)
    g = Grid(nx=40, nz=30, Lx=0.4, Lz=0.3, periodic_x=periodic)
    c = np.zeros(g.cell_shape)
    c[12:22, 0:8] = 1.0
    c[12:22, 8] = 0.3
    c[22, 0:5] = 0.05
    phi = 0.56 * c
    vel = g.pack_velocity(0.05 * rng.normal(size=g.xface_shape), 0.05 * rng.normal(size=g.zface_shape))
    dilation = np.where((c > 0) & (c < 0.5), 0.3, 0.0)
    assert M.material_window(g, c, phi) is not None
    cut = M.advect_material(g, c, phi, vel, 0.02, 0.6, dilation, psi_min=0.3)
    monkeypatch.setattr(M, "WINDOW_FRACTION", 0.0)
    assert M.material_window(g, c, phi) is None
    whole = M.advect_material(g, c, phi, vel, 0.02, 0.6, dilation, psi_min=0.3)
    for name in ("c", "phi", "flux_x", "flux_z"):
        assert np.array_equal(getattr(cut, name), getattr(whole, name)), name
    assert np.abs(whole.flux_x).max() > 0


def test_shifted_is_the_clipped_take():
    """physics.material._shifted (slices and copies) against its definition, the neighbour
    k cells away with the wall cell repeated beyond a wall: np.take(q, clip(i + k, 0, n - 1))."""
    from granflow.physics.material import _shifted

    rng = np.random.default_rng(1)
    for shape in [(5, 7), (1, 3), (2, 1), (40, 30)]:
        q = rng.random(shape)
        for axis in (0, 1):
            n = q.shape[axis]
            for k in (-3, -2, -1, 0, 1, 2, 3):
                ref = np.take(q, np.clip(np.arange(n) + k, 0, n - 1), axis=axis)
                assert np.array_equal(_shifted(q, k, axis, False), ref), (shape, axis, k)
            assert np.array_equal(_shifted(q, 1, axis, True), np.roll(q, -1, axis=axis))


def test_solid_fluxes_only_are_those_of_the_whole_step():
    """material_solid_fluxes (what the consistent momentum transport uses each Picard sweep) gives
    advect_material's fluxes bit for bit, whatever the thin cells' dilatation."""
    from granflow.physics.material import advect_material, material_solid_fluxes

    rng = np.random.default_rng(5)
    g = Grid(nx=30, nz=20, Lx=0.3, Lz=0.2)
    c = np.zeros(g.cell_shape)
    c[5:15, 0:6] = 1.0
    c[5:15, 6] = 0.35
    phi = 0.57 * c
    vel = g.pack_velocity(0.05 * rng.normal(size=g.xface_shape), 0.05 * rng.normal(size=g.zface_shape))
    whole = advect_material(g, c, phi, vel, 0.02, 0.6, np.where(c == 0.35, 0.5, 0.0), psi_min=0.3)
    fx, fz = material_solid_fluxes(g, c, phi, vel, 0.02, 0.6)
    assert np.array_equal(fx, whole.flux_x) and np.array_equal(fz, whole.flux_z)
    assert np.abs(fz).max() > 0


def test_draining_cells_never_go_negative():
    """Random material fields (partial and full cells, packings 0.3-0.6) under random velocities at
    CFL 1/4: a cell that its outflow drains must not lose more grains than it holds, although the
    upwind MUSCL packing of a face can exceed the donor's (phi >= 0 to round-off; without the
    solid fluxes' lower-bound limiter the minimum was -1.4e-3 over these 300 draws)."""
    rng = np.random.default_rng(1)
    g = Grid(nx=6, nz=6, Lx=0.06, Lz=0.06)
    lowest = 0.0
    for _ in range(300):
        c = np.where(rng.random(g.cell_shape) < 0.7, rng.random(g.cell_shape), 0.0)
        c[rng.random(g.cell_shape) < 0.4] = 1.0
        phi = c * rng.uniform(0.3, 0.6, g.cell_shape)
        u, w = rng.normal(size=g.xface_shape), rng.normal(size=g.zface_shape)
        u[[0, -1]] = 0.0
        w[:, [0, -1]] = 0.0
        dt = 0.25 / max(np.abs(u).max() / g.dx, np.abs(w).max() / g.dz)
        out = advect_material(g, c, phi, g.pack_velocity(u, w), dt, 0.6)
        assert abs(out.phi.sum() - phi.sum()) <= 1e-13 * phi.sum()
        lowest = min(lowest, float(out.phi.min()))
    assert lowest >= -1e-15
