"""Output writers and checkpointers of a :class:`~granflow.simulation.Simulation` (its
``output_writers`` and ``checkpointers``; Oceananigans' shape)::

    sim.output_writers["fields"] = NetCDFOutputWriter(model, "out.nc", field_outputs(model),
                                                      schedule=TimeInterval(0.05))
    sim.checkpointers["checkpoint"] = Checkpointer("checkpoints", IterationInterval(100))

* :class:`NetCDFOutputWriter` writes one record of its :class:`~granflow.output.fields.Output` s
  each time its schedule is due, through :class:`granflow.output.NetCDFWriter` (CF attributes,
  synced after every record: a killed run leaves a readable file). The file is created by
  :meth:`~NetCDFOutputWriter.open` -- at the start of the run at the latest -- so that a restored
  writer continues the file of the checkpointed run (records after the checkpoint time are
  dropped and written again) instead of replacing it. At the end of a completed run it adds the
  final state if that is not a record already;
* :class:`Checkpointer` saves :meth:`Simulation.checkpoint_payload` (with everything the
  scheduled entries add) as ``checkpoint_<step>.npz`` (:class:`granflow.output.CheckpointManager`)
  on its schedule, skipping step 0, and -- whatever ends the run -- the last accepted state.
"""
from __future__ import annotations

import logging
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import GranflowInputError
from granflow.output.checkpoint import CheckpointManager
from granflow.output.fields import check_outputs, grid_coords
from granflow.output.netcdf import NetCDFFormat, NetCDFWriter
from granflow.schedules import Schedule, check_schedule
from granflow.topography import base_height

if TYPE_CHECKING:
    from granflow.model import Model
    from granflow.simulation import Simulation

logger = logging.getLogger(__name__)

LAST_RECORD_KEY = "run.last_out_t"
"""Checkpoint scalar of the time of the writer's last record [s] (the case runner's key)."""
STATE_STEP_KEY = "state.step"


def topography_attrs(model) -> dict[str, Any]:
    """Global attributes of a base profile (none on the flat base): its points
    ``topography_x``, ``topography_z`` [m] and the staircase the solver used, ``base_height``
    [m] per cell column (the top of its solid cells, :mod:`granflow.topography`)."""
    topo = getattr(model, "topography", None)
    if topo is None:
        return {}
    return {"topography_x": np.asarray(topo.x), "topography_z": np.asarray(topo.z),
            "base_height": base_height(model.grid, model.solid), "topography_units": "m"}


