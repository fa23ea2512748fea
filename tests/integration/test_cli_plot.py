"""``granflow plot``: snapshots (PNG) and animations (GIF) of a run's output.nc, and bad input.

One tiny run of the dry example (16 x 6 cells, 0.02 s, records every 5 ms: 5 records) is made
once. Independent checks: file magic bytes; the GIF frame count read with PIL against the number
of records read with netCDF4; the record picked for ``--time`` recomputed here (nearest time);
the drawn array against the field read with netCDF4 (speed = hypot(u, w) computed here, exact to
1e-12 relative); the free-surface contour level against ``numerics.ambient.phi_c`` parsed here
from the file's ``config_effective`` attribute; the colour-bar label against the variable's
``long_name`` and ``units`` attributes.
"""
from __future__ import annotations

from pathlib import Path

import netCDF4
import numpy as np
import pytest

from granflow.cli import ExitCode, main
from granflow.output import ordered

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLE = ROOT / "examples" / "column_collapse_dry.toml"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
GIF_MAGIC = (b"GIF87a", b"GIF89a")
N_RECORDS = 5  # t = 0, 0.005, ..., 0.02 s


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("plot") / "run"
    code = main(["run", str(EXAMPLE), "--out", str(out), "--quiet", "--set", "grid.nx=16",
                 "--set", "grid.nz=6", "--set", "time.stop_time=0.02",
                 "--set", "output.interval=0.005", "--set", "output.figures=false"])
    assert code == ExitCode.OK
    return out


def nc_times(run_dir: Path) -> np.ndarray:
    with netCDF4.Dataset(run_dir / "output.nc") as ds:
        return np.asarray(ds["time"][:], dtype=float)


def test_default_snapshot_is_the_last_record(run_dir, capsys):
    assert nc_times(run_dir).size == N_RECORDS
    code, out, err = run_cli(capsys, "plot", run_dir)
    assert code == ExitCode.OK, err
    png = run_dir / "phi_t0.02s.png"
    assert png.read_bytes()[:8] == PNG_MAGIC
    assert f"record {N_RECORDS} of {N_RECORDS}" in out


@pytest.mark.parametrize("t", [0.0, 0.0061, 0.0139, 0.02])
def test_time_picks_the_nearest_record(run_dir, tmp_path, capsys, t):
    times = nc_times(run_dir)
    nearest = int(np.argmin(np.abs(times - t)))
    png = tmp_path / "sub" / "p.png"
    code, out, err = run_cli(capsys, "plot", run_dir / "output.nc", "--var", "p", "--time", t,
                             "--out", png)
    assert code == ExitCode.OK, err
    assert png.read_bytes()[:8] == PNG_MAGIC
    assert f"record {nearest + 1} of {N_RECORDS}" in out
    assert f"t = {times[nearest]:.6g} s" in out


def test_animation_has_one_frame_per_record(run_dir, tmp_path, capsys):
    from PIL import Image

    gif = tmp_path / "speed.gif"
    code, _, err = run_cli(capsys, "plot", run_dir, "--var", "speed", "--animate", gif)
    assert code == ExitCode.OK, err
    assert gif.read_bytes()[:6] in GIF_MAGIC
    with Image.open(gif) as im:
        assert im.n_frames == nc_times(run_dir).size == N_RECORDS
    assert not list(run_dir.glob("speed_*.png"))  # --animate alone writes no snapshot
    png = tmp_path / "u.png"
    code, _, err = run_cli(capsys, "plot", run_dir, "--var", "u", "--animate", tmp_path / "u.gif",
                           "--out", png)
    assert code == ExitCode.OK, err
    assert png.read_bytes()[:8] == PNG_MAGIC and (tmp_path / "u.gif").read_bytes()[:6] in GIF_MAGIC


