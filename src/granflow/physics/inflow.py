"""An inflow (source) boundary (``[inflow]``, issue 14 item 2): a prescribed supply of grains, with
their packing, velocity and pore pressure, through part of the west wall or of the base -- a
sustained current fed at a constant rate (e.g. Rowley et al. 2014's sustained flows).

The source is a strip of **source cells** along the wall: the cells of the first column (west) or
of the bottom row (base) whose centre lies within ``[lower, upper]`` along that side. While the
source is on (``start <= t < stop``):

* in the (u, p, p_f) solve the velocity of the faces of the source cells is held at the supply's:
  ``speed`` [m s^-1] into the box on the faces parallel to the wall (for a west source, the x-faces
  between the first and the second column; for a base source, the z-faces between the first and
  the second row), 0 on the faces between two source cells. It is a Brinkman penalisation
  (Angot, Bruneau & Fabrie 1999, Numer. Math. 81, 497): the term ``lambda (u_in - u)`` with
  ``lambda = PENALTY (rho_s phi_in / dt)`` [kg m^-3 s^-1] joins the momentum rows of those faces,
  so ``|u - u_in| ~ |u_in| / PENALTY``. Its work ``P_src = dV sum lambda (u_in - u) u`` [W m^-1]
  is the power of the supply, a physical input of the energy budget;
* the source cells carry no dilatancy row (``p = 0``, free in the active set): they are a source
  of volume, ``div u = speed / dx`` there, which no constitutive law describes;
* with gas, the source cells have no gas row: ``p_f = 0`` there (the incoming grains carry gas at
  atmospheric pressure, and the source's volume supply does not decompress it; a pressurised
  supply is not implemented);
* at the start of each step the source cells are refilled: solid fraction ``phi_in`` [-], material
  fraction ``c = 1``, ``p_f = 0``. What the refill adds -- solid volume, and the kinetic,
  potential and gas energy that come with it -- is counted as inflow in the budgets
  (:func:`granflow.physics.outflow.exchange`, with the opposite sign of an outflow).

The supplied volume flux is therefore ``q = phi_in speed n h`` [m^2 s^-1 of solid] (``n`` source
cells of height, or width, ``h``: ``phi_in speed (upper - lower)`` when the span's ends are cell
faces; :meth:`Source.flux`), to within the transport's face value of the packing, plus the first
fill of the source cells. Into material already at ``phi_max`` the transport's upper-bound limiter
can hold part of it back (the step's ``limited_mass``), and the refill *sets* the source cells:
where they hold more grains than ``phi_in`` it takes grains out (a negative supply, booked as such).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

from granflow.errors import GranflowInputError

PENALTY = 1.0e6
"""Penalty factor of the prescribed velocity, relative to the inertia ``rho_s phi_in / dt``."""


class SourceSide(Enum):
    """Where the grains enter."""

    WEST = "west"
    """Through the west wall, x = x0, over ``lower <= z <= upper``."""
    BOTTOM = "bottom"
    """Through the base, z = z0, over ``lower <= x <= upper``."""


@dataclass(frozen=True)
class Source:
    """A supply of grains (module docstring).

    Parameters
    ----------
    side : SourceSide or str
    lower, upper : float
        The span along the side [m] (z for ``west``, x for ``bottom``), ``lower < upper``.
    phi : float
        Solid fraction of the incoming material [-], in (0, phi_max].
    speed : float
        Velocity into the box [m s^-1], > 0.
    start, stop : float
        The source is on for ``start <= t < stop`` [s].
    """

    side: SourceSide
    lower: float
    upper: float
    phi: float
    speed: float
    start: float = 0.0
    stop: float = math.inf

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "side", SourceSide(self.side))
        except ValueError:
            raise GranflowInputError(f"Source: side must be 'west' or 'bottom', got {self.side!r}") from None
        if not self.lower < self.upper:
            raise GranflowInputError(f"Source: lower = {self.lower} must be below upper = {self.upper}")
        if not (math.isfinite(self.speed) and self.speed > 0):
            raise GranflowInputError(f"Source: speed must be > 0, got {self.speed!r}")
        if not self.start < self.stop:
            raise GranflowInputError(f"Source: start = {self.start} must be before stop = {self.stop}")

    def active(self, t: float) -> bool:
        """The source is on at time ``t`` [s]."""
        return self.start <= t < self.stop

    def cells(self, grid, base=None) -> np.ndarray:
        """Boolean mask (nx, nz) of the source cells; GranflowInputError if the span holds no
        cell centre. ``base`` (int (nx,), optional): the lowest fluid cell of each column above a
        topography (:mod:`granflow.topography`): a base source sits on it, a west source above it."""
        mask = np.zeros(grid.cell_shape, dtype=bool)
        base = np.zeros(grid.nx, dtype=np.int64) if base is None else np.asarray(base, dtype=np.int64)
        if self.side is SourceSide.WEST:
            mask[0, :] = (grid.zc >= self.lower) & (grid.zc <= self.upper) & (np.arange(grid.nz) >= base[0])
        else:
            mask[np.arange(grid.nx), base] = (grid.xc >= self.lower) & (grid.xc <= self.upper)
        along, start, length = (("z", grid.z0, grid.Lz) if self.side is SourceSide.WEST
                                else ("x", grid.x0, grid.Lx))
        if self.upper > start + length * (1 + 1e-12) or self.lower < start - length * 1e-12:
            raise GranflowInputError(f"inflow.upper/lower: the span [{self.lower:g}, {self.upper:g}] ({along}) "
                                     f"runs beyond the {self.side.value} side [{start:g}, {start + length:g}] "
                                     f"of the box")
        if not mask.any():
            raise GranflowInputError(f"inflow.lower/upper: the span [{self.lower:g}, {self.upper:g}] ({along}) "
                                     f"holds no cell centre of the {self.side.value} side (cells "
                                     f"{length / (grid.nz if along == 'z' else grid.nx):g} wide); widen it")
        return mask

    def faces(self, grid, base=None) -> tuple[np.ndarray, np.ndarray]:
        """(mask, target velocity) over the velocity unknowns (``grid.pack_velocity`` layout);
        ``base`` as :meth:`cells`."""
        cells = self.cells(grid, base)
        base = np.zeros(grid.nx, dtype=np.int64) if base is None else np.asarray(base, dtype=np.int64)
        u_shape, w_shape = (grid.nx + 1, grid.nz), (grid.nx, grid.nz + 1)
        u_m, w_m = np.zeros(u_shape, dtype=bool), np.zeros(w_shape, dtype=bool)
        u_t, w_t = np.zeros(u_shape), np.zeros(w_shape)
        if self.side is SourceSide.WEST:
            rows = cells[0]
            u_m[1, rows], u_t[1, rows] = True, self.speed
            w_m[0, 1:-1] = rows[1:] & rows[:-1]
        else:  # the z-face on top of each source cell, the x-faces between source cells at one level
            cols = cells[np.arange(grid.nx), base]
            w_m[cols, base[cols] + 1], w_t[cols, base[cols] + 1] = True, self.speed
            pair = np.flatnonzero(cols[1:] & cols[:-1] & (base[1:] == base[:-1]))
            u_m[pair + 1, base[pair]] = True
        mask = grid.pack_velocity(u_m.astype(float), w_m.astype(float)) > 0.5
        return mask, grid.pack_velocity(u_t, w_t)

    def flux(self, grid, base=None) -> float:
        """Supplied solid volume flux ``phi speed n h`` [m^2 s^-1]: ``n`` source cells of height
        (west) or width (base) ``h`` -- ``phi speed (upper - lower)`` when the span's ends are
        cell faces."""
        h = grid.dz if self.side is SourceSide.WEST else grid.dx
        return self.phi * self.speed * int(np.count_nonzero(self.cells(grid, base))) * h


@dataclass(frozen=True)
class SourceTerms:
    """The source's share of one step's momentum rows."""

    penalty: np.ndarray
    """``lambda`` on the velocity unknowns [kg m^-3 s^-1] (0 off the source faces)."""
    target: np.ndarray
    """``u_in`` [m s^-1]."""
    cells: np.ndarray
    """Flat mask of the source cells."""

    def power(self, dV: float, u) -> float:
        """``P_src = dV sum lambda (u_in - u) u`` [W m^-1]."""
        return dV * float(np.sum(self.penalty * (self.target - u) * u))


def source_terms(source: Source, grid, rho_s: float, dt: float, base=None) -> SourceTerms:
    """:class:`SourceTerms` of ``source`` for a step ``dt`` [s] (module docstring; ``base`` as
    :meth:`Source.cells`)."""
    mask, target = source.faces(grid, base)
    lam = PENALTY * rho_s * source.phi / dt
    return SourceTerms(penalty=np.where(mask, lam, 0.0), target=np.where(mask, target, 0.0),
                       cells=source.cells(grid, base).ravel())


def refill(source: Source, grid, phi, c, p_f, base=None):
    """The fields with the source cells refilled (copies): ``phi_in``, ``c = 1``, ``p_f = 0``."""
    cells = source.cells(grid, base)
    phi_new = np.where(cells, source.phi, phi)
    c_new = None if c is None else np.where(cells, 1.0, c)
    pf_new = None if p_f is None else np.where(cells.ravel(), 0.0, np.ravel(p_f)).reshape(np.shape(p_f))
    return phi_new, c_new, pf_new
