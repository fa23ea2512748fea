"""Diagnostics recorders of a :class:`~granflow.simulation.Simulation` (its ``diagnostics``)::

    sim.output_writers["fields"] = NetCDFOutputWriter(model, "out.nc", outputs, TimeInterval(0.05))
    sim.diagnostics["front"] = FrontRecorder(threshold=5e-3, writer=sim.output_writers["fields"])
    sim.diagnostics["rest"] = RestDetector(rest_speed=1e-3, schedule=IterationInterval(1))

* :class:`FrontRecorder`: the front position (:func:`granflow.diagnostics.front_position`) at
  each due time, its history kept in checkpoints; given a writer, exactly at the writer's record
  times (:func:`front_output` is the writer's ``x_front`` variable of the same values);
* :class:`RestDetector`: the time since which the granular flow is at rest (rms speed of the
  granular faces below ``rest_speed``) and the peak speed; with ``hold`` it ends the run once at
  rest that long;
* :class:`WallContactRecorder`: grains reaching the east wall or the lid
  (:mod:`granflow.output.wall_contact`), warned once and flagged in the writer's file;
* :class:`EquilibriumRangeCheck`: warns once when the run reaches an inertial number at which the
  closure's phi_eq(I) < 0.

Warnings go to the logger and to a ``warnings`` list (shared by the recorders of a run, so that it
keeps their order). The checkpoint keys are the case runner's (``run.front_t``...), so that its
checkpoints written before these recorders existed restart.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import diagnostics as dg
from granflow.errors import GranflowInputError
from granflow.output.fields import SERIES_SPECS, Output, si_unit
from granflow.output.netcdf import TIME_DIM, VariableSpec
from granflow.output.wall_contact import SIDES, WallWatch, warning_text
from granflow.schedules import Schedule, check_schedule

if TYPE_CHECKING:
    from granflow.model import Model
    from granflow.output.writers import NetCDFOutputWriter
    from granflow.simulation import Simulation

logger = logging.getLogger(__name__)


def _warn(sink: list[str], text: str) -> None:
    sink.append(text)
    logger.warning(f"granflow: warning: {text}")


def _new_record(t: float, last_t: float, writer: NetCDFOutputWriter | None) -> bool:
    """True if time ``t`` [s] is after ``last_t`` and, with a writer, after its last record (the
    writer then writes one now: diagnostics run before the writers)."""
    return t > last_t and (writer is None or t > writer.last_time)


def _schedule_of(schedule: Schedule | None, writer: NetCDFOutputWriter | None, where: str) -> Schedule:
    """``schedule``, or the writer's when only a writer is given."""
    if schedule is None and writer is not None:
        return writer.schedule
    return check_schedule(schedule, where)


def granular_speeds(model: Model, state) -> tuple[float, float]:
    """(rms, max) speed of the granular faces (``phi_face >= phi_c``) [m s^-1]; the rms is
    weighted by ``phi_face`` (a mass-weighted mean), so that the few interface faces where
    grains left in the ambient by numerical diffusion fall onto the deposit do not decide
    whether the deposit is at rest. (0, 0) without granular faces."""
    phi_f = model.ops.cell_to_face @ state.phi.ravel()
    faces = phi_f >= model.ambient.phi_c
    if not np.any(faces):
        return 0.0, 0.0
    v = state.vel[faces]
    weight = getattr(model, "unknown_weight", None)  # axisymmetric: each face's ring mass
    mass = phi_f[faces] if weight is None else model.dual_mean(state.phi)[faces] * weight[faces]
    rms = float(np.sqrt(np.sum(mass * v * v) / np.sum(mass)))
    return rms, float(np.max(np.abs(v)))


def front_position(sim: Simulation, threshold: float) -> float:
    """Front position of the simulation's state [m] for a deposit ``threshold`` [m] (nan if no
    column is above it)."""
    return dg.front_position(sim.model.grid, sim.state.phi, sim.model.material.phi_max, threshold)


