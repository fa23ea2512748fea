"""Topography: a base profile ``z_b(x)`` as a staircase of solid cells inside the box (issue 14 item 3).

Geometry
--------
A :class:`Topography` is a piecewise-linear base profile through points ``(x_k, z_k)`` [m],
continued at constant height beyond its ends. On a :class:`~granflow.grid.Grid` it marks a cell
**solid** when its centre lies below the profile, ``z_c < z_b(x_c)``
(:meth:`Topography.solid_cells`). The solid cells of each column are therefore the lowest ones
(the mask is contiguous from the base up), which is what :func:`masked_operators` relies on.
The representation is a staircase: first order in the position of the base (an error of at most
half a cell in z), the cut-cell alternative being left for later (docs/solver.md, "Topography").

Faces and nodes (MAC grid, :mod:`granflow.operators`)
------------------------------------------------------
* A velocity face between two fluid cells is **open**; a face with a solid cell on one side is a
  **wall face** (its normal velocity is zero, as on the box walls); a face between two solid cells
  is **buried**. Only open faces carry velocity: the model keeps them in its velocity region
  (:class:`granflow.physics.momentum.VelocityRegion`), the others are ``u = 0``.
* A node's control-volume weight is the box weight (1, 1/2, 1/4) times the fraction of its
  neighbouring cells that are fluid: 1/2 on a flat piece of base, 3/4 at the edge of a step,
  1/4 at its foot. On the box walls this is the box's own rule (:data:`WALL_NODE_WEIGHT`).
* The tangential shear at a node on a flat piece of base (two solid cells below, two fluid cells
  above -- a tread --, or the same turned by 90 degrees at a step's side -- a riser) reads the
  buried face across the wall as the ghost ``sign * mirror`` of the open face on the other side,
  exactly as a box wall does (NUMERICS.md §8): ``sign = -1`` for no-slip, ``+1`` for free slip;
  a Coulomb base has the no-slip ghost on its treads (where its friction acts) and free-slip
  risers (:func:`profile_ghost_signs`). With that,
  a Couette profile above a raised floor has the same discrete shear and viscous residual as one
  above the box's base (tests/unit/test_topography.py). Every other reference to a wall or buried
  face reads the wall's value, zero.

``div`` and ``ec`` read only open faces and ``grad = -div^T`` still holds exactly, so the discrete
energy identity of :mod:`granflow.operators` holds on the fluid cells.

References
----------
NUMERICS.md §2, §8 (MAC operators, wall ghosts); issue 14 item 3 (topography).
"""
from __future__ import annotations

import csv
import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from granflow.errors import GranflowInputError
from granflow.grid import Grid, Side, VelocityBC
from granflow.operators import GHOST_SIGN, Operators

MIN_FLUID_CELLS = 2
"""Fewest fluid cells above the profile in every column (a column needs an interior z-face)."""


