"""Performance of granflow on the Lagree, Staron & Popinet (2011) column collapse (issue 3 item 10).

Case: ``lagree_column`` (src/granflow/cases/lagree_column.py): dimensionless half column
(H0 = g = rho = 1, aspect ratio ``--aspect``, default 1.42) against a symmetry wall in a 5 x 5 box,
no-slip base, mu_s = 0.32, Delta mu = 0.28, I0 = 0.4, d = 1/40, run to ``--stop-time`` (default
t = 4 sqrt(H0/g)) with ``dt_max = 0.01``, the default CFL (0.3 before session 25, 0.4 since),
on ``n x n`` cells for each n of ``--resolutions``, for each closure of ``--models`` ("incompressible": the incompressible mu(I)
reference, the model of the paper; "mu_i": the Chupin-Dubois mu(I) closure with dilatancy) and each
linear solver of ``--linear-solvers`` (auto, direct, pardiso, amg).

Prints one row per run: cells, accepted steps, wall and CPU time, cell-steps per wall second,
Picard sweeps and Krylov iterations per step, the wall-time share of each phase of
:attr:`granflow.model.StepReport.timings` (assembly, solve, transport) plus the simulation's
diagnostics and the rest (time-step choice, state backup, checks), ms per step, the peak
resident memory of the process that ran it (``resource.getrusage().ru_maxrss``; each run in its
own process unless ``--in-process``), and the front x_f (deposit thickness above
``--front-threshold`` H0) at the end. A run stopped by ``--max-steps`` is marked ``capped``: its
per-step figures are those of the first steps only. Asserts nothing about time.

Basilisk (a mature serial C code) is not timed here: absolute times do not transfer between
machines, so ``benchmarks/vs_basilisk.py`` runs both codes side by side on the same host.

Run:   python benchmarks/lagree_column.py                       # 64, 128 to t = 4; 256 capped at 20 steps
       python benchmarks/lagree_column.py --resolutions 128 --linear-solvers direct,amg
       python benchmarks/lagree_column.py --models mu_i --resolutions 64
Time:  ~1-1.5 min at 64^2 and ~8-10 min at 128^2 (to t = 4), ~2.5 min for 20 steps at 256^2 (one core
       of the shared 2-core machine; benchmarks/README.md has the measured figures).
"""
from __future__ import annotations

import argparse
import concurrent.futures as cf
import multiprocessing
import os
import resource
import sys
import time
from dataclasses import dataclass

from granflow import diagnostics as dg
from granflow.cases import CASES
from granflow.config import CaseConfig

CASE = "lagree_column"
DT_MAX = 0.01
"""Largest time step [sqrt(H0/g)] (the Basilisk reference run's order of magnitude)."""
DEFAULT_CAPS = "256:20"
"""Step caps per resolution by default: 256^2 to t = 4 would take about half an hour of CPU."""
DEFAULT_FRONT_THRESHOLD = 0.05
"""Deposit thickness [H0] defining the front in the table (two grain diameters)."""
PHASES = ("assembly", "solve", "transport", "diagnostics")
KIB = 1024.0


@dataclass
class Row:
    n: int
    model: str
    solver: str
    cells: int
    steps: int
    t_end: float
    capped: bool
    wall_s: float
    cpu_s: float
    cell_steps_per_s: float
    sweeps_per_step: float
    krylov_per_step: float
    shares: dict
    ms_per_step: float
    peak_mb: float
    x_f: float
    rejected: int
    band: int = 0


DEFAULT_SWEEPS = None
"""Picard sweep cap of the runs: None = the Model's default (``numerics.picard.max_sweeps``)."""


def config(n: int, model: str, solver: str, stop_time: float, max_steps: int | None,
           aspect: float, threshold: float, sweeps: int | None = DEFAULT_SWEEPS,
           band: int | None = None, predictor: str | None = None) -> CaseConfig:
    """The case file of one run (as a dict through the strict loader)."""
    time_section = {"stop_time": stop_time, "dt_max": DT_MAX}
    if max_steps:
        time_section["max_steps"] = max_steps
    return CaseConfig.from_dict({
        "case": {"name": CASE}, "setup": {"model": model, "a": aspect},
        "grid": {"nx": n, "nz": n}, "time": time_section,
        "numerics": {"linear_solver": solver,
                     "picard": ({} if sweeps is None else {"max_sweeps": sweeps})
                     | ({} if predictor is None else {"predictor": predictor}),
                     "ambient": {} if band is None else {"velocity_band": band}},
        "output": {"front_threshold": threshold}})


