"""Uniform MAC (marker-and-cell) staggered grid of a closed rectangular box, or of a layer
periodic in x; wall conditions.

Layout (NUMERICS.md §2; Harlow & Welch, Phys. Fluids 8, 2182, 1965): the domain
``[x0, x0 + Lx] x [z0, z0 + Lz]`` is cut into ``nx x nz`` cells of size ``dx x dz``.

=================  =============  ===============================================
location           array shape    carries
=================  =============  ===============================================
cell centres       (nx, nz)       phi, p, p_f, I, eta_c (scalars)
x-faces            (nx + 1, nz)   u (horizontal velocity)
z-faces            (nx, nz + 1)   w (vertical velocity)
nodes (corners)    (nx + 1, nz + 1)  shear rate du/dz + dw/dx, eta_n
=================  =============  ===============================================

Axis 0 is x, axis 1 is z, so ``field[i, j]`` sits at ``(x_i, z_j)``. Flattened fields use
NumPy's C order (index ``i * n_z_points + j``).

The box is closed: the normal velocity vanishes on every wall, so the velocity unknowns are the
*interior* faces only, ``u[1:-1, :]`` (shape ``(nx - 1, nz)``) then ``w[:, 1:-1]`` (shape
``(nx, nz - 1)``), concatenated in that order into one vector of length :attr:`Grid.n_unknowns`
(see :meth:`Grid.pack_velocity` / :meth:`Grid.unpack_velocity`). The tangential condition of each
wall (no-slip or free-slip) is a :class:`VelocityBCs`; it enters the operators only through the
shear rate at the wall nodes (:mod:`granflow.operators`). The grid knows nothing of gravity,
cases or output.

Periodic in x (``periodic_x=True``; issue 3 item 9c, steady flows on an infinite incline). The x
direction wraps: there are no west/east walls, the cell ``i = -1`` is the cell ``nx - 1``, and the
x-face ``nx`` (at ``x0 + Lx``) *is* the x-face 0. The full arrays keep their shapes -- u on
``(nx + 1, nz)`` x-faces, nodes ``(nx + 1, nz + 1)`` -- with the last x-column the periodic
IMAGE of the first (identification layout): this keeps every full-array formula of the closed box
(``np.diff`` divergences of face fluxes, node averages) valid unchanged. The u unknowns are the nx
distinct x-faces ``u[:-1, :]`` (shape ``(nx, nz)``, so :attr:`Grid.n_u` = ``nx nz``);
:meth:`Grid.unpack_velocity` fills the image column ``u[-1] = u[0]``. The w unknowns are unchanged
(interior z-faces; base and top are walls). Node quantities live on the ``(nx + 1)`` node columns
with columns 0 and nx carrying identical values; a node's control volume is split equally
between it and its image (weight 1/2 each in x, :mod:`granflow.operators`), so every node sum
counts each physical node once. The west/east entries of :class:`VelocityBCs` have no wall to
act on and must stay at their default (:mod:`granflow.operators` rejects a ``no_slip`` there).
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from enum import Enum
from functools import cached_property
from typing import NamedTuple

import numpy as np

from granflow.errors import GranflowInputError

MIN_CELLS = 2
"""Smallest number of cells per direction (at least one interior face in each direction)."""


class Side(Enum):
    """The four walls of the box."""

    WEST = "west"
    """x = x0."""
    EAST = "east"
    """x = x0 + Lx."""
    BOTTOM = "bottom"
    """z = z0 (the base)."""
    TOP = "top"
    """z = z0 + Lz."""


class Geometry(str, Enum):
    """What the grid's x axis is (issue 14 item 4)."""

    PLANE = "plane"
    """A vertical plane, fields per unit width (the paper's set-up)."""
    AXISYMMETRIC = "axisymmetric"
    """(r, z): x is the radius, the west side ``x0 = 0`` the axis of symmetry; every integral is
    over the full cylinder (:attr:`Grid.cell_volumes`, :mod:`granflow.axisymmetric`)."""


