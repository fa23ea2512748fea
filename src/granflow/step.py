"""The named stages of one time step of :class:`granflow.model.Model` (paper eqs syst1b-syst4b;
the scheme is described in the module docstring of :mod:`granflow.model`):

1. :func:`explicit_stage` -- t^n quantities: masks, inertia, gravity, the v1 momentum advection,
   the gas rows, the velocity band and the layout of the unknowns (:class:`SaddleLayout`);
2. :func:`implicit_stage` -- the Picard loop on the monolithic (u, p[, p_f]) saddle system,
   with the consistent momentum transport (:func:`consistent_inertia`) recomputed per sweep;
3. :func:`energy_terms` -- the step's powers for the energy budget
   (:class:`granflow.diagnostics.EnergyBudget`);
4. :func:`transport_stage` -- the phi transport with u^{n+1}, its bounds and CFL checks.

A stage that cannot go on raises :class:`StepFailed`; :meth:`Model.advance` turns it into a FAILED
report and leaves the state untouched. The stages read the model's attributes and know nothing
of cases, output or the CLI.
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from granflow.active_set import never_active, start_free
from granflow.errors import GranflowInputError
from granflow.grid import VelocityBC
from granflow.model_options import BaseFriction
from granflow.physics import inflow
from granflow.physics import momentum as mom
from granflow.physics import momentum_transport as mt
from granflow.physics import wall_friction as wf
from granflow.physics.material import C_ROW, material_window, packing
from granflow.physics.transport import POSITIVITY_CFL, cfl_number, clip_to_bounds
from granflow.predictor import first_iterate, sweep_cap
from granflow.region import band_edge, step_region  # noqa: F401  (re-exported)
from granflow.solvers import SaddleHints
from granflow.step_energy import energy_terms  # noqa: F401  (stage 3, re-exported)


class StepFailed(Exception):
    """A stage could not complete: ``message`` names the quantity, ``sweeps`` the Picard sweeps
    done, ``cfl`` the CFL number of ``u^{n+1}`` when that is what failed (else NaN)."""

    def __init__(self, message: str, sweeps: int = 0, cfl: float = float("nan")) -> None:
        super().__init__(message)
        self.message, self.sweeps, self.cfl = message, sweeps, cfl


@dataclass(frozen=True)
class SaddleLayout:
    """Where the unknowns of one saddle solve sit in its vector ``[u_kept, p_unknowns, p_f_wet]``.

    ``keep`` (mask of the velocity unknowns solved; None: all ``n_velocity`` of them, the others
    are u = 0, the velocity band) and ``pressure`` (mask (n_cells,) of the cells whose p is an
    unknown; the free cells among them are pinned to 0)."""

    n_velocity: int
    n_cells: int
    keep: np.ndarray | None
    pressure: np.ndarray

    @property
    def n_kept(self) -> int:
        return self.n_velocity if self.keep is None else int(np.count_nonzero(self.keep))

    @property
    def n_pressure(self) -> int:
        return int(np.count_nonzero(self.pressure))

    def kept(self, v: np.ndarray) -> np.ndarray:
        """The solved velocity entries of a full velocity vector ``v``."""
        return v if self.keep is None else v[self.keep]

    def velocity(self, sol: np.ndarray) -> np.ndarray:
        """Full velocity vector (zero beyond the band) from a solution."""
        if self.keep is None:
            return sol[:self.n_velocity].copy()
        u = np.zeros(self.n_velocity)
        u[self.keep] = sol[:self.n_kept]
        return u

    def pressure_of(self, sol: np.ndarray) -> np.ndarray:
        """p on every cell (zero where not an unknown) from a solution [Pa]."""
        p = np.zeros(self.n_cells)
        p[self.pressure] = sol[self.n_kept:self.n_kept + self.n_pressure]
        return p

    def gas(self, sol: np.ndarray) -> np.ndarray:
        """The gas entries (wet cells) of a solution."""
        return sol[self.n_kept + self.n_pressure:]

    def guess(self, u: np.ndarray, p: np.ndarray, size: int) -> np.ndarray:
        """Initial guess ``[u_kept, p_unknowns, 0...]`` of length ``size``."""
        head = [self.kept(u), p[self.pressure]]
        return np.concatenate(head + [np.zeros(size - self.n_kept - self.n_pressure)])


@dataclass
class Explicit:
    """t^n quantities of a step (:func:`explicit_stage`)."""

    dense: np.ndarray
    phi_e: np.ndarray
    iso: np.ndarray | None
    rho_n: np.ndarray
    """Face inertia at t^n [kg m^-3]."""
    f_g: np.ndarray
    drag: np.ndarray
    rhs_u: np.ndarray
    """Momentum right-hand side (consistent transport: without the flux term, added per sweep)."""
    adv: np.ndarray | None
    """v1 ``(u . grad) u`` (None with the consistent transport)."""
    gas_sys: object | None
    border: object | None
    rhs_gas: list
    keep: np.ndarray | None
    region: object | None
    thin: np.ndarray | None = None
    """Indicator surface: the thin material cells, ``c < C_ROW`` (no dilatancy row, ``p = 0`` in the
    solve: their centre lies above the surface; their ambient share takes up the divergence),
    else None."""
    p_fric: np.ndarray | None = None
    """Indicator surface: the pressure of the yield stress in the thin cells, the discrete
    lithostatic pressure at the middle of their material less ``p_f`` at t^n [Pa]
    (:meth:`granflow.model.Model.lithostatic_pressure`)."""
    band_edge: tuple | None = None
    """Indicator surface with the velocity band: masks (cells, nodes) whose viscous stencil
    reaches a face beyond the band (:func:`band_edge`), else None."""
    window: tuple | None = None
    """:func:`granflow.physics.material.material_window` of ``(c^n, phi^n)`` (None: the whole grid,
    or the threshold surface)."""
    fluxes_n: tuple | None = None
    """Solid fluxes of a transport with ``u^n`` (:meth:`granflow.model.Model.transport_fluxes`),
    shared by the gravity weight and the first Picard sweep of the consistent transport (whose
    iterate starts at ``u^n``); None if neither needs them."""
    strain: object = None
    """``|S|`` on the dense cells (:meth:`granflow.operators.Operators.strain_rate_on`), where the
    closure is evaluated (set by :func:`explicit_stage`)."""
    source: object = None
    """:class:`granflow.physics.inflow.SourceTerms` of a source that is on, else None."""
    pressure_cells: np.ndarray | None = None
    """Cells whose p is an unknown with PARDISO's stable pattern (:func:`step_region`; None: the
    dense cells)."""
    phi_f: np.ndarray | None = None
    """``phi^n`` at the velocity unknowns, :meth:`granflow.model.Model.dual_mean` (the dual-cell
    mean), computed once per step."""


@dataclass
class Implicit:
    """Outcome of the Picard loop (:func:`implicit_stage`)."""

    u: np.ndarray
    p: np.ndarray
    p_solve: np.ndarray
    """p of the last solve, before freeing (the dilatancy work uses it)."""
    p_f: np.ndarray
    free: np.ndarray
    eta: tuple
    rho_k: np.ndarray
    """Face inertia of the last solve [kg m^-3]."""
    flux_div: tuple | None
    """``(A, div_dual F)`` of the consistent transport's last sweep (None for v1)."""
    sweeps: int
    rel: float
    converged: bool
    changes: int
    n_negative_Z: int
    krylov: int
    dilation: np.ndarray | None = None
    """Indicator surface: the dilatancy law's rate ``b - C p_fric`` in the thin cells [s^-1]
    (0 elsewhere), for their material's dilatation in the transport."""
    residual_u: np.ndarray | None = None
    """``K x - rhs`` of the last solve on the velocity rows, on every unknown (0 off the band)
    [N m^-3]: the linear solve's error, whose power the energy budget books (``linear_solve``)."""
    residual_gas: np.ndarray | None = None
    """The same on the scaled gas rows of the wet cells (``-1/p_atm`` times the gas equation,
    :meth:`granflow.physics.coupling.GasSystem.scaled_rhs`) [s^-1], else None."""
    div_u: np.ndarray | None = None
    """``divergence @ u`` of the returned ``u``, per cell [s^-1] (the active set's test computed
    it; the dilatancy work of :func:`granflow.step_energy.energy_terms` reuses it)."""


