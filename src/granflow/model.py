"""The model: one semi-implicit time step of paper eqs syst1b-syst4b on the MAC grid, for any
closure of the registry (NUMERICS.md §0, §3.1 "v1"); dry (``gas=None``, p_f = 0, eq. syst2b
absent) or fluidised (``gas`` a :class:`~granflow.physics.pore_pressure.GasLaw`).

Step n -> n+1 (:meth:`Model.advance`):

1. explicit parts (:mod:`granflow.physics.momentum`): momentum transport -- the v1 schemes
   ``"upwind"``/``"muscl"`` advect ``(u . grad) u`` with the inertia
   ``rho_f = max(phi_f rho_s, rho_a)`` at t^n; ``advection = "consistent"`` (scheme v2, the default) is
   conservative, with the mass fluxes of a phi transport with the Picard iterate and the inertia
   ``m = rho_s phi_f + rho_a`` after it (:mod:`granflow.physics.momentum_transport`,
   :meth:`Model.inertia_density`; recomputed in each sweep of step 2) --, gravity
   ``phi_f rho_s g`` on the grains only. With ``consistent_gravity`` (default) the gravity
   ``phi_f`` is the face fraction of the mass flux of a transport step with ``u^n``
   (:func:`granflow.physics.transport.flux_face_fraction`), so that the gravity work matches the
   potential-energy change of the transport (the centred ``phi_f`` of the prototype creates
   energy at the smeared free surface and feeds a never-ending surface film); on slow faces the
   blend of that weight is a drag, treated implicitly (:meth:`Model.gravity_split`);
2. Picard loop (at most ``picard.max_sweeps`` sweeps) on the monolithic (u, p) saddle-point
   system -- (u, p, p_f) when fluidised: the gas rows of :mod:`granflow.physics.coupling` on the
   dense cells (free or active; ``p_f = 0`` in the ambient) border it, and the momentum rows get
   ``-Grad p_f`` (NUMERICS.md §3.1, §3.3) -- with coefficients lagged at the iterate (u_k, p_k)
   (the gas block depends on t^n fields only); the closure is evaluated at
   ``I_e = I(sqrt(|S_k|^2 + eps^2), p_e)``, ``p_e = sqrt(max(p_k, 0)^2 + delta_p^2)`` (finite, > 0):

   * yield viscosity ``eta = max(Z, 0) p_k / (2 sqrt(|S_k|^2 + eps^2)) + eta_visc/2 + eta_b``
     at cells (``eta_visc S`` is the closure's viscous stress), arithmetic mean to nodes
     (regularisation ``eps``, NUMERICS.md §4; ``eta_b`` the dense background viscosity,
     :attr:`Model.background_viscosity`); ambient cells get ``eta_a``; cells with ``Z < 0``
     are counted in the report;
   * dilatancy row on dense, active cells ``Div u + C p = b``: the stiff-safe law
     ``div u = fac (2|S| A(phi, I) - G(phi) sqrt(p))`` (``Closure.A``,
     ``Closure.compaction_coefficient``) with the AP factor ``fac`` of
     :func:`granflow.physics.dilatancy.ap_factor`, linearised in p as
     ``G sqrt(p) ~ G (p + p_k) / (2 sqrt(p_e))`` in a step's first sweep (the tangent about
     ``p_k``; the secant ``G p / sqrt(p_e)`` of NUMERICS.md §5.1 there grew a period-2 mode of
     the fluidised chute for dt >= 0.045 s, docs/solver.md "One solve per step"), the secant in
     the later sweeps (their loop converges in more steps), and
     ``2|S| A(I(p)) ~ 2|S| A(I_e) - |S| I_e dA/dI (p - p_e)/p_e`` (Newton on the I-dependence,
     clipped to keep ``C >= 0``); ``fac = 0`` (infinitely stiff) gives ``div u = 0``;
   * with ``isochoric_interface = r > 0`` (default 1) the dense cells within ``r`` cells of the
     ambient get ``b = C = 0`` (isochoric, or free): partial cells at the free surface are not
     loose material (with the closure's law there, a sheared surface cell evaluated at phi_loc
     dilates at any pressure and a loose one compacts, and the pair drives a surface film that
     never stops, docs/solver.md "Free surface");
   * primal-dual active set for ``p >= 0`` (NUMERICS.md §5.4), every dense cell starting active:
     active cells with ``p < 0`` become free (``p = 0``, not an unknown), free cells with
     ``Div u < b`` are reactivated; converged when the relative velocity increment is below
     ``picard.tol`` and the active set did not change;
3. conservative MUSCL-minmod SSP-RK2 transport of phi with ``u^{n+1}``; bounds measured, then
   clipped, the clipped mass reported (:mod:`granflow.physics.transport`).

With the velocity band (:attr:`AmbientParams.velocity_band`, :meth:`Model.velocity_region`) the
velocity unknowns of step 2 are only the faces within that many cells of grains; the others are
``u^{n+1} = 0`` (docs/solver.md, "Velocity band").

A step FAILS (state untouched) on a non-finite closure value or solution, a Picard increment
above ``picard.fail_tol``, a CFL number of ``u^{n+1}`` above 1/2 (positivity limit) or phi
outside ``[-tol phi_max, (1 + tol) phi_max]`` before clipping.

Cells with ``phi < phi_c`` are a pressureless light ambient (``p = 0``, no constraint, ``eta_a``,
``rho_a``; NUMERICS.md §7). Dense cells within :data:`INTERFACE_RADIUS` cells of the ambient
evaluate the closure at the local packing ``phi_loc`` = max of phi over the ``(2r+1)^2``
neighbourhood (the partial-cell compaction pump fix of NUMERICS.md §7.1). The closure is always
evaluated at phi clipped to ``[PHI_FLOOR, phi_max]``. Nothing here is closure-specific.

Periodic in x (``grid.periodic_x``, :mod:`granflow.grid`): the operators, the transport, the
momentum advection, the gas block and the phi_loc neighbourhood all wrap in x; with a tilted
gravity this is an infinite incline (steady uniform flows exist, issue 3 item 9c). The step
reports the solid volume carried through the periodic face (:attr:`StepReport.wrapped_mass`).

An outflow east wall (``bcs.east = "outflow"``) empties the last column after the transport
(:mod:`granflow.physics.outflow`); the step reports what left (:attr:`StepReport.outflow`).

The dry model keeps ``state.p_f`` untouched (zero). The fluidised model stores ``p_f^{n+1}``
(zero in the ambient of t^n) and reports the gas energy terms
(:class:`granflow.physics.coupling.GasPowers`) in :attr:`StepReport.gas`.
"""
from __future__ import annotations

