"""The worked example of docs/cases.md, "Writing a new case in Python" (issue 14 item 5): the case
module examples/custom_case/mound.py, registered from outside the package, runs through the case
runner as documented, conserves mass, keeps 0 <= phi <= phi_max, and a heap slumps when its slope
exceeds the closure's static friction coefficient and stays when below it."""
from __future__ import annotations

import importlib.util
import json
import re
import sys

import numpy as np
import pytest
import xarray as xr

from granflow.cases import CASES
from granflow.cli import main
from granflow.config import load_case

from _scripts import ROOT  # noqa: E402  (the repository, whatever the tier folder)
MODULE = ROOT / "examples" / "custom_case" / "mound.py"
CASE_FILE = ROOT / "examples" / "custom_case" / "mound.toml"
MODULE_NAME = "granflow_example_mound"
"""Name under which the test imports the example module (any name not taken)."""
VERBATIM = re.compile(r"^<!-- verbatim: (\S+) -->\n```[a-z]*\n(.*?)^```", re.S | re.M)
"""A docs block marked as a copy of a repository file: ``<!-- verbatim: PATH -->`` then the block."""

TINY = ["grid.nx=12", "grid.nz=4", "time.stop_time=0.1", "output.figures=false"]
"""Overrides making the documented run tiny (0.1 s on 12 x 4 cells)."""
MASS_RTOL = 1e-12
"""Relative tolerance on the conservation of the grain volume sum(phi) dx dz [-]."""
PROFILE_RTOL = 5e-3
"""Relative error of the initial volume with the module's 8 x 8 sub-grid points per cell on the
example's 24 x 8 grid [-] (measured 1.5e-3)."""
FINE_SUBCELLS = 32
"""A finer sub-grid, which must halve that error [-]."""
SLOPE_FACTOR = 2.0
"""The steep wedge's slope is this many times the friction coefficient, the gentle one's this
many times smaller [-]."""
WEDGE_GRID = ["grid.nx=16", "grid.nz=8", "time.stop_time=0.3", "output.figures=false"]
"""Grid and duration of the wedge runs (dx = 15 mm, dz = 10 mm; 0.3 s, 150 steps)."""
GENTLE_HALF_WIDTH = 0.1
"""Base half-width of the gentle wedge [m] (its height is then about 2 cells)."""
STEEP_HALF_WIDTH = 0.07
"""Base half-width of the steep wedge [m] (its height is then about 6 cells)."""
STILL_DH = 0.01
"""A heap at rest: no column's deposit thickness changes by more than this fraction of dz [-]
(measured 1.2e-3 for the gentle wedge)."""
SLUMP_DROP = 0.1
"""A heap that slumps: its thickness at the wall drops by more than this fraction (measured 0.28
for the steep wedge) [-]."""
CENTRE_DROP = 0.005
"""The documented ellipse slumps: the height of its centre of mass falls by more than this
fraction in the tiny run (measured 0.016) [-]."""


@pytest.fixture(scope="module")
def mound():
    """The example module, imported as user code (it registers the case ``mound``); unregistered
    afterwards. The module goes into sys.modules before it runs: pydantic resolves the ``[setup]``
    model's annotations there."""
    spec = importlib.util.spec_from_file_location(MODULE_NAME, MODULE)
    module = importlib.util.module_from_spec(spec)
    sys.modules[MODULE_NAME] = module
    spec.loader.exec_module(module)
    yield module
    CASES.unregister("mound")
    del sys.modules[MODULE_NAME]


def thickness(ds: xr.Dataset, phi_max: float) -> np.ndarray:
    """Deposit thickness h(t, x) = sum_z phi dz / phi_max [m]."""
    dz = float(ds.z[1] - ds.z[0])
    return ds.phi.transpose("time", "x", "z").values.sum(axis=2) * dz / phi_max


def test_the_docs_hold_the_example_files_verbatim():
    blocks = VERBATIM.findall((ROOT / "docs" / "cases.md").read_text(encoding="utf-8"))
    assert {path for path, _ in blocks} == {"examples/custom_case/mound.py",
                                            "examples/custom_case/mound.toml"}
    for path, text in blocks:
        assert text == (ROOT / path).read_text(encoding="utf-8"), f"docs/cases.md: stale copy of {path}"


