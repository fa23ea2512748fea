"""Output: crash-safe CF NetCDF writer, atomic JSON summaries, the ``ds.granflow`` accessor.

References are independent of the code under test: field values come from closed-form formulas
written here (and, for the killed writer, re-typed in the child script), deposit thickness and
front positions from the analytic triangular deposit H(x) = H0 (1 - x/L). Stored float64 values
must come back exactly (tolerance 0); analytic front/run-out comparisons use rtol = 1e-12.
"""
from __future__ import annotations

import datetime as dt
import doctest
import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
import xarray as xr

import granflow
import granflow.output.accessor
import granflow.output.netcdf
import granflow.output.summary
from granflow.errors import GranflowInputError
from granflow.output import (
    NetCDFFormat,
    NetCDFWriter,
    VariableSpec,
    atomic_write,
    write_json_atomic,
)
from granflow.output.netcdf import git_revision

RTOL = 1e-12
PHI_MAX = 0.6
CASE_TEXT = '# column collapse, φ_max = 0.6\nclosure = "mu_i"\n[material]\nd = 7e-05\n'
NX, NZ = 6, 4
X = (np.arange(NX) + 0.5) * 0.01
Z = (np.arange(NZ) + 0.5) * 0.005
DT_OUT = 0.01


def expected_phi(i: int) -> np.ndarray:
    """Field written at record i (closed form, also typed into the child script below)."""
    return 0.6 * np.sin(i + 100.0 * X[:, None] * Z[None, :] + 1.0) ** 2


def make_writer_args():
    coords = {"x": (X, {"units": "m", "long_name": "horizontal position"}),
              "z": (Z, {"units": "m", "long_name": "height", "positive": "up"})}
    variables = {"phi": VariableSpec(("time", "x", "z"), "1", "packing fraction",
                                     attrs={"phi_max": PHI_MAX})}
    return coords, variables


def make_writer(path, fmt=NetCDFFormat.CLASSIC_64BIT, **kw) -> NetCDFWriter:
    return NetCDFWriter(path, *make_writer_args(), case_file=CASE_TEXT, format=fmt, **kw)


# ------------------------------------------------------------------------------ NetCDF writer
@pytest.mark.parametrize("fmt", list(NetCDFFormat))
def test_netcdf_roundtrip_values_and_cf_attributes(tmp_path, fmt):
    path = tmp_path / "run.nc"
    with make_writer(path, fmt, global_attrs={"title": "dam break"}) as w:
        for i in range(3):
            assert w.append(i * DT_OUT, {"phi": expected_phi(i)}) == i
    with xr.open_dataset(path) as ds:
        assert ds.sizes == {"time": 3, "x": NX, "z": NZ}
        np.testing.assert_array_equal(ds.time.values, np.arange(3) * DT_OUT)
        np.testing.assert_array_equal(ds.x.values, X)
        for i in range(3):
            np.testing.assert_array_equal(ds.phi.isel(time=i).values, expected_phi(i))
        for name in ("time", "x", "z", "phi"):
            assert ds[name].attrs["units"] and ds[name].attrs["long_name"], name
        assert ds.time.attrs["units"] == "s"
        assert ds.phi.attrs["phi_max"] == PHI_MAX
        a = ds.attrs
        assert a["Conventions"] == "CF-1.10"
        assert a["title"] == "dam break"
        assert a["case_file"] == CASE_TEXT  # full text, unicode and newlines intact
        assert a["granflow_version"] == granflow.__version__
        assert a["git_revision"] == git_revision()
        created = dt.datetime.fromisoformat(a["created"])
        assert abs((dt.datetime.now(dt.UTC) - created).total_seconds()) < 600
        assert granflow.__version__ in a["history"]


CHILD = textwrap.dedent('''
    import sys, time
    import numpy as np
    from granflow.output import NetCDFWriter, VariableSpec
    path, n = sys.argv[1], int(sys.argv[2])
    X = (np.arange(6) + 0.5) * 0.01
    Z = (np.arange(4) + 0.5) * 0.005
    coords = {"x": (X, {"units": "m", "long_name": "x"}), "z": (Z, {"units": "m", "long_name": "z"})}
    spec = {"phi": VariableSpec(("time", "x", "z"), "1", "packing fraction")}
    with NetCDFWriter(path, coords, spec, case_file="a = 1") as w:
        for i in range(n):
            w.append(i * 0.01, {"phi": 0.6 * np.sin(i + 100.0 * X[:, None] * Z[None, :] + 1.0) ** 2})
            print(i, flush=True)
            time.sleep(0.05)
''')


