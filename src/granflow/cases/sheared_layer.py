"""Case ``sheared_layer``: a homogeneous layer under imposed shear relaxes to phi_eq(I)
(verification ladder item 2; MODEL.md §7, NUMERICS.md §11 item 2 and §5.2).

Under an imposed strain-rate norm ``|S|`` [s^-1] and granular pressure ``p`` [Pa] (so a fixed
inertial number ``I = c_I d |S| / sqrt(p/rho_s)``), mass (paper eq. syst1b, Lagrangian form) and the
dilatancy law (eq. syst4b) reduce to the ODE ``dphi/dt = -phi R(phi; p, |S|)``,
``R = Closure.div_rate``, which relaxes phi to ``phi_eq(I)``: compaction from a loose start
(``phi0 < phi_eq``), dilation from a dense one.

Why 0-D and not the full solver. A homogeneous simple shear needs a moving lid (or a moving base)
over a layer periodic in x; :class:`granflow.grid.VelocityBCs` offers only walls at rest (no-slip
or free-slip), so :class:`granflow.model.Model` cannot impose the shear, and with gravity p is not
uniform either. The case therefore runs the homogeneous problem itself: its model,
:class:`HomogeneousShearModel`, advances every cell as an independent copy of the layer with
:func:`granflow.physics.dilatancy.homogeneous_layer_step` -- the asymptotic-preserving factor
``fac = 1/(1 + dt phi dR/dphi)`` that the dilatancy row of ``Model.advance`` uses
(``setup.scheme = "ap_linearised"``, default) or the exact backward-Euler solve
(``"backward_euler"``). There is no momentum, transport or gravity: the imposed ``p`` is written
to the state's pressure, the velocity (hence ``u``, ``w`` and ``S`` in output.nc) stays zero --
the imposed ``|S|`` is a parameter, reported in ``case_diagnostics``. The grid only sets how many
identical copies are advanced (choose a small one, e.g. 2 x 2). The time step is
``time.dt_max`` (no velocity, no CFL limit); ``rate_dt`` in the diagnostics is its stiffness.

Reference: for ``drucker_prager`` with the linear equilibrium law the exact logistic solution of
:mod:`granflow.verification.sheared_layer` (``phi(t) = phi_eq / (1 + (phi_eq/phi0 - 1)
exp(-beta phi_eq t))``, ``beta = 2 lambda sin(delta) sqrt(p)``, ``lambda = 1/(c_I delta_phi d
sqrt(rho_s))``); for any other closure a tightly converged Radau integration (SciPy) of the same
ODE with the closure's own ``div_rate`` (a consistency check, not an independent solution).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import Field

from granflow.casekit.common import flat_base_problems, make_grid, make_simulation, packing_problems
from granflow.casekit import headlines
from granflow.casekit.registry import CASES
from granflow.config import CaseConfig, Section
from granflow.grid import VelocityBCs
from granflow.model import Model, StepReport, StepStatus
from granflow.physics.dilatancy import (
    LayerScheme,
    ddiv_rate_dphi,
    homogeneous_layer_step,
)
from granflow.simulation import IterationInterval, Simulation, TimeInterval
from granflow.state import State
from granflow.verification.sheared_layer import drucker_prager_layer

CASE = "sheared_layer"
EXACT_CLOSURE = "drucker_prager"
EXACT_LAW = "linear"
"""The closure and equilibrium law with an exact (logistic) solution."""
STEP_RECORD = f"{CASE}:phi_step"
OUTPUT_RECORD = f"{CASE}:phi_output"
"""Names of the two recording callbacks (every step; at the output times)."""
NO_GRAVITY = (0.0, 0.0)
"""The homogeneous layer has no weight: the imposed p replaces it [m s^-2]."""
RADAU_RTOL = 1e-11
RADAU_ATOL = 1e-13
"""Tolerances of the Radau reference for closures without an exact solution."""


class ShearedLayerSetup(Section):
    """``[setup]`` of ``sheared_layer``."""

    p: float = Field(1000.0, gt=0, description="imposed granular pressure [Pa]")
    S: float = Field(200.0, ge=0, description="imposed strain-rate norm S = sqrt(S:S/2) (simple "
                     "shear: half the shear rate) [s^-1]")
    phi0: float = Field(0.55, gt=0, lt=1, description="initial packing fraction [-]")
    scheme: Literal["ap_linearised", "backward_euler"] = Field(
        "ap_linearised", description='time discretisation: "ap_linearised" (the AP factor of the '
        'solver\'s dilatancy row) or "backward_euler" (exact scalar solve) [-]')


class HomogeneousShearModel(Model):
    """The homogeneous sheared layer, one independent copy per cell (module docstring).

    A :class:`~granflow.model.Model` subclass, though the time loop needs only the interface of
    :class:`granflow.simulation.SteppingModel` (``grid``, ``gravity``, ``material``, ``gas``,
    ``advance``, ``inertia_density``): the case runner, the NetCDF writers, the recorders and the
    checkpoints of ``granflow run`` read more of a Model (``closure``, ``ambient``, ``ops`` for
    the strain rate of output.nc, ``lithostatic_pressure``, ``material_of``,
    ``linear_solver_name``, ``velocity_band``, ...), which a stand-alone class would copy.

    Parameters
    ----------
    grid : Grid
    closure : Closure
    p : float
        Imposed granular pressure [Pa].
    S : float
        Imposed strain-rate norm |S| [s^-1].
    scheme : LayerScheme or str
        Time discretisation of ``phi' = -phi R(phi)``.
    phi_tolerance : float
        Relative overshoot of phi_max that fails a step (as in :class:`Model`).
    """

    def __init__(self, grid, closure, p: float, S: float,
                 scheme: LayerScheme | str = LayerScheme.AP_LINEARISED, **options) -> None:
        super().__init__(grid, closure, gravity=NO_GRAVITY, bcs=VelocityBCs(), **options)
        self.p_imposed = float(p)
        self.S_imposed = float(S)
        self.scheme = LayerScheme(scheme)

    def initial_state(self, phi, p_f=0.0) -> State:
        """The layer at rest (no velocity field) with the imposed pressure."""
        return State.at_rest(self.grid, phi, p=self.p_imposed, p_f=p_f)

    def advance(self, state: State, dt: float) -> StepReport:
        """``phi <- homogeneous_layer_step(phi)`` in every cell; FAILED (state untouched) on a
        non-finite result or phi beyond ``(1 + phi_tolerance) phi_max``."""
        phi_max = self.material.phi_max
        with np.errstate(all="ignore"):
            new = homogeneous_layer_step(self.closure, state.phi, self.p_imposed, self.S_imposed, dt,
                                         self.scheme)
        if not np.all(np.isfinite(new)):
            return StepReport(status=StepStatus.FAILED, dt=dt, message="non-finite phi")
        hi, lo = float(new.max()), float(new.min())
        if hi > phi_max * (1.0 + self.phi_tolerance) or lo < 0.0:
            return StepReport(status=StepStatus.FAILED, dt=dt,
                              message=f"phi = {hi if hi > phi_max else lo:.6g} out of [0, phi_max]")
        state.phi = np.clip(new, 0.0, phi_max)
        state.p = np.full(self.grid.cell_shape, self.p_imposed)
        state.t += dt
        state.step += 1
        return StepReport(status=StepStatus.OK, dt=dt, n_dense=self.grid.n_cells,
                          max_phi_before_clip=hi, min_phi_before_clip=lo, cfl=0.0)


def equilibrium(config: CaseConfig) -> tuple[float, float]:
    """``(I, phi_eq(I))`` of the imposed ``|S|`` and ``p`` [-]."""
    s = config.setup
    c = config.make_closure()
    inertial = float(c.material.inertial_number(s.S, s.p))
    return inertial, float(c.equilibrium.phi_eq(inertial))


def relaxation_rate(config: CaseConfig) -> float:
    """Linearised relaxation rate ``phi_eq dR/dphi(phi_eq)`` [s^-1] (for DP: ``beta phi_eq``)."""
    s = config.setup
    c = config.make_closure()
    phi_eq = equilibrium(config)[1]
    return float(phi_eq * ddiv_rate_dphi(c, phi_eq, s.p, s.S))


def check(config: CaseConfig) -> list[tuple[str, str]]:
    s = config.setup
    out = packing_problems(config)
    if config.gas.law != "none":
        out.append(("gas.law", f"{CASE} has no pore gas (use \"none\")"))
    if config.gas.compressibility != "isothermal":
        out.append(("gas.compressibility", f"{CASE} has no pore gas to make adiabatic"))
    if config.inflow.side != "none":
        out.append(("inflow.side", f"{CASE} is a homogeneous cell with no walls to feed (use \"none\")"))
    if config.walls.east == "outflow":
        out.append(("walls.east", f"{CASE} is a homogeneous cell with no walls (\"outflow\" has no meaning)"))
    inertial, phi_eq = equilibrium(config)
    if not config.numerics.ambient.phi_c < phi_eq <= config.material.phi_max:
        out.append(("setup.S", (f"|S| = {s.S} 1/s at p = {s.p} Pa gives I = {inertial:.4g} and "
                                f"phi_eq = {phi_eq:.4g}, outside (numerics.ambient.phi_c = "
                                f"{config.numerics.ambient.phi_c}, material.phi_max = "
                                f"{config.material.phi_max}]; lower setup.S or raise setup.p")))
    out += flat_base_problems(config, CASE)
    return out


def reference(config: CaseConfig, t) -> tuple[np.ndarray, str]:
    """phi(t) of the reference solution at times ``t`` [s], and its name (module docstring)."""
    s = config.setup
    c = config.make_closure()
    m = c.material
    t = np.asarray(t, dtype=float)
    if config.closure.name == EXACT_CLOSURE and config.equilibrium.law == EXACT_LAW:
        return (drucker_prager_layer(t, s.phi0, s.p, s.S, sin_delta=c.sin_delta, d=m.d, rho_s=m.rho_s,
                                     phi_max=m.phi_max, delta_phi=c.equilibrium.delta_phi, c_I=m.c_I),
                "exact logistic solution (granflow.verification.sheared_layer)")
    from scipy.integrate import solve_ivp

    t_end = float(t.max()) if t.size else 0.0
    if t_end <= 0.0:
        return np.full(t.shape, s.phi0), "initial value"
    sol = solve_ivp(lambda _, y: -y * c.div_rate(y, s.p, s.S), (0.0, t_end), [s.phi0], method="Radau",
                    rtol=RADAU_RTOL, atol=RADAU_ATOL, dense_output=True)
    return sol.sol(t)[0], "SciPy Radau integration of dphi/dt = -phi div_rate (same closure)"


@dataclass
class PhiRecord:
    """phi over the run (mean and spread over the cells), at times ``t`` [s]; a callback."""

    t: list = field(default_factory=list)
    phi: list = field(default_factory=list)
    spread: float = 0.0

    def __call__(self, sim: Simulation) -> None:
        phi = sim.state.phi
        self.t.append(float(sim.state.t))
        self.phi.append(float(phi.mean()))
        self.spread = max(self.spread, float(phi.max() - phi.min()))


def _record(sim: Simulation, name: str) -> PhiRecord | None:
    for cb in sim.callbacks:
        if cb.name == name and isinstance(cb.func, PhiRecord):
            return cb.func
    return None


def diagnostics(sim: Simulation, config: CaseConfig) -> dict[str, Any]:
    """phi(t) against the reference, largest error, overshoot of phi_eq (module docstring)."""
    s = config.setup
    inertial, phi_eq = equilibrium(config)
    rate = relaxation_rate(config)
    gap = abs(s.phi0 - phi_eq)
    out: dict[str, Any] = {"p_Pa": s.p, "S_per_s": s.S, "I": inertial, "phi0": s.phi0,
                           "phi_eq": phi_eq, "scheme": s.scheme, "rate_per_s": rate,
                           "rate_dt": rate * config.time.dt_max,
                           "direction": "compaction" if s.phi0 < phi_eq else "dilation"}
    step = _record(sim, STEP_RECORD)
    if step is not None and step.t:
        ref, name = reference(config, step.t)
        phi = np.asarray(step.phi)
        err = np.abs(phi - ref)
        towards = np.sign(phi_eq - s.phi0)
        overshoot = float(max(0.0, np.max(towards * (phi - phi_eq)))) if towards else 0.0
        out.update({"reference": name, "max_error": float(err.max()),
                    "max_error_rel": float(err.max() / gap) if gap > 0 else None,
                    "overshoot": overshoot, "overshoot_rel": overshoot / gap if gap > 0 else None,
                    "final_distance_rel": float(abs(phi[-1] - phi_eq) / gap) if gap > 0 else None,
                    "cell_spread": step.spread})
    rec = _record(sim, OUTPUT_RECORD)
    if rec is not None and rec.t:
        out["phi_record"] = {"t_s": rec.t, "phi": rec.phi, "reference": reference(config, rec.t)[0].tolist()}
    return out


@CASES.register(CASE, setup_model=ShearedLayerSetup, check=check, diagnostics=diagnostics,
                headline=headlines.sheared_layer,
                summary="homogeneous layer under imposed shear relaxes to phi_eq(I) (0-D; exact for DP)")
def setup(config: CaseConfig) -> Simulation:
    """The 0-D model of the homogeneous layer (:class:`HomogeneousShearModel`), phi = phi0 in
    every cell, and two phi recorders (every step; every ``output.interval``)."""
    s, n = config.setup, config.numerics
    model = HomogeneousShearModel(make_grid(config), config.make_closure(), s.p, s.S, s.scheme,
                                  ambient=n.ambient, phi_tolerance=n.phi_tolerance)
    state = model.initial_state(np.full(model.grid.cell_shape, s.phi0))
    sim = make_simulation(config, model, state)
    sim.add_callback(PhiRecord(), IterationInterval(1), name=STEP_RECORD)
    sim.add_callback(PhiRecord(), TimeInterval(config.output.interval), name=OUTPUT_RECORD)
    return sim
