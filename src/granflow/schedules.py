"""When things happen during a :class:`~granflow.simulation.Simulation`: schedules, callbacks and
the named collections of scheduled objects (Oceananigans' ``simulation.output_writers[...]``).

* :class:`IterationInterval` (every ``n`` accepted steps) and :class:`TimeInterval` (every
  ``interval`` seconds of simulated time; the time step is shortened to land on those times) are
  the :class:`Schedule` s;
* :class:`Callback` is ``func(simulation)`` on a schedule;
* :class:`ScheduledEntries` is the dict-like of :attr:`Simulation.output_writers`,
  :attr:`Simulation.diagnostics` and :attr:`Simulation.checkpointers`: ``name -> entry``, where
  an entry is a callable ``entry(simulation)`` with a ``schedule`` attribute; anything else is
  refused with a :class:`~granflow.errors.GranflowInputError` naming the key and the value.

Several entries may share one schedule object (a NetCDF writer and the front recorder whose
history must match its records): the simulation asks a schedule once per step, and every entry on
it runs when it is due.
"""
from __future__ import annotations

import math
import numbers
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator, MutableMapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from granflow.errors import GranflowInputError

if TYPE_CHECKING:
    from granflow.simulation import Simulation

TIME_EPS = 1e-12
"""Relative tolerance on times (stop time, output times)."""


class Schedule(ABC):
    """When a scheduled entry is due."""

    @abstractmethod
    def due(self, sim: Simulation) -> bool:
        """True if the entries on this schedule run now (a time schedule then moves on)."""

    @abstractmethod
    def next_time(self, sim: Simulation) -> float:
        """The next simulated time [s] at which this schedule is due (inf: none in particular)."""


@dataclass
class IterationInterval(Schedule):
    """Due every ``n`` accepted steps (and at step 0)."""

    n: int

    def __post_init__(self) -> None:
        if isinstance(self.n, bool) or not (isinstance(self.n, int) and self.n >= 1):
            raise GranflowInputError(f"IterationInterval: n must be an integer >= 1, got {self.n!r}")

    def due(self, sim: Simulation) -> bool:
        return sim.state.step % self.n == 0

    def next_time(self, sim: Simulation) -> float:
        return math.inf


@dataclass
class TimeInterval(Schedule):
    """Due every ``interval`` seconds of simulated time (the time step is shortened to land on
    the output times)."""

    interval: float
    _next: float = field(default=0.0, init=False)

    def __post_init__(self) -> None:
        if isinstance(self.interval, bool) or not (
                isinstance(self.interval, numbers.Real) and self.interval > 0 and math.isfinite(self.interval)):
            raise GranflowInputError(f"TimeInterval: interval must be a number > 0 [s], got {self.interval!r}")

    def due(self, sim: Simulation) -> bool:
        if sim.state.t >= self._next - TIME_EPS * max(1.0, abs(self._next)):
            until = sim.state.t + TIME_EPS * max(1.0, abs(sim.state.t))
            behind = math.floor((until - self._next) / self.interval)
            if behind > 1:  # far behind (a restart at a later time): jump there, do not loop
                self._next += (behind - 1) * self.interval
            while self._next <= until:
                self._next += self.interval
            return True
        return False

    def next_time(self, sim: Simulation) -> float:
        return self._next


def check_schedule(schedule: Any, where: str) -> Schedule:
    """``schedule`` if it is a :class:`Schedule`, else a GranflowInputError naming ``where``."""
    if not isinstance(schedule, Schedule):
        raise GranflowInputError(f"{where}: schedule must be a TimeInterval(seconds) or an "
                                 f"IterationInterval(steps), got {schedule!r}")
    return schedule


@dataclass
class Callback:
    """``func(simulation)`` run when ``schedule.due(simulation)``."""

    func: Callable[[Simulation], None]
    schedule: Schedule
    name: str = ""

    def __post_init__(self) -> None:
        if not callable(self.func):
            raise GranflowInputError(f"callback {self.name!r}: func must be callable, got {self.func!r}")
        check_schedule(self.schedule, f"callback {self.name!r}")

    def __call__(self, sim: Simulation) -> None:
        self.func(sim)


class ScheduledEntries(MutableMapping):
    """``name -> entry`` of the objects a simulation calls on their schedules, in insertion order.

    An entry is callable as ``entry(simulation)`` and has a ``schedule`` (:class:`Schedule`).
    Optional methods the simulation uses when present: ``initialize(simulation)`` at the start of
    its first :meth:`Simulation.run`, ``finalize(simulation, completed)`` at the
    end of every :meth:`Simulation.run` (``completed``: it reached the stop time or its step
    limit), ``checkpoint_payload(simulation) -> (arrays, scalars)`` and
    ``restore_checkpoint(arrays, scalars)`` for restarts, ``close()`` in :meth:`Simulation.close`.

    Parameters
    ----------
    kind : str
        Name of the collection in messages (``"output_writers"``).
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._entries: dict[str, Any] = {}

    def __setitem__(self, name: str, entry: Any) -> None:
        where = f"{self.kind}[{name!r}]"
        if not isinstance(name, str) or not name:
            raise GranflowInputError(f"{where}: the name must be a non-empty string")
        check_schedule(getattr(entry, "schedule", None), where)
        if not callable(entry):
            raise GranflowInputError(f"{where}: {type(entry).__name__} is not callable as entry(simulation)")
        self._entries[name] = entry

    def __getitem__(self, name: str) -> Any:
        try:
            return self._entries[name]
        except KeyError:
            raise KeyError(f"{self.kind} has no entry {name!r}; it has {sorted(self._entries)}") from None

    def __delitem__(self, name: str) -> None:
        del self._entries[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"{self.kind}({', '.join(f'{k}={type(v).__name__}' for k, v in self._entries.items())})"


def time_schedule_keys(named: Iterable[tuple[str, Any]]) -> list[tuple[str, TimeInterval]]:
    """``("schedule.<name>", schedule)`` of every distinct :class:`TimeInterval` of the
    ``(name, entry)`` pairs, named after its first entry: the checkpoint keys of their phases.

    Raises
    ------
    GranflowInputError
        If two different time schedules get the same name.
    """
    keys: dict[str, TimeInterval] = {}
    seen: set[int] = set()
    for name, entry in named:
        schedule = entry.schedule
        if not isinstance(schedule, TimeInterval) or id(schedule) in seen:
            continue
        seen.add(id(schedule))
        key = f"schedule.{name}"
        if key in keys:
            raise GranflowInputError(f"Simulation: two time schedules are named {name!r} (a callback "
                                     "and an entry?); give them distinct names")
        keys[key] = schedule
    return list(keys.items())


def add_entry_payloads(sim: Simulation, named: Iterable[tuple[str, Any]], arrays: dict[str, Any],
                       scalars: dict[str, Any]) -> None:
    """Add the ``checkpoint_payload(sim) -> (arrays, scalars)`` of the entries that have one.

    Raises
    ------
    GranflowInputError
        If an entry writes a key already taken (by the simulation or another entry).
    """
    for name, entry in named:
        payload = getattr(entry, "checkpoint_payload", None)
        if payload is None:
            continue
        a, s = payload(sim)
        clash = sorted((set(a) & set(arrays)) | (set(s) & set(scalars)))
        if clash:
            raise GranflowInputError(f"Simulation: {name!r} writes checkpoint entries {clash} "
                                     "that are written already")
        arrays.update(a)
        scalars.update(s)
