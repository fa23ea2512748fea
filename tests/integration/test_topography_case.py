"""A base profile in a case file (``[topography]``, issue 14 item 3): read, checked, run, written.

The run is a tiny version of examples/column_on_topography.toml; its output must describe the
profile (summary.json, output.nc attributes) and keep the grains out of the rock.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from granflow.cli import main
from granflow.cli.commands import ExitCode
from granflow.config import CaseConfig, load_case
from granflow.errors import GranflowInputError

from _restart import assert_restart_bit_identical
from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLE = ROOT / "examples" / "column_on_topography.toml"


def test_example_profile_is_read_and_given_to_the_model():
    cfg = load_case(EXAMPLE)
    topo = cfg.make_topography()
    assert topo.x.tolist() == [0.0, 0.3, 0.6] and topo.z.tolist() == [0.109, 0.0, 0.0]
    assert CaseConfig.from_dict({"case": {"name": "column_collapse"}}).make_topography() is None


def test_profile_from_a_csv_file_next_to_the_case_file(tmp_path):
    (tmp_path / "profile.csv").write_text("x_m,z_m\n0.0,0.04\n0.4,0.0\n")
    case = tmp_path / "case.toml"
    case.write_text('[case]\nname = "column_collapse"\n[topography]\nfile = "profile.csv"\n')
    cfg = load_case(case)
    assert cfg.topography.x == [0.0, 0.4] and cfg.topography.z == [0.04, 0.0]
    assert cfg.topography.file is None and "file" not in cfg.to_toml().split("[topography]")[1]
    case.write_text('[case]\nname = "column_collapse"\n[topography]\nfile = "none.csv"\n')
    with pytest.raises(GranflowInputError, match="topography.file: .*none.csv.* does not exist"):
        load_case(case)


@pytest.mark.parametrize("topography, match", [
    ({"x": [0.0, 1.0], "z": [0.1]}, "same length"),
    ({"x": [0.0, 0.0], "z": [0.1, 0.1]}, "strictly increasing"),
    ({"x": [0.0], "z": [0.1], "file": "a.csv"}, "not both"),
    ({"x": [0.0], "z": [0.1], "slope": 3}, "slope"),
])
def test_bad_profiles_name_the_key(topography, match):
    with pytest.raises(GranflowInputError, match=match):
        CaseConfig.from_dict({"case": {"name": "column_collapse"}, "topography": topography})


def test_cases_on_a_flat_base_and_the_injection_refuse_a_profile():
    for name in ("static_layer", "lagree_column", "sheared_layer"):
        with pytest.raises(GranflowInputError, match=f"topography.x: {name} has the box's flat base"):
            CaseConfig.from_dict({"case": {"name": name}, "topography": {"x": [0.0], "z": [0.01]}})
    with pytest.raises(GranflowInputError, match='setup.preparation: "injection" .* not available'):
        CaseConfig.from_dict({"case": {"name": "column_collapse"}, "gas": {"law": "linear"},
                              "setup": {"preparation": "injection"},
                              "topography": {"x": [0.0], "z": [0.01]}})
    with pytest.raises(GranflowInputError, match=r"setup.H0: the column \(0.1 m\) on the profile"):
        CaseConfig.from_dict({"case": {"name": "column_collapse"}, "topography": {"x": [0.0], "z": [0.1]}})


def test_tiny_run_on_the_example_profile(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["run", str(EXAMPLE), "--out", str(out), "--quiet", "--set", "grid.nx=24",
                 "--set", "grid.nz=10", "--set", "time.stop_time=0.05"])
    assert code == ExitCode.OK, capsys.readouterr().err
    s = json.loads((out / "summary.json").read_text())
    assert s["topography"]["x_m"] == [0.0, 0.3, 0.6]
    assert 0.0 < s["topography"]["staircase_error_m"] <= 0.5 * 0.025 + 1e-12
    assert abs(s["mass_rel_error"]) < 1e-12 and s["clipped_mass"] == 0.0
    with xr.open_dataset(out / "output.nc") as ds:
        base = np.asarray(ds.attrs["base_height"])
        assert base.shape == (24,) and base[0] > base[-1] == 0.0
        assert np.allclose(ds.attrs["topography_z"], [0.109, 0.0, 0.0])
        rock = ds["z"].values[None, :] < base[:, None]
        assert float(np.abs(ds["phi"].transpose("time", "x", "z").values[:, rock]).max()) == 0.0
    assert (out / "snapshots.png").exists()


def test_restart_on_a_profile_is_bit_identical(tmp_path, capsys):
    """A run on the example profile restarted from its checkpoint at t = 0.03 s ends with the
    straight run's fields and budget, bit for bit (the profile is in the restored configuration)."""
    assert_restart_bit_identical(EXAMPLE, tmp_path, ["--set", "output.figures=false", "--set", "grid.nx=24",
                                                     "--set", "grid.nz=10", "--set", "output.interval=0.01"], 0.03, 0.05)
    capsys.readouterr()
