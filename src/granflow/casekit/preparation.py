"""Gas-injection preparation of a column (issue 4 item 1, option b): the column is fluidised as in
the experiments before the gate opens.

In the experiments of Roche et al. (2002, 2004) and Roche (2012) the bed of fine glass beads rests
in a reservoir closed by a gate; gas is injected through the reservoir's porous base at a set
superficial velocity (about the minimum fluidisation velocity U_mf) until the bed is steady
(expanded, pore pressure about lithostatic); then the gate opens and the gas supply is stopped.
:func:`prepare` reproduces that procedure with the model itself:

1. a separate simulation of the column alone, on a grid of width ``L0`` (a whole number of cells
   of the collapse grid, same ``dx``, ``dz`` and height ``Lz``), closed by walls on both sides
   (the gate, east, is :data:`GATE_WALL`), with the same closure, material, numerics and gas law,
   the column ``[0, L0] x [0, H0]`` at ``phi0`` at rest with ``p_f = 0``, and the superficial
   velocity ``U_prep`` injected through its whole base (Neumann ``-kappa dp_f/dz = U_prep``,
   :mod:`granflow.physics.pore_pressure`);
2. it runs until steady (:class:`SteadyCriterion`: the largest granular speed -- or, for an
   over-fluidised bed that never comes to rest, the drift of its height -- AND the largest
   ``|dp_f/dt|`` below stated thresholds, continuously over one gas time ``tau_1``) or until the
   maximum preparation time, whichever comes first -- never longer; whether the steady state was
   reached is reported, not assumed. Above U_mf the bed expands to the homogeneous packing of
   :mod:`granflow.theory.fluidisation` in the kinematic-wave time ``t_s`` (seconds for a 10 cm
   bed: a physical time, not a numerical creep), and may then turn unstable (bubbling);
3. its ``phi``, ``p`` and ``p_f`` are copied into the columns ``x < L0`` of the collapse grid
   (ambient elsewhere, velocity zero) by :func:`released_state`.

Minimum fluidisation velocity (:func:`minimum_fluidisation_velocity`). The model's Darcy law
(paper eqs ``darcy``, ``beta``; MODEL.md §1-2; :mod:`granflow.physics.pore_pressure`) is
``q = -kappa(phi) grad p_f`` with the MOBILITY ``kappa = d^2 (1-phi)^3 / (150 eta_f phi^2)``
[m^2 Pa^-1 s^-1] (:meth:`granflow.materials.Material.permeability`; the gas viscosity is already
inside kappa: kappa = k/eta_f with the Carman-Kozeny permeability k [m^2]), and ``q`` is the
superficial gas velocity relative to the grains. The momentum equation (syst3b) has no gas
buoyancy, so the bed is fluidised when the gas pressure gradient carries the whole weight,
``-dp_f/dz = phi rho_s |g_z|``: ``U_mf = kappa(phi) phi rho_s |g_z|`` [m s^-1] (the textbook
Carman-Kozeny U_mf with (rho_s - rho_f) -> rho_s, since rho_f / rho_s ~ 5e-4). A uniform bed
under ``U < U_mf`` keeps the steady profile ``p_f = U (H - z)/kappa``, i.e. ``U/U_mf`` times the
lithostatic pressure.
"""
from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from granflow.casekit.common import make_model, packing, rectangle_fraction
from granflow.config import MAX_STEPS, CaseConfig, GasSection, GridSection, WallsSection
from granflow.errors import GranflowInputError
from granflow.grid import MIN_CELLS
from granflow.model import Model
from granflow.simulation import IterationInterval, Simulation, StepFailure
from granflow.state import State
from granflow.theory import fluidisation as fluid
from granflow.theory.fluidisation import minimum_fluidisation_velocity  # noqa: F401  (re-exported)

