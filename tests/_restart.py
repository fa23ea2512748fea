"""A restart check shared by the integration tests: a run split at ``t_mid`` and continued from its
checkpoint must end as the straight run does, bit for bit."""
from __future__ import annotations

import json

import numpy as np
import xarray as xr

from granflow.cli import main
from granflow.cli.commands import ExitCode


def assert_restart_bit_identical(case_file, tmp_path, args: list[str], t_mid: float, t_end: float) -> None:
    """``granflow run case_file`` to ``t_end`` straight, and to ``t_mid`` then ``--restart`` to
    ``t_end``: the same steps, energy budget and last phi and u."""
    straight, split = tmp_path / "straight", tmp_path / "split"
    run = ["run", str(case_file), "--quiet", *args]
    assert main([*run, "--out", str(straight), "--set", f"time.stop_time={t_end}"]) == ExitCode.OK
    assert main([*run, "--out", str(split), "--set", f"time.stop_time={t_mid}"]) == ExitCode.OK
    assert main([*run, "--out", str(split), "--set", f"time.stop_time={t_end}", "--restart", str(split)]) == ExitCode.OK
    a = json.loads((straight / "summary.json").read_text())
    b = json.loads((split / "summary.json").read_text())
    assert a["energy"] == b["energy"] and a["steps"] == b["steps"]
    with xr.open_dataset(straight / "output.nc") as x, xr.open_dataset(split / "output.nc") as y:
        assert np.array_equal(x["phi"].values[-1], y["phi"].values[-1])
        assert np.array_equal(x["u"].values[-1], y["u"].values[-1])
