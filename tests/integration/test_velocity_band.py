"""The velocity band (``numerics.ambient.velocity_band``, docs/solver.md "Velocity band"): the
velocity is solved only on the faces of the cells within r cells of grains; the ambient beyond
is at rest and not an unknown.

Checks: the restricted saddle-point matrix is the sub-matrix SciPy extracts from the whole one
(independent indexing), with and without the pore-gas border; a banded step is the whole system
solved with u = 0 imposed on the dropped faces; mass is conserved exactly; a dry collapse with
the band follows the unbanded one (stated tolerances below); bad widths are input errors naming
the key.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from granflow import diagnostics as dg
from granflow.config import CaseConfig
from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.model import PHI_TRACE, Model
from granflow.physics.momentum import GasBorder
from granflow.rheology import make_closure
from granflow.simulation import Simulation

PHI_MAX = 0.6
FRONT_CELLS = 1.0
"""Fronts of the banded and unbanded collapses agree to this many cells (measured: equal)."""
SPEED_TOLERANCE = 0.02
"""Granular-face velocities agree to this fraction of the peak speed (measured 3.3e-4 at 0.15 s)."""


def dp_model(band: int, nx: int = 40, nz: int = 15, gas: str | None = None, solver: str = "direct",
             **options) -> Model:
    closure = make_closure("drucker_prager", material={"d": 70e-6}, delta_deg=26.74)
    return Model(Grid(nx=nx, nz=nz, Lx=0.4, Lz=0.15), closure, gas=gas, linear_solver=solver,
                 ambient={"velocity_band": band}, **options)


def column(model: Model, phi0: float = PHI_MAX) -> np.ndarray:
    X, Z = model.grid.cell_coords()
    return np.where((X < 0.1) & (Z < 0.1), phi0, 0.0)


def test_region_covers_the_faces_near_grains_only():
    model = dp_model(3)
    phi = column(model)
    keep = model.velocity_region(phi)
    assert keep is not None and 0 < keep.sum() < keep.size
    g = model.grid
    u, w = g.unpack_velocity(keep.astype(float))
    # x-faces at x = i dx: kept iff a neighbouring cell is within 3 cells of the column (x < 0.1, z < 0.1)
    xf, zc = g.xf, g.zc
    near_x = (xf[:, None] <= 0.1 + 3 * g.dx + 1e-12) & (zc[None, :] < 0.1 + 3 * g.dz)
    interior = np.zeros_like(near_x)
    interior[g.u_columns] = True
    np.testing.assert_array_equal(u.astype(bool)[interior], near_x[interior])
    assert not w.astype(bool)[:, -1].any() and w.astype(bool)[0, 1]
    # traces below PHI_TRACE phi_max do not extend it; no grains at all: everything is solved
    trace = phi + np.where(phi == 0.0, 0.5 * PHI_TRACE * PHI_MAX, 0.0)
    np.testing.assert_array_equal(model.velocity_region(trace), keep)
    assert model.velocity_region(np.zeros_like(phi)) is None
    assert dp_model(0).velocity_region(phi) is None


def test_amg_solves_everywhere():
    assert dp_model(3, solver="amg").velocity_band is None
    assert dp_model(3, solver="direct").velocity_band == 3


@pytest.mark.parametrize("with_gas", [False, True])
def test_restricted_saddle_is_the_scipy_submatrix(with_gas):
    model = dp_model(2, gas="linear" if with_gas else None)
    g, asm = model.grid, model.assembler
    phi = column(model)
    keep = model.velocity_region(phi)
    rng = np.random.default_rng(3)
    a_data = asm.velocity_data(rng.uniform(1, 2, g.n_unknowns), rng.uniform(1, 5, g.n_cells),
                               rng.uniform(1, 5, g.n_nodes))
    dense = model.dense(phi)
    active = dense & (rng.uniform(size=g.n_cells) < 0.8)
    C = rng.uniform(0, 1, g.n_cells)
    border = None
    if with_gas:
        nw = int(dense.sum())
        block = sp.random(nw, nw, density=0.01, random_state=4) + sp.identity(nw)
        border = GasBorder(wet=dense, block=-(block + block.T))
    full = asm.saddle(a_data, active, C, border, unknowns=dense).tocsr()
    region = asm.region(keep)
    sub = asm.saddle(a_data, active, C, border, unknowns=dense, velocity=region)
    sel = np.concatenate([keep, np.ones(full.shape[0] - g.n_unknowns, dtype=bool)])
    expected = full[sel][:, sel]
    assert sub.shape == expected.shape and region.size == int(keep.sum())
    assert abs(sub - expected).max() == 0.0
    # the restricted data from velocity_data(region=...) are the kept entries of the whole pattern
    np.testing.assert_array_equal(
        asm.velocity_data(2.0, np.ones(g.n_cells), np.ones(g.n_nodes), region),
        asm.velocity_data(2.0, np.ones(g.n_cells), np.ones(g.n_nodes))[region.a_keep])


def test_banded_step_is_the_whole_system_with_the_far_ambient_at_rest():
    """One step with the band against the whole system solved by SciPy with u = 0 imposed
    (identity rows) on the faces outside the band, same Picard sweeps (one). The threshold
    surface (v1) is pinned: its band edge is a u = 0 wall; the indicator surface's edge is
    stress-free (next test)."""
    banded, whole = dp_model(3, surface="threshold"), dp_model(0, surface="threshold")
    banded.ambient = banded.ambient.model_copy(update={"velocity_band_margin": 0})  # the band itself
    for m in (banded, whole):
        m.picard = m.picard.model_copy(update={"max_sweeps": 1, "predictor": "previous"})
    phi = column(banded)
    s_band = banded.initial_state(phi)
    keep = banded.velocity_region(phi)
    captured = {}
    import granflow.step as model_module  # the stage that calls the direct solver

    real = model_module.spla.spsolve

    def spy(K, rhs):
        captured["K"], captured["rhs"] = K.copy(), rhs.copy()
        return real(K, rhs)

    model_module.spla.spsolve = spy
    try:
        assert not whole.advance(whole.initial_state(phi), 1e-3).failed
        K, rhs = sp.csr_matrix(captured["K"]), captured["rhs"]
        assert not banded.advance(s_band, 1e-3).failed
    finally:
        model_module.spla.spsolve = real
    n = whole.grid.n_unknowns
    drop = np.flatnonzero(~keep)
    K = K.tolil()
    for i in drop:  # u_i = 0
        K.rows[i], K.data[i] = [i], [1.0]
    rhs = rhs.copy()
    rhs[drop] = 0.0
    sol = spla.spsolve(K.tocsc(), rhs)
    assert np.all(s_band.vel[~keep] == 0.0)
    scale = np.abs(sol[:n]).max()
    assert scale > 1e-4
    # round-off of two LU factorisations of an ill-conditioned saddle system (yield viscosity
    # contrast ~1e8): measured 1.2e-9 of the peak; a plumbing error would be O(1)
    np.testing.assert_allclose(s_band.vel, sol[:n], rtol=0, atol=1e-7 * scale)


def test_indicator_band_edge_is_stress_free():
    """With the indicator surface the viscosity of the cells and nodes whose strain rate reaches a
    face beyond the band is 0 (granflow.step.band_edge): the viscous operator V = ec^T eta_c ec +
    en^T w eta_n en then couples no kept face to an excluded one (the excluded faces' u = 0 exerts
    no stress on the band), while the band keeps its interior coupling."""
    from granflow.step import band_edge

    model = dp_model(3)
    ops, phi = model.ops, column(model)
    keep = model.velocity_region(phi)
    edge_c, edge_n = band_edge(ops, keep)
    assert edge_c.any() and edge_n.any()
    full = ops.viscous_operator(np.ones(model.grid.n_cells), np.ones(model.grid.n_nodes)).tocsr()
    assert abs(full[keep][:, ~keep]).sum() > 0      # the u = 0 wall the v1 band has
    V = ops.viscous_operator(np.where(edge_c, 0.0, 1.0), np.where(edge_n, 0.0, 1.0)).tocsr()
    assert abs(V[keep][:, ~keep]).sum() == 0.0
    # the material's own faces are untouched: no edge cell or node holds grains
    assert not np.any(edge_c & (phi.ravel() > 0))
    inner = V[keep][:, keep]
    assert inner.nnz > 0.5 * full[keep][:, keep].nnz


def test_banded_collapse_follows_the_whole_one():
    runs = {}
    for band in (0, 3):
        model = dp_model(band)
        phi0 = column(model)
        sim = Simulation(model, model.initial_state(phi0), stop_time=0.15)
        sim.run()
        runs[band] = (model, sim, phi0)
    (m0, s0, phi0), (_, s3, _) = runs[0], runs[3]
    g = m0.grid
    fronts = [dg.front_position(g, s.state.phi, PHI_MAX, g.dz) for s in (s0, s3)]
    print(f"\nfronts at 0.15 s: whole {fronts[0]:.4f} m, band {fronts[1]:.4f} m; "
          f"max |du| / peak {np.abs(s3.state.vel - s0.state.vel).max() / np.abs(s0.state.vel).max():.2e}")
    assert abs(fronts[1] - fronts[0]) <= FRONT_CELLS * g.dx
    phi_f = m0.ops.cell_to_face @ s0.state.phi.ravel()
    granular = phi_f >= m0.ambient.phi_c
    peak = np.abs(s0.state.vel[granular]).max()
    assert peak > 0.1  # the column is collapsing
    assert np.abs(s3.state.vel - s0.state.vel)[granular].max() <= SPEED_TOLERANCE * peak
    m = dg.mass(g, phi0)
    assert abs(dg.mass(g, s3.state.phi) + s3.totals.clipped_mass - m) <= 1e-13 * m


@pytest.mark.parametrize("bad", [1, -1, 2.5])
def test_band_width_is_checked_naming_the_key(bad):
    with pytest.raises(GranflowInputError, match="numerics.ambient.velocity_band"):
        CaseConfig.from_dict({"case": {"name": "column_collapse"},
                              "numerics": {"ambient": {"velocity_band": bad}}})
