"""Pieces shared by the cases: the Model and Simulation of a :class:`~granflow.config.CaseConfig`,
the pore-gas options, exact cell fractions of rectangles, and shared checks."""
from __future__ import annotations

import inspect
import math
from typing import Any

import numpy as np

from granflow.config import CaseConfig
from granflow.errors import GranflowInputError
from granflow.grid import Grid, VelocityBCs
from granflow.model import Model
from granflow.physics.inflow import Source
from granflow.simulation import Simulation
from granflow.state import State

GAS_OPTION = "gas"
"""Keyword of :class:`granflow.model.Model` that switches the pore-gas coupling on."""
INJECTION_OPTION = "U_inj"
"""Keyword of :class:`granflow.model.Model` for the gas injected through the base."""
OPEN_TOP_OPTION = "open_top"
"""Keyword of :class:`granflow.model.Model` for ``p_f = 0`` on the top wall."""
COMPRESSIBILITY_OPTION = "gas_compressibility"
"""Keyword of :class:`granflow.model.Model` for the gas's state law (``gas.compressibility``)."""
ISOTHERMAL = "isothermal"
"""Default of ``gas.compressibility``: the paper's isothermal gas."""


def make_grid(config: CaseConfig) -> Grid:
    g = config.grid
    return Grid(nx=g.nx, nz=g.nz, Lx=g.Lx, Lz=g.Lz, periodic_x=g.periodic_x, geometry=g.geometry)


def gas_options(config: CaseConfig) -> dict[str, Any]:
    """Keywords of the pore-gas model for :class:`Model` (empty for the dry model)."""
    if config.gas.law == "none":
        return {}
    from granflow.physics.pore_pressure import GasLaw

    options: dict[str, Any] = {GAS_OPTION: GasLaw(config.gas.law)}
    for option, value, default in ((INJECTION_OPTION, config.gas.U_inj, 0.0),
                                   (OPEN_TOP_OPTION, config.gas.open_top, False),
                                   (COMPRESSIBILITY_OPTION, config.gas.compressibility, ISOTHERMAL)):
        if value != default:
            options[option] = value
    return options


def gas_problems(config: CaseConfig) -> list[tuple[str, str]]:
    """Load-time check of the ``[gas]`` section: injection and an open top need a gas law."""
    out = []
    if config.gas.law == "none":
        if config.gas.U_inj > 0:
            out.append(("gas.U_inj", 'gas injection needs gas.law = "linear" or "nonlinear"'))
        if config.gas.open_top:
            out.append(("gas.open_top", 'needs gas.law = "linear" or "nonlinear"'))
    if config.gas.compressibility != ISOTHERMAL and config.gas.law != "linear":
        out.append(("gas.compressibility", (f'"{config.gas.compressibility}" needs gas.law = "linear" '
                    f'(got "{config.gas.law}": the non-linear law is the isothermal state law itself)')))
    return out


def make_source(config: CaseConfig) -> Source | None:
    """The :class:`granflow.physics.inflow.Source` of ``[inflow]``, or None (``side = "none"``)."""
    f = config.inflow
    if f.side == "none":
        return None
    return Source(side=f.side, lower=f.lower, upper=f.upper,
                  phi=config.material.phi_max if f.phi is None else f.phi, speed=f.speed,
                  start=f.start, stop=math.inf if f.stop is None else f.stop)


def make_model(config: CaseConfig, **overrides: Any) -> Model:
    """The :class:`Model` of ``config``: grid, closure, gravity, walls, numerics, gas.

    ``overrides`` replace the keyword arguments of :class:`Model` built from the config (e.g.
    ``grid=`` a periodic grid, ``U_inj=`` one value per column [m s^-1]); a gas keyword
    (``U_inj``, ``open_top``) needs a gas law in ``[gas]``.
    """
    n, w = config.numerics, config.walls
    kwargs: dict[str, Any] = dict(
        grid=make_grid(config), closure=config.make_closure(), gravity=config.gravity_vector,
        bcs=VelocityBCs(west=w.west, east=w.east, bottom=w.bottom, top=w.top), eps=n.eps,
        ambient=n.ambient, picard=n.picard, delta_p=n.delta_p,
        interface_packing=n.interface_packing, phi_tolerance=n.phi_tolerance,
        consistent_gravity=n.consistent_gravity, advection=n.advection, phi_transport=n.phi_transport,
        gravity_blend_velocity=n.gravity_blend_velocity, linear_solver=n.linear_solver,
        isochoric_interface=n.isochoric_interface, surface=n.surface, base_friction=n.base_friction,
        momentum_theta=n.momentum_theta, wall_friction=w.wall_friction, source=make_source(config),
        topography=config.make_topography(), **gas_options(config))
    unknown = set(overrides) - set(inspect.signature(Model).parameters)
    if unknown:
        raise GranflowInputError(f"make_model: Model has no option(s) {sorted(unknown)}")
    if config.gas.law == "none" and {INJECTION_OPTION, OPEN_TOP_OPTION} & set(overrides):
        raise GranflowInputError('make_model: U_inj and open_top need gas.law = "linear" or "nonlinear"')
    kwargs.update(overrides)
    return Model(**kwargs)


def initial_state(model: Model, phi, b0: float = 0.0) -> State:
    """State at rest with the lithostatic pressure; with ``b0 > 0`` (gas models only) the pore
    pressure ``p_f = b0 p_lith`` carries that fraction of the weight (``p = p_lith - p_f``)."""
    if b0 == 0.0:
        return model.initial_state(phi)
    return model.initial_state(phi, p_f=b0 * model.lithostatic_pressure(phi))


