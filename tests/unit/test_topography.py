"""Topography as solid cells (issue 14 item 3): the profile, its staircase, and the MAC operators on
the fluid cells (:mod:`granflow.topography`).

The operators are checked against an independent construction: above a floor raised by k cells
they must equal, entry for entry, the operators of the shorter box built by
:meth:`granflow.operators.Operators.build` (whose own tests check them against analytic
stencils); at a step's side the ghost must give the exact shear of a linear profile.
"""
from __future__ import annotations

import numpy as np
import pytest

from granflow.errors import GranflowInputError
from granflow.grid import Grid, VelocityBCs
from granflow.operators import Operators
from granflow.topography import Topography, face_classes, masked_operators, staircase_error


def _floor(nx: int, nz: int, k: int, periodic: bool, bcs=None):
    g = Grid(nx=nx, nz=nz, Lx=float(nx), Lz=float(nz), periodic_x=periodic)
    solid = np.zeros(g.cell_shape, dtype=bool)
    solid[:, :k] = True
    short = Grid(nx=nx, nz=nz - k, Lx=float(nx), Lz=float(nz - k), z0=float(k), periodic_x=periodic)
    return g, masked_operators(Operators.build(g, bcs), solid), Operators.build(short, bcs)


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("bottom", ["no_slip", "free_slip"])
def test_raised_floor_equals_the_shorter_box(periodic, bottom):
    k = 3
    g, m, box = _floor(5, 7, k, periodic, VelocityBCs(bottom=bottom))
    o, f = m.open_faces, ~m.solid
    assert o.sum() == box.grid.n_unknowns and f.sum() == box.grid.n_cells
    rng = np.random.default_rng(1)
    eta_c, eta_n = rng.random(g.n_cells), rng.random(g.n_nodes)
    upper_nodes = np.zeros(g.node_shape, dtype=bool)
    upper_nodes[:, k:] = True
    upper_nodes = upper_nodes.ravel()
    V = m.viscous_operator(eta_c, eta_n)[o][:, o]
    V_box = box.viscous_operator(eta_c.reshape(g.cell_shape)[:, k:].ravel(), eta_n[upper_nodes])
    assert abs(V - V_box).max() < 1e-12
    assert abs(m.div[f][:, o] - box.div).max() == 0.0
    assert abs(m.ec[f][:, o] - box.ec).max() == 0.0
    assert abs(m.en[upper_nodes][:, o] - box.en).max() < 1e-12
    assert np.array_equal(m.node_weights[upper_nodes], box.node_weights)
    assert np.all(m.node_weights[~upper_nodes] == 0.0)
    assert abs(m.cell_to_node[upper_nodes][:, f] - box.cell_to_node).max() < 1e-15
    assert abs(m.cell_to_face[o][:, f] - box.cell_to_face).max() < 1e-15


def _step(nx=8, nz=6, periodic=False):
    g = Grid(nx=nx, nz=nz, Lx=float(nx), Lz=float(nz), periodic_x=periodic)
    t = Topography(x=[0.0, 3.99, 4.01, 8.0], z=[1.0, 1.0, 3.0, 3.0])  # a 2-cell step up at x = 4
    return g, t, masked_operators(Operators.build(g), t.solid_cells(g))


@pytest.mark.parametrize("periodic", [False, True])
def test_energy_identity_on_a_step(periodic):
    g, _, m = _step(periodic=periodic)
    assert abs(m.grad + m.div.T).max() == 0.0
    rng = np.random.default_rng(2)
    vel = rng.standard_normal(g.n_unknowns) * m.open_faces
    eta_c, eta_n = rng.random(g.n_cells), rng.random(g.n_nodes)
    V = m.viscous_operator(eta_c, eta_n)
    assert abs(V - V.T).max() < 1e-12
    assert np.isclose(g.cell_volume * vel @ V @ vel, m.dissipation(vel, eta_c, eta_n), rtol=1e-12)
    p = rng.standard_normal(g.n_cells)
    assert np.isclose(p @ (m.div @ vel), -vel @ (m.grad @ p), rtol=1e-12)
    # nothing reads the velocity of a closed (wall or buried) face
    for op in (m.div, m.ec, m.en):
        assert abs(op[:, ~m.open_faces]).max() == 0.0
    # every face and node keeps a mean (a harmonic mean of permeabilities stays finite inside the solid)
    ones = np.ones(g.n_cells)
    assert np.allclose(m.cell_to_face @ ones, 1.0) and np.allclose(m.cell_to_node @ ones, 1.0)


def test_step_side_ghost_gives_the_exact_shear():
    """w = gamma (x - x_wall) beside the step's vertical side (x_wall = 4) vanishes on the wall;
    dw/dx at the side's nodes (weight 1/2) must be gamma, as on a no-slip box wall."""
    g, _, m = _step()
    gamma = 0.7
    u = np.zeros(g.xface_shape)
    w = np.zeros(g.zface_shape)
    xc = g.xc[:, None] * np.ones(g.nz + 1)
    w[:] = gamma * (xc - 4.0)
    vel = g.pack_velocity(u, w) * m.open_faces
    en = (m.en @ vel).reshape(g.node_shape)
    wn = m.node_weights.reshape(g.node_shape)
    assert wn[4, 2] == 0.5                    # the side's one node between its foot and edge
    assert np.isclose(en[4, 2], gamma)
    assert wn[4, 1] == 0.25 and wn[4, 3] == 0.75  # foot and edge of the step