class RadialMetric(NamedTuple):
    """Circumferences ``2 pi r`` of an axisymmetric grid [m] as column vectors (broadcast over z):
    ``faces`` (nx + 1, 1) at the x-faces, ``cells`` (nx, 1) at the cell centres. A cell's volume
    is ``cells dx dz`` [m^3]; the area of its x-faces ``faces dz``, of its z-faces ``cells dx``
    [m^2]."""

    faces: np.ndarray
    cells: np.ndarray


class VelocityBC(Enum):
    """Tangential velocity condition on a wall (the normal velocity of the solve is always zero:
    closed box; an ``OUTFLOW`` wall lets grains out through its absorbing column)."""

    NO_SLIP = "no_slip"
    """Tangential velocity zero on the wall (ghost value = -interior value, NUMERICS.md §8)."""
    FREE_SLIP = "free_slip"
    """Zero shear stress on the wall: zero normal gradient of the tangential velocity."""
    COULOMB = "coulomb"
    """Base only: the no-slip ghost, with the wall's shear stress capped at the Coulomb friction
    ``mu_w p_wall`` (the layer slides when the interior would carry more;
    :mod:`granflow.physics.wall_friction`)."""
    OUTFLOW = "outflow"
    """East wall only: free-slip in the solve, and the last column of cells absorbs the grains
    that reach it -- they leave the box (:mod:`granflow.physics.outflow`)."""


@dataclass(frozen=True)
class VelocityBCs:
    """Tangential velocity condition of each wall (NUMERICS.md §8).

    Attributes
    ----------
    west, east, bottom, top : VelocityBC or str
        Condition on each wall; strings ``"no_slip"`` / ``"free_slip"`` / ``"coulomb"`` /
        ``"outflow"`` are converted. Defaults: no-slip base, free-slip side walls and top. ``"coulomb"`` is a base
        condition only (its friction coefficient is :class:`granflow.model.Model`'s
        ``wall_friction``), ``"outflow"`` an east-wall one.
    """

    west: VelocityBC = VelocityBC.FREE_SLIP
    east: VelocityBC = VelocityBC.FREE_SLIP
    bottom: VelocityBC = VelocityBC.NO_SLIP
    top: VelocityBC = VelocityBC.FREE_SLIP

    def __post_init__(self) -> None:
        for side in Side:
            value = getattr(self, side.value)
            if isinstance(value, VelocityBC):
                continue
            try:
                converted = VelocityBC(value)
            except ValueError:
                allowed = ", ".join(repr(k.value) for k in VelocityBC)
                raise GranflowInputError(
                    f"VelocityBCs: invalid condition {value!r} for wall {side.value!r}; "
                    f"expected one of {allowed}"
                ) from None
            object.__setattr__(self, side.value, converted)
        for side in (Side.WEST, Side.EAST, Side.TOP):
            if getattr(self, side.value) is VelocityBC.COULOMB:
                raise GranflowInputError(f"VelocityBCs: 'coulomb' is a base condition (bottom wall) only, "
                                         f"got it for wall {side.value!r}")
        for side in (Side.WEST, Side.BOTTOM, Side.TOP):
            if getattr(self, side.value) is VelocityBC.OUTFLOW:
                raise GranflowInputError(f"VelocityBCs: 'outflow' is an east-wall condition only, "
                                         f"got it for wall {side.value!r}")

    def kind(self, side: Side) -> VelocityBC:
        """Condition on wall ``side``."""
        return getattr(self, Side(side).value)

    @classmethod
    def uniform(cls, kind: VelocityBC | str) -> VelocityBCs:
        """The same condition ``kind`` on all four walls."""
        return cls(**{side.value: kind for side in Side})


