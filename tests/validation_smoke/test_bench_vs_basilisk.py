"""benchmarks/vs_basilisk.py (issue 15 item 1) without Basilisk: it skips cleanly when the
Basilisk folder or its executable is missing, its deposit rule is granflow's front rule, and its
granflow command lines are valid case overrides.
"""
from __future__ import annotations

import stat

import numpy as np
import pytest
from _scripts import load_script

from granflow import diagnostics as dg
from granflow.config import load_case


@pytest.fixture(scope="module")
def bench():
    return load_script("benchmarks/vs_basilisk.py", "bench_vs_basilisk")


@pytest.mark.parametrize("argv", [[], ["--quick"], ["--basilisk-dir", "/nonexistent/basilisk"]])
def test_skips_with_a_message_without_basilisk(bench, capsys, argv):
    assert bench.main(argv) == 0
    out = capsys.readouterr().out
    assert out.startswith("vs_basilisk: skipped:") and "benchmarks/README.md" in out


def test_skips_when_the_folder_has_no_executable(bench, capsys, tmp_path):
    assert bench.main(["--basilisk-dir", str(tmp_path)]) == 0
    assert "no executable granular_column_bench" in capsys.readouterr().out


def test_deposit_lines_front_and_profile_follow_granflow_rules(bench):
    n, dx = 8, 5.0 / 8
    h = np.array([0.6, 0.5, 0.3, 0.06, 0.04, 0.0, 0.051, -1e-21])
    text = "noise\n" + f"deposit 4 447 {dx} " + " ".join(map(str, h)) + "\n"
    steps, dx_read, h_read = bench.parse_deposits(text)[4.0]
    assert steps == 447 and dx_read == dx and np.array_equal(h_read, h)
    edges = np.arange(n + 1) * dx
    assert bench.front(h, dx) == dg.front_from_thickness(edges, h, 0.05) == 7 * dx
    assert bench.profile(h, dx, x=[0.0, dx, 5.0]) == pytest.approx([0.6, 0.55, 0.0], abs=1e-12)


@pytest.mark.parametrize("variant", ["v1", "consistent", "v2", "v2_1solve", "defaults"])
def test_granflow_command_lines_are_valid_overrides(bench, tmp_path, variant):
    cmd = bench.granflow_cmd(32, 6.26, variant, tmp_path)
    sets = [cmd[i + 1] for i, a in enumerate(cmd) if a == "--set"]
    cfg = load_case(bench.CASE_FILE, sets)
    assert (cfg.grid.nx, cfg.grid.nz, cfg.time.stop_time, cfg.setup.a) == (32, 32, 4.0, 6.26)
    assert cfg.output.figures is False
    # every variant but "defaults" pins its scheme and its loop, so that it keeps its meaning
    # when the defaults change; "defaults" is the case file's numerics, whatever they are
    default = load_case(bench.CASE_FILE, [])
    want = {"v1": ("upwind", "threshold", 10, 0.3), "consistent": ("consistent", "threshold", 10, 0.3),
            "v2": ("consistent", "indicator", 10, 0.3), "v2_1solve": ("consistent", "indicator", 1, 0.3),
            "defaults": (default.numerics.advection, default.numerics.surface,
                         default.numerics.picard.max_sweeps, default.time.cfl)}[variant]
    got = (cfg.numerics.advection, cfg.numerics.surface, cfg.numerics.picard.max_sweeps, cfg.time.cfl)
    assert got == want


def test_resolutions_must_be_powers_of_two(bench):
    assert bench.level_of(128) == 7
    with pytest.raises(SystemExit):
        bench.level_of(96)
