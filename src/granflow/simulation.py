"""Simulation: the time loop around :meth:`granflow.model.Model.advance` (STYLE.md idioms 4, 6).

* time step ``dt = min(cfl dt_CFL(u^n), dt_max, time to stop, time to the next scheduled output)``
  with the CFL number of :func:`granflow.physics.transport.cfl_number` over the model's
  ``transport_cells(phi, c)`` if it has that method (:meth:`granflow.model.Model.transport_cells`);
* a step reported FAILED (NaN, Picard divergence, CFL or phi-bound violation) or leaving a
  non-finite state is rejected: the state is restored and the step retried with ``dt/2`` (a CFL
  failure: the dt that puts the CFL number 10 % under its bound, :func:`retry_factor`), at most
  ``max_retries`` times, then :class:`StepFailure` is raised;
* scheduled entries run after every accepted step and once at the start, each when its schedule
  (:class:`IterationInterval`, :class:`TimeInterval`; module :mod:`granflow.schedules`) is due, in
  this order: :attr:`Simulation.diagnostics` (recorders: front, rest, ...), the callbacks
  ``func(simulation)`` (:meth:`Simulation.add_callback`), :attr:`Simulation.output_writers`
  (e.g. :class:`granflow.output.writers.NetCDFOutputWriter`), :attr:`Simulation.checkpointers`
  (:class:`granflow.output.writers.Checkpointer`) last, so that a checkpoint sees everything of
  its step done. A schedule shared by several entries is asked once per step;
* whatever ends :meth:`Simulation.run` (the stop time, a :class:`StepFailure`, an exception, a
  stop request), every entry with a ``finalize(simulation, completed)`` method gets it, in the same
  order: a writer then adds the final state of a completed run, a checkpointer saves the last
  accepted state -- so a run that fails mid-way still leaves its output and a checkpoint;
* the energy budget (:class:`granflow.diagnostics.EnergyBudget`) is updated after every accepted
  step, and wall times per phase (assembly, solve, transport, diagnostics) are accumulated;
* running totals over the whole run (:class:`RunTotals`: clipped mass, rejected steps, phi
  extremes before clipping, ...) survive a restart;
* :meth:`Simulation.request_stop` ends :meth:`Simulation.run` cleanly after the current step
  (the CLI calls it on Ctrl-C); an exception raised inside a step (e.g. ``KeyboardInterrupt``)
  restores the state of the start of that step before propagating, so the state is always that of
  an accepted step;
* :meth:`Simulation.checkpoint_payload` / :meth:`Simulation.restore_checkpoint`: everything a
  restart needs (state, clock, energy budget, totals, the phase of time schedules, the history of
  the scheduled entries that keep one), stored exactly, so that a restarted run reproduces the
  uninterrupted one bit for bit (:mod:`granflow.output.checkpoint`).
"""
from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from granflow.diagnostics import EnergyBudget
from granflow.errors import GranflowError, GranflowInputError
from granflow.model import Model, StepReport  # noqa: F401  (Model: the model of the docstrings)
from granflow.model_interface import MODEL_INTERFACE, SteppingModel  # re-exported
from granflow.physics.transport import stable_dt
from granflow.schedules import (  # noqa: F401 - re-exported: the schedules of a Simulation
    TIME_EPS,
    Callback,
    IterationInterval,
    Schedule,
    ScheduledEntries,
    TimeInterval,
    add_entry_payloads,
    time_schedule_keys,
)
from granflow.state import OPTIONAL_FIELDS, State
from granflow.step_retry import retry_factor

SERIAL_BLAS = "openblas"
"""threadpoolctl ``internal_api`` of the BLAS pools run single-threaded during
:meth:`Simulation.run`. The BLAS calls of a step act on vectors of 1e4-1e5 entries and gain
nothing from threads, while idle OpenBLAS threads spin and take the cores from the threaded sparse
solver (MKL PARDISO): at 128^2 (Lagree column, 60 steps) 32.7 s wall with both pools at 2
threads, 15.4 s with OpenBLAS at 1 and MKL at 2, 20.9 s with both at 1 (benchmarks/README.md).
The limits are restored after the run."""


