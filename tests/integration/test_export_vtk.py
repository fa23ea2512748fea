"""`granflow export vtk`: legacy VTK rectilinear grids, one file per record, parsed back here
(independently of the writer) and compared with the NetCDF output."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from granflow.cli import main

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLE = ROOT / "examples" / "column_collapse_fluidised.toml"
TINY = ["--set", "grid.nx=16", "--set", "grid.nz=6", "--set", "grid.Lx=0.4", "--set", "output.interval=0.01", "--set",
        "time.stop_time=0.02", "--set", "output.figures=false", "--quiet"]


def parse_vtk(path: Path) -> dict:
    """Minimal reader of the legacy ASCII rectilinear-grid format (VTK file formats, Kitware)."""
    tokens = path.read_text().split("\n")
    assert tokens[0].startswith("# vtk DataFile Version")
    assert tokens[2] == "ASCII" and tokens[3] == "DATASET RECTILINEAR_GRID"
    words = " ".join(tokens[4:]).split()
    out, i = {"scalars": {}}, 0
    while i < len(words):
        w = words[i]
        if w == "DIMENSIONS":
            out["dims"] = tuple(int(v) for v in words[i + 1:i + 4])
            i += 4
        elif w.endswith("_COORDINATES"):
            n = int(words[i + 1])
            out[w] = np.array(words[i + 3:i + 3 + n], dtype=float)
            i += 3 + n
        elif w == "FIELD":
            out["time"] = float(words[i + 7])
            i += 8
        elif w == "CELL_DATA":
            out["n_cells"] = int(words[i + 1])
            i += 2
        elif w == "SCALARS":
            name, n = words[i + 1], out["n_cells"]
            out["scalars"][name] = np.array(words[i + 6:i + 6 + n], dtype=float)
            i += 6 + n
        elif w == "VECTORS":
            n = out["n_cells"]
            out["velocity"] = np.array(words[i + 3:i + 3 + 3 * n], dtype=float).reshape(n, 3)
            i += 3 + 3 * n
        else:
            raise AssertionError(f"unexpected token {w!r}")
    return out


def test_export_vtk_round_trip(tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["run", str(EXAMPLE), "--out", str(run), *TINY]) == 0
    assert main(["export", "vtk", str(run)]) == 0
    files = sorted((run / "vtk").glob("output_*.vtk"))
    with xr.open_dataset(run / "output.nc") as ds:
        assert len(files) == ds.sizes["time"] == 3
        dx, dz = 0.4 / 16, 0.15 / 6
        for k, f in enumerate(files):
            v = parse_vtk(f)
            assert v["dims"] == (17, 7, 1) and v["n_cells"] == 96
            np.testing.assert_allclose(v["X_COORDINATES"], np.arange(17) * dx, atol=1e-12)
            np.testing.assert_allclose(v["Y_COORDINATES"], np.arange(7) * dz, atol=1e-12)
            assert v["time"] == float(ds["time"][k])
            for name in ("phi", "p", "p_f", "S", "u", "w"):
                ref = ds[name][k].transpose("z", "x").values.ravel()  # x fastest, then z
                np.testing.assert_allclose(v["scalars"][name], ref, rtol=1e-8, atol=1e-12 * (1 + abs(ref).max()))
            u_ref = ds["u"][k].transpose("z", "x").values.ravel()
            np.testing.assert_allclose(v["velocity"][:, 0], u_ref, rtol=1e-8, atol=1e-15)
            assert np.all(v["velocity"][:, 2] == 0)


def test_export_vtk_bad_input(tmp_path, capsys):
    assert main(["export", "vtk", str(tmp_path / "missing")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "missing" in err and "Traceback" not in err
