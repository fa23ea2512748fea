"""Axisymmetric (r, z) MAC operators (issue 14 item 4, first step: the operators alone; the solver
does not use them yet).

The grid's x axis is the radius r (the west side ``x0 = 0`` is the axis of symmetry, a free-slip
"wall": ``u = 0`` on it, zero shear), z is vertical; the fields do not depend on the azimuth and
carry no swirl. Every integral is per radian of azimuth: a cell's control volume is
``r_c dr dz``, a u face's ``r_f dr dz``, a w face's ``r_c dr dz`` (it sits at the cell's
radius), a node's ``r_n w_n dr dz`` (``w_n`` the box's node weight, :mod:`granflow.operators`).

Continuous conventions (docs/model.md §1 in cylindrical form): the strain rate has the hoop
component ``e_tt = u / r``,

    div u = (1/r) d(r u)/dr + dw/dz = e_rr + e_tt + e_zz,
    S = e - (div u / 3) Id          (the three-dimensional deviator of an axisymmetric flow),
    |S|^2 = S:S / 2 = (S_rr^2 + S_tt^2 + S_zz^2)/2 + S_rz^2,

which is ``gamma/2`` in simple shear as in the plane model; the dissipation density is
``tau:S = 4 eta |S|^2`` [W m^-3]. Since ``sum_i S_ii^2 = sum_{i<j} (e_ii - e_jj)^2 / 3``,

    tau:S = (2 eta / 3) [(e_rr - e_tt)^2 + (e_tt - e_zz)^2 + (e_zz - e_rr)^2] + eta (2 S_rz)^2.

Discrete operators (:class:`AxisymmetricOperators`): ``div = diag(1/r_c) D_r diag(r_f) + D_z``
(exact for ``u = a r``: 2a), ``grad`` the plain centred face gradient, so that with the volume
weights ``M_c = diag(r_c)``, ``M_f = diag(r at the unknowns)``

    sum_c r_c p (div u) = - sum_f r_f u (grad p)     (``M_c div = -(M_f grad)^T``, exactly),

the strain rows ``e_rr`` (cells), ``e_tt = mean(u)/r_c`` (cells), ``e_zz`` (cells) and
``en = du/dz + dw/dr = 2 S_rz`` (nodes, the box's ghosts: the axis is free-slip), and

    V = sum_pairs E_p^T diag(2/3 eta_c r_c) E_p + en^T diag(w_n r_n eta_n) en    (symmetric, >= 0),

``E_p`` the three differences of the diagonal strain rows: ``dV u^T V u`` is the discrete
dissipation per radian [W rad^-1] and ``V u`` approximates ``r (-div(2 eta S))`` at the unknowns
(the momentum rows multiplied by their volume weight, which keeps the saddle-point system
symmetric: ``[[M_f rho/dt + V, -(M_c div)^T], [M_c div, ...]]``).

References
----------
Batchelor, An Introduction to Fluid Dynamics (1967), appendix 2 (cylindrical strain rate);
NUMERICS.md §2, §9 (MAC operators, energy identity) in the form of docs/solver.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from granflow.errors import GranflowInputError
from granflow.grid import Grid, Side, VelocityBC, VelocityBCs
from granflow.operators import Operators

DEVIATOR_WEIGHT = 2.0 / 3.0
"""``2/3``: ``2 eta sum_i S_ii^2 = (2 eta / 3) sum_{i<j} (e_ii - e_jj)^2``."""


@dataclass(frozen=True, eq=False)
class AssemblyOperators:
    """What :class:`granflow.physics.momentum.SaddleAssembler` reads of an axisymmetric grid: the
    viscous operator ``V = sum_k R_k^T diag(eta_c) R_k + en^T diag(node_weights eta_n) en`` and
    the momentum rows' pressure gradient ``grad``, all weighted by ``2 pi r``
    (:meth:`AxisymmetricOperators.assembly_operators`). Then ``grad^T = -(2 pi r_c) div`` is the
    continuity rows' operator and the system stays symmetric."""

    grid: Grid
    cell_rows: tuple
    en: sp.csr_matrix
    node_weights: np.ndarray
    grad: sp.csr_matrix