def _run_thread_limits() -> dict[str, int]:
    """threadpoolctl limits keyed by library prefix (its dict keys are prefixes or user APIs, and
    the ``blas`` user API would also pin MKL, the sparse solver's pool)."""
    return {info["prefix"]: 1 for info in threadpool_info() if info["internal_api"] == SERIAL_BLAS}

DEFAULT_CFL = 0.4
"""Default CFL number (0.3 before session 25, when one solve per step became the default)."""
DEFAULT_DT_MAX = 1.0e-3
"""Accuracy cap on dt [s] (NUMERICS.md §8b)."""
DEFAULT_MAX_RETRIES = 6
"""Retries (smaller dt, :func:`retry_factor`) allowed for one step."""
STATE_ARRAYS = ("phi", "vel", "p", "p_f")
"""State arrays stored in a checkpoint (under ``state.<name>``)."""


class StepFailure(GranflowError):
    """A step failed even after ``max_retries`` retries with smaller dt.

    Attributes
    ----------
    t : float
        Time of the last accepted state [s] (the failed step started there).
    step : int
        Number of the step that failed (accepted steps + 1).
    attempts : list of str
        One message per attempt (``"dt=...: <what failed>"``).
    """

    def __init__(self, message: str, t: float = float("nan"), step: int = -1,
                 attempts: list[str] | None = None) -> None:
        super().__init__(message)
        self.t = t
        self.step = step
        self.attempts = list(attempts or [])


def nonfinite_message(state: State, grid) -> str:
    """Name the first non-finite field of ``state`` and where it is (cell index and x, z [m])."""
    for name in ("phi", "p", "p_f"):
        a = getattr(state, name)
        bad = np.argwhere(~np.isfinite(a))
        if bad.size:
            i, j = (int(v) for v in bad[0])
            return (f"non-finite {name} ({a[i, j]!r}) in {len(bad)} cell(s), first at cell ({i}, {j}), "
                    f"x = {grid.xc[i]:.4g} m, z = {grid.zc[j]:.4g} m")
    bad = np.flatnonzero(~np.isfinite(state.vel))
    if bad.size:
        k = int(bad[0])
        comp = "u" if k < grid.n_u else "w"
        return f"non-finite velocity {comp} on {bad.size} face(s), first at unknown {k}"
    return "non-finite time" if not math.isfinite(state.t) else "state is finite"


def _summarise(messages: list[str]) -> str:
    """The distinct kinds of failure of the attempts (numbers ignored), the last of each kind with
    its count: ``"Picard diverged (relative increment 0.03) [x7]"``."""
    kinds: dict[str, tuple[str, int]] = {}
    for m in messages:
        text = m.split(": ", 1)[-1]
        key = re.sub(r"[-+]?[0-9][0-9.e+-]*", "#", text)
        kinds[key] = (text, kinds.get(key, ("", 0))[1] + 1)
    return "; ".join(text + (f" [x{n}]" if n > 1 else "") for text, n in kinds.values())


LATER_BUDGET_FIELDS = ("outflow_mechanical", "outflow_potential", "outflow_gas", "inflow_mechanical",
                       "inflow_potential", "inflow_gas", "source_work", "linear_solve", "gas_linear_solve")
"""Energy-budget fields and numerical terms a checkpoint written before they existed lacks (0 then)."""


