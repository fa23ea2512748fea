"""A run whose grains reach the box edge says so (issue 16 item 1, issue 14 item 1): summary
warnings and ``wall_contact``, output.nc flags; a layer that fills the box is not reported."""
from __future__ import annotations

import json

import netCDF4
import numpy as np

from granflow.output.wall_contact import WallWatch
from granflow.cli import ExitCode, main

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)


def test_watch_reports_new_contacts_once_and_ignores_the_initial_ones():
    w = WallWatch(periodic_x=False)
    phi = np.zeros((6, 4))
    phi[:2, :2] = 0.6
    assert w.check(phi, 0.6, 0.0) == []
    phi[-1, 0] = 0.01                      # a film in the last column
    assert w.check(phi, 0.6, 0.3) == ["east_wall"]
    assert w.check(phi, 0.6, 0.4) == []    # once
    assert w.attributes() == {"reached_east_wall": 1, "reached_east_wall_t": 0.3, "reached_lid": 0,
                              "reached_east_outflow": 0}
    assert w.check(phi, 0.6, 0.5, outflow_cells=1e-4) == []          # a round-off trace left
    assert w.check(phi, 0.6, 0.6, outflow_cells=0.5) == ["east_outflow"]
    full = WallWatch(periodic_x=False)
    layer = np.full((6, 4), 0.6)
    layer[:, -1] = 0.0
    assert full.check(layer, 0.6, 0.0) == [] and full.check(layer, 0.6, 1.0) == []
    assert WallWatch(periodic_x=True).check(phi, 0.6, 0.0) == []


def test_collapse_cut_by_the_east_wall_is_flagged(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["run", str(ROOT / "examples" / "column_collapse_dry.toml"), "--out", str(out), "--quiet",
                 "--set", "grid.nx=12", "--set", "grid.nz=6", "--set", "grid.Lx=0.15", "--set", "grid.Lz=0.15",
                 "--set", "time.stop_time=0.3", "--set", "output.figures=false"])
    assert code == ExitCode.OK
    summary = json.loads((out / "summary.json").read_text())
    assert "east_wall" in summary["wall_contact"]
    assert any("reached the east wall" in w and "lower bound" in w for w in summary["warnings"])
    err = capsys.readouterr().err
    assert "granflow: warning: grains reached the east wall" in err
    assert "warning: granflow:" not in err and "warning: granflow:" not in " ".join(summary["warnings"])
    with netCDF4.Dataset(out / "output.nc") as ds:
        assert ds.getncattr("reached_east_wall") == 1 and ds.getncattr("reached_lid") == 0
        assert 0.0 < ds.getncattr("reached_east_wall_t") <= 0.3


def test_wall_contact_survives_a_restart(tmp_path, capsys):
    """Reached before the checkpoint (t = 0.14 s on this grid), the east wall is still flagged
    after a restart: output.nc attributes, summary ``wall_contact`` and warning (the recorder's
    checkpoint scalars ``walls.*``). Before they existed the restarted file had no flag."""
    out = tmp_path / "run"
    args = ["run", str(ROOT / "examples" / "column_collapse_dry.toml"), "--out", str(out), "--quiet",
            "--set", "grid.nx=12", "--set", "grid.nz=6", "--set", "grid.Lx=0.15", "--set", "grid.Lz=0.15",
            "--set", "output.figures=false"]
    assert main(args + ["--set", "time.stop_time=0.2"]) == ExitCode.OK
    first = json.loads((out / "summary.json").read_text())["wall_contact"]["east_wall"]
    assert 0.0 < first <= 0.2
    assert main(args + ["--set", "time.stop_time=0.3", "--restart", str(out)]) == ExitCode.OK
    summary = json.loads((out / "summary.json").read_text())
    assert summary["t_final"] == 0.3 or abs(summary["t_final"] - 0.3) < 1e-9
    assert summary["wall_contact"]["east_wall"] == first
    assert any("reached the east wall" in w for w in summary["warnings"])
    with netCDF4.Dataset(out / "output.nc") as ds:
        assert ds.getncattr("reached_east_wall") == 1
        assert ds.getncattr("reached_east_wall_t") == first
    capsys.readouterr()