import time

import numpy as np

from granflow.errors import GranflowInputError
from granflow.grid import Grid, VelocityBC, VelocityBCs
from granflow import step
from granflow.model_options import (  # re-exported: the Model's options and step report
    AUTO_AMG_UNKNOWNS,
    AUTO_BANDED_DIRECT_UNKNOWNS,
    DEFAULT_DELTA_P,
    DEFAULT_EPS,
    DEFAULT_GRAVITY,
    DEFAULT_ISOCHORIC_INTERFACE,
    DEFAULT_PHI_TOLERANCE,
    INTERFACE_RADIUS,
    PHI_FLOOR,
    PHI_TRACE,
    VISCOUS_ADDITION_FACTOR,
    AmbientParams,
    BaseFriction,
    Coefficients,
    LinearSolverChoice,
    PicardParams,
    Predictor,
    StepReport,
    StepStatus,
    Surface,
)
from granflow.operators import Operators
from granflow.topography import Topography, masked_operators
from granflow.physics import momentum as mom
from granflow.physics import momentum_transport as mt
from granflow.physics import inflow, outflow
from granflow.physics.inflow import Source, SourceSide
from granflow.physics.coupling import GasCoupling
from granflow.model_coefficients import ClosureCoefficients
from granflow.model_fields import FieldMaps
from granflow.model_geometry import GeometryWeights
from granflow.model_gravity import GravityWeights
from granflow.physics.material import packing
from granflow.physics.pore_pressure import GasLaw
from granflow.physics.transport import PhiScheme
from granflow.rheology.base import Closure
from granflow.solvers import pardiso_available
from granflow.state import State