def explicit_stage(model, state, dt: float, tim: dict) -> Explicit:
    """Stage 1: masks, packing of the closure, inertia, gravity, the v1 advection, gas rows."""
    t0 = time.perf_counter()
    phi = state.phi
    dense = model.dense(phi, state.c)
    iso = (model.interface_band(phi, model.isochoric_interface).ravel()
           if model.isochoric_interface else None)
    phi_f = model.dual_mean(phi)  # (shared: inertia, gravity weight, the consistent transport's mass)
    rho_n = model.inertia_density(phi, phi_f)
    window = material_window(model.grid, state.c, phi) if state.c is not None else None
    fluxes_n = (model.transport_fluxes(phi, state.vel, dt, state.c, window)
                if model.consistent_gravity or model.advection is mom.Advection.CONSISTENT else None)
    f_g, drag = model.gravity_split(phi, state.vel, dt, state.c, fluxes_n, phi_f)
    adv = None
    if model.advection is mom.Advection.CONSISTENT:
        rhs_u = rho_n * state.vel / dt + f_g
    else:
        adv = mom.momentum_advection(model.ops, state.vel, model.advection)
        rhs_u = rho_n * (state.vel / dt - adv) + f_g
    source = None
    if model.source is not None and model.source.active(state.t):  # the supply's velocity, penalised
        source = inflow.source_terms(model.source, model.grid, model.material.rho_s, dt, model.base_index)
        drag = drag + source.penalty
        rhs_u = rhs_u + source.penalty * source.target
    thin, p_fric = None, None
    if model.indicator:
        thin = dense & (np.ravel(state.c) < C_ROW)
        p_fric = np.maximum(model.lithostatic_pressure(phi, state.c) - state.p_f, 0.0).ravel()
    gas_sys, border, rhs_gas = None, None, []
    if model.gas_coupling is not None:
        # indicator surface: the gas lives in the cells with a row, at the material's packing,
        # with p_f = 0 at the reconstructed surface (Model.gas_face_factor)
        wet, gas_phi, factor = dense, phi, None
        if model.indicator:
            wet, gas_phi = dense & ~thin, packing(state.c, phi)
            factor = model.gas_face_factor(state.c, gas_phi)
        if source is not None:  # p_f = 0 in a source's cells (granflow.physics.inflow)
            wet = wet & ~source.cells
        try:
            gas_sys = model.gas_coupling.prepare(gas_phi, state.p_f, state.vel, dt, wet, factor)
        except GranflowInputError as err:
            raise StepFailed(f"pore-pressure block: {err}") from None
        if gas_sys.n_wet:
            border = gas_sys.border(model.material.p_atm)
            rhs_gas = [gas_sys.scaled_rhs(model.material.p_atm)]
    keep, region, edge, pressure_cells = step_region(model, phi, dense, never_active(thin, source, dense))
    tim["assembly"] += time.perf_counter() - t0
    return Explicit(dense=dense, phi_e=model.effective_packing(phi, state.c), iso=iso, rho_n=rho_n, f_g=f_g,
                    drag=drag, rhs_u=rhs_u, adv=adv, gas_sys=gas_sys, border=border,
                    rhs_gas=rhs_gas, keep=keep, region=region, thin=thin, p_fric=p_fric,
                    band_edge=edge, window=window, fluxes_n=fluxes_n, strain=model.strain_rate_on(dense),
                    source=source, pressure_cells=pressure_cells, phi_f=phi_f)


