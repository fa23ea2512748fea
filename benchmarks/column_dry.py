"""Performance of the dry solver v1 on the tiny column collapse (NUMERICS.md §12 setup, scaled).

Case: 10 x 10 cm Drucker-Prager column (sin(delta) = 0.45, d = 70 um, phi_max = 0.6) against the
left wall of a 0.4 x 0.15 m box, no-slip base; ``n`` x ``3n/8`` cells for each n of
``--resolutions``; run to ``--stop-time``. Prints, per resolution: cells x steps per second (CPU
time), Picard sweeps per step, per-phase CPU share (assembly, solve, transport, diagnostics), and
the physics numbers (front, mass error, clipped mass, max phi before clip, energy residual).
Asserts nothing about time.

Run:   python benchmarks/column_dry.py [--resolutions 40,80,120] [--stop-time 0.1]
Time:  ~1 min with the defaults on one core (the 120-cell level dominates).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from granflow import diagnostics as dg
from granflow.grid import Grid
from granflow.model import Model, StepStatus
from granflow.rheology import make_closure
from granflow.simulation import Simulation

PHI_MAX = 0.6
FRONT_THRESHOLD = 0.005  # m
Z_CELLS_PER_X_CELLS = 3 / 8


def run(nx: int, stop_time: float) -> dict:
    nz = int(round(nx * Z_CELLS_PER_X_CELLS))
    grid = Grid(nx=nx, nz=nz, Lx=0.4, Lz=0.15)
    clo = make_closure("drucker_prager", material=dict(d=70e-6), delta_deg=26.74)
    model = Model(grid, clo)
    X, Z = grid.cell_coords()
    phi0 = np.where((X < 0.1) & (Z < 0.1), PHI_MAX, 0.0)
    sim = Simulation(model, model.initial_state(phi0), stop_time=stop_time)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    sim.run()
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    reps = sim.reports
    m0 = dg.mass(grid, phi0)
    clipped = sum(r.clipped_mass for r in reps)
    phase_total = sum(sim.timings.values())
    return dict(
        grid=f"{nx}x{nz}", unknowns=grid.n_unknowns + grid.n_cells, steps=len(reps), cpu=cpu, wall=wall,
        cell_steps_per_s=grid.n_cells * len(reps) / cpu,
        sweeps=float(np.mean([r.picard_iterations for r in reps])),
        not_converged=float(np.mean([r.status is StepStatus.NOT_CONVERGED for r in reps])),
        shares={k: v / phase_total for k, v in sim.timings.items()},
        ms_per_solve=1e3 * sim.timings["solve"] / sum(r.picard_iterations for r in reps),
        front=dg.front_position(grid, sim.state.phi, PHI_MAX, FRONT_THRESHOLD),
        mass_err=(dg.mass(grid, sim.state.phi) + clipped - m0) / m0,
        clipped=clipped / m0,
        max_phi=max(r.max_phi_before_clip for r in reps),
        energy=sim.budget.relative_residual, rejected=sim.n_rejected,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolutions", default="40,80,120", help="comma-separated nx values")
    ap.add_argument("--stop-time", type=float, default=0.1, help="simulated time [s]")
    args = ap.parse_args()
    for nx in (int(v) for v in args.resolutions.split(",")):
        r = run(nx, args.stop_time)
        shares = " ".join(f"{k} {v:.0%}" for k, v in r["shares"].items())
        print(f"{r['grid']:>7} ({r['unknowns']} unknowns): {r['steps']} steps, cpu {r['cpu']:.1f} s "
              f"(wall {r['wall']:.1f} s), {r['cell_steps_per_s']:.3g} cell-steps/s, "
              f"{r['sweeps']:.2f} Picard sweeps/step ({r['not_converged']:.0%} at the cap), "
              f"{r['ms_per_solve']:.1f} ms/solve; phases: {shares}")
        print(f"        front(h>{FRONT_THRESHOLD * 1e3:.0f} mm) {r['front']:.3f} m, mass err "
              f"{r['mass_err']:.1e}, clipped {r['clipped']:.1e}, max phi before clip {r['max_phi']:.4f}, "
              f"energy err/released {r['energy']:+.3f}, rejected steps {r['rejected']}")


if __name__ == "__main__":
    main()
