"""The fields of a step on the cells and faces (module docstring of :mod:`granflow.model`): the
dense mask, the material fraction and the packing at which the closure is evaluated (phi_loc near
the ambient, NUMERICS.md §7.1, or ``phi / c`` with the indicator surface), the transport of the
grains (eq. syst1b), the velocity band, the face inertia, the discrete lithostatic pressure and the
face weights of the reconstructed surface, as a mixin of :class:`granflow.model.Model` (it reads
the model's grid, operators, material, ambient, gravity, surface and interface options).
"""
from __future__ import annotations

from functools import cached_property
from typing import Any, Mapping

import numpy as np

from granflow.errors import GranflowInputError
from granflow.max_filter import maximum_filter
from granflow.model_options import (
    ANALYSIS_STEPS,
    INTERFACE_RADIUS,
    PHI_FLOOR,
    PHI_TRACE,
    LinearSolverChoice,
    Surface,
)
from granflow.physics import momentum as mom
from granflow.physics.material import (
    C_MIN,
    PHI_EMPTY,
    advect_material,
    face_solid_fraction,
    material_fraction,
    material_solid_fluxes,
    packing,
    surface_distance,
    surface_lithostatic,
)
from granflow.physics.pore_pressure import cell_permeability, face_permeability
from granflow.physics.transport import advect
from granflow.region import region_payload, restore_region
from granflow.solvers import make_linear_solver
from granflow.state import State

LINEAR_SOLVER_PREFIX = "model.linear_solver."
"""Prefix of the linear solver's entries in a checkpoint (:meth:`FieldMaps.checkpoint_payload`)."""