@dataclass(frozen=True, eq=False)
class AxisymmetricOperators:
    """Sparse MAC operators of an axisymmetric (r, z) grid (module docstring). Build with
    :meth:`build`.

    Attributes
    ----------
    box : Operators
        The plane operators of the same grid (their ``grad``, ``en`` and averaging maps are the
        axisymmetric ones too).
    r_cells, r_unknowns, r_nodes : ndarray
        Radius of the cell centres (n_cells,), of the velocity unknowns (n_unknowns,: r_f for u,
        r_c for w) and of the nodes (n_nodes,) [m]: the volume weights per radian over dr dz.
    div : csr_matrix, (n_cells, n_unknowns)
        ``(1/r) d(r u)/dr + dw/dz`` [m^-1].
    e_rr, e_tt, e_zz : csr_matrix, (n_cells, n_unknowns)
        The diagonal strain rates at the cell centres [m^-1].
    """

    box: Operators
    r_cells: np.ndarray
    r_unknowns: np.ndarray
    r_nodes: np.ndarray
    div: sp.csr_matrix
    e_rr: sp.csr_matrix
    e_tt: sp.csr_matrix
    e_zz: sp.csr_matrix

    @classmethod
    def build(cls, grid: Grid, bcs: VelocityBCs | None = None) -> AxisymmetricOperators:
        """The operators of ``grid`` read as (r, z): ``grid.x0`` must be 0 (the axis), the grid
        not periodic, and the west "wall" (the axis) free-slip."""
        if not isinstance(grid, Grid):
            raise GranflowInputError(f"AxisymmetricOperators.build: grid must be a Grid, got {type(grid).__name__}")
        if grid.periodic_x:
            raise GranflowInputError("axisymmetric grid: r cannot be periodic (grid.periodic_x = false)")
        if grid.x0 != 0.0:
            raise GranflowInputError(f"axisymmetric grid: the axis is r = 0, so grid.x0 must be 0 (got {grid.x0})")
        bcs = VelocityBCs() if bcs is None else bcs
        if bcs.kind(Side.WEST) is not VelocityBC.FREE_SLIP:
            raise GranflowInputError(f"axisymmetric grid: the west side is the axis of symmetry, free-slip "
                                     f"(got {bcs.kind(Side.WEST).value!r})")
        box = Operators.build(grid, bcs)
        rc = np.repeat(grid.xc, grid.nz)
        ru = np.repeat(grid.xf[1:-1], grid.nz)
        rw = np.repeat(grid.xc, grid.nz - 1)
        rn = np.repeat(grid.xf, grid.nz + 1)
        div_u = box.div[:, grid.u_slice]
        div_w = box.div[:, grid.w_slice]
        radial = sp.diags(1.0 / rc) @ div_u @ sp.diags(ru)            # (1/r) d(r u)/dr
        zeros_w = sp.csr_matrix(div_w.shape)
        zeros_u = sp.csr_matrix(div_u.shape)
        hoop = sp.diags(1.0 / rc) @ _faces_to_cells(grid)              # mean of the two u faces / r_c
        e_rr = sp.hstack([div_u, zeros_w], format="csr")
        e_tt = sp.hstack([hoop, zeros_w], format="csr")
        e_zz = sp.hstack([zeros_u, div_w], format="csr")
        div = sp.hstack([radial, div_w], format="csr")
        for a in (rc, ru, rw, rn):
            a.setflags(write=False)
        return cls(box=box, r_cells=rc, r_unknowns=np.concatenate([ru, rw]), r_nodes=rn, div=div,
                   e_rr=e_rr, e_tt=e_tt, e_zz=e_zz)

    # --- weighted forms -----------------------------------------------------------------------
    @property
    def grid(self) -> Grid:
        return self.box.grid

    @property
    def grad(self) -> sp.csr_matrix:
        """Centred face gradient of a cell field [m^-1] (the plane one; module docstring)."""
        return self.box.grad

    @property
    def en(self) -> sp.csr_matrix:
        """``du/dz + dw/dr = 2 S_rz`` at the nodes [m^-1] (the plane operator: the same ghosts)."""
        return self.box.en

    def weighted_div(self) -> sp.csr_matrix:
        """``M_c div`` [m^0]: the continuity rows of the symmetric saddle-point system; equal to
        ``-(M_f grad)^T`` exactly."""
        return (sp.diags(self.r_cells) @ self.div).tocsr()

    def pairs(self) -> tuple[sp.csr_matrix, sp.csr_matrix, sp.csr_matrix]:
        """``(e_rr - e_tt, e_tt - e_zz, e_zz - e_rr)`` at the cells [m^-1]."""
        return ((self.e_rr - self.e_tt).tocsr(), (self.e_tt - self.e_zz).tocsr(),
                (self.e_zz - self.e_rr).tocsr())

    def viscous_operator(self, eta_c, eta_n) -> sp.csr_matrix:
        """``V`` of the module docstring [Pa s m^-1 per radian]: symmetric positive semidefinite,
        ``V u ~ r (-div(2 eta S))`` at the unknowns."""
        g = self.grid
        ec_w = DEVIATOR_WEIGHT * Operators._coefficient("eta_c", eta_c, g.cell_shape) * self.r_cells
        en_w = Operators._coefficient("eta_n", eta_n, g.node_shape) * self.box.node_weights * self.r_nodes
        v = self.en.T @ sp.diags(en_w) @ self.en
        for e in self.pairs():
            v = v + e.T @ sp.diags(ec_w) @ e
        return sp.csr_matrix(v)

    def dissipation(self, vel, eta_c, eta_n) -> float:
        """``dV [sum_c (2/3) eta_c r_c sum_pairs (E_p u)^2 + sum_n w_n r_n eta_n (en u)^2]`` [W rad^-1]:
        the integral of ``tau:S`` per radian; equal to ``dV u^T V u``."""
        vel = self.box._velocity(vel)
        g = self.grid
        ec_w = DEVIATOR_WEIGHT * Operators._coefficient("eta_c", eta_c, g.cell_shape) * self.r_cells
        en_w = Operators._coefficient("eta_n", eta_n, g.node_shape) * self.box.node_weights * self.r_nodes
        cells = sum(float(ec_w @ (e @ vel) ** 2) for e in self.pairs())
        return g.cell_volume * (cells + float(en_w @ (self.en @ vel) ** 2))

    def strain_rate_norm(self, vel) -> np.ndarray:
        """``|S| = sqrt(S:S/2)`` at the cell centres [s^-1]: ``sum_pairs (E_p u)^2 / 6`` plus the
        mean over the cell's four nodes of ``(en u)^2 / 4`` (as the plane operator's S_xz)."""
        vel = self.box._velocity(vel)
        diag = sum((e @ vel) ** 2 for e in self.pairs()) / 6.0
        return np.sqrt(diag + 0.25 * (self.box.node_to_cell @ (self.en @ vel) ** 2))

    @property
    def strain_rows(self) -> tuple[sp.csr_matrix, sp.csr_matrix, sp.csr_matrix]:
        """The three pair rows scaled by ``sqrt(2/3)`` [m^-1]: ``|S|^2 = sum_k (row_k u)^2 / 4 +
        S_rz^2``, the form of the plane ``(ec u)^2 / 4 + S_xz^2`` (one row there); what the
        strain-rate evaluations of the solver take (:class:`granflow.strain_rate.StrainRate` ``rows``,
        :func:`granflow.physics.wall_friction.base_strain_rate_norm`)."""
        scale = np.sqrt(DEVIATOR_WEIGHT)
        return tuple((scale * e).tocsr() for e in self.pairs())

    def assembly_operators(self) -> AssemblyOperators:
        """The operators of the symmetric saddle-point system over the full circumference (module
        docstring; every weight ``r`` becomes ``2 pi r``), for
        :class:`granflow.physics.momentum.SaddleAssembler`."""
        two_pi = 2.0 * np.pi
        cell_w = sp.diags(np.sqrt(two_pi * DEVIATOR_WEIGHT * self.r_cells))
        rows = tuple((cell_w @ e).tocsr() for e in self.pairs())
        return AssemblyOperators(grid=self.grid, cell_rows=rows, en=self.en,
                                 node_weights=self.box.node_weights * two_pi * self.r_nodes,
                                 grad=(sp.diags(two_pi * self.r_unknowns) @ self.grad).tocsr())

    def volume(self) -> float:
        """Volume of the grid's cells per radian, ``sum r_c dr dz`` [m^3 rad^-1] (``R^2 H / 2``)."""
        return float(self.r_cells.sum() * self.grid.cell_volume)


def _faces_to_cells(grid: Grid) -> sp.csr_matrix:
    """(n_cells, n_u): mean of the two x-face unknowns of each cell (the wall and axis faces
    carry u = 0)."""
    nx, nz = grid.nx, grid.nz
    mean = sp.diags([np.full(nx, 0.5), np.full(nx, 0.5)], [0, 1], shape=(nx, nx + 1), format="csc")
    return sp.kron(mean[:, 1:-1], sp.identity(nz), format="csr")
