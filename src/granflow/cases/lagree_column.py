"""Case ``lagree_column``: the dimensionless granular column collapse of Lagree, Staron & Popinet
(2011, J. Fluid Mech. 686, 378-408), issue 4 (and the reference case of the issue-3 benchmark).

Set-up (dimensionless units: length H0, time sqrt(H0/g), density rho = phi rho_s, so
H0 = g = rho = 1): a rectangular half column ``[0, L0] x [0, 1]``, ``L0 = 1/a``, at packing
``phi_max`` against a free-slip west wall (a symmetry plane: the full column is ``2 L0`` wide), in
a ``5 x 5`` box, no-slip base, released at t = 0 and followed to t = 4. The paper's aspect ratios
are a = 0.5, 1.42 (default) and 6.26; its mu(I) parameters mu_s = 0.32, Delta mu = 0.28, I0 = 0.4
are in the literature convention of the inertial number (I = d gamma_dot / sqrt(p / rho_s), GDR
MiDi 2004), which is granflow's ``c_I = 2`` (:class:`granflow.materials.InertialConvention`).

Two models (``setup.model``):

* ``"incompressible"``: the incompressible mu(I) reference closure of granflow (``f = 0``,
  ``Z = mu(I)``; the model of Lagree et al. 2011), ``mu1 = mu_s``, ``mu2 = mu_s + Delta mu``;
* ``"mu_i"``: the paper's mu(I) closure with its stabilising divergence law
  (Chupin & Dubois §6.2, closure ``mu_i``), with the linear equilibrium law
  ``phi_eq(I) = phi_max - delta_phi I``.

The case is self-contained: it builds the material (``d`` from ``setup.d``,
``rho_s = 1 / phi_max``, ``c_I = 2``), the closure and ``g = 1`` from ``[setup]`` and does not read
``[material]``, ``[closure]``, ``[equilibrium]``, ``gravity.g``, ``grid.Lx`` or ``grid.Lz``; a value
other than the common default in any of them is an error naming the ``setup`` key to use (to run
another closure on this geometry, use ``column_collapse``). Two numerical options of ``[numerics]``
carry physical units whose common defaults are meaningless here: ``numerics.delta_p`` (1 Pa) and
``numerics.ambient.rho_a`` (2 kg m^-3, heavier than the grains' rho = 1); unless set explicitly they
take :data:`DIMENSIONLESS_DELTA_P` and :data:`DIMENSIONLESS_RHO_A` (and ``numerics.ambient.eta_a``
:data:`DIMENSIONLESS_ETA_A`, Basilisk's ambient viscosity). Everything else (grid
resolution, walls, time, numerics, output) is read as usual.

Grain size. The default reproduces Basilisk's ``granular_column.c`` (the public counterpart of
Lagree et al. 2011; Basilisk's ``granular.h`` evaluates ``I = D gamma_dot / sqrt(p/rho)`` with the
*bulk* density ``rho = 1`` and ``D = 1/30``, and ``granular_column.c`` sets ``D = 1/65`` before its
a = 1.42 and 6.26 runs, none before its a = 0.5 run). granflow's inertial number is
``I = c_I d |S| / sqrt(p/rho_s)`` with the *grain* density ``rho_s = 1/phi_max`` and, in simple shear,
``c_I |S| = gamma_dot`` (c_I = 2), so the two agree when

    d = sqrt(phi_max) * D_basilisk                                   (d = 0.0119 for D = 1/65).

``setup.d_basilisk`` is D (default :func:`basilisk_grain_size`: 1/30 at a < 1, 1/65 otherwise);
``setup.d`` sets granflow's d directly instead (the case before scheme v2 used ``d = 1/40``,
an inertial number 2.1 times Basilisk's at a = 1.42: ``setup.d = 0.025``).
"""
from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from granflow import diagnostics as dg
from granflow.casekit import common
from granflow.casekit.common import flat_base_problems, make_simulation, rectangle_fraction
from granflow.casekit import headlines
from granflow.casekit.registry import CASES
from granflow.config import (
    DEFAULT_GRAVITY,
    CaseConfig,
    ClosureSection,
    EquilibriumSection,
    GridSection,
    MaterialSection,
    Section,
)
from granflow.grid import Grid
from granflow.materials import InertialConvention, Material
from granflow.model import Model
from granflow.rheology import make_closure
from granflow.simulation import Simulation, TimeInterval

