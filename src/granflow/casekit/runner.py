"""Run a case with output: NetCDF fields, ``summary.json``, checkpoints, restart, progress.

:class:`CaseRun` builds the :class:`~granflow.simulation.Simulation` of a case through the
registry and wires onto it the output of :mod:`granflow.output` (the simulation runs them, in its
order: diagnostics, callbacks, output writers, checkpointers):

* ``output_writers["output"]``: a :class:`~granflow.output.writers.NetCDFOutputWriter` on
  :class:`~granflow.simulation.TimeInterval` ``output.interval`` (synced after each record, so a
  killed run leaves a readable file) of phi, u and w at cell centres, p, p_f, |S|
  (``output.fields``), the kinetic energy, the front and the basal probes;
* ``diagnostics``: ``front`` (:class:`~granflow.output.recorders.FrontRecorder`, at the records),
  ``equilibrium_range`` and ``wall_contact`` (warnings, checked at the records), ``rest`` (every
  step: ``t_rest``, ``peak_speed``, ``time.stop_at_rest``);
* the callback ``progress`` (every step);
* ``checkpointers["checkpoint"]`` (every ``output.checkpoint_interval`` steps):
  ``checkpoints/checkpoint_<step>.npz`` (:class:`~granflow.output.writers.Checkpointer`).

Whatever ends the run -- the stop time, a :class:`~granflow.simulation.StepFailure`, a
``KeyboardInterrupt`` or :meth:`~granflow.simulation.Simulation.request_stop` -- the state of the
last accepted step gets a checkpoint and ``summary.json`` (written atomically); a completed run
also gets a final NetCDF record if the stop time is not an output time (an interrupted or failed
run keeps its records on the output times, so that its restart rewrites the same file). A restart
(``restart=`` a checkpoint file or a run directory) restores the state, the energy budget, the
totals, the phase of the output schedule and the diagnostics history, and continues the NetCDF
file (records after the checkpoint time are dropped and written again), so a restarted run
reproduces the uninterrupted one bit for bit.
"""
from __future__ import annotations

import enum
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from granflow import diagnostics as dg
from granflow.casekit.memory import check_memory
from granflow.cases import CASES  # the package: importing it registers the cases
from granflow.casekit.restart import (
    CHECKPOINT_DIR,
    check_checkpoint,
    check_resume_output,
    resolve_checkpoint,
)
from granflow.casekit.step_clock import StepClock
from granflow.config import CaseConfig
from granflow.config.checks import advisories
from granflow.errors import GranflowInputError
from granflow.output import load_checkpoint, write_json_atomic
from granflow.output.fields import (SI_KIND, UNIT_KINDS, BasalProbes, boundary_outputs, field_outputs,
                                    kinetic_energy_output)
from granflow.output.netcdf import git_revision
from granflow.output.paths import check_directory
from granflow.output.recorders import (
    EquilibriumRangeCheck,
    FrontRecorder,
    RestDetector,
    WallContactRecorder,
    front_output,
    granular_speeds,
)
from granflow.output.writers import Checkpointer, NetCDFOutputWriter, warn_numerics_mismatch
from granflow.simulation import IterationInterval, Simulation, StepFailure, TimeInterval

logger = logging.getLogger(__name__)

OUTPUT_FILE = "output.nc"
SUMMARY_FILE = "summary.json"
RUN_FILES = (OUTPUT_FILE, SUMMARY_FILE)
"""Files of a run directory that must be writable files (checked before the run starts)."""
CHECKPOINT_GLOB = f"{CHECKPOINT_DIR}/*.npz"
FIGURE_GLOB = "*.png"
"""Entries of a run directory that a run may overwrite (checkpoints; figures with
``output.figures``): an existing one that is not a regular file is refused before the run."""


def run_file_globs(config: CaseConfig) -> tuple[str, ...]:
    """The patterns of :data:`CHECKPOINT_GLOB` and :data:`FIGURE_GLOB` that apply to ``config``."""
    return (CHECKPOINT_GLOB, FIGURE_GLOB) if config.output.figures else (CHECKPOINT_GLOB,)
REST_SPEED_FACTOR = 10.0
"""Default rest speed = REST_SPEED_FACTOR eps Lz [m s^-1] (eps Lz is the creep speed scale)."""
EVERY_STEP = 1
MASS0_KEY, WALL_S_KEY = "run.mass0", "run.wall_s"
"""Checkpoint scalars of the runner itself: the initial mass [m^2] and the wall time so far [s]."""

