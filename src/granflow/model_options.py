"""The options of :class:`granflow.model.Model` (numerical constants, the ambient and Picard
parameters, the linear-solver choice) and what one step reports (:class:`StepReport`).

Split from :mod:`granflow.model`, which re-exports every name here; see its docstring for the
scheme these options control.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Literal

import numpy as np
from pydantic import Field, field_validator

from granflow.params import Params
from granflow.physics.coupling import GasPowers
from granflow.physics.outflow import NOTHING, Absorbed

DEFAULT_GRAVITY = (0.0, -9.81)
"""Gravity (g_x, g_z) [m s^-2]."""
DEFAULT_EPS = 5.0e-3
"""Regularisation strain rate eps [s^-1] (NUMERICS.md §4: 1e-3..5e-3 gives the same run-out)."""
DEFAULT_DELTA_P = 1.0
"""Pressure offset delta_p [Pa] of the sqrt(p) linearisation and of I at p -> 0 (NUMERICS.md §3.1)."""
PHI_FLOOR = 1.0e-3
"""Lower clip of phi where the closure is evaluated (NUMERICS.md §6)."""
INTERFACE_RADIUS = 2
"""Half-width (cells) of the neighbourhood of the interface packing phi_loc (NUMERICS.md §7.1)."""
MIN_VELOCITY_BAND = 2
"""Smallest :attr:`AmbientParams.velocity_band` [cells]: a step moves grains by at most two cells
(CFL < 1/2, two Runge-Kutta stages), so they never reach the faces held at rest."""
MAX_VELOCITY_BAND = 1_000_000
"""Widest velocity band [cells]: more than any grid's extent (a wider band is the whole grid;
``2**62`` overflowed a C index)."""
MAX_PICARD_SWEEPS = 1000
"""Most Picard sweeps per step (a step of more never converges; ``2**62`` would never end)."""
DEFAULT_VELOCITY_BAND = 10
"""Default :attr:`AmbientParams.velocity_band` [cells]. The ambient held at rest beyond the band
drags on the surface (viscous stress ~ eta_a u / (band dx)); measured on the Lagree column
(a = 1.42, 128^2, fronts at rest against velocity_band = 0): band 3 -1.5 % (toe) / -1.0 %
(0.05 H0 front), band 6 -0.6 % / -0.45 %, band 10 -0.16 % / -0.2 %; the a = 1.42 run at 32^2
moved 5 % with band 3 and not with 6 or 10. Cost at 128^2: 11.4 s (3), 11.5 s (6), 12.4 s (10);
at 256^2 39.8 s (3), 49.1 s (10) (benchmarks/README.md)."""
DEFAULT_BAND_MARGIN = 3
"""Default :attr:`AmbientParams.velocity_band_margin` [cells] (since session 25; 0 before): the
velocity band and the pressure unknowns are kept across steps, built 3 cells wider (Lagree
column at 256^2: the pattern rebuilt at 22 of 553 steps; docs/solver.md "Keeping the pattern")."""
ANALYSIS_STEPS = 64
"""Steps over which PARDISO keeps an analysis (ordering, scaling, matching) of an unchanged pattern
when :attr:`AmbientParams.velocity_band_margin` > 0. Its scaling and matching are those of the
matrix it analysed: kept longer, the factorisation and the solve grow (Lagree column, 256^2, one
solve per step, margin 3, single runs of a scratch version that forgot the analysis every k-th
step: k = 1 / 2 / 4 / 8 took 31.0 / 27.0 / 23.0 / 25.0 s; docs/solver.md "Keeping the pattern").
16 since session 24, when isolated traces stopped rebuilding the region (:data:`PHI_STRANDED`) and
the window, not the pattern, ended most analyses: user CPU 4 -> 16 at 128^2 4.63 / 4.68 / 4.51 ->
4.39 / 4.54 / 4.36 s, at 256^2 16.03 / 16.08 -> 15.72 / 15.35 s (alternated, same fronts). 64 since
session 27, once the pivot perturbation of 1e-6 (:data:`granflow.solvers.pardiso.SYMMETRIC_PIVOT_PERTURBATION`)
kept the residuals of the older analyses at ~1e-13 (at 1e-8 a 64-step window put the 256^2
residuals at the 1e-8 limit): analyses 29 -> 11 at 128^2 and 42 -> 24 at 256^2; user CPU at 128^2
median 6.09 -> 5.68 s (5 alternated pairs on a noisy host, per-pair ratios 0.88-1.03)."""
PHI_TRACE = 1.0e-6
"""Cells with ``phi > PHI_TRACE phi_max`` hold grains for the velocity band
(:attr:`AmbientParams.velocity_band`); below it, trace material left by numerical diffusion."""
PHI_STRANDED = 1.0e-3
"""Grains outside the kept velocity region (:func:`granflow.region.step_region`) in cells with
``phi < PHI_STRANDED phi_max``, in their eight neighbours too, do not make the region be rebuilt
(unless dense with a row, or more than :data:`STRANDED_VOLUME`): they keep the faces the kept
region gives them, at rest beyond it, until the region is rebuilt for another reason. Such traces,
carried away from the pile by the ambient, rebuilt the region (and PARDISO's analysis) every 3-4
steps (docs/solver.md "Keeping the pattern")."""
STRANDED_VOLUME = 1.0e-4
"""Most grains (a fraction of all the grains' volume) that may be stranded at once
(:data:`PHI_STRANDED`): above it the cells are a dilute cloud, not traces, and the region is
rebuilt. The Lagree column's traces are ~1e-6 of its volume."""
VISCOUS_ADDITION_FACTOR = 0.5
"""The closure's viscous stress eta_visc S is 2 (eta_visc/2) S in the tau = 2 eta S convention."""
DEFAULT_PHI_TOLERANCE = 0.05
"""Relative overshoot of phi_max (before clipping) that fails a step."""
DEFAULT_ISOCHORIC_INTERFACE = 1
"""Default isochoric band [cells] next to the ambient (:class:`Model` ``isochoric_interface``;
NUMERICS.md §7.1): dense cells within it follow div u = 0 instead of the dilatancy law."""
AUTO_AMG_UNKNOWNS = 20_000
"""``linear_solver="auto"`` uses the AMG path from this many saddle-point unknowns (velocities +
pressures) up; below it SciPy's sparse LU is faster (benchmarks/linear_solvers.py: AMG 15-28
iterations from 40 x 15 to 160 x 60 cells, cost ~N^1.04 against ~N^1.46 for the LU)."""


AUTO_BANDED_DIRECT_UNKNOWNS = 200_000
"""Without PARDISO, ``linear_solver="auto"`` with the velocity band on uses SciPy's LU below this
many whole-grid unknowns (velocities + cells; 256^2 has 1.96e5): a collapse's banded systems are
small. Above it the band may still cover a flow that fills the box, so the AMG path is taken."""


class LinearSolverChoice(str, Enum):
    """Linear solver of the Picard sweeps (:class:`Model` ``linear_solver``)."""

    AUTO = "auto"
    """``pardiso`` if its optional dependency is installed (``granflow[fast]``), else ``direct``
    when the velocity band is on (:attr:`AmbientParams.velocity_band`, default: the banded
    systems of a collapse are small; Lagree 128^2: 26 s with SuperLU) and the grid has fewer
    than :data:`AUTO_BANDED_DIRECT_UNKNOWNS` unknowns, else ``direct`` below
    :data:`AUTO_AMG_UNKNOWNS` unknowns and ``amg`` above."""
    DIRECT = "direct"
    """SciPy's sparse LU (SuperLU): exact, the reference; cost grows ~N^1.5."""
    AMG = "amg"
    """FGMRES preconditioned by the block AMG of :mod:`granflow.solvers.saddle`: ~O(N)."""
    PARDISO = "pardiso"
    """Intel MKL PARDISO sparse LU (:mod:`granflow.solvers.pardiso`, optional extra
    ``granflow[fast]``): exact like ``direct``, with the symbolic analysis kept while the pattern
    does not change; 2-4x faster than SuperLU on the column systems (benchmarks/README.md)."""


class Surface(str, Enum):
    """How the model tells grains from the ambient (``numerics.surface``)."""

    THRESHOLD = "threshold"
    """v1: cells with ``phi < ambient.phi_c`` are a pressureless light ambient; the closure sees
    ``phi_loc`` near it and an isochoric band keeps partial cells from dilating."""
    INDICATOR = "indicator"
    """Scheme v2: a transported material fraction ``c`` (:mod:`granflow.physics.material`);
    every cell with material has its pressure, weight and strength, the closure sees the packing
    inside the material ``phi / c``; no threshold, no band, no ``phi_loc``."""


class BaseFriction(str, Enum):
    """Pressure of the friction on a no-slip base (``numerics.base_friction``)."""

    CENTRE = "centre"
    """The base's nodes take the mean viscosity of the two cells above, evaluated at the cells'
    centre pressure (half a cell of weight short of the wall: the basal friction of a layer one
    cell thick is half its weight's)."""
    WALL = "wall"
    """The same cells' viscosity evaluated at the pressure extrapolated to the wall
    (:func:`granflow.physics.momentum.base_pressure`) and the wall's strain rate
    (:func:`granflow.physics.wall_friction.base_strain_rate_norm`), so that the basal stress is
    ``Z(I_wall) p_wall`` at any thickness (default with the indicator surface)."""


class AmbientParams(Params):
    """The pressureless light ambient (NUMERICS.md §7).

    Attributes
    ----------
    phi_c : float
        Cells with phi < phi_c are ambient [-]. Default 0.3.
    rho_a : float
        Ambient inertia [kg m^-3] (no weight). Default 2.
    eta_a : float
        Ambient viscosity [Pa s]. Default 1e-3.
    eta_b : float, optional
        Background viscosity added to the dense cells [Pa s]; default (None) ``eta_a`` with the
        threshold surface (one number sets both: the v1 behaviour) and 0 with the indicator surface
        (:attr:`granflow.model.Model.background_viscosity`). Set it apart from ``eta_a`` to damp the grains
        that numerical diffusion leaves in the ambient without changing the dense rheology.
    velocity_band : int
        The velocity is solved only on the faces of the cells within this many cells of a cell
        holding grains (``phi > PHI_TRACE phi_max``); the ambient beyond is at rest (``u = 0``,
        not an unknown). Cuts the linear systems to the neighbourhood of the material (a
        column collapse fills a few % of its box: at 128^2 the Lagree column runs 8x faster,
        benchmarks/README.md). Default :data:`DEFAULT_VELOCITY_BAND`; 0 solves everywhere
        (the scheme before issue 6); else at least :data:`MIN_VELOCITY_BAND`. Not applied with ``linear_solver = "amg"`` (its block AMG
        works on the whole grid).
    velocity_band_margin : int
        With a margin ``m > 0`` the velocity unknowns are those of a band ``velocity_band + m``
        cells wide, and the pressure unknowns every dense cell or cell within ``m`` cells of
        grains, both kept from step to step while the ``velocity_band`` band and the dense cells
        stay inside them (:func:`granflow.region.step_region`); with ``linear_solver`` PARDISO the
        matrix pattern then stays the same over those steps and its analysis is kept for up to
        :data:`ANALYSIS_STEPS` steps (:class:`granflow.solvers.pardiso.PardisoSolver`). Default
        :data:`DEFAULT_BAND_MARGIN` (3; before session 25 0, both rebuilt at every step).
        Checkpoints store both, so restarts stay bit-identical (docs/solver.md "Keeping the
        pattern").
    """

    phi_c: float = Field(0.3, gt=0, lt=1, description="ambient threshold on phi [-]")
    rho_a: float = Field(2.0, gt=0, description="ambient density [kg m^-3]")
    eta_a: float = Field(1.0e-3, gt=0, description="ambient viscosity [Pa s]")
    eta_b: float | None = Field(None, ge=0, description="background viscosity of the dense cells "
                                "(default: eta_a with surface = \"threshold\", 0 with \"indicator\") [Pa s]")
    velocity_band: int = Field(DEFAULT_VELOCITY_BAND, ge=0, le=MAX_VELOCITY_BAND, description="solve the velocity only "
                               "within this many cells of the grains, u = 0 beyond; 0 = everywhere, "
                               f"else >= {MIN_VELOCITY_BAND} [cells]")

    velocity_band_margin: int = Field(DEFAULT_BAND_MARGIN, ge=0, le=MAX_VELOCITY_BAND,
                                      description="keep the velocity band and the pressure unknowns "
                                      "across steps, built this many cells wider; 0 = rebuilt every step [cells]")

    @field_validator("velocity_band")
    @classmethod
    def _band_width(cls, value: int) -> int:
        if 0 < value < MIN_VELOCITY_BAND:
            raise ValueError(f"velocity_band must be 0 (off) or >= {MIN_VELOCITY_BAND} cells, got {value}")
        return value

    @property
    def background_viscosity(self) -> float:
        """``eta_b``, or ``eta_a`` when not given [Pa s]."""
        return self.eta_a if self.eta_b is None else self.eta_b


DEFAULT_MAX_SWEEPS = 1
"""Default Picard cap: one linear solve per step (session 25). With the extrapolated predictor
the step is linearly implicit (docs/solver.md, "One solve per step"): on the Lagree column the
t = 4 fronts equal the converged loop's (cap 10, tol 1e-3) and the deposit differs by 4-5e-3,
for a half to a third of the cost. ``max_sweeps = 10`` with ``predictor = "previous"`` is the
converged loop of sessions 12-24 (7 sweeps at 128^2, 10 on the fluidised flagship)."""


class Predictor(str, Enum):
    """First iterate of the Picard loop (:attr:`PicardParams.predictor`)."""

    PREVIOUS = "previous"
    """``u^n``: the closure, the strain rate and the momentum fluxes of the first sweep are
    those of the last step (lagged by one step: an O(dt) error in the coefficients)."""
    EXTRAPOLATED = "extrapolated"
    """``u^n + min(dt, dt_{n-1}) minmod(a^n, a^{n-1})`` with ``a^n = (u^n - u^{n-1}) / dt_{n-1}``
    the last step's mean acceleration (:attr:`granflow.state.State.accel`, ``accel_prev`` the
    one before; :func:`granflow.predictor.first_iterate`): the coefficients of the first sweep
    are O(dt^2) from those of ``u^{n+1}`` where the flow is smooth in time, and an oscillation
    from step to step is not extrapolated. ``u^n`` at the first step and after a restart from a
    checkpoint without ``state.accel``."""


class PicardParams(Params):
    """Picard / active-set loop of one step.

    Attributes
    ----------
    max_sweeps : int
        Maximum number of linear solves per step. Default :data:`DEFAULT_MAX_SWEEPS` (1; 10
        before session 25).
    tol : float
        Converged when ``|u_{k+1} - u_k| <= tol (|u_{k+1}| + sqrt(n) eps Lz)`` and the active set
        did not change [-]. Default 1e-3.
    fail_tol : float
        The step FAILS if the last relative increment exceeds this [-]. Default 0.5. Not with
        ``max_sweeps = 1``: one solve has no loop to diverge, and its increment is the step's own
        change from the first iterate (near rest it reached 0.95 of the small velocities whatever
        dt, and a decelerating axisymmetric column failed at t = 0.35 s).
    predictor : {"previous", "extrapolated"}
        First iterate of the loop (:class:`Predictor`). Default ``"extrapolated"`` (since
        session 25; ``"previous"``, ``u^n``, before).
        With ``"extrapolated"`` and ``max_sweeps = 1`` the step is *linearly implicit*: one
        linear solve with coefficients extrapolated from the two last steps (docs/solver.md,
        "One solve per step").
    """

    max_sweeps: int = Field(DEFAULT_MAX_SWEEPS, ge=1, le=MAX_PICARD_SWEEPS, description="maximum Picard sweeps per step")
    tol: float = Field(1.0e-3, gt=0, description="relative velocity-increment tolerance")
    fail_tol: float = Field(0.5, gt=0, description="relative increment that fails the step")
    predictor: Literal[tuple(p.value for p in Predictor)] = Field(  # type: ignore[valid-type]
        Predictor.EXTRAPOLATED.value, description='first iterate: "previous" (u^n) or "extrapolated" '
        "(u^n + min(dt, dt_(n-1)) minmod(a^n, a^(n-1)), a^n = (u^n - u^(n-1)) / dt_(n-1)) [-]")


class StepStatus(str, Enum):
    """Outcome of :meth:`Model.advance`."""

    OK = "ok"
    """Converged and within bounds."""
    NOT_CONVERGED = "not_converged"
    """Accepted: Picard stopped at ``max_sweeps`` with an increment below ``fail_tol``."""
    FAILED = "failed"
    """Rejected (state unchanged): NaN, Picard divergence, CFL or phi-bound violation."""


@dataclass(frozen=True)
class StepReport:
    """What happened during one step. Powers are per unit width [W m^-1], masses [m^2]."""

    status: StepStatus
    dt: float
    message: str = ""
    picard_iterations: int = 0
    picard_increment: float = float("nan")
    active_set_changes: int = 0
    n_dense: int = 0
    n_free: int = 0
    n_negative_Z: int = 0
    cfl: float = float("nan")
    clipped_mass: float = 0.0
    added_mass: float = 0.0
    limited_mass: float = 0.0
    """Solid volume per unit width [m^2] the transport's upper-bound limiter kept in donor cells
    (:func:`granflow.physics.transport.limit_to_upper_bound`; mass is conserved, only where it
    goes changes)."""
    max_phi_before_clip: float = float("nan")
    min_phi_before_clip: float = float("nan")
    dissipation_yield: float = 0.0
    """``dV u^T V u`` with the viscosity of the last solve (yield + viscous + background)."""
    dissipation_dilatancy: float = 0.0
    """``-dV sum p Div u`` (the dilatancy work; may be negative locally and in total)."""
    inertia_dissipation: float = 0.0
    """Backward-Euler numerical dissipation ``sum rho_f |u^{n+1} - u^n|^2 dV / (2 dt)``."""
    advection_power: float = 0.0
    """``dV sum rho_f a^n . u^{n+1}`` (upwind advection work)."""
    gravity_power: float = 0.0
    """``dV sum f_g . u^{n+1}``."""
    solve_power: float = 0.0
    """``dV r_u . u^{n+1}``, ``r_u = K x - b`` the linear solve's error on the velocity rows (the
    energy budget's ``linear_solve`` term; ~1e-9 of the other powers with a kept PARDISO
    analysis, round-off with a fresh one)."""
    timings: dict = field(default_factory=dict)
    """Wall time per phase [s]: 'assembly', 'solve', 'transport'."""
    gas: GasPowers | None = None
    """Gas energy terms of the step (None for the dry model)."""
    linear_iterations: int = 0
    """Krylov iterations summed over the Picard sweeps (0 with the direct solver)."""
    solve_density: np.ndarray | None = None
    """Face inertia used by the final solve of the step [kg m^-3]: ``m_k`` with the consistent
    momentum transport, else the inertia at t^n (after a source's refill; None: a report built
    without it, the budget then uses the inertia of the previous record); the energy budget's
    inertia-transport term is ``(m^{n+1} - m_k) |u^{n+1}|^2 dV / 2``."""
    wrapped_mass: float = 0.0
    """Periodic grid: solid volume per unit width [m^2] carried in +x through the periodic
    x-face 0 by the transport of the step (0 for a closed box); the energy budget uses it to
    follow the potential energy across the period."""
    outflow: Absorbed = NOTHING
    """What an outflow east wall took out of the box in the step (solid volume [m^2], kinetic,
    potential and gas energy [J m^-1]; :mod:`granflow.physics.outflow`)."""
    inflow: Absorbed = NOTHING
    """What a source put into the box in the step (the same quantities, positive when added;
    :mod:`granflow.physics.inflow`)."""
    source_power: float = 0.0
    """Power of the source's prescribed velocity, ``dV sum lambda (u_in - u) u`` [W m^-1]."""

    @property
    def failed(self) -> bool:
        return self.status is StepStatus.FAILED


@dataclass(frozen=True)
class Coefficients:
    """Lagged coefficients of one Picard sweep, flat over cells."""

    eta_c: np.ndarray
    b: np.ndarray
    C: np.ndarray
    n_negative_Z: int
    nonfinite: dict
    """Number of dense cells with a non-finite Z, b or C (empty if all finite)."""
