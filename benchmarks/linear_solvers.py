"""Linear solvers on the systems of the dry column collapse: SuperLU ("direct") against the
block-AMG FGMRES solver ("amg", granflow.solvers.saddle) at 3-4 resolutions.

Case: 10 x 10 cm Drucker-Prager column (sin(delta) = 0.45, d = 70 um, phi_max = 0.6) against the
left wall of a 0.4 x 0.15 m box (benchmarks/column_dry.py). A 56 x 21 run to ``--time`` (default
0.05 s, mid-collapse) is refined by the factors ``--levels`` (default 2, 4, 6, 8: 112x42 .. 448x168
cells, i.e. 69^2 .. 274^2 equivalents, 1.4e4 .. 2.3e5 unknowns); two steps of dt = 1 ms / r are
taken at each level and every linear system the Model assembles (all Picard sweeps) is captured
by intercepting its solve. Both solvers then solve the captured sequence in order:

* direct: ``splu`` per system (set-up = factorisation);
* amg: one solver per level (hierarchies refreshed across sweeps and steps), warm start from the
  previous solution (pressure mapped through the active cells), default ``augmented`` Schur
  approximation with the physical hints, rtol 1e-8 (scaled system).

Prints per level: unknowns, per-solve set-up/solve wall times and iterations (first solve =
cold set-up, then the mean over the rest), the relative difference between the two solutions,
and the fitted cost exponents ``t ~ N^a``. Asserts nothing about time.

Run:   python benchmarks/linear_solvers.py [--levels 2,4,6,8] [--time 0.05]
Time:  ~3 min on one core (the 448x168 direct solves dominate).
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.sparse.linalg as spla
from scipy.interpolate import RegularGridInterpolator

import granflow.model as gm
from granflow.grid import Grid
from granflow.model import Model
from granflow.rheology import make_closure
from granflow.simulation import Simulation
from granflow.solvers import SaddleHints, make_linear_solver
from granflow.state import State

PHI_MAX = 0.6
BASE = (56, 21)
BOX = (0.4, 0.15)
DT_BASE = 1.0e-3
STEPS = 2


class _Spsolve:
    """Stand-in for ``scipy.sparse.linalg`` in granflow.model that records each system."""

    def __init__(self, systems: list) -> None:
        self.systems = systems

    def spsolve(self, K, rhs):
        x = spla.spsolve(K, rhs)
        self.systems.append(dict(K=K.copy(), rhs=np.array(rhs), x=x))
        return x


def model_at(r: int) -> Model:
    clo = make_closure("drucker_prager", material=dict(d=70e-6, rho_s=2500.0, phi_max=PHI_MAX),
                       delta_deg=26.74)
    return Model(Grid(nx=BASE[0] * r, nz=BASE[1] * r, Lx=BOX[0], Lz=BOX[1]), clo)


def refine(state: State, coarse: Grid, fine: Grid) -> State:
    """Piecewise-constant phi and p, bilinear face velocities, on a grid ``r`` times finer."""
    r = fine.nx // coarse.nx
    u, w = coarse.unpack_velocity(state.vel)
    out = State.at_rest(fine, np.kron(state.phi, np.ones((r, r))), p=np.kron(state.p, np.ones((r, r))))
    vel = []
    for comp, (Xc, Zc), (Xf, Zf) in ((u, coarse.xface_coords(), fine.xface_coords()),
                                     (w, coarse.zface_coords(), fine.zface_coords())):
        f = RegularGridInterpolator((Xc[:, 0], Zc[0]), comp, bounds_error=False, fill_value=None)
        vel.append(f(np.stack([Xf, Zf], axis=-1)))
    vel[0][[0, -1], :] = 0.0
    vel[1][:, [0, -1]] = 0.0
    out.vel = fine.pack_velocity(*vel)
    return out


def capture(model: Model, state: State, dt: float, steps: int) -> list[dict]:
    """Every system solved by ``steps`` calls of Model.advance, with the solver hints (inertia
    diagonal from ``velocity_data``, eta_c at the active cells) and the active mask."""
    systems, coefs, actives, masses = [], [], [], []
    asm = model.assembler
    orig = (model.coefficients, asm.saddle, asm.velocity_data, gm.spla)

    def coefficients(*args, **kwargs):
        coefs.append(orig[0](*args, **kwargs))
        return coefs[-1]

    def saddle(a_data, active, *args, **kwargs):
        actives.append(np.array(active, dtype=bool))
        return orig[1](a_data, active, *args, **kwargs)

    def velocity_data(rho_over_dt, *args, **kwargs):
        masses.append(np.array(rho_over_dt, dtype=float))
        return orig[2](rho_over_dt, *args, **kwargs)

    model.coefficients, asm.saddle, asm.velocity_data = coefficients, saddle, velocity_data
    gm.spla = _Spsolve(systems)
    try:
        for _ in range(steps):
            report = model.advance(state, dt)
            if report.failed:
                raise RuntimeError(report.message)
    finally:
        del model.coefficients, asm.saddle, asm.velocity_data
        gm.spla = orig[3]
    for s, c, a, m in zip(systems, coefs, actives, masses):
        s.update(hints=SaddleHints(mass=m, viscosity=c.eta_c[a]), active=a)
    return systems


def warm_start(prev_x: np.ndarray | None, prev_active, active, n: int, size: int) -> np.ndarray | None:
    """Previous solution as the initial guess: velocity as is, pressure through the cells."""
    if prev_x is None:
        return None
    p_cells = np.zeros(active.size)
    m_prev = int(prev_active.sum())
    p_cells[prev_active] = prev_x[n:n + m_prev]
    x0 = np.zeros(size)
    x0[:n] = prev_x[:n]
    x0[n:n + int(active.sum())] = p_cells[active]
    return x0


def run_level(r: int, state0: State, coarse: Grid) -> dict:
    model = model_at(r)
    systems = capture(model, refine(state0, coarse, model.grid), DT_BASE / r, STEPS)
    n = model.grid.n_unknowns
    direct = make_linear_solver("direct")
    amg = make_linear_solver("amg", grid=model.grid)
    rows, prev, prev_act = [], None, None
    for s in systems:
        xd, di = direct.solve(s["K"], s["rhs"])
        x0 = warm_start(prev, prev_act, s["active"], n, s["K"].shape[0])
        xa, ai = amg.solve(s["K"], s["rhs"], x0=x0, hints=s["hints"])
        diff = np.linalg.norm(xa - xd) / np.linalg.norm(xd)
        rows.append((di, ai, diff))
        prev, prev_act = xa, s["active"]
    return dict(grid=f"{model.grid.nx}x{model.grid.nz}", N=systems[0]["K"].shape[0], rows=rows)


def summary(level: dict) -> dict:
    rows = level["rows"]
    rest = rows[1:] if len(rows) > 1 else rows
    tot = lambda info: info.setup_time + info.solve_time  # noqa: E731
    return dict(
        direct=float(np.mean([tot(d) for d, _, _ in rows])),
        direct_setup=float(np.mean([d.setup_time for d, _, _ in rows])),
        amg_first=tot(rows[0][1]), amg_first_its=rows[0][1].iterations,
        amg=float(np.mean([tot(a) for _, a, _ in rest])),
        amg_setup=float(np.mean([a.setup_time for _, a, _ in rest])),
        amg_solve=float(np.mean([a.solve_time for _, a, _ in rest])),
        its=[a.iterations for _, a, _ in rows],
        diff=max(d for _, _, d in rows),
        residual=max(a.residual for _, a, _ in rows))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="2,4,6,8", help="refinement factors of the 56x21 base grid")
    ap.add_argument("--time", type=float, default=0.05, help="collapse time of the captured state [s]")
    args = ap.parse_args()
    coarse = model_at(1)
    state = coarse.initial_state(np.where(
        (coarse.grid.cell_coords()[0] < 0.1) & (coarse.grid.cell_coords()[1] < 0.1), PHI_MAX, 0.0))
    t0 = time.perf_counter()
    Simulation(coarse, state, stop_time=args.time).run()
    print(f"base run {BASE[0]}x{BASE[1]} to t = {args.time} s: {time.perf_counter() - t0:.1f} s wall")
    print(f"{'grid':>8} {'N':>7} | {'direct s/solve':>14} {'(factor)':>8} | {'amg cold s':>10} {'its':>4} | "
          f"{'amg s/solve':>11} {'(setup':>7} {'solve)':>7} | iterations per solve        | max |x_amg - x_lu|/|x_lu|, residual")
    table = []
    for r in (int(v) for v in args.levels.split(",")):
        level = run_level(r, state, coarse.grid)
        s = summary(level)
        table.append((level["N"], s))
        print(f"{level['grid']:>8} {level['N']:>7} | {s['direct']:>14.3f} {s['direct_setup']:>8.3f} | "
              f"{s['amg_first']:>10.3f} {s['amg_first_its']:>4d} | {s['amg']:>11.3f} {s['amg_setup']:>7.3f} "
              f"{s['amg_solve']:>7.3f} | {str(s['its']):<27} | {s['diff']:.1e}, {s['residual']:.1e}")
    if len(table) >= 2:
        logN = np.log([N for N, _ in table])
        for key, label in (("direct", "direct (SuperLU)"), ("amg", "amg, warm/refreshed"),
                           ("amg_first", "amg, cold set-up")):
            slope = np.polyfit(logN, np.log([s[key] for _, s in table]), 1)[0]
            print(f"cost exponent t ~ N^a, {label:<20}: a = {slope:.2f}")
        its = [np.mean(s["its"]) for _, s in table]
        print(f"mean FGMRES iterations per level: {', '.join(f'{v:.1f}' for v in its)}")


if __name__ == "__main__":
    main()