GATE_WALL = "free_slip"
"""Velocity condition of the gate (east wall of the preparation grid) [-]: a smooth gate."""
DEFAULT_U_PREP_OVER_UMF = 1.0
"""``setup.U_prep_over_Umf`` when not given: the experiments are fluidised at about U_mf [-]."""
DEFAULT_PREP_MAX_TIME = 1.0
"""``setup.prep_max_time`` when not given [s] (20 gas times tau_1 of a 10 cm bed of 70 um beads)."""
PF_STEADY_TOL = 1.0e-3
"""p_f is steady when ``max |dp_f/dt| tau_1 <= PF_STEADY_TOL p_lith,base``: the slowest gas mode
decays as ``exp(-t/tau_1)``, so this bounds ``|p_f - p_f,steady|`` by ~1e-3 of the basal
lithostatic pressure [-]."""
REST_SPEED_FACTOR = 1.0e-3
"""The bed is at rest when its largest granular face speed is below ``REST_SPEED_FACTOR`` times the
model's creep velocity scale :attr:`Model.gravity_blend_velocity` [-] (eps Lz by default, then
7.5e-7 m/s; ``numerics.gravity_blend_velocity`` changes it). A bed under U < U_mf has speeds
~1e-13 m/s; an over-fluidised one (U > U_mf, or the non-linear law at U_mf, whose top exceeds
U_mf as the gas expands) rises at U - U_mf(phi0) until expanded, then keeps grid-scale packing
fluctuations at ~1e-4 m/s: it is judged on its height drift (:data:`HEIGHT_DRIFT_TOL`)."""
HEIGHT_DRIFT_TOL = 1.0e-3
"""An expanded (over-fluidised) bed is quiet when its height drifts by less than this fraction of
the kinematic-wave crossing time's worth: ``|dh/dt| <= HEIGHT_DRIFT_TOL c(phi0)``, with
``c = -phi dU_mf/dphi`` the speed of the bed's continuity waves
(:func:`granflow.theory.fluidisation.kinematic_wave_speed`, 26 mm/s for 70 um beads). Over the
time ``H/c`` a packing perturbation takes to leave the bed, the remaining drift changes the
height, and the mean packing, by at most ~1e-3 of their values [-]. The rise of the bed before
the fluidisation front reaches its surface, ``U - U_mf(phi0)``, exceeds this limit by far
(0.05 c at 1.3 U_mf) for any U above 1.01 U_mf; below that the whole expansion is < 1e-3."""
STEADY_WINDOW_TAU = 1.0
"""Both criteria must hold continuously over this many gas times tau_1 [-]."""
MIN_STEADY_STEPS = 3
"""... and over at least this many accepted steps [-]."""
TAU_1_FACTOR = 4.0 / math.pi**2
"""tau_1 = TAU_1_FACTOR H^2 / D: slowest mode of gas diffusion in a bed of height H, impermeable
base, p_f = 0 at the surface (MODEL.md §7), D = p_atm kappa/(1 - phi) [-]."""
CELL_TOL = 1.0e-9
"""Relative tolerance on ``L0`` being a whole number of cells [-]."""


class Preparation(StrEnum):
    """Values of ``setup.preparation``."""

    NONE = "none"
    INJECTION = "injection"


class KeepInjection(StrEnum):
    """Values of ``setup.keep_injection``: where the gas keeps being injected at ``U_prep``
    after the gate opens."""

    NONE = "none"
    """The supply stops when the gate opens (the experiments)."""
    RESERVOIR = "reservoir"
    """Through the reservoir's porous base, ``x < L0``."""
    BASE = "base"
    """Through the whole base."""


# --- physics ---------------------------------------------------------------------------------------
def gas_time(material, phi: float, height: float) -> float:
    """Slowest gas-diffusion time ``tau_1 = 4 H^2 / (pi^2 D)`` [s] of a bed of ``height`` [m],
    ``D = p_atm kappa(phi)/(1 - phi)`` (MODEL.md §6.7, §7)."""
    return TAU_1_FACTOR * height**2 / float(material.gas_diffusivity(phi))


def injection_velocity(config: CaseConfig) -> tuple[float, float]:
    """``(U_prep, U_mf)`` [m s^-1] of a case: ``U_mf`` at ``phi0`` and the base-normal gravity."""
    s = config.setup
    ratio = DEFAULT_U_PREP_OVER_UMF if s.U_prep_over_Umf is None else s.U_prep_over_Umf
    u_mf = minimum_fluidisation_velocity(config.make_closure().material, packing(config),
                                         config.gravity_vector[1])
    return ratio * u_mf, u_mf


def reservoir_cells(config: CaseConfig) -> int:
    """Number of cells across ``L0`` (the gate is the face ``x = L0``)."""
    return round(config.setup.L0 / (config.grid.Lx / config.grid.nx))


