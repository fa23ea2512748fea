"""CF/COARDS layout of ``output.nc`` (issue 16 item 11): fields stored (time, z, x), CF axis
attributes on the coordinates, and files written before in (time, x, z) still read, plot,
export and resume.

Checks: the on-disk dimensions and attributes read with netCDF4 (no decoding) and with xarray
(``decode_times=False``); a run's file rewritten here in either order (by xarray, transposing by
name) gives the same front, the same drawn arrays in ``granflow plot`` and the run figures, and
byte-identical VTK files; a run restarted on an output file in the old order continues it bit for
bit and leaves it in the CF order.
"""
from __future__ import annotations

import shutil
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import granflow.output  # noqa: F401  (ds.granflow accessor)
from granflow.cli import ExitCode, main
from granflow.errors import GranflowInputError
from granflow.output import ordered

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLES = ROOT / "examples"
FLUIDISED = EXAMPLES / "column_collapse_fluidised.toml"
NX, NZ = 16, 6
TINY = ["--set", f"grid.nx={NX}", "--set", f"grid.nz={NZ}", "--set", "output.interval=0.01",
        "--set", "output.figures=false", "--set", "output.probes_x=[0.01, 0.2]", "--quiet"]
FIELDS = ("phi", "c", "u", "w", "p", "p_f", "S")
CF_ORDER = ("time", "z", "x")
OLD_ORDER = ("time", "x", "z")
N = 20
"""Steps before the restart (dt = dt_max = 1 ms, records every 10 steps)."""


def run(out: Path, stop_time: float, *extra: str, example: Path = FLUIDISED) -> None:
    code = main(["run", str(example), "--out", str(out), *TINY, "--set", f"time.stop_time={stop_time}",
                 *extra])
    assert code == ExitCode.OK


def rewrite(src: Path, dst: Path, order: tuple[str, ...]) -> Path:
    """``src`` written again by xarray with every field transposed (by name) to ``order``; the
    raw values and attributes are kept (no CF decoding), in the classic format granflow writes."""
    with xr.open_dataset(src, decode_cf=False) as ds:
        ds.load().transpose(*order, ...).to_netcdf(dst, format="NETCDF3_64BIT")
    with netCDF4.Dataset(dst) as nc:
        assert nc["phi"].dimensions == order
    return dst


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("cf") / "run"
    run(out, 0.02)
    return out


# ------------------------------------------------------------------------------ on-disk layout
def test_fields_are_stored_time_z_x_with_cf_axis_attributes(run_dir):
    with netCDF4.Dataset(run_dir / "output.nc") as nc:
        for name in FIELDS:
            assert nc[name].dimensions == CF_ORDER, name
            assert nc[name].shape[1:] == (NZ, NX), name
        assert nc["kinetic_energy"].dimensions == ("time",)
        assert nc["x_front"].dimensions == ("time",)
        assert nc["probe_p_f"].dimensions == ("time", "x_probe")
        assert nc.dimensions["time"].isunlimited()
        t = nc["time"]
        assert (t.units, t.axis, t.standard_name) == ("s", "T", "time") and t.long_name
        assert nc["x"].axis == "X" and nc["x"].units == "m"
        assert nc["z"].axis == "Z" and nc["z"].positive == "up" and nc["z"].units == "m"
        assert nc.getncattr("Conventions").startswith("CF-1.")
        # record 0 of phi, read raw, is rows of constant z (x varies fastest): the column of the
        # example, phi0 = 0.58 over 0 < x < L0 = 0.1 m, 0 < z < H0 = 0.1 m, each cell filled by
        # the fraction of it inside (written here from the geometry)
        x, z = np.asarray(nc["x"][:]), np.asarray(nc["z"][:])
        dx, dz = x[1] - x[0], z[1] - z[0]
        in_x = np.clip((0.1 - (x - dx / 2)) / dx, 0.0, 1.0)
        in_z = np.clip((0.1 - (z - dz / 2)) / dz, 0.0, 1.0)
        np.testing.assert_allclose(np.asarray(nc["phi"][0]), 0.58 * np.outer(in_z, in_x), rtol=1e-12,
                                   atol=1e-15)
    with xr.open_dataset(run_dir / "output.nc", decode_times=False) as ds:
        assert ds["phi"].dims == CF_ORDER
        assert ds["time"].attrs["units"] == "s" and ds["time"].attrs["axis"] == "T"
        assert ds["z"].attrs["positive"] == "up"


def test_dimensionless_case_has_a_t_axis_in_its_own_time_unit(tmp_path):
    out = tmp_path / "lag"
    assert main(["run", str(EXAMPLES / "lagree_column.toml"), "--out", str(out), "--quiet",
                 "--set", "grid.nx=16", "--set", "grid.nz=8", "--set", "time.stop_time=0.05",
                 "--set", "output.figures=false"]) == ExitCode.OK
    with netCDF4.Dataset(out / "output.nc") as nc:
        assert nc["phi"].dimensions == CF_ORDER
        t = nc["time"]
        assert t.units == "sqrt(H0/g)" and t.axis == "T" and t.long_name
        assert "standard_name" not in t.ncattrs()  # not a time in s: no CF standard name
        assert nc["z"].axis == "Z" and nc["z"].positive == "up"