def test_coulomb_profile_has_no_slip_treads_and_free_slip_risers():
    """A Coulomb base caps the friction of its treads (the no-slip ghost) and leaves the risers
    free-slip: dw/dx of a profile vanishing on the step's side is 0 there, 2 u/dz on a tread."""
    g = Grid(nx=8, nz=6, Lx=8.0, Lz=6.0)
    t = Topography(x=[0.0, 3.99, 4.01, 8.0], z=[1.0, 1.0, 3.0, 3.0])
    m = masked_operators(Operators.build(g, VelocityBCs(bottom="coulomb")), t.solid_cells(g))
    w = 0.7 * (g.xc[:, None] * np.ones(g.nz + 1) - 4.0)
    vel = g.pack_velocity(np.zeros(g.xface_shape), w) * m.open_faces
    assert (m.en @ vel).reshape(g.node_shape)[4, 2] == 0.0
    u = np.ones(g.xface_shape)
    vel = g.pack_velocity(u, np.zeros(g.zface_shape)) * m.open_faces
    assert np.isclose((m.en @ vel).reshape(g.node_shape)[2, 1], 2.0)   # tread at z = 1, x = 2


def test_node_weights_are_the_fluid_share_of_the_box_weights():
    g, t, m = _step()
    box = Operators.build(g)
    fluid = (~t.solid_cells(g)).astype(float).ravel()
    assert np.allclose(m.node_weights, box.node_weights * (box.cell_to_node @ fluid))
    # the fluid cells' control volume is that of the nodes: sum of weights = fluid area / cell
    assert np.isclose(m.node_weights.sum(), fluid.sum())


def test_face_classes_of_a_step():
    g, t, m = _step()
    cls = face_classes(g, t.solid_cells(g))
    assert not np.any(cls.open & cls.wall) and not np.any(cls.wall & cls.buried)
    assert np.all(cls.open | cls.wall | cls.buried)
    u_wall = cls.wall[g.u_slice].reshape(g.n_xfaces, g.nz)
    assert np.flatnonzero(u_wall.any(axis=1)).tolist() == [3]    # x-face 4: the step's side
    assert np.flatnonzero(u_wall[3]).tolist() == [1, 2]


def test_profile_height_slope_and_staircase():
    t = Topography(x=[0.0, 1.0, 2.0], z=[1.0, 0.0, 0.0])
    assert np.allclose(t.height([-1.0, 0.5, 1.5, 9.0]), [1.0, 0.5, 0.0, 0.0])
    for n in (10, 20, 40):
        g = Grid(nx=n, nz=n, Lx=2.0, Lz=2.0)
        assert staircase_error(t, g) <= 0.5 * g.dz + 1e-12


def test_profile_errors_name_the_problem(tmp_path):
    with pytest.raises(GranflowInputError, match="strictly increasing"):
        Topography(x=[0.0, 0.0], z=[1.0, 1.0])
    with pytest.raises(GranflowInputError, match="same length"):
        Topography(x=[0.0, 1.0], z=[1.0])
    with pytest.raises(GranflowInputError, match="finite"):
        Topography(x=[0.0, np.nan], z=[1.0, 1.0])
    g = Grid(nx=4, nz=4, Lx=4.0, Lz=4.0)
    with pytest.raises(GranflowInputError, match=r"x = 3\.5 m .* raise grid\.Lz"):
        Topography(x=[0.0, 3.0, 3.01], z=[0.0, 0.0, 3.9]).solid_cells(g)
    bad = np.zeros(g.cell_shape, dtype=bool)
    bad[1, 2] = True
    with pytest.raises(GranflowInputError, match="column 1 has a fluid cell below a solid one"):
        masked_operators(Operators.build(g), bad)


def test_profile_from_csv(tmp_path):
    f = tmp_path / "base.csv"
    f.write_text("x_m, z_m\n0.0, 0.3\n# a comment\n1.0, 0.0\n")
    t = Topography.from_csv(f)
    assert t.x.tolist() == [0.0, 1.0] and t.z.tolist() == [0.3, 0.0]
    f.write_text("0, 1\n1, two\n")
    with pytest.raises(GranflowInputError, match="line 2"):
        Topography.from_csv(f)
    with pytest.raises(GranflowInputError, match="does not exist"):
        Topography.from_csv(tmp_path / "none.csv")


# --- the indicator transport beside solid cells (granflow.physics.material) -----------------------
def _film(nx=6, nz=6, k=2, periodic=False):
    """A c = 0.3 film (packing 0.55) on a floor raised by k cells, moving in +x at CFL 0.2."""
    g = Grid(nx=nx, nz=nz, Lx=float(nx), Lz=float(nz), periodic_x=periodic)
    solid = np.zeros(g.cell_shape, dtype=bool)
    solid[:, :k] = True
    c = np.zeros(g.cell_shape)
    c[1:4, k] = 0.3
    u = np.zeros(g.xface_shape)
    u[1:-1, k:] = 0.2
    return g, solid, c, 0.55 * c, u, np.zeros(g.zface_shape)


