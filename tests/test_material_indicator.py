"""The material indicator transport (granflow.physics.material, numerics.surface = "indicator"):
grain mass to round-off, bounds, a full region stays exactly full, a sliding layer keeps its
fraction, the surface stays sharp, and the Model/State plumbing (checkpoint of c, refusal without c)."""
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


def test_model_state_carries_c_and_refuses_a_state_without_it():
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
    report = model.advance(st, 1e-4)
    assert report.status.value != "failed"
    assert st.phi.sum() == pytest.approx(phi.sum(), rel=1e-12)
    with pytest.raises(GranflowInputError, match="state.c"):
        model.advance(State.at_rest(g, phi), 1e-4)
    with pytest.raises(GranflowInputError, match="surface"):
        Model(g, make_closure("drucker_prager"), surface="vof")