def test_the_documented_run_conserves_mass_and_bounds_phi(mound, tmp_path):
    """``granflow run mound.toml`` (the documented command: the CLI with the module loaded)."""
    out = tmp_path / "mound"
    assert main(["run", str(CASE_FILE), "--out", str(out), "--quiet", *[f"--set={s}" for s in TINY]]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed"
    assert summary["case_diagnostics"]["profile"] == "ellipse"
    assert (out / "checkpoints").is_dir()
    phi_max = load_case(CASE_FILE).material.phi_max
    with xr.open_dataset(out / "output.nc") as ds:
        assert ds.sizes["time"] >= 3
        phi = ds.phi.values
        assert phi.min() >= 0.0 and phi.max() <= phi_max
        mass = phi.sum(axis=(1, 2))
        assert np.abs(mass / mass[0] - 1.0).max() < MASS_RTOL
        h = thickness(ds, phi_max)
        z_centre = (phi * ds.z.values[None, :, None]).sum(axis=(1, 2)) / mass  # phi is (t, z, x)
        beyond_toe = (ds.x.values > load_case(CASE_FILE).setup.a)
    # the semi-ellipse is vertical at its toe, steeper than any friction angle: it slumps, grains
    # pass its toe and its centre of mass falls
    assert h[0, beyond_toe].max() == 0.0 and h[-1, beyond_toe].max() > 0.0
    assert z_centre[-1] < (1.0 - CENTRE_DROP) * z_centre[0]


def test_the_initial_heap_follows_its_profile(mound):
    """The cell fractions integrate the profile: the initial volume is phi0 pi H a / 4 (ellipse)
    within PROFILE_RTOL with the module's sub-grid, and closer on a finer one (the midpoint rule
    converges); phi0 fills the cells under the surface."""
    config = load_case(CASE_FILE)
    grid = mound.make_model(config).grid
    s = config.setup
    exact = config.material.phi_max * np.pi / 4 * s.H * s.a

    def error(n: int) -> float:
        phi = mound.packing(config) * mound.cell_fraction(
            grid, lambda x, z: z < s.H * mound.PROFILES["ellipse"](x / s.a), n)
        return abs(phi.sum() * grid.dx * grid.dz / exact - 1.0)

    phi = mound.phi_initial(config, grid)
    assert abs(phi.sum() * grid.dx * grid.dz / exact - 1.0) == error(mound.SUBCELLS) < PROFILE_RTOL
    assert error(FINE_SUBCELLS) < error(mound.SUBCELLS) / 2
    assert phi.min() == 0.0 and phi.max() == config.material.phi_max


@pytest.mark.parametrize("steep", [False, True], ids=["gentle", "steep"])
def test_a_wedge_slumps_above_the_friction_coefficient_and_stays_below(mound, tmp_path, steep):
    """Wedges of slope SLOPE_FACTOR times the closure's static friction coefficient Z(phi, 0)
    (sin(25 deg) = 0.423 for the example's drucker_prager: not tan(delta)) and SLOPE_FACTOR times
    below it. Below: the front does not move by one column and no thickness changes by
    STILL_DH dz. Above: the front advances and the heap's thickness at the wall drops by more
    than SLUMP_DROP."""
    config = load_case(CASE_FILE)
    mu = mound.friction_coefficient(config)
    assert mu == pytest.approx(np.sin(np.radians(config.closure.delta_deg)))
    a = STEEP_HALF_WIDTH if steep else GENTLE_HALF_WIDTH
    slope = mu * SLOPE_FACTOR if steep else mu / SLOPE_FACTOR
    out = tmp_path / "wedge"
    assert main(["run", str(CASE_FILE), "--out", str(out), "--quiet",
                 *[f"--set={s}" for s in [*WEDGE_GRID, 'setup.profile="wedge"', f"setup.a={a}",
                                          f"setup.H={slope * a}"]]]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["case_diagnostics"]["mean_slope"] == pytest.approx(slope)
    dx = summary["resolution"]["dx_m"]
    dz = summary["resolution"]["dz_m"]
    with xr.open_dataset(out / "output.nc") as ds:
        h = thickness(ds, config.material.phi_max)
    if steep:
        assert summary["runout_m"] >= dx
        assert h[-1, 0] < (1.0 - SLUMP_DROP) * h[0, 0]
    else:
        assert summary["runout_m"] == 0.0
        assert np.abs(h[-1] - h[0]).max() < STILL_DH * dz


def test_granflow_finds_an_outside_case_through_the_environment(tmp_path):
    """GRANFLOW_CASES_PATH (granflow.cases.CASES_PATH_ENV) makes the installed command know the
    example's case: ``list cases`` names it and ``run`` completes with mass conserved; a path that
    is not a directory is refused with exit 2, naming the variable."""
    import subprocess

    from granflow.cases import CASES_PATH_ENV

    env = {**__import__("os").environ, CASES_PATH_ENV: str(MODULE.parent)}
    cmd = [sys.executable, "-c", "import sys; from granflow.cli import main; sys.exit(main())"]
    listed = subprocess.run(cmd + ["list", "cases"], env=env, capture_output=True, text=True, timeout=120)
    assert listed.returncode == 0 and "\nmound" in "\n" + listed.stdout
    out = tmp_path / "run"
    run = subprocess.run(cmd + ["run", str(CASE_FILE), "--out", str(out), "--quiet", "--set", "grid.nx=12",
                                "--set", "grid.nz=4", "--set", "time.stop_time=0.05", "--set",
                                "output.figures=false"], env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["case"] == "mound" and abs(summary["mass_rel_error"]) < 1e-12
    bad = subprocess.run(cmd + ["list", "cases"], env={**env, CASES_PATH_ENV: str(tmp_path / "nope")},
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and CASES_PATH_ENV in bad.stderr and "Traceback" not in bad.stderr
