"""Diagnostics of a run: mass, energies, dissipation, front position and the energy budget
(NUMERICS.md §9, §10; paper Theorem th1, MODEL.md §5). All integrals are per unit width.

Discrete quantities (dV = dx dz):

* mass ``M = sum_c phi dV`` [m^2];
* kinetic energy ``E_k = 1/2 sum_f rho_f u_f^2 dV`` [J m^-1] with the model's face inertia
  ``rho_f = max(phi_f rho_s, rho_a)`` (so that the backward-Euler identity below is exact);
* potential energy ``E_p = -sum_c phi rho_s (g . x_c) dV`` [J m^-1];
* dissipation rates [W m^-1]: yield/viscous ``D_y = dV u^T V(eta) u`` and dilatancy work
  ``D_d = -dV sum_c p (Div u)_c``; with ``Div = -Grad^T`` their sum is the power of the stresses,
  and in the continuum ``D_y + D_d = int 2 (Z - f) p |S|`` (paper eq. dissipation-general-exp).

Energy budget (:class:`EnergyBudget`): ``err(t) = E_k + E_p - (E_k + E_p)(0) + int_0^t (D_y + D_d) dt``,
reported relative to the released potential energy ``E_p(0) - E_p(t)``. Dotting the discrete
momentum equation with ``u^{n+1} dV`` shows that ``err`` is exactly the sum of four numerical terms
(five with the linear solve's error, below),
which the budget also accumulates:

* ``-int BE dt``, BE = ``sum rho_f |u^{n+1} - u^n|^2 dV / (2 dt)`` (backward Euler, <= 0 contribution);
* ``-int P_adv dt``, ``P_adv = dV sum rho_f a^n . u^{n+1}`` (upwind momentum advection);
* ``sum 1/2 (rho_f^{n+1} - rho_f^n) |u^{n+1}|^2 dV`` (inertia carried by the phi transport);
* ``sum [E_p^{n+1} - E_p^n + dt dV f_g . u^{n+1}]`` (gravity/transport mismatch: centred phi_f in
  the gravity force versus MUSCL fluxes in the transport; includes the clipping).

The identity assumes the step's linear system solved exactly; the solve's error ``r = K x - b``
on the velocity rows adds ``sum dt dV r_u . u^{n+1}``, booked as a fifth term, ``linear_solve``
(~1e-9 of the released energy with a kept PARDISO analysis, round-off otherwise); on the gas rows
(scaled by ``-1/p_atm``) it adds ``-sum dt p_atm dV e'(p_f) . r_g``, ``gas_linear_solve``
(:attr:`granflow.model_options.StepReport.solve_power`, :class:`granflow.physics.coupling.GasPowers`).

Fluidised model (MODEL.md §5, paper Theorem th1): the budget adds the gas energy
``E_1 = sum (1 - phi) e(p_f) dV``, ``e(p) = (p_atm + p) ln(1 + p/p_atm) - p`` (LOG, paper eq. H(p)
+ p_atm; with the indicator surface ``phi`` is the material's packing ``phi/c``, that of the gas
rows, :func:`gas_energy_of`), the Darcy dissipation (pairing of :mod:`granflow.physics.coupling`: weighted for the
LINEAR law, unweighted for NONLINEAR) and the injected power, so that

    err = [E_k + E_p + E_1](t) - [E_k + E_p + E_1](0) + int (D_y + D_d + D_darcy - P_inj) dt.

The pressure work ``W_f = dV sum p_f Div u`` enters the mechanical budget (``+W_f`` from
``-Grad p_f``) and the gas budget (``-W_f`` from ``p_atm Div u``) with opposite signs:
``err = err_mech + err_gas + int (W_f^mom - W_f^gas) dt``, where ``err_mech`` is the sum of the five
terms above and ``err_gas`` the sum of the five gas terms of
:class:`granflow.physics.coupling.GasPowers` (backward Euler, cells turned ambient,
transport/compression, diffusion, linear solve); the last integral is round-off (``Grad = -Div^T``) and is kept
in :attr:`EnergyBudget.numerical` as ``pressure_work_mismatch`` so that the terms sum to ``err``.

Open boundaries (:mod:`granflow.physics.outflow`, :mod:`granflow.physics.inflow`): the kinetic,
potential and gas energy the grains carry out of the box, ``E_out``, what a source puts in,
``E_in``, and the work of the source's prescribed velocity ``W_src = int P_src dt`` are physical
terms, ``err = [...](t) - [...](0) + int (...) dt + E_out - E_in - W_src``; the four mechanical
terms are those of the step without the exchange (the inertia and gravity terms add back what the
outflow took after the step, the gravity term what the source's refill before the step added to
``E_p``; the refill's kinetic energy is in the step's t^n inertia), so they still sum to ``err``, and the released potential energy
leaves ``E_p,out`` and ``E_p,in`` out.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from granflow.grid import Grid
from granflow.physics.material import packing
from granflow.physics.pore_pressure import GasEnergy, gas_energy

HALF = 0.5


def mass(grid: Grid, phi) -> float:
    """Solid mass per unit width and per unit grain density, ``sum phi dV`` [m^2]; on an
    axisymmetric grid the solid volume of the cylinder, ``sum 2 pi r_c phi dr dz`` [m^3]."""
    if grid.axisymmetric:
        return float(np.sum(np.reshape(phi, grid.cell_shape) * grid.cell_volumes))
    return float(np.sum(phi) * grid.cell_volume)


def _on_faces(model, a):
    """``a`` at the velocity unknowns times the rings' circumference (axisymmetric), else ``a``."""
    weight = getattr(model, "unknown_weight", None)
    return a if weight is None else weight * a