@dataclass
class RunTotals:
    """Running totals over all accepted steps of a run (restored by a restart)."""

    rejected: int = 0
    """Rejected attempts (each retried with a smaller dt, :func:`retry_factor`)."""
    clipped_mass: float = 0.0
    """Mass removed by clipping phi to phi_max [m^2]."""
    added_mass: float = 0.0
    """Mass added by clipping phi to 0 [m^2]."""
    limited_mass: float = 0.0
    """Solid volume the transport's upper-bound limiter kept in donor cells [m^2]."""
    outflow_mass: float = 0.0
    """Solid volume that left through an outflow wall [m^2] (:mod:`granflow.physics.outflow`)."""
    inflow_mass: float = 0.0
    """Solid volume a source put in [m^2] (:mod:`granflow.physics.inflow`)."""
    max_phi_before_clip: float = -math.inf
    min_phi_before_clip: float = math.inf
    picard_iterations: int = 0
    linear_iterations: int = 0
    """Krylov iterations of the linear solves (0 with the direct solver)."""
    not_converged: int = 0
    """Accepted steps whose Picard loop stopped at ``max_sweeps``."""
    max_negative_Z: int = 0
    """Largest number of dense cells with Z < 0 in one step."""

    def record(self, report: StepReport) -> None:
        self.clipped_mass += report.clipped_mass
        self.added_mass += report.added_mass
        self.limited_mass += report.limited_mass
        self.outflow_mass += report.outflow.volume
        self.inflow_mass += report.inflow.volume
        self.max_phi_before_clip = max(self.max_phi_before_clip, report.max_phi_before_clip)
        self.min_phi_before_clip = min(self.min_phi_before_clip, report.min_phi_before_clip)
        self.picard_iterations += report.picard_iterations
        self.linear_iterations += report.linear_iterations
        self.not_converged += int(report.status.value == "not_converged")
        self.max_negative_Z = max(self.max_negative_Z, report.n_negative_Z)