def preparation_problems(config: CaseConfig) -> list[tuple[str, str]]:
    """Load-time checks of the preparation options (``setup.preparation`` and its companions)."""
    s = config.setup
    out = []
    if s.preparation == Preparation.NONE:
        for key, value, off in (("U_prep_over_Umf", s.U_prep_over_Umf, None),
                                ("prep_max_time", s.prep_max_time, None),
                                ("keep_injection", s.keep_injection, KeepInjection.NONE)):
            if value != off:
                out.append((f"setup.{key}", f'needs setup.preparation = "{Preparation.INJECTION}"'))
        return out
    max_time = DEFAULT_PREP_MAX_TIME if s.prep_max_time is None else s.prep_max_time
    if max_time / config.time.dt_max > MAX_STEPS:  # the preparation has no time.max_steps
        out.append(("time.dt_max", f"the injection preparation of up to {max_time:g} s (setup.prep_max_time) "
                                   f"needs {max_time / config.time.dt_max:.3g} steps of dt_max = "
                                   f"{config.time.dt_max:g} s at least, more than the step budget of "
                                   f"{MAX_STEPS} (granflow.config.MAX_STEPS); raise time.dt_max"))
    if config.gas.law == "none":
        out.append(("setup.preparation", (f'"{Preparation.INJECTION}" injects gas through the base: it '
                    'needs gas.law = "linear" or "nonlinear"')))
    if s.b0 > 0:
        out.append(("setup.b0", (f'the pore pressure comes from setup.preparation = "{s.preparation}"; '
                    "set b0 = 0")))
    if config.gas.U_inj > 0:
        out.append(("gas.U_inj", (f'with setup.preparation = "{s.preparation}" the injection is '
                    "setup.U_prep_over_Umf, and setup.keep_injection after the gate opens; set U_inj = 0")))
    dx = config.grid.Lx / config.grid.nx
    n = reservoir_cells(config)
    if abs(s.L0 - n * dx) > CELL_TOL * s.L0:
        out.append(("setup.L0", (f"{s.L0} m: with a preparation the gate is a cell face, so L0 must be "
                    f"a whole number of cells (dx = {dx:.6g} m; nearest {max(n, 1) * dx:.6g} m)")))
    elif n < MIN_CELLS:
        out.append(("setup.L0", (f"{s.L0} m: the preparation needs at least {MIN_CELLS} cells across "
                    f"the reservoir (dx = {dx:.6g} m)")))
    return out


# --- the preparation run ---------------------------------------------------------------------------
@dataclass
class SteadyCriterion:
    """Steady when the bed is quiet and ``max |dp_f/dt| <= pf_rate`` at every accepted step over
    the last ``window`` seconds (and at least :data:`MIN_STEADY_STEPS` steps).

    Quiet: ``max speed <= rest_speed`` (a bed at rest, U <= U_mf), or, with ``drift_rate`` given,
    the height drift ``|h(t) - h(t - window)| / window <= drift_rate`` (an over-fluidised bed:
    frictionless, p = 0, its packing fluctuates at the grid scale at ~1e-4 m/s for ever, so
    it is never at rest, but its height, the mass-weighted mean of its packing, stops).

    Attributes
    ----------
    rest_speed : float
        [m s^-1], :data:`REST_SPEED_FACTOR` x :attr:`Model.gravity_blend_velocity`.
    pf_rate : float
        [Pa s^-1], :data:`PF_STEADY_TOL` p_lith,base / tau_1.
    window : float
        [s], :data:`STEADY_WINDOW_TAU` tau_1.
    drift_rate : float or None
        [m s^-1], :data:`HEIGHT_DRIFT_TOL` x the kinematic-wave speed, for U > U_mf; None: the
        speed criterion alone.
    """

    rest_speed: float
    pf_rate: float
    window: float
    drift_rate: float | None = None
    since: float | None = None
    steps: int = 0
    steady: bool = False
    last_speed: float = math.inf
    last_rate: float = math.inf
    last_drift: float = math.inf
    """Height drift rate over the last window [m s^-1] (inf until the run spans a window)."""
    _p_f: np.ndarray | None = field(default=None, repr=False)
    _t: float = 0.0
    _heights: deque = field(default_factory=deque, repr=False)

    def __call__(self, sim: Simulation) -> None:
        """Callback run after every accepted step (and once at the start)."""
        st, model = sim.state, sim.model
        if self.drift_rate is not None:
            self._track_height(st.t, bed_height(model.grid, st.phi))
        if self._p_f is not None and st.t > self._t:
            self.last_rate = float(np.max(np.abs(st.p_f - self._p_f))) / (st.t - self._t)
            self.last_speed = granular_speed(model, st)
            quiet = self.last_speed <= self.rest_speed or (
                self.drift_rate is not None and self.last_drift <= self.drift_rate)
            if quiet and self.last_rate <= self.pf_rate:
                self.since = self._t if self.since is None else self.since
                self.steps += 1
                if st.t - self.since >= self.window and self.steps >= MIN_STEADY_STEPS:
                    self.steady = True
                    sim.request_stop("preparation steady")
            else:
                self.since, self.steps = None, 0
        self._p_f, self._t = st.p_f.copy(), st.t

    def _track_height(self, t: float, h: float) -> None:
        """Keep ``(t, h)`` back to the newest sample at least ``window`` old; update ``last_drift``."""
        hs = self._heights
        hs.append((t, h))
        while len(hs) > 1 and t - hs[1][0] >= self.window:
            hs.popleft()
        t_old, h_old = hs[0]
        if t - t_old >= self.window:
            self.last_drift = abs(h - h_old) / (t - t_old)


