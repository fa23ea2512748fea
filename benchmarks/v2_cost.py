"""CPU cost of scheme v2 against v1 on the Lagree column (issue 12 acceptance 6).

Case ``lagree_column`` (a = 1.42, Basilisk's parameters, to t = 4, dt_max = 0.01, the
default loop and CFL: 0.3 before session 25, 0.4 since) at
``n x n`` cells, run with the two numerics side by side:

* ``v1``: ``numerics.advection = "upwind"``, ``numerics.surface = "threshold"`` (the defaults
  until 2026-12-03, the "today" of issue 12);
* ``v2``: the defaults (``"consistent"``, ``"indicator"``).

Each run is a fresh process (``spawn``); the variants alternate, ``--rounds`` times, the order
rotated per round. Prints per run the accepted steps, Picard sweeps, user CPU and wall time of the
stepping (``time.process_time`` / ``perf_counter`` around ``sim.run()``; start-up excluded) and the
front, then the medians and the v2/v1 ratio of the medians, with the CPU model and the load
average. Asserts nothing about time.

Run:   python benchmarks/v2_cost.py                   # 128^2, 3 rounds (~2 min)
       python benchmarks/v2_cost.py --n 64 --rounds 5
"""
from __future__ import annotations

import argparse
import concurrent.futures as cf
import multiprocessing
import os
import platform
import statistics
import sys
import time

VARIANTS = {"v1": {"advection": "upwind", "surface": "threshold"}, "v2": {}}
ASPECT = 1.42
STOP_TIME = 4.0
DT_MAX = 0.01
FRONT_THRESHOLD = 0.05
"""Deposit thickness [H0] of the front (validation/basilisk_column's rule)."""


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def run_one(variant: str, n: int) -> dict:
    from granflow import diagnostics as dg
    from granflow.cases import CASES
    from granflow.config import CaseConfig

    cfg = CaseConfig.from_dict({
        "case": {"name": "lagree_column"}, "setup": {"a": ASPECT}, "grid": {"nx": n, "nz": n},
        "time": {"stop_time": STOP_TIME, "dt_max": DT_MAX}, "numerics": VARIANTS[variant],
        "output": {"figures": False}})
    sim = CASES.get("lagree_column").setup(cfg)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    sim.run()
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    g = sim.model.grid
    return {"variant": variant, "n": n, "steps": len(sim.reports), "sweeps": sim.totals.picard_iterations,
            "cpu_s": cpu, "wall_s": wall,
            "front": dg.front_position(g, sim.state.phi, sim.model.material.phi_max, FRONT_THRESHOLD)}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=128, help="cells per side")
    ap.add_argument("--rounds", type=int, default=3, help="alternated rounds of both variants")
    args = ap.parse_args(argv)
    print(f"# CPU: {cpu_model()} ({os.cpu_count()} logical cores), Python {platform.python_version()}, "
          f"load average {os.getloadavg()[0]:.2f} at start")
    print("| round | variant | steps | sweeps | CPU s | wall s | front |\n|---:|---|---:|---:|---:|---:|---:|")
    rows = []
    ctx = multiprocessing.get_context("spawn")
    names = list(VARIANTS)
    for k in range(args.rounds):
        for variant in names[k % 2:] + names[:k % 2]:
            with cf.ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
                r = pool.submit(run_one, variant, args.n).result()
            rows.append(r)
            print(f"| {k + 1} | {variant} | {r['steps']} | {r['sweeps']} | {r['cpu_s']:.2f} | "
                  f"{r['wall_s']:.2f} | {r['front']:.3f} |", flush=True)
    med = {v: statistics.median(r["cpu_s"] for r in rows if r["variant"] == v) for v in names}
    medw = {v: statistics.median(r["wall_s"] for r in rows if r["variant"] == v) for v in names}
    print(f"\n{args.n}^2, medians of {args.rounds}: CPU v1 {med['v1']:.2f} s, v2 {med['v2']:.2f} s, "
          f"ratio v2/v1 {med['v2'] / med['v1']:.3f}; wall ratio {medw['v2'] / medw['v1']:.3f}; "
          f"load average {os.getloadavg()[0]:.2f} at the end")
    return med


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
