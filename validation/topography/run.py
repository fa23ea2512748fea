"""A heap released on a uniform slope, two ways: a staircase base profile under vertical gravity
against a flat base under tilted gravity (issue 14 item 3, acceptance (a): "a uniform slope
against the tilted-gravity case, same answer").

The problem (dimensionless, the units of the lagree_column case: H = g = rho = 1): a rectangle of
grains 1 long (along the slope) and 1 high (normal to it) at rest on a no-slip slope of
theta = 12 deg, its upslope face at s = 1 from the box's upslope end; incompressible mu(I)
(mu_s = 0.32 = tan 17.7 deg, delta_mu = 0.28, I0 = 0.4, d = sqrt(0.6)/65, the lagree_column
defaults), so the heap slumps, spreads along the slope and stops. Two discretisations:

* **tilted**: the box along the slope (7 x 2.5), flat base, gravity (sin theta, -cos theta);
* **staircase**: the box in the vertical plane, a `[topography]`-style profile
  z_b(x) = Z0 - x tan(theta), gravity (0, -1); the heap is the same rectangle rotated by theta
  (its cells' fractions by 8 x 8 sub-sampling, the cells under the staircase left empty).

Compared in the slope's own coordinates (s along the slope downwards, from the profile's upslope
end): the centre of mass's travel Delta s_cm(t) and the 1 % and 99 % mass quantiles of s (rear
and front; no thresholds, robust on the staircase). The staircase is first order in the base's
position (a step of one cell under the heap), so the two should approach each other as the grid
is refined; the script prints the table of both at N = 16, 24, 32 cells per unit length.

Part (b), ``--part runout``: examples/column_on_topography.toml (a 10 cm column of glass beads
down a 20 deg profile onto a flat run-out zone, Drucker-Prager) to rest on 60 x 25, 120 x 50 and
240 x 100 cells: the front, the 99 % mass quantile and the centre of mass of the deposit, its mass
and energy budget.

Run:   python validation/topography/run.py [--quick] [--part slope|runout|all] [--levels 16 24 32]
Time:  ~4.5 min on one core for (a), ~5 min for (b) (``--quick``: N = 8 to t = 1 and the example
       on 24 x 10 cells to t = 0.05 s, a few seconds; the smoke test of
       tests/validation_smoke/test_validation_topography.py).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from granflow.casekit import common
from granflow.cases import lagree_column as lc
from granflow.config import CaseConfig
from granflow.grid import Grid
from granflow.simulation import Simulation
from granflow.topography import Topography

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results.json"
THETA_DEG = 12.0
LENGTH = 7.0          # box length along the slope [H]
HEIGHT = 2.5          # box height normal to the slope (tilted) [H]
HEAP = (1.0, 2.0)     # the heap's extent along the slope [H]
HEAP_H = 1.0          # its height normal to the slope [H]
MARGIN = 0.1          # rock under the profile's lowest point [H]
T_END = 8.0
DT_MAX = 0.01         # as examples/lagree_column.toml [sqrt(H/g)]
RECORD = 0.5
LEVELS = (16, 24, 32)
QUICK = {"levels": (8,), "t_end": 1.0}
SUB = 8               # sub-samples per cell side for the rotated heap


def config() -> CaseConfig:
    return CaseConfig.from_dict({"case": {"name": "lagree_column"}, "grid": {"nx": 16, "nz": 16},
                                 "time": {"stop_time": T_END}, "output": {"figures": False}})


def model_on(cfg: CaseConfig, grid: Grid, gravity, topography=None):
    used = lc.numerics_used(cfg)
    return common.make_model(cfg, grid=grid, closure=lc.closure(cfg), gravity=gravity,
                             ambient={**cfg.numerics.ambient.model_dump(), "rho_a": used["rho_a"],
                                      "eta_a": used["eta_a"]},
                             delta_p=used["delta_p"], topography=topography)


def tilted(n: int):
    """The flat-base box along the slope: (model, phi, s of the cells)."""
    th = math.radians(THETA_DEG)
    g = Grid(nx=round(LENGTH * n), nz=round(HEIGHT * n), Lx=LENGTH, Lz=HEIGHT)
    model = model_on(config(), g, (math.sin(th), -math.cos(th)))
    phi = model.material.phi_max * common.rectangle_fraction(g, HEAP[0], HEAP[1], 0.0, HEAP_H)
    s = np.broadcast_to(g.xc[:, None], g.cell_shape)
    return model, phi, s


def staircase(n: int):
    """The vertical box over the profile z_b = Z0 - x tan(theta): (model, phi, s of the cells)."""
    th = math.radians(THETA_DEG)
    Lx = LENGTH * math.cos(th)
    Z0 = Lx * math.tan(th) + MARGIN
    Lz = Z0 + HEIGHT / math.cos(th)
    g = Grid(nx=round(Lx * n), nz=round(Lz * n), Lx=round(Lx * n) / n, Lz=round(Lz * n) / n)
    topo = Topography(x=[0.0, g.Lx], z=[Z0, Z0 - g.Lx * math.tan(th)])
    model = model_on(config(), g, (0.0, -1.0), topo)
    # slope coordinates of sub-samples: s along the slope (down), m normal to it (up)
    off = (np.arange(SUB) + 0.5) / SUB - 0.5
    xs = g.xc[:, None, None, None] + off[None, None, :, None] * g.dx
    zs = g.zc[None, :, None, None] + off[None, None, None, :] * g.dz
    s_sub = xs * math.cos(th) - (zs - Z0) * math.sin(th)
    m_sub = xs * math.sin(th) + (zs - Z0) * math.cos(th)
    inside = (s_sub >= HEAP[0]) & (s_sub <= HEAP[1]) & (m_sub >= 0.0) & (m_sub <= HEAP_H)
    phi = model.material.phi_max * inside.mean(axis=(2, 3))
    phi[model.solid] = 0.0
    s = g.xc[:, None] * math.cos(th) - (g.zc[None, :] - Z0) * math.sin(th)
    return model, phi, s


def measures(phi, s) -> dict:
    """Centre of mass and the 1 %, 99 % mass quantiles along the slope [H]."""
    w = np.asarray(phi).ravel()
    order = np.argsort(np.asarray(s).ravel())
    ss, cum = np.asarray(s).ravel()[order], np.cumsum(w[order]) / w.sum()
    return {"s_cm": float((w * np.asarray(s).ravel()).sum() / w.sum()),
            "s_01": float(np.interp(0.01, cum, ss)), "s_99": float(np.interp(0.99, cum, ss))}


def run(resolution: int, quick: bool = False) -> list[dict]:
    """Part (a) at ``resolution`` cells per unit length: the tilted and the staircase run (to
    t = 1 with ``quick``, else to :data:`T_END`)."""
    t_end = QUICK["t_end"] if quick else T_END
    return [run_frame(frame, resolution, t_end) for frame in ("tilted", "staircase")]


def run_frame(frame: str, n: int, t_end: float = T_END) -> dict:
    model, phi, s = (tilted if frame == "tilted" else staircase)(n)
    sim = Simulation(model, model.initial_state(phi), stop_time=t_end, dt_max=DT_MAX)
    rows = [{"t": 0.0, **measures(sim.state.phi, s)}]
    t0 = time.process_time()
    for k in range(1, round(t_end / RECORD) + 1):
        sim.stop_time = k * RECORD
        sim.run()
        rows.append({"t": sim.state.t, **measures(sim.state.phi, s)})
    start = rows[0]
    for r in rows:
        r["travel"] = r["s_cm"] - start["s_cm"]
    return {"frame": frame, "n": n, "cells": model.grid.n_cells, "steps": sim.state.step,
            "cpu_s": time.process_time() - t0, "mass0": float(phi.sum() * model.grid.cell_volume),
            "mass_end": float(sim.state.phi.sum() * model.grid.cell_volume),
            "energy_residual_rel": sim.budget.relative_residual if sim.budget is not None else None,
            "rows": rows}


# --- (b): a column down a slope onto a flat run-out zone (examples/column_on_topography.toml) ----
EXAMPLE = HERE.parent.parent / "examples" / "column_on_topography.toml"
RUNOUT_LEVELS = ((60, 25), (120, 50), (240, 100))
QUICK_RUNOUT = ((24, 10),)


def runout(nx: int, nz: int, t_end: float | None = None) -> dict:
    """The example at nx x nz cells, to rest (or ``t_end``): front (5 mm threshold), the 99 %
    mass quantile of x, rest time, mass and energy budget."""
    from granflow import diagnostics as dg
    from granflow.cases import CASES
    from granflow.config import load_case

    sets = [f"grid.nx={nx}", f"grid.nz={nz}", "output.figures=false"]
    if t_end is not None:
        sets.append(f"time.stop_time={t_end}")
    cfg = load_case(EXAMPLE, overrides=sets)
    sim = CASES.get("column_collapse").setup(cfg)
    g, phi0 = sim.model.grid, sim.state.phi.copy()
    t0 = time.process_time()
    sim.run()
    phi = sim.state.phi
    w = phi.sum(axis=1) / phi.sum()
    front = dg.front_position(g, phi, sim.model.material.phi_max, 0.05 * cfg.setup.H0)
    return {"nx": nx, "nz": nz, "t": sim.state.t, "steps": sim.state.step, "cpu_s": time.process_time() - t0,
            "front_m": float(front), "x99_m": float(np.interp(0.99, np.cumsum(w), g.xc)),
            "x_cm_m": float((w * g.xc).sum()), "mass_rel_error": float(phi.sum() / phi0.sum() - 1.0),
            "energy_residual_rel": sim.budget.relative_residual, "speed": float(np.abs(sim.state.vel).max())}


def runout_table(rows: list[dict]) -> str:
    lines = ["| grid | dx [mm] | steps | t_end [s] | front (5 mm) [m] | x_0.99 [m] | x_cm [m] | mass error "
             "| energy residual | CPU [s] |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['nx']} x {r['nz']} | {600 / r['nx']:.1f} | {r['steps']} | {r['t']:.3f} "
                     f"| {r['front_m']:.4f} | {r['x99_m']:.4f} | {r['x_cm_m']:.4f} | {r['mass_rel_error']:.1e} "
                     f"| {100 * r['energy_residual_rel']:.1f} % | {r['cpu_s']:.0f} |")
    return "\n".join(lines)


def table(results: list[dict]) -> str:
    lines = ["| N per H | frame | cells | steps | travel t=2 | travel t=4 | travel end | rear s_01 end "
             "| front s_99 end |", "|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in results:
        by_t = {round(x["t"], 6): x for x in r["rows"]}
        last = r["rows"][-1]
        cell = lambda t: f"{by_t[t]['travel']:.4f}" if t in by_t else "-"  # noqa: E731
        lines.append(f"| {r['n']} | {r['frame']} | {r['cells']} | {r['steps']} | {cell(2.0)} | {cell(4.0)} "
                     f"| {last['travel']:.4f} | {last['s_01']:.4f} | {last['s_99']:.4f} |")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="N = 8 to t = 1 (smoke test)")
    ap.add_argument("--levels", type=int, nargs="+", default=list(LEVELS), help="cells per unit length")
    ap.add_argument("--part", choices=["slope", "runout", "all"], default="all",
                    help="(a) the heap on a slope two ways, (b) the example's column down a slope "
                         "onto a flat run-out zone on three grids, or both")
    args = ap.parse_args(argv)
    levels, t_end = (QUICK["levels"], QUICK["t_end"]) if args.quick else (tuple(args.levels), T_END)
    out: dict = {}
    if args.part in ("slope", "all"):
        out["runs"] = [r for n in levels for r in run(n, args.quick)]
        print(table(out["runs"]))
    if args.part in ("runout", "all"):
        grids = QUICK_RUNOUT if args.quick else RUNOUT_LEVELS
        out["runout"] = [runout(nx, nz, 0.05 if args.quick else None) for nx, nz in grids]
        print(runout_table(out["runout"]))
    if not args.quick:
        old = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
        RESULTS.write_text(json.dumps({**old, "theta_deg": THETA_DEG, "t_end": t_end, **out}, indent=1))
    return out


if __name__ == "__main__":
    main(sys.argv[1:])