def test_film_on_a_raised_floor_moves_as_on_the_box_base():
    """The reconstruction reads the solid below a flat floor as the box reads its wall (the cell
    repeated), so the film's fluxes equal those of the same film on the box's base, bit for bit:
    without the fill a c = 0.3 film got face fractions of 1 (solid c = 0 read as air)."""
    import granflow.physics.material as M
    g, solid, c, phi, u, w = _film()
    k = 2
    box = Grid(nx=g.nx, nz=g.nz - k, Lx=g.Lx, Lz=g.Lz - k)
    ref = M._fluxes_numpy(box, c[:, k:], phi[:, k:], u[:, k:], w[:, k:], 1.0, 0.6)
    for fluxes in (M._fluxes_numpy, M._fluxes):
        got = fluxes(g, c, phi, u, w, 1.0, 0.6, M.solid_filled(c, solid))
        assert np.array_equal(got[0][0][:, k:], ref[0][0]) and np.array_equal(got[1][0][:, k:], ref[1][0])
        assert np.all(got[0][0][:, :k] == 0.0)
    unfilled = M._fluxes_numpy(g, c, phi, u, w, 1.0, 0.6)
    assert not np.array_equal(unfilled[0][0][:, k:], ref[0][0])  # the fill is what makes them equal


@pytest.mark.parametrize("seed", range(4))
def test_filled_reconstruction_numpy_and_numba_agree(seed):
    import granflow.physics.material as M
    from granflow.physics.material_kernel import kernel_available
    from granflow.physics.transport import cfl_number, face_velocities
    if not kernel_available():
        pytest.skip("Numba not installed")
    rng = np.random.default_rng(seed)
    g = Grid(nx=12, nz=10, Lx=1.2, Lz=1.0, periodic_x=bool(seed % 2))
    topo = Topography(x=[0.0, 1.2], z=[rng.uniform(0.1, 0.5), rng.uniform(0.1, 0.5)])
    solid = topo.solid_cells(g)
    c = np.where(rng.random(g.cell_shape) < 0.3, 0.0, rng.random(g.cell_shape)) * ~solid
    phi = c * rng.uniform(0.3, 0.6, g.cell_shape)
    m = masked_operators(Operators.build(g), solid)
    vel = rng.normal(0.0, 1.0, g.n_unknowns) * m.open_faces
    u, w = face_velocities(g, vel)
    dt = 0.45 / cfl_number(g, vel, 1.0)
    c_rec = M.solid_filled(c, solid)
    a = M._fluxes(g, c, phi, u, w, dt, 0.6, c_rec)
    b = M._fluxes_numpy(g, c, phi, u, w, dt, 0.6, c_rec)
    for x, y in zip(a[0] + a[1], b[0] + b[1]):
        assert np.array_equal(x, y)


@pytest.mark.parametrize("gas", ["linear", "nonlinear"])
def test_gas_block_with_injection_on_a_raised_floor_is_the_shorter_boxs(gas):
    """The pore-gas block (granflow.physics.pore_pressure.gas_operator): no Darcy flux into the
    rock, and the base injection enters through the lowest fluid cell of each column (the box's
    bottom row above a flat raised floor): matrix and source equal to the shorter box's."""
    from granflow.materials import Material
    from granflow.physics.pore_pressure import gas_operator
    k = 2
    g, m, box = _floor(6, 8, k, False)
    mat = Material()
    rng = np.random.default_rng(5)
    phi = np.zeros(g.cell_shape)
    phi[:, k:] = rng.uniform(0.5, 0.6, (g.nx, g.nz - k))
    p_f = np.zeros(g.cell_shape)
    p_f[:, k:] = rng.uniform(0.0, 500.0, (g.nx, g.nz - k))
    dirichlet = np.zeros(g.cell_shape, dtype=bool)
    dirichlet[:, :k] = True   # the rock: no gas row (the model's cells without material)
    dirichlet[:, -1] = True
    inj = rng.uniform(0.0, 0.01, g.nx)
    a = gas_operator(g, m, phi, 1e-3, mat, gas=gas, p_f=p_f, dirichlet=dirichlet, injection=inj)
    b = gas_operator(box.grid, box, phi[:, k:], 1e-3, mat, gas=gas, p_f=p_f[:, k:],
                     dirichlet=dirichlet[:, k:], injection=inj)
    fluid = ~m.solid
    assert abs(a.matrix.tocsr()[fluid][:, fluid] - b.matrix).max() <= 1e-12 * abs(b.matrix).max()
    assert np.allclose(a.rhs[fluid], b.rhs, rtol=1e-14, atol=0.0) and np.all(a.rhs[~fluid] == 0.0)
    assert np.count_nonzero(b.rhs) == g.nx