H0 = 1.0
"""Initial column height: the length unit [H0]."""
GRAVITY = 1.0
"""Magnitude of gravity: the acceleration unit [g]."""
BULK_DENSITY = 1.0
"""phi_max rho_s: the density unit [rho]; rho_s = BULK_DENSITY / phi_max."""
DIMENSIONLESS_DELTA_P = 1.0e-3
"""``numerics.delta_p`` when not set [rho g H0]: about 1 Pa over the basal pressure
rho g H0 ~ 1.5 kPa of a 10 cm laboratory column (the ratio of the common default)."""
DIMENSIONLESS_RHO_A = 1.0e-3
"""``numerics.ambient.rho_a`` when not set [rho]: Basilisk's ``RHOF`` (granular.h), a light
ambient (1e-2 before scheme v2)."""
DIMENSIONLESS_ETA_A = 1.0e-4
"""``numerics.ambient.eta_a`` when not set [rho sqrt(g H0^3)]: Basilisk's ``mug`` (granular.h).
The common default 1e-3 is not negligible here: the ambient at rest beyond the velocity band
drags on the surface (t = 4 front at 256^2, a = 1.42, consistent transport: 2.480 with 1e-3,
2.598 with 1e-4)."""
FRONT_RECORD_INTERVAL = 1.0
"""Simulated time between the front records of the case [sqrt(H0/g)]."""
FRONT_TIMES = (1.0, 2.0, 3.0, 4.0)
"""Times at which ``case_diagnostics.front_at`` reports the front [sqrt(H0/g)]."""
FRONT_CALLBACK = "lagree_fronts"
"""Name of the callback that records the front (also its schedule key in checkpoints)."""
LAMBDA1_BAND = (1.2, 2.2)
"""Published planar run-out band (L_inf - L0)/L0 = lambda1 a for a < ~3 (Lube et al. 2005;
Lajeunesse et al. 2005; MODEL.md §7)."""
PAPER_ASPECT_RATIOS = (0.5, 1.42, 6.26)
"""The aspect ratios of Lagree et al. (2011)."""
BASILISK_DEFAULT_GRAIN = 1.0 / 30.0
"""``D`` of Basilisk's granular.h (used by granular_column.c for its a = 0.5 run) [H0]."""
BASILISK_COLUMN_GRAIN = 1.0 / 65.0
"""``D`` that granular_column.c sets for its a = 1.42 and a = 6.26 runs [H0]."""
BASILISK_DEFAULT_GRAIN_BELOW = 1.0
"""Aspect ratios below this take :data:`BASILISK_DEFAULT_GRAIN` (the file's a = 0.5 run)."""
PROFILE_STATIONS = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5)
"""Abscissae at which ``case_diagnostics.final_profile`` reports the deposit thickness [H0]."""
ModelChoice = Literal["incompressible", "mu_i"]


MAX_FRICTION = 10.0
"""Largest ``setup.mu_s`` and ``setup.delta_mu`` (friction coefficients; ``delta_mu = 1e300``
only failed the first linear solve, exit 1)."""

