"""Case ``defluidisation_column``: a static, initially fluidised layer loses its gas through the
free surface (verification ladder item 1; MODEL.md §7, NUMERICS.md §11 item 1).

A uniform layer ``0 <= z <= H`` fills the whole box width at packing ``phi0`` on an impermeable
base, at rest, with an initial pore-gas over-pressure

* ``profile = "lithostatic"``: ``p_f0 = b0 phi0 rho_s |g_z| (H - z)`` (``b0`` times the lithostatic
  pressure; the granular pressure carries the rest), or
* ``profile = "uniform"``: ``p_f0 = b0 phi0 rho_s |g_z| H`` at every height.

The gas escapes through the bed surface (``p_f = 0`` in the ambient cells above the layer, which
the gas block imposes at the bed surface to second order; or on the top wall with
``gas.open_top = true`` when the layer fills the box). The full solver (:class:`granflow.model.Model`
with the pore-gas coupling, paper eq. syst2b) runs the case.

Reference (independent of the solver): the Fourier series of
:mod:`granflow.verification.defluidisation` for a RIGID bed (``u = 0``) with the diffusivity
``D = p_atm kappa(phi0)/(1 - phi0)`` (Carman-Kozeny kappa, paper eq. beta), slowest time constant
``tau_1 = 4 H^2/(pi^2 D)``; the basal pressure halves at ``0.4854 tau_1`` (lithostatic profile,
MODEL.md §7) or ``0.9345 tau_1`` (uniform profile). The series applies when the bed stays rigid:
``phi0 = phi_max`` (an expanded bed compacts and generates pore pressure) and the lithostatic
profile (a uniform over-pressure exceeds the lithostatic pressure near the surface, so the top of
the bed is lifted and expands, which lowers p_f by the ``p_atm div u`` term: the series does not
describe that). ``case_diagnostics`` says whether the run stayed rigid.

Gas law: this case always has pore gas. When ``gas.law`` is not given in the case file the linear
law (eq. syst2b, the one the series solves) is used; ``gas.law = "none"`` written explicitly is an
error. (``config_effective`` in output.nc then still shows the section default ``"none"``; the law
actually used is ``case_diagnostics.gas_law``.)

The basal pressure is recorded at every accepted step (bottom-cell centre, ``z = dz/2``, and its
zero-slope extrapolation to the base ``(9 p_0 - p_1)/8``) and, for ``summary.json``, at the
output times (``output.interval``). A run continued with ``--restart`` records only the steps
after the restart.
"""
from __future__ import annotations

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
    packing,
    packing_problems,
    rectangle_fraction,
)
from granflow.casekit import headlines
from granflow.casekit.registry import CASES
from granflow.config import CaseConfig, Section
from granflow.gas import GasCompressibility
from granflow.simulation import IterationInterval, Simulation, TimeInterval
from granflow.verification import defluidisation as dfl

CASE = "defluidisation_column"
DEFAULT_GAS_LAW = "linear"
"""Gas law used when the case file does not set ``gas.law`` (paper eq. syst2b; the series' law)."""
STEP_RECORD = f"{CASE}:basal_step"
OUTPUT_RECORD = f"{CASE}:basal_output"
"""Names of the two recording callbacks (every step; at the output times)."""
WHOLE_CELL_TOL = 1e-9
"""Relative tolerance for ``H`` being a whole number of cells."""
BASE_EXTRAPOLATION = (9.0 / 8.0, -1.0 / 8.0)
"""Weights of the two lowest cell centres in the zero-slope quadratic extrapolation to z = 0
(``p = a + b z^2`` through ``z = dz/2`` and ``3 dz/2``)."""
HALF = 0.5
"""The half-life is the time to fall to this fraction of the initial basal pressure."""
RIGID_PHI_TOL = 1e-9
"""Largest change of phi [-] for which the bed counts as rigid (the series' assumption)."""


