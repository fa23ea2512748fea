"""|S| on the cells of a mask (granflow.strain_rate): the compiled kernel (Numba; the whole
operators' CSR rows read at the mask's cells) against the NumPy reference (StrainRateOn.numpy:
the rows sliced per mask, sparse mat-vecs) and against the whole-grid operators. Each row's
entries are summed from 0 in their stored order in all three, so the values must be identical
(asserted with np.array_equal): plane grids with both bottom conditions and periodic in x, the
axisymmetric grid's three rows, random and compact masks, the empty and the full mask, and a
short run of a model with the kernel against the same run with the NumPy reference forced."""
from __future__ import annotations

import numpy as np
import pytest

import granflow.strain_rate as SR
from granflow.axisymmetric import AxisymmetricOperators
from granflow.grid import Grid, VelocityBC, VelocityBCs
from granflow.operators import Operators

pytestmark = pytest.mark.skipif(not SR.kernel_available(), reason="Numba not installed")


def masks(g, rng):
    xc, zc = np.meshgrid(g.xc, g.zc, indexing="ij")
    return [rng.random(g.n_cells) < 0.3, ((xc < 0.5 * g.Lx) & (zc < 0.6 * g.Lz)).ravel(),
            (rng.random(g.cell_shape) < 0.5), np.zeros(g.n_cells, dtype=bool),
            np.ones(g.n_cells, dtype=bool)]


def whole(rows, ops, vel):
    """``sqrt(sum_k (R_k u)^2/4 + (node_to_cell (en u)^2)/4)`` on the whole grid."""
    diag = sum((r @ vel) ** 2 for r in rows)
    return np.sqrt(0.25 * diag + 0.25 * (ops.node_to_cell @ (ops.en @ vel) ** 2))


def agree(on, reference, cells, vel):
    cells = np.asarray(cells, dtype=bool).ravel()
    S = on(vel)
    assert S.shape == reference.shape and S.dtype == np.float64
    assert np.array_equal(S, on.numpy(vel))
    assert np.array_equal(S[cells], reference[cells]) and not S[~cells].any()
    return S


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("bottom", [VelocityBC.NO_SLIP, VelocityBC.FREE_SLIP])
def test_plane_masks_agree_with_the_reference_and_the_whole_grid(bottom, periodic):
    rng = np.random.default_rng(5)
    g = Grid(nx=17, nz=11, Lx=1.7, Lz=1.1, periodic_x=periodic)
    ops = Operators.build(g, VelocityBCs(bottom=bottom))
    for cells in masks(g, rng):
        on = ops.strain_rate_on(cells)
        for _ in range(3):
            u = rng.normal(size=g.n_unknowns) * rng.choice([1e-8, 1.0, 1e6])
            agree(on, ops.strain_rate_norm(u), cells, u)


def test_axisymmetric_rows_agree():
    """The three scaled pair rows of the axisymmetric grid (the model's strain_rows)."""
    rng = np.random.default_rng(9)
    g = Grid(nx=14, nz=9, Lx=1.4, Lz=0.9, geometry="axisymmetric")
    axi = AxisymmetricOperators.build(g, VelocityBCs(bottom=VelocityBC.NO_SLIP))
    rate = SR.StrainRate(axi.box, axi.strain_rows)
    for cells in masks(g, rng):
        on = rate.on(cells)
        u = rng.normal(size=g.n_unknowns)
        agree(on, whole(axi.strain_rows, axi.box, u), cells, u)
        assert np.array_equal(SR.StrainRateOn.of(axi.box, cells, axi.strain_rows)(u), on(u))


def test_the_set_up_takes_the_cell_list_only():
    """One StrainRate per operators (Operators.strain_rate, cached); a mask keeps its cells."""
    g = Grid(nx=6, nz=5, Lx=0.6, Lz=0.5)
    ops = Operators.build(g, VelocityBCs())
    cells = np.zeros(g.cell_shape, dtype=bool)
    cells[1:3, 0:2] = True
    a, b = ops.strain_rate_on(cells), ops.strain_rate_on(cells.ravel())
    assert a.rate is b.rate is ops.strain_rate
    assert np.array_equal(a.cells, np.flatnonzero(cells)) and np.array_equal(a.cells, b.cells)


def test_bad_velocity_is_refused_and_inputs_are_converted():
    from granflow.errors import GranflowInputError

    g = Grid(nx=5, nz=4, Lx=0.5, Lz=0.4)
    ops = Operators.build(g, VelocityBCs())
    on = ops.strain_rate_on(np.ones(g.n_cells, dtype=bool))
    with pytest.raises(GranflowInputError):
        on(np.zeros(g.n_unknowns + 1))
    u = np.random.default_rng(0).normal(size=2 * g.n_unknowns)[::2]  # not contiguous
    assert np.array_equal(on(u), ops.strain_rate_norm(u))
    assert np.array_equal(on(list(u)), ops.strain_rate_norm(u))
    for size in (g.n_cells + 1, g.n_cells - 1):  # the kernel does not check its indices
        with pytest.raises(ValueError, match="mask of"):
            ops.strain_rate_on(np.ones(size, dtype=bool))


def _run(case_toml_dict):
    from granflow.cases import CASES
    from granflow.config import CaseConfig

    cfg = CaseConfig.from_dict(case_toml_dict)
    sim = CASES.get(cfg.case.name).setup(cfg)
    sim.run()
    return sim


LAGREE = {"case": {"name": "lagree_column"}, "grid": {"nx": 24, "nz": 24},
          "time": {"stop_time": 0.15, "dt_max": 0.01}, "output": {"figures": False}}
AXISYMMETRIC = {"case": {"name": "column_collapse"}, "setup": {"H0": 0.1, "L0": 0.1},
                "closure": {"name": "drucker_prager", "delta_deg": 26.74},
                "grid": {"geometry": "axisymmetric", "nx": 24, "nz": 10, "Lx": 0.4, "Lz": 0.12},
                "time": {"stop_time": 0.02, "dt_max": 1e-3}, "output": {"figures": False}}


@pytest.mark.parametrize("case", [LAGREE, AXISYMMETRIC], ids=["lagree", "axisymmetric"])
def test_model_steps_use_the_kernel_and_match_numpy(case, monkeypatch):
    """A short run calls the kernel at every Picard sweep and gives the same fields, bit for bit,
    as the same run with the NumPy reference forced."""
    calls, numpy_calls = [], []
    compiled, reference = SR.StrainRateOn.__call__, SR.StrainRateOn.numpy
    monkeypatch.setattr(SR.StrainRateOn, "__call__", lambda s, v: calls.append(1) or compiled(s, v))
    monkeypatch.setattr(SR.StrainRateOn, "numpy", lambda s, v: numpy_calls.append(1) or reference(s, v))
    fast = _run(case)
    assert len(calls) >= fast.totals.picard_iterations > 0
    assert not numpy_calls  # the kernel ran
    monkeypatch.setattr(SR, "kernel_available", lambda: False)
    ref = _run(case)
    assert len(numpy_calls) >= ref.totals.picard_iterations > 0
    assert len(fast.reports) == len(ref.reports)
    for name in ("phi", "vel", "p"):
        assert np.array_equal(getattr(fast.state, name), getattr(ref.state, name)), name
    assert np.abs(fast.state.vel).max() > 0
