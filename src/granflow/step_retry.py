"""The time step of a retried step (:meth:`granflow.simulation.Simulation.step`): a rejected
step is tried again with ``dt * retry_factor(report)``."""
from __future__ import annotations

import math

from granflow.model_options import StepReport
from granflow.physics.transport import POSITIVITY_CFL

RETRY_FACTOR = 0.5
"""dt of a retried step relative to the failed one (any failure but the CFL bound's)."""
CFL_RETRY_MARGIN = 0.9
"""A step rejected for the CFL number ``c > 1/2`` of its ``u^{n+1}`` is retried with
``dt * CFL_RETRY_MARGIN * (1/2) / c`` (between ``dt * CFL_RETRY_MIN`` and
``dt * CFL_RETRY_MARGIN``): ``u^{n+1}`` hardly changes with dt, so that dt puts its CFL number
10 % under the positivity bound, where halving dt threw up to half a step away. Measured on
the Lagree column at 256^2 to t = 4 with ``time.cfl = 0.45`` (benchmarks/README.md, issue 15)."""
CFL_RETRY_MIN = 0.1
"""Smallest dt ratio of a CFL retry (a diverging step can report a huge CFL number)."""


def retry_factor(report: StepReport) -> float:
    """dt of the retry of a rejected step relative to its dt (:data:`RETRY_FACTOR`, or from the
    CFL number of a step rejected by the CFL bound, :data:`CFL_RETRY_MARGIN`)."""
    cfl = report.cfl
    if not (report.failed and math.isfinite(cfl) and cfl > POSITIVITY_CFL):
        return RETRY_FACTOR
    return min(max(CFL_RETRY_MARGIN * POSITIVITY_CFL / cfl, CFL_RETRY_MIN), CFL_RETRY_MARGIN)
