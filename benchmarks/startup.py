"""Start-up wall time of the ``granflow`` command and of ``import granflow``; with ``--run``, the
fixed cost of a run.

Times whole processes (fresh interpreter each run, wall clock, ``time.perf_counter`` around
``subprocess.run``, and user CPU, the children's ``resource.getrusage``) and prints, per command,
the median and the minimum of ``--runs`` runs, the ratio of the median wall time to that of the
reference command ``python -c pass`` (the interpreter's own start-up on this machine) and the
median user CPU. Ratios travel between machines better than seconds; the CPU model
name (``/proc/cpuinfo``) and the core count are printed with them. Asserts nothing about time.

Commands (``python`` is this interpreter, ``sys.executable``):

* ``granflow --help`` and ``granflow list closures``, run as the console script does it
  (``from granflow.cli import main; sys.exit(main())``) but without a launcher in front (a pyenv
  shim or a Windows .exe wrapper would add its own start-up);
* ``python -c "import granflow"``;
* the reference ``python -c pass``;
* with ``--run``: ``granflow run examples/lagree_column.toml`` at 128² to t = 0.02 (two steps, no
  figures, output to a temporary directory, one thread): nearly all of it is the fixed cost of a
  run -- imports, Numba's start-up, set-up, output -- that issue 15's whole-process user CPU
  against Basilisk includes (benchmarks/vs_basilisk.py runs the same command line).

The granflow imported is the one on this interpreter's path: to measure a source tree, set
``PYTHONPATH=<tree>/src``. One warm-up run of each command precedes the timed runs (file-system
cache, Numba's kernel cache), after :func:`compile_bytecode` has written granflow's ``__pycache__``:
an installed package has its bytecode (pip compiles it), an editable install writes it on first
import -- unless ``PYTHONDONTWRITEBYTECODE`` is set, as on the development machine, where every
process then compiled granflow's ~100 modules again (0.1-0.2 s of a run's CPU).

Run:   python benchmarks/startup.py [--runs 5] [--importtime] [--run]
Time:  ~10 s for 5 runs; ~25 s more with --run.
"""
from __future__ import annotations

import argparse
import compileall
import importlib.util
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CLI = "import sys; from granflow.cli import main; sys.exit(main())"

COMMANDS = {
    "python -c pass (reference)": [sys.executable, "-c", "pass"],
    "python -c 'import granflow'": [sys.executable, "-c", "import granflow"],
    "granflow --help": [sys.executable, "-c", CLI, "--help"],
    "granflow list closures": [sys.executable, "-c", CLI, "list", "closures"],
}
REFERENCE = "python -c pass (reference)"
ROOT = Path(__file__).resolve().parents[1]
RUN_NAME = "granflow run (Lagree 128², 2 steps)"
RUN_SETS = ["grid.nx=128", "grid.nz=128", "time.stop_time=0.02", "setup.a=1.42",
            "time.stop_at_rest=100", "output.figures=false", "output.interval=1"]
"""The two-step run: vs_basilisk.py's command line at 128² stopped after two steps."""
RUN_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def run_command(out: Path) -> list[str]:
    """``granflow run`` of the two-step Lagrée column, writing to ``out``."""
    cmd = [sys.executable, "-c", CLI, "run", str(ROOT / "examples" / "lagree_column.toml"),
           "--out", str(out), "--overwrite"]
    for s in RUN_SETS:
        cmd += ["--set", s]
    return cmd


def cpu_model() -> str:
    """The CPU model name from /proc/cpuinfo ("unknown" where there is none)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def compile_bytecode() -> str:
    """Write the ``__pycache__`` of the granflow package that this interpreter imports (the one
    the timed processes import, same path) and say where; a stale file is rewritten, a current
    one kept. Python checks a file against its source's time stamp and size, so this cannot make
    a process run old code."""
    spec = importlib.util.find_spec("granflow")
    if spec is None or not spec.submodule_search_locations:
        return "granflow not found: no bytecode written"
    folder = spec.submodule_search_locations[0]
    ok = compileall.compile_dir(folder, quiet=1)
    return f"bytecode of {folder} {'up to date' if ok else 'NOT all compiled'}"


def times(cmd: list[str], runs: int, env: dict | None = None) -> list[tuple[float, float]]:
    """(wall s, user CPU s) of ``runs`` runs of ``cmd`` after one untimed warm-up run."""
    kw = dict(check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
              env={**os.environ, **(env or {})})
    subprocess.run(cmd, **kw)
    out = []
    for _ in range(runs):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
        t0 = time.perf_counter()
        subprocess.run(cmd, **kw)
        out.append((time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - r0))
    return out


def top_imports(code: str = CLI, args: tuple[str, ...] = ("--help",), n: int = 12) -> list[tuple[int, str]]:
    """The ``n`` slowest imports (cumulative microseconds) of ``python -c code args``, from
    ``python -X importtime``."""
    res = subprocess.run([sys.executable, "-X", "importtime", "-c", code, *args],
                         capture_output=True, text=True, check=True)
    rows = []
    for line in res.stderr.splitlines():
        parts = line.split("|")
        if len(parts) == 3 and parts[1].strip().isdigit():
            rows.append((int(parts[1]), parts[2].rstrip()))
    return sorted(rows, reverse=True)[:n]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=5, help="timed runs per command (default 5)")
    ap.add_argument("--importtime", action="store_true",
                    help="also list the slowest imports of granflow --help (python -X importtime), "
                         "and with --run those of granflow.casekit.runner")
    ap.add_argument("--run", action="store_true",
                    help="also time the two-step granflow run (the fixed cost of a run)")
    args = ap.parse_args(argv)

    print(f"CPU: {cpu_model()} ({os.cpu_count()} logical cores), Python {sys.version.split()[0]}, "
          f"median of {args.runs} runs; {compile_bytecode()}")
    results = {name: times(cmd, args.runs) for name, cmd in COMMANDS.items()}
    if args.run:
        with tempfile.TemporaryDirectory() as tmp:
            results[RUN_NAME] = times(run_command(Path(tmp) / "run"), args.runs, RUN_ENV)
    ref = statistics.median(w for w, _ in results[REFERENCE])
    print("| command | median s | min s | median / reference | median user CPU s |")
    print("|---|---:|---:|---:|---:|")
    for name, tw in results.items():
        wall = [w for w, _ in tw]
        med = statistics.median(wall)
        print(f"| {name} | {med:.3f} | {min(wall):.3f} | {med / ref:.1f} | "
              f"{statistics.median(u for _, u in tw):.3f} |")
    if args.importtime:
        print("\nslowest imports of granflow --help (cumulative ms):")
        for us, name in top_imports():
            print(f"  {us / 1000:8.1f}  {name}")
        if args.run:
            print("\nslowest imports of import granflow.casekit.runner (a run's, cumulative ms):")
            for us, name in top_imports("import granflow.casekit.runner", ()):
                print(f"  {us / 1000:8.1f}  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
