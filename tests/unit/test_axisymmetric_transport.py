"""The axisymmetric grid's metric and its transport (issue 14 item 4): volumes, the r-weighted
flux divergence, the material transport and the momentum transport's dual cells, against exact
solutions of the continuous (r, z) equations and against the discrete conservation laws."""
import numpy as np
import pytest

from granflow.errors import GranflowInputError
from granflow.grid import Geometry, Grid
from granflow.operators import Operators
from granflow.physics import momentum_transport as mt
from granflow.physics.material import advect_material
from granflow.physics.transport import cfl_number, flux_divergence, plane_flux_divergence

PHI = 0.55
PHI_MAX = 0.6


def axi_grid(nx=24, nz=12, Lx=1.0, Lz=0.5):
    return Grid(nx=nx, nz=nz, Lx=Lx, Lz=Lz, geometry="axisymmetric")


def face_field(g, fu, fw):
    """u = fu(r, z) on the x-faces, w = fw(r, z) on the z-faces, zero on the walls and the axis."""
    xu, zu = g.xface_coords()
    xw, zw = g.zface_coords()
    u, w = fu(xu, zu), fw(xw, zw)
    u[0] = u[-1] = 0.0
    w[:, 0] = w[:, -1] = 0.0
    return u, w


def test_geometry_is_validated_by_name():
    with pytest.raises(GranflowInputError, match="x0 must be 0"):
        Grid(nx=4, nz=4, Lx=1.0, Lz=1.0, x0=0.1, geometry="axisymmetric")
    with pytest.raises(GranflowInputError, match="periodic"):
        Grid(nx=4, nz=4, Lx=1.0, Lz=1.0, periodic_x=True, geometry="axisymmetric")
    with pytest.raises(GranflowInputError, match="geometry must be one of"):
        Grid(nx=4, nz=4, Lx=1.0, Lz=1.0, geometry="spherical")
    plane = Grid(nx=4, nz=4, Lx=1.0, Lz=1.0)
    assert plane.geometry is Geometry.PLANE and plane.radial is None and plane.unknown_metric is None


def test_cell_volumes_add_up_to_the_cylinder():
    """sum 2 pi r_c dr dz is exactly pi R^2 H (the midpoint rule is exact for r)."""
    g = axi_grid(nx=7, nz=3, Lx=0.3, Lz=0.2)
    assert np.isclose(g.cell_volumes.sum(), np.pi * 0.3 ** 2 * 0.2, rtol=1e-14)
    assert g.unknown_metric.shape == (g.n_unknowns,)


def test_flux_divergence_of_radial_fields_is_exact():
    """(1/r) d(r F)/dr of F = a r is 2a; of F = b/r (a line source) 0 away from the axis."""
    g = axi_grid()
    fx, fz = face_field(g, lambda r, z: 0.7 * r, lambda r, z: 0.0 * r)
    div = flux_divergence(g, fx, fz)
    assert np.allclose(div[1:-1], 1.4, rtol=1e-13)
    fx, fz = face_field(g, lambda r, z: 0.3 / np.maximum(r, 1e-300), lambda r, z: 0.0 * r)
    assert np.allclose(flux_divergence(g, fx, fz)[1:-1], 0.0, atol=1e-12)
    # the plane formula would not see the rings (the mutant this test guards against)
    assert not np.allclose(plane_flux_divergence(g, fx, fz)[1:-1], 0.0, atol=1e-3)


def test_uniform_expansion_dilutes_as_exp_minus_2at():
    """u = a r (div u = 2a, w = 0): a region filled with the material keeps c = 1 and its packing
    falls by the factor (1 - 2 a dt) per step exactly (D psi/Dt = -psi div u, eq. syst1b); the
    plane factor would be (1 - a dt)."""
    g = axi_grid(nx=40, nz=8)
    a, dt, steps = 0.2, 0.01, 20
    u, w = face_field(g, lambda r, z: a * r, lambda r, z: 0.0 * r)
    vel = g.pack_velocity(u, w)
    X, _ = g.cell_coords()
    c = (X < 0.5).astype(float)
    phi = PHI * c
    for _ in range(steps):
        out = advect_material(g, c, phi, vel, dt, PHI_MAX)
        c, phi = out.c, out.phi
    inner = slice(0, 10)  # well behind the front, which has moved to r ~ 0.5 exp(0.04)
    assert np.allclose(c[inner], 1.0, atol=1e-12)
    assert np.allclose(phi[inner], PHI * (1.0 - 2.0 * a * dt) ** steps, rtol=1e-12)


def test_material_transport_conserves_the_cylinder_mass():
    """An isochoric swirl-free flow (u = a r, w = -2 a z): the grains' volume sum phi 2 pi r dr dz
    is conserved to round-off, full cells keep their packing, bounds hold."""
    g = axi_grid(nx=40, nz=20)
    a, dt = 0.5, 0.01
    u, w = face_field(g, lambda r, z: a * r, lambda r, z: -2.0 * a * z)
    vel = g.pack_velocity(u, w)
    X, Z = g.cell_coords()
    c = ((X < 0.3) & (Z < 0.3)).astype(float)
    phi = PHI * c
    m0 = float(np.sum(phi * g.cell_volumes))
    assert cfl_number(g, vel, dt) <= 0.5
    for _ in range(30):
        out = advect_material(g, c, phi, vel, dt, PHI_MAX)
        c, phi = out.c, out.phi
    assert abs(float(np.sum(phi * g.cell_volumes)) / m0 - 1.0) < 1e-13
    assert phi.max() <= PHI_MAX * (1 + 1e-12) and phi.min() > -1e-15
    full = c > 0.999
    assert full.sum() > 20 and np.allclose(phi[full] / c[full], PHI, rtol=1e-4)