def _option(enum_type, value, what: str):
    """``enum_type(value)``, or a GranflowInputError naming ``what`` and the accepted values."""
    try:
        return enum_type(value)
    except ValueError:
        raise GranflowInputError(f"Model: unknown {what} {value!r}; expected one of "
                                 f"{[e.value for e in enum_type]}") from None


def _isochoric_interface(value) -> int:
    """The ``isochoric_interface`` option, checked: an integer in [0, INTERFACE_RADIUS] [cells]."""
    if (isinstance(value, bool) or not isinstance(value, (int, np.integer))
            or not 0 <= value <= INTERFACE_RADIUS):
        raise GranflowInputError(f"Model: isochoric_interface must be an integer in [0, {INTERFACE_RADIUS}] "
                                 f"(cells), got {value!r}")
    return int(value)


def _wall_friction(bcs: VelocityBCs, mu_w) -> float | None:
    """The base's Coulomb coefficient mu_w [-] (:mod:`granflow.physics.wall_friction`), checked
    against the base condition: a ``"coulomb"`` base needs one (finite, > 0), the others take none."""
    coulomb = bcs.bottom is VelocityBC.COULOMB
    if mu_w is None:
        if coulomb:
            raise GranflowInputError("Model: a 'coulomb' base needs wall_friction = mu_w > 0 "
                                     "(walls.base_friction_deg)")
        return None
    if not coulomb:
        raise GranflowInputError(f"Model: wall_friction = {mu_w!r} needs the 'coulomb' base (walls.bottom), "
                                 f"got {bcs.bottom.value!r}")
    if isinstance(mu_w, bool) or not isinstance(mu_w, (int, float, np.floating)) or not (np.isfinite(mu_w) and mu_w > 0):
        raise GranflowInputError(f"Model: wall_friction must be a finite number > 0, got {mu_w!r}")
    return float(mu_w)


