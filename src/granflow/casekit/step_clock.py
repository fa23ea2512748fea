"""Rate and ETA of a run for its progress display (:class:`granflow.casekit.runner.CaseRun`), measured
only over steps that compile nothing.

The first steps of a session compile the Numba kernels, and not all in the first step: measured
on the flagship at 30 x 10 cells, step 1 took 0.8 s of compilation, step 2 again 0.8 s, then
14 ms each; a rate from step 2 on printed "ETA 0:18:00" for a 10 s run. So the clock's origin
moves to the end of any of the first :data:`WARMUP_MAX_STEPS` steps that took more than
:data:`COMPILE_RATIO` times the step after it, and no rate or ETA is given ("compiling kernels
(once)") until :data:`MIN_TIMED_STEPS` steps were timed after the origin.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

WARMUP_MAX_STEPS = 10
"""Steps of a session within which a slow step is taken for a compilation."""
COMPILE_RATIO = 5.0
"""A step this many times slower than the next one compiled something."""
MIN_TIMED_STEPS = 3
"""Steps timed after the origin before a rate and an ETA are shown."""


@dataclass(frozen=True)
class Rate:
    """What :meth:`StepClock.tick` returns."""

    warming_up: bool
    steps_per_s: float
    eta_s: float


class StepClock:
    """Feed :meth:`tick` after every step with the simulated time, the wall clock and the count of
    steps of this session."""

    def __init__(self) -> None:
        self._origin: tuple[float, float, int] | None = None
        self._last: tuple[float, float, int] | None = None
        self._last_duration: float | None = None

    def tick(self, t: float, now: float, n: int, stop_time: float) -> Rate:
        if self._origin is None:  # the end of the first step: it compiled the kernels
            self._origin = (t, now, n)
        elif self._last is not None:
            duration = now - self._last[1]
            if (n <= WARMUP_MAX_STEPS and self._last_duration is not None
                    and self._last_duration > COMPILE_RATIO * duration):
                self._origin = self._last  # the previous step compiled: time from its end
            self._last_duration = duration
        self._last = (t, now, n)
        t0, w0, n0 = self._origin
        elapsed = now - w0
        if n - n0 < MIN_TIMED_STEPS or elapsed <= 0:
            return Rate(True, 0.0, math.inf)
        rate = (t - t0) / elapsed
        eta = (stop_time - t) / rate if rate > 0 else math.inf
        return Rate(False, (n - n0) / elapsed, eta)
