"""Performance on the glass-bead column collapse, fluidised (the flagship) and dry (issue 6 item 5).

Case: ``column_collapse`` from examples/column_collapse_fluidised.toml (10 x 10 cm column of
70 um beads, Drucker-Prager sin(delta) = 0.45, linear pore-gas law, phi0 = 0.58, p_f = 0.9 x
lithostatic) or examples/column_collapse_dry.toml (``--states dry``), on the examples' 0.4 x 0.15 m
box with N cells over H0 = 0.1 m for each N of ``--resolutions`` (grid 4N x 1.5N, dx = dz = H0/N),
run to ``--stop-time`` (default 0.3 s: the collapse and most of the run-out) with the examples'
other options; each run in its own process (clean peak memory).

Prints one Markdown row per run: cells, accepted steps, wall and CPU time, cell·steps per wall
second, Picard sweeps per step, wall-time share of assembly / solve / transport / diagnostics /
rest, ms per step, peak resident memory, the front (deposit thickness > 5 mm) at the end; and the
cost exponent per step between successive resolutions (CPU ms per step ~ cells^alpha). Asserts
nothing about time.

Run:   python benchmarks/column_collapse.py                          # fluidised, N = 10, 20, 40, auto solver
       python benchmarks/column_collapse.py --states dry,fluidised --linear-solvers direct,pardiso
Time:  ~3 min with the defaults on one core (N = 40 dominates).
"""
from __future__ import annotations

import argparse
import concurrent.futures as cf
import math
import multiprocessing
import os
import resource
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from granflow import diagnostics as dg
from granflow.cases import CASES
from granflow.config import load_case

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
FILES = {"fluidised": EXAMPLES / "column_collapse_fluidised.toml", "dry": EXAMPLES / "column_collapse_dry.toml"}
H0 = 0.1
"""Column height of the examples [m]."""
BOX = (0.4, 0.15)
"""The examples' box (Lx, Lz) [m]."""
FRONT_THRESHOLD = 5e-3
"""Deposit thickness defining the front [m]."""
PHASES = ("assembly", "solve", "transport", "diagnostics")
KIB = 1024.0


@dataclass
class Row:
    state: str
    n: int
    grid: str
    solver: str
    cells: int
    steps: int
    t_end: float
    wall_s: float
    cpu_s: float
    sweeps_per_step: float
    shares: dict
    peak_mb: float
    x_f: float


def run_one(state: str, n: int, solver: str, stop_time: float, sweeps: int | None) -> Row:
    nx, nz = round(BOX[0] / H0 * n), round(BOX[1] / H0 * n)
    over = [f"grid.nx={nx}", f"grid.nz={nz}", f"time.stop_time={stop_time}", "time.stop_at_rest=1e3",  # never: fixed simulated time
            f'numerics.linear_solver="{solver}"', "output.figures=false", "output.probes_x=[]"]
    if sweeps:
        over.append(f"numerics.picard.max_sweeps={sweeps}")
    cfg = load_case(FILES[state], over)
    sim = CASES.get(cfg.case.name).setup(cfg)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    sim.run()
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    steps = len(sim.reports)
    phases = {k: sim.timings.get(k, 0.0) for k in PHASES}
    shares = {k: v / wall for k, v in phases.items()}
    shares["rest"] = max(wall - sum(phases.values()), 0.0) / wall
    g = sim.model.grid
    return Row(state=state, n=n, grid=f"{nx}x{nz}", solver=sim.model.linear_solver_name, cells=g.n_cells,
               steps=steps, t_end=sim.state.t, wall_s=wall, cpu_s=cpu,
               sweeps_per_step=sim.totals.picard_iterations / max(steps, 1), shares=shares,
               peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / KIB,
               x_f=dg.front_position(g, sim.state.phi, sim.model.material.phi_max, FRONT_THRESHOLD))


HEADER = ("| state | N (cells/H0) | grid | solver | steps | t_end s | wall s | CPU s | cell·steps/s | sweeps/step "
          "| assembly | solve | transport | diagn. | rest | CPU ms/step | peak MB | front m |")


def format_row(r: Row) -> str:
    s = r.shares
    return (f"| {r.state} | {r.n} | {r.grid} | {r.solver} | {r.steps} | {r.t_end:.3f} | {r.wall_s:.1f} | "
            f"{r.cpu_s:.1f} | {r.cells * r.steps / r.wall_s:.3g} | {r.sweeps_per_step:.2f} | "
            f"{s['assembly']:.0%} | {s['solve']:.0%} | {s['transport']:.0%} | {s['diagnostics']:.0%} | "
            f"{s['rest']:.0%} | {1e3 * r.cpu_s / r.steps:.0f} | {r.peak_mb:.0f} | {r.x_f:.3f} |")


def exponents(rows: list[Row]) -> list[str]:
    """CPU per step ~ cells^alpha between successive resolutions of the same state and solver."""
    out = []
    for key in sorted({(r.state, r.solver) for r in rows}):
        rs = sorted((r for r in rows if (r.state, r.solver) == key), key=lambda r: r.cells)
        for a, b in zip(rs, rs[1:]):
            alpha = math.log((b.cpu_s / b.steps) / (a.cpu_s / a.steps)) / math.log(b.cells / a.cells)
            out.append(f"{key[0]}, {key[1]}: N {a.n} -> {b.n}: CPU per step ~ cells^{alpha:.2f}")
    return out


def main(argv: list[str] | None = None) -> list[Row]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", default="fluidised", help='comma-separated: "fluidised", "dry"')
    ap.add_argument("--resolutions", default="10,20,40", help="comma-separated N, cells over H0 = 0.1 m")
    ap.add_argument("--linear-solvers", default="auto", help="comma-separated: auto, direct, pardiso, amg")
    ap.add_argument("--stop-time", type=float, default=0.3, help="simulated time [s]")
    ap.add_argument("--picard-sweeps", type=int, default=None, help="numerics.picard.max_sweeps (default: the model's)")
    args = ap.parse_args(argv)
    jobs = [(state, int(n), solver, args.stop_time, args.picard_sweeps)
            for state in args.states.split(",") for solver in args.linear_solvers.split(",")
            for n in args.resolutions.split(",")]
    print(f"# {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start; "
          f"OMP/MKL threads {os.environ.get('OMP_NUM_THREADS', '-')}/{os.environ.get('MKL_NUM_THREADS', '-')}")
    print(HEADER)
    print("|" + "---|" * HEADER.count(" |"))
    rows = []
    ctx = multiprocessing.get_context("spawn")
    for job in jobs:
        with cf.ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
            row = pool.submit(run_one, *job).result()
        rows.append(row)
        print(format_row(row), flush=True)
    print()
    print("\n".join(exponents(rows)))
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