UNITS = {
    "runout_m": "m", "front_position": "m (t_s in s)", "final_height_at_wall": "m",
    "t_rest": "s", "rest_speed": "m s-1", "peak_speed": "m s-1", "mass_rel_error": "1",
    "clipped_mass": "1 (fraction of the initial mass)", "limited_mass": "1 (fraction of the initial mass)",
    "outflow_mass": "1 (fraction of the initial mass that left through an outflow wall)",
    "inflow_mass": "1 (a source's supply, in fractions of the initial mass)", "phi_min": "1", "phi_max": "1",
    "energy_residual_rel": "1 (of energy_residual.reference, the run's largest energy source; null if negligible)",
    "energy": "J m-1",
    "wall_s": "s", "t_final": "s", "topography": "m",
}


def topography_summary(model) -> dict[str, Any] | None:
    """The base profile of a run (None: the flat base): its points and how far the solver's
    staircase departs from it at the cell centres (at most half a cell, granflow.topography)."""
    topo = getattr(model, "topography", None)
    if topo is None:
        return None
    from granflow.topography import staircase_error

    return {"x_m": topo.x.tolist(), "z_m": topo.z.tolist(),
            "staircase_error_m": staircase_error(topo, model.grid)}


class RunStatus(str, enum.Enum):
    """How a run ended."""

    COMPLETED = "completed"
    INTERRUPTED = "interrupted"
    FAILED = "failed"
    """A step failed after all dt halvings (:class:`~granflow.simulation.StepFailure`)."""
    ERROR = "error"
    """An unexpected exception (a bug); re-raised after the output is saved."""


@dataclass(frozen=True)
class Progress:
    """What a progress display needs, passed to the ``progress`` callable after every step."""

    t: float
    stop_time: float
    dt: float
    step: int
    steps_per_s: float
    eta_s: float
    wall_s: float
    warming_up: bool = False
    """True while the kernels compile (:mod:`granflow.casekit.step_clock`): no rate, no ETA."""


@dataclass(frozen=True)
class RunResult:
    """Outcome of :meth:`CaseRun.run`."""

    status: RunStatus
    message: str
    directory: Path
    summary: dict[str, Any]
    checkpoint: Path | None