class Simulation:
    """Run a model from ``state`` to ``stop_time``.

    Parameters
    ----------
    model : SteppingModel
        A :class:`granflow.model.Model`, or any object with the interface of
        :class:`SteppingModel`.
    state : State
        Advanced in place.
    stop_time : float
        Final time [s].
    cfl : float
        CFL number of the time step (<= 1/2 keeps phi >= 0). Default 0.3.
    dt_max : float
        Largest time step [s]. Default 1e-3.
    max_retries : int
        retries with smaller dt allowed per step (:func:`retry_factor`). Default 6.
    max_steps : int, optional
        Stop after this many accepted steps.
    callbacks : sequence of Callback, optional

    Attributes
    ----------
    output_writers, diagnostics, checkpointers : ScheduledEntries
        ``name -> entry`` (``simulation.output_writers["fields"] = NetCDFOutputWriter(...)``);
        an entry is callable as ``entry(simulation)`` and has a ``schedule``
        (:class:`granflow.schedules.ScheduledEntries`).
    """

    def __init__(self, model: SteppingModel, state: State, stop_time: float, cfl: float = DEFAULT_CFL,
                 dt_max: float = DEFAULT_DT_MAX, max_retries: int = DEFAULT_MAX_RETRIES,
                 max_steps: int | None = None, callbacks=None) -> None:
        if not isinstance(model, SteppingModel):
            missing = [name for name in MODEL_INTERFACE if not hasattr(model, name)]
            raise GranflowInputError(f"Simulation: model must have the model interface (a Model, or "
                                     f"granflow.simulation.SteppingModel), got {type(model).__name__} "
                                     f"without {', '.join(missing)}")
        state.check(model.grid)
        if not (0 < cfl <= 1 and dt_max > 0 and stop_time >= state.t):
            raise GranflowInputError(
                f"Simulation: need 0 < cfl <= 1, dt_max > 0, stop_time >= t (got cfl={cfl}, "
                f"dt_max={dt_max}, stop_time={stop_time}, t={state.t})")
        self.model = model
        self.state = state
        self.stop_time = float(stop_time)
        self.cfl = float(cfl)
        self.dt_max = float(dt_max)
        self.max_retries = int(max_retries)
        self.max_steps = max_steps
        self.callbacks: list[Callback] = list(callbacks or [])
        for cb in self.callbacks:
            if not isinstance(cb, Callback):
                raise GranflowInputError(f"Simulation: callbacks must be Callback objects, got {cb!r}")
        self.diagnostics = ScheduledEntries("diagnostics")
        self.output_writers = ScheduledEntries("output_writers")
        self.checkpointers = ScheduledEntries("checkpointers")
        self.reports: list[StepReport] = []
        """Every accepted step's report; all but the last drop ``solve_density`` (memory)."""
        self.n_rejected = 0
        self.totals = RunTotals()
        self.budget = EnergyBudget.start(model, state)
        self.timings = {"assembly": 0.0, "solve": 0.0, "transport": 0.0, "diagnostics": 0.0}
        self.stop_reason = ""
        self._started = False

    @property
    def stop_requested(self) -> bool:
        """True once :meth:`request_stop` was called."""
        return bool(self.stop_reason)

    def request_stop(self, reason: str = "stop requested") -> None:
        """Make :meth:`run` return after the step in progress (safe to call from a signal handler)."""
        self.stop_reason = reason or "stop requested"

    def add_callback(self, func: Callable[[Simulation], None], schedule, name: str = "") -> None:
        """Register ``func(simulation)`` on ``schedule``.

        Raises
        ------
        GranflowInputError
            If ``func`` is not callable or ``schedule`` is not a schedule.
        """
        self.callbacks.append(Callback(func, schedule, name))

    def _entries(self) -> Iterator[tuple[str, Any]]:
        """(name, entry) of everything on a schedule, in the order they run (module docstring)."""
        yield from self.diagnostics.items()
        yield from ((cb.name or str(i), cb) for i, cb in enumerate(self.callbacks))
        yield from self.output_writers.items()
        yield from self.checkpointers.items()

    def _schedules(self) -> list[Schedule]:
        """The distinct schedule objects of the entries."""
        return list({id(e.schedule): e.schedule for _, e in self._entries()}.values())

    def close(self) -> None:
        """Close the output writers (their files stay readable; idempotent)."""
        for _, writer in self.output_writers.items():
            close = getattr(writer, "close", None)
            if close is not None:
                close()

    # --- loop ---------------------------------------------------------------------------------
    def time_step(self) -> float:
        """The next dt [s] (before any retry)."""
        cells = getattr(self.model, "transport_cells", lambda phi, c: None)(self.state.phi, self.state.c)
        dt = min(self.cfl * stable_dt(self.model.grid, self.state.vel, 1.0, cells), self.dt_max,
                 self.stop_time - self.state.t)
        for schedule in self._schedules():
            t_next = schedule.next_time(self)
            if t_next > self.state.t * (1 + TIME_EPS) + TIME_EPS:
                dt = min(dt, t_next - self.state.t)
        return dt

    def step(self) -> StepReport:
        """One accepted step (with retries); raises :class:`StepFailure`.

        If anything raises during the attempts (e.g. ``KeyboardInterrupt``), the state of the
        start of the step is restored before the exception propagates.
        """
        dt = dt0 = self.time_step()
        backup = self.state.copy()
        messages = []
        try:
            for _ in range(self.max_retries + 1):
                report = self.model.advance(self.state, dt)
                for k, v in report.timings.items():
                    self.timings[k] = self.timings.get(k, 0.0) + v
                if not report.failed and self.state.is_finite():
                    break
                what = report.message if report.failed else nonfinite_message(self.state, self.model.grid)
                messages.append(f"dt={dt:.3g}: {what}")
                last_dt = dt
                self.state.restore(backup)
                self.n_rejected += 1
                self.totals.rejected += 1
                dt *= retry_factor(report)
            else:
                raise StepFailure(
                    f"step {self.state.step + 1} at t = {self.state.t:.6g} s failed {len(messages)} times "
                    f"(dt {dt0:.3g} down to {last_dt:.3g} s): " + _summarise(messages),
                    t=self.state.t, step=self.state.step + 1, attempts=messages)
        except BaseException:
            self.state.restore(backup)
            raise
        t0 = time.perf_counter()
        self.totals.record(report)
        self.budget.record(report, self.state)
        if self.reports and self.reports[-1].solve_density is not None:
            self.reports[-1] = replace(self.reports[-1], solve_density=None)
        self.reports.append(report)
        self._run_callbacks()
        self.timings["diagnostics"] += time.perf_counter() - t0
        return report

    def _run_callbacks(self) -> None:
        due: dict[int, bool] = {}  # each schedule asked once: a TimeInterval moves on when due
        for _, entry in list(self._entries()):
            key = id(entry.schedule)
            if key not in due:
                due[key] = entry.schedule.due(self)
            if due[key]:
                entry(self)

    def _finalize(self, completed: bool) -> Exception | None:
        """``finalize(self, completed)`` of every entry that has one; all are called, the first
        error is returned."""
        first = None
        for name, entry in list(self._entries()):
            finalize = getattr(entry, "finalize", None)
            if finalize is None:
                continue
            try:
                finalize(self, completed)
            except Exception as err:  # noqa: BLE001 - the other entries still save their output
                err.add_note(f"in finalize() of {name!r}")
                first = first or err
        return first

    def done(self) -> bool:
        """True at ``stop_time`` or after ``max_steps`` steps of this Simulation object."""
        if self.max_steps is not None and len(self.reports) >= self.max_steps:
            return True
        return self.state.t >= self.stop_time - TIME_EPS * max(1.0, self.stop_time)

    def run(self) -> Simulation:
        """Advance until :meth:`done` or :meth:`request_stop`; returns ``self``.

        Numpy's OpenBLAS runs single-threaded during the run (:data:`SERIAL_BLAS`); the sparse
        direct solver keeps its own threads (``MKL_NUM_THREADS``, default all cores). The limit is
        process-wide: simulations run in threads of one process restore each other's limits
        when they end (the sweep runner uses processes).

        Whatever ends the run, the entries' ``finalize(simulation, completed)`` run (module
        docstring); an exception then propagates with a note if saving failed too.
        """
        with threadpool_limits(limits=_run_thread_limits()):
            try:
                self._run()
            except BaseException as err:
                problem = self._finalize(completed=False)
                if problem is not None:
                    err.add_note(f"saving the output afterwards failed too: {problem!r}")
                raise
            problem = self._finalize(completed=self.done() and not self.stop_requested)
            if problem is not None:
                raise problem
            return self

    def _run(self) -> Simulation:
        if not self._started:
            self._started = True
            if not self.state.is_finite():
                raise StepFailure("initial state is not finite: "
                                  + nonfinite_message(self.state, self.model.grid),
                                  t=self.state.t, step=self.state.step)
            t0 = time.perf_counter()
            for _, entry in list(self._entries()):
                initialize = getattr(entry, "initialize", None)
                if initialize is not None:
                    initialize(self)
            self._run_callbacks()
            self.timings["diagnostics"] += time.perf_counter() - t0
        while not self.done() and not self.stop_requested:
            self.step()
        return self

    # --- checkpoint / restart -----------------------------------------------------------------
    def _schedule_keys(self) -> list[tuple[str, TimeInterval]]:
        """:func:`granflow.schedules.time_schedule_keys` of the entries, named in the order
        callbacks, output writers, diagnostics, checkpointers (a writer names the schedule it
        shares with recorders)."""
        return time_schedule_keys([*((cb.name or str(i), cb) for i, cb in enumerate(self.callbacks)),
                                   *self.output_writers.items(), *self.diagnostics.items(),
                                   *self.checkpointers.items()])

    def checkpoint_payload(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """``(arrays, scalars)`` with everything a bit-identical restart needs. Arrays:
        ``state.<phi|vel|p|p_f>`` (``c``, ``accel``, ``accel_prev``, ``free`` if set), the budget's
        arrays (``budget.rho_f``). Scalars: ``state.t``, ``state.step`` (``accel_dt`` if set), the
        other budget fields, :class:`RunTotals`, the next due time of every :class:`TimeInterval`
        schedule (``schedule.<name>``). Then what the scheduled entries with a
        ``checkpoint_payload(simulation)`` method add: the model (what it keeps across steps,
        :meth:`granflow.model.Model.checkpoint_payload`), a :class:`granflow.output.recorders.
        FrontRecorder`'s front history; :func:`granflow.output.checkpoint.save_checkpoint` saves them."""
        st, b = self.state, self.budget
        arrays = {f"state.{k}": getattr(st, k) for k in STATE_ARRAYS + OPTIONAL_FIELDS
                  if getattr(st, k) is not None}
        scalars: dict[str, Any] = {"state.t": st.t, "state.step": st.step, "n_rejected": self.n_rejected,
                                   **({} if st.accel_dt is None else {"state.accel_dt": st.accel_dt})}
        for f in fields(b):  # every float, array and dict-of-floats field of the budget
            value = getattr(b, f.name)
            if isinstance(value, np.ndarray):
                arrays[f"budget.{f.name}"] = value
            elif isinstance(value, dict):
                scalars.update({f"budget.{f.name}.{k}": v for k, v in value.items()})
            elif isinstance(value, (int, float)):
                scalars[f"budget.{f.name}"] = value
        scalars.update({f"totals.{f.name}": getattr(self.totals, f.name) for f in fields(RunTotals)})
        scalars.update({key: schedule._next for key, schedule in self._schedule_keys()})
        add_entry_payloads(self, [("model", self.model), *self._entries()], arrays, scalars)
        return arrays, scalars

    def restore_checkpoint(self, arrays: Mapping[str, np.ndarray], scalars: Mapping[str, Any]) -> None:
        """Continue from a :meth:`checkpoint_payload` (as loaded from a checkpoint file).

        Time schedules are matched by name (:meth:`_schedule_keys`); schedules absent from the
        checkpoint keep their phase. Then every scheduled entry with a
        ``restore_checkpoint(arrays, scalars)`` method restores what it saved.

        Raises
        ------
        GranflowInputError
            If an entry is missing or the arrays do not fit the model's grid.
        """
        b = self.budget
        try:
            state = State(**{k: np.array(arrays[f"state.{k}"]) for k in STATE_ARRAYS},
                          t=float(scalars["state.t"]), step=int(scalars["state.step"]),
                          accel_dt=float(scalars["state.accel_dt"]) if "state.accel_dt" in scalars else None,
                          **{k: np.array(arrays[f"state.{k}"]) for k in OPTIONAL_FIELDS if f"state.{k}" in arrays})
            budget: dict[str, Any] = {}
            for f in fields(b):
                value, key = getattr(b, f.name), f"budget.{f.name}"
                if isinstance(value, np.ndarray):
                    budget[f.name] = np.array(arrays[key])
                    if budget[f.name].shape != value.shape:
                        raise GranflowInputError(f"checkpoint: {key} does not fit the grid")
                elif isinstance(value, dict):
                    budget[f.name] = {k: float(scalars[f"{key}.{k}"] if k not in LATER_BUDGET_FIELDS
                                               else scalars.get(f"{key}.{k}", 0.0)) for k in value}
                elif isinstance(value, (int, float)):  # (fields added later start from their default)
                    budget[f.name] = type(value)(scalars[key] if f.name not in LATER_BUDGET_FIELDS
                                                 else scalars.get(key, f.default))
            totals = RunTotals(**{f.name: type(f.default)(scalars.get(f"totals.{f.name}", f.default))
                                  for f in fields(RunTotals)})  # (a total added since: its default)
            n_rejected = int(scalars["n_rejected"])
        except KeyError as err:
            raise GranflowInputError(f"checkpoint: missing entry {err}") from None
        state.check(self.model.grid)
        if getattr(self.model, "indicator", False) and state.c is None:
            raise GranflowInputError('checkpoint: no material fraction (state.c) for numerics.surface = "indicator"')
        self.state.restore(state)
        for k, v in budget.items():
            setattr(b, k, v)
        self.totals = totals
        self.n_rejected = n_rejected
        for key, schedule in self._schedule_keys():
            if key in scalars:
                schedule._next = float(scalars[key])
        for name, entry in [("model", self.model), *self._entries()]:
            restore = getattr(entry, "restore_checkpoint", None)
            if restore is None:
                continue
            try:
                restore(arrays, scalars)
            except KeyError as err:
                raise GranflowInputError(f"checkpoint: missing entry {err} (of {name!r})") from None