def test_netcdf_readable_while_running_and_after_kill_9(tmp_path):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    path = tmp_path / "killed.nc"
    n_total, n_wait = 10_000, 5
    with subprocess.Popen([sys.executable, str(script), str(path), str(n_total)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
        try:
            synced = 0
            deadline = time.monotonic() + 30.0
            while synced < n_wait:
                line = proc.stdout.readline()
                assert line, f"writer died: {proc.stderr.read()}"
                synced = int(line) + 1
                assert time.monotonic() < deadline
            with xr.open_dataset(path) as ds:  # the writer still has the file open
                assert ds.sizes["time"] >= synced
        finally:
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == -signal.SIGKILL
    with xr.open_dataset(path) as ds:
        n = ds.sizes["time"]
        assert synced <= n < n_total
        np.testing.assert_array_equal(ds.time.values, np.arange(n) * 0.01)
        for i in range(n):
            np.testing.assert_array_equal(ds.phi.isel(time=i).values, expected_phi(i))
        assert ds.phi.attrs["units"] == "1" and ds.attrs["case_file"] == "a = 1"


def test_netcdf_resume_after_restart(tmp_path):
    path = tmp_path / "run.nc"
    with make_writer(path) as w:  # the first run got to record 4, its checkpoint was at record 2
        for i in range(5):
            w.append(i * DT_OUT, {"phi": expected_phi(i)})
    with NetCDFWriter.resume(path, 2 * DT_OUT, *make_writer_args(), case_file=CASE_TEXT) as w:
        assert w.n_records == 3
        for i in range(3, 6):
            w.append(i * DT_OUT, {"phi": expected_phi(i)})
    with xr.open_dataset(path) as ds:
        np.testing.assert_array_equal(ds.time.values, np.arange(6) * DT_OUT)
        for i in range(6):
            np.testing.assert_array_equal(ds.phi.isel(time=i).values, expected_phi(i))
        assert "restarted at t = 0.02 s" in ds.attrs["history"]
        assert ds.attrs["case_file"] == CASE_TEXT
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.nc"]
    with pytest.raises(GranflowInputError, match="'rho'"):
        NetCDFWriter.resume(path, 0.0, make_writer_args()[0],
                            {"rho": VariableSpec(("time", "x"), "kg m-3", "density")})
    with pytest.raises(GranflowInputError, match="cannot resume"):
        NetCDFWriter.resume(tmp_path / "none.nc", 0.0, *make_writer_args())
    with xr.open_dataset(path) as ds:  # failed resumes left the file alone
        assert ds.sizes["time"] == 6


def test_netcdf_input_validation_names_the_culprit(tmp_path):
    w = make_writer(tmp_path / "a.nc")
    with pytest.raises(GranflowInputError, match="'rho'"):
        w.append(0.0, {"phi": expected_phi(0), "rho": expected_phi(0)})
    with pytest.raises(GranflowInputError, match="missing.*'phi'"):
        w.append(0.0, {})
    with pytest.raises(GranflowInputError, match=r"'phi'.*\(4, 6\).*\(6, 4\)"):
        w.append(0.0, {"phi": expected_phi(0).T})
    w.append(1.0, {"phi": expected_phi(0)})
    with pytest.raises(GranflowInputError, match="time"):
        w.append(1.0, {"phi": expected_phi(0)})
    w.close()
    w.close()  # idempotent
    with pytest.raises(GranflowInputError, match="closed"):
        w.append(2.0, {"phi": expected_phi(0)})

    xs = {"x": (X, {"units": "m", "long_name": "x"})}
    with pytest.raises(GranflowInputError, match="coordinate 'x'.*units"):
        NetCDFWriter(tmp_path / "b.nc", {"x": (X, {"long_name": "x"})}, {})
    with pytest.raises(GranflowInputError, match="'u'.*start with 'time'"):
        NetCDFWriter(tmp_path / "b.nc", xs, {"u": VariableSpec(("x",), "m/s", "u")})
    with pytest.raises(GranflowInputError, match="'u'.*'y'"):
        NetCDFWriter(tmp_path / "b.nc", xs, {"u": VariableSpec(("time", "y"), "m/s", "u")})
    with pytest.raises(GranflowInputError, match="'u'.*long_name"):
        NetCDFWriter(tmp_path / "b.nc", xs, {"u": VariableSpec(("time", "x"), "m/s", "")})
    with pytest.raises(GranflowInputError, match="git_revision"):
        NetCDFWriter(tmp_path / "b.nc", xs, {}, {"git_revision": "fake"})
    with pytest.raises(GranflowInputError, match="'n'.*i8"):
        NetCDFWriter(tmp_path / "b.nc", xs, {"n": VariableSpec(("time", "x"), "1", "n", "i8")})


def test_git_revision_matches_git_and_never_fails(monkeypatch):
    git_revision.cache_clear()
    try:
        rev = git_revision()
        try:
            head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                  text=True, cwd=os.path.dirname(granflow.__file__), check=True)
            assert rev.split("-")[0] == head.stdout.strip()
        except (OSError, subprocess.CalledProcessError):
            assert rev == "unknown"
        git_revision.cache_clear()

        def no_git(*args, **kwargs):
            raise FileNotFoundError("git")

        monkeypatch.setattr(granflow.output.netcdf.subprocess, "run", no_git)
        assert git_revision() == "unknown"
    finally:
        git_revision.cache_clear()


# ------------------------------------------------------------------------------ summary.json
def test_json_conversions(tmp_path):
    data = {"runout": np.float64(0.25), "n": np.int32(7), "ok": np.bool_(True),
            "bad": float("nan"), "big": np.inf, "arr": np.array([[1.0, np.nan]]), "t": (1, 2),
            "path": tmp_path / "x"}
    write_json_atomic(tmp_path / "s.json", data)
    text = (tmp_path / "s.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {"runout": 0.25, "n": 7, "ok": True, "bad": None, "big": None,
                                "arr": [[1.0, None]], "t": [1, 2], "path": str(tmp_path / "x")}


def _leftovers(directory):
    return sorted(p.name for p in directory.iterdir() if p.name.endswith(".tmp"))


def test_json_write_is_atomic(tmp_path, monkeypatch):
    target = tmp_path / "summary.json"
    write_json_atomic(target, {"v": 1})
    before = target.read_bytes()
    # serialisation fails midway (an unconvertible object deep in the data)
    with pytest.raises(GranflowInputError, match=r"b\.c"):
        write_json_atomic(target, {"a": 2, "b": {"c": object()}})
    assert target.read_bytes() == before
    # the write fails after part of the text is on disk
    with pytest.raises(RuntimeError):
        with atomic_write(target) as fh:
            fh.write('{"v": ')
            fh.flush()
            raise RuntimeError("killed midway")
    assert target.read_bytes() == before
    # the final rename fails
    def broken_replace(src, dst):
        raise OSError("disk gone")

    monkeypatch.setattr(granflow.output.summary.os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk gone"):
        write_json_atomic(target, {"v": 3})
    monkeypatch.undo()
    assert target.read_bytes() == before
    assert _leftovers(tmp_path) == []
    write_json_atomic(target, {"v": 4})
    assert json.loads(target.read_text()) == {"v": 4}
    umask = os.umask(0)
    os.umask(umask)
    new = tmp_path / "new.json"
    write_json_atomic(new, {})
    assert new.stat().st_mode & 0o777 == 0o666 & ~umask


# ------------------------------------------------------------------------------ accessor
H0 = 0.06  # triangle height [m]
DX = DZ = 0.005
XC = (np.arange(80) + 0.5) * DX  # 0.4 m
ZC = (np.arange(20) + 0.5) * DZ  # 0.1 m
TIMES = np.array([0.0, 0.5, 1.0])
LENGTHS = np.array([0.1, 0.2, 0.3])  # L(t)


def H(x, L):
    """Analytic deposit: a triangle of height H0 and length L."""
    return np.clip(H0 * (1.0 - x / L), 0.0, None)


def triangle_dataset() -> xr.Dataset:
    """phi fills each cell by the fraction of it below H(x), so sum_z phi dz / phi_max = H."""
    zlo = ZC - DZ / 2
    phi = np.stack([PHI_MAX * np.clip((H(XC, L)[:, None] - zlo[None, :]) / DZ, 0.0, 1.0)
                    for L in LENGTHS])
    return xr.Dataset({"phi": (("time", "x", "z"), phi, {"units": "1"})},
                      coords={"time": ("time", TIMES, {"units": "s"}),
                              "x": ("x", XC, {"units": "m"}), "z": ("z", ZC, {"units": "m"})},
                      attrs={"phi_max": PHI_MAX})


def test_deposit_thickness_of_triangle():
    ds = triangle_dataset()
    h = ds.granflow.deposit_thickness()
    assert h.dims == ("time", "x") and h.attrs["units"] == "m"
    for k, L in enumerate(LENGTHS):
        np.testing.assert_allclose(h.isel(time=k).values, H(XC, L), rtol=RTOL, atol=1e-15)
    np.testing.assert_allclose(ds.granflow.deposit_thickness(t=0.6).values, H(XC, LENGTHS[1]),
                               rtol=RTOL, atol=1e-15)


@pytest.mark.parametrize("thr", [DZ, 0.02])
def test_front_and_runout_of_triangle(thr):
    ds = triangle_dataset()
    exact = LENGTHS * (1.0 - thr / H0)  # H(x_f) = thr
    edge = np.array([XC[H(XC, L) > thr].max() + DX / 2 for L in LENGTHS])  # right edge of the column
    lin = ds.granflow.front_position(threshold=thr, method="linear")
    assert lin.dims == ("time",) and lin.attrs["units"] == "m"
    np.testing.assert_allclose(lin.values, exact, rtol=RTOL)
    np.testing.assert_allclose(ds.granflow.front_position(threshold=thr).values, edge, rtol=RTOL)
    r = ds.granflow.runout(threshold=thr, method="linear")
    assert r.ndim == 0 and r.attrs["units"] == "m"
    np.testing.assert_allclose(float(r), exact[-1] - exact[0], rtol=RTOL)
    np.testing.assert_allclose(float(ds.granflow.runout(threshold=thr)), edge[-1] - edge[0],
                               rtol=RTOL)
    # the front is within one column of the exact crossing (its documented resolution)
    assert np.all(np.abs(edge - exact) <= DX)
    assert ds.granflow.front_position(thr).attrs["resolution"] == pytest.approx(DX, rel=1e-9)
    # the same flow spreading towards -x
    mirror = ds.assign_coords(x=("x", -XC, {"units": "m"})).isel(x=slice(None, None, -1))
    np.testing.assert_allclose(mirror.granflow.front_position(thr, "linear", "-x").values,
                               -exact, rtol=RTOL)
    np.testing.assert_allclose(float(mirror.granflow.runout(thr, "linear", "-x")),
                               exact[-1] - exact[0], rtol=RTOL)
    np.testing.assert_allclose(mirror.granflow.front_position(thr, direction="-x").values, -edge,
                               rtol=RTOL)


def test_front_defaults_and_edge_cases():
    ds = triangle_dataset()
    np.testing.assert_array_equal(ds.granflow.front_position().values,
                                  ds.granflow.front_position(threshold=DZ).values)
    assert np.isnan(ds.granflow.front_position(threshold=1.0).values).all()
    with pytest.raises(GranflowInputError, match="threshold"):
        ds.granflow.front_position(threshold=-1.0)
    snap = ds.granflow.snapshot(0.6)
    assert float(snap.time) == 0.5 and snap.phi.dims == ("x", "z")
    np.testing.assert_allclose(float(snap.granflow.front_position(method="linear")),
                               LENGTHS[1] * (1 - DZ / H0), rtol=RTOL)


def test_phi_max_and_cell_heights_sources():
    heights = np.array([0.001, 0.002, 0.004, 0.008])
    edges = np.concatenate([[0.0], np.cumsum(heights)])
    z = 0.5 * (edges[1:] + edges[:-1])
    phi = np.full((1, 3, 4), 0.3)
    ds = xr.Dataset({"phi": (("time", "x", "z"), phi, {"phi_max": 0.5}),
                     "z_bounds": (("z", "nv"), np.stack([edges[:-1], edges[1:]], axis=1))},
                    coords={"time": [0.0], "x": [0.0, 1.0, 2.0], "z": ("z", z, {"bounds": "z_bounds"})})
    np.testing.assert_allclose(ds.granflow.cell_heights().values, heights, rtol=RTOL)
    np.testing.assert_allclose(ds.granflow.deposit_thickness().values,
                               np.full((1, 3), 0.3 * heights.sum() / 0.5), rtol=RTOL)
    no_bounds = ds.drop_vars("z_bounds").assign_coords(z=("z", z))
    with pytest.raises(GranflowInputError, match="not uniformly spaced"):
        no_bounds.granflow.deposit_thickness()
    no_phi_max = triangle_dataset()
    no_phi_max.attrs = {}
    with pytest.raises(GranflowInputError, match="phi_max"):
        no_phi_max.granflow.runout()
    with pytest.raises(GranflowInputError, match="'phi'"):
        xr.Dataset().granflow.front_position()


def test_accessor_on_a_written_file(tmp_path):
    path = tmp_path / "tri.nc"
    ds0 = triangle_dataset()
    coords = {"x": (XC, {"units": "m", "long_name": "x"}), "z": (ZC, {"units": "m", "long_name": "z"})}
    spec = {"phi": VariableSpec(("time", "x", "z"), "1", "packing fraction")}
    with NetCDFWriter(path, coords, spec, global_attrs={"phi_max": PHI_MAX}) as w:
        for k, t in enumerate(TIMES):
            w.append(t, {"phi": ds0.phi.isel(time=k).values})
    with xr.open_dataset(path) as ds:
        np.testing.assert_allclose(float(ds.granflow.runout(method="linear")),
                                   (LENGTHS[-1] - LENGTHS[0]) * (1 - DZ / H0), rtol=RTOL)


@pytest.mark.parametrize("module", [granflow.output.summary, granflow.output.netcdf,
                                    granflow.output.accessor])
def test_docstring_examples(module):
    result = doctest.testmod(module)
    assert result.attempted > 0 and result.failed == 0
