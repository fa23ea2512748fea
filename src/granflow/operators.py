"""Finite-volume operators of the MAC grid as sparse matrices, built once (NUMERICS.md §2, §8, §13).

All velocity operators act on the unknown vector of :class:`granflow.grid.Grid` (interior faces,
u then w; zero normal velocity on the walls); cell fields, node fields and face fields are flat
C-order vectors (reshape with ``grid.cell_shape``, ``grid.node_shape``...).

Continuous conventions (MODEL.md §1): ``S = (grad u + grad u^T)/2 - (div u/2) Id`` is the 2-D
deviatoric strain rate, so ``S_zz = -S_xx`` and ``|S|^2 = S:S/2 = S_xx^2 + S_xz^2``. The
deviatoric stress is ``tau = 2 eta S``: ``tau_xx = -tau_zz = eta (du/dx - dw/dz)`` and
``tau_xz = eta (du/dz + dw/dx)``; the dissipation density is
``tau:S = 4 eta |S|^2 = eta (du/dx - dw/dz)^2 + eta (du/dz + dw/dx)^2`` [W m^-3].

Discrete operators (``h`` = dx or dz; all in m^-1):

``div``  (cells x unknowns)  ``(u[i+1,j] - u[i,j])/dx + (w[i,j+1] - w[i,j])/dz``.
``grad`` (unknowns x cells)  ``-div.T`` exactly: the centred face gradient of a cell field with
                             zero normal gradient (Neumann) at the walls, since wall faces are not
                             unknowns. Hence ``sum_c p (div u) dV = -sum_f u (grad p) dV``.
``ec``   (cells x unknowns)  ``du/dx - dw/dz = 2 S_xx`` at cell centres.
``en``   (nodes x unknowns)  ``du/dz + dw/dx = 2 S_xz`` at nodes. Wall nodes use a ghost
                             tangential velocity: no-slip ``ghost = -interior`` (one-sided
                             gradient ``2 u/h``), free-slip ``ghost = +interior`` (zero gradient;
                             since the normal velocity vanishes along the wall, the whole ``en`` row
                             is zero there). Corner rows are always zero.

Node weights ``w_n`` (1 inside, 1/2 on a wall, 1/4 at a corner) are the fractions of the node
control volume inside the box. With them the discrete dissipation is

``D = dV [ sum_c eta_c (ec u)_c^2 + sum_n w_n eta_n (en u)_n^2 ] = dV u^T V u``     [W m^-1],

``V = ec^T diag(eta_c) ec + en^T diag(w_n eta_n) en`` (:meth:`Operators.viscous_operator`), and
``(V u)_f`` approximates ``-div(2 eta S)`` at face ``f`` [Pa m^-1 = N m^-3]. Sign convention: V is
symmetric positive semidefinite, the viscous/plastic force per unit volume in the momentum
equation is ``-V u``. The half weight at wall nodes reproduces the classical ghost-cell stencil:
for a u row next to a no-slip base, ``(V u) = eta (3 u_0 - u_1)/dz^2`` in the z part, which
vanishes for a linear (Couette) profile ``u = gamma z``.

Periodic in x (``grid.periodic_x``, layout in :mod:`granflow.grid`). The x blocks of the
Kronecker products are replaced by their circulant versions (:func:`periodic_x_blocks`): the
face difference and the cell-to-face mean wrap (x-face 0 lies between cells nx - 1 and 0), the
tangential difference ``dw/dx`` at the node columns 0 and nx (one physical node and its image) is
``(w[0] - w[nx-1])/dx`` on both, ``du/dz`` at node column nx reads the u of x-face 0. Node weights
keep the value 1/2 on the columns 0 and nx: each physical node of that column is counted twice at
half weight, so ``D`` and ``V`` are unchanged in form, and the shear rate at a base node is that
of a wall node in z only (no corners). ``grad = -div.T`` still holds exactly; it is now the
periodic centred gradient in x. West/east wall conditions do not exist: a ``no_slip`` value
there is rejected.

References
----------
F.H. Harlow, J.E. Welch, Phys. Fluids 8, 2182 (1965) -- MAC layout.
NUMERICS.md §2 (operators), §8 (wall conditions), §9 (energy identity), §13 (code structure).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from granflow.errors import GranflowInputError
from granflow.grid import Grid, Side, VelocityBC, VelocityBCs

if TYPE_CHECKING:
    from granflow.strain_rate import StrainRate, StrainRateOn

GHOST_SIGN = {VelocityBC.NO_SLIP: -1.0, VelocityBC.FREE_SLIP: 1.0, VelocityBC.COULOMB: -1.0,
              VelocityBC.OUTFLOW: 1.0}
"""Ghost tangential velocity = sign * first interior value, per wall condition (a Coulomb base has
the no-slip ghost; its friction caps the base nodes' viscosity, :mod:`granflow.physics.wall_friction`;
an outflow wall is free-slip in the solve, :mod:`granflow.physics.outflow`)."""

WALL_NODE_WEIGHT = 0.5
"""Fraction of a wall node's control volume inside the box (a corner gets the square, 1/4)."""


