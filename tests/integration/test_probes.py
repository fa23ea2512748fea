"""Basal probes (``output.probes_x``): p_f and p of the bottom cell under each x, a time series in
output.nc, checked against the recorded fields themselves and against the initial lithostatic
pressure (p_f0 = b0 p_lith, the initial state of case column_collapse)."""
from __future__ import annotations


import numpy as np
import pytest
import xarray as xr

from granflow.cli import main
from granflow.config import load_case
from granflow.errors import GranflowInputError
from _scripts import ROOT  # the repository (tests/ holds tiers)

EXAMPLE = ROOT / "examples" / "column_collapse_fluidised.toml"
TINY = ["grid.nx=16", "grid.nz=6", "grid.Lx=0.4", "time.stop_time=0.02", "output.interval=0.01"]  # the 0.4 m box the
# expected values below are computed for (the example itself is 0.5 m long)


def test_probes_record_the_basal_pore_pressure(tmp_path):
    out = tmp_path / "run"
    argv = ["run", str(EXAMPLE), "--out", str(out), "--quiet", "--set", "output.probes_x=[0.01, 0.04, 0.3]"]
    for item in TINY:
        argv += ["--set", item]
    assert main(argv) == 0
    with xr.open_dataset(out / "output.nc") as ds:
        assert ds["probe_p_f"].dims == ("time", "x_probe") and ds["probe_p_f"].attrs["units"] == "Pa"
        np.testing.assert_allclose(ds["x_probe"], [0.0125, 0.0375, 0.2875])  # centres of cells 0, 1, 11
        for k, cell in enumerate((0, 1, 11)):
            np.testing.assert_array_equal(ds["probe_p_f"][:, k], ds["p_f"].isel(x=cell, z=0))
            np.testing.assert_array_equal(ds["probe_p"][:, k], ds["p"].isel(x=cell, z=0))
        # t = 0: p_f = b0 x the discrete lithostatic pressure at the bottom centre of a full column,
        # phi0 rho_s g (H0 - dz/2) for the 4 cells under H0 = 0.1 m (dz = 0.025 m)
        expected = 0.9 * 0.58 * 2500.0 * 9.81 * (0.1 - 0.0125)
        np.testing.assert_allclose(ds["probe_p_f"][0, :2], expected, rtol=1e-12)
        assert float(ds["probe_p_f"][0, 2]) == 0.0  # x = 0.3 m: ambient


def test_probe_outside_the_box_is_rejected():
    with pytest.raises(GranflowInputError, match=r"output\.probes_x.*\[0\.8\]"):
        load_case(EXAMPLE, overrides=["output.probes_x=[0.1, 0.8]"])  # the box is 0.7 m long


def test_restart_with_other_probes_is_rejected(tmp_path):
    out = tmp_path / "run"
    argv = ["run", str(EXAMPLE), "--out", str(out), "--quiet", "--set", "output.probes_x=[0.01]"]
    for item in TINY:
        argv += ["--set", item]
    assert main(argv) == 0
    argv = ["run", str(EXAMPLE), "--out", str(out), "--quiet", "--restart", str(out),
            "--set", "output.probes_x=[0.2]", "--set", "time.stop_time=0.04"]
    for item in TINY[:3]:
        argv += ["--set", item]
    assert main(argv) == 2


def test_probe_box_of_a_dimensionless_case_is_its_setup_box():
    lagree = EXAMPLE.with_name("lagree_column.toml")
    assert load_case(lagree, overrides=["output.probes_x=[1.0, 2.0]"]).output.probes_x == [1.0, 2.0]
    with pytest.raises(GranflowInputError, match=r"output\.probes_x.*setup\.Lx"):
        load_case(lagree, overrides=["output.probes_x=[6.0]"])
