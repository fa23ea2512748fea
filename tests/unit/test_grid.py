"""Tests of granflow.grid: coordinates (closed forms), validation, packing of the velocity vector."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from granflow.errors import GranflowInputError
from granflow.grid import Grid, Side, VelocityBC, VelocityBCs

NX, NZ, LX, LZ, X0, Z0 = 5, 3, 2.5, 0.9, -1.0, 0.4


@pytest.fixture
def grid():
    return Grid(nx=NX, nz=NZ, Lx=LX, Lz=LZ, x0=X0, z0=Z0)


def test_spacings_and_sizes(grid):
    assert grid.dx == pytest.approx(LX / NX, rel=1e-15)
    assert grid.dz == pytest.approx(LZ / NZ, rel=1e-15)
    assert grid.cell_volume == pytest.approx(LX * LZ / (NX * NZ), rel=1e-15)
    assert grid.cell_shape == (NX, NZ)
    assert grid.xface_shape == (NX + 1, NZ)
    assert grid.zface_shape == (NX, NZ + 1)
    assert grid.node_shape == (NX + 1, NZ + 1)
    assert grid.n_cells == NX * NZ
    assert grid.n_nodes == (NX + 1) * (NZ + 1)
    assert grid.n_u == (NX - 1) * NZ
    assert grid.n_w == NX * (NZ - 1)
    assert grid.n_unknowns == (NX - 1) * NZ + NX * (NZ - 1)


def test_coordinates_closed_form(grid):
    # tolerance: round-off on O(1) coordinates
    xc = [X0 + (i + 0.5) * LX / NX for i in range(NX)]
    zc = [Z0 + (j + 0.5) * LZ / NZ for j in range(NZ)]
    xf = [X0 + i * LX / NX for i in range(NX + 1)]
    zf = [Z0 + j * LZ / NZ for j in range(NZ + 1)]
    np.testing.assert_allclose(grid.xc, xc, rtol=0, atol=1e-14)
    np.testing.assert_allclose(grid.zc, zc, rtol=0, atol=1e-14)
    np.testing.assert_allclose(grid.xf, xf, rtol=0, atol=1e-14)
    np.testing.assert_allclose(grid.zf, zf, rtol=0, atol=1e-14)
    assert grid.xf[0] == X0 and grid.xf[-1] == pytest.approx(X0 + LX, abs=1e-14)
    assert grid.zf[-1] == pytest.approx(Z0 + LZ, abs=1e-14)
    X, Z = grid.xface_coords()
    assert X.shape == grid.xface_shape and X[2, 1] == grid.xf[2] and Z[2, 1] == grid.zc[1]
    X, Z = grid.zface_coords()
    assert X.shape == grid.zface_shape and X[2, 1] == grid.xc[2] and Z[2, 1] == grid.zf[1]
    X, Z = grid.node_coords()
    assert X.shape == grid.node_shape and X[3, 2] == grid.xf[3] and Z[3, 2] == grid.zf[2]
    X, Z = grid.cell_coords()
    assert X.shape == grid.cell_shape and X[4, 0] == grid.xc[4] and Z[4, 0] == grid.zc[0]


def test_coordinates_are_read_only(grid):
    with pytest.raises(ValueError):
        grid.xc[0] = 0.0


def test_frozen_and_equality(grid):
    with pytest.raises(dataclasses.FrozenInstanceError):
        grid.nx = 7
    assert grid == Grid(NX, NZ, LX, LZ, X0, Z0)
    assert hash(grid) == hash(Grid(np.int64(NX), NZ, LX, LZ, X0, Z0))
    assert isinstance(Grid(np.int64(4), 3, 1, 1).nx, int)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"nx": 1}, "nx"),
        ({"nz": 0}, "nz"),
        ({"nx": 2.5}, "nx"),
        ({"nz": True}, "nz"),
        ({"Lx": 0.0}, "Lx"),
        ({"Lz": -1.0}, "Lz"),
        ({"Lx": float("nan")}, "Lx"),
        ({"Lz": float("inf")}, "Lz"),
        ({"Lx": "1"}, "Lx"),
        ({"x0": float("nan")}, "x0"),
        ({"z0": float("-inf")}, "z0"),
    ],
)
def test_invalid_arguments_name_the_argument(kwargs, name):
    args = {"nx": 4, "nz": 4, "Lx": 1.0, "Lz": 1.0} | kwargs
    with pytest.raises(GranflowInputError, match=rf"\b{name}\b"):
        Grid(**args)
    with pytest.raises(ValueError):  # GranflowInputError is a ValueError
        Grid(**args)


def test_pack_layout_and_roundtrip(grid):
    rng = np.random.default_rng(0)
    u = rng.standard_normal(grid.xface_shape)
    w = rng.standard_normal(grid.zface_shape)
    vel = grid.pack_velocity(u, w)
    assert vel.shape == (grid.n_unknowns,)
    # documented order: u[1:-1, :] in C order, then w[:, 1:-1] in C order
    assert vel[(2 - 1) * NZ + 1] == u[2, 1]
    assert vel[grid.n_u + 3 * (NZ - 1) + 1] == w[3, 2]
    u2, w2 = grid.unpack_velocity(vel)
    np.testing.assert_array_equal(u2[1:-1], u[1:-1])
    np.testing.assert_array_equal(w2[:, 1:-1], w[:, 1:-1])
    # zero normal velocity on all four walls
    assert not u2[0].any() and not u2[-1].any()
    assert not w2[:, 0].any() and not w2[:, -1].any()
    np.testing.assert_array_equal(grid.pack_velocity(u2, w2), vel)
    assert vel[grid.u_slice].size == grid.n_u and vel[grid.w_slice].size == grid.n_w


def test_pack_shape_errors(grid):
    with pytest.raises(GranflowInputError, match="u must have shape"):
        grid.pack_velocity(np.zeros(grid.cell_shape), np.zeros(grid.zface_shape))
    with pytest.raises(GranflowInputError, match="w must have shape"):
        grid.pack_velocity(np.zeros(grid.xface_shape), np.zeros(grid.xface_shape))
    with pytest.raises(GranflowInputError, match="vel must have shape"):
        grid.unpack_velocity(np.zeros(grid.n_unknowns + 1))


def test_velocity_bcs_defaults_and_conversion():
    bcs = VelocityBCs()
    assert bcs.kind(Side.BOTTOM) is VelocityBC.NO_SLIP
    for side in (Side.WEST, Side.EAST, Side.TOP):
        assert bcs.kind(side) is VelocityBC.FREE_SLIP
    assert VelocityBCs(top="no_slip").top is VelocityBC.NO_SLIP
    assert all(VelocityBCs.uniform("free_slip").kind(s) is VelocityBC.FREE_SLIP for s in Side)
    assert VelocityBCs(bottom="no_slip") == VelocityBCs()
    with pytest.raises(GranflowInputError, match="'west'"):
        VelocityBCs(west="sticky")
    with pytest.raises(dataclasses.FrozenInstanceError):
        bcs.top = VelocityBC.NO_SLIP
