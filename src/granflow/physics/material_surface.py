"""The reconstructed surface of the material indicator (scheme v2, issue 12; the fields ``c`` and
``phi`` of :mod:`granflow.physics.material`): the packing inside the material ``psi = phi / c``
(eq. syst1b's phi as the closure sees it), with each cell's material filling it from below as under
gravity (:data:`C_ROW`), the solid fraction of the z-faces' dual cells, the distance from a cell
centre to the surface, and the discrete hydrostatic pressure of that reconstruction
(``p = 0`` at the surface, Gibou et al. 2002). Re-exported by :mod:`granflow.physics.material`.
"""
from __future__ import annotations

import numpy as np

from granflow.physics.transport import HALF

C_MIN = 1e-6
"""Cells with ``c > C_MIN`` are material [-]."""
C_FULL = 1.0 - 1e-9
"""Cells with ``c >= C_FULL`` are full of material [-] (the others with ``c > C_MIN`` are the
partial cells of the surface, counted in the tests' sharpness checks)."""
C_ROW = 0.5
"""Cells with ``c >= C_ROW`` hold their centre inside the material (the material of a cell is taken
to fill it from below, as under gravity): they carry a pressure unknown, the dilatancy row and the
dilatation source ``c div u``, like full cells. Thinner cells (``C_MIN < c < C_ROW``) are free
(``p = 0`` at their centre, which lies above the surface) and their grains weigh on the z-face below
them (:func:`face_solid_fraction`). With the face weights of that reconstruction, ``p = 0`` sits at
the reconstructed surface: the discrete hydrostatic pressure at a cell centre a distance ``s``
below the surface is ``rho_s psi |g_z| s`` exactly (a cut-face finite volume, equivalent for a
horizontal surface to the ghost-fluid condition of Gibou et al. 2002, J. Comput. Phys. 176, 205)."""
PHI_EMPTY = 1e-14
"""A cell with fewer grains than this (solid fraction) holds no material [-]."""


def packing(c, phi) -> np.ndarray:
    """Packing inside the material ``psi = phi / c`` [-] (0 outside the material, ``c <= C_MIN``)."""
    c = np.asarray(c, dtype=float)
    phi = np.asarray(phi, dtype=float)
    material = c > C_MIN
    return np.where(material, phi / np.where(material, c, 1.0), 0.0)


def face_solid_fraction(c, phi) -> np.ndarray:
    """Solid fraction of the dual cells of the interior z-faces, shape (nx, nz - 1) [-]: the
    grains between the centres of the cells below and above a face, with each cell's material
    filling it from below (:data:`C_ROW`). A cell's lower half holds ``psi min(c, 1/2)``, its
    upper half ``psi max(c - 1/2, 0)``, so that ``phi_f = phi_below - lower_below + lower_above``.
    Between full cells this is the centred mean; above a surface cell it is the material between
    its centre and the surface. The sum over a column is the column's grains less the lower half of
    its bottom cell and the upper half of its top cell (the wall faces' halves)."""
    c = np.asarray(c, dtype=float)
    phi = np.asarray(phi, dtype=float)
    lower = packing(c, phi) * np.minimum(c, HALF)
    return phi[:, :-1] - lower[:, :-1] + lower[:, 1:]


THETA_MIN = 0.05
"""Floor of the centre-to-surface distance in cells (:func:`surface_distance`): a surface closer
to a centre than this is taken at this distance (bounded face mobilities)."""


def surface_distance(c) -> np.ndarray:
    """Distance from the centre of a cell with a row (``c >= C_ROW``) to the reconstructed surface
    above it, in cells, on the interior z-faces whose upper cell has no row, shape (nx, nz - 1);
    NaN on the other faces. With the material filling cells from below it is
    ``c_below - 1/2 + c_above``, floored at :data:`THETA_MIN`."""
    c = np.asarray(c, dtype=float)
    below, above = c[:, :-1], c[:, 1:]
    face = (below >= C_ROW) & (above < C_ROW)
    return np.where(face, np.maximum(below - HALF + np.maximum(above, 0.0), THETA_MIN), np.nan)


def surface_lithostatic(c, phi, weight: float) -> np.ndarray:
    """Discrete hydrostatic pressure of the reconstructed material [Pa], shape (nx, nz): ``Grad p``
    balances ``weight * face_solid_fraction`` on the z-faces with ``p = 0`` in the thin and empty
    cells, i.e. ``weight * (psi max(c - 1/2, 0) + sum of phi above)`` in the cells with a row
    (``c >= C_ROW``); in the thin cells the pressure at the middle of their material,
    ``weight * (phi/2 + sum of phi above)`` (their friction pressure). ``weight = rho_s |g_z| dz``
    [Pa]."""
    c = np.asarray(c, dtype=float)
    phi = np.asarray(phi, dtype=float)
    above = np.cumsum(phi[:, ::-1], axis=1)[:, ::-1] - phi
    own = np.where(c >= C_ROW, packing(c, phi) * np.maximum(c - HALF, 0.0), HALF * phi)
    return np.where(c > C_MIN, weight * (above + own), 0.0)


def material_fraction(phi, packing_of_material) -> np.ndarray:
    """Material fraction of a solid fraction field whose material packing is known:
    ``c = min(phi / psi, 1)`` where ``phi > PHI_EMPTY``, else 0 [-]."""
    phi = np.asarray(phi, dtype=float)
    psi = np.asarray(packing_of_material, dtype=float)
    full = (phi > PHI_EMPTY) & (psi > 0)
    return np.where(full, np.minimum(phi / np.where(full, psi, 1.0), 1.0), 0.0)
