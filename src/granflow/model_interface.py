"""The model interface of :class:`granflow.simulation.Simulation` (issue 18 item 4): a
:class:`typing.Protocol`, so that the time loop runs any object that has it, a subclass of
:class:`granflow.model.Model` or not.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np

    from granflow.grid import Grid
    from granflow.materials import Material
    from granflow.model_options import StepReport
    from granflow.state import State


@runtime_checkable
class SteppingModel(Protocol):
    """What :class:`granflow.simulation.Simulation` uses of its model (issue 18 item 4): any object
    with these attributes is accepted, :class:`granflow.model.Model` or not.

    The loop reads ``grid`` (time step, state checks) and calls ``advance(state, dt)``, which
    advances ``state`` in place by ``dt`` [s] and returns a :class:`~granflow.model.StepReport`
    (FAILED: state untouched); the energy budget (:class:`granflow.diagnostics.EnergyBudget`)
    reads ``inertia_density(phi)`` (face inertia [kg m^-3]), ``gravity`` ``(g_x, g_z)``
    [m s^-2], ``material`` (rho_s) and ``gas`` (None: dry). The case runner and the output
    writers read more of a :class:`~granflow.model.Model` (``closure``, ``ambient``, ``ops``,
    ``linear_solver_name``, ``velocity_band``, ...): a model run by ``granflow run`` is a Model.
    """

    grid: Grid
    gravity: tuple[float, float]
    material: Material
    gas: Any

    def advance(self, state: State, dt: float) -> StepReport: ...

    def inertia_density(self, phi) -> np.ndarray: ...


MODEL_INTERFACE = ("grid", "gravity", "material", "gas", "advance", "inertia_density")
"""The members of :class:`SteppingModel`, named in the error of a model without them."""
