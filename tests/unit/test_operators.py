"""Tests of granflow.operators: discrete identities, exactness and second-order accuracy.

Independent references used here: (i) a direct array-slicing implementation with explicit ghost
values (``ref_*`` below), (ii) closed forms for affine / quadratic / Couette fields, (iii) SymPy
derivatives of the continuous definitions (S = sym(grad u) - (div u / 2) Id, |S|^2 = S:S/2,
f = -div(2 eta S)). Convergence orders are measured over 3 resolutions and must lie in
[1.8, 2.2]. Round-off tolerances are 1e-12 relative unless stated.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest
import scipy.sparse as sp
import sympy as sy

from granflow.errors import GranflowInputError
from granflow.grid import Grid, Side, VelocityBC, VelocityBCs
from granflow.operators import Operators

RTOL = 1e-12
ORDER_MIN, ORDER_MAX = 1.8, 2.2
RESOLUTIONS = (16, 32, 64)  # nz; nx = 2 nz on a 2 x 1 box (dx = dz)

NO, FREE = VelocityBC.NO_SLIP, VelocityBC.FREE_SLIP
BC_SETS = {
    "default": VelocityBCs(),
    "no_slip": VelocityBCs.uniform(NO),
    "free_slip": VelocityBCs.uniform(FREE),
    "mixed": VelocityBCs(west=NO, east=FREE, bottom=FREE, top=NO),
}


# --- independent reference implementation ---------------------------------------------------
def random_faces(grid, rng):
    """Random full face arrays with zero normal velocity on the walls."""
    u = rng.standard_normal(grid.xface_shape)
    w = rng.standard_normal(grid.zface_shape)
    u[[0, -1], :] = 0.0
    w[:, [0, -1]] = 0.0
    return u, w


def ghost_sign(kind):
    return -1.0 if kind is VelocityBC.NO_SLIP else 1.0


def ref_div(g, u, w):
    return ((u[1:] - u[:-1]) / g.dx + (w[:, 1:] - w[:, :-1]) / g.dz).ravel()


def ref_ec(g, u, w):
    return ((u[1:] - u[:-1]) / g.dx - (w[:, 1:] - w[:, :-1]) / g.dz).ravel()


def ref_en(g, bcs, u, w):
    """du/dz + dw/dx at nodes from ghost-padded arrays."""
    sb, st, sw, se = (ghost_sign(k) for k in (bcs.bottom, bcs.top, bcs.west, bcs.east))
    up = np.concatenate([sb * u[:, :1], u, st * u[:, -1:]], axis=1)
    wp = np.concatenate([sw * w[:1], w, se * w[-1:]], axis=0)
    return ((up[:, 1:] - up[:, :-1]) / g.dz + (wp[1:] - wp[:-1]) / g.dx).ravel()


def ref_node_weights(g):
    wts = np.ones(g.node_shape)
    for i in range(g.nx + 1):
        for j in range(g.nz + 1):
            on_x_wall = i in (0, g.nx)
            on_z_wall = j in (0, g.nz)
            # fraction of the node control volume [x_i -+ dx/2] x [z_j -+ dz/2] inside the box
            wts[i, j] = (0.5 if on_x_wall else 1.0) * (0.5 if on_z_wall else 1.0)
    return wts.ravel()


def interior_cells(g):
    """Mask of cells whose faces and corner nodes are all interior (one layer off each wall)."""
    m = np.zeros(g.cell_shape, dtype=bool)
    m[1:-1, 1:-1] = True
    return m.ravel()


def interior_nodes(g):
    m = np.zeros(g.node_shape, dtype=bool)
    m[1:-1, 1:-1] = True
    return m.ravel()


def observed_orders(errors):
    e = np.asarray(errors)
    return np.log2(e[:-1] / e[1:])


# --- symbolic smooth fields ---------------------------------------------------------------------
X, Z = sy.symbols("x z", real=True)
LXS, LZS = 2, 1  # box of the convergence tests
_SX, _SZ = sy.pi * X / LXS, sy.pi * Z / LZS
# Each field has zero normal velocity on the walls and the parity implied by the wall condition
# (odd tangential velocity at a no-slip wall, even at a free-slip wall), so the ghost stencils
# are second order up to the wall.
FIELDS = {
    "default": (sy.sin(_SX) * sy.sin(_SZ / 2), sy.cos(2 * _SX) * sy.sin(_SZ)),
    "no_slip": (sy.sin(_SX) * sy.sin(2 * _SZ), sy.sin(2 * _SX) * sy.sin(_SZ)),
    "free_slip": (sy.sin(_SX) * sy.cos(2 * _SZ), sy.cos(3 * _SX) * sy.sin(_SZ)),
    "mixed": (sy.sin(_SX) * sy.cos(_SZ / 2), sy.sin(_SX / 2) * sy.sin(_SZ)),
}
ETA_VAR = 1 + X * Z / 4 + sy.cos(_SX) / 3


@functools.cache
def continuum(key, eta_expr=None):
    """Lambdified u, w, div u, |S|^2 and -div(2 eta S) (x, z components) of FIELDS[key]."""
    u, w = FIELDS[key]
    eta = sy.Integer(1) if eta_expr is None else eta_expr
    grad = sy.Matrix([[sy.diff(u, X), sy.diff(u, Z)], [sy.diff(w, X), sy.diff(w, Z)]])
    div = grad.trace()
    S = (grad + grad.T) / 2 - div / 2 * sy.eye(2)
    s2 = (S.multiply_elementwise(S)).applyfunc(sy.expand)
    s2 = sum(s2) / 2
    tau = 2 * eta * S
    fx = -(sy.diff(tau[0, 0], X) + sy.diff(tau[0, 1], Z))
    fz = -(sy.diff(tau[1, 0], X) + sy.diff(tau[1, 1], Z))
    f = [sy.lambdify((X, Z), e, "numpy") for e in (u, w, div, s2, fx, fz, eta)]
    return tuple(lambda a, b, fn=fn: np.broadcast_to(fn(a, b), a.shape).astype(float) for fn in f)


def convergence_grid(n):
    return Grid(nx=2 * n, nz=n, Lx=float(LXS), Lz=float(LZS))


def sample_velocity(g, fu, fw):
    return g.pack_velocity(fu(*g.xface_coords()), fw(*g.zface_coords()))


# --- identities ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def small():
    return Grid(nx=6, nz=5, Lx=1.5, Lz=1.1, x0=0.3, z0=-0.2)


def test_shapes(small):
    ops = Operators.build(small)
    g = small
    assert ops.div.shape == ops.ec.shape == (g.n_cells, g.n_unknowns)
    assert ops.grad.shape == (g.n_unknowns, g.n_cells)
    assert ops.en.shape == (g.n_nodes, g.n_unknowns)
    assert ops.cell_to_face.shape == (g.n_unknowns, g.n_cells)
    assert ops.cell_to_node.shape == (g.n_nodes, g.n_cells)
    assert ops.node_to_cell.shape == (g.n_cells, g.n_nodes)
    assert all(isinstance(m, sp.csr_matrix) for m in (ops.div, ops.grad, ops.ec, ops.en))


def test_grad_is_exactly_minus_div_transpose(small):
    ops = Operators.build(small)
    assert abs(ops.grad + ops.div.T).max() == 0.0
    rng = np.random.default_rng(1)
    p = rng.standard_normal(small.n_cells)
    u = rng.standard_normal(small.n_unknowns)
    lhs = p @ (ops.div @ u) * small.cell_volume
    rhs = -u @ (ops.grad @ p) * small.cell_volume
    scale = np.abs(p).sum() * np.abs(ops.div @ u).max() * small.cell_volume
    assert abs(lhs - rhs) <= RTOL * scale


@pytest.mark.parametrize("key", BC_SETS)
def test_operators_match_ghost_cell_reference(small, key):
    bcs = BC_SETS[key]
    ops = Operators.build(small, bcs)
    u, w = random_faces(small, np.random.default_rng(2))
    vel = small.pack_velocity(u, w)
    scale = 1 / min(small.dx, small.dz) * np.abs(vel).max()
    np.testing.assert_allclose(ops.div @ vel, ref_div(small, u, w), rtol=0, atol=RTOL * scale)
    np.testing.assert_allclose(ops.ec @ vel, ref_ec(small, u, w), rtol=0, atol=RTOL * scale)
    np.testing.assert_allclose(ops.en @ vel, ref_en(small, bcs, u, w), rtol=0, atol=RTOL * scale)
    np.testing.assert_array_equal(ops.node_weights, ref_node_weights(small))


def test_affine_fields_exact_in_interior(small):
    """div = a1 + b2, ec = a1 - b2, en = a2 + b1 for u = a0 + a1 x + a2 z, w = b0 + b1 x + b2 z."""
    a0, a1, a2, b0, b1, b2 = 0.3, -1.7, 2.2, 0.9, 0.6, 1.3
    ops = Operators.build(small)
    Xu, Zu = small.xface_coords()
    Xw, Zw = small.zface_coords()
    vel = small.pack_velocity(a0 + a1 * Xu + a2 * Zu, b0 + b1 * Xw + b2 * Zw)
    ic, inn = interior_cells(small), interior_nodes(small)
    np.testing.assert_allclose((ops.div @ vel)[ic], a1 + b2, rtol=RTOL)
    np.testing.assert_allclose((ops.ec @ vel)[ic], a1 - b2, rtol=RTOL)
    np.testing.assert_allclose((ops.en @ vel)[inn], a2 + b1, rtol=RTOL)


def test_div_and_ec_exact_on_quadratic_wall_compatible_fields(small):
    """Centred differences are exact on u = x'(Lx - x') c(z), w = z'(Lz - z') d(x), all cells."""
    g, ops = small, Operators.build(small)
    Xu, Zu = g.xface_coords()
    Xw, Zw = g.zface_coords()
    xu, xw, zw = Xu - g.x0, Xw - g.x0, Zw - g.z0
    vel = g.pack_velocity(xu * (g.Lx - xu) * np.cos(Zu), zw * (g.Lz - zw) * (1 + xw))
    Xc, Zc = g.cell_coords()
    xc, zc = Xc - g.x0, Zc - g.z0
    dudx = (g.Lx - 2 * xc) * np.cos(Zc)
    dwdz = (g.Lz - 2 * zc) * (1 + xc)
    np.testing.assert_allclose(ops.div @ vel, (dudx + dwdz).ravel(), rtol=0, atol=RTOL * 10)
    np.testing.assert_allclose(ops.ec @ vel, (dudx - dwdz).ravel(), rtol=0, atol=RTOL * 10)


@pytest.mark.parametrize("kind", [NO, FREE])
def test_wall_shear_rate(small, kind):
    """Couette u = gamma (z - z0) or w = gamma (x - x0): wall-node shear rate gamma (no-slip), 0
    (free-slip)."""
    gamma, g = 0.7, small
    ops = Operators.build(g, VelocityBCs(bottom=kind, west=kind))
    _, Zu = g.xface_coords()
    Xw, _ = g.zface_coords()
    shear_u = g.pack_velocity(gamma * (Zu - g.z0), np.zeros(g.zface_shape))
    shear_w = g.pack_velocity(np.zeros(g.xface_shape), gamma * (Xw - g.x0))
    en_u = (ops.en @ shear_u).reshape(g.node_shape)
    en_w = (ops.en @ shear_w).reshape(g.node_shape)
    expected = gamma if kind is NO else 0.0
    np.testing.assert_allclose(en_u[1:-1, 0], expected, rtol=RTOL, atol=RTOL)
    np.testing.assert_allclose(en_w[0, 1:-1], expected, rtol=RTOL, atol=RTOL)
    np.testing.assert_allclose(en_u[1:-1, 1:-1], gamma, rtol=RTOL)  # interior nodes
    assert en_u[0, 0] == en_u[-1, 0] == en_w[0, 0] == en_w[0, -1] == 0.0  # corners


# --- strain-rate norm ----------------------------------------------------------------------------
def test_strain_rate_norm_pure_shear_and_pure_strain(small):
    gamma, a, g = 1.9, -0.8, small
    ops = Operators.build(g)
    Xu, Zu = g.xface_coords()
    Xw, Zw = g.zface_coords()
    ic = interior_cells(g)
    shear = g.pack_velocity(gamma * Zu, np.zeros(g.zface_shape))
    np.testing.assert_allclose(ops.strain_rate_norm(shear)[ic], abs(gamma) / 2, rtol=RTOL)
    strain = g.pack_velocity(a * Xu, -a * Zw)
    np.testing.assert_allclose(ops.strain_rate_norm(strain)[ic], abs(a), rtol=RTOL)
    rotation = g.pack_velocity(-Zu, Xw)  # rigid rotation: S = 0
    np.testing.assert_allclose(ops.strain_rate_norm(rotation)[ic], 0.0, atol=RTOL)


@pytest.mark.parametrize("key", BC_SETS)
def test_div_and_strain_rate_second_order(key):
    fu, fw, fdiv, fs2, *_ = continuum(key)
    err_div, err_s2 = [], []
    for n in RESOLUTIONS:
        g = convergence_grid(n)
        ops = Operators.build(g, BC_SETS[key])
        vel = sample_velocity(g, fu, fw)
        Xc, Zc = g.cell_coords()
        err_div.append(np.abs(ops.div @ vel - fdiv(Xc, Zc).ravel()).max())
        err_s2.append(np.abs(ops.strain_rate_norm_squared(vel) - fs2(Xc, Zc).ravel()).max())
    for errs in (err_div, err_s2):  # max norm over all cells, walls included
        orders = observed_orders(errs)
        assert np.all((orders > ORDER_MIN) & (orders < ORDER_MAX)), (errs, orders)


def test_strain_rate_norm_second_order_interior():
    """|S| (not squared) where it is bounded away from 0 (the square root is then smooth):
    u = x + eps sin sin, w = -z + eps cos cos, cells one layer off the walls."""
    eps = 0.2
    u = X + eps * sy.sin(sy.pi * X) * sy.sin(sy.pi * Z)
    w = -Z + eps * sy.cos(sy.pi * X) * sy.cos(sy.pi * Z)
    grad = sy.Matrix([[sy.diff(u, X), sy.diff(u, Z)], [sy.diff(w, X), sy.diff(w, Z)]])
    S = (grad + grad.T) / 2 - grad.trace() / 2 * sy.eye(2)
    norm = sy.lambdify((X, Z), sy.sqrt(sum(S.multiply_elementwise(S)) / 2), "numpy")
    fu, fw = (sy.lambdify((X, Z), e, "numpy") for e in (u, w))
    errs = []
    for n in RESOLUTIONS:
        g = Grid(nx=n, nz=n, Lx=1.0, Lz=1.0)
        ops = Operators.build(g)
        Xc, Zc = g.cell_coords()
        err = ops.strain_rate_norm(sample_velocity(g, fu, fw)) - norm(Xc, Zc).ravel()
        errs.append(np.abs(err[interior_cells(g)]).max())
    orders = observed_orders(errs)
    assert np.all((orders > ORDER_MIN) & (orders < ORDER_MAX)), (errs, orders)


# --- viscous operator -----------------------------------------------------------------------------
@pytest.mark.parametrize("key", BC_SETS)
def test_viscous_operator_symmetric_psd_and_energy(small, key):
    bcs, g = BC_SETS[key], small
    ops = Operators.build(g, bcs)
    rng = np.random.default_rng(3)
    eta_c = rng.uniform(0.1, 2.0, g.cell_shape)
    eta_n = rng.uniform(0.1, 2.0, g.node_shape)
    V = ops.viscous_operator(eta_c, eta_n)
    dense = V.toarray()
    norm = np.abs(dense).max()
    assert np.abs(dense - dense.T).max() <= 1e-14 * norm
    assert np.linalg.eigvalsh(dense).min() >= -1e-12 * np.linalg.norm(dense, 2)
    u, w = random_faces(g, rng)
    vel = g.pack_velocity(u, w)
    energy = (eta_c.ravel() @ ref_ec(g, u, w) ** 2
              + (ref_node_weights(g) * eta_n.ravel()) @ ref_en(g, bcs, u, w) ** 2)
    assert vel @ (V @ vel) == pytest.approx(energy, rel=RTOL)
    assert ops.dissipation(vel, eta_c, eta_n) == pytest.approx(energy * g.dx * g.dz, rel=RTOL)


@pytest.mark.parametrize("key", BC_SETS)
@pytest.mark.parametrize("variable_eta", [False, True], ids=["eta_const", "eta_var"])
def test_viscous_operator_second_order(key, variable_eta):
    """V u -> -div(2 eta S) (SymPy) at every interior face, walls included, max norm."""
    eta_expr = ETA_VAR if variable_eta else None
    fu, fw, _, _, fx, fz, feta = continuum(key, eta_expr)
    errs = []
    for n in RESOLUTIONS:
        g = convergence_grid(n)
        ops = Operators.build(g, BC_SETS[key])
        V = ops.viscous_operator(feta(*g.cell_coords()), feta(*g.node_coords()))
        exact = g.pack_velocity(fx(*g.xface_coords()), fz(*g.zface_coords()))
        errs.append(np.abs(V @ sample_velocity(g, fu, fw) - exact).max())
    orders = observed_orders(errs)
    assert np.all((orders > ORDER_MIN) & (orders < ORDER_MAX)), (errs, orders)


def test_viscous_operator_couette_wall_row(small):
    """u = gamma (z - z0), eta const: the force vanishes up to the no-slip base (ghost stencil);
    with a free-slip base the first row carries the missing wall stress, -eta gamma / dz."""
    gamma, eta, g = 1.3, 0.45, small
    _, Zu = g.xface_coords()
    vel = g.pack_velocity(gamma * (Zu - g.z0), np.zeros(g.zface_shape))
    scale = eta * gamma / g.dz
    for kind, first_row in ((NO, 0.0), (FREE, -scale)):
        ops = Operators.build(g, VelocityBCs(bottom=kind))
        fu = (ops.viscous_operator(eta, eta) @ vel)[g.u_slice].reshape(g.nx - 1, g.nz)
        rows = fu[1:-1, :-1]  # away from the side and top walls, which the field violates
        np.testing.assert_allclose(rows[:, 1:], 0.0, atol=RTOL * scale)
        np.testing.assert_allclose(rows[:, 0], first_row, atol=RTOL * scale)


def test_shear_part_null_space_uniform_u(small):
    """Uniform interior u, w = 0, eta_c = 0: En^T W En u = 0 with free-slip top and bottom;
    a no-slip base adds the wall friction eta (u / (dz/2)) / dz to the first row."""
    U, eta, g = 0.8, 1.7, small
    vel = g.pack_velocity(np.full(g.xface_shape, U), np.zeros(g.zface_shape))
    ops = Operators.build(g, VelocityBCs(bottom=FREE, top=FREE))
    scale = eta * U / g.dz**2
    np.testing.assert_allclose(ops.viscous_operator(0.0, eta) @ vel, 0.0, atol=RTOL * scale)
    ops = Operators.build(g, VelocityBCs(bottom=NO, top=FREE))
    f = ops.viscous_operator(0.0, eta) @ vel
    fu = f[g.u_slice].reshape(g.nx - 1, g.nz)
    np.testing.assert_allclose(fu[:, 0], 2 * eta * U / g.dz**2, rtol=RTOL)
    np.testing.assert_allclose(fu[:, 1:], 0.0, atol=RTOL * eta * U / g.dz**2)
    np.testing.assert_allclose(f[g.w_slice], 0.0, atol=RTOL * eta * U / g.dz**2)


# --- averaging and gradient ---------------------------------------------------------------------
def test_averaging_constants_and_linear_fields(small):
    g, ops = small, Operators.build(small)
    c = 3.7
    for m, n_in in ((ops.cell_to_xface, g.n_cells), (ops.cell_to_zface, g.n_cells),
                    (ops.cell_to_face, g.n_cells), (ops.cell_to_node, g.n_cells),
                    (ops.node_to_cell, g.n_nodes)):
        np.testing.assert_allclose(m @ np.full(n_in, c), c, rtol=RTOL)

    def lin(Xa, Za):
        return 0.4 - 1.1 * Xa + 2.3 * Za

    cells = lin(*g.cell_coords()).ravel()
    xf = lin(*g.xface_coords())[1:-1].ravel()
    zf = lin(*g.zface_coords())[:, 1:-1].ravel()
    np.testing.assert_allclose(ops.cell_to_xface @ cells, xf, rtol=RTOL)
    np.testing.assert_allclose(ops.cell_to_zface @ cells, zf, rtol=RTOL)
    np.testing.assert_allclose(ops.cell_to_face @ cells, np.concatenate([xf, zf]), rtol=RTOL)
    nodes = lin(*g.node_coords()).ravel()
    inn = interior_nodes(g)
    np.testing.assert_allclose((ops.cell_to_node @ cells)[inn], nodes[inn], rtol=RTOL)
    np.testing.assert_allclose(ops.node_to_cell @ nodes, cells, rtol=RTOL)
    # a corner node takes its single cell, a wall node the mean of its two cells
    cn = (ops.cell_to_node @ cells).reshape(g.node_shape)
    cc = cells.reshape(g.cell_shape)
    assert cn[0, 0] == cc[0, 0]
    assert cn[2, 0] == pytest.approx(0.5 * (cc[1, 0] + cc[2, 0]), rel=RTOL)


def test_face_gradient_linear_and_neumann(small):
    g, ops = small, Operators.build(small)
    b, c = -1.1, 2.3
    Xc, Zc = g.cell_coords()
    grad = ops.face_gradient(0.4 + b * Xc + c * Zc)
    np.testing.assert_allclose(grad[g.u_slice], b, rtol=RTOL)
    np.testing.assert_allclose(grad[g.w_slice], c, rtol=RTOL)
    # insulated walls: the discrete Laplacian conserves the total and annihilates constants
    p = np.random.default_rng(4).standard_normal(g.n_cells)
    lap = ops.div @ ops.face_gradient(p)
    assert abs(lap.sum()) <= RTOL * np.abs(lap).sum()
    np.testing.assert_allclose(ops.div @ ops.face_gradient(np.ones(g.cell_shape)), 0.0, atol=RTOL)


# --- input validation -------------------------------------------------------------------------
def test_invalid_inputs(small):
    ops = Operators.build(small)
    with pytest.raises(GranflowInputError, match="eta_c"):
        ops.viscous_operator(-1.0, 1.0)
    with pytest.raises(GranflowInputError, match="eta_n"):
        ops.viscous_operator(1.0, np.ones(small.cell_shape))
    with pytest.raises(GranflowInputError, match="eta_n"):
        ops.viscous_operator(1.0, np.nan)
    with pytest.raises(GranflowInputError, match="vel"):
        ops.strain_rate_norm(np.zeros(small.n_unknowns - 1))
    with pytest.raises(GranflowInputError, match="p must"):
        ops.face_gradient(np.zeros(small.n_nodes))
    with pytest.raises(GranflowInputError, match="grid"):
        Operators.build("grid")
    with pytest.raises(GranflowInputError, match="bcs"):
        Operators.build(small, {Side.TOP: NO})


def test_sorted_unique_equals_numpy_unique():
    """``sorted_unique`` (one sort; NumPy 2.4's hashing ``np.unique`` was 100x slower on the
    assembler's 1.5e6 keys) gives ``np.unique``'s array: values, order and dtype, empty and
    all-equal inputs included."""
    from granflow.operators import sorted_unique

    rng = np.random.default_rng(7)
    for a in (rng.integers(0, 50, 1000), rng.integers(0, 10**12, 5000, dtype=np.int64),
              np.zeros(0, dtype=np.int64), np.full(9, 3), rng.normal(size=100)):
        u = sorted_unique(a)
        assert u.dtype == np.unique(a).dtype and np.array_equal(u, np.unique(a))


@pytest.mark.parametrize("bottom", [VelocityBC.NO_SLIP, VelocityBC.FREE_SLIP])
def test_strain_rate_on_a_mask_equals_the_whole_grid_norm_bit_for_bit(bottom):
    """``Operators.strain_rate_on(cells)`` (the Picard sweeps' |S| on the dense cells) equals
    ``strain_rate_norm`` exactly on the cells of the mask and is 0 elsewhere: random velocities,
    a random mask, a compact blob, the empty and the full mask."""
    g = Grid(nx=13, nz=9, Lx=1.3, Lz=0.7)
    ops = Operators.build(g, VelocityBCs(bottom=bottom))
    rng = np.random.default_rng(3)
    xc, zc = np.meshgrid(g.xc, g.zc, indexing="ij")
    masks = [rng.random(g.n_cells) < 0.3, ((xc < 0.5) & (zc < 0.4)).ravel(),
             np.zeros(g.n_cells, dtype=bool), np.ones(g.n_cells, dtype=bool)]
    for cells in masks:
        on = ops.strain_rate_on(cells)
        for _ in range(3):
            u = rng.normal(size=g.n_unknowns)
            S = on(u)
            assert np.array_equal(S[cells], ops.strain_rate_norm(u)[cells]) and not S[~cells].any()