# --- 1-D building blocks (all CSR) -------------------------------------------------------------
def _eye(n: int) -> sp.csr_matrix:
    return sp.identity(n, format="csr")


def _face_to_cell_diff(n: int, h: float) -> sp.csr_matrix:
    """(n x (n-1)): difference across each cell of interior-face values, walls = 0."""
    full = sp.diags([-np.ones(n), np.ones(n)], [0, 1], shape=(n, n + 1), format="csc") / h
    return full[:, 1:-1].tocsr()


def _tangential_diff(n: int, h: float, sign_low: float, sign_high: float) -> sp.csr_matrix:
    """((n+1) x n): derivative at the n+1 nodes of a tangential field at the n cell positions.

    Node k sits between values k-1 and k; the ghost values beyond the walls are
    ``sign_low * value[0]`` and ``sign_high * value[n-1]``.
    """
    d = sp.diags([np.ones(n), -np.ones(n)], [0, -1], shape=(n + 1, n), format="lil")
    d[0, 0] = 1.0 - sign_low
    d[n, n - 1] = sign_high - 1.0
    return (d.tocsr() / h).tocsr()


def _interior_to_all(n: int) -> sp.csr_matrix:
    """((n+1) x (n-1)): injection of interior face values into all n+1 positions (walls = 0)."""
    return sp.eye(n + 1, n - 1, k=-1, format="csr")


def _mean_pairs(n: int) -> sp.csr_matrix:
    """(n x (n+1)): mean of consecutive values (faces/nodes -> cells)."""
    return sp.diags([np.full(n, 0.5), np.full(n, 0.5)], [0, 1], shape=(n, n + 1), format="csr")


def _cell_to_interior_faces(n: int) -> sp.csr_matrix:
    """((n-1) x n): mean of the two cells on either side of each interior face."""
    half = np.full(n - 1, 0.5)
    return sp.diags([half, half], [0, 1], shape=(n - 1, n), format="csr")


def _cell_to_all_nodes(n: int) -> sp.csr_matrix:
    """((n+1) x n): mean of the neighbouring cells (two inside, the single one on a wall)."""
    m = sp.diags([np.full(n, 0.5), np.full(n, 0.5)], [0, -1], shape=(n + 1, n), format="lil")
    m[0, 0] = 1.0
    m[n, n - 1] = 1.0
    return m.tocsr()


def _node_weights_1d(n: int) -> np.ndarray:
    """Wall nodes 1/2; periodic: a node and its image 1/2 each (same array)."""
    wgt = np.ones(n + 1)
    wgt[[0, -1]] = WALL_NODE_WEIGHT
    return wgt


# --- periodic 1-D blocks (x-face k is between cells k-1 and k, indices mod n) -------------------
def _periodic_face_to_cell_diff(n: int, h: float) -> sp.csr_matrix:
    """(n x n): ``(f[i+1] - f[i])/h`` with ``f[n] = f[0]``."""
    i = np.arange(n)
    return sp.csr_matrix((np.r_[-np.ones(n), np.ones(n)] / h, (np.r_[i, i], np.r_[i, (i + 1) % n])),
                         shape=(n, n))


def _periodic_tangential_diff(n: int, h: float) -> sp.csr_matrix:
    """((n+1) x n): ``(v[k] - v[k-1])/h`` at the n+1 node columns (indices mod n)."""
    k = np.arange(n + 1)
    return sp.csr_matrix((np.r_[np.ones(n + 1), -np.ones(n + 1)] / h,
                          (np.r_[k, k], np.r_[k % n, (k - 1) % n])), shape=(n + 1, n))