def run_one(n: int, model: str, solver: str, stop_time: float, max_steps: int | None,
            aspect: float, threshold: float, sweeps: int | None = DEFAULT_SWEEPS, band: int | None = None,
            predictor: str | None = None) -> Row:
    """One run; figures of :class:`Row`."""
    cfg = config(n, model, solver, stop_time, max_steps, aspect, threshold, sweeps, band, predictor)
    sim = CASES.get(CASE).setup(cfg)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    sim.run()
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    g, steps = sim.model.grid, len(sim.reports)
    phases = {k: sim.timings.get(k, 0.0) for k in PHASES}
    shares = {k: v / wall for k, v in phases.items()}
    shares["rest"] = max(wall - sum(phases.values()), 0.0) / wall
    tot = sim.totals
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / KIB  # Linux: KiB -> MiB
    x_f = dg.front_position(g, sim.state.phi, sim.model.material.phi_max, threshold)
    return Row(n=n, model=model, solver=sim.model.linear_solver_name, cells=g.n_cells, steps=steps,
               t_end=sim.state.t, capped=sim.state.t < stop_time * (1 - 1e-9), wall_s=wall, cpu_s=cpu,
               cell_steps_per_s=g.n_cells * steps / wall, sweeps_per_step=tot.picard_iterations / steps,
               krylov_per_step=tot.linear_iterations / steps, shares=shares,
               ms_per_step=1e3 * wall / steps, peak_mb=peak, x_f=x_f, rejected=tot.rejected,
               band=sim.model.velocity_band or 0)


def _caps(text: str, resolutions: list[int]) -> dict[int, int | None]:
    """``"N"`` (every resolution) or ``"RES:N,RES:N"``; 0 = no cap."""
    caps: dict[int, int | None] = {n: None for n in resolutions}
    for item in filter(None, text.split(",")):
        if ":" in item:
            res, cap = item.split(":")
            caps[int(res)] = int(cap) or None
        else:
            caps = {n: int(item) or None for n in resolutions}
    return caps


HEADER = ("| grid | model | solver | band | steps | t_end | wall s | CPU s | cell·steps/s | sweeps/step | Krylov/step "
          "| assembly | solve | transport | diagn. | rest | ms/step | peak MB | x_f |")


def format_row(r: Row) -> str:
    s = r.shares
    t_end = f"{r.t_end:.2f}" + (" (capped)" if r.capped else "")
    return (f"| {r.n}² | {r.model} | {r.solver} | {r.band} | {r.steps} | {t_end} | {r.wall_s:.1f} | "
            f"{r.cpu_s:.1f} | "
            f"{r.cell_steps_per_s:.3g} | {r.sweeps_per_step:.2f} | {r.krylov_per_step:.1f} | "
            f"{s['assembly']:.0%} | {s['solve']:.0%} | {s['transport']:.0%} | {s['diagnostics']:.0%} | "
            f"{s['rest']:.0%} | {r.ms_per_step:.0f} | {r.peak_mb:.0f} | {r.x_f:.3f} |")


def main(argv: list[str] | None = None) -> list[Row]:
    """Run the benchmark; returns the rows (also printed as a Markdown table)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolutions", default="64,128,256", help="comma-separated n (n x n cells)")
    ap.add_argument("--models", default="incompressible", help='comma-separated: "incompressible", "mu_i"')
    ap.add_argument("--linear-solvers", default="auto", help="comma-separated: auto, direct, pardiso, amg")
    ap.add_argument("--stop-time", type=float, default=4.0, help="simulated time [sqrt(H0/g)]")
    ap.add_argument("--max-steps", default=DEFAULT_CAPS,
                    help=f'step cap: "N" for every resolution or "RES:N,..." (0 = none; default {DEFAULT_CAPS})')
    ap.add_argument("--aspect", type=float, default=1.42, help="aspect ratio a = H0/L0 [-]")
    ap.add_argument("--front-threshold", type=float, default=DEFAULT_FRONT_THRESHOLD,
                    help="deposit thickness defining the front [H0]")
    ap.add_argument("--picard-sweeps", type=int, default=DEFAULT_SWEEPS,
                    help="numerics.picard.max_sweeps (default: the model's; 1 = one lagged-coefficient solve per step)")
    ap.add_argument("--predictor", choices=("previous", "extrapolated"), default=None,
                    help="numerics.picard.predictor (default: the model's, previous; with --picard-sweeps 1 "
                         "extrapolated is the linearly implicit step of docs/solver.md)")
    ap.add_argument("--velocity-band", type=int, default=None,
                    help="numerics.ambient.velocity_band [cells] (default: the case's, 3; 0 = solve everywhere)")
    ap.add_argument("--in-process", action="store_true",
                    help="run in this process (peak memory is then the running maximum)")
    args = ap.parse_args(argv)
    resolutions = [int(v) for v in args.resolutions.split(",")]
    caps = _caps(args.max_steps, resolutions)
    jobs = [(n, model, solver, args.stop_time, caps[n], args.aspect, args.front_threshold, args.picard_sweeps,
             args.velocity_band, args.predictor)
            for model in args.models.split(",") for solver in args.linear_solvers.split(",")
            for n in resolutions]
    print(f"# {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start; "
          f"front threshold {args.front_threshold} H0")
    print(HEADER)
    print("|" + "---|" * HEADER.count(" |"))
    rows = []
    for job in jobs:
        if args.in_process:
            row = run_one(*job)
        else:  # a fresh process per run: a clean peak-memory figure
            ctx = multiprocessing.get_context("spawn")
            with cf.ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
                row = pool.submit(run_one, *job).result()
        rows.append(row)
        print(format_row(row), flush=True)
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() else 1)

