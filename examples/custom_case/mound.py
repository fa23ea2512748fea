"""Case ``mound``: a heap of grains of a shape given in Python slumps, or stays, under its weight.

The heap rests against the west wall (free-slip by default: a symmetry plane, so the heap is the
right half of a symmetric one) on the base z = 0. Its surface is ``z = H f(x / a)`` for
0 <= x <= a, with the profile f of ``setup.profile`` from :data:`PROFILES` (f(0) = 1, f(1) = 0):
"ellipse", a semi-elliptical mound, vertical at its toe; "wedge", a uniform slope of H/a. The
cells cut by the surface hold the fraction of their area under it (midpoint rule on a
:data:`SUBCELLS` x :data:`SUBCELLS` sub-grid). At rest at t = 0 with the lithostatic
pressure and no pore pressure (dry unless ``[gas]`` sets a law).

Run it with the full case runner (NetCDF, checkpoints, restart, summary, figures, progress):
``python examples/custom_case/mound.py run examples/custom_case/mound.toml --out runs/mound``.
"""
from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from pydantic import Field

from granflow.cases import CASES
from granflow.cases.common import (extent_problems, gas_problems, initial_state, make_model,
                                   make_simulation, packing, packing_problems)
from granflow.config import CaseConfig, Section
from granflow.grid import Grid
from granflow.simulation import Simulation

PROFILES: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "ellipse": lambda s: np.sqrt(np.clip(1.0 - s**2, 0.0, None)),  # semi-ellipse, vertical toe
    "wedge": lambda s: np.clip(1.0 - s, 0.0, None),                 # uniform slope H/a
}
"""Surface profiles f(s) [-] of the dimensionless distance s = x/a >= 0 from the wall."""
SUBCELLS = 8
"""Sub-grid points per cell and direction of the cell fractions of the initial deposit [-]."""
FRONT_THRESHOLD_FRACTION = 0.05
"""Deposit thickness defining the front, as a fraction of H [-] (not one cell height: a heap a
few cells high thins below a cell as it spreads, and its front would seem to retreat)."""


class MoundSetup(Section):
    """``[setup]`` of ``mound``."""

    H: float = Field(0.05, gt=0, description="height of the heap at the west wall [m]")
    a: float = Field(0.1, gt=0, description="half-width of the heap at its base [m]")
    profile: Literal["ellipse", "wedge"] = Field("ellipse", description="surface profile: "
                                                 '"ellipse" or "wedge" (slope H/a) [-]')
    phi0: float | None = Field(None, gt=0, lt=1, description="packing fraction of the heap "
                               "(default: material.phi_max) [-]")


def cell_fraction(grid: Grid, inside: Callable[[np.ndarray, np.ndarray], np.ndarray],
                  n: int = SUBCELLS) -> np.ndarray:
    """Fraction of each cell's area where ``inside(x, z)`` [m, m] is true [-], shape (nx, nz)."""
    offsets = (np.arange(n) + 0.5) / n - 0.5  # sub-point positions in cell widths
    x = grid.xc[:, None, None, None] + offsets[None, None, :, None] * grid.dx
    z = grid.zc[None, :, None, None] + offsets[None, None, None, :] * grid.dz
    return inside(x, z).mean(axis=(2, 3))


def phi_initial(config: CaseConfig, grid: Grid) -> np.ndarray:
    """phi0(x, z) [-]: the packing under the surface z = H f(x/a), 0 above it."""
    s, f = config.setup, PROFILES[config.setup.profile]
    return packing(config) * cell_fraction(grid, lambda x, z: z < s.H * f(x / s.a))


def check(config: CaseConfig) -> list[tuple[str, str]]:
    """Load-time conditions: packing, gas options, the heap fits in the box with room to spread."""
    s = config.setup
    out = packing_problems(config) + gas_problems(config)
    out += extent_problems(config, "setup.H", s.H, "z") + extent_problems(config, "setup.a", s.a, "x")
    if s.a >= config.grid.Lx:
        out.append(("setup.a", f"{s.a} m leaves no room to spread (grid.Lx = {config.grid.Lx} m)"))
    if config.grid.periodic_x:
        out.append(("grid.periodic_x", "the heap needs its west wall; set periodic_x = false"))
    return out


def friction_coefficient(config: CaseConfig) -> float:
    """Static friction coefficient of the closure, its yield function Z(phi0, I = 0) [-]: a
    surface slope below it is stable (sin(delta) for drucker_prager, mu_s for mu(I))."""
    return float(config.make_closure().Z(packing(config), 0.0))


def diagnostics(sim: Simulation, config: CaseConfig) -> dict[str, Any]:
    """``case_diagnostics`` of summary.json: the heap's size [m], profile and packing [-], its
    mean slope H/a and the closure's static friction coefficient [-]."""
    s = config.setup
    return {"H_m": s.H, "a_m": s.a, "profile": s.profile, "phi0": packing(config),
            "mean_slope": s.H / s.a, "friction_coefficient": friction_coefficient(config)}


def front_threshold(config: CaseConfig) -> float:
    """Deposit thickness [m] defining the front: :data:`FRONT_THRESHOLD_FRACTION` x H."""
    return FRONT_THRESHOLD_FRACTION * config.setup.H


@CASES.register("mound", setup_model=MoundSetup, check=check, diagnostics=diagnostics,
                front_threshold=front_threshold, settles=True,
                summary="heap of grains z < H f(x/a) against the west wall slumps")
def setup(config: CaseConfig) -> Simulation:
    """Model (from the config's sections), the heap at rest, stop criteria (``[time]``)."""
    model = make_model(config)
    return make_simulation(config, model, initial_state(model, phi_initial(config, model.grid)))


if __name__ == "__main__":  # this file as the `granflow` command, with the case registered
    from granflow.cli import main

    sys.exit(main())