class NetCDFOutputWriter:
    """Write ``outputs`` of a simulation to a NetCDF file each time ``schedule`` is due.

    Parameters
    ----------
    model : Model
        Gives the grid (coordinates ``x``, ``z`` of the cell centres) and the default global
        attributes ``phi_max``, ``closure``, ``phi_c``.
    path : path-like
        The file; replaced when opened, unless the writer was restored from a checkpoint and the
        file exists (then continued, :meth:`granflow.output.NetCDFWriter.resume`).
    outputs : mapping of str to Output
        ``name -> Output(values(simulation), VariableSpec)``, e.g.
        :func:`granflow.output.fields.field_outputs`.
    schedule : TimeInterval or IterationInterval
    coords : mapping, optional
        Further coordinates ``name -> (values, attrs)`` (e.g. :meth:`BasalProbes.coords`).
    global_attrs : mapping, optional
        Global attributes added to (or replacing) the defaults.
    length_unit, time_units : str
        Units of the coordinates and of the time (``m``, ``s``; a dimensionless case's own).
    case_file, title, format
        As :class:`granflow.output.NetCDFWriter`.

    Raises
    ------
    GranflowInputError
        For a schedule that is not one, or outputs that are not :class:`Output` s.
    """

    def __init__(self, model: Model, path: str | os.PathLike, outputs: Mapping[str, Any],
                 schedule: Schedule, *, coords: Mapping[str, Any] | None = None,
                 global_attrs: Mapping[str, Any] | None = None, length_unit: str = "m",
                 time_units: str = "s", case_file: str = "", title: str = "granflow run",
                 format: NetCDFFormat | str = NetCDFFormat.CLASSIC_64BIT) -> None:
        self.schedule = check_schedule(schedule, "NetCDFOutputWriter")
        self.outputs = check_outputs(outputs)
        self.path = Path(path)
        self.coords = {**grid_coords(model.grid, length_unit), **dict(coords or {})}
        defaults = {"phi_max": model.material.phi_max, "closure": model.closure.name,
                    "phi_c": model.ambient.phi_c, **topography_attrs(model)}
        given = dict(global_attrs or {})
        self.global_attrs = {**given, **{k: v for k, v in defaults.items() if k not in given}}
        self._kwargs = {"case_file": case_file, "title": title, "time_units": time_units,
                        "format": NetCDFFormat(format)}
        self._writer: NetCDFWriter | None = None
        self.last_time = -np.inf
        """Time of the last record [s] (-inf: none); a time not after it is not written again."""
        self.restart_time: float | None = None
        """Time of the checkpoint this writer was restored from [s] (None: a fresh run)."""

    @property
    def variables(self) -> dict[str, Any]:
        """``name -> VariableSpec`` of the outputs."""
        return {name: out.spec for name, out in self.outputs.items()}

    @property
    def is_open(self) -> bool:
        return self._writer is not None and not self._writer.closed

    @property
    def n_records(self) -> int:
        """Records in the file (0 before it is opened)."""
        return self._writer.n_records if self._writer is not None else 0

    def open(self) -> None:
        """Create the file (with its header, and its directory), or continue it after a restore
        (idempotent)."""
        if self._writer is not None:
            return
        if self.restart_time is not None and self.path.exists():
            self._writer = NetCDFWriter.resume(self.path, self.restart_time, self.coords, self.variables,
                                               self.global_attrs, **self._kwargs)
            times = self._writer.times
            self.last_time = float(times.max()) if times.size else -np.inf
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._writer = NetCDFWriter(self.path, self.coords, self.variables, self.global_attrs,
                                        **self._kwargs)

    def initialize(self, sim: Simulation) -> None:
        """Start of the run: the file exists from here on."""
        self.open()

    def __call__(self, sim: Simulation) -> None:
        self.write(sim)

    def write(self, sim: Simulation) -> bool:
        """One record of the current state, unless it is not after the last one; True if written."""
        self.open()
        t = sim.state.t
        if t <= self.last_time:  # already written (e.g. a restart at an output time)
            return False
        self._writer.append(t, {name: out.values(sim) for name, out in self.outputs.items()})
        self.last_time = t
        return True

    def set_attributes(self, attrs: Mapping[str, Any]) -> None:
        """Set global attributes of the file (e.g. a flag found during the run)."""
        self.open()
        self._writer.set_attributes(attrs)

    def finalize(self, sim: Simulation, completed: bool) -> None:
        """End of a run: a completed run gets its final state as a record (if it is not one)."""
        if completed:
            self.write(sim)
        elif self._writer is not None:
            self._writer.sync()

    def close(self) -> None:
        """Close the file (idempotent; a later :meth:`write` is an error)."""
        if self._writer is not None:
            self._writer.close()

    def checkpoint_payload(self, sim: Simulation) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        return {}, {LAST_RECORD_KEY: self.last_time}

    def restore_checkpoint(self, arrays: Mapping[str, np.ndarray], scalars: Mapping[str, Any]) -> None:
        """Continue after a checkpoint: the file is continued when opened, from its record times;
        without the file, from the checkpoint's last record time.

        Raises
        ------
        GranflowInputError
            If the file was opened already (a restore must come first).
        """
        if self._writer is not None:
            raise GranflowInputError(f"NetCDFOutputWriter {self.path}: restore the checkpoint before "
                                     "the file is opened (before running)")
        self.last_time = float(scalars[LAST_RECORD_KEY])
        self.restart_time = float(scalars["state.t"])


