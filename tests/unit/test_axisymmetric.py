"""The axisymmetric (r, z) operators (issue 14 item 4, first step; granflow.axisymmetric) against
exact fields of cylindrical kinematics, worked out by hand in the comments:

* ``u = a r``: div = 2a exactly (the discrete ``(1/r) d(r u)/dr`` with r_c the mean of the face
  radii), and with ``w = -2 a z`` the field is solenoidal, to round-off;
* ``u = a r, w = a z``: an isotropic expansion, e_rr = e_tt = e_zz = a, so S = 0 and |S| = 0;
* simple shear ``u = gamma z``: |S| = gamma/2, as in the plane model;
* pipe flow ``w = R^2 - r^2``: ``r (-(1/r) d/dr(r eta dw/dr)) = 4 eta r``, which the viscous
  operator reproduces exactly on every w row away from the outer wall and the top and bottom;
* the weighted adjointness ``M_c div = -(M_f grad)^T`` and the dissipation identity
  ``dV u^T V u = D`` (V symmetric, >= 0).
"""
from __future__ import annotations

import numpy as np
import pytest

from granflow.axisymmetric import AxisymmetricOperators
from granflow.errors import GranflowInputError
from granflow.grid import Grid, VelocityBCs


def ops(nx=8, nz=6, R=2.0, H=1.5):
    return AxisymmetricOperators.build(Grid(nx=nx, nz=nz, Lx=R, Lz=H))


def pack(g, u_of, w_of):
    r_u, z_u = np.meshgrid(g.xf, g.zc, indexing="ij")
    r_w, z_w = np.meshgrid(g.xc, g.zf, indexing="ij")
    return g.pack_velocity(u_of(r_u, z_u), w_of(r_w, z_w))


def test_radial_stretch_has_divergence_2a_and_with_w_minus_2az_none():
    o = ops()
    g = o.grid
    a = 0.7
    # u = a r vanishes on the axis; at the outer wall (a wall: u = 0 there) the last cells differ
    vel = pack(g, lambda r, z: a * r, lambda r, z: 0.0 * r)
    div = (o.div @ vel).reshape(g.cell_shape)
    assert np.allclose(div[:-1], 2 * a, rtol=0, atol=1e-13)
    vel = pack(g, lambda r, z: a * r, lambda r, z: -2 * a * z)
    div = (o.div @ vel).reshape(g.cell_shape)
    assert np.allclose(div[:-1, 1:-1], 0.0, atol=1e-13)


def test_isotropic_expansion_is_deviator_free_and_simple_shear_gives_half_gamma():
    o = ops()
    g = o.grid
    a = 0.3
    vel = pack(g, lambda r, z: a * r, lambda r, z: a * z)
    for e in (o.e_rr, o.e_tt, o.e_zz):
        assert np.allclose((e @ vel).reshape(g.cell_shape)[:-1, 1:-1], a, atol=1e-13)
    S = o.strain_rate_norm(vel).reshape(g.cell_shape)
    assert np.allclose(S[1:-1, 1:-1], 0.0, atol=1e-13)
    gamma = 0.8
    vel = pack(g, lambda r, z: gamma * z, lambda r, z: 0.0 * r)
    S = o.strain_rate_norm(vel).reshape(g.cell_shape)
    # away from the walls and the axis, where u/r is small against gamma only far out: use the
    # 2-D part; the hoop strain u/r = gamma z / r adds (e_tt)^2/3 -- checked against its formula
    e_tt = (o.e_tt @ vel).reshape(g.cell_shape)
    # u/r (but in the cells on the axis and the outer wall, whose outer face velocity is 0)
    assert np.allclose(e_tt[1:-1], gamma * g.zc[None, :] / g.xc[1:-1, None], rtol=1e-12)
    # S_rr = -e_tt/3, S_tt = 2 e_tt/3, S_zz = -e_tt/3, S_rz = gamma/2: |S|^2 = e_tt^2/3 + gamma^2/4
    expected = np.sqrt(gamma ** 2 / 4 + e_tt ** 2 / 3)
    assert np.allclose(S[1:-1, 1:-1], expected[1:-1, 1:-1], rtol=1e-12)


def test_pipe_flow_viscous_force_is_exact_in_the_interior():
    o = ops(nx=10, nz=8)
    g = o.grid
    eta, R = 1.7, g.Lx
    vel = pack(g, lambda r, z: 0.0 * r, lambda r, z: R ** 2 - r ** 2)
    force = (o.viscous_operator(eta, eta) @ vel)[g.w_slice].reshape(g.nx, g.nz - 1)
    r_w = g.xc[:, None] * np.ones(g.nz - 1)
    # rows 1..nz-3 (away from the top and bottom walls, where dw/dz != 0), columns but the last
    # (the outer no-slip wall's ghost is first order)
    inner = (slice(0, g.nx - 1), slice(1, g.nz - 2))
    assert np.allclose(force[inner], 4 * eta * r_w[inner], rtol=1e-12)