class CaseRun:
    """A case with its output in ``directory`` (see the module docstring).

    Parameters
    ----------
    config : CaseConfig
    directory : path-like
        Output directory (created).
    restart : path-like, optional
        Checkpoint file or run directory to continue from.
    progress : callable, optional
        ``progress(Progress)`` after every accepted step.
    overwrite : bool
        Replace an existing output of a fresh run; without it an existing ``output.nc`` is an error
        (use ``restart`` to continue it).
    """

    def __init__(self, config: CaseConfig, directory: str | Path, restart: str | Path | None = None,
                 progress: Callable[[Progress], None] | None = None, overwrite: bool = False) -> None:
        self.config = config
        self.case = CASES.get(config.case.name)
        self.directory = check_directory(directory, "output directory", files=RUN_FILES,
                                         subdirs=(CHECKPOINT_DIR,), file_globs=run_file_globs(config))
        self.output_path = self.directory / OUTPUT_FILE
        if restart is None and self.output_path.exists() and not overwrite:
            raise GranflowInputError(f"{self.output_path} exists (an earlier run); write this run elsewhere "
                                     f"with --out DIR, replace it with --overwrite, or continue that run "
                                     f"with --restart {self.directory} (only with its case file and --set "
                                     f"options: the grid must be the same)")
        check_memory(config)
        self.sim: Simulation = self.case.setup(config)
        self.grid = self.sim.model.grid
        self.phi_max = self.sim.model.material.phi_max
        out = config.output
        if out.front_threshold is not None:
            self.threshold = out.front_threshold
        elif self.case.front_threshold is not None:
            self.threshold = float(self.case.front_threshold(config))
        else:
            self.threshold = self.grid.dz
        self.probes = BasalProbes(self.grid, out.probes_x)
        self.rest_speed = (out.rest_speed if out.rest_speed is not None
                           else REST_SPEED_FACTOR * config.numerics.eps * self.grid.Lz)
        self.progress = progress
        self.warnings: list[str] = advisories(config)  # option combinations not validated
        for text in self.warnings:
            logger.warning("granflow: warning: %s", text)
        self.mass0 = dg.mass(self.grid, self.sim.state.phi)
        self.wall_before = 0.0
        self._session_t0 = (self.sim.state.t, time.perf_counter())
        self._wire()
        if restart is not None:  # every check of the checkpoint before anything is written
            self._restore(resolve_checkpoint(restart))
            if self.output_path.exists():
                self._check_resume_output()
        self.directory.mkdir(parents=True, exist_ok=True)
        if restart is None:
            self.checkpointer.clear()
        self._session_t0 = (self.sim.state.t, time.perf_counter())
        self._clock = StepClock()
        """Rate and ETA of the progress line, without the steps that compile the Numba kernels."""
        self.writer.open()

    # --- wiring ---------------------------------------------------------------------------------
    def _wire(self) -> None:
        """Register the writer, the recorders, the progress and the checkpointer (module docstring)."""
        sim, cfg, out = self.sim, self.config, self.config.output
        unit = self._si_unit
        outputs = {**field_outputs(sim.model, out.fields, unit), "kinetic_energy": kinetic_energy_output(unit),
                   **boundary_outputs(sim.model, unit),
                   "x_front": front_output(self.threshold, unit), **self.probes.outputs(unit)}
        self.writer = NetCDFOutputWriter(
            sim.model, self.output_path, outputs, TimeInterval(out.interval),
            coords=self.probes.coords(self.case_unit("length")), global_attrs=self._global_attrs(),
            length_unit=self.case_unit("length"), time_units=self.case_unit("time"),
            case_file=cfg.source_text, title=f"granflow {cfg.case.name}")
        self.front_recorder = FrontRecorder(self.threshold, writer=self.writer)
        self.rest = RestDetector(self.rest_speed, IterationInterval(EVERY_STEP), hold=cfg.time.stop_at_rest)
        self.walls = WallContactRecorder(self.writer, "setup.Lx" if hasattr(cfg.setup, "Lx") else "grid.Lx",
                                         self.case_unit("time"), self.warnings)
        sim.diagnostics["front"] = self.front_recorder
        sim.diagnostics["equilibrium_range"] = EquilibriumRangeCheck(
            writer=self.writer, law_name=cfg.equilibrium.law, warnings=self.warnings)
        sim.diagnostics["wall_contact"] = self.walls
        sim.diagnostics["rest"] = self.rest
        sim.add_callback(self._report_progress, IterationInterval(EVERY_STEP), name="progress")
        sim.output_writers["output"] = self.writer
        self.checkpointer = Checkpointer(self.directory / CHECKPOINT_DIR, IterationInterval(out.checkpoint_interval),
                                         keep=out.checkpoint_keep, meta=self._checkpoint_meta,
                                         payload=self._checkpoint_payload)
        sim.checkpointers["checkpoint"] = self.checkpointer

    def _global_attrs(self) -> dict[str, Any]:
        unit, length = self.case_unit, self.case_unit("length")
        attrs = {"case": self.config.case.name, "config_effective": self.config.to_toml(),
                 "overrides": " ".join(self.config.overrides), "phi_max": self.phi_max,
                 "front_threshold_m": self.threshold, "closure": self.sim.model.closure.name,
                 "rest_speed": self.rest_speed, "phi_c": self.sim.model.ambient.phi_c,
                 "geometry": self.sim.model.grid.geometry.value,
                 **{f"{kind}_unit": unit(kind) for kind in UNIT_KINDS}}
        if self.case.units:
            attrs["units_note"] = (f"dimensionless case: lengths in {length}, times in {unit('time')}; "
                                   "names ending in _m or _s keep those units")
        return attrs

    def case_unit(self, kind: str) -> str:
        """Unit of ``kind`` (``length``, ``time``, ``speed``, ``pressure``, ``rate``, ``energy``,
        or an SI unit string, returned as is) in this case (:attr:`Case.units`)."""
        if kind not in UNIT_KINDS:
            return kind
        return geometry_unit(self.case.unit(kind), self.sim.model.grid)

    def _si_unit(self, si: str) -> str:
        """The case's unit for the SI unit ``si`` of an output (``m s-1`` -> the speed unit)."""
        return self.case_unit(SI_KIND.get(si, si))

    def _check_resume_output(self) -> None:
        """The output.nc a restart continues is one of this grid and these probes."""
        _, old = check_resume_output(self.output_path, self.grid.nx, self.grid.nz)
        new = self.probes.x
        if old.shape != new.shape or not np.array_equal(old, new):
            raise GranflowInputError(f"--restart: output.probes_x gives probe cells at x = {new.tolist()} m, "
                                     f"but {self.output_path} has {old.tolist()} m; keep the original probes_x")

    def front(self) -> float:
        """Front position of the current state [m] (nan if no column is above the threshold)."""
        return self.front_recorder.position(self.sim)

    # --- progress, checkpoints ------------------------------------------------------------------
    def _report_progress(self, sim: Simulation) -> None:
        if self.progress is not None and sim.reports:
            rate = self._clock.tick(sim.state.t, time.perf_counter(), len(sim.reports), sim.stop_time)
            self.progress(Progress(t=sim.state.t, stop_time=sim.stop_time, dt=sim.reports[-1].dt,
                                   step=sim.state.step, steps_per_s=rate.steps_per_s, eta_s=rate.eta_s,
                                   wall_s=self.wall_s(), warming_up=rate.warming_up))

    def wall_s(self) -> float:
        """Wall time of the run so far, over all restarts [s]."""
        return self.wall_before + time.perf_counter() - self._session_t0[1]

    def _checkpoint_meta(self, sim: Simulation) -> dict[str, Any]:
        return {"case": self.config.case.name, "config_effective": self.config.to_toml(),
                "case_file": self.config.source_path}

    def _checkpoint_payload(self, sim: Simulation) -> tuple[dict, dict]:
        return {}, {MASS0_KEY: self.mass0, WALL_S_KEY: self.wall_s()}

    def save_checkpoint(self) -> Path | None:
        """Checkpoint of the current state (skipped if this step already has one)."""
        return self.checkpointer.save(self.sim)

    def _restore(self, path: Path) -> None:
        arrays, scalars, meta = load_checkpoint(path)
        check_checkpoint(path, arrays, scalars, meta, self.config, self.grid, self.phi_max)
        try:  # the state, the totals and every registered writer and recorder
            self.sim.restore_checkpoint(arrays, scalars)
            self.mass0 = float(scalars[MASS0_KEY])
            self.wall_before = float(scalars[WALL_S_KEY])
        except (KeyError, GranflowInputError) as err:
            raise GranflowInputError(f"--restart {path}: not a checkpoint of this case ({err})") from None
        warn_numerics_mismatch(meta, self.sim.model)
        max_steps = self.config.time.max_steps
        if max_steps is not None:
            self.sim.max_steps = max(max_steps - self.sim.state.step, 0)
        logger.info("restarted from %s at t = %r s, step %d", path, self.sim.state.t, self.sim.state.step)

    # --- the run ---------------------------------------------------------------------------------
    def run(self) -> RunResult:
        """Run to the end; never raises for a step failure or an interruption (see RunStatus)."""
        status, message = RunStatus.COMPLETED, ""
        try:
            self.sim.run()  # its writers and checkpointer save the output, whatever ends it
            if self.sim.stop_requested:
                status, message = RunStatus.INTERRUPTED, self.sim.stop_reason
        except StepFailure as err:
            status, message = RunStatus.FAILED, str(err)
        except KeyboardInterrupt:
            status, message = RunStatus.INTERRUPTED, "interrupted (KeyboardInterrupt)"
        except BaseException as err:
            self._finish(RunStatus.ERROR, f"{type(err).__name__}: {err}")
            raise
        return self._finish(status, message)

    def _finish(self, status: RunStatus, message: str) -> RunResult:
        checkpoint = None
        try:
            checkpoint = self.save_checkpoint()  # saved at the end of sim.run(): its path
        finally:
            self.writer.close()
            summary = self.summary(status, message, checkpoint)
            self._summary_for_figures = summary
            if self.config.output.figures:
                summary["figures"] = self._figures()
            write_json_atomic(self.directory / SUMMARY_FILE, summary)
        return RunResult(status, message, self.directory, summary, checkpoint)

    def _figures(self) -> dict[str, Any]:
        """Write the run figures; a plotting problem is recorded, never fatal to the run."""
        try:
            from granflow import case_figures, plotting

            paths = plotting.run_figures(self.output_path, self.directory)
            paths += case_figures.case_figures(self.output_path, self._summary_for_figures, self.directory)
            return {"files": [p.name for p in paths]}
        except Exception as err:  # noqa: BLE001 - figures must not lose a finished run
            return {"error": f"{type(err).__name__}: {err}"}

    def _end_warnings(self, status: RunStatus, rms: float, runout: float) -> tuple[bool, list[str]]:
        """(still moving, the warnings of the end of the run): a settling case that completed
        before coming to rest; Picard iterations accepted unconverged."""
        st, tot, cfg = self.sim.state, self.sim.totals, self.config
        still_moving = bool(self.case.settles and status is RunStatus.COMPLETED and self.rest.t_rest is None)
        warnings = []
        length, time_unit = self.case.unit("length"), self.case.unit("time")
        if still_moving:
            ended = ("time.max_steps" if cfg.time.max_steps is not None and st.step >= cfg.time.max_steps
                     else "time.stop_time")
            warnings.append(
                f"still moving at t = {st.t:.4g} {time_unit} (rms granular speed {rms:.3g} "
                f"{self.case.unit('speed')} > output.rest_speed {self.rest_speed:.3g}): the run reached "
                f"{ended} before the flow came to rest, so the run-out "
                + (f"{runout:.4g} {length}" if np.isfinite(runout) else "")
                + " is not final; raise time.stop_time and set time.stop_at_rest")
        pic = cfg.numerics.picard
        if tot.not_converged and pic.max_sweeps > 1:  # max_sweeps = 1: one solve per step, by choice
            warnings.append(
                f"Picard iteration not converged in {tot.not_converged} of {st.step} steps "
                f"({100.0 * tot.not_converged / max(st.step, 1):.0f} %): those steps were accepted after "
                f"numerics.picard.max_sweeps = {pic.max_sweeps} sweeps with a velocity increment between "
                f"tol = {pic.tol:g} and fail_tol = {pic.fail_tol:g}")
        return still_moving, warnings

    def summary(self, status: RunStatus, message: str = "", checkpoint: Path | None = None) -> dict[str, Any]:
        """The ``summary.json`` content (NaN and inf become null)."""
        sim, g, cfg = self.sim, self.grid, self.config
        st, tot, b = sim.state, sim.totals, sim.budget
        fronts, rest = self.front_recorder, self.rest
        mass = dg.mass(g, st.phi)
        x_final = self.front()
        x_first = fronts.x[0] if fronts.x else float("nan")
        h = dg.deposit_thickness(g, st.phi, self.phi_max)
        closure = sim.model.closure
        rms, _ = granular_speeds(sim.model, st)
        still_moving, warnings = self._end_warnings(status, rms, x_final - x_first)
        energy = energy_residual(b)
        return {
            "case": cfg.case.name, "status": status.value, "message": message,
            "warnings": list(self.warnings) + warnings, "still_moving": still_moving,
            "wall_contact": self.walls.first,
            "rms_speed_final": rms,
            "t_final": st.t, "stop_time": cfg.time.stop_time, "steps": st.step,
            "rejected_steps": tot.rejected, "wall_s": self.wall_s(),
            "runout_m": x_final - x_first,
            "front_position": {"threshold_m": self.threshold, "t_s": list(fronts.t),
                               "x_m": list(fronts.x), "final_m": x_final,
                               "definition": dg.FRONT_DEFINITION,
                               # fronts are quantised by the column width (diagnostics.front_from_thickness)
                               "resolution_m": g.dx},
            "final_height_at_wall": float(h[0]),
            "topography": topography_summary(sim.model),
            "t_rest": rest.t_rest, "rest_speed": self.rest_speed, "peak_speed": rest.peak_speed,
            "stopped_at_rest": rest.stopped_at_rest,
            "mass_rel_error": ((mass + tot.clipped_mass - tot.added_mass + tot.outflow_mass - tot.inflow_mass
                                - self.mass0) / (self.mass0 + max(tot.inflow_mass, 0.0))),
            "mass_change_rel": (mass - self.mass0) / self.mass0,
            "clipped_mass": tot.clipped_mass / self.mass0,
            "added_mass": tot.added_mass / self.mass0,
            "outflow_mass": tot.outflow_mass / self.mass0,
            "inflow_mass": tot.inflow_mass / self.mass0,
            "limited_mass": tot.limited_mass / self.mass0,
            "phi_min": float(st.phi.min()), "phi_max": float(st.phi.max()),
            "phi_max_before_clip": tot.max_phi_before_clip,
            "phi_min_before_clip": tot.min_phi_before_clip,
            "energy_residual_rel": energy["relative"],
            "energy_residual": energy,
            "energy": {"released": b.released, "released_gas": b.released_gas, "injected": b.injected,
                       "outflow": b.outflow_mechanical + b.outflow_gas,
                       "inflow": b.inflow_mechanical + b.inflow_gas, "source_work": b.source_work,
                       "dissipated": b.dissipated, "kinetic": b.e_k,
                       "residual": b.residual, **{f"numerical_{k}": v for k, v in b.numerical.items()}},
            "picard": {"iterations": tot.picard_iterations, "not_converged_steps": tot.not_converged,
                       "not_converged_fraction": tot.not_converged / st.step if st.step else 0.0,
                       "max_cells_negative_Z": tot.max_negative_Z, "max_sweeps": cfg.numerics.picard.max_sweeps},
            "linear_solver": {"name": sim.model.linear_solver_name,
                              "krylov_iterations": tot.linear_iterations,
                              # solves PARDISO handed to SuperLU (residual check; counted since this process started)
                              "fallbacks": int(getattr(sim.model.linear_solver, "fallbacks", 0)),
                              # cells around the grains where the velocity is solved (0: everywhere)
                              "velocity_band_cells": sim.model.velocity_band or 0},
            "closure": closure.describe(),
            "resolution": {"nx": g.nx, "nz": g.nz, "dx_m": g.dx, "dz_m": g.dz, "geometry": g.geometry.value},
            "case_diagnostics": self.case.diagnostics(sim, cfg),
            "files": {"output": OUTPUT_FILE,
                      "checkpoint": str(checkpoint.relative_to(self.directory)) if checkpoint else None},
            "units": case_units(self.case, g),
            "granflow_version": _version(), "git_revision": git_revision(),
        }