def test_cfl_number_counts_the_rings():
    """The first ring empties through an outer face twice its mean radius: its CFL number is
    twice the plane one."""
    g = axi_grid(nx=8, nz=4)
    u, w = face_field(g, lambda r, z: 1.0 + 0.0 * r, lambda r, z: 0.0 * r)
    vel = g.pack_velocity(u, w)
    plane = Grid(nx=8, nz=4, Lx=1.0, Lz=0.5)
    cells = np.zeros(g.cell_shape, dtype=bool)
    cells[0] = True
    assert np.isclose(cfl_number(g, vel, 0.01, cells), 2.0 * cfl_number(plane, vel, 0.01, cells))


def test_dual_cells_follow_the_transport_exactly():
    """The momentum transport's dual-cell mass (the volume-weighted face mean of phi) changes by
    exactly its dual divergence: dual(phi^{n+1}) = dual(phi^n) - dt div_dual F (to round-off)."""
    g = axi_grid(nx=20, nz=10)
    ops = Operators.build(g)
    rng = np.random.default_rng(3)
    u, w = face_field(g, lambda r, z: 0.3 * np.sin(3 * r) * z, lambda r, z: -0.2 * np.cos(2 * r) * z)
    vel = g.pack_velocity(u, w)
    X, Z = g.cell_coords()
    c = ((X < 0.5) & (Z < 0.3)).astype(float)
    phi = c * (0.5 + 0.05 * rng.random(g.cell_shape))
    dt = 0.01
    out = advect_material(g, c, phi, vel, dt, PHI_MAX)
    wc = np.repeat(g.radial.cells[:, 0], g.nz)

    def dual(p):
        return (ops.cell_to_face @ (wc * p.ravel())) / g.unknown_metric

    _, div_w = mt.axisymmetric_transport(ops, out.flux_x, out.flux_z, vel)
    assert np.allclose(dual(out.phi), dual(phi) - dt * div_w / g.unknown_metric, atol=1e-14)
    # the momentum flux divergence of a uniform radial velocity field is that velocity times the
    # dual mass rate wherever the upwind values are that velocity (here: w = 0 and u = U inside)
    U = 0.4
    uu, ww = face_field(g, lambda r, z: U + 0.0 * r, lambda r, z: 0.0 * r)
    A_w, div_w = mt.axisymmetric_transport(ops, out.flux_x, out.flux_z, g.pack_velocity(uu, ww),
                                           second_order=False)
    inner = np.zeros(g.n_unknowns, dtype=bool)
    iu = np.zeros((g.nx - 1, g.nz), dtype=bool)
    iu[1:-1] = True
    inner[g.u_slice] = iu.ravel()
    assert np.allclose(A_w[inner], U * div_w[inner], atol=1e-12)


def test_clipped_mass_is_a_ring_volume():
    """phi above phi_max by 1e-3 in one cell at r = 0.75 m: the clip removes 1e-3 of that ring's
    volume, 2 pi r_c dr dz (not its section dr dz)."""
    from granflow.physics.transport import clip_to_bounds

    g = axi_grid(nx=4, nz=2, Lx=1.0, Lz=0.5)
    phi = np.full(g.cell_shape, 0.3)
    phi[3, 0] = PHI_MAX + 1e-3
    _, report = clip_to_bounds(phi, PHI_MAX, g.cell_volumes)
    assert report.clipped_mass == pytest.approx(1e-3 * 2 * np.pi * 0.875 * 0.25 * 0.25, rel=1e-9)
    _, plane = clip_to_bounds(phi, PHI_MAX, g.cell_volume)
    assert plane.clipped_mass == pytest.approx(1e-3 * 0.25 * 0.25, rel=1e-9)


def test_lower_bound_limiter_kernel_agrees_on_a_round_off_negative_cell():
    """A cell at phi = -1e-20 with no outflow needs no limiting: the NumPy reference and the
    compiled kernel both leave the fluxes alone (the kernel divided 0/0 before)."""
    from granflow.physics.interface_capturing import limit_to_lower_bound

    q = np.array([[0.5, -1e-20], [0.5, 0.5]])
    fx = np.zeros((3, 2))
    fz = np.zeros((2, 3))
    fx[1, 0] = 0.1  # cell (0, 0) -> (1, 0); cell (0, 1) has no outflow
    ref = limit_to_lower_bound(q, fx, fz, 0.1, 1.0, 1.0, False)
    kernel = pytest.importorskip("granflow.physics._material_numba")
    gx, gz = fx.copy(), fz.copy()
    kernel.limit_to_lower_bound(q, gx, gz, 0.1, 1.0, 1.0, False)
    assert np.array_equal(ref[0], gx) and np.array_equal(ref[1], gz) and np.all(np.isfinite(gx))
