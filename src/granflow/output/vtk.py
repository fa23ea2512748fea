"""Export of run records to legacy VTK rectilinear-grid files for ParaView / VisIt.

One ASCII ``.vtk`` file per record (``<stem>_<record>.vtk``, which ParaView opens as a time
series), cells of the MAC grid as VTK cells: x and z edges as the X and Y coordinates (Z = 0),
every cell-centred field as CELL_DATA scalars, and the velocity (u, w, 0) as a vector when both are
present. Reference: VTK file formats, "Simple Legacy Formats" (Kitware, VTK User's Guide).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

#: Fields exported as scalars when present (cell-centred, dims time, z and x, in any order).
SCALARS = ("phi", "p", "p_f", "S", "u", "w")


ROUND_OFF = 1e-9
"""Edges closer to 0 than this fraction of the cell size are 0 (round-off of centre - h/2)."""


def cell_edges(centres: np.ndarray) -> np.ndarray:
    """Cell edges of a uniform axis from its centres [m] (also the mesh of the snapshot figures,
    :mod:`granflow.plotting`)."""
    if centres.size < 2:
        raise ValueError("need at least two cells per direction")
    h = float(centres[1] - centres[0])
    edges = np.concatenate([centres - h / 2, [centres[-1] + h / 2]])
    edges[np.abs(edges) < ROUND_OFF * h] = 0.0  # x0 = 0 exactly, not 8.7e-19 (centre - h/2 round-off)
    return edges


def _zx(field) -> np.ndarray:
    """The values of a record's field as (z, x), whatever the order of its dimensions in the file:
    VTK cell order is x fastest, then z."""
    return np.asarray(field.transpose("z", "x").values, dtype=float)


def _values(a: np.ndarray) -> str:
    """VTK order: x fastest, then z (``a`` is (z, x), :func:`_zx`)."""
    return "\n".join(" ".join(f"{v:.9g}" for v in row) for row in a)


def write_record(ds, record: int, path: str | Path) -> Path:
    """Write record ``record`` of a run Dataset (fields over time, z, x in any order) to ``path``."""
    snap = ds.isel(time=record)
    xe, ze = cell_edges(ds["x"].values), cell_edges(ds["z"].values)
    nx, nz = ds.sizes["x"], ds.sizes["z"]
    t = float(snap["time"])
    lines = [
        "# vtk DataFile Version 3.0",
        f"granflow {ds.attrs.get('case', '')} t = {t:.9g} s",
        "ASCII",
        "DATASET RECTILINEAR_GRID",
        f"DIMENSIONS {nx + 1} {nz + 1} 1",
        f"X_COORDINATES {nx + 1} double", " ".join(f"{v:.9g}" for v in xe),
        f"Y_COORDINATES {nz + 1} double", " ".join(f"{v:.9g}" for v in ze),
        "Z_COORDINATES 1 double", "0",
        "FIELD FieldData 1", "TIME 1 1 double", f"{t:.17g}",
        f"CELL_DATA {nx * nz}",
    ]
    for name in SCALARS:
        if name in snap:
            lines += [f"SCALARS {name} double 1", "LOOKUP_TABLE default", _values(_zx(snap[name]))]
    if "u" in snap and "w" in snap:
        u, w = _zx(snap["u"]).ravel(), _zx(snap["w"]).ravel()
        lines += ["VECTORS velocity double",
                  "\n".join(f"{a:.9g} {b:.9g} 0" for a, b in zip(u, w))]
    path = Path(path)
    path.write_text("\n".join(lines) + "\n")
    return path


def export_run(ds, outdir: str | Path, stem: str = "output") -> list[Path]:
    """Write every record of ``ds`` to ``outdir/<stem>_<record:04d>.vtk``; returns the paths."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    return [write_record(ds, i, outdir / f"{stem}_{i:04d}.vtk") for i in range(ds.sizes["time"])]