def kinetic_energy(model, state) -> float:
    """``1/2 sum_f rho_f u_f^2 dV`` [J m^-1; J on an axisymmetric grid] with the model's face inertia."""
    rho_f = model.inertia_density(state.phi)
    return HALF * model.grid.cell_volume * float(_on_faces(model, rho_f) @ (state.vel * state.vel))


def potential_energy(model, state) -> float:
    """``-sum_c phi rho_s (g . x_c) dV`` [J m^-1] (zero at the origin of the grid's coordinates).

    On a grid periodic in x with ``g_x != 0`` this is the energy in the current periodic frame:
    it jumps by ``rho_s g_x Lx m`` when a volume ``m`` leaves through ``x0 + Lx`` and re-enters at
    ``x0``; :class:`EnergyBudget` removes those jumps."""
    gx, gz = model.gravity
    g = model.grid
    geo = gx * g.xc[:, None] + gz * g.zc[None, :]  # g . x_c, (nx, nz) by broadcasting (no meshgrid)
    if g.axisymmetric:  # (a radial gravity is refused: gx = 0)
        return -model.material.rho_s * float(np.sum(g.cell_volumes * state.phi * geo))
    return -model.material.rho_s * g.cell_volume * float(np.sum(state.phi * geo))


def gas_energy_of(model, state) -> float:
    """``E_1 = sum (1 - phi) e(p_f) dV`` [J m^-1] (LOG density, module docstring); 0 if dry.

    With the indicator surface the gas rows hold the gas at the material's packing
    ``psi = phi / c`` (capacity ``1 - psi``, :func:`granflow.step.explicit_stage`), so ``E_1`` is
    ``sum (1 - psi) e(p_f) dV`` -- the energy of the gas identity of
    :class:`granflow.physics.coupling.GasPowers` (``p_f = 0`` outside the cells with a row;
    ``c`` defaults to :meth:`Model.material_of` for a state without it). Divided by the gas's
    polytropic index n (:class:`granflow.gas.GasCompressibility`; 1 isothermal)."""
    if model.gas is None:
        return 0.0
    phi = state.phi
    if getattr(model, "indicator", False):
        c = state.c if state.c is not None else model.material_of(state.phi)
        phi = packing(c, state.phi)
    return gas_energy(model.grid, phi, state.p_f, model.material, GasEnergy.LOG,
                      polytropic=getattr(getattr(model, "gas_coupling", None), "polytropic", 1.0))


def basal_pressure(grid: Grid, field, x: float) -> float:
    """Value of a cell field (e.g. ``state.p_f`` [Pa]) in the bottom cell of the column containing
    ``x`` [m]."""
    i = int(np.clip(np.searchsorted(grid.xf, x, side="right") - 1, 0, grid.nx - 1))
    return float(np.asarray(field).reshape(grid.cell_shape)[i, 0])


