"""Run a case with output: NetCDF fields, ``summary.json``, checkpoints, restart, progress.

:class:`CaseRun` builds the :class:`~granflow.simulation.Simulation` of a case through the
registry and hangs on it, in this order (the checkpoint last, so that a periodic checkpoint
sees every other callback of its step done):

1. ``output`` (:class:`~granflow.simulation.TimeInterval` ``output.interval``): one NetCDF record
   (:class:`granflow.output.NetCDFWriter`, synced after each record, so a killed run leaves a
   readable file) of phi, u and w at cell centres, p, p_f, |S|, the kinetic energy and the front;
2. ``monitor`` (every step): rest detection for ``t_rest`` and the progress report;
3. ``checkpoint`` (every ``output.checkpoint_interval`` steps):
   ``checkpoints/checkpoint_<step>.npz`` (:class:`granflow.output.CheckpointManager`).

Whatever ends the run -- the stop time, a :class:`~granflow.simulation.StepFailure`, a
``KeyboardInterrupt`` or :meth:`~granflow.simulation.Simulation.request_stop` -- the state of the
last accepted step gets a checkpoint and ``summary.json`` (written atomically); a completed run
also gets a final NetCDF record if the stop time is not an output time (an interrupted or failed
run keeps its records on the output times, so that its restart rewrites the same file). A restart (``restart=`` a checkpoint file or a run directory) restores the state,
the energy budget, the totals, the phase of the output schedule and the diagnostics history, and
continues the NetCDF file (records after the checkpoint time are dropped and written again), so a
restarted run reproduces the uninterrupted one bit for bit.
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
from granflow.cases.memory import check_memory
from granflow.cases.output_specs import FIELD_SPECS, PROBE_DIM, PROBE_SPECS, SERIES_SPECS, SI_KIND, UNIT_KINDS
from granflow.cases.registry import CASES
from granflow.cases.restart import (
    CHECKPOINT_DIR,
    check_checkpoint,
    check_resume_output,
    resolve_checkpoint,
)
from granflow.cases.step_clock import StepClock
from granflow.cases.wall_contact import WallWatch, warning_text
from granflow.config import CaseConfig
from granflow.errors import GranflowInputError
from granflow.output import (
    FIELD_DIMS,
    CheckpointManager,
    NetCDFWriter,
    VariableSpec,
    load_checkpoint,
    write_json_atomic,
)
from granflow.output.netcdf import git_revision
from granflow.output.paths import check_directory
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

UNITS = {
    "runout_m": "m", "front_position": "m (t_s in s)", "final_height_at_wall": "m",
    "t_rest": "s", "rest_speed": "m s-1", "peak_speed": "m s-1", "mass_rel_error": "1",
    "clipped_mass": "1 (fraction of the initial mass)", "limited_mass": "1 (fraction of the initial mass)", "phi_min": "1", "phi_max": "1",
    "energy_residual_rel": "1 (of energy_residual.reference, the run's largest energy source; null if negligible)",
    "energy": "J m-1",
    "wall_s": "s", "t_final": "s",
}


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
    """True while the kernels compile (:mod:`granflow.cases.step_clock`): no rate, no ETA."""


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
        self.probe_cells = np.clip(np.floor((np.asarray(out.probes_x, dtype=float) - self.grid.x0) / self.grid.dx),
                                   0, self.grid.nx - 1).astype(int)  # the cell containing each x
        self.rest_speed = (out.rest_speed if out.rest_speed is not None
                           else REST_SPEED_FACTOR * config.numerics.eps * self.grid.Lz)
        self.progress = progress
        self.warnings: list[str] = []
        self._phi_eq_warned = False
        self.walls = WallWatch(self.grid.periodic_x)
        self.front_t: list[float] = []
        self.front_x: list[float] = []
        self.mass0 = dg.mass(self.grid, self.sim.state.phi)
        self.t_rest: float | None = None
        self.stopped_at_rest = False
        self.peak_speed = 0.0
        self.wall_before = 0.0
        self._last_out_t = -np.inf
        self._last_ckpt_step = -1
        self._session_t0 = (self.sim.state.t, time.perf_counter())
        self.sim.add_callback(self._write_output, TimeInterval(out.interval), name="output")
        self.sim.add_callback(self._monitor, IterationInterval(EVERY_STEP), name="monitor")
        self.sim.add_callback(self._periodic_checkpoint, IterationInterval(out.checkpoint_interval),
                              name="checkpoint")
        self._resume: tuple[np.ndarray, np.ndarray] | None = None
        if restart is not None:  # every check of the checkpoint before anything is written
            self._restore(resolve_checkpoint(restart))
            if self.output_path.exists():
                self._resume = check_resume_output(self.output_path, self.grid.nx, self.grid.nz)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.checkpoints = CheckpointManager(self.directory / CHECKPOINT_DIR, keep=out.checkpoint_keep)
        if restart is None:
            for old in self.checkpoints.steps():
                self.checkpoints.path(old).unlink(missing_ok=True)
        self._session_t0 = (self.sim.state.t, time.perf_counter())
        self._clock = StepClock()
        """Rate and ETA of the progress line, without the steps that compile the Numba kernels."""
        self.writer = self._open_writer(resume=self._resume is not None)

    # --- output ---------------------------------------------------------------------------------
    def _declarations(self) -> tuple[dict, dict, dict]:
        g = self.grid
        unit = self.case_unit
        length = unit("length")
        coords = {"x": (np.asarray(g.xc), {"units": length, "long_name": "x of the cell centres",
                                          "axis": "X"}),
                  "z": (np.asarray(g.zc), {"units": length, "long_name": "height z of the cell centres",
                                          "axis": "Z", "positive": "up",
                                          **({"standard_name": "height"} if length == "m" else {})})}
        variables = {}
        for name in self._field_names():
            units, long_name = FIELD_SPECS[name]
            attrs = {"phi_max": self.phi_max} if name == "phi" else None
            variables[name] = VariableSpec(FIELD_DIMS, unit(SI_KIND.get(units, units)), long_name,
                                           attrs=attrs)
        for name, (units, long_name) in SERIES_SPECS.items():
            variables[name] = VariableSpec(("time",), unit(SI_KIND.get(units, units)), long_name)
        if self.probe_cells.size:
            coords[PROBE_DIM] = (self.grid.xc[self.probe_cells], {
                "units": length, "long_name": "x of the cell centre of each basal probe"})
            for name, (units, long_name) in PROBE_SPECS.items():
                variables[name] = VariableSpec(("time", PROBE_DIM), unit(SI_KIND.get(units, units)), long_name)
        attrs = {"case": self.config.case.name, "config_effective": self.config.to_toml(),
                 "overrides": " ".join(self.config.overrides), "phi_max": self.phi_max,
                 "front_threshold_m": self.threshold, "closure": self.sim.model.closure.name,
                 "rest_speed": self.rest_speed, "phi_c": self.sim.model.ambient.phi_c,
                 **{f"{kind}_unit": unit(kind) for kind in UNIT_KINDS}}
        if self.case.units:
            attrs["units_note"] = (f"dimensionless case: lengths in {length}, times in {unit('time')}; "
                                   "names ending in _m or _s keep those units")
        return coords, variables, attrs

    def case_unit(self, kind: str) -> str:
        """Unit of ``kind`` (``length``, ``time``, ``speed``, ``pressure``, ``rate``, ``energy``,
        or an SI unit string, returned as is) in this case (:attr:`Case.units`)."""
        if kind not in UNIT_KINDS:
            return kind
        return self.case.unit(kind)

    def _open_writer(self, resume: bool) -> NetCDFWriter:
        coords, variables, attrs = self._declarations()
        kw = {"case_file": self.config.source_text, "title": f"granflow {self.config.case.name}",
              "time_units": self.case_unit("time")}
        if not resume:
            return NetCDFWriter(self.output_path, coords, variables, attrs, **kw)
        t = self.sim.state.t
        times, old = self._resume
        new = np.asarray(self.grid.xc[self.probe_cells], dtype=float)
        if old.shape != new.shape or not np.array_equal(old, new):
            raise GranflowInputError(f"--restart: output.probes_x gives probe cells at x = {new.tolist()} m, "
                                     f"but {self.output_path} has {old.tolist()} m; keep the original probes_x")
        kept = times[times <= t]
        self._last_out_t = float(kept.max()) if kept.size else -np.inf
        return NetCDFWriter.resume(self.output_path, t, coords, variables, attrs, **kw)

    def _fields(self) -> dict[str, np.ndarray]:
        g, st = self.grid, self.sim.state
        u, w = g.unpack_velocity(st.vel)
        c = st.c if st.c is not None or not self.sim.model.indicator else self.sim.model.material_of(st.phi)
        all_fields = {"phi": st.phi, "c": c, "u": 0.5 * (u[1:, :] + u[:-1, :]),
                      "w": 0.5 * (w[:, 1:] + w[:, :-1]), "p": st.p, "p_f": st.p_f,
                      "S": self.sim.model.ops.strain_rate_norm(st.vel).reshape(g.cell_shape)}
        return {k: all_fields[k].T for k in self._field_names()}  # (x, z) -> (z, x) on disk

    def _field_names(self) -> list[str]:
        """``output.fields`` less ``c`` when the model has no material indicator."""
        return [k for k in self.config.output.fields if k != "c" or self.sim.model.indicator]

    def front(self) -> float:
        """Front position of the current state [m] (nan if no column is above the threshold)."""
        return dg.front_position(self.grid, self.sim.state.phi, self.phi_max, self.threshold)

    def _write_output(self, sim: Simulation) -> None:
        t = sim.state.t
        if t <= self._last_out_t:  # already written (restart at an output time)
            return
        x_f = self.front()
        probes = {}
        if self.probe_cells.size:
            st = sim.state
            probes = {"probe_p_f": st.p_f[self.probe_cells, 0], "probe_p": st.p[self.probe_cells, 0]}
        self.writer.append(t, {**self._fields(), "kinetic_energy": np.float64(sim.budget.e_k),
                               "x_front": np.float64(x_f), **probes})
        self._check_equilibrium_range()
        self._check_walls(t)
        self._last_out_t = t
        self.front_t.append(t)
        self.front_x.append(x_f)

    def _check_walls(self, t: float) -> None:
        """Warn (once per side) when grains reach the east wall or the lid (module
        :mod:`granflow.cases.wall_contact`); flag it in output.nc."""
        new = self.walls.check(self.sim.state.phi, self.phi_max, t)
        key = "setup.Lx" if hasattr(self.config.setup, "Lx") else "grid.Lx"
        for side in new:
            text = warning_text(side, t, self.case_unit("time"), key)
            self.warnings.append(text)
            logger.warning(f"granflow: warning: {text}")
        if new or not self.front_t:  # the flags exist (0) from the first record on
            self.writer.set_attributes(self.walls.attributes())

    def _check_equilibrium_range(self) -> None:
        """Warn (once) when the run reaches an I at which phi_eq(I) < 0 (e.g. a large
        material.delta_phi): the equilibrium law is then outside its meaning."""
        if self._phi_eq_warned:
            return
        m, st = self.sim.model, self.sim.state
        grains = (st.phi >= m.ambient.phi_c) & (st.p > 0)
        if not np.any(grains):
            return
        S = m.ops.strain_rate_norm(st.vel).reshape(self.grid.cell_shape)
        I = m.material.inertial_number(S[grains], st.p[grains])
        I = I[np.isfinite(I)]
        if not I.size:
            return
        I_max = float(I.max())
        law = m.closure.equilibrium
        phi_eq = float(law.phi_eq(I_max))
        if phi_eq < 0:
            text = (f"phi_eq(I) = {phi_eq:.3g} < 0 at I = {I_max:.3g}, reached at "
                    f"t = {st.t:.6g} s (equilibrium law {self.config.equilibrium.law!r}, "
                    f"delta_phi = {getattr(law, 'delta_phi', float('nan')):g}): the dilatancy law "
                    "is outside its range; lower delta_phi or use a law with phi_eq > 0 at every I")
            self.warnings.append(text)
            self._phi_eq_warned = True
            logger.warning(f"granflow: warning: {text}")

    # --- monitor, checkpoints -------------------------------------------------------------------
    def _speeds(self) -> tuple[float, float]:
        """(rms, max) speed of the granular faces (``phi_face >= phi_c``) [m s^-1]; the rms is
        weighted by ``phi_face`` (a mass-weighted mean), so that the few interface faces where
        grains left in the ambient by numerical diffusion fall onto the deposit do not decide
        whether the deposit is at rest."""
        st, m = self.sim.state, self.sim.model
        phi_f = m.ops.cell_to_face @ st.phi.ravel()
        faces = phi_f >= m.ambient.phi_c
        if not np.any(faces):
            return 0.0, 0.0
        v = st.vel[faces]
        rms = float(np.sqrt(np.sum(phi_f[faces] * v * v) / np.sum(phi_f[faces])))
        return rms, float(np.max(np.abs(v)))

    def _monitor(self, sim: Simulation) -> None:
        rms, speed = self._speeds()
        self.peak_speed = max(self.peak_speed, speed)
        if rms > self.rest_speed:
            self.t_rest = None
        elif self.t_rest is None:
            self.t_rest = sim.state.t
        hold = self.config.time.stop_at_rest
        if hold is not None and self.t_rest is not None and sim.state.t - self.t_rest >= hold:
            sim.stop_time = sim.state.t  # at rest long enough: done() is now true, status completed
            self.stopped_at_rest = True
        if self.progress is not None and sim.reports:
            rate = self._clock.tick(sim.state.t, time.perf_counter(), len(sim.reports), sim.stop_time)
            self.progress(Progress(t=sim.state.t, stop_time=sim.stop_time, dt=sim.reports[-1].dt,
                                   step=sim.state.step, steps_per_s=rate.steps_per_s, eta_s=rate.eta_s,
                                   wall_s=self.wall_s(), warming_up=rate.warming_up))

    def wall_s(self) -> float:
        """Wall time of the run so far, over all restarts [s]."""
        return self.wall_before + time.perf_counter() - self._session_t0[1]

    def _periodic_checkpoint(self, sim: Simulation) -> None:
        if sim.state.step > 0:
            self.save_checkpoint()

    def save_checkpoint(self) -> Path | None:
        """Checkpoint of the current state (skipped if this step already has one)."""
        step = self.sim.state.step
        if step == self._last_ckpt_step:
            return self.checkpoints.path(step)
        arrays, scalars = self.sim.checkpoint_payload()
        arrays.update({"run.front_t": np.asarray(self.front_t, dtype=float),
                       "run.front_x": np.asarray(self.front_x, dtype=float)})
        scalars.update({"run.t_rest": self.t_rest, "run.peak_speed": self.peak_speed,
                        "run.mass0": self.mass0, "run.wall_s": self.wall_s(),
                        "run.last_out_t": self._last_out_t})
        g = self.grid
        meta = {"case": self.config.case.name, "grid": [g.nx, g.nz, g.Lx, g.Lz],
                "config_effective": self.config.to_toml(), "case_file": self.config.source_path,
                **self._numerics_meta()}
        path = self.checkpoints.save(step, arrays, scalars, meta)
        self._last_ckpt_step = step
        return path

    def _numerics_meta(self) -> dict:
        """What decides the last bits of a step besides the case file: the linear solver ``auto``
        resolved to on this machine, and the velocity band in use."""
        model = self.sim.model
        return {"linear_solver": model.linear_solver_name, "velocity_band": int(model.velocity_band or 0)}

    def _restore(self, path: Path) -> None:
        arrays, scalars, meta = load_checkpoint(path)
        check_checkpoint(path, arrays, scalars, meta, self.config, self.grid, self.phi_max)
        try:
            self.sim.restore_checkpoint(arrays, scalars)
            self.front_t = [float(v) for v in arrays["run.front_t"]]
            self.front_x = [float(v) for v in arrays["run.front_x"]]
            self.t_rest = scalars["run.t_rest"]
            self.peak_speed = float(scalars["run.peak_speed"])
            self.mass0 = float(scalars["run.mass0"])
            self.wall_before = float(scalars["run.wall_s"])
            self._last_out_t = float(scalars["run.last_out_t"])
        except (KeyError, GranflowInputError) as err:
            raise GranflowInputError(f"--restart {path}: not a checkpoint of this case ({err})") from None
        for key, now in self._numerics_meta().items():
            then = meta.get(key)
            if then is not None and then != now:
                logger.warning("--restart: the checkpoint was written with %s = %r, this run uses %r: "
                               "it continues, but not bit for bit as the uninterrupted run would", key, then, now)
        max_steps = self.config.time.max_steps
        if max_steps is not None:
            self.sim.max_steps = max(max_steps - self.sim.state.step, 0)
        self._last_ckpt_step = self.sim.state.step
        logger.info("restarted from %s at t = %r s, step %d", path, self.sim.state.t, self.sim.state.step)

    # --- the run ---------------------------------------------------------------------------------
    def run(self) -> RunResult:
        """Run to the end; never raises for a step failure or an interruption (see RunStatus)."""
        status, message = RunStatus.COMPLETED, ""
        try:
            self.sim.run()
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
            if status is RunStatus.COMPLETED and self.sim.state.t > self._last_out_t:
                self._write_output(self.sim)  # the final state, even if off the output times
            checkpoint = self.save_checkpoint()
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

    def summary(self, status: RunStatus, message: str = "", checkpoint: Path | None = None) -> dict[str, Any]:
        """The ``summary.json`` content (NaN and inf become null)."""
        sim, g, cfg = self.sim, self.grid, self.config
        st, tot, b = sim.state, sim.totals, sim.budget
        mass = dg.mass(g, st.phi)
        x_final = self.front()
        x_first = self.front_x[0] if self.front_x else float("nan")
        h = dg.deposit_thickness(g, st.phi, self.phi_max)
        closure = sim.model.closure
        rms, _ = self._speeds()
        still_moving = bool(self.case.settles and status is RunStatus.COMPLETED and self.t_rest is None)
        warnings = []
        length, time_unit = self.case.unit("length"), self.case.unit("time")
        if still_moving:
            ended = ("time.max_steps" if cfg.time.max_steps is not None and st.step >= cfg.time.max_steps
                     else "time.stop_time")
            runout = x_final - x_first
            warnings.append(
                f"still moving at t = {st.t:.4g} {time_unit} (rms granular speed {rms:.3g} "
                f"{self.case.unit('speed')} > output.rest_speed {self.rest_speed:.3g}): the run reached "
                f"{ended} before the flow came to rest, so the run-out "
                + (f"{runout:.4g} {length}" if np.isfinite(runout) else "")
                + " is not final; raise time.stop_time and set time.stop_at_rest")
        if tot.not_converged:
            pic = cfg.numerics.picard
            warnings.append(
                f"Picard iteration not converged in {tot.not_converged} of {st.step} steps "
                f"({100.0 * tot.not_converged / max(st.step, 1):.0f} %): those steps were accepted after "
                f"numerics.picard.max_sweeps = {pic.max_sweeps} sweeps with a velocity increment between "
                f"tol = {pic.tol:g} and fail_tol = {pic.fail_tol:g}")
        energy = energy_residual(b)
        return {
            "case": cfg.case.name, "status": status.value, "message": message,
            "warnings": list(self.warnings) + warnings, "still_moving": still_moving,
            "wall_contact": dict(self.walls.first),
            "rms_speed_final": rms,
            "t_final": st.t, "stop_time": cfg.time.stop_time, "steps": st.step,
            "rejected_steps": tot.rejected, "wall_s": self.wall_s(),
            "runout_m": x_final - x_first,
            "front_position": {"threshold_m": self.threshold, "t_s": list(self.front_t),
                               "x_m": list(self.front_x), "final_m": x_final,
                               "definition": dg.FRONT_DEFINITION,
                               # fronts are quantised by the column width (diagnostics.front_from_thickness)
                               "resolution_m": g.dx},
            "final_height_at_wall": float(h[0]),
            "t_rest": self.t_rest, "rest_speed": self.rest_speed, "peak_speed": self.peak_speed,
            "stopped_at_rest": self.stopped_at_rest,
            "mass_rel_error": (mass + tot.clipped_mass - tot.added_mass - self.mass0) / self.mass0,
            "mass_change_rel": (mass - self.mass0) / self.mass0,
            "clipped_mass": tot.clipped_mass / self.mass0,
            "added_mass": tot.added_mass / self.mass0,
            "limited_mass": tot.limited_mass / self.mass0,
            "phi_min": float(st.phi.min()), "phi_max": float(st.phi.max()),
            "phi_max_before_clip": tot.max_phi_before_clip,
            "phi_min_before_clip": tot.min_phi_before_clip,
            "energy_residual_rel": energy["relative"],
            "energy_residual": energy,
            "energy": {"released": b.released, "released_gas": b.released_gas, "injected": b.injected,
                       "dissipated": b.dissipated, "kinetic": b.e_k,
                       "residual": b.residual, **{f"numerical_{k}": v for k, v in b.numerical.items()}},
            "picard": {"iterations": tot.picard_iterations, "not_converged_steps": tot.not_converged,
                       "not_converged_fraction": tot.not_converged / st.step if st.step else 0.0,
                       "max_cells_negative_Z": tot.max_negative_Z},
            "linear_solver": {"name": sim.model.linear_solver_name,
                              "krylov_iterations": tot.linear_iterations,
                              # solves PARDISO handed to SuperLU (residual check; counted since this process started)
                              "fallbacks": int(getattr(sim.model.linear_solver, "fallbacks", 0)),
                              # cells around the grains where the velocity is solved (0: everywhere)
                              "velocity_band_cells": sim.model.velocity_band or 0},
            "closure": closure.describe(),
            "resolution": {"nx": g.nx, "nz": g.nz, "dx_m": g.dx, "dz_m": g.dz},
            "case_diagnostics": self.case.diagnostics(sim, cfg),
            "files": {"output": OUTPUT_FILE,
                      "checkpoint": str(checkpoint.relative_to(self.directory)) if checkpoint else None},
            "units": case_units(self.case),
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
               "injected gas energy": budget.injected}
    name, value = max(sources.items(), key=lambda kv: kv[1])
    present = abs(budget.e_p0) + budget.e_k0 + budget.e_10 + abs(budget.injected)
    usable = value > ENERGY_REFERENCE_TOL * present and value > 0.0
    return {"absolute": budget.residual, "reference": name if usable else None,
            "reference_value": value if usable else None,
            "relative": budget.residual / value if usable else None,
            "energy_present": present}


def case_units(case) -> dict[str, str]:
    """The ``units`` entry of summary.json in the case's own units (H0, sqrt(H0/g) for the
    dimensionless Lagree column)."""
    length, time_unit = case.unit("length"), case.unit("time")
    speed, energy = case.unit("speed"), case.unit("energy")
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