def _periodic_faces_to_all(n: int) -> sp.csr_matrix:
    """((n+1) x n): the n face values on the n+1 columns (the last is the image of the first)."""
    k = np.arange(n + 1)
    return sp.csr_matrix((np.ones(n + 1), (k, k % n)), shape=(n + 1, n))


def _periodic_cell_to_faces(n: int) -> sp.csr_matrix:
    """(n x n): mean of the cells k-1 and k either side of face k."""
    i = np.arange(n)
    return sp.csr_matrix((np.full(2 * n, 0.5), (np.r_[i, i], np.r_[(i - 1) % n, i])), shape=(n, n))


def _periodic_cell_to_nodes(n: int) -> sp.csr_matrix:
    """((n+1) x n): mean of the cells k-1 and k either side of node column k."""
    k = np.arange(n + 1)
    return sp.csr_matrix((np.full(2 * (n + 1), 0.5), (np.r_[k, k], np.r_[(k - 1) % n, k % n])),
                         shape=(n + 1, n))


@dataclass(frozen=True)
class AxisBlocks:
    """The 1-D blocks of one direction, from which :meth:`Operators.build` takes Kronecker products.

    Attributes
    ----------
    diff : (n_cells_1d, n_faces_1d)
        Difference of face unknowns across each cell, divided by h.
    tangential : (n_nodes_1d, n_cells_1d)
        Derivative at the nodes of a tangential field held at cell positions (ghosts or wrap).
    faces_to_nodes : (n_nodes_1d, n_faces_1d)
        Face unknowns placed on the node positions (zero on walls, image when periodic).
    cell_to_faces : (n_faces_1d, n_cells_1d)
        Mean of the two cells either side of each face unknown.
    cell_to_nodes : (n_nodes_1d, n_cells_1d)
        Mean of the neighbouring cells of each node position.
    """

    diff: sp.csr_matrix
    tangential: sp.csr_matrix
    faces_to_nodes: sp.csr_matrix
    cell_to_faces: sp.csr_matrix
    cell_to_nodes: sp.csr_matrix


def wall_blocks(n: int, h: float, sign_low: float, sign_high: float) -> AxisBlocks:
    """1-D blocks of a direction bounded by two walls (ghost signs of the tangential velocity)."""
    return AxisBlocks(_face_to_cell_diff(n, h), _tangential_diff(n, h, sign_low, sign_high),
                      _interior_to_all(n), _cell_to_interior_faces(n), _cell_to_all_nodes(n))


def periodic_blocks(n: int, h: float) -> AxisBlocks:
    """1-D blocks of a periodic direction (circulant; n faces, n + 1 node positions)."""
    return AxisBlocks(_periodic_face_to_cell_diff(n, h), _periodic_tangential_diff(n, h),
                      _periodic_faces_to_all(n), _periodic_cell_to_faces(n),
                      _periodic_cell_to_nodes(n))