def hint_viscosity(model, eta) -> np.ndarray:
    """The pressure cells' viscosity given to the preconditioners [Pa s], floored at
    ``ambient.eta_a``: with no background viscosity (the indicator surface's default) a material
    cell at ``p = 0`` has ``eta = 0``, which the Schur-complement approximations (``1/eta``)
    cannot take. The matrix itself is not changed."""
    return np.maximum(eta, model.ambient.eta_a)


def _momentum_flux(model, fx, fz, vel_n, window, second_order: bool = True):
    """``(A, div_dual F)`` of the solid fluxes ``(fx, fz)`` carrying ``vel_n`` (the plane or the
    axisymmetric form; :func:`consistent_inertia`), MUSCL or first-order face values."""
    if model.unknown_weight is not None:  # axisymmetric: the fluxes through the rings' areas
        A, div_dual = mt.axisymmetric_transport(model.ops, fx, fz, vel_n, window=window, theta=model.momentum_theta,
                                                second_order=second_order)
        return A / model.unknown_weight, div_dual / model.unknown_weight
    A = mt.momentum_flux_divergence(model.grid, fx, fz, vel_n, window=window, theta=model.momentum_theta,
                                    second_order=second_order,
                                    base=None if model.solid is None else model.base_index)
    return A, mt.dual_mass_divergence(model.ops, fx, fz)