class Model(ClosureCoefficients, GravityWeights, GeometryWeights, FieldMaps):
    """Grid + closure + gravity + wall conditions + numerical parameters; :meth:`advance`.

    Parameters
    ----------
    grid : Grid
    closure : Closure
        Any registered closure (:func:`granflow.rheology.make_closure`); its ``material`` gives
        rho_s, phi_max, d and the inertial-number convention c_I.
    gravity : (float, float)
        ``(g_x, g_z)`` [m s^-2]. Default (0, -9.81); tilt it to model a slope. On a grid periodic
        in x, ``g = g (sin theta, -cos theta)`` is an infinite incline of angle theta.
    bcs : VelocityBCs, optional
        Wall conditions (default no-slip base, free-slip sides and top).
    eps : float
        Regularisation strain rate [s^-1]. Default :data:`DEFAULT_EPS` = 5e-3.
    ambient : AmbientParams or dict, optional
    picard : PicardParams or dict, optional
    delta_p : float
        Pressure floor [Pa] of the closure's inertial number and of the sqrt(p) linearisation:
        ``p_e = sqrt(p^2 + delta_p^2)``, ``delta_p`` at ``p = 0`` and ``p (1 + O(delta_p^2/p^2))``
        in the bulk. (Until 2026-12-03 ``p + delta_p``: a first-order bias of ``I`` by
        ``sqrt(1 + delta_p/p)``, +1.2 % on u_s of a 1 cm Bagnold layer at every resolution.)
        Default 1.
    interface_packing : bool
        Use phi_loc near the ambient (NUMERICS.md §7.1). Default True.
    phi_tolerance : float
        Relative overshoot of phi_max (before clipping) that fails the step (also
        ``phi < -phi_tolerance phi_max``). Default 0.05.
    consistent_gravity : bool
        Weigh the gravity force with the face fraction of the mass flux (energy-consistent
        gravity; with the indicator surface the flux of the material transport) instead of the
        centred mean (at rest: :meth:`face_fraction`). Default True.
    gravity_blend_velocity : float, optional
        Faces slower than this keep (a blend towards) the centred weight [m s^-1]; default
        ``eps * Lz``, the creep velocity scale (threshold surface), or ``|g| dt``
        (indicator surface, :meth:`blend_velocity`). The blend is implicit where it damps
        (:meth:`gravity_split`).
    advection : Advection or str
        Momentum transport: the v1 non-conservative ``(u . grad) u`` schemes ``"upwind"``
        and ``"muscl"``, or ``"consistent"`` (default, scheme v2: conservative, with the mass
        fluxes of the phi transport, :mod:`granflow.physics.momentum_transport`).
    momentum_theta : float
        Slope limiter of the consistent momentum transport's face values, 1 (minmod) to 2
        (monotonized central, default) [-].
    base_friction : BaseFriction or str, optional
        Pressure of the friction on a no-slip base: ``"wall"`` (the bottom cells' viscosity at the
        pressure extrapolated to the wall) or ``"centre"`` (at their centre pressure). Default
        (None): ``"wall"`` with the indicator surface, ``"centre"`` with the threshold one.
    surface : Surface or str
        ``"threshold"`` (v1: ``phi < ambient.phi_c`` is ambient) or ``"indicator"``
        (default, scheme v2: a transported material fraction ``c``, :mod:`granflow.physics.material`; the
        state carries ``c``, every material cell is dense and the closure is evaluated at the
        packing ``phi / c``, never looser than ``ambient.phi_c`` (the material volume is bounded
        by ``phi / phi_c``); the weight of a z-face is the reconstructed material of its dual
        cell (:meth:`face_fraction`), so ``p = 0`` sits at the surface; ``interface_packing``,
        ``isochoric_interface`` and ``phi_transport`` are then not used).
    phi_transport : PhiScheme or str
        Face values of the phi transport: ``"muscl"`` (default, v1: MUSCL-minmod) or ``"sharp"``
        (MUSCL-THINC-BVD: the free surface stays within 1-2 cells,
        :mod:`granflow.physics.interface_capturing`).
    gas : GasLaw or str, optional
        Pore-gas law (paper eq. syst2b ``"linear"`` or eq. pressure-diffusion-nonlinear
        ``"nonlinear"``); None or ``"none"`` (default None) is the dry model.
    U_inj : float or array_like (nx,)
        Superficial gas velocity [m s^-1] injected through the porous base (Neumann
        ``-kappa dp_f/dz = U_inj``); default 0 (impermeable base). Needs ``gas``.
    open_top : bool
        ``p_f = 0`` on the top wall face (the velocity top stays closed). Default False
        (impermeable top; the ambient cells carry ``p_f = 0`` in any case). Needs ``gas``.
    gas_compressibility : str
        ``"isothermal"`` (default, paper eq. syst2b) or ``"adiabatic"`` (:class:`granflow.gas.GasCompressibility`).
    isochoric_interface : int
        Dense cells within this many cells of the ambient (default 1; 0 = off, the v1 scheme; at
        most :data:`INTERFACE_RADIUS`) drop the closure's dilatancy row: ``div u = 0`` while ``p > 0``,
        free (``p = 0``) otherwise -- partial cells at the free surface are then not taken for
        loose material that dilates under shear or compacts (docs/solver.md, "Free surface").
        The yield stress there is unchanged.
    linear_solver : LinearSolverChoice or str
        ``"direct"`` (default; SciPy's sparse LU), ``"pardiso"`` (MKL sparse LU, optional extra
        ``granflow[fast]``), ``"amg"`` (FGMRES + block AMG, ~O(N)) or ``"auto"`` (``pardiso`` if
        installed, else ``direct`` with the velocity band on (its systems are small) below
        :data:`AUTO_BANDED_DIRECT_UNKNOWNS` whole-grid unknowns, else ``amg`` from
        :data:`AUTO_AMG_UNKNOWNS` unknowns up and ``direct`` below).
        The chosen one is :attr:`linear_solver_name`.
    wall_friction : float, optional
        Coulomb friction coefficient of the base ``mu_w = tan(delta_w)`` [-] (``walls.base_friction_deg``):
        needed by, and only allowed with, a ``"coulomb"`` base (``bcs.bottom``); the base shear
        stress is then ``min(interior, mu_w p_wall)`` (:mod:`granflow.physics.wall_friction`).
    source : granflow.physics.inflow.Source, optional
        A supply of grains through part of the west wall or of the base (``[inflow]``,
        :mod:`granflow.physics.inflow`). Default none.
    topography : granflow.topography.Topography, optional
        A base profile ``z_b(x)``: the cells below it are solid (:mod:`granflow.topography`; the
        base condition ``bcs.bottom`` applies along it). Default none (the flat base of the box).
        So far with the indicator surface, the consistent momentum transport, the direct or
        PARDISO solver; ``U_inj`` enters through the lowest fluid cell of each column (the
        treads), a Coulomb base caps the treads' friction (its risers are free-slip), and a base
        source sits on the lowest fluid cells.
    """

    def __init__(self, grid: Grid, closure: Closure, gravity=DEFAULT_GRAVITY,
                 bcs: VelocityBCs | None = None, eps: float = DEFAULT_EPS,
                 ambient: AmbientParams | dict | None = None,
                 picard: PicardParams | dict | None = None, delta_p: float = DEFAULT_DELTA_P,
                 interface_packing: bool = True,
                 phi_tolerance: float = DEFAULT_PHI_TOLERANCE, consistent_gravity: bool = True,
                 gravity_blend_velocity: float | None = None,
                 advection: mom.Advection | str = mom.Advection.CONSISTENT,
                 gas: GasLaw | str | None = None, U_inj=0.0, open_top: bool = False,
                 linear_solver: LinearSolverChoice | str = LinearSolverChoice.DIRECT,
                 isochoric_interface: int = DEFAULT_ISOCHORIC_INTERFACE, phi_transport: PhiScheme | str = PhiScheme.MUSCL,
                 surface: Surface | str = Surface.INDICATOR,
                 base_friction: BaseFriction | str | None = None,
                 momentum_theta: float = mt.MC_THETA, gas_compressibility: str = "isothermal",
                 wall_friction: float | None = None, source: Source | None = None,
                 topography: Topography | None = None) -> None:
        if not isinstance(grid, Grid):
            raise GranflowInputError(f"Model: grid must be a Grid, got {type(grid).__name__}")
        if not isinstance(closure, Closure):
            raise GranflowInputError(f"Model: closure must be a Closure, got {type(closure).__name__}")
        g = np.asarray(gravity, dtype=float)
        if g.shape != (2,) or not np.all(np.isfinite(g)):
            raise GranflowInputError(f"Model: gravity must be two finite numbers (g_x, g_z), got {gravity!r}")
        for name, value in (("eps", eps), ("delta_p", delta_p), ("phi_tolerance", phi_tolerance)):
            if not (np.isfinite(value) and value > 0):
                raise GranflowInputError(f"Model: {name} must be > 0, got {value!r}")
        self.grid = grid
        self.closure = closure
        self.material = closure.material
        self.gravity = (float(g[0]), float(g[1]))
        self.ops = self._operators(grid, bcs, topography)
        self.wall_friction = _wall_friction(self.ops.bcs, wall_friction)
        self.outflow = self.ops.bcs.east is VelocityBC.OUTFLOW  # (granflow.physics.outflow)
        self.assembler = mom.SaddleAssembler(self.assembly_operators())
        self.eps = float(eps)
        self.ambient = ambient if isinstance(ambient, AmbientParams) else AmbientParams(**(ambient or {}))
        self.picard = picard if isinstance(picard, PicardParams) else PicardParams(**(picard or {}))
        if not self.ambient.phi_c < self.material.phi_max:
            raise GranflowInputError(
                f"Model: ambient.phi_c = {self.ambient.phi_c} must be below phi_max = {self.material.phi_max}")
        self.delta_p = float(delta_p)
        self.interface_packing = bool(interface_packing)
        self.isochoric_interface = _isochoric_interface(isochoric_interface)
        self.phi_tolerance = float(phi_tolerance)
        self.consistent_gravity = bool(consistent_gravity)
        if not mt.MINMOD_THETA <= momentum_theta <= mt.MC_THETA:
            raise GranflowInputError(f"Model: momentum_theta must be in [{mt.MINMOD_THETA}, {mt.MC_THETA}], "
                                     f"got {momentum_theta!r}")
        self.momentum_theta = float(momentum_theta)
        self.advection = _option(mom.Advection, advection, "advection scheme")
        self.phi_transport = _option(PhiScheme, phi_transport, "phi_transport")
        self.surface = _option(Surface, surface, "surface")
        if self.surface is Surface.INDICATOR:  # the reconstructed surface replaces these
            self.isochoric_interface, self.interface_packing = 0, False  # not consistent_gravity
        self.base_friction = (_option(BaseFriction, base_friction, "base_friction") if base_friction is not None
                              else BaseFriction.WALL if self.surface is Surface.INDICATOR
                              else BaseFriction.CENTRE)
        self._blend_set = gravity_blend_velocity is not None
        self.gravity_blend_velocity = (self.eps * grid.Lz if gravity_blend_velocity is None
                                       else float(gravity_blend_velocity))
        if not self.gravity_blend_velocity > 0:
            raise GranflowInputError("Model: gravity_blend_velocity must be > 0")
        choice = self._linear_solver_choice(_option(LinearSolverChoice, linear_solver, "linear_solver"))
        self.linear_solver_name = choice.value
        self._stable_pattern = choice is LinearSolverChoice.PARDISO
        """Pressure unknowns = every dense cell (free ones pinned to 0), so that the matrix
        pattern does not change with the active set and PARDISO keeps its analysis."""
        self.velocity_band = (None if choice is LinearSolverChoice.AMG or not self.ambient.velocity_band
                              else self.ambient.velocity_band)
        """The velocity band in use [cells] (:attr:`AmbientParams.velocity_band`; None: off, or the AMG)."""
        self._face_cells = abs(self.ops.cell_to_face).tocsr()
        self.linear_solver = self._make_linear_solver(choice)
        self.gas_coupling = self._gas_coupling(gas, open_top, U_inj, gas_compressibility)
        self.gas = None if self.gas_coupling is None else self.gas_coupling.gas
        self.source = self._source(source)
        if self.solid is not None:
            self._check_topography(choice)
        self._check_geometry(choice is LinearSolverChoice.AMG)

    def _operators(self, grid: Grid, bcs: VelocityBCs | None, topography: Topography | None) -> Operators:
        """The operators of the box, or of its fluid cells above ``topography``
        (:mod:`granflow.topography`); sets :attr:`topography`, :attr:`solid` and :attr:`base_index`."""
        if topography is not None and not isinstance(topography, Topography):
            raise GranflowInputError(f"Model: topography must be a granflow.topography.Topography, got {topography!r}")
        self.topography = topography
        self.solid = None if topography is None else topography.solid_cells(grid)
        """bool (nx, nz): the solid cells of the topography (None: the flat base)."""
        self.base_index = (np.zeros(grid.nx, dtype=np.int64) if self.solid is None
                           else self.solid.sum(axis=1).astype(np.int64))
        """int (nx,): the lowest fluid cell of each column (0 on the flat base)."""
        ops = Operators.build(grid, bcs)
        return ops if self.solid is None else masked_operators(ops, self.solid)

    def _check_topography(self, choice: LinearSolverChoice) -> None:
        """What a topography does not support yet (issue 14 item 3), named."""
        unsupported = [(not self.indicator, f"surface = {self.surface.value!r} (needs 'indicator')"),
                       (self.advection is not mom.Advection.CONSISTENT,
                        f"advection = {self.advection.value!r} (needs 'consistent')"),
                       (choice is LinearSolverChoice.AMG, "linear_solver = 'amg' (use 'direct' or 'pardiso')")]
        bad = [what for flag, what in unsupported if flag]
        if bad:
            raise GranflowInputError(f"Model: a topography does not support {'; '.join(bad)} yet")

    def _source(self, source: Source | None) -> Source | None:
        if source is None:
            return None
        if not isinstance(source, Source):
            raise GranflowInputError(f"Model: source must be a granflow.physics.inflow.Source, got {source!r}")
        if not 0.0 < source.phi <= self.material.phi_max:
            raise GranflowInputError(f"inflow.phi = {source.phi} must be in (0, phi_max = {self.material.phi_max}]")
        if source.side is SourceSide.WEST and self.grid.periodic_x:
            raise GranflowInputError("inflow.side = 'west': the grid is periodic in x (grid.periodic_x), it has "
                                     "no west wall; use a base source")
        if self.outflow and source.side is SourceSide.BOTTOM and source.cells(self.grid, self.base_index)[-1].any():
            raise GranflowInputError(f"inflow.upper = {source.upper:g}: a base source may not reach the last "
                                     f"column, the outflow's (keep the cell centres below x = "
                                     f"{self.grid.xc[-1]:g}, i.e. upper < {self.grid.xc[-1]:g})")
        source.cells(self.grid, self.base_index)  # a span that holds no cell is an error now, not at the first step
        return source

    def _gas_coupling(self, gas, open_top: bool, U_inj, gas_compressibility) -> GasCoupling | None:
        """The pore-gas coupling of ``gas`` (None without a gas law, which allows neither an
        injection nor an open top)."""
        if gas is None or gas == GasLaw.NONE:
            if open_top or np.any(np.asarray(U_inj, dtype=float) != 0.0):
                raise GranflowInputError("Model: U_inj and open_top need a gas law (gas=...)")
            return None
        return GasCoupling(self.grid, self.ops, self.material, gas, open_top, U_inj, gas_compressibility)

    def _linear_solver_choice(self, choice: LinearSolverChoice) -> LinearSolverChoice:
        """The solver of ``numerics.linear_solver = choice``: "direct" is SciPy's sparse LU (the
        reference, fastest below ~1e4 unknowns), "amg" FGMRES with the block AMG preconditioner of
        :mod:`granflow.solvers.saddle` (pays above ~2e4 unknowns), "pardiso" MKL PARDISO; "auto"
        takes PARDISO when installed, else the direct solver for the small banded systems or below
        :data:`AUTO_AMG_UNKNOWNS` (or with a topography or an axisymmetric grid), else the AMG."""
        if choice is LinearSolverChoice.AUTO:
            size = self.grid.n_unknowns + self.grid.n_cells
            choice = (LinearSolverChoice.PARDISO if pardiso_available()
                      else LinearSolverChoice.DIRECT if self.ambient.velocity_band and size < AUTO_BANDED_DIRECT_UNKNOWNS
                      else LinearSolverChoice.AMG if size >= AUTO_AMG_UNKNOWNS and self.solid is None
                      and not self.grid.axisymmetric  # (the AMG takes neither)
                      else LinearSolverChoice.DIRECT)
        if choice is LinearSolverChoice.PARDISO and not pardiso_available():
            raise GranflowInputError("linear_solver 'pardiso' (numerics.linear_solver) needs the optional "
                                     "dependency pypardiso with Intel MKL: pip install 'granflow[fast]' "
                                     "(x86-64 only); or use 'auto' or 'direct'")
        return choice

    # --- one step -----------------------------------------------------------------------------
    def advance(self, state: State, dt: float) -> StepReport:
        """Advance ``state`` in place by ``dt`` [s]; on FAILED the state is left unchanged (but for
        ``state.c``: a state without it gets :meth:`material_of` its ``phi`` first).

        The stages (:mod:`granflow.step`): explicit t^n terms, the implicit Picard solve, the
        energy terms, the phi transport; then the gas powers and the state update.

        Returns
        -------
        StepReport
        """
        if not (np.isfinite(dt) and dt > 0):
            raise GranflowInputError(f"Model.advance: dt must be > 0, got {dt!r}")
        if self.indicator and state.c is None:  # a State built without c: c from phi, once
            state.c = self.material_of(state.phi)
        tim = {"assembly": 0.0, "solve": 0.0, "transport": 0.0}
        sweeps = 0
        kept = (state.phi, state.c, state.p_f)
        put_in = self._refill(state)
        try:
            ex = step.explicit_stage(self, state, dt, tim)
            im = step.implicit_stage(self, state, dt, ex, tim)
            sweeps = im.sweeps
            powers = step.energy_terms(self, state, dt, ex, im)
            tr = step.transport_stage(self, state, dt, im.u, tim, sweeps, im.dilation)
        except step.StepFailed as failure:
            state.phi, state.c, state.p_f = kept  # (the refill too: it is booked with the step)
            return self._failed(dt, failure.message, failure.sweeps or sweeps, tim, failure.cfl)
        gas_powers = None
        if ex.gas_sys is not None:
            t0 = time.perf_counter()
            phi_gas = tr.phi if tr.c is None else packing(tr.c, tr.phi)  # the gas's packing
            gas_powers = self.gas_coupling.powers(ex.gas_sys, im.p_f, im.u, phi_gas, im.residual_gas)
            tim["assembly"] += time.perf_counter() - t0
            state.p_f = im.p_f.reshape(self.grid.cell_shape)
        out = self._absorb(state, tr, im.u, im.p_f if ex.gas_sys is not None else None)
        state.phi = tr.phi
        if tr.c is not None:
            state.c = tr.c
        if self.picard.predictor == Predictor.EXTRAPOLATED:  # its a^n, and a^(n-1) for its limiter
            state.accel_prev, state.accel, state.accel_dt = state.accel, (im.u - state.vel) / dt, dt
        state.vel = im.u
        state.p = im.p.reshape(self.grid.cell_shape)
        if self.picard.max_sweeps == 1:  # one solve per step carries its interior (active_set)
            state.free = im.free.reshape(self.grid.cell_shape)
        state.t += dt
        state.step += 1
        b = tr.bounds
        return StepReport(
            status=StepStatus.OK if im.converged else StepStatus.NOT_CONVERGED, dt=dt,
            picard_iterations=im.sweeps, picard_increment=im.rel, active_set_changes=im.changes,
            n_dense=int(np.count_nonzero(ex.dense)), n_free=int(np.count_nonzero(im.free)),
            n_negative_Z=im.n_negative_Z, cfl=tr.cfl, clipped_mass=b.clipped_mass,
            added_mass=b.added_mass, max_phi_before_clip=b.max_before, min_phi_before_clip=b.min_before,
            timings=tim, gas=gas_powers, wrapped_mass=tr.wrapped, linear_iterations=im.krylov,
            limited_mass=tr.held_back, solve_density=im.rho_k,
            outflow=out, inflow=put_in, **powers)

    def _absorb(self, state: State, tr, u, p_f):
        """An outflow east wall empties its column after the transport (in ``tr``, and
        ``state.p_f`` if ``p_f`` is given); returns what left (:mod:`granflow.physics.outflow`)."""
        if not self.outflow:
            return outflow.NOTHING
        tr.phi, tr.c, pf_new, out = outflow.absorb(self, tr.phi, tr.c, u, p_f)
        if p_f is not None:
            state.p_f = pf_new.reshape(self.grid.cell_shape)
        return out

    def _refill(self, state: State):
        """A source that is on refills its cells at the start of the step (in ``state``, new
        arrays); returns what that put in (:mod:`granflow.physics.inflow`)."""
        if self.source is None or not self.source.active(state.t):
            return outflow.NOTHING
        p_f = state.p_f if self.gas_coupling is not None else None
        after = inflow.refill(self.source, self.grid, state.phi, state.c, p_f, self.base_index)
        put_in = outflow.exchange(self, (state.phi, state.c, p_f), after, state.vel).negated()
        state.phi, state.c = after[0], after[1]
        if p_f is not None:
            state.p_f = after[2]
        return put_in

    @staticmethod
    def _failed(dt: float, message: str, sweeps: int, timings: dict, cfl: float = float("nan")) -> StepReport:
        return StepReport(status=StepStatus.FAILED, dt=dt, message=message,
                          picard_iterations=sweeps, timings=timings, cfl=cfl)