def bed_height(grid, phi) -> float:
    """Mean over the columns of twice the height of the bed's centre of mass [m] (the height of
    the uniform bed with the same mass and potential energy; :meth:`PreparationResult.bed_profile`)."""
    column = phi.sum(axis=1) * grid.dz
    centroid = (phi * grid.zc[None, :]).sum(axis=1) * grid.dz / column
    return float((2.0 * centroid).mean())


@dataclass(frozen=True)
class PreparationResult:
    """Outcome of :func:`prepare` (the entries of :meth:`diagnostics` go to ``summary.json``)."""

    state: State
    """Final state on the preparation grid."""
    model: Model
    """The preparation model (grid of width L0)."""
    U_prep: float
    """Injected superficial velocity [m s^-1]."""
    U_mf: float
    """Minimum fluidisation velocity at phi0 [m s^-1]."""
    tau_1: float
    """Gas time of the initial bed [s]."""
    steady: bool
    """Both steady criteria held over the window before ``prep_max_time``."""
    max_speed: float
    """Largest granular speed at the end [m s^-1]."""
    pf_rate: float
    """Largest |dp_f/dt| over the last step [Pa s^-1]."""
    rejected: int
    wall_s: float
    height_drift: float = math.inf
    """Height drift rate over the last steady window [m s^-1] (inf if the run is shorter)."""
    drift_limit: float = math.inf
    """The quiet limit of the height drift, :data:`HEIGHT_DRIFT_TOL` x c(phi0) [m s^-1]."""
    phi_expected: float = math.nan
    """Steady homogeneous packing of the model at U_prep
    (:func:`granflow.theory.fluidisation.expanded_packing`) [-]."""
    expansion_time: float = math.nan
    """Predicted time to reach it (:func:`granflow.theory.fluidisation.expansion_time`) [s]."""

    def bed_profile(self) -> tuple[float, float, float]:
        """``(height, mean phi, basal p_f / lithostatic)`` of the prepared bed, column means.

        ``height`` [m] is twice the height of the bed's centre of mass (the height of the uniform
        bed with the same mass and potential energy: exact for a uniform bed, insensitive to the
        smeared surface cell); ``mean phi`` is the mass per unit area over that height.
        """
        g, st = self.model.grid, self.state
        column = st.phi.sum(axis=1) * g.dz
        centroid = (st.phi * g.zc[None, :]).sum(axis=1) * g.dz / column
        height = 2.0 * centroid
        lith = self.model.lithostatic_pressure(st.phi)[:, 0]
        return (float(height.mean()), float((column / height).mean()),
                float(np.mean(st.p_f[:, 0] / lith)))

    def diagnostics(self) -> dict[str, Any]:
        height, phi_mean, basal = self.bed_profile()
        return {"prep_time_s": self.state.t, "prep_steps": self.state.step,
                "prep_rejected_steps": self.rejected, "prep_steady": self.steady,
                "prep_wall_s": self.wall_s, "prep_tau1_s": self.tau_1,
                "prep_bed_height_m": height, "prep_phi_mean": phi_mean,
                "prep_basal_pf_over_lithostatic": basal,
                "prep_max_speed_m_s": self.max_speed, "prep_pf_rate_Pa_s": self.pf_rate,
                "U_prep_m_s": self.U_prep, "U_mf_m_s": self.U_mf,
                "U_prep_over_Umf": self.U_prep / self.U_mf,
                "prep_height_drift_m_s": self.height_drift, "prep_height_drift_limit_m_s": self.drift_limit,
                "prep_phi_expected": self.phi_expected,
                "prep_phi_error": phi_mean / self.phi_expected - 1.0,
                "prep_expansion_time_s": self.expansion_time}


def granular_speed(model: Model, state: State) -> float:
    """Largest |face velocity| over the granular faces (``phi_face >= phi_c``) [m s^-1]."""
    faces = model.ops.cell_to_face @ state.phi.ravel() >= model.ambient.phi_c
    return float(np.max(np.abs(state.vel[faces]), initial=0.0))


def model_with_injection(config: CaseConfig, U_inj) -> Model:
    """:func:`granflow.casekit.common.make_model` of ``config`` with the base injection ``U_inj``
    [m s^-1] (a scalar, or one value per column), whatever ``gas.U_inj`` says."""
    return make_model(config, U_inj=U_inj)