def consistent_inertia(model, vel_n, u_k, dt: float, rhs_0, phi, c, phi_f, window, fluxes=None,
                       bounded: bool = False):
    """Inertia and right-hand side of the consistent momentum transport for the iterate ``u_k``
    (:mod:`granflow.physics.momentum_transport`): the phi transport of a step with ``u_k`` gives
    the solid fluxes ``F_k`` (:meth:`granflow.model.Model.transport_fluxes`, the fluxes only);
    the solve uses the dual-cell mass after that step, ``m_k = rho_s max(phi_f - dt div_dual F_k,
    0) + rho_a`` (``phi_f = cell_to_face @ phi``, computed once per step), and
    ``rhs_0 - rho_s A(F_k, u^n)``. At Picard convergence ``F_k`` is the flux of the step's own
    transport, so mass and momentum move together. ``c`` the material fraction (None: threshold
    surface); ``window`` the :func:`granflow.physics.material.material_window` of ``(c, phi)``,
    the same at every sweep of a step (None: the whole grid; the indicator's one-stage fluxes
    vanish beyond it, v1's two-stage MUSCL fluxes are not cut); ``fluxes`` those of ``u_k`` if
    already known. ``bounded`` (one solve per step): the dual cells that lose more than three
    quarters of their grains in the step take first-order face values
    (:func:`granflow.physics.momentum_transport.draining`). Returns ``(m_k, (A, div_dual F_k), rhs)``."""
    fx, fz = model.transport_fluxes(phi, u_k, dt, c, window) if fluxes is None else fluxes
    A, div_dual = _momentum_flux(model, fx, fz, vel_n, window)
    if bounded:
        drained = mt.draining(phi_f, div_dual, dt)
        if drained.any():
            A = np.where(drained, _momentum_flux(model, fx, fz, vel_n, window, second_order=False)[0], A)
    rho = model.material.rho_s * np.maximum(phi_f - dt * div_dual, 0.0) + model.ambient.rho_a
    return rho, (A, div_dual), rhs_0 - model.material.rho_s * A


def _solve(model, K, rhs, x0, hints, tim: dict, sweeps: int):
    t1 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            if model.linear_solver is None:
                sol, its, error = spla.spsolve(K, rhs), 0, None
            else:
                sol, info = model.linear_solver.solve(K, rhs, x0=x0(), hints=hints)
                its, error = int(info.iterations), info.error
        except Exception as err:  # singular matrix, SuperLU failure, Krylov non-convergence
            raise StepFailed(f"linear solve failed: {err}", sweeps) from None
        finally:
            tim["solve"] += time.perf_counter() - t1
    if not np.all(np.isfinite(sol)):
        raise StepFailed("non-finite solution of the linear system", sweeps)
    return sol, its, error