class DefluidisationSetup(Section):
    """``[setup]`` of ``defluidisation_column``."""

    H: float = Field(0.1, gt=0, description="layer thickness, a whole number of cells [m]")
    phi0: float | None = Field(None, gt=0, lt=1, description="packing fraction (default: "
                               "material.phi_max; the series assumes a rigid bed at phi_max) [-]")
    b0: float = Field(0.9, gt=0, le=1, description="initial basal pore pressure as a fraction of "
                      "the basal lithostatic pressure [-]")
    profile: Literal["lithostatic", "uniform"] = Field(
        "lithostatic", description='initial pore-pressure profile: "lithostatic" (b0 x the '
        'lithostatic pressure, linear in z) or "uniform" (b0 x the basal lithostatic pressure) [-]')


def gas_law(config: CaseConfig) -> str:
    """The gas law of the run: ``gas.law``, or :data:`DEFAULT_GAS_LAW` when not set in the file."""
    law = config.gas.law
    if law == "none" and "law" not in config.gas.model_fields_set:
        return DEFAULT_GAS_LAW
    return law


def _with_gas(config: CaseConfig) -> CaseConfig:
    """``config`` with the gas law of :func:`gas_law` (no re-validation needed: a Literal value)."""
    return config.model_copy(update={"gas": config.gas.model_copy(update={"law": gas_law(config)})})


def check(config: CaseConfig) -> list[tuple[str, str]]:
    s, g = config.setup, config.grid
    out = packing_problems(config) + gas_problems(_with_gas(config))
    out += extent_problems(config, "setup.H", s.H, "z")
    if gas_law(config) == "none":
        out.append(("gas.law", (f'{CASE} needs pore gas: "linear" (the series\' law, the default of '
                               'this case) or "nonlinear", not "none"')))
    if config.gas.U_inj != 0.0:
        out.append(("gas.U_inj", (f"{config.gas.U_inj} m/s: the defluidising column has an "
                                 "impermeable base (U_inj = 0)")))
    dz = g.Lz / g.nz
    cells = s.H / dz
    if abs(cells - round(cells)) > WHOLE_CELL_TOL * max(cells, 1.0):
        out.append(("setup.H", (f"{s.H} m is {cells:.4g} cells of {dz:.4g} m; the series needs a "
                               "layer of whole cells (choose H = k grid.Lz/grid.nz)")))
    elif round(cells) >= g.nz and not config.gas.open_top:
        out.append(("setup.H", (f"{s.H} m fills the box (grid.Lz = {g.Lz} m): the gas cannot escape; "
                               "leave at least one ambient cell above the layer or set "
                               "gas.open_top = true")))
    out += flat_base_problems(config, CASE)
    return out


def diffusivity(config: CaseConfig) -> float:
    """``D = n p_atm kappa(phi0)/(1 - phi0)`` [m^2 s^-1] (Carman-Kozeny kappa; NUMERICS.md §1.1),
    n the polytropic index of ``gas.compressibility`` (1 isothermal, 1.4 adiabatic;
    :class:`granflow.gas.GasCompressibility`)."""
    n = GasCompressibility(config.gas.compressibility).polytropic_index
    return n * float(config.make_closure().material.gas_diffusivity(packing(config)))


def basal_amplitude(config: CaseConfig) -> float:
    """Initial basal pore pressure ``b0 phi0 rho_s |g_z| H`` [Pa] (the series' amplitude)."""
    s = config.setup
    return s.b0 * packing(config) * config.material.rho_s * abs(config.gravity_vector[1]) * s.H


@dataclass
class BasalRecord:
    """Basal pore pressure over the run [Pa]: bottom-cell centre (mean over the columns) and its
    extrapolation to z = 0, at times ``t`` [s]. Called as a :class:`Simulation` callback."""

    t: list = field(default_factory=list)
    centre: list = field(default_factory=list)
    base: list = field(default_factory=list)

    def __call__(self, sim: Simulation) -> None:
        p0, p1 = sim.state.p_f[:, 0].mean(), sim.state.p_f[:, 1].mean()
        self.t.append(float(sim.state.t))
        self.centre.append(float(p0))
        self.base.append(float(BASE_EXTRAPOLATION[0] * p0 + BASE_EXTRAPOLATION[1] * p1))


def _record(sim: Simulation, name: str) -> BasalRecord | None:
    for cb in sim.callbacks:
        if cb.name == name and isinstance(cb.func, BasalRecord):
            return cb.func
    return None