def make_simulation(config: CaseConfig, model: Model, state: State) -> Simulation:
    """A :class:`Simulation` with the ``[time]`` options."""
    t = config.time
    return Simulation(model, state, stop_time=t.stop_time, cfl=t.cfl, dt_max=t.dt_max,
                      max_retries=t.max_retries, max_steps=t.max_steps)


def rectangle_fraction(grid: Grid, x0: float, x1: float, z0: float, z1: float) -> np.ndarray:
    """Fraction of each cell's area inside ``[x0, x1] x [z0, z1]`` [-], shape (nx, nz) (exact)."""
    fx = np.clip((np.minimum(grid.xf[1:], x1) - np.maximum(grid.xf[:-1], x0)) / grid.dx, 0.0, 1.0)
    fz = np.clip((np.minimum(grid.zf[1:], z1) - np.maximum(grid.zf[:-1], z0)) / grid.dz, 0.0, 1.0)
    return np.outer(fx, fz)


def packing(config: CaseConfig) -> float:
    """``setup.phi0``, or ``material.phi_max`` when not given [-]."""
    phi0 = getattr(config.setup, "phi0", None)
    return config.material.phi_max if phi0 is None else phi0


def packing_problems(config: CaseConfig) -> list[tuple[str, str]]:
    """``phi_c <= phi0 <= phi_max``."""
    phi0, m, a = packing(config), config.material, config.numerics.ambient
    out = []
    if phi0 > m.phi_max:
        out.append(("setup.phi0", f"{phi0} exceeds material.phi_max = {m.phi_max}"))
    if phi0 < a.phi_c:
        out.append(("setup.phi0", (f"{phi0} is below numerics.ambient.phi_c = {a.phi_c}: the grains "
                                   "would be treated as the pressureless ambient")))
    if not a.phi_c < m.phi_max:
        out.append(("numerics.ambient.phi_c", f"{a.phi_c} must be below material.phi_max = {m.phi_max}"))
    return out


def extent_problems(config: CaseConfig, key: str, size: float, axis: str) -> list[tuple[str, str]]:
    """A length ``size`` [m] along ``axis`` must span at least one cell and fit in the box."""
    g = config.grid
    length, cell = (g.Lx, g.Lx / g.nx) if axis == "x" else (g.Lz, g.Lz / g.nz)
    box = "grid.Lx" if axis == "x" else "grid.Lz"
    if size > length:
        return [(key, f"{size} m does not fit in the box ({box} = {length} m)")]
    if size < cell:
        return [(key, f"{size} m is smaller than one cell ({cell:.4g} m); refine the grid")]
    return []


def flat_base_problems(config: CaseConfig, case: str) -> list[tuple[str, str]]:
    """A case built on the box's flat base, in a plane, refuses a ``[topography]`` and an
    axisymmetric grid."""
    out = []
    if config.topography.x:
        out.append(("topography.x", f"{case} has the box's flat base; a base profile needs the "
                                    "column_collapse case (remove [topography])"))
    if config.grid.geometry != "plane":
        out.append(("grid.geometry", f'{case} is plane; "{config.grid.geometry}" needs the column_collapse case'))
    return out


AXISYMMETRIC_LIMITS = (
    ("topography.x", lambda c: bool(c.topography.x), "a base profile is not available (remove [topography])"),
    ("inflow.side", lambda c: c.inflow.side != "none", 'an inflow source is not available (inflow.side = "none")'),
    ("walls.east", lambda c: c.walls.east == "outflow", "an outflow wall is not available"),
    ("walls.bottom", lambda c: c.walls.bottom == "coulomb", 'a Coulomb base is not available ("no_slip" or "free_slip")'),
    ("walls.west", lambda c: c.walls.west != "free_slip", 'the west side is the axis: it must be "free_slip"'),
    ("gravity.slope_deg", lambda c: c.gravity.slope_deg != 0.0, "gravity must be vertical (slope_deg = 0)"),
    ("numerics.surface", lambda c: c.numerics.surface != "indicator", 'needs the "indicator" surface'),
    ("numerics.advection", lambda c: c.numerics.advection != "consistent", 'needs the "consistent" advection'),
    ("numerics.linear_solver", lambda c: c.numerics.linear_solver == "amg", 'the "amg" solver is not available'),
)
"""What an axisymmetric grid does not support yet: (key, test of the config, why)."""


def axisymmetric_problems(config: CaseConfig) -> list[tuple[str, str]]:
    """The keys of a case file that an axisymmetric grid refuses (:data:`AXISYMMETRIC_LIMITS`;
    the Model refuses the same, :mod:`granflow.model_geometry`)."""
    if config.grid.geometry != "axisymmetric":
        return []
    return [(key, f'grid.geometry = "axisymmetric": {why}') for key, bad, why in AXISYMMETRIC_LIMITS if bad(config)]


def column_on_base(grid: Grid, x0: float, x1: float, height: float, base: np.ndarray) -> np.ndarray:
    """Fraction of each cell's area inside ``[x0, x1] x [base_i, base_i + height]`` [-], shape
    (nx, nz): a rectangle of grains standing on the (staircase) base ``base`` [m] of each column
    (:func:`rectangle_fraction` on a flat base)."""
    fx = np.clip((np.minimum(grid.xf[1:], x1) - np.maximum(grid.xf[:-1], x0)) / grid.dx, 0.0, 1.0)
    lo, hi = np.asarray(base, dtype=float)[:, None], np.asarray(base, dtype=float)[:, None] + height
    fz = np.clip((np.minimum(grid.zf[None, 1:], hi) - np.maximum(grid.zf[None, :-1], lo)) / grid.dz, 0.0, 1.0)
    return fx[:, None] * fz