def base_node_viscosity(model, phi_e, dense, p_eval, p_f, S, dt: float, eta_c, eta_n, vel=None) -> np.ndarray:
    """``eta_n`` with the nodes of a no-slip base re-evaluated at the wall pressure [Pa s].

    ``numerics.base_friction = "wall"`` (:class:`granflow.model_options.BaseFriction`): each base
    node takes the mean viscosity of the (one or two) bottom cells beside it, the closure evaluated
    at the cells' packing and strain rate but at the pressure extrapolated to the wall
    (:func:`granflow.physics.momentum.base_pressure`; the pore-pressure gradient of the first
    interior z-face) and the strain rate at the wall (``vel`` given:
    :func:`granflow.physics.wall_friction.base_strain_rate_norm`, the cell's two base nodes; else the
    cell's ``S``). The basal shear stress ``2 eta_n S_xz`` is then ``Z p_wall`` for a film of any
    thickness, where the centre pressure gives half the weight of a one-cell layer and the centre
    strain rate (the mean over the cell's four nodes) ``sqrt(2)`` times the friction of a film one
    cell thick.
    """
    nx, nz = model.grid.cell_shape
    at = (np.arange(nx), model.base_index)  # the base cells: the lowest fluid cell of each column
    p_wall = np.array(p_eval, dtype=float).reshape(nx, nz)
    p_wall[at] = wf.wall_pressure(model, phi_e, p_eval, p_f)
    base = np.zeros((nx, nz), dtype=bool)
    base[at] = True
    base = base.ravel() & np.asarray(dense, dtype=bool).ravel()
    if not base.any():
        return eta_n
    S_wall = np.array(S, dtype=float).reshape(nx, nz)
    if vel is not None:
        S_wall[at] = wf.base_strain_rate_norm(model.ops, vel, model.base_strain_rows)
    eta_wall = np.where(base, model.cell_viscosity(phi_e, p_wall.ravel(), S_wall.ravel(), base), eta_c)
    nodes, to_nodes = model.base_node_rows
    out = np.array(eta_n, dtype=float)
    out[nodes] = to_nodes @ eta_wall
    return out


def base_nodes(model, phi_e, dense, p_eval, p_f, S, dt: float, eta_c, eta_n, vel):
    """The base nodes' viscosity [Pa s] and, on a Coulomb base, their material share (else None):
    :func:`base_node_viscosity` with ``numerics.base_friction = "wall"`` on a no-slip or Coulomb
    base, then the Coulomb cap of :func:`granflow.physics.wall_friction.coulomb_base_viscosity`."""
    if model.base_friction is BaseFriction.WALL and model.ops.bcs.bottom is not VelocityBC.FREE_SLIP:
        # the wall's strain rate on a no-slip base; a Coulomb base's S already leaves out the slip
        wall_vel = vel if model.ops.bcs.bottom is VelocityBC.NO_SLIP else None
        eta_n = base_node_viscosity(model, phi_e, dense, p_eval, p_f, S, dt, eta_c, eta_n, vel=wall_vel)
    if model.wall_friction is None:
        return eta_n, None
    return wf.coulomb_base_viscosity(model, phi_e, p_eval, p_f, vel, eta_n)


def sweep_strain_rate(model, ex: Explicit, u_k, share) -> np.ndarray:
    """``|S|`` of a Picard sweep [s^-1]: on a Coulomb base with the slip left out of the bottom
    cells (:func:`granflow.physics.wall_friction.strain_rate_norm`), else on the dense cells only
    (``ex.strain``; where the closure and the base friction read it)."""
    if model.wall_friction is not None:
        return wf.strain_rate_norm(model, u_k, share)
    return ex.strain(u_k)


def solve_error(K, sol, rhs, layout: SaddleLayout, gas: bool, error=None) -> dict:
    """The last solve's error ``r = K x - b`` on the velocity rows (every unknown, 0 off the band)
    and on the gas rows (if ``gas``): :attr:`Implicit.residual_u`, :attr:`Implicit.residual_gas`.
    ``error``: that ``r`` if the solver computed it (:attr:`granflow.solvers.SolveInfo.error`)."""
    r = K @ sol - rhs if error is None else error
    return {"residual_u": layout.velocity(r), "residual_gas": layout.gas(r) if gas else None}