def half_life(times, values, initial: float) -> float | None:
    """First time [s] at which ``values`` falls to ``initial/2`` (linear interpolation between
    records); None if it never does, or if it did before the record began (a restarted run)."""
    v = np.asarray(values, dtype=float)
    below = np.flatnonzero(v <= HALF * initial)
    if below.size == 0:
        return None
    k = int(below[0])
    if k == 0:
        return float(times[0]) if times[0] == 0.0 else None
    t0, t1, v0, v1 = times[k - 1], times[k], v[k - 1], v[k]
    return float(t0 + (v0 - HALF * initial) / (v0 - v1) * (t1 - t0))


def diagnostics(sim: Simulation, config: CaseConfig) -> dict[str, Any]:
    """Basal p_f against the Fourier series (module docstring)."""
    s, g = config.setup, sim.model.grid
    D = diffusivity(config)
    tau1 = dfl.first_time_constant(s.H, D)
    amp = basal_amplitude(config)
    phi_max = sim.model.material.phi_max
    phi0 = packing(config)
    out: dict[str, Any] = {
        "H_m": s.H, "phi0": phi0, "b0": s.b0, "profile": s.profile, "gas_law": gas_law(config),
        "gas_compressibility": config.gas.compressibility,
        "D_m2_s": D, "tau_1_s": tau1, "p_f0_base_Pa": amp,
        "reference": ("Fourier series of the rigid defluidising column "
                      "(granflow.verification.defluidisation), linear gas law"),
    }
    layer = g.cell_coords()[1] < s.H
    dphi = float(np.max(np.abs(sim.state.phi[layer] - phi0)))
    out["max_phi_change"] = dphi
    out["max_speed_m_s"] = float(np.max(np.abs(sim.state.vel), initial=0.0))
    out["rigid"] = bool(dphi <= RIGID_PHI_TOL)
    out["reference_applies"] = bool(phi0 == phi_max and s.profile == "lithostatic"
                                    and gas_law(config) == "linear" and out["rigid"])
    rec = _record(sim, OUTPUT_RECORD)
    if rec is not None:
        t = np.asarray(rec.t)
        late = t > 0
        z0 = float(g.zc[0])
        series = np.asarray(rec.centre, dtype=float).copy()
        if late.any():
            series[late] = dfl.pressure(z0, t[late], s.H, D, s.profile, amp)
        err = np.abs(np.asarray(rec.centre) - series) / amp
        out["basal_record"] = {"z_m": z0, "t_s": rec.t, "p_f_Pa": rec.centre,
                               "series_Pa": series.tolist()}
        out["max_error_rel"] = float(err[late].max()) if late.any() else None
    step = _record(sim, STEP_RECORD)
    series_half = dfl.basal_half_life(s.H, D, s.profile)
    measured = half_life(step.t, step.base, amp) if step is not None and step.t else None
    out["half_life_s"] = measured
    out["record_start_s"] = step.t[0] if step is not None and step.t else None
    out["series_half_life_s"] = series_half
    out["half_life_tau_1"] = measured / tau1 if measured is not None else None
    out["series_half_life_tau_1"] = series_half / tau1
    out["half_life_rel_error"] = measured / series_half - 1.0 if measured is not None else None
    return out


@CASES.register(CASE, setup_model=DefluidisationSetup, check=check, diagnostics=diagnostics,
                headline=headlines.defluidisation_column,
                summary="initially fluidised static layer drains its gas; basal p_f vs Fourier series")
def setup(config: CaseConfig) -> Simulation:
    """Model (with pore gas), initial state at rest with the over-pressure of ``setup.profile``,
    and two recorders of the basal pressure (every step; every ``output.interval``)."""
    s = config.setup
    model = make_model(_with_gas(config))
    g = model.grid
    phi = packing(config) * rectangle_fraction(g, 0.0, g.Lx, 0.0, s.H)
    if s.profile == "lithostatic":
        p_f = s.b0 * model.lithostatic_pressure(phi)
    else:
        p_f = np.where(g.cell_coords()[1] < s.H, basal_amplitude(config), 0.0)
    sim = make_simulation(config, model, model.initial_state(phi, p_f=p_f))
    sim.add_callback(BasalRecord(), IterationInterval(1), name=STEP_RECORD)
    sim.add_callback(BasalRecord(), TimeInterval(config.output.interval), name=OUTPUT_RECORD)
    return sim