class FieldMaps:
    """Fields of :class:`granflow.model.Model` (a mixin; not used alone)."""

    @cached_property
    def strain_stencils(self) -> tuple:
        """``(|ec|, |en|)`` (:mod:`granflow.operators`): which velocity unknowns each cell's and
        node's strain rate reads (the band edge, :func:`granflow.step.band_edge`)."""
        return sum(abs(r) for r in self.strain_rows).tocsr(), abs(self.ops.en).tocsr()

    @cached_property
    def base_node_rows(self) -> tuple:
        """``(mask of the bottom-row nodes, cell_to_node restricted to them)``
        (:func:`granflow.step.base_node_viscosity`)."""
        nodes = np.zeros(self.grid.node_shape, dtype=bool)
        cols = np.arange(self.grid.nx)
        nodes[cols, self.base_index] = nodes[cols + 1, self.base_index] = True  # the base cells' bottom corners
        nodes = nodes.ravel()
        return nodes, self.ops.cell_to_node.tocsr()[nodes]

    @cached_property
    def base_strain_rows(self) -> tuple:
        """``(ec, en_left, en_right)`` (:mod:`granflow.operators`) restricted to the base cells
        (the lowest fluid cell of each column, :attr:`base_index`) and to their bottom-left and
        bottom-right nodes: the wall strain rate of
        :func:`granflow.physics.wall_friction.base_strain_rate_norm`."""
        g = self.grid
        cols, jb = np.arange(g.nx), self.base_index
        en = self.ops.en.tocsr()
        cells = cols * g.nz + jb
        ec = (self.ops.ec.tocsr()[cells] if len(self.strain_rows) == 1
              else tuple(r.tocsr()[cells] for r in self.strain_rows))  # axisymmetric: three rows
        return ec, en[cols * (g.nz + 1) + jb], en[(cols + 1) * (g.nz + 1) + jb]

    @property
    def indicator(self) -> bool:
        """True with the material-indicator surface (:class:`Surface`)."""
        return self.surface is Surface.INDICATOR

    def dense(self, phi, c=None) -> np.ndarray:
        """Flat mask of the granular (non-ambient) cells: ``phi >= phi_c`` (threshold surface) or
        ``c > C_MIN`` (indicator surface; without ``c``, the cells holding grains)."""
        if self.indicator:
            return np.ravel(c) > C_MIN if c is not None else np.ravel(phi) > PHI_EMPTY
        return np.ravel(phi) >= self.ambient.phi_c

    def material_of(self, phi) -> np.ndarray | None:
        """Initial material fraction of a solid fraction field (indicator surface; None
        otherwise): ``c = min(phi / psi, 1)`` with ``psi`` the largest packing in the 3 x 3
        neighbourhood (a cell cut by the initial surface holds the packing of the cells beside it)."""
        if not self.indicator:
            return None
        phi = np.asarray(phi, dtype=float).reshape(self.grid.cell_shape)
        return material_fraction(phi, maximum_filter(phi, size=3, mode=self._filter_mode()))

    def transport(self, phi, vel, dt: float, c=None, dilation=None):
        """The step's transport of the grains with ``vel`` (:func:`granflow.physics.transport.advect`,
        or with the indicator :func:`granflow.physics.material.advect_material`, whose result also
        carries ``c``; ``dilation`` the partial cells' dilatation rate [s^-1])."""
        if self.indicator:
            return advect_material(self.grid, c, phi, vel, dt, self.material.phi_max, dilation,
                                   psi_min=self.ambient.phi_c, solid=self.solid)
        return advect(self.grid, phi, vel, dt, self.material.phi_max, self.phi_transport)

    def transport_fluxes(self, phi, vel, dt: float, c=None, window="auto") -> tuple:
        """The solid fluxes ``(flux_x, flux_z)`` [m s^-1] of :meth:`transport` with the same
        arguments (the indicator: :func:`granflow.physics.material.material_solid_fluxes`, the
        fluxes only; ``window`` its material window if known)."""
        if self.indicator:
            return material_solid_fluxes(self.grid, c, phi, vel, dt, self.material.phi_max, window, self.solid)
        moved = self.transport(phi, vel, dt, c)
        return moved.flux_x, moved.flux_z

    def _filter_mode(self):
        return ("wrap", "nearest") if self.grid.periodic_x else "nearest"

    def interface_band(self, phi, radius: int = INTERFACE_RADIUS) -> np.ndarray:
        """Mask (nx, nz) of the dense cells within ``radius`` cells (a (2r+1)^2 neighbourhood)
        of an ambient cell."""
        phi = np.asarray(phi, dtype=float).reshape(self.grid.cell_shape)
        ambient = phi < self.ambient.phi_c
        return maximum_filter(ambient, size=2 * radius + 1, mode=self._filter_mode()) & ~ambient

    def transport_cells(self, phi, c=None) -> np.ndarray | None:
        """Mask (nx, nz) of the cells over which the time step's CFL number is taken, and that of
        its check after the solve (:func:`granflow.physics.transport.cfl_number`); None = every
        cell.

        With the consistent momentum transport nothing crosses a face unless a cell beside it
        holds grains: the material's own fluxes carry the grains, the indicator and the momentum
        (the ambient's inertia floor ``rho_a`` is not transported). So the ambient's velocity
        (weightless, pressureless air in the velocity band, which runs up to four times faster
        than the grains above the Lagree deposit at 256^2) does not set the time step:

        * indicator surface: the material cells (``c > C_MIN``) and the cells with grains above
          the trace level (``phi > PHI_TRACE phi_max``). Its one-stage transport keeps
          ``phi >= 0`` and ``0 <= c <= 1`` at any CFL number by limiting the outflows
          (:mod:`granflow.physics.material`), so the trace material that numerical diffusion
          leaves in the air (``c`` ~ 1e-7) may be carried by a faster air at CFL > 1/2, with the
          grain mass still conserved to round-off;
        * threshold surface: every cell with grains, and one more ring of cells for the two
          SSP-RK2 stages of its phi transport (the first stage can fill a neighbour that the
          second empties), whose positivity needs the CFL bound.

        The v1 ``(u . grad) u`` advection moves the ambient's momentum too: every cell counts."""
        if self.advection is not mom.Advection.CONSISTENT:
            return None
        phi = np.asarray(phi, dtype=float).reshape(self.grid.cell_shape)
        if not self.indicator:
            mode = ("wrap", "constant") if self.grid.periodic_x else "constant"
            return maximum_filter(phi > 0.0, size=3, mode=mode)
        cells = phi > PHI_TRACE * self.material.phi_max
        if c is not None:
            cells |= np.asarray(c, dtype=float).reshape(self.grid.cell_shape) > C_MIN
        return cells

    region_cache: tuple | None = None
    """The velocity region and pressure cells kept across steps (:func:`granflow.region.step_region`)."""

    def _make_linear_solver(self, choice: LinearSolverChoice):
        """The model's linear solver (None: SciPy's direct solve): PARDISO keeps its analysis
        :data:`ANALYSIS_STEPS` steps with a velocity band margin (:func:`granflow.region.step_region`)."""
        if choice is LinearSolverChoice.DIRECT:
            return None
        if choice is LinearSolverChoice.PARDISO:
            return make_linear_solver(choice.value, analysis_steps=ANALYSIS_STEPS
                                      if self.ambient.velocity_band_margin else 1)
        return make_linear_solver(choice.value, grid=self.grid)

    def forget_caches(self) -> None:
        """Drop what is kept from step to step besides the state: the region of
        :func:`granflow.region.step_region` and the linear solver's kept set-up
        (:meth:`granflow.solvers.linear.LinearSolver.forget`)."""
        self.region_cache = None
        if self.linear_solver is not None:
            self.linear_solver.forget()

    def checkpoint_payload(self, simulation=None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """``(arrays, scalars)`` of what is kept from step to step besides the state, so that a
        restart continues bit for bit (:class:`granflow.simulation.Simulation` saves them with
        every checkpoint): the kept region (:func:`granflow.region.region_payload`) and the
        linear solver's kept set-up, under :data:`LINEAR_SOLVER_PREFIX` (PARDISO's analysed
        matrix, :meth:`granflow.solvers.pardiso.PardisoSolver.checkpoint_payload`). Empty
        without ``numerics.ambient.velocity_band_margin``."""
        a, s = ({}, {}) if self.linear_solver is None else self.linear_solver.checkpoint_payload()
        return ({**region_payload(self), **{LINEAR_SOLVER_PREFIX + k: v for k, v in a.items()}},
                {LINEAR_SOLVER_PREFIX + k: v for k, v in s.items()})

    def restore_checkpoint(self, arrays: Mapping[str, Any], scalars: Mapping[str, Any]) -> None:
        """Take up a :meth:`checkpoint_payload`; what it lacks starts afresh (a checkpoint of a
        run without a margin, or of an older version)."""
        restore_region(self, arrays)
        if self.linear_solver is not None:
            def own(d):
                return {k[len(LINEAR_SOLVER_PREFIX):]: v for k, v in d.items() if k.startswith(LINEAR_SOLVER_PREFIX)}
            self.linear_solver.restore_checkpoint(own(arrays), own(scalars))

    def grain_cells(self, phi, margin: int, cells=None) -> np.ndarray:
        """Flat mask of the cells within ``margin`` cells of grains (``phi > PHI_TRACE phi_max``)
        or of the flat mask ``cells``."""
        grains = np.asarray(phi, dtype=float).reshape(self.grid.cell_shape) > PHI_TRACE * self.material.phi_max
        if cells is not None:
            grains |= np.asarray(cells, dtype=bool).reshape(self.grid.cell_shape)
        mode = ("wrap", "constant") if self.grid.periodic_x else "constant"
        return maximum_filter(grains, size=2 * margin + 1, mode=mode).ravel()

    def velocity_region(self, phi, band: int | None = None) -> np.ndarray | None:
        """Flat mask (n_unknowns,) of the velocity unknowns solved in a step from ``phi``: the
        faces of the cells within ``band`` (default :attr:`velocity_band`) cells of grains
        (``phi > PHI_TRACE phi_max``, :attr:`AmbientParams.velocity_band`); None = all of them
        (no band, or no grains). With a topography, only open faces (between two fluid cells,
        :mod:`granflow.topography`) are kept, band or not: the others are ``u = 0``."""
        r, open_faces = self.velocity_band if band is None else band, self.ops.open_faces
        if r is None:
            return None if open_faces is None else open_faces
        grains = np.asarray(phi, dtype=float).reshape(self.grid.cell_shape) > PHI_TRACE * self.material.phi_max
        mode = ("wrap", "constant") if self.grid.periodic_x else "constant"
        band = maximum_filter(grains, size=2 * r + 1, mode=mode)
        faces = (self._face_cells @ band.ravel().astype(float)) > 0.0
        if open_faces is not None:
            return faces & open_faces if faces.any() else open_faces
        return faces if faces.any() and not faces.all() else None

    def effective_packing(self, phi, c=None) -> np.ndarray:
        """Flat phi at which the closure is evaluated: the packing inside the material
        ``phi / c`` (indicator surface) or phi_loc near the ambient (NUMERICS.md §7.1), clipped
        to ``[PHI_FLOOR, phi_max]``."""
        if self.indicator:
            return np.clip(packing(c, phi), PHI_FLOOR, self.material.phi_max).ravel()
        phi = np.asarray(phi, dtype=float).reshape(self.grid.cell_shape)
        out = phi
        if self.interface_packing:
            near = self.interface_band(phi)
            out = np.where(near, maximum_filter(phi, size=2 * INTERFACE_RADIUS + 1,
                                                mode=self._filter_mode()), phi)
        return np.clip(out, PHI_FLOOR, self.material.phi_max).ravel()

    def inertia_density(self, phi, phi_f=None) -> np.ndarray:
        """Face inertia [kg m^-3] at the velocity unknowns: ``rho_s phi_f + rho_a`` with the
        consistent momentum transport (the dual-cell mass of
        :mod:`granflow.physics.momentum_transport` plus a constant ambient floor), else
        ``max(phi_f rho_s, rho_a)`` (v1, :func:`granflow.physics.momentum.face_density`).
        ``phi_f``: :meth:`dual_mean` of ``phi`` if already known (consistent transport only)."""
        if self.advection is mom.Advection.CONSISTENT:
            phi_f = self.dual_mean(phi) if phi_f is None else phi_f
            return self.material.rho_s * np.maximum(phi_f, 0.0) + self.ambient.rho_a
        return mom.face_density(self.ops, phi, self.material.rho_s, self.ambient.rho_a)

    def lithostatic_pressure(self, phi, c=None) -> np.ndarray:
        """Discrete hydrostatic p [Pa], shape (nx, nz): the p with ``Grad p = f_g`` on the z-faces
        of every column (trapezoidal sum of ``phi rho_s |g_z| dz`` from the top), zero in the
        ambient. For a uniform layer filling whole cells it equals ``phi rho_s |g_z| (H - z)``.
        Indicator surface: the hydrostatic pressure of the reconstructed material
        (:func:`granflow.physics.material.surface_lithostatic`; ``c`` defaults to
        :meth:`material_of`), ``p = 0`` at the surface."""
        phi = np.asarray(phi, dtype=float).reshape(self.grid.cell_shape)
        if self.indicator:
            c = self.material_of(phi) if c is None else np.asarray(c, dtype=float).reshape(phi.shape)
            return surface_lithostatic(c, phi, self.material.rho_s * abs(self.gravity[1]) * self.grid.dz)
        upper = np.concatenate([phi[:, 1:], np.zeros((phi.shape[0], 1))], axis=1)
        face = 0.5 * (phi + upper) * self.material.rho_s * abs(self.gravity[1]) * self.grid.dz
        p = np.cumsum(face[:, ::-1], axis=1)[:, ::-1]
        return np.where(self.dense(phi).reshape(self.grid.cell_shape), p, 0.0)

    def initial_state(self, phi, p_f=0.0) -> State:
        """State at rest with ``phi``, pore pressure ``p_f`` [Pa] (zeroed in the ambient) and
        ``p = max(lithostatic - p_f, 0)`` as first Picard iterate (the effective pressure
        ``p + p_f`` carries the weight). ``p_f = b * model.lithostatic_pressure(phi)`` is a bed
        fluidised to the degree ``b``. A dry model accepts only ``p_f = 0``."""
        phi = np.asarray(phi, dtype=float)
        try:
            p_f = np.broadcast_to(np.asarray(p_f, dtype=float), self.grid.cell_shape)
        except ValueError:
            raise GranflowInputError(f"Model.initial_state: p_f must be a scalar or of shape "
                                     f"{self.grid.cell_shape}") from None
        if self.gas is None and np.any(p_f != 0.0):
            raise GranflowInputError("Model.initial_state: p_f != 0 needs a gas law (gas=...)")
        if self.solid is not None and np.any(phi.reshape(self.grid.cell_shape)[self.solid] != 0.0):
            i, j = np.argwhere(self.solid & (phi.reshape(self.grid.cell_shape) != 0.0))[0]
            raise GranflowInputError(f"Model.initial_state: phi != 0 in the solid cell ({i}, {j}) at "
                                     f"x = {self.grid.xc[i]:.6g} m, z = {self.grid.zc[j]:.6g} m, below the "
                                     f"topography; grains must sit on the profile")
        p_f = np.where(self.dense(phi).reshape(self.grid.cell_shape), p_f, 0.0)
        p = np.maximum(self.lithostatic_pressure(phi) - p_f, 0.0)
        return State.at_rest(self.grid, phi, p=p, p_f=p_f, c=self.material_of(phi))

    def face_fraction(self, phi, c=None, phi_f=None) -> np.ndarray:
        """Solid fraction weighed at the velocity unknowns when they are at rest [-]: the centred
        mean of the two cells, and with the indicator surface on the interior z-faces the grains
        of the reconstructed material in the face's dual cell
        (:func:`granflow.physics.material.face_solid_fraction`), so that ``p = 0`` sits at the
        surface. ``phi_f``: :meth:`dual_mean` of ``phi`` if already known (not changed)."""
        phi = np.asarray(phi, dtype=float).reshape(self.grid.cell_shape)
        out = self.dual_mean(phi) if phi_f is None else phi_f.copy()
        if self.indicator and c is not None:
            c = np.asarray(c, dtype=float).reshape(phi.shape)
            out[self.grid.w_slice] = face_solid_fraction(c, phi).ravel()  # interior z-faces
        return out

    def gas_face_factor(self, c, psi) -> np.ndarray:
        """Multiplier of the gas face mobilities (n_unknowns,) that puts ``p_f = 0`` at the
        reconstructed surface (indicator surface): on a z-face from a wet cell to the cell above
        it without a row, the mobility becomes ``kappa(psi_below) / theta`` with ``theta`` the
        centre-to-surface distance in cells (:func:`granflow.physics.material.surface_distance`),
        so that the Darcy flux there is ``kappa p_f / (theta dz)`` (Gibou et al. 2002); 1 on the
        other faces. ``psi`` the packing inside the material [-]."""
        g = self.grid
        psi = np.asarray(psi, dtype=float).reshape(g.cell_shape)
        theta = surface_distance(np.asarray(c, dtype=float).reshape(g.cell_shape))
        kappa_f, _ = face_permeability(g, self.ops, psi, self.material)
        kc = cell_permeability(psi, self.material)
        out = np.ones(g.n_unknowns)
        kz = kappa_f[g.w_slice].reshape(g.nx, g.nz - 1)
        at = np.isfinite(theta)
        out_z = np.ones_like(kz)
        out_z[at] = kc[:, :-1][at] / (theta[at] * kz[at])
        out[g.w_slice] = out_z.ravel()
        return out