def implicit_stage(model, state, dt: float, ex: Explicit, tim: dict) -> Implicit:
    """Stage 2: the Picard loop (module docstring of :mod:`granflow.model`, step 2)."""
    g, ops = model.grid, model.ops
    consistent = model.advection is mom.Advection.CONSISTENT
    dense = ex.dense
    u_k = first_iterate(model, state, dt)  # (sweep 1 keeps u^n's fluxes ex.fluxes_n: docs/solver.md)
    p_k = np.maximum(state.p.ravel(), 0.0)
    p_f_new = state.p_f.ravel()
    free, fixed_free = start_free(model, state, ex, dense)  # (one solve per step carries the interior's)
    if model.linear_solver is not None:
        model.linear_solver.begin_step()
    floor = np.sqrt(g.n_unknowns) * model.eps * g.Lz
    changes, rel, n_negz, krylov, converged, sweeps = 0, np.inf, 0, 0, False, 0
    rho_k, flux_div, rhs_u, share = ex.rho_n, None, ex.rhs_u, None  # share: base_nodes
    phi_f_n = ex.phi_f if consistent else None
    window_n = ex.window if consistent else None
    for sweeps in range(1, sweep_cap(model, state) + 1):  # (one solve per step: 1 but at its start)
        t0 = time.perf_counter()
        if consistent:
            rho_k, flux_div, rhs_u = consistent_inertia(model, state.vel, u_k, dt, ex.rhs_u, state.phi,
                                                        state.c, phi_f_n, window_n,
                                                        ex.fluxes_n if sweeps == 1 else None,
                                                        bounded=model.picard.max_sweeps == 1)
        p_eval = p_k if ex.thin is None else np.where(ex.thin, ex.p_fric, p_k)
        S_k = sweep_strain_rate(model, ex, u_k, share)
        coef = model.coefficients(ex.phi_e, p_eval, S_k, dt, dense, tangent=sweeps == 1)
        if ex.iso is not None:  # isochoric interface band: div u = 0 there (or free, p = 0)
            coef.b[ex.iso] = 0.0
            coef.C[ex.iso] = 0.0
        if coef.nonfinite:
            raise StepFailed(f"closure {model.closure.name!r} gave non-finite values in dense cells: "
                             f"{coef.nonfinite}", sweeps)
        n_negz = max(n_negz, coef.n_negative_Z)
        eta_c = coef.eta_c
        eta_n = ops.cell_to_node @ eta_c
        eta_n, share = base_nodes(model, ex.phi_e, dense, p_eval, state.p_f, S_k, dt, coef.eta_c, eta_n, u_k)
        if ex.band_edge is not None:  # a stress-free band edge
            eta_c = np.where(ex.band_edge[0], 0.0, eta_c)
            eta_n = np.where(ex.band_edge[1], 0.0, eta_n)
        mass = model.on_unknowns(rho_k / dt + ex.drag)  # the rows' volume weights (model_geometry)
        a_data = model.assembler.velocity_data(mass, eta_c, eta_n, ex.region)
        act = dense & ~free
        layout = SaddleLayout(g.n_unknowns, g.n_cells, ex.keep, act if not model._stable_pattern
                              else dense if ex.pressure_cells is None else ex.pressure_cells)
        K = model.assembler.saddle(a_data, act, model.on_cells(coef.C), ex.border, unknowns=layout.pressure,
                                   velocity=ex.region)
        rhs = np.concatenate([layout.kept(model.on_unknowns(rhs_u)),
                              -model.on_cells(np.where(act, coef.b, 0.0))[layout.pressure]] + ex.rhs_gas)
        tim["assembly"] += time.perf_counter() - t0
        sol, its, error = _solve(model, K, rhs, lambda: layout.guess(u_k, np.where(act, p_k, 0.0), K.shape[0]),
                          SaddleHints(mass=mass, viscosity=hint_viscosity(model, coef.eta_c[act])), tim, sweeps)
        krylov += its
        u_new = layout.velocity(sol)
        p_new = layout.pressure_of(sol)  # 0 in the free cells among the unknowns
        if ex.gas_sys is not None:
            p_f_new = ex.gas_sys.expand(layout.gas(sol))
        eta_last = (eta_c, eta_n)
        to_free = act & (p_new < 0.0)
        to_act = free & ((div_u := model.divergence @ u_new) < coef.b)
        if fixed_free is not None:
            to_act &= ~fixed_free
        n_change = int(np.count_nonzero(to_free) + np.count_nonzero(to_act))
        changes += n_change
        free = (free & ~to_act) | to_free
        p_raw = p_new
        p_new = np.where(act & ~to_free, p_new, 0.0)
        rel = float(np.linalg.norm(u_new - u_k)) / (float(np.linalg.norm(u_new)) + floor)
        u_k, p_k, p_solve = u_new, p_new, p_raw
        if rel <= model.picard.tol and n_change == 0:
            converged = True
            break
    if not converged and model.picard.max_sweeps > 1 and rel > model.picard.fail_tol:  # (one solve: no loop)
        raise StepFailed(f"Picard diverged (relative increment {rel:.3g})", sweeps)
    if ex.gas_sys is not None and np.any(p_f_new <= -model.material.p_atm):
        raise StepFailed("p_f below vacuum (p_f <= -p_atm)", sweeps)
    dilation = None if ex.thin is None else np.where(ex.thin, coef.b - coef.C * ex.p_fric, 0.0)
    return Implicit(u=u_k, p=p_k, p_solve=p_solve, p_f=p_f_new, free=free, eta=eta_last,
                    rho_k=rho_k, flux_div=flux_div, sweeps=sweeps, rel=rel, converged=converged,
                    changes=changes, n_negative_Z=n_negz, krylov=krylov, dilation=dilation, div_u=div_u,
                    **solve_error(K, sol, rhs, layout, ex.gas_sys is not None, error))