def numerics_meta(model: Model) -> dict[str, Any]:
    """What decides the last bits of a step besides the configuration: the linear solver
    ``auto`` resolved to on this machine, and the velocity band in use."""
    return {"linear_solver": model.linear_solver_name, "velocity_band": int(model.velocity_band or 0)}


def warn_numerics_mismatch(meta: Mapping[str, Any], model: Model) -> list[str]:
    """Warn (log) for every :func:`numerics_meta` entry of a checkpoint that differs from the
    model's: the restart continues, but not bit for bit. Returns the keys that differ."""
    differ = []
    for key, now in numerics_meta(model).items():
        then = meta.get(key)
        if then is not None and then != now:
            differ.append(key)
            logger.warning("--restart: the checkpoint was written with %s = %r, this run uses %r: "
                           "it continues, but not bit for bit as the uninterrupted run would", key, then, now)
    return differ


class Checkpointer:
    """Save checkpoints of a simulation in ``directory`` each time ``schedule`` is due.

    Parameters
    ----------
    directory : path-like
        Created at the first save.
    schedule : IterationInterval or TimeInterval
    keep : int or None
        Newest checkpoints kept (None: all). Default 2.
    meta : callable, optional
        ``meta(simulation) -> dict``: descriptive metadata stored with each checkpoint (besides
        :func:`numerics_meta` and the grid).
    payload : callable, optional
        ``payload(simulation) -> (arrays, scalars)`` added to
        :meth:`Simulation.checkpoint_payload`.

    Raises
    ------
    GranflowInputError
        For a schedule that is not one, or ``keep < 1``.
    """

    def __init__(self, directory: str | os.PathLike, schedule: Schedule, keep: int | None = 2, *,
                 meta: Callable[[Simulation], Mapping[str, Any]] | None = None,
                 payload: Callable[[Simulation], tuple[dict, dict]] | None = None) -> None:
        self.schedule = check_schedule(schedule, "Checkpointer")
        if keep is not None and (isinstance(keep, bool) or not isinstance(keep, int) or keep < 1):
            raise GranflowInputError(f"Checkpointer: keep must be an integer >= 1 or None, got {keep!r}")
        self.directory = Path(directory)
        self.keep = keep
        self.meta = meta
        self.payload = payload
        self._manager: CheckpointManager | None = None
        self.last_step = -1
        """Step of the last checkpoint saved (or restored from)."""

    @property
    def manager(self) -> CheckpointManager:
        """The :class:`CheckpointManager` of :attr:`directory` (creates the directory)."""
        if self._manager is None:
            self._manager = CheckpointManager(self.directory, keep=self.keep)
        return self._manager

    def clear(self) -> None:
        """Remove the checkpoints in :attr:`directory` (those of an earlier run)."""
        for old in self.manager.steps():
            self.manager.path(old).unlink(missing_ok=True)

    def __call__(self, sim: Simulation) -> None:
        if sim.state.step > 0:
            self.save(sim)

    def save(self, sim: Simulation) -> Path:
        """Checkpoint of the current state (skipped if this step already has one); its path."""
        step = sim.state.step
        if step == self.last_step:
            return self.manager.path(step)
        arrays, scalars = sim.checkpoint_payload()
        if self.payload is not None:
            extra_arrays, extra_scalars = self.payload(sim)
            arrays.update(extra_arrays)
            scalars.update(extra_scalars)
        g = sim.model.grid
        meta = {**dict(self.meta(sim) if self.meta is not None else {}), "grid": [g.nx, g.nz, g.Lx, g.Lz],
                **numerics_meta(sim.model)}
        path = self.manager.save(step, arrays, scalars, meta)
        self.last_step = step
        return path

    def finalize(self, sim: Simulation, completed: bool) -> None:
        """Whatever ended the run: a checkpoint of the last accepted state."""
        self.save(sim)

    def restore_checkpoint(self, arrays: Mapping[str, np.ndarray], scalars: Mapping[str, Any]) -> None:
        """The restored step has its checkpoint already."""
        self.last_step = int(scalars[STATE_STEP_KEY])