class LagreeColumnSetup(Section):
    """``[setup]`` of ``lagree_column`` (all lengths in units of H0)."""

    a: float = Field(1.42, gt=0, description="aspect ratio H0/L0 of the half column (Lagree et al. "
                     "2011: 0.5, 1.42, 6.26) [-]")
    d: float | None = Field(None, gt=0, lt=1, description="grain diameter in granflow's convention "
                            "(I = c_I d |S| / sqrt(p/rho_s)); default sqrt(phi_max) d_basilisk [H0]")
    d_basilisk: float | None = Field(None, gt=0, lt=1, description="grain diameter D of Basilisk's "
                                     "granular.h (I = D gamma_dot / sqrt(p/rho), bulk rho = 1); default "
                                     "1/30 for a < 1, 1/65 otherwise, as granular_column.c [H0]")
    model: ModelChoice = Field("incompressible", description='"incompressible" (reference mu(I), '
                               'div u = 0) or "mu_i" (the paper\'s mu(I) closure with dilatancy) [-]')
    mu_s: float = Field(0.32, gt=0, le=MAX_FRICTION, description="mu(0), static friction coefficient [-]")
    delta_mu: float = Field(0.28, gt=0, le=MAX_FRICTION, description="mu(inf) - mu(0) [-]")
    I0: float = Field(0.4, gt=0, description="inertial-number scale of mu(I), literature "
                      "convention c_I = 2 [-]")
    phi_max: float = Field(0.6, gt=0, lt=1, description="initial and maximum packing fraction; "
                           "rho_s = 1/phi_max [-]")
    delta_phi: float = Field(0.2, gt=0, lt=1, description="slope of phi_eq(I) = phi_max - "
                             'delta_phi I (model = "mu_i" only) [-]')
    Lx: float = Field(5.0, gt=0, description="box length (replaces grid.Lx) [H0]")
    Lz: float = Field(5.0, gt=0, description="box height (replaces grid.Lz) [H0]")


# --- the configuration ---------------------------------------------------------------------------
def _changed(section, default) -> list[str]:
    """Keys of ``section`` whose values differ from those of the default section."""
    now, ref = section.model_dump(), default.model_dump()
    return [k for k in sorted(set(now) | set(ref)) if now.get(k) != ref.get(k)]


def _grid_default(key: str) -> float:
    return GridSection.model_fields[key].default


def check(config: CaseConfig) -> list[tuple[str, str]]:
    """Options this case does not read must keep their common defaults; the column must fit."""
    s, g = config.setup, config.grid
    owned = "lagree_column is dimensionless (H0 = g = rho = 1) and sets this from [setup]"
    out = [(f"material.{k}", f"{owned}: use setup.d, setup.phi_max, setup.delta_phi")
           for k in _changed(config.material, MaterialSection())]
    use_model = (f'{owned}: use setup.model ("incompressible" or "mu_i"), setup.mu_s, setup.delta_mu, '
                 "setup.I0 (or the column_collapse case for another closure)")
    out += [(f"closure.{k}", use_model) for k in _changed(config.closure, ClosureSection())]
    out += [(f"equilibrium.{k}", f"{owned}: the linear law with setup.phi_max, setup.delta_phi")
            for k in _changed(config.equilibrium, EquilibriumSection())]
    if config.gravity.g != DEFAULT_GRAVITY:
        out.append(("gravity.g", f"{owned}: g = 1; remove gravity.g"))
    for key in ("Lx", "Lz"):
        if getattr(g, key) != _grid_default(key):
            out.append((f"grid.{key}", f"{owned}: use setup.{key} (in units of H0)"))
    if g.periodic_x:
        out.append(("grid.periodic_x", "a column collapse needs walls; set periodic_x = false"))
    if config.gas.law != "none":
        out.append(("gas.law", 'lagree_column is dry; use law = "none"'))
    if config.gas.compressibility != "isothermal":
        out.append(("gas.compressibility", "lagree_column is dry: no pore gas to make adiabatic"))
    L0, dx, dz = H0 / s.a, s.Lx / g.nx, s.Lz / g.nz
    if L0 >= s.Lx:
        out.append(("setup.a", f"L0 = 1/a = {L0:.4g} H0 leaves no room to spread (setup.Lx = {s.Lx})"))
    elif L0 < dx:
        out.append(("setup.a", f"L0 = 1/a = {L0:.4g} H0 is smaller than one cell ({dx:.4g} H0); refine grid.nx"))
    if H0 > s.Lz:
        out.append(("setup.Lz", f"{s.Lz} H0 is lower than the column (H0 = 1)"))
    elif H0 < dz:
        out.append(("grid.nz", f"H0 = 1 is smaller than one cell ({dz:.4g} H0); refine grid.nz"))
    if s.d is not None and s.d_basilisk is not None:
        out.append(("setup.d_basilisk", "give setup.d or setup.d_basilisk, not both"))
    if s.phi_max <= config.numerics.ambient.phi_c:
        phi_c = config.numerics.ambient.phi_c
        out.append(("setup.phi_max", f"{s.phi_max} must exceed numerics.ambient.phi_c = {phi_c}"))
    out += flat_base_problems(config, "lagree_column")
    return out


