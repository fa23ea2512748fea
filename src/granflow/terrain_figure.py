"""The rock under a base profile in the figures of a run (issue 14 item 3): a grey staircase of
the solid cells the solver used and the profile itself, from the global attributes of output.nc
(:func:`granflow.output.writers.topography_attrs`)."""
from __future__ import annotations

import numpy as np

from granflow.output.vtk import cell_edges

TERRAIN_COLOUR = "0.6"
"""Fill colour of the rock under a base profile."""


def solid_mask(ds) -> np.ndarray | None:
    """bool (x, z): the solid cells under a base profile (the output's ``base_height``
    attribute, :func:`granflow.output.writers.topography_attrs`), or None (flat base)."""
    base = ds.attrs.get("base_height")
    if base is None:
        return None
    return ds["z"].values[None, :] < np.atleast_1d(np.asarray(base, dtype=float))[:, None]


def draw_terrain(ax, ds) -> None:
    """Fill the solid cells under a base profile (grey staircase) and draw the profile itself
    (black line); nothing on a flat base."""
    base = ds.attrs.get("base_height")
    if base is None:
        return
    xe, ze = cell_edges(ds["x"].values), cell_edges(ds["z"].values)
    ax.stairs(np.atleast_1d(np.asarray(base, dtype=float)), xe, baseline=ze[0], fill=True,
              color=TERRAIN_COLOUR, zorder=2)
    px = np.atleast_1d(np.asarray(ds.attrs.get("topography_x", []), dtype=float))
    pz = np.atleast_1d(np.asarray(ds.attrs.get("topography_z", []), dtype=float))
    if px.size:
        x = np.concatenate([[min(xe[0], px[0])], px, [max(xe[-1], px[-1])]])
        ax.plot(x, np.concatenate([[pz[0]], pz, [pz[-1]]]), "k-", linewidth=0.8, zorder=3)
        ax.set_xlim(xe[0], xe[-1])


def x_name(ds) -> str:
    """The name of a run's x axis in figures: ``r`` on an axisymmetric grid (output.nc attribute
    ``geometry``), else ``x``."""
    return "r" if ds.attrs.get("geometry") == "axisymmetric" else "x"