ENERGY_REFERENCE_TOL = 1e-6
"""An energy source smaller than this fraction of the energy present is no reference for the
residual (a static layer releases round-off: its "relative" residual would be 1e10)."""


def energy_residual(budget) -> dict[str, Any]:
    """The energy-budget residual, absolute [J m-1], and relative to its reference: the largest
    energy source of the run -- the released potential energy (collapses), the released gas energy
    (a draining bed) or the injected gas energy. ``relative`` is null when even that source is
    negligible (below :data:`ENERGY_REFERENCE_TOL` of the energy present: a layer at rest)."""
    sources = {"released potential energy": budget.released,
               "released gas energy": budget.released_gas,
               "injected gas energy": budget.injected,
               "energy supplied by the source": sum(getattr(budget, k, 0.0) for k in
                                                    ("inflow_mechanical", "inflow_gas", "source_work"))}
    name, value = max(sources.items(), key=lambda kv: kv[1])
    present = abs(budget.e_p0) + budget.e_k0 + budget.e_10 + abs(budget.injected)
    usable = value > ENERGY_REFERENCE_TOL * present and value > 0.0
    return {"absolute": budget.residual, "reference": name if usable else None,
            "reference_value": value if usable else None,
            "relative": budget.residual / value if usable else None,
            "energy_present": present}


