"""Case ``static_layer``: a uniform layer at rest on the base, a verification case.

The layer ``0 <= z <= H`` fills the whole box width at packing ``phi0``. With a horizontal base
(or any slope below the friction angle) the exact solution is rest with the lithostatic
pressure ``p = phi0 rho_s g cos(slope) (H - z)``, which the discrete scheme reproduces exactly in
every completely filled cell below a completely filled top cell (telescoping sum of the discrete
hydrostatic balance; tests/integration/test_solver_dry.py). ``summary.json`` reports the largest speed, the
largest relative deviation from that pressure over the filled cells and the pressure profile
(``pressure_profile``, drawn in ``pressure.png``).
"""
from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from granflow.casekit.common import (
    flat_base_problems,
    extent_problems,
    gas_problems,
    make_model,
    make_simulation,
    packing,
    packing_problems,
    rectangle_fraction,
)
from granflow.casekit import headlines
from granflow.casekit.registry import CASES
from granflow.config import CaseConfig, Section
from granflow.simulation import Simulation
from granflow.state import State


ROUND_OFF = 1e-12
"""Relative tolerance of the comparisons of cell edges with the layer top H."""


class StaticLayerSetup(Section):
    """``[setup]`` of ``static_layer``."""

    H: float = Field(0.05, gt=0, description="layer thickness [m]")
    phi0: float | None = Field(None, gt=0, lt=1, description="packing fraction "
                               "(default: material.phi_max) [-]")


def check(config: CaseConfig) -> list[tuple[str, str]]:
    return (packing_problems(config) + gas_problems(config) + flat_base_problems(config, "static_layer")
            + extent_problems(config, "setup.H", config.setup.H, "z"))


def lithostatic_reference(config: CaseConfig, grid) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form pressure ``phi0 rho_s |g_z| (H - z)`` [Pa] and the mask of the cells where the
    discrete solution must equal it (cells entirely inside the layer)."""
    _, Z = grid.cell_coords()
    H = config.setup.H
    p = packing(config) * config.material.rho_s * abs(config.gravity_vector[1]) * (H - Z)
    full = Z + 0.5 * grid.dz <= H * (1 + ROUND_OFF)
    return np.where(full, p, 0.0), full


def diagnostics(sim: Simulation, config: CaseConfig) -> dict[str, Any]:
    p_ref, full = lithostatic_reference(config, sim.model.grid)
    err = np.abs(sim.state.p - p_ref)[full]
    scale = float(p_ref.max()) if p_ref.size else 0.0
    return {"H_m": config.setup.H, "max_speed_m_s": float(np.max(np.abs(sim.state.vel))),
            "pressure_rel_error": float(err.max() / scale) if err.size and scale > 0 else None,
            "pressure_reference": "phi0 rho_s |g_z| (H - z) in completely filled cells",
            "pressure_profile": pressure_profile(sim, config)}


def pressure_profile(sim: Simulation, config: CaseConfig) -> dict[str, list]:
    """The pressure of the final state against the lithostatic one, row by row over the rows
    holding grains (``pressure.png``): ``z_m``, ``p_Pa`` (mean over x: the layer fills the box
    width), ``reference_Pa`` (closed form, clipped at 0 above H) and ``full`` (the row is entirely
    inside the layer, where the two must agree)."""
    grid = sim.model.grid
    H = config.setup.H
    z = np.asarray(grid.zc)
    rows = z - 0.5 * grid.dz < H * (1 - ROUND_OFF)  # a row whose bottom is H holds no grains
    ref = packing(config) * config.material.rho_s * abs(config.gravity_vector[1]) * np.maximum(H - z, 0.0)
    _, full = lithostatic_reference(config, grid)
    return {"z_m": z[rows].tolist(), "p_Pa": np.asarray(sim.state.p).mean(axis=0)[rows].tolist(),
            "reference_Pa": ref[rows].tolist(), "full": full.all(axis=0)[rows].tolist()}


@CASES.register("static_layer", setup_model=StaticLayerSetup, check=check, diagnostics=diagnostics,
                headline=headlines.static_layer,
                summary="uniform layer at rest: lithostatic pressure, no motion (verification)")
def setup(config: CaseConfig) -> Simulation:
    """Model, initial state (p = 0: the solver must find the lithostatic pressure) and stop
    criteria of the static layer."""
    model = make_model(config)
    g = model.grid
    phi = packing(config) * rectangle_fraction(g, 0.0, g.Lx, 0.0, config.setup.H)
    return make_simulation(config, model, State.at_rest(g, phi))
