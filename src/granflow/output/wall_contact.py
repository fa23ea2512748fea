"""Runs whose grains reach the box edge (issue 16 item 1, issue 14 item 1): the front is then cut
by the wall and the run-out is a lower bound. :class:`WallWatch` looks at every output record for
grains in the last column (east wall; not on a grid periodic in x) and in the top row (the lid),
and remembers when each was first reached (sides touched from the first record on, by a layer
that fills the box, are not reported); the run reports it in ``summary.json``
(``wall_contact``, ``warnings``), on the console and as ``output.nc`` global attributes
(``reached_east_wall``, ``reached_lid``: 0 or 1, with ``..._t`` the first time). Behind an outflow
east wall (:mod:`granflow.physics.outflow`) the last column is kept empty; the side
``east_outflow`` is then reached once grains have left the box (``reached_east_outflow``).
"""
from __future__ import annotations

import numpy as np

CONTACT_FRACTION = 1.0e-3
"""A cell holds grains for this check when ``phi > CONTACT_FRACTION phi_max`` (well above the
round-off traces the transport leaves, below any film a figure would show)."""
SIDES = ("east_wall", "lid", "east_outflow")


class WallWatch:
    """First times at which grains sit in the last column / top row of the grid."""

    def __init__(self, periodic_x: bool) -> None:
        self.periodic_x = periodic_x
        self.first: dict[str, float] = {}
        self.initial: set[str] | None = None
        """Sides the grains touch in the first record (a layer that fills the box): not a flow
        cut by the wall, never reported."""

    def check(self, phi: np.ndarray, phi_max: float, t: float, outflow_cells: float = 0.0) -> list[str]:
        """Sides newly reached at time ``t`` by ``phi`` (nx, nz); ``outflow_cells``: the solid
        volume that left through an outflow wall so far, in cell volumes [-]."""
        phi = np.asarray(phi, dtype=float)
        level = CONTACT_FRACTION * phi_max
        touched = {"east_wall": (not self.periodic_x) and bool(np.any(phi[-1, :] > level)),
                   "lid": bool(np.any(phi[:, -1] > level)),
                   "east_outflow": outflow_cells > level}
        if self.initial is None:
            self.initial = {s for s in SIDES if touched[s]}
        new = [s for s in SIDES if touched[s] and s not in self.first and s not in self.initial]
        for s in new:
            self.first[s] = float(t)
        return new

    def attributes(self) -> dict[str, float | int]:
        """NetCDF global attributes: ``reached_<side>`` (0/1) and ``reached_<side>_t``."""
        out: dict[str, float | int] = {}
        for s in SIDES:
            out[f"reached_{s}"] = int(s in self.first)
            if s in self.first:
                out[f"reached_{s}_t"] = self.first[s]
        return out


def warning_text(side: str, t: float, time_unit: str, length_key: str) -> str:
    """The console / summary warning for a side first reached at ``t``."""
    if side == "east_outflow":
        return (f"grains left the box through the east outflow from t = {t:.4g} {time_unit}: the "
                f"run-out and the deposit are those of the grains left in the box (summary outflow_mass)")
    where = "the east wall" if side == "east_wall" else "the lid (top of the box)"
    fix = f"enlarge {length_key}" if side == "east_wall" else "raise the box height"
    return (f"grains reached {where} at t = {t:.4g} {time_unit}: the box cuts the "
            f"flow and the run-out is a lower bound; {fix}")