@dataclass(frozen=True, eq=False)
class Operators:
    """Sparse MAC operators of one grid and one set of wall conditions (NUMERICS.md §2).

    Build with :meth:`build`. Matrices are ``scipy.sparse.csr_matrix``; do not modify them.

    Attributes
    ----------
    grid : Grid
    bcs : VelocityBCs
    div : csr_matrix, (n_cells, n_unknowns)
        Divergence [m^-1].
    grad : csr_matrix, (n_unknowns, n_cells)
        Face gradient with Neumann walls, exactly ``-div.T`` [m^-1].
    ec : csr_matrix, (n_cells, n_unknowns)
        ``du/dx - dw/dz = 2 S_xx`` at cells [m^-1].
    en : csr_matrix, (n_nodes, n_unknowns)
        ``du/dz + dw/dx = 2 S_xz`` at nodes, wall conditions included [m^-1].
    node_weights : ndarray, (n_nodes,)
        Control-volume fraction of each node inside the box: 1, 1/2 (wall), 1/4 (corner);
        periodic in x, 1/2 on the node columns 0 and nx (a node and its image share one volume).
    cell_to_xface : csr_matrix, (n_u, n_cells)
        Mean of the two cells either side of each interior (periodic: each) x-face.
    cell_to_zface : csr_matrix, (n_w, n_cells)
        Mean of the two cells either side of each interior z-face.
    cell_to_face : csr_matrix, (n_unknowns, n_cells)
        ``cell_to_xface`` stacked over ``cell_to_zface`` (ordering of the velocity vector).
    cell_to_node : csr_matrix, (n_nodes, n_cells)
        Mean of the neighbouring cells: 4 inside, 2 on a wall, 1 at a corner.
    node_to_cell : csr_matrix, (n_cells, n_nodes)
        Mean of the 4 corner nodes of each cell.
    solid : ndarray of bool, (n_cells,), or None
        Solid cells of a base profile (:func:`granflow.topography.masked_operators`); None in the
        plain box.
    open_faces : ndarray of bool, (n_unknowns,), or None
        Velocity unknowns between two fluid cells (the only ones that carry velocity); None in the
        plain box (all of them).
    """

    grid: Grid
    bcs: VelocityBCs
    div: sp.csr_matrix
    grad: sp.csr_matrix
    ec: sp.csr_matrix
    en: sp.csr_matrix
    node_weights: np.ndarray
    cell_to_xface: sp.csr_matrix
    cell_to_zface: sp.csr_matrix
    cell_to_face: sp.csr_matrix
    cell_to_node: sp.csr_matrix
    node_to_cell: sp.csr_matrix
    solid: np.ndarray | None = None
    open_faces: np.ndarray | None = None

    @classmethod
    def build(cls, grid: Grid, bcs: VelocityBCs | None = None) -> Operators:
        """Assemble all operators of ``grid`` with wall conditions ``bcs``.

        Parameters
        ----------
        grid : Grid
        bcs : VelocityBCs, optional
            Default ``VelocityBCs()`` (no-slip base, free-slip elsewhere).

        Examples
        --------
        >>> ops = Operators.build(Grid(nx=3, nz=2, Lx=3.0, Lz=2.0))
        >>> ops.div.shape, ops.en.shape
        ((6, 7), (12, 7))
        """
        if not isinstance(grid, Grid):
            raise GranflowInputError(
                f"Operators.build: grid must be a Grid, got {type(grid).__name__}"
            )
        bcs = VelocityBCs() if bcs is None else bcs
        if not isinstance(bcs, VelocityBCs):
            raise GranflowInputError(
                f"Operators.build: bcs must be VelocityBCs, got {type(bcs).__name__}"
            )
        nx, nz, dx, dz = grid.nx, grid.nz, grid.dx, grid.dz
        ix, iz = _eye(nx), _eye(nz)
        sign = {side: GHOST_SIGN[bcs.kind(side)] for side in Side}
        if grid.periodic_x:
            walls = [s.value for s in (Side.WEST, Side.EAST) if bcs.kind(s) is not VelocityBC.FREE_SLIP]
            if walls:
                raise GranflowInputError(
                    f"Operators.build: the grid is periodic in x, it has no {' or '.join(walls)} wall; "
                    f"leave VelocityBCs.{walls[0]} at its default"
                )
            bx = periodic_blocks(nx, dx)
        else:
            bx = wall_blocks(nx, dx, sign[Side.WEST], sign[Side.EAST])
        bz = wall_blocks(nz, dz, sign[Side.BOTTOM], sign[Side.TOP])

        div_u = sp.kron(bx.diff, iz)                         # du/dx at cells
        div_w = sp.kron(ix, bz.diff)                         # dw/dz at cells
        div = sp.hstack([div_u, div_w], format="csr")
        ec = sp.hstack([div_u, -div_w], format="csr")

        du_dz = sp.kron(bx.faces_to_nodes, bz.tangential)    # du/dz at nodes
        dw_dx = sp.kron(bx.tangential, bz.faces_to_nodes)    # dw/dx at nodes
        en = sp.hstack([du_dz, dw_dx], format="csr")
        en.eliminate_zeros()

        weights = np.outer(_node_weights_1d(nx), _node_weights_1d(nz)).ravel()
        weights.setflags(write=False)

        c2x = sp.kron(bx.cell_to_faces, iz, format="csr")
        c2z = sp.kron(ix, bz.cell_to_faces, format="csr")
        return cls(
            grid=grid,
            bcs=bcs,
            div=div,
            grad=(-div.T).tocsr(),
            ec=ec,
            en=en,
            node_weights=weights,
            cell_to_xface=c2x,
            cell_to_zface=c2z,
            cell_to_face=sp.vstack([c2x, c2z], format="csr"),
            cell_to_node=sp.kron(bx.cell_to_nodes, bz.cell_to_nodes, format="csr"),
            node_to_cell=sp.kron(_mean_pairs(nx), _mean_pairs(nz), format="csr"),
        )

    # --- argument checks --------------------------------------------------------------------
    def _velocity(self, vel) -> np.ndarray:
        vel = np.asarray(vel, dtype=float)
        if vel.shape != (self.grid.n_unknowns,):
            raise GranflowInputError(
                f"vel must be the velocity unknown vector of shape ({self.grid.n_unknowns},), "
                f"got {vel.shape}"
            )
        return vel

    @staticmethod
    def _coefficient(name: str, value, shape: tuple[int, int]) -> np.ndarray:
        """Flat, finite, non-negative coefficient at ``shape`` points (scalar broadcast)."""
        a = np.asarray(value, dtype=float)
        size = shape[0] * shape[1]
        if a.ndim == 0:
            a = np.full(size, float(a))
        elif a.shape in (shape, (size,)):
            a = a.ravel()
        else:
            raise GranflowInputError(
                f"{name} must be a scalar or have shape {shape} or ({size},), got {a.shape}"
            )
        if not np.all(np.isfinite(a)) or np.any(a < 0.0):
            raise GranflowInputError(f"{name} must be finite and >= 0")
        return a

    # --- operators depending on fields ---------------------------------------------------------
    def viscous_operator(self, eta_c, eta_n) -> sp.csr_matrix:
        """Viscous/plastic operator ``V = ec^T diag(eta_c) ec + en^T diag(w_n eta_n) en``.

        Parameters
        ----------
        eta_c : float or array_like, shape ``(nx, nz)`` or ``(n_cells,)``
            Viscosity at cell centres [Pa s], >= 0.
        eta_n : float or array_like, shape ``(nx + 1, nz + 1)`` or ``(n_nodes,)``
            Viscosity at nodes [Pa s], >= 0 (e.g. ``cell_to_node @ eta_c``).

        Returns
        -------
        csr_matrix, (n_unknowns, n_unknowns)
            Symmetric positive semidefinite [Pa s m^-2]. ``V u`` approximates ``-div(2 eta S)``
            [N m^-3] at the interior faces (the force in the momentum equation is ``-V u``) and
            ``dV * u^T V u`` is the discrete dissipation :meth:`dissipation` [W m^-1]
            (NUMERICS.md §2, §9).
        """
        g = self.grid
        ec_w = self._coefficient("eta_c", eta_c, g.cell_shape)
        en_w = self._coefficient("eta_n", eta_n, g.node_shape) * self.node_weights
        v = self.ec.T @ sp.diags(ec_w) @ self.ec + self.en.T @ sp.diags(en_w) @ self.en
        return v.tocsr()

    def dissipation(self, vel, eta_c, eta_n) -> float:
        """Discrete dissipation ``dV [sum_c eta_c (ec u)^2 + sum_n w_n eta_n (en u)^2]`` [W m^-1].

        The integral of ``tau:S = 4 eta |S|^2`` over the box per unit width (NUMERICS.md §9);
        equal to ``dV * vel @ viscous_operator(eta_c, eta_n) @ vel``.
        """
        vel = self._velocity(vel)
        g = self.grid
        ec_w = self._coefficient("eta_c", eta_c, g.cell_shape)
        en_w = self._coefficient("eta_n", eta_n, g.node_shape) * self.node_weights
        return g.cell_volume * float(ec_w @ (self.ec @ vel) ** 2 + en_w @ (self.en @ vel) ** 2)

    def strain_rate_norm_squared(self, vel) -> np.ndarray:
        """``|S|^2 = S_xx^2 + S_xz^2`` at cell centres [s^-2], shape ``(n_cells,)``.

        ``S_xx = (ec u)/2`` at the cell; ``S_xz^2`` is the mean over the 4 corner nodes of
        ``((en u)/2)^2`` (NUMERICS.md §2), so ``|S|^2 = (ec u)^2/4 + <(en u)^2>/4``.
        """
        vel = self._velocity(vel)
        return 0.25 * (self.ec @ vel) ** 2 + 0.25 * (self.node_to_cell @ (self.en @ vel) ** 2)

    @cached_property
    def strain_rate(self) -> StrainRate:
        """:class:`granflow.strain_rate.StrainRate` of these operators (built once)."""
        from granflow.strain_rate import StrainRate

        return StrainRate(self)

    def strain_rate_on(self, cells) -> StrainRateOn:
        """:meth:`strain_rate_norm` on the cells of the bool mask ``cells`` only (see
        :class:`granflow.strain_rate.StrainRateOn`): the Picard sweeps need ``|S|`` where the
        closure is evaluated."""
        return self.strain_rate.on(cells)

    def strain_rate_norm(self, vel) -> np.ndarray:
        """``|S| = sqrt(S:S/2)`` at cell centres [s^-1], shape ``(n_cells,)``.

        Simple shear ``u = (gamma z, 0)`` gives ``gamma/2``; pure strain ``(a x, -a z)`` gives
        ``|a|``.
        """
        return np.sqrt(self.strain_rate_norm_squared(vel))

    def face_gradient(self, p) -> np.ndarray:
        """Gradient of a cell field at the interior faces, zero normal flux at walls [unit m^-1].

        Parameters
        ----------
        p : array_like, shape ``(nx, nz)`` or ``(n_cells,)``
            Cell-centred field.

        Returns
        -------
        ndarray, (n_unknowns,)
            ``(p[i] - p[i-1])/dx`` on interior x-faces then ``(p[j] - p[j-1])/dz`` on interior
            z-faces, i.e. ``grad @ p``. Wall faces carry no flux (Neumann), so
            ``div @ (k * face_gradient(p))`` is the conservative Laplacian with insulated walls.
            Dirichlet cells (e.g. p_f = 0 in the ambient, NUMERICS.md §8) are left to the caller.
        """
        a = np.asarray(p, dtype=float)
        g = self.grid
        if a.shape not in (g.cell_shape, (g.n_cells,)):
            raise GranflowInputError(
                f"p must have shape {g.cell_shape} or ({g.n_cells},), got {a.shape}"
            )
        return self.grad @ a.ravel()