@dataclass
class Transported:
    """Outcome of :func:`transport_stage`."""

    phi: np.ndarray
    """Clipped phi^{n+1}."""
    bounds: object
    cfl: float
    wrapped: float
    held_back: float
    c: np.ndarray | None = None
    """Material fraction at t^{n+1} (indicator surface), else None."""


def transport_stage(model, state, dt: float, u_new, tim: dict, sweeps: int, dilation=None) -> Transported:
    """Stage 4: phi transport with ``u^{n+1}``; CFL, finiteness and bound checks (module
    docstring of :mod:`granflow.model`, step 3)."""
    g, mat = model.grid, model.material
    t0 = time.perf_counter()
    cfl = cfl_number(g, u_new, dt, model.transport_cells(state.phi, state.c))
    if cfl > POSITIVITY_CFL:
        raise StepFailed(f"CFL number {cfl:.3g} of u^(n+1) exceeds {POSITIVITY_CFL}", sweeps, cfl=cfl)
    moved = model.transport(state.phi, u_new, dt, state.c, dilation)
    phi_new = moved.phi
    wrapped = dt * g.dz * float(np.sum(moved.flux_x[0])) if g.periodic_x else 0.0
    if not np.all(np.isfinite(phi_new)):
        bad = np.unravel_index(int(np.argmax(~np.isfinite(phi_new))), phi_new.shape)
        raise StepFailed(f"non-finite phi after transport {location(g, bad)}", sweeps)
    phi_clip, bounds = clip_to_bounds(phi_new, mat.phi_max, g.cell_volume if g.radial is None else g.cell_volumes)
    tim["transport"] += time.perf_counter() - t0
    if bounds.max_before > mat.phi_max * (1.0 + model.phi_tolerance):
        where = location(g, np.unravel_index(int(np.argmax(phi_new)), phi_new.shape))
        raise StepFailed(f"phi = {bounds.max_before:.4g} exceeds phi_max by more than "
                         f"{model.phi_tolerance:.2%} {where}", sweeps)
    if bounds.min_before < -mat.phi_max * model.phi_tolerance:
        where = location(g, np.unravel_index(int(np.argmin(phi_new)), phi_new.shape))
        raise StepFailed(f"phi = {bounds.min_before:.4g} < 0 beyond the tolerance {where}", sweeps)
    return Transported(phi=phi_clip, bounds=bounds, cfl=cfl, wrapped=wrapped, held_back=moved.held_back,
                       c=getattr(moved, "c", None))


def location(grid, index) -> str:
    """'at cell (i, j), x = .. m, z = .. m' for a cell index of ``grid`` (failure messages)."""
    i, j = (int(k) for k in index)
    return f"at cell ({i}, {j}), x = {grid.xc[i]:.4g} m, z = {grid.zc[j]:.4g} m"
