"""The script of docs/scripting.md runs as written (issue 18 item 2): a Model, a Simulation and a
NetCDF writer without the case runner. Its ```python block is run in a fresh directory; the file
it writes must hold the declared variables with their units and one record per due time of its
schedule (read from the script itself, so that the check follows an edit of the doc)."""
from __future__ import annotations

import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
DOC = ROOT / "docs" / "scripting.md"
PYTHON_BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
TIMEOUT_S = 300


def script() -> str:
    """The first ```python block of docs/scripting.md."""
    blocks = PYTHON_BLOCK.findall(DOC.read_text(encoding="utf-8"))
    assert blocks, f"{DOC}: no ```python block"
    return blocks[0]


def expected_times(text: str) -> np.ndarray:
    """Record times of the script's writer: 0, interval, ... up to the stop time, plus the stop
    time itself when it is not one of them [s]."""
    interval = float(re.search(r"TimeInterval\(([0-9.eE+-]+)\)", text).group(1))
    stop = float(re.search(r"stop_time=([0-9.eE+-]+)", text).group(1))
    n = math.floor(stop / interval * (1 + 1e-12))
    times = [k * interval for k in range(n + 1)]
    if stop > times[-1] * (1 + 1e-12):
        times.append(stop)
    return np.array(times)


def test_expected_times_counts_the_final_record():
    assert expected_times("TimeInterval(0.02) stop_time=0.1").tolist() == pytest.approx([0, .02, .04, .06, .08, .1])
    assert expected_times("TimeInterval(0.04) stop_time=0.1").tolist() == pytest.approx([0, .04, .08, .1])


def test_the_extraction_finds_the_script():
    text = script()
    assert "NetCDFOutputWriter" in text and "CaseRun" not in text and "granflow.cases" not in text
    assert len([ln for ln in text.splitlines() if ln.strip()]) <= 25


def test_documented_script_writes_the_netcdf_it_says(tmp_path):
    text = script()
    (tmp_path / "script.py").write_text(text, encoding="utf-8")
    env = dict(os.environ, MPLBACKEND="Agg",
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT / "src"), os.environ.get("PYTHONPATH")])))
    res = subprocess.run([sys.executable, "script.py"], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=TIMEOUT_S)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    path = tmp_path / re.search(r'NetCDFOutputWriter\(model, "([^"]+)"', text).group(1)
    with xr.open_dataset(path) as ds:
        assert set(ds.data_vars) == {"phi", "u", "w", "p", "kinetic_energy", "x_front"}
        units = {name: ds[name].attrs["units"] for name in [*ds.data_vars, "x", "z", "time"]}
        assert units == {"phi": "1", "u": "m s-1", "w": "m s-1", "p": "Pa", "kinetic_energy": "J m-1",
                         "x_front": "m", "x": "m", "z": "m", "time": "s"}
        assert all(ds[name].attrs["long_name"] for name in ds.data_vars)
        assert ds.phi.dims == ("time", "z", "x") and ds.phi.shape[1:] == (8, 24)
        times = ds["time"].values.astype(float)
        np.testing.assert_allclose(times, expected_times(text), rtol=0, atol=1e-12)
        assert ds.attrs["Conventions"].startswith("CF-") and ds.attrs["closure"] == "drucker_prager"
        front = ds.x_front.values
        phi = ds.phi.values
    assert np.all(np.isfinite(front)) and front[-1] > front[0]  # the column spreads
    assert phi[0].max() > 0.5 and np.all(phi >= 0)
    printed = res.stdout.split()
    assert printed[:4] == [str(times.size), "records;", "1", "m"]
