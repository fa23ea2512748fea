"""Ctrl-C during the start-up of ``granflow run`` (imports, case loading, model set-up -- before
the run's own SIGINT handler is installed) exits with 130 (128 + SIGINT), not 1 and not a
traceback."""
from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from _scripts import ROOT, terminal_sigint  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLE = ROOT / "examples" / "column_collapse_dry.toml"
# The console script's body, with a line on stdout once ``main`` has entered its ``try`` (printed
# from build_parser, its first call): the signal is sent after it, so it cannot land before
# granflow's handler exists (a KeyboardInterrupt outside ``main`` makes Python die of the signal,
# returncode -2, which is not what is tested: printing before calling ``main`` left a few bytecodes
# of that window open, and the test failed about once in four runs on a loaded machine), and it
# lands while ``granflow run`` is still importing the solver and loading the case (about a second),
# long before the first step.
CHILD = "\n".join([
    "import sys",
    "import granflow.cli as cli",
    "build = cli.build_parser",
    "def build_parser():",
    "    parser = build()",
    "    print('ready', flush=True)",
    "    return parser",
    "cli.build_parser = build_parser",
    "sys.exit(cli.main())",
])


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_during_run_start_up_exits_130(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, "run", str(EXAMPLE), "--out", str(tmp_path / "run"),
         "--quiet", "--set", "grid.nx=16", "--set", "grid.nz=6"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, preexec_fn=terminal_sigint)
    try:
        assert proc.stdout.readline().strip() == "ready"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert "interrupted" in err