def front_output(threshold: float, unit: Callable[[str], str] = si_unit) -> Output:
    """The ``x_front`` time series of a writer: :func:`front_position` [m] at each record (a
    :class:`FrontRecorder` given the writer records the same values)."""
    units, long_name = SERIES_SPECS["x_front"]
    return Output(lambda sim: np.float64(front_position(sim, threshold)),
                  VariableSpec((TIME_DIM,), unit(units), long_name))


class FrontRecorder:
    """History of the front position [m] (nan while no column is above the threshold).

    Parameters
    ----------
    threshold : float
        Deposit thickness defining the front [m] (:func:`granflow.diagnostics.front_position`).
    schedule : TimeInterval or IterationInterval, optional
        When to record (default: the writer's).
    writer : NetCDFOutputWriter, optional
        Record exactly at this writer's records (on its schedule, and at its final record).
    """

    T_KEY, X_KEY = "run.front_t", "run.front_x"

    def __init__(self, threshold: float, schedule: Schedule | None = None,
                 writer: NetCDFOutputWriter | None = None) -> None:
        if not (isinstance(threshold, (int, float)) and np.isfinite(threshold) and threshold > 0):
            raise GranflowInputError(f"FrontRecorder: threshold must be a length > 0 [m], got {threshold!r}")
        self.threshold = float(threshold)
        self.writer = writer
        self.schedule = _schedule_of(schedule, writer, "FrontRecorder")
        self.t: list[float] = []
        """Times of the records [s]."""
        self.x: list[float] = []
        """Front position at those times [m]."""

    def position(self, sim: Simulation) -> float:
        """Front position of the current state [m] (nan if no column is above the threshold)."""
        return front_position(sim, self.threshold)

    def __call__(self, sim: Simulation) -> None:
        t = sim.state.t
        if not _new_record(t, self.t[-1] if self.t else -np.inf, self.writer):
            return  # recorded already (a restart at a record time), or no record of the writer
        self.t.append(t)
        self.x.append(self.position(sim))

    def finalize(self, sim: Simulation, completed: bool) -> None:
        """A completed run records its final state (if not recorded), as the writers do."""
        if completed:
            self(sim)

    def checkpoint_payload(self, sim: Simulation) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        return {self.T_KEY: np.asarray(self.t, dtype=float), self.X_KEY: np.asarray(self.x, dtype=float)}, {}

    def restore_checkpoint(self, arrays: Mapping[str, np.ndarray], scalars: Mapping[str, Any]) -> None:
        self.t = [float(v) for v in arrays[self.T_KEY]]
        self.x = [float(v) for v in arrays[self.X_KEY]]


class RestDetector:
    """When the granular flow came to rest, and its peak speed.

    Parameters
    ----------
    rest_speed : float
        At rest while the rms speed of the granular faces (:func:`granular_speeds`) is at most
        this [m s^-1].
    schedule : IterationInterval or TimeInterval
        Usually every step.
    hold : float, optional
        End the run (its stop time becomes the current time: it completes) once at rest for this
        long [s]; never before a source (:attr:`granflow.model.Model.source`) has stopped.
    """

    T_REST_KEY, PEAK_KEY = "run.t_rest", "run.peak_speed"

    def __init__(self, rest_speed: float, schedule: Schedule, hold: float | None = None) -> None:
        if not (isinstance(rest_speed, (int, float)) and np.isfinite(rest_speed) and rest_speed >= 0):
            raise GranflowInputError(f"RestDetector: rest_speed must be a speed >= 0 [m s-1], got {rest_speed!r}")
        if hold is not None and not (isinstance(hold, (int, float)) and hold >= 0):
            raise GranflowInputError(f"RestDetector: hold must be a duration >= 0 [s] or None, got {hold!r}")
        self.rest_speed = float(rest_speed)
        self.schedule = check_schedule(schedule, "RestDetector")
        self.hold = hold
        self.t_rest: float | None = None
        """Time since which the flow is at rest [s] (None: moving)."""
        self.peak_speed = 0.0
        """Largest speed of a granular face so far [m s^-1]."""
        self.stopped_at_rest = False
        """True once ``hold`` ended the run."""

    def __call__(self, sim: Simulation) -> None:
        rms, speed = granular_speeds(sim.model, sim.state)
        self.peak_speed = max(self.peak_speed, speed)
        if rms > self.rest_speed:
            self.t_rest = None
        elif self.t_rest is None:
            self.t_rest = sim.state.t
        source = getattr(sim.model, "source", None)  # a supply still to come or running: not done
        if source is not None and sim.state.t < source.stop:
            return
        if self.hold is not None and self.t_rest is not None and sim.state.t - self.t_rest >= self.hold:
            sim.stop_time = sim.state.t  # at rest long enough: done() is now true, the run completes
            self.stopped_at_rest = True

    def checkpoint_payload(self, sim: Simulation) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        return {}, {self.T_REST_KEY: self.t_rest, self.PEAK_KEY: self.peak_speed}

    def restore_checkpoint(self, arrays: Mapping[str, np.ndarray], scalars: Mapping[str, Any]) -> None:
        self.t_rest = scalars[self.T_REST_KEY]
        self.peak_speed = float(scalars[self.PEAK_KEY])