def basilisk_grain_size(a: float) -> float:
    """Basilisk's ``D`` for aspect ratio ``a`` as granular_column.c runs it [H0]:
    :data:`BASILISK_DEFAULT_GRAIN` below :data:`BASILISK_DEFAULT_GRAIN_BELOW`, else
    :data:`BASILISK_COLUMN_GRAIN`."""
    return BASILISK_DEFAULT_GRAIN if a < BASILISK_DEFAULT_GRAIN_BELOW else BASILISK_COLUMN_GRAIN


def grain_size(setup) -> float:
    """granflow's ``d`` [H0]: ``setup.d``, else ``sqrt(phi_max) D`` with ``D = setup.d_basilisk``
    or :func:`basilisk_grain_size` (module docstring: the same inertial number as Basilisk's)."""
    if setup.d is not None:
        return float(setup.d)
    D = setup.d_basilisk if setup.d_basilisk is not None else basilisk_grain_size(setup.a)
    return float(np.sqrt(setup.phi_max) * D)


def material(config: CaseConfig) -> Material:
    """The dimensionless material: ``d`` of :func:`grain_size`, ``rho_s = 1/phi_max`` (so rho = 1),
    ``c_I = 2``."""
    s = config.setup
    return Material(d=grain_size(s), rho_s=BULK_DENSITY / s.phi_max, phi_max=s.phi_max, delta_phi=s.delta_phi,
                    c_I=float(InertialConvention.LITERATURE))


def closure(config: CaseConfig):
    """The closure of ``setup.model`` with ``mu1 = mu_s``, ``mu2 = mu_s + delta_mu``, ``I0``."""
    s = config.setup
    mu = {"mu1": s.mu_s, "mu2": s.mu_s + s.delta_mu, "I0": s.I0}
    if s.model == "incompressible":
        return make_closure("incompressible", material=material(config), yield_law="mu_i", **mu)
    return make_closure("mu_i", material=material(config), equilibrium="linear",
                        equilibrium_params={"delta_phi": s.delta_phi}, **mu)


def numerics_used(config: CaseConfig) -> dict[str, float]:
    """``delta_p``, ``rho_a``, ``eta_a``, ``eps`` as used (dimensionless defaults when not set)."""
    n = config.numerics
    amb = n.ambient
    return {"delta_p": n.delta_p if "delta_p" in n.model_fields_set else DIMENSIONLESS_DELTA_P,
            "rho_a": amb.rho_a if "rho_a" in amb.model_fields_set else DIMENSIONLESS_RHO_A,
            "eta_a": amb.eta_a if "eta_a" in amb.model_fields_set else DIMENSIONLESS_ETA_A,
            "eps": n.eps}


def make_model(config: CaseConfig) -> Model:
    """The :class:`Model`: :func:`granflow.casekit.common.make_model` with the case's box,
    material, closure, g = 1 and the dimensionless numerics substitutes (:func:`numerics_used`);
    every other option from the config."""
    n, s = config.numerics, config.setup
    used = numerics_used(config)
    slope = np.radians(config.gravity.slope_deg)
    return common.make_model(
        config, grid=Grid(nx=config.grid.nx, nz=config.grid.nz, Lx=s.Lx, Lz=s.Lz),
        closure=closure(config), gravity=(GRAVITY * np.sin(slope), -GRAVITY * np.cos(slope)),
        ambient={**n.ambient.model_dump(), "rho_a": used["rho_a"], "eta_a": used["eta_a"]},
        delta_p=used["delta_p"])


# --- diagnostics ---------------------------------------------------------------------------------
def front_threshold(config: CaseConfig, grid) -> float:
    """Deposit thickness defining the front [H0]: ``output.front_threshold``, else one cell
    height (the rule of summary.json's ``front_position``)."""
    t = config.output.front_threshold
    return float(t) if t is not None else float(grid.dz)