# ------------------------------------------------------------------------------ readers, either order
def test_ordered_takes_either_order_by_name(run_dir):
    with netCDF4.Dataset(run_dir / "output.nc") as nc:
        raw = np.asarray(nc["phi"][:])  # (time, z, x)
        np.testing.assert_array_equal(ordered(nc["phi"]), raw.transpose(0, 2, 1))
        np.testing.assert_array_equal(ordered(nc["phi"], CF_ORDER), raw)
        with pytest.raises(GranflowInputError, match="dimensions"):
            ordered(nc["kinetic_energy"])
    da = xr.DataArray(raw.transpose(0, 2, 1), dims=OLD_ORDER)
    np.testing.assert_array_equal(ordered(da), raw.transpose(0, 2, 1))


@pytest.fixture(scope="module")
def both_orders(run_dir, tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("orders")
    return {"cf": rewrite(run_dir / "output.nc", d / "cf.nc", CF_ORDER),
            "old": rewrite(run_dir / "output.nc", d / "old.nc", OLD_ORDER)}


def test_accessor_front_and_thickness_do_not_depend_on_the_order(both_orders):
    fronts, thickness = {}, {}
    for key, path in both_orders.items():
        with xr.open_dataset(path) as ds:
            fronts[key] = ds.granflow.front_position().values
            thickness[key] = ds.granflow.deposit_thickness().transpose("time", "x").values
    np.testing.assert_array_equal(fronts["cf"], fronts["old"])
    np.testing.assert_array_equal(thickness["cf"], thickness["old"])
    assert np.isfinite(fronts["cf"]).all()


def _meshes(fig) -> list[np.ndarray]:
    from matplotlib.collections import QuadMesh

    return [np.ma.filled(np.ma.masked_invalid(c.get_array()).astype(float), np.nan)
            for ax in fig.axes if ax.get_title()  # the panels, not their colour bars
            for c in ax.collections if isinstance(c, QuadMesh)]


@pytest.mark.parametrize("var", ["phi", "p_f", "speed"])
def test_snapshot_draws_the_same_field_from_either_order(both_orders, var):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from granflow import plotting

    drawn = {}
    for key, path in both_orders.items():
        with xr.open_dataset(path) as ds:
            fig, ax = plt.subplots()
            try:
                mesh, _, _ = plotting.snapshot_axes(ax, ds.load(), var, 2)
                drawn[key] = np.ma.filled(np.ma.masked_invalid(mesh.get_array()).astype(float), np.nan)
            finally:
                plt.close(fig)
    assert drawn["cf"].size == NX * NZ
    np.testing.assert_array_equal(drawn["cf"], drawn["old"])
    with xr.open_dataset(both_orders["cf"]) as ds:  # rows are z: the column's top cell row is z_3
        if var == "phi":
            field = ds["phi"][2].transpose("z", "x").values
            np.testing.assert_array_equal(drawn["cf"].reshape(NZ, NX), field)


def test_run_figures_and_granflow_plot_read_the_old_order(both_orders, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from granflow import plotting

    saved: dict[str, Figure] = {}
    original = Figure.savefig

    def keep(self, path, *args, **kwargs):
        saved[f"{path.parent.name}/{path.name}"] = self
        return original(self, path, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    for key, path in both_orders.items():
        (tmp_path / key).mkdir()
        written = plotting.run_figures(path, tmp_path / key)
        assert {p.name for p in written} >= {"snapshots.png", "front.png"}
    cf, old = _meshes(saved["cf/snapshots.png"]), _meshes(saved["old/snapshots.png"])
    assert len(cf) == len(old) == 6  # phi and p_f at three records
    for a, b in zip(cf, old):
        assert a.shape == (NZ, NX)
        np.testing.assert_array_equal(a, b)
    png = tmp_path / "old_phi.png"
    assert main(["plot", str(both_orders["old"]), "--var", "speed", "--out", str(png)]) == ExitCode.OK
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_vtk_export_is_the_same_from_either_order(both_orders, tmp_path):
    files = {}
    for key, path in both_orders.items():
        assert main(["export", "vtk", str(path), "--out", str(tmp_path / key)]) == ExitCode.OK
        files[key] = sorted((tmp_path / key).glob("*.vtk"))
    assert len(files["cf"]) == len(files["old"]) == 3
    for a, b in zip(files["cf"], files["old"]):
        assert a.read_bytes() == b.read_bytes(), a.name


# ------------------------------------------------------------------------------ restart
def test_restart_on_an_old_order_output_is_bit_identical_and_writes_cf_order(tmp_path):
    """2N steps in one go versus: the same run's output rewritten in (time, x, z), then a
    restart from the step-N checkpoint: every record of the resumed file equals the uninterrupted
    run's, byte for byte, and the resumed file is in the CF order."""
    ref, out = tmp_path / "ref", tmp_path / "out"
    stop = 2 * N * 1e-3
    run(ref, stop, "--set", f"output.checkpoint_interval={N}", "--set", "output.checkpoint_keep=10")
    out.mkdir()
    rewrite(ref / "output.nc", out / "output.nc", OLD_ORDER)
    ckpt = out / "checkpoints"
    ckpt.mkdir()
    shutil.copy(ref / "checkpoints" / f"checkpoint_{N:08d}.npz", ckpt)
    run(out, stop, "--restart", str(out))
    with netCDF4.Dataset(ref / "output.nc") as dr, netCDF4.Dataset(out / "output.nc") as do:
        assert dr["time"][:].tobytes() == do["time"][:].tobytes() and do["time"].size == 5
        for var in (*FIELDS, "kinetic_energy", "x_front", "probe_p_f"):
            assert do[var].dimensions == dr[var].dimensions, var
            assert dr[var][:].tobytes() == do[var][:].tobytes(), var
        assert do["phi"].dimensions == CF_ORDER