def test_weighted_adjointness_and_dissipation_identity():
    o = ops(nx=7, nz=5)
    g = o.grid
    rng = np.random.default_rng(3)
    vel = rng.standard_normal(g.n_unknowns)
    p = rng.standard_normal(g.n_cells)
    assert np.isclose(o.r_cells @ (p * (o.div @ vel)), -(o.r_unknowns * vel) @ (o.grad @ p), rtol=1e-12)
    lhs = o.weighted_div()
    rhs = -(o.grad.T @ np.diag(o.r_unknowns))
    assert np.abs(lhs.toarray() - rhs).max() < 1e-12
    eta_c, eta_n = rng.random(g.n_cells), rng.random(g.n_nodes)
    V = o.viscous_operator(eta_c, eta_n)
    assert abs(V - V.T).max() < 1e-12
    assert np.linalg.eigvalsh(V.toarray()).min() > -1e-12
    assert np.isclose(g.cell_volume * vel @ V @ vel, o.dissipation(vel, eta_c, eta_n), rtol=1e-12)
    assert np.isclose(o.volume(), g.Lx ** 2 * g.Lz / 2, rtol=1e-12)


def test_the_axis_is_r_0_and_free_slip():
    with pytest.raises(GranflowInputError, match="x0 must be 0"):
        AxisymmetricOperators.build(Grid(nx=4, nz=4, Lx=1.0, Lz=1.0, x0=0.5))
    with pytest.raises(GranflowInputError, match="cannot be periodic"):
        AxisymmetricOperators.build(Grid(nx=4, nz=4, Lx=1.0, Lz=1.0, periodic_x=True))
    with pytest.raises(GranflowInputError, match="axis of symmetry, free-slip"):
        AxisymmetricOperators.build(Grid(nx=4, nz=4, Lx=1.0, Lz=1.0), VelocityBCs(west="no_slip"))


def _stokes_error(n: int, fields) -> float:
    """Max relative velocity error of the discrete axisymmetric Stokes problem on n x n cells of
    the unit (r, z) box: ``[[V, M_f grad], [M_c div, 0]] (u, p) = (M_f f, 0)``, the pressure pinned
    in one cell (the system the solver will assemble, module docstring of granflow.axisymmetric)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    U, W, FR, FZ, eta = fields
    g = Grid(nx=n, nz=n, Lx=1.0, Lz=1.0)
    o = AxisymmetricOperators.build(g, VelocityBCs(west="free_slip", east="no_slip", bottom="no_slip",
                                                   top="no_slip"))
    ru, zu = np.meshgrid(g.xf, g.zc, indexing="ij")
    rw, zw = np.meshgrid(g.xc, g.zf, indexing="ij")
    safe = np.maximum(ru, 1e-12)                      # u faces on the axis are not unknowns
    exact = g.pack_velocity(U(safe, zu), W(rw, zw))
    force = g.pack_velocity(FR(safe, zu), FZ(rw, zw))
    B = o.weighted_div()
    K = sp.bmat([[o.viscous_operator(eta, eta), -B.T], [-B, None]], format="lil")
    K[g.n_unknowns, :] = 0.0
    K[g.n_unknowns, g.n_unknowns] = 1.0
    sol = spla.spsolve(K.tocsc(), np.concatenate([o.r_unknowns * force, np.zeros(g.n_cells)]))
    return float(np.abs(sol[:g.n_unknowns] - exact).max() / np.abs(exact).max())


def test_stokes_manufactured_solution_converges_at_second_order():
    """Independent reference: a solenoidal field from the Stokes stream function
    psi = r^2 (1 - r^2)^2 z^2 (1 - z)^2 (u = -psi_z / r, w = psi_r / r: u = 0 on the axis,
    dw/dr = 0 there, no-slip on the other sides) with p = r^2 z; SymPy gives the body force
    f = -eta (vector Laplacian of (u, w)) + grad p (constant eta, div u = 0, so div(2 eta S) is the
    vector Laplacian, whose radial part carries -u/r^2). Measured: 1.78e-2, 4.49e-3, 1.12e-3 at
    16, 32, 64 cells (order 1.99, 2.00); asserted on 16 and 32 cells: order >= 1.8."""
    sy = pytest.importorskip("sympy")
    r, z = sy.symbols("r z", positive=True)
    eta = sy.Rational(3, 2)
    psi = r**2 * (1 - r**2)**2 * z**2 * (1 - z)**2
    u, w, p = -sy.diff(psi, z) / r, sy.diff(psi, r) / r, r**2 * z
    assert sy.simplify(sy.diff(r * u, r) / r + sy.diff(w, z)) == 0

    def lap(f):
        return sy.diff(r * sy.diff(f, r), r) / r + sy.diff(f, z, 2)

    fr = -eta * (lap(u) - u / r**2) + sy.diff(p, r)
    fz = -eta * lap(w) + sy.diff(p, z)
    fields = [sy.lambdify((r, z), sy.simplify(e), "numpy") for e in (u, w, fr, fz)] + [float(eta)]
    e16, e32 = _stokes_error(16, fields), _stokes_error(32, fields)
    assert e32 < 5e-3
    assert np.log2(e16 / e32) >= 1.8