NOT_REACHED = -1.0
"""Checkpoint value of a wall-contact time that has not happened (times are >= 0) [s]."""


class WallContactRecorder:
    """Grains reaching the east wall or the lid: a warning once per side, and the flags
    (:meth:`WallWatch.attributes`) in ``writer``'s file from its first record on.

    Parameters
    ----------
    writer : NetCDFOutputWriter
        Checked at its records (on its schedule, and at its final record).
    length_key : str
        The configuration key that enlarges the box, named in the warning.
    time_unit : str
        Unit of the times in the warning.
    warnings : list of str, optional
        Where the warnings are added (besides the log).
    """

    def __init__(self, writer: NetCDFOutputWriter, length_key: str = "grid.Lx", time_unit: str = "s",
                 warnings: list[str] | None = None) -> None:
        self.writer = writer
        self.schedule = writer.schedule
        self.length_key = length_key
        self.time_unit = time_unit
        self.warnings = warnings if warnings is not None else []
        self.watch: WallWatch | None = None
        self._last_t = -np.inf
        self._rewrite = False
        """Write the flags at the next record (a restart: the resumed file may lack them)."""

    def __call__(self, sim: Simulation) -> None:
        t = sim.state.t
        if not _new_record(t, self._last_t, self.writer):
            return
        self._last_t = t
        if self.watch is None:
            self.watch = WallWatch(sim.model.grid.periodic_x)
        self.watch.periodic_x = sim.model.grid.periodic_x  # (a restored watch does not know it)
        out = sim.totals.outflow_mass / sim.model.grid.cell_volume
        new = self.watch.check(sim.state.phi, sim.model.material.phi_max, t, outflow_cells=out)
        for side in new:
            _warn(self.warnings, warning_text(side, t, self.time_unit, self.length_key))
        if new or self.writer.n_records == 0 or self._rewrite:  # the flags exist from the first record on
            self.writer.set_attributes(self.watch.attributes())
            self._rewrite = False

    def finalize(self, sim: Simulation, completed: bool) -> None:
        if completed:
            self(sim)

    KEY = "walls"
    """Prefix of the recorder's checkpoint scalars."""

    def checkpoint_payload(self, sim: Simulation) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Scalars ``walls.first.<side>`` (first contact time [s], -1: not reached; checkpoint
        scalars must be finite),
        ``walls.initial.<side>`` (1: touched in the first record, never reported; -1: no record
        checked yet) and ``walls.last_t``, so that a restart keeps the flags and warnings."""
        scalars: dict[str, Any] = {f"{self.KEY}.last_t": float(self._last_t) if np.isfinite(self._last_t)
                                   else NOT_REACHED}
        for side in SIDES:
            first = self.watch.first.get(side, NOT_REACHED) if self.watch is not None else NOT_REACHED
            initial = (-1 if self.watch is None or self.watch.initial is None
                       else int(side in self.watch.initial))
            scalars[f"{self.KEY}.first.{side}"] = float(first)
            scalars[f"{self.KEY}.initial.{side}"] = initial
        return {}, scalars

    def restore_checkpoint(self, arrays: Mapping[str, np.ndarray], scalars: Mapping[str, Any]) -> None:
        """Continue from :meth:`checkpoint_payload`: the contacts found before the checkpoint are
        kept (and their warnings listed again, not logged again), and the next record writes the
        flags into the resumed file. A checkpoint without these scalars (written before they
        existed) starts a fresh watch."""
        if f"{self.KEY}.last_t" not in scalars:
            return
        last = float(scalars[f"{self.KEY}.last_t"])
        self._last_t = -np.inf if last == NOT_REACHED else last
        # (a side added after the checkpoint was written: not touched, not reached)
        initial = {side: int(scalars.get(f"{self.KEY}.initial.{side}", 0)) for side in SIDES}
        if any(v < 0 for v in initial.values()):
            return  # no record had been checked: nothing to keep
        self.watch = WallWatch(periodic_x=False)  # set from the grid at the next record
        self.watch.initial = {side for side in SIDES if initial[side] == 1}
        for side in SIDES:
            t = float(scalars.get(f"{self.KEY}.first.{side}", NOT_REACHED))
            if t != NOT_REACHED:
                self.watch.first[side] = t
                self.warnings.append(warning_text(side, t, self.time_unit, self.length_key))
        self._rewrite = True

    @property
    def first(self) -> dict[str, float]:
        """Side -> first time it was reached [s]."""
        return dict(self.watch.first) if self.watch is not None else {}


class EquilibriumRangeCheck:
    """Warn once when the run reaches an I at which the closure's phi_eq(I) < 0 (e.g. a large
    ``material.delta_phi``): the equilibrium law is then outside its meaning. Never for an
    isochoric closure (``closure.isochoric``, f = 0: ``incompressible``), whose flow does not
    depend on phi_eq (the Lagree column at 512^2 warned at I = 8.3 in its sheet).

    Parameters
    ----------
    schedule : TimeInterval or IterationInterval, optional
        When to check (default: the writer's).
    writer : NetCDFOutputWriter, optional
        Check exactly at this writer's records.
    law_name : str
        Name of the equilibrium law in the warning.
    warnings : list of str, optional
        Where the warning is added (besides the log).
    """

    def __init__(self, schedule: Schedule | None = None, writer: NetCDFOutputWriter | None = None,
                 law_name: str = "", warnings: list[str] | None = None) -> None:
        self.writer = writer
        self.schedule = _schedule_of(schedule, writer, "EquilibriumRangeCheck")
        self.law_name = law_name
        self.warnings = warnings if warnings is not None else []
        self.warned = False
        self._last_t = -np.inf

    def __call__(self, sim: Simulation) -> None:
        m, st = sim.model, sim.state
        if self.warned or m.closure.isochoric or not _new_record(st.t, self._last_t, self.writer):
            return  # (an isochoric closure, f = 0, never reads phi_eq: nothing to warn about)
        self._last_t = st.t
        grains = (st.phi >= m.ambient.phi_c) & (st.p > 0)
        if not np.any(grains):
            return
        ops = getattr(m, "axisymmetric_operators", None) or m.ops  # (|S| with the hoop strain)
        S = ops.strain_rate_norm(st.vel).reshape(m.grid.cell_shape)
        I = m.material.inertial_number(S[grains], st.p[grains])
        I = I[np.isfinite(I)]
        if not I.size:
            return
        I_max = float(I.max())
        law = m.closure.equilibrium
        phi_eq = float(law.phi_eq(I_max))
        if phi_eq < 0:
            _warn(self.warnings, f"phi_eq(I) = {phi_eq:.3g} < 0 at I = {I_max:.3g}, reached at "
                  f"t = {st.t:.6g} s (equilibrium law {self.law_name!r}, "
                  f"delta_phi = {getattr(law, 'delta_phi', float('nan')):g}): the dilatancy law "
                  "is outside its range; lower delta_phi or use a law with phi_eq > 0 at every I")
            self.warned = True

    def finalize(self, sim: Simulation, completed: bool) -> None:
        if completed:
            self(sim)