def geometry_unit(unit: str, grid) -> str:
    """``unit`` of an integral over the grid: per unit width in a plane (``J m-1``), over the whole
    cylinder on an axisymmetric grid (``J``)."""
    return "J" if unit == "J m-1" and grid is not None and grid.axisymmetric else unit


def case_units(case, grid=None) -> dict[str, str]:
    """The ``units`` entry of summary.json in the case's own units (H0, sqrt(H0/g) for the
    dimensionless Lagree column; energies over the cylinder on an axisymmetric ``grid``)."""
    length, time_unit = case.unit("length"), case.unit("time")
    speed, energy = case.unit("speed"), geometry_unit(case.unit("energy"), grid)
    units = dict(UNITS)
    units.update({"runout_m": length, "front_position": f"{length} (t_s in {time_unit})",
                  "final_height_at_wall": length, "t_rest": time_unit, "rest_speed": speed,
                  "peak_speed": speed, "rms_speed_final": speed, "energy": energy,
                  "energy_residual": f"{energy} (relative: 1, of the named reference)",
                  "t_final": time_unit})
    if case.units:
        units["note"] = ("dimensionless case: keys ending in _m or _s are in the units above, "
                         "not metres and seconds")
    return units


def _version() -> str:
    from granflow import __version__

    return __version__
