"""The active set's start of a step (granflow.active_set): which free cells one solve per step
carries, against a cell-by-cell loop written out here."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from granflow.active_set import carried_free, interior
from granflow.grid import Grid


def loop_interior(mask: np.ndarray, periodic: bool) -> np.ndarray:
    """Cell-by-cell reference: in the mask and its four neighbours too (a wall counts as in)."""
    nx, nz = mask.shape
    out = np.zeros_like(mask)
    for i in range(nx):
        for j in range(nz):
            ok = mask[i, j]
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                a, b = i + di, j + dj
                if periodic:
                    a %= nx
                if 0 <= a < nx and 0 <= b < nz:
                    ok = ok and mask[a, b]
            out[i, j] = ok
    return out


@pytest.mark.parametrize("periodic", [False, True])
def test_interior_matches_a_cell_loop(periodic):
    g = Grid(nx=7, nz=5, Lx=7.0, Lz=5.0, periodic_x=periodic)
    rng = np.random.default_rng(3)
    for _ in range(20):
        mask = rng.random((7, 5)) < 0.8
        got = interior(g, mask.ravel()).reshape(7, 5)
        assert np.array_equal(got, loop_interior(mask, periodic))


def _model(sweeps: int, grid: Grid):
    return SimpleNamespace(picard=SimpleNamespace(max_sweeps=sweeps), grid=grid)


def test_carried_free_keeps_only_the_interior_of_the_last_free_set():
    """A 6 x 6 dense block with a thin top row: of a free set covering everything, the cells
    next to the thin row or to the empty columns are dropped, the rest carried."""
    g = Grid(nx=8, nz=6, Lx=8.0, Lz=6.0)
    dense = np.zeros((8, 6), dtype=bool)
    dense[1:7, :] = True  # columns 0 and 7 empty
    thin = np.zeros_like(dense)
    thin[1:7, 5] = True
    state = SimpleNamespace(free=np.ones((8, 6), dtype=bool))
    ex = SimpleNamespace(thin=thin.ravel())
    got = carried_free(_model(1, g), state, ex, dense.ravel()).reshape(8, 6)
    expect = np.zeros_like(dense)
    expect[2:6, 0:4] = True  # not next to the empty columns, not next to the thin row; the base is a wall
    assert np.array_equal(got, expect)
    state.free[3, 1] = False  # an active cell stays active
    assert not carried_free(_model(1, g), state, ex, dense.ravel()).reshape(8, 6)[3, 1]


def test_carried_free_is_off_for_the_picard_loop_and_before_the_first_step():
    g = Grid(nx=3, nz=3, Lx=3.0, Lz=3.0)
    dense = np.ones(9, dtype=bool)
    ex = SimpleNamespace(thin=None)
    assert carried_free(_model(2, g), SimpleNamespace(free=np.ones((3, 3), bool)), ex, dense) is None
    assert carried_free(_model(1, g), SimpleNamespace(free=None), ex, dense) is None
    assert carried_free(_model(1, g), SimpleNamespace(free=np.ones((3, 3), bool)), ex, dense).all()
