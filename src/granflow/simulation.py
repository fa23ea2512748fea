"""Simulation: the time loop around :meth:`granflow.model.Model.advance` (STYLE.md idioms 4, 6).

* time step ``dt = min(cfl dt_CFL(u^n), dt_max, time to stop, time to the next scheduled output)``
  with the CFL number of :func:`granflow.physics.transport.cfl_number`;
* a step reported FAILED (NaN, Picard divergence, CFL or phi-bound violation) or leaving a
  non-finite state is rejected: the state is restored and the step retried with ``dt/2``, at most
  ``max_retries`` times, then :class:`StepFailure` is raised;
* callbacks ``func(simulation)`` run on schedules (:class:`IterationInterval`,
  :class:`TimeInterval`), also once at the start;
* the energy budget (:class:`granflow.diagnostics.EnergyBudget`) is updated after every accepted
  step, and wall times per phase (assembly, solve, transport, diagnostics) are accumulated.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from granflow.diagnostics import EnergyBudget
from granflow.errors import GranflowError, GranflowInputError
from granflow.model import Model, StepReport
from granflow.physics.transport import stable_dt
from granflow.state import State

DEFAULT_CFL = 0.3
DEFAULT_DT_MAX = 1.0e-3
"""Accuracy cap on dt [s] (NUMERICS.md §8b)."""
DEFAULT_MAX_RETRIES = 6
"""Halvings of dt allowed for one step."""
RETRY_FACTOR = 0.5
"""dt of a retried step relative to the failed one."""
TIME_EPS = 1e-12
"""Relative tolerance on times (stop time, output times)."""


class StepFailure(GranflowError):
    """A step failed even after ``max_retries`` halvings of dt."""


@dataclass
class IterationInterval:
    """Due every ``n`` accepted steps."""

    n: int

    def __post_init__(self) -> None:
        if not (isinstance(self.n, int) and self.n >= 1):
            raise GranflowInputError(f"IterationInterval: n must be an integer >= 1, got {self.n!r}")

    def due(self, sim: Simulation) -> bool:
        return sim.state.step % self.n == 0

    def next_time(self, sim: Simulation) -> float:
        return math.inf


@dataclass
class TimeInterval:
    """Due every ``interval`` seconds of simulated time (the time step is shortened to land on
    the output times)."""

    interval: float
    _next: float = field(default=0.0, init=False)

    def __post_init__(self) -> None:
        if not (self.interval > 0 and math.isfinite(self.interval)):
            raise GranflowInputError(f"TimeInterval: interval must be > 0, got {self.interval!r}")

    def due(self, sim: Simulation) -> bool:
        if sim.state.t >= self._next - TIME_EPS * max(1.0, abs(self._next)):
            while self._next <= sim.state.t + TIME_EPS * max(1.0, abs(sim.state.t)):
                self._next += self.interval
            return True
        return False

    def next_time(self, sim: Simulation) -> float:
        return self._next


@dataclass
class Callback:
    """``func(simulation)`` run when ``schedule.due(simulation)``."""

    func: Callable[[Simulation], None]
    schedule: IterationInterval | TimeInterval
    name: str = ""


class Simulation:
    """Run a :class:`Model` from ``state`` to ``stop_time``.

    Parameters
    ----------
    model : Model
    state : State
        Advanced in place.
    stop_time : float
        Final time [s].
    cfl : float
        CFL number of the time step (<= 1/2 keeps phi >= 0). Default 0.3.
    dt_max : float
        Largest time step [s]. Default 1e-3.
    max_retries : int
        dt halvings allowed per step. Default 6.
    max_steps : int, optional
        Stop after this many accepted steps.
    callbacks : sequence of Callback, optional
    """

    def __init__(self, model: Model, state: State, stop_time: float, cfl: float = DEFAULT_CFL,
                 dt_max: float = DEFAULT_DT_MAX, max_retries: int = DEFAULT_MAX_RETRIES,
                 max_steps: int | None = None, callbacks=None) -> None:
        if not isinstance(model, Model):
            raise GranflowInputError(f"Simulation: model must be a Model, got {type(model).__name__}")
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
        self.reports: list[StepReport] = []
        self.n_rejected = 0
        self.budget = EnergyBudget.start(model, state)
        self.timings = {"assembly": 0.0, "solve": 0.0, "transport": 0.0, "diagnostics": 0.0}
        self._started = False

    def add_callback(self, func: Callable[[Simulation], None], schedule, name: str = "") -> None:
        """Register ``func(simulation)`` on ``schedule``."""
        self.callbacks.append(Callback(func, schedule, name))

    # --- loop ---------------------------------------------------------------------------------
    def time_step(self) -> float:
        """The next dt [s] (before any retry)."""
        dt = min(self.cfl * stable_dt(self.model.grid, self.state.vel, 1.0), self.dt_max,
                 self.stop_time - self.state.t)
        for cb in self.callbacks:
            t_next = cb.schedule.next_time(self)
            if t_next > self.state.t * (1 + TIME_EPS) + TIME_EPS:
                dt = min(dt, t_next - self.state.t)
        return dt

    def step(self) -> StepReport:
        """One accepted step (with retries); raises :class:`StepFailure`."""
        dt = self.time_step()
        backup = self.state.copy()
        messages = []
        for _ in range(self.max_retries + 1):
            report = self.model.advance(self.state, dt)
            for k, v in report.timings.items():
                self.timings[k] = self.timings.get(k, 0.0) + v
            if not report.failed and self.state.is_finite():
                break
            messages.append(f"dt={dt:.3g}: {report.message or 'non-finite state'}")
            self.state.restore(backup)
            self.n_rejected += 1
            dt *= RETRY_FACTOR
        else:
            raise StepFailure(f"step at t = {self.state.t:.6g} s failed {self.max_retries + 1} times: "
                              + "; ".join(messages))
        t0 = time.perf_counter()
        self.reports.append(report)
        self.budget.record(report, self.state)
        self._run_callbacks()
        self.timings["diagnostics"] += time.perf_counter() - t0
        return report

    def _run_callbacks(self) -> None:
        for cb in self.callbacks:
            if cb.schedule.due(self):
                cb.func(self)

    def done(self) -> bool:
        if self.max_steps is not None and len(self.reports) >= self.max_steps:
            return True
        return self.state.t >= self.stop_time - TIME_EPS * max(1.0, self.stop_time)

    def run(self) -> Simulation:
        """Advance until :meth:`done`; returns ``self``."""
        if not self._started:
            self._started = True
            if not self.state.is_finite():
                raise StepFailure("initial state is not finite")
            t0 = time.perf_counter()
            self._run_callbacks()
            self.timings["diagnostics"] += time.perf_counter() - t0
        while not self.done():
            self.step()
        return self