def preparation_config(config: CaseConfig, U_prep: float) -> CaseConfig:
    """The case restricted to the reservoir: grid of width ``L0`` (same dx, dz, Lz), the gate as
    east wall, injection ``U_prep`` through the base."""
    g, w = config.grid, config.walls
    n = reservoir_cells(config)
    grid = GridSection(nx=n, nz=g.nz, Lx=n * g.Lx / g.nx, Lz=g.Lz, periodic_x=False, geometry=g.geometry)
    walls = WallsSection(west=w.west, east=GATE_WALL, bottom=w.bottom, top=w.top,
                         base_friction_deg=w.base_friction_deg)
    gas = GasSection(law=config.gas.law, U_inj=U_prep, open_top=config.gas.open_top,
                     compressibility=config.gas.compressibility)
    return config.model_copy(update={"grid": grid, "walls": walls, "gas": gas})


def prepare(config: CaseConfig) -> PreparationResult:
    """Run the injection preparation of a ``column_collapse`` case (module docstring).

    Raises
    ------
    GranflowInputError
        Naming ``setup.preparation`` if a step of the preparation fails after every dt halving.
    """
    s, t = config.setup, config.time
    U_prep, U_mf = injection_velocity(config)
    cfg = preparation_config(config, U_prep)
    model = make_model(cfg)
    g, mat = model.grid, model.material
    phi0 = packing(config)
    phi = phi0 * rectangle_fraction(g, 0.0, g.Lx, 0.0, s.H0)
    state = model.initial_state(phi)
    tau_1 = gas_time(mat, phi0, s.H0)
    p_base = float(model.lithostatic_pressure(phi)[:, 0].max())
    g_z = config.gravity_vector[1]
    ratio = DEFAULT_U_PREP_OVER_UMF if s.U_prep_over_Umf is None else s.U_prep_over_Umf
    criterion = SteadyCriterion(rest_speed=REST_SPEED_FACTOR * model.gravity_blend_velocity,
                                pf_rate=PF_STEADY_TOL * p_base / tau_1,
                                window=STEADY_WINDOW_TAU * tau_1,
                                drift_rate=HEIGHT_DRIFT_TOL * fluid.kinematic_wave_speed(mat, phi0, g_z))
    max_time = DEFAULT_PREP_MAX_TIME if s.prep_max_time is None else s.prep_max_time
    sim = Simulation(model, state, stop_time=max_time, cfl=t.cfl, dt_max=t.dt_max,
                     max_retries=t.max_retries)
    sim.add_callback(criterion, IterationInterval(1), name="steady")
    t0 = time.perf_counter()
    try:
        sim.run()
    except StepFailure as err:
        raise GranflowInputError(f"setup.preparation: the injection preparation failed: {err}") from None
    return PreparationResult(state=sim.state, model=model, U_prep=U_prep, U_mf=U_mf, tau_1=tau_1,
                             steady=criterion.steady, max_speed=granular_speed(model, sim.state),
                             pf_rate=criterion.last_rate, rejected=sim.n_rejected,
                             wall_s=time.perf_counter() - t0, height_drift=criterion.last_drift,
                             drift_limit=criterion.drift_rate,
                             phi_expected=fluid.expanded_packing(mat, phi0, ratio, g_z),
                             expansion_time=fluid.expansion_time(mat, phi0, s.H0, ratio, g_z))


def released_state(model: Model, prep: PreparationResult) -> State:
    """Initial state of the collapse: the prepared ``phi``, ``p``, ``p_f`` in the first columns
    of ``model``'s grid, ambient elsewhere, at rest (the gate opens at t = 0)."""
    g = model.grid
    n = prep.model.grid.nx
    if prep.model.grid.nz != g.nz:
        raise GranflowInputError("released_state: the preparation grid must have the collapse grid's nz")
    fields = {}
    for name in ("phi", "p", "p_f"):
        a = np.zeros(g.cell_shape)
        a[:n] = getattr(prep.state, name)
        fields[name] = a
    return State.at_rest(g, fields["phi"], p=fields["p"], p_f=fields["p_f"])


def collapse_injection(config: CaseConfig, prep: PreparationResult):
    """Base injection of the collapse [m s^-1]: 0, or ``U_prep`` under the reservoir (per column)
    or everywhere, per ``setup.keep_injection``."""
    keep = config.setup.keep_injection
    if keep == KeepInjection.BASE:
        return prep.U_prep
    if keep == KeepInjection.RESERVOIR:
        u = np.zeros(config.grid.nx)
        u[:prep.model.grid.nx] = prep.U_prep
        return u
    return 0.0
