"""The kept region's cover (:func:`granflow.region.band_cover`): checking that this step's grains
lie in it must say exactly what building the step's band and comparing it with the kept
velocity unknowns says (``velocity_region(phi) <= wide``), on random grains and random kept
regions, walled and periodic."""
from __future__ import annotations

import numpy as np
import pytest

from granflow.grid import Grid
from granflow.model import Model
from granflow.model_options import MIN_VELOCITY_BAND, PHI_TRACE
from granflow.region import band_cover
from granflow.rheology import make_closure

PHI_MAX = 0.6
TRIALS = 60


def model_on(periodic: bool, band: int) -> Model:
    g = Grid(nx=20, nz=14, Lx=0.2, Lz=0.14, periodic_x=periodic)
    clo = make_closure("drucker_prager", delta_deg=26.74)
    return Model(g, clo, linear_solver="direct", ambient={"velocity_band": band, "velocity_band_margin": 2})


def random_grains(rng, model: Model, density: float) -> np.ndarray:
    phi = np.where(rng.random(model.grid.cell_shape) < density, PHI_MAX, 0.0)
    return phi


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("band", [MIN_VELOCITY_BAND, 3])
def test_cover_agrees_with_the_band_it_replaces(periodic, band):
    rng = np.random.default_rng(7 + band + 10 * periodic)
    model = model_on(periodic, band)
    agree = {True: 0, False: 0}
    for trial in range(TRIALS):
        kept = random_grains(rng, model, 0.02)
        if trial % 2:  # a kept region of the kind step_region builds: a wider band
            wide = model.velocity_region(kept, band=band + 2)
            if wide is None:
                continue
        else:  # any mask of velocity unknowns
            wide = rng.random(model.grid.n_unknowns) < 0.97
        cover = band_cover(model, wide)
        # this step's grains: some of the kept ones, moved by up to two cells, and a few new ones
        shift = tuple(rng.integers(-2, 3, size=2)) if trial % 3 else (0, 0)
        phi = np.roll(np.where(rng.random(kept.shape) < 0.7, kept, 0.0), shift, axis=(0, 1))
        phi = np.maximum(phi, random_grains(rng, model, rng.choice([0.0, 0.002, 0.01])))
        grains = phi.ravel() > PHI_TRACE * PHI_MAX
        keep = model.velocity_region(phi)
        if keep is None or not grains.any():
            continue
        covered = not np.any(grains & ~cover)
        assert covered == (not np.any(keep & ~wide)), f"trial {trial}"
        agree[covered] += 1
    assert agree[True] >= 3 and agree[False] >= 3, agree  # both answers were tested


def test_no_cover_without_a_band():
    g = Grid(nx=8, nz=6, Lx=0.08, Lz=0.06)
    model = Model(g, make_closure("drucker_prager", delta_deg=26.74), linear_solver="direct",
                  ambient={"velocity_band": 0})
    assert band_cover(model, np.ones(g.n_unknowns, dtype=bool)) is None