def deposit_thickness(grid: Grid, phi, phi_max: float) -> np.ndarray:
    """``h(x) = sum_z phi dz / phi_max`` per column [m], shape (nx,)."""
    return np.sum(phi, axis=1) * grid.dz / phi_max


#: The front definition, used by the run (``x_front``, ``summary.json``), the ``ds.granflow``
#: accessor, the figures and the validation scripts (docs/cases.md, "Front position").
FRONT_DEFINITION = ("right edge of the furthest column whose deposit thickness "
                    "h = sum_z(phi dz)/phi_max exceeds the threshold")
FRONT_EDGE, FRONT_LINEAR = "edge", "linear"
FRONT_METHODS = (FRONT_EDGE, FRONT_LINEAR)


def front_from_thickness(x_edges, h, threshold: float, method: str = FRONT_EDGE):
    """The front x_f [m] of deposit thicknesses ``h`` [m] (the one definition, :data:`FRONT_DEFINITION`).

    Parameters
    ----------
    x_edges : array (nx + 1,)
        Increasing x of the column edges [m].
    h : array (..., nx)
        Deposit thickness per column (:func:`deposit_thickness`), any leading dimensions (time).
    threshold : float
        Thickness [m] a column must exceed.
    method : {"edge", "linear"}
        ``"edge"`` (the front): the right edge ``x_edges[i + 1]`` of the furthest column ``i``
        with ``h > threshold``. Its resolution is one column width: for a thickness decreasing
        with x the point where it falls through the threshold lies within ``dx`` of that edge
        (within ``dx/2`` when h is linear there), so fronts are quantised by ``dx``.
        ``"linear"``: a sub-cell estimate for comparing resolutions, the point between the
        centres of column ``i`` and ``i + 1`` where the linear interpolant of h equals the
        threshold (exact for a linear thickness); the right edge when ``i`` is the last column.

    Returns
    -------
    float or ndarray
        Shape ``h.shape[:-1]``; ``nan`` where no column exceeds the threshold.

    Examples
    --------
    >>> front_from_thickness([0.0, 0.1, 0.2, 0.3], [0.05, 0.03, 0.0], 0.02)
    0.2
    >>> round(front_from_thickness([0.0, 0.1, 0.2, 0.3], [0.05, 0.03, 0.0], 0.02, "linear"), 6)
    0.183333
    """
    if method not in FRONT_METHODS:
        raise ValueError(f"front method must be one of {FRONT_METHODS}, got {method!r}")
    edges = np.asarray(x_edges, dtype=float)
    hv = np.asarray(h, dtype=float)
    nx = hv.shape[-1]
    if edges.shape != (nx + 1,):
        raise ValueError(f"x_edges: shape {edges.shape}, expected ({nx + 1},) for {nx} columns")
    flat = hv.reshape(-1, nx)
    above = flat > threshold  # NaN compares False
    has = above.any(axis=1)
    last = nx - 1 - np.argmax(above[:, ::-1], axis=1)
    front = edges[last + 1].copy()
    if method == FRONT_LINEAR:
        centres = 0.5 * (edges[1:] + edges[:-1])
        rows = np.flatnonzero(has & (last < nx - 1))
        i = last[rows]
        h0, h1 = flat[rows, i], flat[rows, i + 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            interp = centres[i] + (h0 - threshold) / (h0 - h1) * (centres[i + 1] - centres[i])
        front[rows] = np.where(np.isfinite(interp), interp, front[rows])
    front[~has] = np.nan
    front = front.reshape(hv.shape[:-1])
    return float(front) if front.ndim == 0 else front


MIN_TOE_CELLS = 2
"""Fewest cells of a straight-line toe fit."""


def toe_front(x, h, window: tuple[float, float]) -> float:
    """The deposit-toe front [units of x]: where the straight line fitted (least squares) to the
    toe of ``h(x)`` reaches h = 0 -- the second front rule, of the validation studies
    (validation/lagree_column, dry_runout, fluidised_vs_dry; :func:`front_from_thickness` is the
    run's). The toe is the contiguous run of columns beyond the last one with ``h > window[1]``
    whose ``h >= window[0]`` (with that last column if the run has fewer than
    :data:`MIN_TOE_CELLS`); nan if h never exceeds ``window[1]`` or the fitted slope is not
    negative.

    Parameters
    ----------
    x : array (nx,)
        Column centres.
    h : array (nx,)
        Deposit thickness per column (same units as ``window``).
    window : (float, float)
        Thicknesses (low, high) bounding the toe.

    Examples
    --------
    >>> round(toe_front([0.5, 1.5, 2.5, 3.5], [0.3, 0.2, 0.1, 0.0], (0.05, 0.15)), 6)
    3.5
    """
    h = np.asarray(h, dtype=float)
    above = np.flatnonzero(h > window[1])
    if above.size == 0:
        return float("nan")
    sel = []
    for i in range(int(above[-1]) + 1, h.size):
        if h[i] < window[0]:
            break
        sel.append(i)
    if len(sel) < MIN_TOE_CELLS:
        sel = [int(above[-1]), *sel]
    if len(sel) < MIN_TOE_CELLS:
        return float("nan")
    slope, icpt = np.polyfit(np.asarray(x)[sel], h[sel], 1)
    return float(-icpt / slope) if slope < 0 else float("nan")


def mass_quantile_front(x_edges, h, q: float) -> float:
    """The x [units of x_edges] left of which a fraction ``q`` of the deposit lies -- the third
    front rule, for comparing codes whose distal sheet hovers about a thickness threshold
    (validation/basilisk_column): the smallest x with ``int_0^x h dx = q int h dx``, with ``h``
    uniform inside each column (so linear interpolation of the cumulative volume). Unlike
    :func:`front_from_thickness` it moves by the sheet's volume, not by whether its thickness
    crosses a threshold. nan if the deposit is empty.

    Parameters
    ----------
    x_edges : array (nx + 1,)
        Increasing column edges.
    h : array (nx,)
        Deposit thickness per column (:func:`deposit_thickness`), >= 0.
    q : float
        Fraction of the deposit volume, 0 < q <= 1.

    Examples
    --------
    >>> mass_quantile_front([0.0, 1.0, 2.0], [3.0, 1.0], 0.5)
    0.6666666666666666
    """
    if not 0.0 < q <= 1.0:
        raise ValueError(f"mass_quantile_front: q must be in (0, 1], got {q!r}")
    edges = np.asarray(x_edges, dtype=float)
    hv = np.asarray(h, dtype=float)
    if edges.shape != (hv.size + 1,):
        raise ValueError(f"x_edges: shape {edges.shape}, expected ({hv.size + 1},)")
    cum = np.concatenate([[0.0], np.cumsum(hv * np.diff(edges))])
    if not cum[-1] > 0.0:
        return float("nan")
    target = q * cum[-1]
    i = int(np.searchsorted(cum, target, side="left"))  # cum[i-1] < target <= cum[i]
    i = min(max(i, 1), hv.size)
    return float(edges[i - 1] + (target - cum[i - 1]) / (cum[i] - cum[i - 1]) * (edges[i] - edges[i - 1]))


def front_position(grid: Grid, phi, phi_max: float, threshold: float, method: str = FRONT_EDGE) -> float:
    """The front [m] of a state (:func:`front_from_thickness` of :func:`deposit_thickness`):
    the right edge of the furthest column where the deposit thickness > threshold [m]; ``nan``
    if no column qualifies or if the grid is periodic in x (a front has no meaning there)."""
    if grid.periodic_x:
        return float("nan")
    return front_from_thickness(grid.xf, deposit_thickness(grid, phi, phi_max), threshold, method)


@dataclass
class EnergyBudget:
    """Running energy budget of a run (see the module docstring).

    Create with :meth:`start`, then call :meth:`record` after every accepted step.
    """

    model: object
    e_k0: float
    e_p0: float
    """Initial potential energy [J m^-1]. Periodic in x: expressed in the current periodic frame,
    i.e. shifted by ``rho_s g_x Lx`` times the volume that crossed the periodic face (so that
    ``e_p - e_p0`` is the change of the unwrapped potential energy)."""
    e_k: float
    e_p: float
    rho_f: np.ndarray
    t: float = 0.0
    dissipated: float = 0.0
    """``int (D_y + D_d) dt`` [J m^-1]."""
    dissipated_yield: float = 0.0
    dissipated_dilatancy: float = 0.0
    numerical: dict = field(default_factory=lambda: dict(
        backward_euler=0.0, advection=0.0, inertia_transport=0.0, gravity_transport=0.0, linear_solve=0.0,
        gas_backward_euler=0.0, gas_ambient=0.0, gas_transport=0.0, gas_diffusion=0.0, gas_linear_solve=0.0,
        pressure_work_mismatch=0.0))
    """The numerical contributions to ``err`` [J m^-1] (five mechanical, five gas, and the
    pressure-work round-off; a linear solve's error is the fifth of each); they sum to
    :attr:`residual`."""
    e_10: float = 0.0
    e_1: float = 0.0
    """Gas energy at the start and now [J m^-1]."""
    dissipated_darcy: float = 0.0
    """``int D_darcy dt`` [J m^-1]."""
    injected: float = 0.0
    """``int P_inj dt`` [J m^-1]."""
    pressure_work_momentum: float = 0.0
    """``int W_f dt`` from the momentum rows, ``-dV u . Grad p_f`` [J m^-1]."""
    pressure_work_gas: float = 0.0
    """``int W_f dt`` from the gas rows, ``dV sum p_f Div u`` [J m^-1]."""
    outflow_mechanical: float = 0.0
    """Kinetic plus potential energy carried out through an outflow wall [J m^-1]
    (:mod:`granflow.physics.outflow`)."""
    outflow_potential: float = 0.0
    """Its potential part [J m^-1] (not released: :attr:`released` leaves it out)."""
    outflow_gas: float = 0.0
    """Gas energy carried out through an outflow wall [J m^-1]."""
    inflow_mechanical: float = 0.0
    """Kinetic plus potential energy a source put in with its grains [J m^-1]
    (:mod:`granflow.physics.inflow`)."""
    inflow_potential: float = 0.0
    """Its potential part [J m^-1] (not released: :attr:`released` leaves it out)."""
    inflow_gas: float = 0.0
    """Gas energy a source put in [J m^-1]."""
    source_work: float = 0.0
    """``int P_src dt``, the work of a source's prescribed velocity [J m^-1]."""

    @classmethod
    def start(cls, model, state) -> EnergyBudget:
        rho_f = model.inertia_density(state.phi)
        e_k, e_p = kinetic_energy(model, state), potential_energy(model, state)
        e_1 = gas_energy_of(model, state)
        return cls(model=model, e_k0=e_k, e_p0=e_p, e_k=e_k, e_p=e_p, rho_f=rho_f, t=state.t,
                   e_10=e_1, e_1=e_1)

    def record(self, report, state) -> None:
        """Account for one accepted step (``report`` from :meth:`Model.advance`)."""
        m, dt = self.model, report.dt
        dV = m.grid.cell_volume
        rho_new = m.inertia_density(state.phi)
        rho_used = getattr(report, "solve_density", None)
        rho_used = self.rho_f if rho_used is None else rho_used
        e_p = potential_energy(m, state)
        # periodic frame jump of E_p (docstring of potential_energy), removed from both terms
        jump = -m.material.rho_s * m.gravity[0] * m.grid.Lx * getattr(report, "wrapped_mass", 0.0)
        self.e_p0 -= jump
        self.numerical["backward_euler"] -= dt * report.inertia_dissipation
        self.numerical["advection"] -= dt * report.advection_power
        self.numerical["linear_solve"] += dt * getattr(report, "solve_power", 0.0)
        out, put_in = getattr(report, "outflow", None), getattr(report, "inflow", None)
        out_k, out_p, out_1 = (0.0, 0.0, 0.0) if out is None else (out.kinetic, out.potential, out.gas)
        in_k, in_p, in_1 = (0.0, 0.0, 0.0) if put_in is None else (put_in.kinetic, put_in.potential, put_in.gas)
        self.outflow_mechanical += out_k + out_p
        self.outflow_potential += out_p
        self.outflow_gas += out_1
        self.inflow_mechanical += in_k + in_p
        self.inflow_potential += in_p
        self.inflow_gas += in_1
        self.source_work += dt * getattr(report, "source_power", 0.0)
        # the exchange, added back to the step's terms: an outflow empties cells after the step
        # (E_k and E_p of the record lack it); a source refills before it, which the step's
        # t^n inertia already holds (backward Euler), so only its potential energy is added back
        out_p = out_p - in_p
        self.numerical["inertia_transport"] += (HALF * dV * float(_on_faces(m, rho_new - rho_used) @ (state.vel ** 2))
                                                + out_k)
        self.numerical["gravity_transport"] += e_p - self.e_p + jump + dt * report.gravity_power + out_p
        self.dissipated_yield += dt * report.dissipation_yield
        self.dissipated_dilatancy += dt * report.dissipation_dilatancy
        gas = getattr(report, "gas", None)
        if gas is not None:
            self.numerical["gas_backward_euler"] += dt * gas.backward_euler
            self.numerical["gas_ambient"] += dt * gas.ambient
            self.numerical["gas_transport"] += dt * gas.transport
            self.numerical["gas_diffusion"] += dt * gas.diffusion
            self.numerical["gas_linear_solve"] += dt * gas.linear_solve
            self.numerical["pressure_work_mismatch"] += dt * (gas.work_momentum - gas.work)
            self.dissipated_darcy += dt * gas.darcy
            self.injected += dt * gas.injection
            self.pressure_work_momentum += dt * gas.work_momentum
            self.pressure_work_gas += dt * gas.work
            self.e_1 = gas_energy_of(m, state)
        self.dissipated = self.dissipated_yield + self.dissipated_dilatancy + self.dissipated_darcy
        self.rho_f = rho_new
        self.e_p = e_p
        self.e_k = HALF * dV * float(_on_faces(m, rho_new) @ (state.vel ** 2))
        self.t = state.t

    @property
    def released(self) -> float:
        """Released potential energy ``E_p(0) - E_p(t) - E_p,out + E_p,in`` [J m^-1] (``E_p,out``
        the potential energy carried out through an outflow wall, ``E_p,in`` that a source put in;
        0 in a closed box)."""
        return self.e_p0 - self.e_p - self.outflow_potential + self.inflow_potential

    @property
    def released_gas(self) -> float:
        """Released gas energy ``E_1(0) - E_1(t)`` [J m^-1]."""
        return self.e_10 - self.e_1

    @property
    def residual(self) -> float:
        """``err = [E_k + E_p + E_1](t) - [E_k + E_p + E_1](0) + int (D - P_inj) dt`` [J m^-1]
        (< 0: numerical dissipation; ``E_1 = D_darcy = P_inj = 0`` for the dry model)."""
        return (self.e_k + self.e_p + self.e_1 - self.e_k0 - self.e_p0 - self.e_10
                + self.dissipated - self.injected + self.outflow_mechanical + self.outflow_gas
                - self.inflow_mechanical - self.inflow_gas - self.source_work)

    @property
    def residual_mechanical(self) -> float:
        """``E_k + E_p - (E_k + E_p)(0) + int (D_y + D_d - W_f^mom) dt`` [J m^-1]: the sum of the
        five mechanical numerical terms."""
        return (self.e_k + self.e_p - self.e_k0 - self.e_p0 + self.dissipated_yield
                + self.dissipated_dilatancy - self.pressure_work_momentum + self.outflow_mechanical
                - self.inflow_mechanical - self.source_work)

    @property
    def residual_gas(self) -> float:
        """``E_1 - E_1(0) + int (D_darcy + W_f^gas - P_inj) dt`` [J m^-1]: the sum of the five gas
        numerical terms."""
        return (self.e_1 - self.e_10 + self.dissipated_darcy + self.pressure_work_gas - self.injected
                + self.outflow_gas - self.inflow_gas)

    @property
    def relative_residual(self) -> float:
        """``err / (E_p(0) - E_p(t))`` [-] (nan while nothing is released)."""
        return self.residual / self.released if self.released > 0 else float("nan")