def sorted_unique(a: np.ndarray) -> np.ndarray:
    """The sorted distinct values of the 1-D array ``a``, as ``np.unique(a)``, by one sort.

    Why: NumPy 2.4's ``np.unique`` hashes first (``_unique_hash``) and took 2.5 s on 1.5e6 int64
    keys, against 0.025 s for this (measured; the saddle assembler's keys at 256^2, 2 s of its
    set-up, growing faster than the grid)."""
    s = np.sort(np.asarray(a).ravel())
    if s.size == 0:
        return s
    keep = np.empty(s.size, dtype=bool)
    keep[0] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    return s[keep]


def product_pairs(B: sp.spmatrix, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All ``(key = k n + l, row r, B_rk B_rl)`` over pairs of non-zeros of each row of ``B``:
    the contributions of ``B^T diag(c) B``, vectorised over rows (loops only over the at most
    ``max_nnz_per_row^2`` pair positions). ``n`` is the number of columns of ``B``. Used to fill
    products such as the viscous block and the pore-gas operator on a fixed pattern, as a linear
    map of ``c`` (``physics.momentum.SaddleAssembler``, ``physics.pore_pressure``)."""
    B = sp.csr_matrix(B)
    B.eliminate_zeros()
    B.sort_indices()
    counts = np.diff(B.indptr)
    keys, rows, vals = [], [], []
    for a in range(int(counts.max(initial=0))):
        for b in range(int(counts.max(initial=0))):
            r = np.flatnonzero(counts > max(a, b))
            ia, ib = B.indptr[r] + a, B.indptr[r] + b
            keys.append(B.indices[ia].astype(np.int64) * n + B.indices[ib])
            rows.append(r)
            vals.append(B.data[ia] * B.data[ib])
    return np.concatenate(keys), np.concatenate(rows), np.concatenate(vals)