def _as_points(name: str, value) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise GranflowInputError(f"{name} must be a list of numbers, got {value!r}") from None
    if a.ndim != 1 or a.size < 1:
        raise GranflowInputError(f"{name} must be a non-empty 1-D list of numbers, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise GranflowInputError(f"{name} must be finite, got {a.tolist()}")
    return a


@dataclass(frozen=True, eq=False)
class Topography:
    """A base profile ``z_b(x)``: piecewise linear through ``(x[k], z[k])`` [m], constant beyond.

    Parameters
    ----------
    x, z : sequence of float
        Abscissae [m], strictly increasing, and the base height at each [m]. One point is a flat
        raised floor.

    Examples
    --------
    >>> t = Topography(x=[0.0, 1.0, 2.0], z=[0.5, 0.0, 0.0])   # a slope meeting a flat run-out
    >>> float(t.height(0.5)), float(t.height(3.0))
    (0.25, 0.0)
    """

    x: np.ndarray
    z: np.ndarray

    def __post_init__(self) -> None:
        x, z = _as_points("topography x", self.x), _as_points("topography z", self.z)
        if x.size != z.size:
            raise GranflowInputError(f"topography: x and z must have the same length, got {x.size} and {z.size}")
        if np.any(np.diff(x) <= 0.0):
            raise GranflowInputError(f"topography: x must be strictly increasing, got {x.tolist()}")
        for name, a in (("x", x), ("z", z)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @classmethod
    def from_csv(cls, path) -> Topography:
        """Read a profile from a CSV file of two columns ``x, z`` [m] (a header line is allowed)."""
        path = Path(path)
        if not path.is_file():
            raise GranflowInputError(f"topography file {str(path)!r} does not exist")
        rows = []
        with path.open(newline="") as fh:
            for k, row in enumerate(csv.reader(fh)):
                cells = [c.strip() for c in row if c.strip()]
                if not cells or cells[0].startswith("#"):
                    continue
                try:
                    rows.append([float(c) for c in cells])
                except ValueError:
                    if k == 0 and not rows:
                        continue  # a header
                    raise GranflowInputError(f"topography file {str(path)!r}, line {k + 1}: "
                                             f"expected two numbers x, z, got {row!r}") from None
                if len(rows[-1]) != 2:
                    raise GranflowInputError(f"topography file {str(path)!r}, line {k + 1}: "
                                             f"expected two columns x, z, got {len(rows[-1])}")
        if not rows:
            raise GranflowInputError(f"topography file {str(path)!r} holds no x, z rows")
        a = np.asarray(rows)
        return cls(x=a[:, 0], z=a[:, 1])

    def height(self, x) -> np.ndarray:
        """Base height ``z_b`` at ``x`` [m] (linear between the points, constant beyond)."""
        return np.interp(np.asarray(x, dtype=float), self.x, self.z)

    def solid_cells(self, grid: Grid) -> np.ndarray:
        """bool ``(nx, nz)``: cells whose centre is below the profile (module docstring).

        Raises
        ------
        GranflowInputError
            When a column keeps fewer than :data:`MIN_FLUID_CELLS` fluid cells, naming its x.
        """
        zb = self.height(grid.xc)
        solid = grid.zc[None, :] < zb[:, None]
        fluid = grid.nz - solid.sum(axis=1)
        bad = np.flatnonzero(fluid < MIN_FLUID_CELLS)
        if bad.size:
            i = int(bad[0])
            raise GranflowInputError(
                f"topography: the base z_b = {zb[i]:.6g} m at x = {grid.xc[i]:.6g} m leaves {int(fluid[i])} "
                f"cell(s) of the box (top at z = {grid.z0 + grid.Lz:.6g} m) above it; at least "
                f"{MIN_FLUID_CELLS} are needed: lower the profile or raise grid.Lz")
        solid.setflags(write=False)
        return solid


@dataclass(frozen=True)
class FaceClasses:
    """Open / wall / buried velocity unknowns of a solid mask (module docstring), bool ``(n_unknowns,)``."""

    open: np.ndarray
    wall: np.ndarray
    buried: np.ndarray


def face_classes(grid: Grid, solid) -> FaceClasses:
    """Classify the velocity unknowns of ``grid`` by the number of solid cells beside each face."""
    solid = _check_mask(grid, solid)
    s = solid.astype(int)
    if grid.periodic_x:
        sx = s + np.roll(s, 1, axis=0)                 # x-face i between cells i-1 (wrapped) and i
    else:
        sx = s[:-1] + s[1:]                            # interior x-faces 1..nx-1
    sz = s[:, :-1] + s[:, 1:]                          # interior z-faces
    n_solid = np.concatenate([sx.ravel(), sz.ravel()])
    return FaceClasses(open=n_solid == 0, wall=n_solid == 1, buried=n_solid == 2)


def _check_mask(grid: Grid, solid) -> np.ndarray:
    solid = np.asarray(solid)
    if solid.shape not in (grid.cell_shape, (grid.n_cells,)) or solid.dtype != bool:
        raise GranflowInputError(f"solid must be a bool array of shape {grid.cell_shape}, "
                                 f"got {solid.dtype} {solid.shape}")
    solid = solid.reshape(grid.cell_shape)
    above = np.diff(solid.astype(int), axis=1)
    if np.any(above > 0):
        i = int(np.flatnonzero(np.any(above > 0, axis=1))[0])
        raise GranflowInputError(f"solid: column {i} has a fluid cell below a solid one; the solid "
                                 f"cells of each column must be its lowest ones (a base profile)")
    return solid


def _mirror_ghosts(ops: Operators, cls: FaceClasses, tread: float, riser: float) -> sp.csr_matrix:
    """``en`` with each buried tangential face replaced by a sign x its mirror open face across
    the node (a flat piece of wall: ``tread`` for a buried u face under a horizontal piece,
    ``riser`` for a buried w face beside a vertical one), and every other wall or buried entry
    dropped."""
    g = ops.grid
    en = ops.en.tocoo()
    rows, cols, vals = en.row.astype(np.int64), en.col.astype(np.int64), en.data.copy()
    n_nodes_z = g.nz + 1
    ni, nj = rows // n_nodes_z, rows % n_nodes_z
    is_u = cols < g.n_u
    # the mirror of a tangential face across node (ni, nj): u faces (i, j - 1) <-> (i, j), w faces
    # (i - 1, j) <-> (i, j), as unknown indices
    uj = cols % g.nz
    ui = cols // g.nz                                   # u unknown column (periodic: = x-face index)
    u_mirror_j = 2 * nj - 1 - uj
    wc = cols - g.n_u
    wi, wj = wc // (g.nz - 1), wc % (g.nz - 1)          # w unknown (i, j - 1)
    w_mirror_i = 2 * ni - 1 - wi
    if g.periodic_x:
        w_mirror_i = w_mirror_i % g.nx
    mirror = np.where(is_u, ui * g.nz + u_mirror_j, g.n_u + w_mirror_i * (g.nz - 1) + wj)
    valid = np.where(is_u, (u_mirror_j >= 0) & (u_mirror_j < g.nz),
                     (w_mirror_i >= 0) & (w_mirror_i < g.nx))
    mirror = np.where(valid, mirror, 0)
    buried = cls.buried[cols]
    ghost = buried & valid & cls.open[mirror]
    keep = cls.open[cols]
    out_rows = np.concatenate([rows[keep], rows[ghost]])
    out_cols = np.concatenate([cols[keep], mirror[ghost]])
    sign = np.where(is_u, tread, riser)
    out_vals = np.concatenate([vals[keep], sign[ghost] * vals[ghost]])
    m = sp.csr_matrix((out_vals, (out_rows, out_cols)), shape=ops.en.shape)  # duplicates summed
    m.eliminate_zeros()
    return m


def _mean_over(m: sp.csr_matrix, keep: np.ndarray) -> sp.csr_matrix:
    """The mean of ``m`` (a row-normalised averaging map) over the columns of ``keep`` only; a row
    with none of them (a face or node inside the solid) keeps its mean over all its cells, so
    that harmonic means such as ``1/(c2f @ (1/k))`` stay finite there."""
    m = sp.csr_matrix(m)
    kept = sp.csr_matrix(m @ sp.diags(keep.astype(float)))
    kept.eliminate_zeros()
    counts = np.diff(kept.indptr)
    kept.data = np.repeat(1.0 / np.maximum(counts, 1), counts)
    inside = sp.diags((counts == 0).astype(float)) @ m
    out = sp.csr_matrix(kept + inside)
    out.eliminate_zeros()
    return out


def profile_ghost_signs(base: VelocityBC) -> tuple[float, float]:
    """Ghost signs ``(tread, riser)`` of the profile for the base condition ``base``: the box
    base's own sign on both (:data:`granflow.operators.GHOST_SIGN`), but for a Coulomb base whose
    risers are free-slip (its friction, :mod:`granflow.physics.wall_friction`, acts on the treads:
    a riser is the staircase's artefact of a slope, not a wall the grains rub along)."""
    if base is VelocityBC.COULOMB:
        return GHOST_SIGN[VelocityBC.COULOMB], GHOST_SIGN[VelocityBC.FREE_SLIP]
    return GHOST_SIGN[base], GHOST_SIGN[base]


def masked_operators(ops: Operators, solid) -> Operators:
    """The operators of ``ops`` on the fluid cells of the solid mask ``solid`` (module docstring).

    Parameters
    ----------
    ops : Operators
        The box operators (:meth:`Operators.build`); the tangential condition of the base,
        ``ops.bcs.bottom``, applies to the whole profile.
    solid : bool array, ``(nx, nz)``
        Solid cells, the lowest ones of each column (:meth:`Topography.solid_cells`).

    Returns
    -------
    Operators
        With ``solid`` (flat bool) and ``open_faces`` set; ``div``, ``ec`` and ``en`` read only
        open faces (``en`` with the wall ghosts), ``grad = -div^T``, node weights scaled by the
        fluid fraction around each node, and the cell-to-face / cell-to-node means taken over fluid
        cells only.
    """
    g = ops.grid
    solid = _check_mask(g, solid)
    fluid = ~solid.ravel()
    cls = face_classes(g, solid)
    if not fluid.any():
        raise GranflowInputError("solid: every cell is solid")
    keep = sp.diags(cls.open.astype(float))
    div = sp.csr_matrix(ops.div @ keep)
    div.eliminate_zeros()
    ec = sp.csr_matrix(ops.ec @ keep)
    ec.eliminate_zeros()
    en = _mirror_ghosts(ops, cls, *profile_ghost_signs(ops.bcs.kind(Side.BOTTOM)))
    box_c2n = ops.cell_to_node
    weights = np.asarray(ops.node_weights) * (box_c2n @ fluid.astype(float))
    weights.setflags(write=False)
    c2x = _mean_over(ops.cell_to_xface, fluid)
    c2z = _mean_over(ops.cell_to_zface, fluid)
    solid_flat = solid.ravel().copy()
    solid_flat.setflags(write=False)
    open_faces = cls.open.copy()
    open_faces.setflags(write=False)
    return dataclasses.replace(
        ops, div=div, grad=(-div.T).tocsr(), ec=ec, en=en, node_weights=weights,
        cell_to_xface=c2x, cell_to_zface=c2z, cell_to_face=sp.vstack([c2x, c2z], format="csr"),
        cell_to_node=_mean_over(box_c2n, fluid), solid=solid_flat, open_faces=open_faces)


def base_height(grid: Grid, solid=None) -> np.ndarray:
    """Height of the staircase's base in each column, ``z0 + n_solid dz`` [m], shape ``(nx,)``
    (``z0`` everywhere without a solid mask)."""
    if solid is None:
        return np.full(grid.nx, grid.z0)
    return grid.z0 + _check_mask(grid, solid).sum(axis=1) * grid.dz


def staircase_error(topography: Topography, grid: Grid) -> float:
    """Largest |staircase base - profile| over the cell centres [m] (at most dz/2 by construction)."""
    zs = base_height(grid, topography.solid_cells(grid))
    return float(np.max(np.abs(zs - topography.height(grid.xc)), initial=0.0))
