"""Case files: the strict, typed configuration of a run (STYLE.md idiom 9) -- the schema.

A case file is TOML with the sections ``[case]`` (``name``: the case registry key),
``[material]`` (:class:`granflow.materials.Material`), ``[closure]`` (``name`` + the closure's
parameters, checked by :func:`granflow.rheology.make_closure`), ``[equilibrium]`` (``law`` + its
parameters), ``[grid]``, ``[walls]``, ``[gravity]``, ``[time]``, ``[numerics]`` (with
``[numerics.picard]`` and ``[numerics.ambient]``), ``[gas]``, ``[output]`` and ``[setup]`` (the
case's own options, validated by the case's model). Every option has a default
(``granflow config show CASE``; docs/cases.md), so ``[case]\nname = "column_collapse"`` is a
complete case file.

Unknown keys, wrong types (no silent conversion of ``"0.1"`` or ``true`` to numbers), NaN or
infinite numbers, out-of-range values, unknown registry names and inconsistent options (e.g.
``setup.phi0 > material.phi_max``) are all reported together in ONE
:class:`~granflow.errors.GranflowInputError` whose parts name the full key path and what was
expected, before any computation.

Examples
--------
>>> cfg = CaseConfig.from_dict({"case": {"name": "column_collapse"}, "grid": {"nx": 20, "nz": 8}})
>>> cfg.grid.nx, cfg.closure.name, cfg.setup.H0
(20, 'drucker_prager', 0.1)
>>> CaseConfig.from_dict({"case": {"name": "column_collapse"}, "grid": {"nx": 0}})
Traceback (most recent call last):
...
granflow.errors.GranflowInputError: grid.nx: Input should be greater than or equal to 2 (got 0)
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    model_validator,
)

from granflow.config.sections import InflowSection, Section, TopographySection
from granflow.config.tomlfile import KEY_SEP, dumps_toml  # noqa: F401  (KEY_SEP: re-exported)
from granflow.gas import GasCompressibility, GasLaw
from granflow.grid import MIN_CELLS, Geometry
from granflow.materials import Material
from granflow.model_options import DEFAULT_ISOCHORIC_INTERFACE
from granflow.model import (
    DEFAULT_DELTA_P,
    DEFAULT_EPS,
    AUTO_AMG_UNKNOWNS,
    AUTO_BANDED_DIRECT_UNKNOWNS,
    DEFAULT_PHI_TOLERANCE,
    INTERFACE_RADIUS,
    AmbientParams,
    BaseFriction,
    LinearSolverChoice,
    PicardParams,
    Surface,
)
from granflow.physics.momentum import Advection
from granflow.physics.momentum_transport import MC_THETA, MINMOD_THETA
from granflow.physics.transport import POSITIVITY_CFL, PhiScheme
from granflow.simulation import DEFAULT_CFL, DEFAULT_DT_MAX, DEFAULT_MAX_RETRIES

MAX_CELLS = 4_000_000
"""Largest grid ``nx * nz`` accepted (a guard against typos such as ``nx = 40000``)."""
MAX_STEPS = 10_000_000
"""Step budget without ``time.max_steps``: ``stop_time / dt_max`` (a lower bound of the number of
steps) above it is refused (a guard against ``dt_max = 1e-300``, which would step for ever)."""
MIN_CFL = 1e-4
"""Smallest CFL number: below it the step budget cannot be reached (``cfl = 1e-300`` gave a
time step of 1e-301 s and overflowing matrices)."""
MAX_RETRIES = 50
"""Most dt halvings of one step (dt_max / 2**50 is ~1e-15 dt_max; more would halve towards 0)."""
MAX_RECORDS = 100_000
"""Most NetCDF records of a run, ``stop_time / output.interval`` (each record holds every field;
the output times also cut the time step, so ``interval = 1e-12`` stepped for ever)."""
PHYSICAL_RANGES = {
    "material.d": (1e-6, 0.1, "m"),
    "material.rho_s": (10.0, 3.0e4, "kg m^-3"),
    "material.eta_f": (1e-7, 10.0, "Pa s"),
    "material.p_atm": (1.0, 1e9, "Pa"),
    "material.rho_f0": (1e-4, 3.0e3, "kg m^-3"),
    "gravity.g": (0.0, 300.0, "m s^-2"),
    "material.c_I": (0.1, 10.0, "-"),
    "grid.Lx": (1e-6, 1e5, "m"),
    "grid.Lz": (1e-6, 1e5, "m"),
    "gas.U_inj": (0.0, 1e3, "m s^-1"),
}
"""Physical range [lo, hi] of the dimensional parameters (grains from 1 um powders to 10 cm
boulders, solids from aerogels to tungsten, gases to liquids, gravity up to 30 g, boxes from 1 um
to 100 km, gas injected at up to 1 km/s); a value outside
is refused unless ``case.allow_unphysical = true``."""
NUMERICS_RANGES = {
    "numerics.eps": (1e-9, 1e4, "s^-1"),
    "numerics.delta_p": (1e-9, 1e6, "Pa"),
    "numerics.gravity_blend_velocity": (1e-12, 1e3, "m s^-1"),
    "numerics.ambient.rho_a": (1e-6, 1e4, "kg m^-3"),
    "numerics.ambient.eta_a": (1e-9, 1e4, "Pa s"),
    "numerics.ambient.eta_b": (0.0, 1e4, "Pa s"),
}
"""Range [lo, hi] of the dimensional numerical parameters, many orders of magnitude around the
defaults (``eps = 1e300`` or ``eta_a = 1e300`` only failed the first step, exit 1); a value
outside is refused unless ``case.allow_unphysical = true``."""
COLUMN_KEYS = ("H0", "h0", "H")
"""``[setup]`` keys of the initial column or layer height, compared with ``material.d``."""
EQUILIBRIUM_I = (0.0, 10.0)
"""Range of I over which the yield function must be non-negative on the equilibrium line."""
DEFAULT_GRAVITY = 9.81
"""Magnitude of gravity [m s^-2]."""
MAX_SLOPE_DEG = 90.0
"""Slope angles must lie strictly within (-90, 90) degrees."""
OUTPUT_FIELDS = ("phi", "c", "u", "w", "p", "p_f", "S")
"""Cell-centred fields that can be written to the NetCDF output."""
WallCondition = Literal["no_slip", "free_slip"]
EastCondition = Literal["no_slip", "free_slip", "outflow"]
"""The east wall's conditions: a wall's, or ``"outflow"`` (:mod:`granflow.physics.outflow`)."""
BaseCondition = Literal["no_slip", "free_slip", "coulomb"]
"""The base's conditions: a wall's, or ``"coulomb"`` (friction ``walls.base_friction_deg``)."""
MAX_FRICTION_DEG = 90.0
"""Base friction angles lie strictly within (0, 90) degrees."""


def enum_values(enum) -> tuple[str, ...]:
    """The values of a ``str`` Enum, in declaration order: the options of a ``Literal`` derived from
    the enum the Model takes (one list of names; pydantic's error names the key and the values)."""
    return tuple(e.value for e in enum)


GasLawName = Literal[enum_values(GasLaw)]  # type: ignore[valid-type]
GasCompressibilityName = Literal[enum_values(GasCompressibility)]  # type: ignore[valid-type]
AdvectionName = Literal[enum_values(Advection)]  # type: ignore[valid-type]
PhiSchemeName = Literal[enum_values(PhiScheme)]  # type: ignore[valid-type]
SurfaceName = Literal[enum_values(Surface)]  # type: ignore[valid-type]
BaseFrictionName = Literal[enum_values(BaseFriction)]  # type: ignore[valid-type]
LinearSolverName = Literal[enum_values(LinearSolverChoice)]  # type: ignore[valid-type]
GeometryName = Literal[enum_values(Geometry)]  # type: ignore[valid-type]
DEFAULT_LINEAR_SOLVER = LinearSolverChoice.AUTO.value
"""The case files' linear solver: ``"auto"`` (the fastest exact or iterative solver for the size).
:class:`granflow.model.Model` keeps ``"direct"`` (SciPy's LU, the reference) as its own default for
library use and tests; a case always passes its ``numerics.linear_solver``."""


class CaseSection(Section):
    """``[case]``."""

    name: str = Field(description="case registry key (granflow list cases) [-]")
    allow_unphysical: bool = Field(False, description="accept material, gravity and numerical "
                                   "parameters outside the ranges of granflow.config.PHYSICAL_RANGES "
                                   "and NUMERICS_RANGES "
                                   "(an unusual study, e.g. dimensionless units) [-]")


class MaterialSection(Material):
    """``[material]``: :class:`granflow.materials.Material`, validated strictly."""

    model_config = ConfigDict(strict=True, allow_inf_nan=False)


class OpenSection(BaseModel):
    """A registry name plus free parameters, validated by the registry's own model."""

    model_config = ConfigDict(frozen=True, extra="allow", strict=True, allow_inf_nan=False)

    def parameters(self) -> dict[str, Any]:
        """The parameters other than the registry key."""
        return dict(self.model_extra or {})


class ClosureSection(OpenSection):
    """``[closure]``: ``name`` and the closure's parameters (``granflow list closures``)."""

    name: str = Field("drucker_prager", description="closure registry key (granflow list closures) [-]")


class EquilibriumSection(OpenSection):
    """``[equilibrium]``: ``law`` and its parameters (``granflow list equilibria``)."""

    law: str = Field("linear", description="equilibrium-law registry key (granflow list equilibria) [-]")


class GridSection(Section):
    """``[grid]``: the closed box [0, Lx] x [0, Lz] cut into nx x nz cells."""

    nx: int = Field(40, ge=MIN_CELLS, description="number of cells along x [-]")
    nz: int = Field(15, ge=MIN_CELLS, description="number of cells along z [-]")
    Lx: float = Field(0.4, gt=0, description="box length [m]")
    Lz: float = Field(0.15, gt=0, description="box height [m]")
    periodic_x: bool = Field(False, description="periodic in x (an infinite layer; the west and east "
                             "walls are then ignored) [-]")
    geometry: GeometryName = Field("plane", description='"plane" (a vertical plane, per unit width) or '
                                   '"axisymmetric" (x is the radius r, the west side the axis: a '
                                   'cylindrical column; integrals over the whole cylinder; column_collapse) '
                                   '[-]')

    @model_validator(mode="after")
    def _size(self) -> GridSection:
        if self.geometry == "axisymmetric" and self.periodic_x:
            raise ValueError('grid.geometry = "axisymmetric" cannot be periodic in r: set grid.periodic_x = false')
        if self.nx * self.nz > MAX_CELLS:
            raise ValueError(f"nx * nz = {self.nx * self.nz} cells exceeds the limit of {MAX_CELLS} "
                             "(granflow.config.MAX_CELLS); check nx and nz")
        return self


class WallsSection(Section):
    """``[walls]``: tangential velocity condition of each wall (the normal velocity is zero)."""

    west: WallCondition = Field("free_slip", description="wall x = 0 (symmetry plane when free_slip) [-]")
    east: EastCondition = Field("free_slip", description='wall x = Lx; "outflow": the grains leave the box '
                                'there (the last column absorbs them: free-slip in the solve, the volume '
                                'and energy that leave counted in the budgets) [-]')
    bottom: BaseCondition = Field("no_slip", description='base z = 0; "coulomb": the grains slide on '
                                  'it once their shear stress reaches tan(base_friction_deg) p_wall [-]')
    top: WallCondition = Field("free_slip", description="lid z = Lz [-]")
    base_friction_deg: float | None = Field(
        None, gt=0, lt=MAX_FRICTION_DEG, description='wall friction angle delta_w of a "coulomb" base '
        '(needed there, refused otherwise): basal shear stress at most tan(delta_w) p_wall, p_wall the '
        'granular pressure on the base [deg]')

    @model_validator(mode="after")
    def _coulomb_friction(self) -> WallsSection:
        if self.bottom == "coulomb" and self.base_friction_deg is None:
            raise ValueError('walls.bottom = "coulomb" needs walls.base_friction_deg (the wall friction '
                             'angle, degrees)')
        if self.bottom != "coulomb" and self.base_friction_deg is not None:
            raise ValueError(f'walls.base_friction_deg needs walls.bottom = "coulomb" (got "{self.bottom}")')
        return self

    @property
    def wall_friction(self) -> float | None:
        """mu_w = tan(base_friction_deg) [-], or None (no Coulomb base)."""
        return None if self.base_friction_deg is None else math.tan(math.radians(self.base_friction_deg))


class GravitySection(Section):
    """``[gravity]``: ``(g_x, g_z) = g (sin(slope), -cos(slope))``."""

    g: float = Field(DEFAULT_GRAVITY, ge=0, description="magnitude of gravity [m s^-2]")
    slope_deg: float = Field(0.0, gt=-MAX_SLOPE_DEG, lt=MAX_SLOPE_DEG,
                             description="tilt of gravity; > 0 is a slope down towards +x [deg]")


class TimeSection(Section):
    """``[time]``."""

    stop_time: float = Field(0.5, gt=0, description="final time [s]")
    cfl: float = Field(DEFAULT_CFL, ge=MIN_CFL, le=POSITIVITY_CFL, description="CFL number of the time step [-]")
    dt_max: float = Field(DEFAULT_DT_MAX, gt=0, description="largest time step [s]")
    max_retries: int = Field(DEFAULT_MAX_RETRIES, ge=0, le=MAX_RETRIES,
                             description="retries with a smaller dt allowed for one step [-]")
    max_steps: int | None = Field(None, ge=1, le=MAX_STEPS, description="stop after this many steps in "
                                  "total, counted from t = 0, at most granflow.config.MAX_STEPS [-] "
                                  "(default: no limit)")
    stop_at_rest: float | None = Field(None, gt=0, description="end the run once the flow has been "
                                       "at rest (t_rest, output.rest_speed) for this long [s] "
                                       "(default: run to stop_time)")


class PicardSection(PicardParams):
    """``[numerics.picard]``: :class:`granflow.model.PicardParams`."""

    model_config = ConfigDict(strict=True, allow_inf_nan=False)


class AmbientSection(AmbientParams):
    """``[numerics.ambient]``: :class:`granflow.model.AmbientParams`."""

    model_config = ConfigDict(strict=True, allow_inf_nan=False)


class NumericsSection(Section):
    """``[numerics]``: the options of :class:`granflow.model.Model`."""

    eps: float = Field(DEFAULT_EPS, gt=0, description="regularisation strain rate [s^-1]")
    delta_p: float = Field(DEFAULT_DELTA_P, gt=0, description="pressure offset of the sqrt(p) "
                           "linearisation and of I at p -> 0 [Pa]")
    advection: AdvectionName = Field(
        Advection.CONSISTENT.value, description='momentum advection scheme: "upwind", "muscl" (non-conservative '
        '(u.grad)u) or "consistent" (conservative, with the phi transport\'s mass fluxes) [-]')
    phi_transport: PhiSchemeName = Field(
        PhiScheme.MUSCL.value, description='face values of the phi transport: "muscl" (MUSCL-minmod) or "sharp" '
        '(MUSCL-THINC-BVD, the free surface kept within 1-2 cells) [-]')
    surface: SurfaceName = Field(
        Surface.INDICATOR.value, description='how grains are told from the ambient: "threshold" (phi < '
        'ambient.phi_c is ambient) or "indicator" (a transported material fraction c; the closure '
        'at the packing phi/c; interface_packing, isochoric_interface, phi_transport and phi_c '
        'unused) [-]')
    base_friction: BaseFrictionName | None = Field(
        None, description='pressure of the friction on a no-slip base: "wall" (the bottom cells\' '
        'viscosity at the pressure extrapolated to the wall: the basal yield stress is Z p_wall) or '
        '"centre" (at their centre pressure, half a cell of weight short); default: "wall" with '
        'surface = "indicator", else "centre" [-]')
    momentum_theta: float = Field(
        MC_THETA, ge=MINMOD_THETA, le=MC_THETA, description="slope limiter of the consistent "
        "momentum transport's face values: 1 = minmod, 2 = monotonized central (default), 1.3 = "
        "Basilisk's minmod2 [-]")
    interface_packing: bool = Field(True, description="closure at the local packing near the ambient [-]")
    consistent_gravity: bool = Field(True, description="energy-consistent gravity weighting [-]")
    gravity_blend_velocity: float | None = Field(
        None, gt=0, description="faces slower than this keep (a blend towards) the centred gravity "
        "weight (default: |g| dt with surface = \"indicator\", eps Lz with \"threshold\") [m s^-1]")
    isochoric_interface: int = Field(
        DEFAULT_ISOCHORIC_INTERFACE, ge=0, le=INTERFACE_RADIUS, description="dense cells within this many cells of the "
        "ambient are isochoric (div u = 0, or free with p = 0) instead of following the "
        "closure's dilatancy law; 0 = off [cells]")
    phi_tolerance: float = Field(DEFAULT_PHI_TOLERANCE, gt=0, description="relative overshoot of "
                                 "phi_max (before clipping) that fails a step [-]")
    linear_solver: LinearSolverName = Field(
        DEFAULT_LINEAR_SOLVER, description='linear solver of each Picard sweep: "direct" (SciPy sparse '
        'LU), "pardiso" (MKL sparse LU, needs granflow[fast]), "amg" (FGMRES + block AMG, ~O(N)) or '
        '"auto" (pardiso if installed, else direct with the velocity band on (below '
        f'{AUTO_BANDED_DIRECT_UNKNOWNS} unknowns), else amg from {AUTO_AMG_UNKNOWNS} unknowns up and '
        'direct below; the default here, while granflow.model.Model defaults to "direct") [-]')
    picard: PicardSection = Field(default_factory=PicardSection, description="Picard loop [-]")
    ambient: AmbientSection = Field(default_factory=AmbientSection, description="light ambient [-]")


class GasSection(Section):
    """``[gas]``: the pore-gas model; anything but ``law = "none"`` needs a Model with gas support."""

    law: GasLawName = Field("none", description='pore-gas law: "none" (dry), "linear" (eq. syst2b) '
                            'or "nonlinear" (eq. pressure-diffusion-nonlinear) [-]')
    U_inj: float = Field(0.0, ge=0, description="superficial gas velocity injected through the base [m s^-1]")
    open_top: bool = Field(False, description="p_f = 0 on the top wall (else impermeable) [-]")
    compressibility: GasCompressibilityName = Field(
        "isothermal", description='state law of the pore gas: "isothermal" (the paper\'s eq. syst2b) or '
        '"adiabatic" (gamma = 1.4: pore-pressure diffusivity 1.4 times larger; needs law = "linear") [-]')


class OutputSection(Section):
    """``[output]``."""

    directory: str | None = Field(None, min_length=1, description="output directory (default: "
                                  "runs/<case-file name>; --out overrides) [-]")
    interval: float = Field(0.05, gt=0, description="simulated time between NetCDF records [s]")
    checkpoint_interval: int = Field(500, ge=1, description="accepted steps between checkpoints [-]")
    checkpoint_keep: int = Field(2, ge=1, description="number of newest periodic checkpoints kept [-]")
    fields: list[Literal[OUTPUT_FIELDS]] = Field(  # type: ignore[valid-type]
        default_factory=lambda: list(OUTPUT_FIELDS), min_length=1,
        description=f"fields written at cell centres, any of {list(OUTPUT_FIELDS)} (c, the material "
        "fraction, only with numerics.surface = \"indicator\") [-]")
    front_threshold: float | None = Field(None, gt=0, description="deposit thickness defining the "
                                          "front (default: the case's, e.g. 0.05 H0 for column_collapse, else one cell height) [m]")
    probes_x: list[float] = Field(default_factory=list, description="x of basal probes [m]: p_f and p of "
                                  "the bottom cell containing each x, in output.nc at every record "
                                  "(probe_p_f, probe_p) [-]")
    rest_speed: float | None = Field(None, gt=0, description="rms granular speed (phi-weighted over "
                                     "the granular faces) below which the flow is at rest, for t_rest "
                                     "(default: 10 eps Lz) [m s^-1]")
    log_interval: float = Field(10.0, gt=0, description="wall time between progress log lines "
                                "when not on a terminal [s]")
    figures: bool = Field(True, description="write snapshot and front-position figures (PNG) at the "
                          "end of the run [-]")


class EmptySetup(Section):
    """``[setup]`` of a case without options."""


class CaseConfig(Section):
    """A validated case file. Build with :func:`load_case` or :meth:`from_dict`; the ``setup``
    section has the type of the case's own model (``case.setup_model``)."""

    case: CaseSection
    material: MaterialSection = Field(default_factory=MaterialSection)
    closure: ClosureSection = Field(default_factory=ClosureSection)
    equilibrium: EquilibriumSection = Field(default_factory=EquilibriumSection)
    grid: GridSection = Field(default_factory=GridSection)
    walls: WallsSection = Field(default_factory=WallsSection)
    gravity: GravitySection = Field(default_factory=GravitySection)
    time: TimeSection = Field(default_factory=TimeSection)
    numerics: NumericsSection = Field(default_factory=NumericsSection)
    gas: GasSection = Field(default_factory=GasSection)
    inflow: InflowSection = Field(default_factory=InflowSection)
    topography: TopographySection = Field(default_factory=TopographySection)
    output: OutputSection = Field(default_factory=OutputSection)
    setup: Section = Field(default_factory=EmptySetup)

    _source_text: str = PrivateAttr(default="")
    _source_path: str = PrivateAttr(default="")
    _overrides: tuple[str, ...] = PrivateAttr(default=())
    _closure: Any = PrivateAttr(default=None)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> CaseConfig:
        """Validate a parsed case file; all problems are reported in one error.

        Raises
        ------
        GranflowInputError
            ``"<key.path>: <what was expected> (got <value>)"`` for each problem, ``"; "``-joined.
        """
        from granflow.config.validation import validate  # deferred: validation builds on this module

        return validate(dict(data))

    # --- derived objects ------------------------------------------------------------------------
    def make_closure(self):
        """The closure of ``[closure]``, ``[material]`` and ``[equilibrium]`` (built once)."""
        if self._closure is None:
            from granflow.rheology import make_closure

            self._closure = make_closure(self.closure.name, material=self.material.model_dump(),
                                         equilibrium=self.equilibrium.law,
                                         equilibrium_params=self.equilibrium.parameters(),
                                         **self.closure.parameters())
        return self._closure

    def make_topography(self):
        """The :class:`granflow.topography.Topography` of ``[topography]``, or None (flat base)."""
        if not self.topography.x:
            return None
        from granflow.topography import Topography

        return Topography(x=self.topography.x, z=self.topography.z)

    @property
    def gravity_vector(self) -> tuple[float, float]:
        """``(g_x, g_z)`` [m s^-2]."""
        th = math.radians(self.gravity.slope_deg)
        return (self.gravity.g * math.sin(th), -self.gravity.g * math.cos(th))

    @property
    def source_text(self) -> str:
        """Text of the case file as read (empty when built from a dict)."""
        return self._source_text

    @property
    def source_path(self) -> str:
        return self._source_path

    @property
    def overrides(self) -> tuple[str, ...]:
        """The ``--set`` items applied on top of the file."""
        return self._overrides

    def to_toml(self) -> str:
        """The effective configuration (defaults filled in) as TOML text."""
        return dumps_toml(self.model_dump(mode="json", exclude_none=True))
