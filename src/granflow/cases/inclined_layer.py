"""Case ``inclined_layer``: steady flow of a uniform layer down an infinite incline, dry or with a
base gas over-pressure (verification ladder item 3; MODEL.md §7, NUMERICS.md §11 item 3; issue 3
items 9c, 9d).

A layer ``0 <= z <= h0`` at packing ``phi0`` fills the whole width of a grid that is ALWAYS
periodic in x (an infinite incline: ``grid.periodic_x`` may be left out; ``false`` is an error),
under the tilted gravity ``g (sin theta, -cos theta)``, ``theta = gravity.slope_deg``, with the
no-slip base of ``walls.bottom`` and the pressureless ambient above. It starts at rest
(``setup.start = "rest"``) or with the exact Bagnold velocity profile (``"bagnold"``, mu(I) only).

Fluidised chute (``setup.beta > 0``, needs ``[gas] law``): the base injects gas at
``U = beta U_mf``, ``U_mf = kappa(phi) phi rho_s g cos(theta)`` (Carman-Kozeny kappa at the packing
of the steady flow), and ``p_f = 0`` at the bed surface, so the steady pore pressure is
``p_f = U (h - z)/kappa = beta`` x lithostatic; the initial p_f is that profile. The case sets
``U_inj`` itself (``gas.U_inj`` must stay 0).

Reference (``closure.name = "mu_i"``; written from MODEL.md §3, §7, independent of the solver):
the stress ratio of a steady uniform layer is ``tan(theta)`` at every depth, and the gas carries
``beta`` of the weight, so ``mu(I_theta) = tan(theta)/(1 - beta)``:
``I_theta = I0 (mu - mu1)/(mu2 - mu)`` (needs ``mu1 < mu < mu2``, checked at load time),
``phi = phi_eq(I_theta)`` uniform, ``p = (1 - beta) phi rho_s g cos(theta) (h - z)``, and with
``I = c_I d |S|/sqrt(p/rho_s)``, ``|S| = |du/dz|/2`` the Bagnold profile

    u(z) = (4 I_theta / (3 c_I d)) sqrt((1 - beta) phi g cos(theta)) [h^(3/2) - (h - z)^(3/2)],

with the steady thickness ``h = h0 phi0 / phi_eq(I_theta)`` (mass); the one definition of that
state is :class:`granflow.verification.bagnold.BagnoldLayer` (``Bagnold`` here). Other closures run, without a
reference (with Drucker-Prager a steady uniform flow exists only at tan(theta) = sin(delta)).

Numerics. The defaults (scheme v2: indicator surface, consistent momentum transport) match
Bagnold within 1 % at 20 and 40 cells over h, from rest or from the exact profile, dry and
fluidised, 22-28 deg (validation/inclined_plane/README.md); the v1 threshold surface needed four
non-default surface options (``run.V1_OPTIONS`` there). The Model is
:func:`granflow.casekit.common.make_model` on the periodic grid (:func:`make_inclined_model`).

Diagnostics: the surface velocity ``u_s`` (the u of the top row of x-faces, mean over x: the
stress-free ambient moves with the surface) against Bagnold's, the profile error, phi against
phi_eq(I_theta), the basal p_f ratio (fluidised), and a steady-state indicator: the relative change
of u_s over the last output interval (``u_surface_record`` holds u_s at every output time).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import Field

from granflow.casekit.common import (
    flat_base_problems,
    extent_problems,
    gas_problems,
    make_model,
    make_simulation,
    packing_problems,
    rectangle_fraction,
)
from granflow.casekit import headlines
from granflow.casekit.registry import CASES
from granflow.config import CaseConfig, Section
from granflow.grid import Grid
from granflow.model import Model
from granflow.simulation import Simulation, TimeInterval
from granflow.verification.bagnold import BagnoldLayer as Bagnold
from granflow.verification.bagnold import steady_inertial_number

CASE = "inclined_layer"
REFERENCE_CLOSURE = "mu_i"
"""The closure with a steady uniform (Bagnold) solution."""
SURFACE_RECORD = f"{CASE}:surface_velocity"
"""Name of the callback recording u_s at the output times."""
STEADY_TOL = 1e-3
"""Relative change of u_s over the last output interval below which the flow counts as steady."""
LOWER_FRACTION = 0.75
"""phi and p_f errors are also taken over the cells below this fraction of h (the surface cells
are looser, validation/inclined_plane/README.md)."""


class InclinedLayerSetup(Section):
    """``[setup]`` of ``inclined_layer``."""

    h0: float = Field(0.05, gt=0, description="initial layer thickness [m]")
    phi0: float | None = Field(None, gt=0, lt=1, description="initial packing fraction (default: "
                               "phi_eq(I_theta) with start = \"bagnold\", else material.phi_max) [-]")
    beta: float = Field(0.0, ge=0, lt=1, description="base gas over-pressure as a fraction of the "
                        "lithostatic pressure (needs [gas]; fluidised chute) [-]")
    start: Literal["rest", "bagnold"] = Field(
        "rest", description='initial velocity: "rest" or "bagnold" (the exact steady profile; '
        'closure mu_i only) [-]')


def effective_friction(config: CaseConfig) -> float:
    """``tan(theta)/(1 - beta)`` [-]: the friction coefficient of the steady flow."""
    return math.tan(math.radians(config.gravity.slope_deg)) / (1.0 - config.setup.beta)


def theta_inertial_number(config: CaseConfig) -> float | None:
    """``I_theta`` with ``mu(I_theta) = tan(theta)/(1 - beta)`` (mu_i only; None outside
    ``(mu1, mu2)`` or for another closure)."""
    if config.closure.name != REFERENCE_CLOSURE:
        return None
    c = config.make_closure()
    mu = effective_friction(config)
    if not c.mu1 < mu < c.mu2:
        return None
    return steady_inertial_number(mu, c.mu1, c.mu2, c.I0)


def initial_packing(config: CaseConfig) -> float:
    """``setup.phi0``, else phi_eq(I_theta) for a Bagnold start, else material.phi_max [-]."""
    s = config.setup
    if s.phi0 is not None:
        return s.phi0
    inertial = theta_inertial_number(config)
    if s.start == "bagnold" and inertial is not None:
        return float(config.make_closure().equilibrium.phi_eq(inertial))
    return config.material.phi_max


def bagnold(config: CaseConfig) -> Bagnold | None:
    """The reference steady state, or None without one."""
    inertial = theta_inertial_number(config)
    if inertial is None:
        return None
    c = config.make_closure()
    phi = float(c.equilibrium.phi_eq(inertial))
    h = config.setup.h0 * initial_packing(config) / phi
    return Bagnold(theta=math.radians(config.gravity.slope_deg), beta=config.setup.beta, I=inertial,
                   phi=phi, h=h, c_I=c.material.c_I, d=c.material.d, g=config.gravity.g)


def flow_packing(config: CaseConfig) -> float:
    """Packing of the steady flow (phi_eq(I_theta), or phi0 without a reference) [-]."""
    ref = bagnold(config)
    return ref.phi if ref is not None else initial_packing(config)


def injection_velocity(config: CaseConfig) -> float:
    """``beta U_mf = beta kappa(phi) phi rho_s g cos(theta)`` [m s^-1] at the flow packing."""
    phi = flow_packing(config)
    mat = config.make_closure().material
    return (config.setup.beta * float(mat.permeability(phi)) * phi * mat.rho_s
            * abs(config.gravity_vector[1]))


def _layer_problem(config: CaseConfig) -> list[tuple[str, str]]:
    s, g = config.setup, config.grid
    dz = g.Lz / g.nz
    ref = bagnold(config)
    top = max(s.h0, ref.h if ref is not None else s.h0)
    if top > g.Lz - dz:
        return [("setup.h0", (f"the layer (up to {top:.4g} m) must leave at least one ambient cell "
                             f"below the lid (grid.Lz - dz = {g.Lz - dz:.4g} m)"))]
    return []


def check(config: CaseConfig) -> list[tuple[str, str]]:
    s = config.setup
    out = packing_problems(config) + gas_problems(config)
    out += extent_problems(config, "setup.h0", s.h0, "z")
    if "periodic_x" in config.grid.model_fields_set and not config.grid.periodic_x:
        out.append(("grid.periodic_x", (f"{CASE} is an infinite incline: periodic in x (true, or "
                                       "leave it out)")))
    for side in ("west", "east"):
        if getattr(config.walls, side) != "free_slip":
            out.append((f"walls.{side}", "no side walls on the periodic incline (leave the default)"))
    if config.closure.name == REFERENCE_CLOSURE:
        c = config.make_closure()
        mu = effective_friction(config)
        if not c.mu1 < mu < c.mu2:
            tan_theta = math.tan(math.radians(config.gravity.slope_deg))
            key = "setup.beta" if mu >= c.mu2 > tan_theta else "gravity.slope_deg"
            out.append((key, (f"tan(theta)/(1 - beta) = {mu:.4g} is outside (closure.mu1, closure.mu2) = "
                              f"({c.mu1:.4g}, {c.mu2:.4g}): no steady uniform flow (at rest below mu1, "
                              "accelerating above mu2)")))
        else:
            phi_eq = float(c.equilibrium.phi_eq(c.I0 * (mu - c.mu1) / (c.mu2 - mu)))
            if not phi_eq > 0.0:
                key = "setup.beta" if s.beta > 0 else "gravity.slope_deg"
                out.append((key, (f"tan(theta)/(1 - beta) = {mu:.4g} gives I_theta = "
                                  f"{steady_inertial_number(mu, c.mu1, c.mu2, c.I0):.4g} and phi_eq(I_theta) = "
                                  f"{phi_eq:.4g} <= 0: no steady packing (lower it, or raise "
                                  "material.phi_max / lower material.delta_phi)")))
    elif s.start == "bagnold":
        out.append(("setup.start", (f'"bagnold" needs closure.name = "{REFERENCE_CLOSURE}" (got '
                                   f'{config.closure.name!r})')))
    if s.beta > 0:
        if config.gas.law == "none":
            out.append(("setup.beta", f'beta = {s.beta} > 0 needs gas.law = "linear" or "nonlinear"'))
        if config.gas.U_inj != 0.0:
            out.append(("gas.U_inj", "the case sets the injection from setup.beta; leave gas.U_inj = 0"))
    if not any(key.startswith("setup.h0") for key, _ in out):
        out += _layer_problem(config)
    out += flat_base_problems(config, CASE)
    return out


def make_inclined_model(config: CaseConfig) -> Model:
    """The Model of :func:`granflow.casekit.common.make_model` on the periodic grid, with the base
    injection of ``setup.beta``."""
    g, s = config.grid, config.setup
    grid = Grid(nx=g.nx, nz=g.nz, Lx=g.Lx, Lz=g.Lz, periodic_x=True)
    extra = {"U_inj": injection_velocity(config)} if s.beta > 0 else {}
    return make_model(config, grid=grid, **extra)


def surface_velocity(sim: Simulation) -> float:
    """Largest row mean of u [m s^-1]: the surface speed of a layer sheared from its base (the
    ambient above is carried at most at the surface's speed, and is at rest beyond the velocity
    band, so the top row of the box is not always it)."""
    u, _ = sim.model.grid.unpack_velocity(sim.state.vel)
    return float(np.max(np.mean(u[:-1, :], axis=0)))


@dataclass
class SurfaceRecord:
    """u_s at times ``t`` [s]; a :class:`Simulation` callback."""

    t: list = field(default_factory=list)
    u: list = field(default_factory=list)

    def __call__(self, sim: Simulation) -> None:
        self.t.append(float(sim.state.t))
        self.u.append(surface_velocity(sim))


def _record(sim: Simulation) -> SurfaceRecord | None:
    for cb in sim.callbacks:
        if cb.name == SURFACE_RECORD and isinstance(cb.func, SurfaceRecord):
            return cb.func
    return None


def diagnostics(sim: Simulation, config: CaseConfig) -> dict[str, Any]:
    """Surface velocity, profile, packing and p_f against the Bagnold state; steadiness."""
    s, model = config.setup, sim.model
    g, st = model.grid, sim.state
    u_s = surface_velocity(sim)
    out: dict[str, Any] = {"theta_deg": config.gravity.slope_deg, "beta": s.beta, "h0_m": s.h0,
                           "phi0": initial_packing(config), "start": s.start,
                           "gravity_blend_velocity_m_s": model.blend_velocity(config.time.dt_max),
                           "u_surface_m_s": u_s, "injection_m_s": injection_velocity(config)}
    rec = _record(sim)
    if rec is not None:
        out["u_surface_record"] = {"t_s": rec.t, "u_m_s": rec.u}
        if len(rec.u) >= 2 and rec.u[-1] != 0.0:
            drift = abs(rec.u[-1] - rec.u[-2]) / abs(rec.u[-1])
            out.update({"steady_drift_rel": drift, "steady_window_s": rec.t[-1] - rec.t[-2],
                        "steady": bool(drift <= STEADY_TOL)})
    ref = bagnold(config)
    if ref is None:
        out["reference"] = None
        return out
    zc = g.zc
    layer = zc < ref.h
    lower = zc < LOWER_FRACTION * ref.h
    u, _ = g.unpack_velocity(st.vel)
    u_ref = ref.surface_velocity
    phi_layer = st.phi[:, layer]
    out.update({
        "reference": "Bagnold profile of the steady mu(I) layer, mu(I) = tan(theta)/(1 - beta)",
        "I_theta": ref.I, "phi_eq": ref.phi, "h_m": ref.h, "u_surface_bagnold_m_s": u_ref,
        "u_surface_rel_error": u_s / u_ref - 1.0,
        "profile_max_error_rel": float(np.max(np.abs(u[:-1, layer] - ref.velocity(zc[layer]))) / u_ref),
        "phi_median_error": float(np.median(phi_layer) - ref.phi),
        "phi_max_error_lower": float(np.max(np.abs(st.phi[:, lower] - ref.phi))) if lower.any() else None,
    })
    if s.beta > 0:
        p_lith = ref.phi * model.material.rho_s * abs(model.gravity[1]) * (ref.h - zc[lower])
        out["p_f_max_error_rel"] = (float(np.max(np.abs(st.p_f[:, lower] - s.beta * p_lith)))
                                    / (s.beta * float(p_lith.max()))) if lower.any() else None
    return out


@CASES.register(CASE, setup_model=InclinedLayerSetup, check=check, diagnostics=diagnostics,
                headline=headlines.inclined_layer,
                summary="uniform layer on an infinite incline (periodic x): steady Bagnold flow, dry or fluidised")
def setup(config: CaseConfig) -> Simulation:
    """Periodic Model (tilted gravity, optional base injection), the layer at rest or with the
    Bagnold profile, and the surface-velocity recorder (every ``output.interval``)."""
    s = config.setup
    model = make_inclined_model(config)
    g = model.grid
    phi = initial_packing(config) * rectangle_fraction(g, 0.0, g.Lx, 0.0, s.h0)
    state = model.initial_state(phi, p_f=s.beta * model.lithostatic_pressure(phi)) if s.beta > 0 \
        else model.initial_state(phi)
    ref = bagnold(config)
    if s.start == "bagnold" and ref is not None:
        u = ref.velocity(g.xface_coords()[1])
        state.vel = g.pack_velocity(u, np.zeros(g.zface_shape))
    sim = make_simulation(config, model, state)
    sim.add_callback(SurfaceRecord(), TimeInterval(config.output.interval), name=SURFACE_RECORD)
    return sim
