"""`granflow --help` stays light (issue 15 item 4): it must not import the numerical or plotting
stack. A module check, not a timing (benchmarks/startup.py measures the time). Merging the config
package once made --help import the whole solver through granflow.config's re-exports (0.12 -> 0.67 s
on the development machine); this test would have caught it. The same for what a run imports
(scipy.optimize, xarray), and the ds.granflow accessor still registered when xarray comes later."""
import subprocess
import sys

import pytest

HEAVY = ("numpy", "scipy", "xarray", "netCDF4", "pydantic", "sympy", "matplotlib", "numba", "dask")

PROBE = """
import sys

import pytest
from granflow.cli import main
try:
    main(["--help"])
except SystemExit:
    pass
print("LOADED", *[m for m in {heavy!r} if m in sys.modules])
"""


def test_help_imports_no_heavy_dependency():
    res = subprocess.run([sys.executable, "-c", PROBE.format(heavy=HEAVY)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    line = [ln for ln in res.stdout.splitlines() if ln.startswith("LOADED")][-1]
    assert line.split()[1:] == [], f"granflow --help imported {line.split()[1:]}"


def test_config_overrides_do_not_import_the_schema():
    # the --set parser is used by the CLI before any case is loaded
    code = ("import sys, granflow.config.overrides; "
            "print('granflow.config.schema' in sys.modules, 'granflow.model' in sys.modules)")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["False", "False"]


RUN_PATH = "granflow.casekit.runner, granflow.cli, granflow.cases, granflow.model, granflow.output"
"""What a run imports."""
NOT_ON_THE_RUN_PATH = (
    # the two brentq root finds (dilatancy's backward-Euler layer step, the defluidisation
    # half-life) import it where they run: it was 0.16-0.2 s of every run's start-up
    "scipy.optimize",
    # the velocity band's dilations use granflow.max_filter (scipy.ndimage's import parses ~170
    # docstrings: 0.07-0.17 s of every run)
    "scipy.ndimage",
    # a run writes with netCDF4; the ds.granflow accessor (xarray + pandas, 0.3-0.5 s) is
    # registered only when xarray is imported (granflow.output.xarray_hook)
    "xarray",
    "pandas",
    # the AMG solvers import PyAMG where they build a hierarchy or iterate: a run on PARDISO or
    # SuperLU never needs it (77 ms of every run's start-up, session 25)
    "pyamg",
)


@pytest.mark.parametrize("module", NOT_ON_THE_RUN_PATH)
def test_a_run_does_not_import(module):
    code = f"import sys, {RUN_PATH}; print({module!r} in sys.modules)"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["False"]


ACCESSOR_PROBE = """
import sys

import pytest
{first}
{second}
import numpy as np
path = sys.argv[1]
xr.Dataset({{"phi": (("time", "x", "z"), np.full((2, 4, 2), 0.6) * [[[1], [1], [0], [0]]],
                    {{"phi_max": 0.6}})}},
           coords={{"time": [0.0, 1.0], "x": np.arange(4) * 0.1 + 0.05,
                    "z": np.arange(2) * 0.01 + 0.005}}).to_netcdf(path)
with xr.open_dataset(path) as ds:
    print(float(ds.granflow.front_position().values[0]))
print(type(xr.__spec__.loader).__name__, type(xr.__loader__).__name__)
print([type(f).__name__ for f in sys.meta_path if type(f).__name__ == "XarrayImportHook"])
"""


@pytest.mark.parametrize("first, second", [
    ("import granflow.output", "import xarray as xr"),  # the hook registers it
    ("import xarray as xr", "import granflow.output"),  # registered at once
    ("import granflow.casekit.runner", "import xarray as xr"),  # what a run imports
])
def test_the_accessor_is_registered_whichever_is_imported_first(tmp_path, first, second):
    code = ACCESSOR_PROBE.format(first=first, second=second)
    res = subprocess.run([sys.executable, "-c", code, str(tmp_path / "ds.nc")], capture_output=True,
                         text=True)
    assert res.returncode == 0, res.stderr
    front, loaders, hooks = res.stdout.splitlines()
    assert float(front) == pytest.approx(0.2)
    assert loaders == "SourceFileLoader SourceFileLoader"  # xarray's own loader, not the wrapper
    assert hooks == "[]"  # one shot: removed after use