class FrontRecorder:
    """Callback recording the front position every :data:`FRONT_RECORD_INTERVAL` (a restart
    loses the records made before it: their entries are then null)."""

    def __init__(self, threshold: float) -> None:
        self.threshold = threshold
        self.fronts: dict[float, float] = {}

    def __call__(self, sim: Simulation) -> None:
        m = sim.model
        self.fronts[round(sim.state.t, 9)] = dg.front_position(m.grid, sim.state.phi,
                                                               m.material.phi_max, self.threshold)


def _recorder(sim: Simulation) -> FrontRecorder | None:
    for cb in sim.callbacks:
        if cb.name == FRONT_CALLBACK:
            return cb.func
    return None


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def diagnostics(sim: Simulation, config: CaseConfig) -> dict[str, Any]:
    """Dimensionless run-out (x_f and (x_f - L0)/L0), fronts at t = 1, 2, 3, 4, final height at
    the wall and at :data:`PROFILE_STATIONS` (linear between cell centres), and the parameters
    actually used (units H0, sqrt(H0/g), rho)."""
    s, g = config.setup, sim.model.grid
    L0 = H0 / s.a
    thr = front_threshold(config, g)
    phi_max = sim.model.material.phi_max
    x_f = dg.front_position(g, sim.state.phi, phi_max, thr)
    rel = (x_f - L0) / L0
    rec = _recorder(sim)
    fronts = rec.fronts if rec is not None else {}
    return {
        "units": {"length": "H0", "time": "sqrt(H0/g)", "density": "rho = phi_max rho_s"},
        "model": s.model, "aspect_ratio": s.a, "H0": H0, "L0": L0, "d": grain_size(s),
        "d_basilisk": grain_size(s) / float(np.sqrt(s.phi_max)),
        "mu_s": s.mu_s, "delta_mu": s.delta_mu, "I0": s.I0, "c_I": float(InertialConvention.LITERATURE),
        "phi_max": s.phi_max, "delta_phi": s.delta_phi if s.model == "mu_i" else None,
        "front_threshold": thr,
        "runout": {"t": sim.state.t, "x_f": _finite(x_f), "relative": _finite(rel),
                   "lambda1": _finite(rel / s.a),
                   "published_lambda1_band": list(LAMBDA1_BAND)},
        "front_at": {f"{t:g}": _finite(fronts.get(round(t, 9), np.nan)) for t in FRONT_TIMES},
        "final_height_at_wall": float(dg.deposit_thickness(g, sim.state.phi, phi_max)[0]),
        "final_profile": {"x": list(PROFILE_STATIONS),
                          "h": [float(v) for v in np.interp(PROFILE_STATIONS, g.xc,
                                                            dg.deposit_thickness(g, sim.state.phi, phi_max))]},
        "numerics_used": numerics_used(config),
    }


@CASES.register("lagree_column", setup_model=LagreeColumnSetup, check=check, diagnostics=diagnostics,
                headline=headlines.lagree_column, settles=True,
                units={"length": "H0", "time": "sqrt(H0/g)", "speed": "sqrt(g H0)",
                       "pressure": "rho g H0", "rate": "sqrt(g/H0)", "energy": "rho g H0^3"},
                summary="dimensionless column collapse of Lagree, Staron & Popinet (2011), mu(I)")
def setup(config: CaseConfig) -> Simulation:
    """Model, initial state (at rest, lithostatic pressure ``p = 1 - z`` in the column) and stop
    criteria of the Lagree et al. (2011) column.

    Parameters
    ----------
    config : CaseConfig
        With ``case.name = "lagree_column"``.

    Returns
    -------
    Simulation
        With a callback ``lagree_fronts`` recording the front every unit of time.
    """
    s = config.setup
    model = make_model(config)
    g = model.grid
    phi = s.phi_max * rectangle_fraction(g, 0.0, H0 / s.a, 0.0, H0)
    sim = make_simulation(config, model, model.initial_state(phi))
    sim.add_callback(FrontRecorder(front_threshold(config, g)), TimeInterval(FRONT_RECORD_INTERVAL),
                     name=FRONT_CALLBACK)
    return sim
