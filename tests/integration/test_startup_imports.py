"""`granflow --help` stays light (issue 15 item 4): it must not import the numerical or plotting
stack. A module check, not a timing (benchmarks/startup.py measures the time). Merging the config
package once made --help import the whole solver through granflow.config's re-exports (0.12 -> 0.67 s
on the development machine); this test would have caught it."""
import subprocess
import sys

HEAVY = ("numpy", "scipy", "xarray", "netCDF4", "pydantic", "sympy", "matplotlib", "numba", "dask")

PROBE = """
import sys
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


def test_a_run_does_not_import_scipy_optimize():
    # the two brentq root finds (dilatancy's backward-Euler layer step, the defluidisation
    # half-life) import it where they run: it was 0.16-0.2 s of every run's start-up
    code = ("import sys, granflow.casekit.runner, granflow.cli, granflow.cases; "
            "print('scipy.optimize' in sys.modules)")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["False"]