def _check_count(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise GranflowInputError(f"Grid: {name} must be an integer, got {value!r}")
    if value < MIN_CELLS:
        raise GranflowInputError(f"Grid: {name} must be >= {MIN_CELLS}, got {value}")
    return int(value)


def _check_real(name: str, value, positive: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise GranflowInputError(f"Grid: {name} must be a real number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise GranflowInputError(f"Grid: {name} must be finite, got {value}")
    if positive and value <= 0.0:
        raise GranflowInputError(f"Grid: {name} must be > 0, got {value}")
    return value


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Grid:
    """Uniform MAC grid of the closed box ``[x0, x0 + Lx] x [z0, z0 + Lz]`` (NUMERICS.md §2, §13).

    Parameters
    ----------
    nx, nz : int
        Number of cells in x and z (>= 2 each).
    Lx, Lz : float
        Box length and height [m] (> 0, finite).
    x0, z0 : float, optional
        Coordinates of the bottom-left corner [m]. Default 0.
    periodic_x : bool, optional
        Wrap the x direction (period ``Lx``; module docstring). Default False (closed box).
    geometry : Geometry or str, optional
        ``"plane"`` (default) or ``"axisymmetric"``: x is the radius r, ``x0`` must be 0 (the
        axis) and the grid not periodic (:class:`Geometry`).

    Raises
    ------
    GranflowInputError
        (a ``ValueError``) naming the bad argument.

    Notes
    -----
    Coordinate arrays are read-only and computed on first access. Cell "volumes" are areas per
    unit width, ``dx * dz`` [m^2]; every interior face and every cell has this control volume.

    Examples
    --------
    >>> g = Grid(nx=4, nz=2, Lx=2.0, Lz=1.0)
    >>> g.dx, g.dz, g.n_unknowns
    (0.5, 0.5, 10)
    >>> g.xc
    array([0.25, 0.75, 1.25, 1.75])
    >>> Grid(nx=4, nz=2, Lx=2.0, Lz=1.0, periodic_x=True).n_unknowns   # 4 x 2 u + 4 x 1 w
    12
    """

    nx: int
    nz: int
    Lx: float
    Lz: float
    x0: float = 0.0
    z0: float = 0.0
    periodic_x: bool = False
    geometry: Geometry = Geometry.PLANE

    def __post_init__(self) -> None:
        object.__setattr__(self, "nx", _check_count("nx", self.nx))
        object.__setattr__(self, "nz", _check_count("nz", self.nz))
        object.__setattr__(self, "Lx", _check_real("Lx", self.Lx, positive=True))
        object.__setattr__(self, "Lz", _check_real("Lz", self.Lz, positive=True))
        object.__setattr__(self, "x0", _check_real("x0", self.x0, positive=False))
        object.__setattr__(self, "z0", _check_real("z0", self.z0, positive=False))
        if not isinstance(self.periodic_x, (bool, np.bool_)):
            raise GranflowInputError(f"Grid: periodic_x must be a bool, got {self.periodic_x!r}")
        object.__setattr__(self, "periodic_x", bool(self.periodic_x))
        try:
            object.__setattr__(self, "geometry", Geometry(self.geometry))
        except ValueError:
            raise GranflowInputError(f"Grid: geometry must be one of {[k.value for k in Geometry]}, "
                                     f"got {self.geometry!r}") from None
        if self.geometry is Geometry.AXISYMMETRIC:
            if self.periodic_x:
                raise GranflowInputError("Grid: an axisymmetric grid cannot be periodic in r (periodic_x)")
            if self.x0 != 0.0:
                raise GranflowInputError(f"Grid: the axis of an axisymmetric grid is r = 0, so x0 must be 0 "
                                         f"(got {self.x0})")

    # --- spacings ---------------------------------------------------------------------------
    @property
    def dx(self) -> float:
        """Cell width [m]."""
        return self.Lx / self.nx

    @property
    def dz(self) -> float:
        """Cell height [m]."""
        return self.Lz / self.nz

    @property
    def cell_volume(self) -> float:
        """Control volume of a cell or of an interior face, ``dx * dz`` [m^2 per unit width]; in
        an axisymmetric grid the area of its (r, z) section (the volume is :attr:`cell_volumes`)."""
        return self.dx * self.dz

    @property
    def axisymmetric(self) -> bool:
        """True for an (r, z) grid (:class:`Geometry`)."""
        return self.geometry is Geometry.AXISYMMETRIC

    @cached_property
    def radial(self) -> RadialMetric | None:
        """The circumferences of an axisymmetric grid (:class:`RadialMetric`), None in a plane."""
        if not self.axisymmetric:
            return None
        return RadialMetric(faces=_readonly(2.0 * np.pi * self.xf[:, None]),
                            cells=_readonly(2.0 * np.pi * self.xc[:, None]))

    @cached_property
    def unknown_metric(self) -> np.ndarray | None:
        """``2 pi r`` at the velocity unknowns (n_unknowns,) [m]: the dual cell of a u face is
        centred on its radius, that of a w face on its cell's; None in a plane. A momentum row
        times this weight is integrated over the full circumference."""
        if not self.axisymmetric:
            return None
        rad = self.radial
        return _readonly(np.concatenate([np.repeat(rad.faces[1:-1, 0], self.nz),
                                         np.repeat(rad.cells[:, 0], self.nz - 1)]))

    @cached_property
    def cell_volumes(self) -> np.ndarray:
        """Control volume of every cell, (nx, nz): ``dx dz`` [m^2 per unit width] in a plane,
        ``2 pi r_c dx dz`` [m^3] in an axisymmetric grid."""
        vol = np.full(self.cell_shape, self.cell_volume)
        if self.axisymmetric:
            vol = vol * self.radial.cells
        return _readonly(vol)

    # --- 1-D coordinates --------------------------------------------------------------------
    @cached_property
    def xc(self) -> np.ndarray:
        """Cell-centre x coordinates, shape ``(nx,)`` [m]."""
        return _readonly(self.x0 + (np.arange(self.nx) + 0.5) * self.dx)

    @cached_property
    def zc(self) -> np.ndarray:
        """Cell-centre z coordinates, shape ``(nz,)`` [m]."""
        return _readonly(self.z0 + (np.arange(self.nz) + 0.5) * self.dz)

    @cached_property
    def xf(self) -> np.ndarray:
        """x coordinates of x-faces and nodes, shape ``(nx + 1,)`` [m] (walls included; periodic:
        the last is the image of the first)."""
        return _readonly(self.x0 + np.arange(self.nx + 1) * self.dx)

    @cached_property
    def zf(self) -> np.ndarray:
        """z coordinates of z-faces and nodes, shape ``(nz + 1,)`` [m] (walls included)."""
        return _readonly(self.z0 + np.arange(self.nz + 1) * self.dz)

    # --- 2-D coordinates (meshgrid, indexing="ij") --------------------------------------------
    def cell_coords(self) -> tuple[np.ndarray, np.ndarray]:
        """``(X, Z)`` of the cell centres, each of shape ``(nx, nz)`` [m]."""
        return np.meshgrid(self.xc, self.zc, indexing="ij")

    def xface_coords(self) -> tuple[np.ndarray, np.ndarray]:
        """``(X, Z)`` of all x-faces (u points), each of shape ``(nx + 1, nz)`` [m]."""
        return np.meshgrid(self.xf, self.zc, indexing="ij")

    def zface_coords(self) -> tuple[np.ndarray, np.ndarray]:
        """``(X, Z)`` of all z-faces (w points), each of shape ``(nx, nz + 1)`` [m]."""
        return np.meshgrid(self.xc, self.zf, indexing="ij")

    def node_coords(self) -> tuple[np.ndarray, np.ndarray]:
        """``(X, Z)`` of the nodes (cell corners), each of shape ``(nx + 1, nz + 1)`` [m]."""
        return np.meshgrid(self.xf, self.zf, indexing="ij")

    # --- shapes and sizes -------------------------------------------------------------------
    @property
    def cell_shape(self) -> tuple[int, int]:
        """``(nx, nz)``."""
        return (self.nx, self.nz)

    @property
    def xface_shape(self) -> tuple[int, int]:
        """Shape of a full u array, ``(nx + 1, nz)``."""
        return (self.nx + 1, self.nz)

    @property
    def zface_shape(self) -> tuple[int, int]:
        """Shape of a full w array, ``(nx, nz + 1)``."""
        return (self.nx, self.nz + 1)

    @property
    def node_shape(self) -> tuple[int, int]:
        """``(nx + 1, nz + 1)``."""
        return (self.nx + 1, self.nz + 1)

    @property
    def n_cells(self) -> int:
        """Number of cells, ``nx * nz``."""
        return self.nx * self.nz

    @property
    def n_nodes(self) -> int:
        """Number of nodes, ``(nx + 1) * (nz + 1)``."""
        return (self.nx + 1) * (self.nz + 1)

    @property
    def n_xfaces(self) -> int:
        """Number of x-face columns carrying u unknowns: ``nx - 1`` (interior), ``nx`` periodic."""
        return self.nx if self.periodic_x else self.nx - 1

    @property
    def u_columns(self) -> slice:
        """Columns of a full u array ``(nx + 1, nz)`` that are unknowns: ``1:-1`` (closed box) or
        ``:-1`` (periodic; column nx is the image of column 0)."""
        return slice(0, -1) if self.periodic_x else slice(1, -1)

    @property
    def n_u(self) -> int:
        """Number of u unknowns, ``(nx - 1) * nz`` (interior x-faces) or ``nx * nz`` (periodic)."""
        return self.n_xfaces * self.nz

    @property
    def n_w(self) -> int:
        """Number of interior z-faces (w unknowns), ``nx * (nz - 1)``."""
        return self.nx * (self.nz - 1)

    @property
    def n_unknowns(self) -> int:
        """Length of the velocity unknown vector, ``n_u + n_w``."""
        return self.n_u + self.n_w

    @property
    def u_slice(self) -> slice:
        """Slice of the u unknowns in the velocity vector."""
        return slice(0, self.n_u)

    @property
    def w_slice(self) -> slice:
        """Slice of the w unknowns in the velocity vector."""
        return slice(self.n_u, self.n_unknowns)

    # --- velocity vector <-> face arrays -------------------------------------------------------
    def pack_velocity(self, u, w) -> np.ndarray:
        """Velocity unknown vector from full face arrays.

        Parameters
        ----------
        u : array_like, shape ``(nx + 1, nz)``
            Horizontal velocity on all x-faces [m s^-1].
        w : array_like, shape ``(nx, nz + 1)``
            Vertical velocity on all z-faces [m s^-1].

        Returns
        -------
        ndarray, shape ``(n_unknowns,)``
            ``[u[1:-1, :].ravel(), w[:, 1:-1].ravel()]``. Wall (normal) values are discarded:
            the closed box imposes zero normal velocity. Periodic in x: ``u[:-1, :]`` (the image
            column ``u[-1]`` is discarded).
        """
        u = np.asarray(u, dtype=float)
        w = np.asarray(w, dtype=float)
        if u.shape != self.xface_shape:
            raise GranflowInputError(
                f"pack_velocity: u must have shape {self.xface_shape}, got {u.shape}"
            )
        if w.shape != self.zface_shape:
            raise GranflowInputError(
                f"pack_velocity: w must have shape {self.zface_shape}, got {w.shape}"
            )
        return np.concatenate([u[self.u_columns, :].ravel(), w[:, 1:-1].ravel()])

    def unpack_velocity(self, vel) -> tuple[np.ndarray, np.ndarray]:
        """Full face arrays ``(u, w)`` from the unknown vector, zero normal velocity on the walls.

        Parameters
        ----------
        vel : array_like, shape ``(n_unknowns,)``
            Velocity unknowns [m s^-1] (see :meth:`pack_velocity`).

        Returns
        -------
        u : ndarray, shape ``(nx + 1, nz)``
            Zero on the west/east walls; periodic in x: ``u[-1] = u[0]``.
        w : ndarray, shape ``(nx, nz + 1)``
        """
        vel = np.asarray(vel, dtype=float)
        if vel.shape != (self.n_unknowns,):
            raise GranflowInputError(
                f"unpack_velocity: vel must have shape ({self.n_unknowns},), got {vel.shape}"
            )
        u = np.zeros(self.xface_shape)
        w = np.zeros(self.zface_shape)
        u[self.u_columns, :] = vel[self.u_slice].reshape(self.n_xfaces, self.nz)
        if self.periodic_x:
            u[-1, :] = u[0, :]
        w[:, 1:-1] = vel[self.w_slice].reshape(self.nx, self.nz - 1)
        return u, w