@pytest.mark.parametrize("var", ["phi", "p", "speed"])
def test_snapshot_draws_the_field_surface_and_units(run_dir, var):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import xarray as xr

    from granflow import plotting

    index = 2
    with netCDF4.Dataset(run_dir / "output.nc") as nc:
        # the indicator surface (default) writes c: grains are the cells with material (c > 0)
        grains = ordered(nc["c"])[index] > 0.0  # (x, z)
        if var == "speed":  # a grain quantity: blank in the ambient (issue 16 item 4)
            expected = np.where(grains, np.hypot(ordered(nc["u"])[index], ordered(nc["w"])[index]), np.nan)
            label = f"grain speed |u|, grains only (c > 0) [{nc['u'].units}]"
        else:
            expected = ordered(nc[var])[index].astype(float)
            label = f"{nc[var].long_name} [{nc[var].units}]"
    with xr.open_dataset(run_dir / "output.nc") as ds:
        fig, ax = plt.subplots()
        mesh, contour, bar = plotting.snapshot_axes(ax, ds.load(), var, index)
    try:
        drawn = np.ma.filled(np.ma.masked_invalid(mesh.get_array()).astype(float), np.nan)
        drawn = drawn.reshape(expected.T.shape)
        np.testing.assert_allclose(drawn, expected.T, rtol=1e-12, atol=0.0, equal_nan=True)
        assert np.isnan(expected).any() == (var == "speed")
        assert bar.ax.get_xlabel() == label
        assert contour is not None and list(contour.levels) == [plotting.SURFACE_FRACTION]  # c = 1/2
    finally:
        plt.close(fig)


def test_snapshot_marks_the_front_with_the_runs_definition(run_dir):
    """Issue 16 item 5: the front drawn on a snapshot is the run's front (right edge of the
    furthest column whose deposit thickness exceeds the run's threshold, computed here from phi),
    not the end of the phi = phi_c line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import xarray as xr

    from granflow import plotting

    index = N_RECORDS - 1
    with netCDF4.Dataset(run_dir / "output.nc") as nc:
        x, z = np.asarray(nc["x"][:]), np.asarray(nc["z"][:])
        phi = ordered(nc["phi"])[index].astype(float)  # (x, z)
        h = phi.sum(axis=1) * (z[1] - z[0]) / nc["phi"].phi_max
        threshold = nc.getncattr("front_threshold_m")
    dx = x[1] - x[0]
    expected = x[np.flatnonzero(h > threshold)[-1]] + dx / 2
    with xr.open_dataset(run_dir / "output.nc") as ds:
        ds = ds.load()
        for data in (ds, ds.drop_vars("x_front")):  # the stored series, or the accessor
            fig, ax = plt.subplots()
            try:
                plotting.snapshot_axes(ax, data, "phi", index)
                fronts = [ln for ln in ax.lines if ln.get_gid() == plotting.FRONT_GID]
                assert len(fronts) == 1
                assert fronts[0].get_xdata()[0] == pytest.approx(expected, abs=1e-12)
                assert "front" in ax.get_title()
            finally:
                plt.close(fig)


# ------------------------------------------------------------------------------ bad input
def test_bad_input_exits_2_in_one_line(run_dir, tmp_path, capsys):
    import xarray as xr

    no_pf = tmp_path / "no_pf.nc"
    with xr.open_dataset(run_dir / "output.nc") as ds:
        ds.drop_vars("p_f").to_netcdf(no_pf)
    text = tmp_path / "junk.nc"
    text.write_text("not netcdf\n")
    cases = [
        ((tmp_path / "missing",), "no such file"),
        ((tmp_path,), "output.nc"),  # a directory without output.nc
        ((text,), "not a readable NetCDF file"),
        ((run_dir, "--var", "rho"), "invalid choice: 'rho'"),
        ((no_pf, "--var", "p_f"), "has no p_f"),
        ((run_dir, "--time", "0.5"), "outside the records"),
        ((run_dir, "--time", "-0.001"), "outside the records"),
        ((run_dir, "--time", "nan"), "outside the records"),
        ((run_dir, "--out", tmp_path / "x.xyz"), "unsupported image format 'xyz'"),
        ((run_dir, "--animate", tmp_path / "x.png"), "expected a .gif file"),
    ]
    for args, message in cases:
        code, out, err = run_cli(capsys, "plot", *args)
        assert code == ExitCode.BAD_INPUT, (args, err)
        assert err.startswith("granflow: error: ") and message in err, (args, err)
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
        assert out == ""
    assert not (tmp_path / "x.xyz").exists() and not (tmp_path / "x.png").exists()
