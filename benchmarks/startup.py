"""Start-up wall time of the ``granflow`` command and of ``import granflow``.

Times whole processes (fresh interpreter each run, wall clock, ``time.perf_counter`` around
``subprocess.run``) and prints, per command, the median and the minimum of ``--runs`` runs and the
ratio of the median to that of the reference command ``python -c pass`` (the interpreter's own
start-up on this machine). Ratios travel between machines better than seconds; the CPU model
name (``/proc/cpuinfo``) and the core count are printed with them. Asserts nothing about time.

Commands (``python`` is this interpreter, ``sys.executable``):

* ``granflow --help`` and ``granflow list closures``, run as the console script does it
  (``from granflow.cli import main; sys.exit(main())``) but without a launcher in front (a pyenv
  shim or a Windows .exe wrapper would add its own start-up);
* ``python -c "import granflow"``;
* the reference ``python -c pass``.

The granflow imported is the one on this interpreter's path: to measure a source tree, set
``PYTHONPATH=<tree>/src``. One warm-up run of each command precedes the timed runs (file-system
cache, ``__pycache__``).

Run:   python benchmarks/startup.py [--runs 5] [--importtime]
Time:  ~10 s for 5 runs.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

CLI = "import sys; from granflow.cli import main; sys.exit(main())"

COMMANDS = {
    "python -c pass (reference)": [sys.executable, "-c", "pass"],
    "python -c 'import granflow'": [sys.executable, "-c", "import granflow"],
    "granflow --help": [sys.executable, "-c", CLI, "--help"],
    "granflow list closures": [sys.executable, "-c", CLI, "list", "closures"],
}
REFERENCE = "python -c pass (reference)"


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


def wall_times(cmd: list[str], runs: int) -> list[float]:
    """Wall-clock seconds of ``runs`` runs of ``cmd`` after one untimed warm-up run."""
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    out = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        out.append(time.perf_counter() - t0)
    return out


def top_imports(n: int = 12) -> list[tuple[int, str]]:
    """The ``n`` slowest imports (cumulative microseconds) of ``granflow --help``, from
    ``python -X importtime``."""
    res = subprocess.run([sys.executable, "-X", "importtime", "-c", CLI, "--help"],
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
                    help="also list the slowest imports of granflow --help (python -X importtime)")
    args = ap.parse_args(argv)

    print(f"CPU: {cpu_model()} ({os.cpu_count()} logical cores), Python {sys.version.split()[0]}, "
          f"median of {args.runs} runs")
    results = {name: wall_times(cmd, args.runs) for name, cmd in COMMANDS.items()}
    ref = statistics.median(results[REFERENCE])
    print("| command | median s | min s | median / reference |")
    print("|---|---:|---:|---:|")
    for name, times in results.items():
        med = statistics.median(times)
        print(f"| {name} | {med:.3f} | {min(times):.3f} | {med / ref:.1f} |")
    if args.importtime:
        print("\nslowest imports of granflow --help (cumulative ms):")
        for us, name in top_imports():
            print(f"  {us / 1000:8.1f}  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
