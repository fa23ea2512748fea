"""Dry run-out of glass-bead columns against aspect ratio, with mesh convergence (issue 4, item 3).

Case ``column_collapse`` with the dry glass-bead parameters of examples/column_collapse_dry.toml:
Drucker-Prager closure sin(delta) = 0.45 (paper eqs f-DP, syst4DP; no rate dependence), d = 70 um,
rho_s = 2500 kg/m^3, phi0 = phi_max = 0.6, free-slip (symmetry) west wall, no-slip base, free-slip
east wall and lid. Fixed column height H0 = 0.1 m (the examples'), aspect ratios
a = H0/L0 = 0.5, 1, 2, 4, 8 (L0 = 0.2 ... 0.0125 m, the half-width).

Grids. Square cells dx = dz = H0/N. Three levels per aspect ratio, N = N0 (1, sqrt 2, 2)
(:data:`COARSE_N`, :data:`REFINEMENT`): N0 = 14 for a <= 2 (14-28 cells over H0, >= 7 across
L0), N0 = 4a for a = 4, 8 (4, 5.7, 8 cells across L0). The coarsest N exceeds 10 so that the
creeping one-cell tongue of the diffuse surface, of thickness (phi_c/phi_max) dz = dz/2
(validation/lagree_column/README.md), is thinner than the front threshold 0.05 H0 at every level.
The box is Lx = :data:`LX_OVER_H0` [a] H0 long (the furthest grain, phi > 1e-3, must stay
>= 2 cells from the east wall: checked per run) and Lz = ceil(1.1 N) dz tall (the column only
falls: the highest grain is recorded and checked).

Run to rest with ``time.dt_max`` = :data:`DT_MAX` (0.25 ms): ``time.stop_at_rest = 0.1`` s with
``output.rest_speed = 7.5e-3`` m/s (the examples' 10 eps Lz at their Lz = 0.15 m, set explicitly
because the default depends on Lz); scheme v1
(:data:`V1_OPTIONS`) also sets ``numerics.gravity_blend_velocity = 7.5e-4`` m/s (the examples'
v1 eps Lz, idem; scheme v2's default is ``|g| dt``); ``stop_time`` = 2 s is an upper bound. ``numerics.linear_solver = "auto"``, every other option as in the example.

Fronts (from h(x) = sum_z phi dz / phi_max at every 0.02 s, with the analysis functions of
validation/lagree_column/run.py, imported): ``thr0.05``, where the piecewise-linear interpolant of
h falls below 0.05 H0 (the case's default front threshold); ``toe``, the straight line fitted to
the deposit toe (h from 0.15 H0 down to 0.05 H0) extrapolated to h = 0. Run-out (L_inf - L0)/L0 at
the end of the run. Extrapolation: ``richardson`` of lagree_column with refinement ratio sqrt 2
(3-level Richardson + GCI when monotone with observed order in [0.5, 4], else first order with
safety factor 3). Power-law fits with its ``power_fit``.

Published planar scalings: (L_inf - L0)/L0 ~ lambda1 a for a <~ 3 (lambda1 = 1.2-2.2) and
lambda2 a^(2/3) above (lambda2 = 1.9-3.9) (Lube et al. 2005; Lajeunesse et al. 2005); Balmforth &
Kerswell (2005): one exponent 0.9 +- 0.1.

Run:   python validation/dry_runout/run.py [--aspects 0.5,1] [--levels 0,1,2] [--timeout 900]
       python validation/dry_runout/run.py --plot-only        # tables + figures from results.json, data/
       python validation/dry_runout/run.py --below-rule       # 5 runs below the tongue rule (~25 s)
       python validation/dry_runout/run.py --quick            # smoke test: a = 1, level 0, 20 steps (~1 s)
Time:  ~15 min for the 15 runs on the shared 2-core machine (9-116 s each; 288 s for a = 8 at 64).
Each run is a subprocess under ``timeout``; its record goes to results.json and its reduced data
(t, x, h(t, x), kinetic energy, cell-edge front) to data/<key>.npz; runs already there are skipped
(``--force`` redoes). NetCDF output in runs/validation_dry_runout/ (not kept).
"""
from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from granflow.config.overrides import CONVERGED_LOOP
from granflow.verification.convergence import richardson
from granflow.verification.scripts import load_json, load_script, save_json

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RESULTS = HERE / "results.json"
DATA = HERE / "data"
WORKDIR = ROOT / "runs" / "validation_dry_runout"
BASE_FILE = ROOT / "examples" / "column_collapse_dry.toml"
LAGREE_RUN = ROOT / "validation" / "lagree_column" / "run.py"
LAGREE_RESULTS = ROOT / "validation" / "lagree_column" / "results.json"
FIG_RUNOUT, FIG_CONVERGENCE = HERE / "runout.png", HERE / "convergence.png"


LAG = load_script(LAGREE_RUN)
"""validation/lagree_column/run.py as a module (its front and fit helpers)."""

H0 = 0.1
"""Column height [m] (examples/column_collapse_dry.toml)."""
ASPECTS = (0.5, 1.0, 2.0, 4.0, 8.0)
COARSE_N = {0.5: 14, 1.0: 14, 2.0: 14, 4.0: 16, 8.0: 32}
"""Coarsest level: cells over H0 (>= 4 cells across L0 = H0/a; > 10 for the tongue rule)."""
REFINEMENT = math.sqrt(2.0)
"""Ratio of successive cell sizes (three levels: N0, sqrt(2) N0, 2 N0)."""
N_LEVELS = 3
LX_OVER_H0 = {0.5: 5.5, 1.0: 4.5, 2.0: 3.6, 4.0: 2.8, 8.0: 2.2}
"""Box length [H0] per aspect ratio (furthest grain checked against it, per run); enlarged on
2026-12-03 for scheme v2, whose finest levels reached the v1 boxes' east walls."""
LZ_OVER_H0 = 1.1
"""Box height [H0] (rounded up to whole cells)."""
PHI_MAX = 0.6
PHI_C = 0.3
"""numerics.ambient.phi_c default [-] (tongue thickness (phi_c/phi_max) dz)."""
STOP_TIME = 2.0
STOP_AT_REST = 0.1
DT_MAX = 2.5e-4
"""time.dt_max of every level [s] (the examples' 1e-3 until session 25). With one solve per step
(the defaults since session 25) the coarse levels, which run at dt_max while the finest is
CFL-bound, carried an O(dt) error as large as the mesh error at 1 ms: the a = 8 toe's levels
8.152 / 8.496 / 8.843 fell back to first order, at 0.25 ms 8.525 / 8.800 / 8.940 converge at
order 1.95 (README, "Session 25"); 0.5 -> 0.25 ms moves the finest a = 8 toe by 0.02."""
REST_SPEED = 7.5e-3
"""[m/s] the examples' default 10 eps Lz with Lz = 0.15 m."""
GRAVITY_BLEND = 7.5e-4
"""[m/s] the examples' scheme-v1 default eps Lz with Lz = 0.15 m: to be set with the threshold
surface, whose default depends on Lz (:data:`V1_OPTIONS`); the indicator surface's default,
``|g| dt``, does not."""
LOOP_OPTIONS = CONVERGED_LOOP + ("time.dt_max=1e-3",)
"""The time stepping the v1 runs were measured with (the iterated Picard loop from u^n, CFL 0.3, the
pattern rebuilt every step: the defaults through session 24; the examples' dt_max 1 ms, not the
study's :data:`DT_MAX`), pinned with v1 so that a change of those defaults leaves v1 as measured."""
V1_OPTIONS = ("numerics.advection=upwind", "numerics.surface=threshold",
              f"numerics.gravity_blend_velocity={GRAVITY_BLEND}") + LOOP_OPTIONS
"""``--set`` overrides of scheme v1 for :func:`run_one`'s ``extra`` (tests)."""
OUTPUT_INTERVAL = 0.02
THRESHOLD = 0.05
"""Front threshold [H0] (the case's FRONT_THRESHOLD_FRACTION)."""
TOE_WINDOW = (0.05, 0.15)
"""Deposit thicknesses [H0] of the toe fit (lagree_column's TOE_WINDOW)."""
FRONTS = ("toe", "thr0.05")
PRIMARY_FRONT = "toe"
REACH_PHI = 1e-3
"""A cell holds grains if phi exceeds this [-]."""
WALL_MARGIN_CELLS = 2
"""The furthest grain must stay this many cells from the east wall / lid."""
TIMEOUT_S = 900
QUICK_ASPECT, QUICK_STEPS = 1.0, 20
"""The ``--quick`` smoke run: a = 1, level 0, this many steps, temporary files."""
SLOPE_WINDOW = (0.2, 0.8)
"""Deposit thicknesses [h_wall] over which the deposit slope is fitted."""
PLATEAU = 0.98
"""h above this [H0] is the undisturbed top of a wide column (left out of the slope fit)."""
BELOW_RULE = ((1.0, 5.0), (1.0, 6.0), (1.0, 5.0 * math.sqrt(2.0)), (1.0, 6.0 * math.sqrt(2.0)), (2.0, 8.0))
"""(a, cells over H0) of ``--below-rule``: levels whose one-cell tongue (phi_c/phi_max) dz is
thicker than the 0.05 H0 threshold (kept out of the analysis; the artefact they show)."""
LAMBDA1_BAND, LAMBDA2_BAND = LAG.LAMBDA1_BAND, LAG.LAMBDA2_BAND
TRANSITION_A = LAG.TRANSITION_A
BK_EXPONENT = LAG.BK_EXPONENT


# --- runs ----------------------------------------------------------------------------------------
def levels(a: float) -> list[float]:
    """Cells over H0 of the levels of aspect ratio ``a``, coarse to fine."""
    return [COARSE_N[a] * REFINEMENT**k for k in range(N_LEVELS)]


def key(a: float, level: int) -> str:
    return f"a{a:g}_L{level}"


def geometry(a: float, n: float) -> dict:
    """Grid of one run: dx = H0/n, whole cells in x and z."""
    dx = H0 / n
    nx, nz = math.ceil(LX_OVER_H0[a] * n - 1e-9), math.ceil(LZ_OVER_H0 * n - 1e-9)
    return {"N": n, "dx": dx, "nx": nx, "nz": nz, "Lx": nx * dx, "Lz": nz * dx, "L0": H0 / a}


def overrides(a: float, n: float, max_steps: int | None = None) -> list[str]:
    g = geometry(a, n)
    out = [f"setup.H0={H0}", f"setup.L0={g['L0']!r}", f"grid.nx={g['nx']}", f"grid.nz={g['nz']}",
           f"grid.Lx={g['Lx']!r}", f"grid.Lz={g['Lz']!r}", f"time.stop_time={STOP_TIME}",
           f"time.stop_at_rest={STOP_AT_REST}", f"output.interval={OUTPUT_INTERVAL}",
           f"output.rest_speed={REST_SPEED}", f"time.dt_max={DT_MAX}",
           'numerics.linear_solver="auto"', 'output.fields=["phi"]', "output.figures=false",
           "output.checkpoint_interval=1000000"]
    if max_steps is not None:
        out.append(f"time.max_steps={max_steps}")
    return out


def extract(run_dir: Path) -> dict:
    """Reduced arrays of a finished run: t, x, h(t, x) [m], kinetic energy, cell-edge front, the
    furthest and highest grain per record [m]."""
    import netCDF4

    from granflow.output import ordered

    with netCDF4.Dataset(run_dir / "output.nc") as ds:
        t = np.asarray(ds["time"][:], dtype=float)
        x, z = np.asarray(ds["x"][:], dtype=float), np.asarray(ds["z"][:], dtype=float)
        phi = ordered(ds["phi"]).astype(float)  # (time, x, z), whatever the order in the file
        dx, dz = x[1] - x[0], z[1] - z[0]
        full = phi > REACH_PHI
        reach = np.array([x[np.flatnonzero(f.any(axis=1))[-1]] + dx / 2 for f in full])
        top = np.array([z[np.flatnonzero(f.any(axis=0))[-1]] + dz / 2 for f in full])
        return {"t": t, "x": x, "h": (phi.sum(axis=2) * dz / PHI_MAX).astype(np.float32),
                "ke": np.asarray(ds["kinetic_energy"][:], dtype=float),
                "x_front_cell_edge": np.asarray(ds["x_front"][:], dtype=float), "reach": reach, "top": top}


def front(arrays: dict, name: str, k: int = -1) -> float:
    """Front ``name`` of :data:`FRONTS` of record ``k`` [m] (lagree_column's definitions, with the
    thicknesses scaled by H0)."""
    h = arrays["h"][k].astype(float)
    if name == "toe":
        return LAG.toe_front(arrays["x"], h, (TOE_WINDOW[0] * H0, TOE_WINDOW[1] * H0))
    return LAG.linear_front(arrays["x"], h, THRESHOLD * H0)


def leading_tail(arrays: dict, k: int = -1) -> dict:
    """The deposit's tail beyond the ``thr0.05`` front: extent [m] of the contiguous cells there
    with h > (phi_c/phi_max) dz / 2 (half the thickness of a one-cell tongue at phi_c), and their
    largest h [m]. A creeping one-cell tongue would show as a long tail of h ~ (phi_c/phi_max) dz."""
    x, h = arrays["x"], arrays["h"][k].astype(float)
    dz_half = 0.5 * PHI_C / PHI_MAX * (arrays["dz"])
    xf = front(arrays, "thr0.05", k)
    beyond = (x > xf) & (h > dz_half)
    if not beyond.any():
        return {"length_m": 0.0, "max_h_m": 0.0}
    idx = np.flatnonzero(beyond)
    run = idx[: np.argmax(np.diff(np.r_[idx, idx[-1] + 2]) > 1) + 1]  # contiguous from the front
    return {"length_m": float(x[run[-1]] - xf), "max_h_m": float(h[run].max())}


def deposit_slope_deg(arrays: dict, k: int = -1) -> float:
    """Mean surface slope of the deposit [deg]: least-squares line through h(x) over the cells with
    SLOPE_WINDOW[0] h_wall < h < SLOPE_WINDOW[1] h_wall (h_wall = h of the first column), leaving
    out the undisturbed plateau (h > PLATEAU H0)."""
    x, h = arrays["x"], arrays["h"][k].astype(float)
    sel = (h > SLOPE_WINDOW[0] * h[0]) & (h < SLOPE_WINDOW[1] * h[0]) & (h < PLATEAU * H0)
    if sel.sum() < 2:
        return float("nan")
    return float(math.degrees(math.atan(-np.polyfit(x[sel], h[sel], 1)[0])))


def lid_check(arrays: dict, g: dict) -> dict:
    """Highest grain over the run, its rise above the initial top (the column's top cell, cut or
    not), and whether at least one empty row of cells stayed below the lid."""
    top = np.asarray(arrays["top"], dtype=float)
    return {"max_top_m": float(top.max()), "top_rise_m": float(top.max() - top[0]),
            "lid_clear": bool(top.max() <= g["Lz"] - g["dx"] + 1e-12)}


def record(a: float, level: int, summary: dict, arrays: dict, cpu_s: float, total_wall: float,
           n: float | None = None) -> dict:
    """The results.json entry of one run (level ``level`` of :func:`levels`, or ``n`` cells over H0)."""
    g = geometry(a, levels(a)[level] if n is None else n)
    L0 = g["L0"]
    t = arrays["t"]
    rec = {"a": a, "level": level, **g, "cells_across_L0": L0 / g["dx"], "steps": summary["steps"],
           "rejected_steps": summary.get("rejected_steps"), "wall_s": summary["wall_s"],
           "total_wall_s": total_wall, "cpu_s": cpu_s, "status": summary["status"],
           "stopped_at_rest": summary["stopped_at_rest"], "t_rest": summary["t_rest"],
           "t_final": summary["t_final"], "runout_cell_edge_m": summary["runout_m"],
           "final_height_at_wall_m": summary["final_height_at_wall"],
           "mass_rel_error": summary["mass_rel_error"], "energy_residual_rel": summary["energy_residual_rel"],
           "max_reach_m": float(arrays["reach"].max()), "max_top_m": float(arrays["top"].max()),
           "tongue_thickness_m": PHI_C / PHI_MAX * g["dx"]}
    rec["east_wall_clear"] = rec["max_reach_m"] <= g["Lx"] - WALL_MARGIN_CELLS * g["dx"] + 1e-12
    rec.update(lid_check(arrays, g))
    earlier = t <= t[-1] - STOP_AT_REST + 1e-9
    for name in FRONTS:
        xf = np.array([front(arrays, name, k) for k in range(t.size)])
        rec[name] = {"x_f_m": float(xf[-1]), "relative": float((xf[-1] - L0) / L0),
                     "drift_last_hold_m": float(xf[-1] - xf[earlier][-1]) if earlier.any() else None}
    rec["tail"] = leading_tail(arrays)
    return rec


def run_single(a: float, level: int, max_steps: int | None = None, workdir: Path = WORKDIR,
               datadir: Path = DATA, results_path: Path = RESULTS, n: float | None = None,
               extra: tuple[str, ...] = ()) -> dict:
    """One collapse through :class:`CaseRun` (level ``level`` of :func:`levels`, or ``n`` cells over
    H0 if given: tests); saves ``datadir``/<key>.npz and the record in ``results_path``.
    ``extra``: further ``--set`` overrides (tests: e.g. scheme v1's numerics)."""
    from granflow.casekit.runner import CaseRun
    from granflow.config import load_case

    name = key(a, level)
    n = levels(a)[level] if n is None else n
    cfg = load_case(BASE_FILE, [*overrides(a, n, max_steps), *extra])
    cpu0, wall0 = time.process_time(), time.perf_counter()
    result = CaseRun(cfg, workdir / name, overwrite=True).run()
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    arrays = extract(workdir / name)
    arrays["dz"] = np.float64(geometry(a, n)["dx"])
    datadir.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(datadir / f"{name}.npz", **arrays)
    rec = record(a, level, result.summary, arrays, cpu, wall, n)
    res = load_results(results_path)
    res["runs"][name] = rec
    save_results(res, results_path)
    print(f"{name}: N = {rec['N']:.2f} ({rec['nx']} x {rec['nz']}), {rec['status']}, t_rest {rec['t_rest']}, "
          f"t_final {rec['t_final']:.3f}, steps {rec['steps']}, wall {rec['wall_s']:.0f} s, toe "
          f"{rec['toe']['relative']:.3f}, thr0.05 {rec['thr0.05']['relative']:.3f}, reach "
          f"{rec['max_reach_m']:.3f}/{rec['Lx']:.3f} m, top {rec['max_top_m']:.3f}/{rec['Lz']:.3f} m", flush=True)
    return rec


def run(resolution: int = 0, quick: bool = False, a: float = QUICK_ASPECT) -> dict:
    """Level ``resolution`` (an index of :func:`levels`) of aspect ratio ``a``: :func:`run_single`
    in this process, to rest, recorded in results.json; ``quick``: :data:`QUICK_STEPS` steps into a
    temporary directory (nothing saved)."""
    if not quick:
        return run_single(a, resolution)
    with tempfile.TemporaryDirectory() as tmp:
        return run_single(a, resolution, max_steps=QUICK_STEPS, workdir=Path(tmp), datadir=Path(tmp),
                          results_path=Path(tmp) / RESULTS.name)


def load_arrays(name: str, datadir: Path = DATA) -> dict:
    with np.load(datadir / f"{name}.npz") as f:
        return {k: f[k] for k in f.files}


def load_results(path: Path = RESULTS) -> dict:
    return load_json(path, {"runs": {}})


def save_results(results: dict, path: Path = RESULTS) -> None:
    save_json(results, path, fallback=float)


# --- analysis ------------------------------------------------------------------------------------
def analyse(results: dict, name: str = PRIMARY_FRONT) -> dict:
    """Per a: relative run-out per level, extrapolated value (lagree_column ``richardson``, ratio
    sqrt 2), lambda1 = est/a, lambda2 = est/a^(2/3); power-law fits of the estimates."""
    runs = [r for r in results["runs"].values() if r["status"] == "completed"]
    table = []
    for a in sorted({r["a"] for r in runs}):
        rs = sorted((r for r in runs if r["a"] == a), key=lambda r: r["level"])
        usable = [r for r in rs if r["tongue_thickness_m"] < THRESHOLD * H0]
        rel = [r[name]["relative"] for r in usable]
        est = richardson(rel, REFINEMENT)
        table.append({"a": a, "levels": [r["level"] for r in usable], "N": [r["N"] for r in usable],
                      "cells_across_L0": [r["cells_across_L0"] for r in usable], "relative": rel,
                      "wall_s": [r["wall_s"] for r in usable], "t_rest": [r["t_rest"] for r in usable],
                      "steps": [r["steps"] for r in usable], "estimate": est,
                      "lambda1": est["value"] / a, "lambda2": est["value"] / a ** (2 / 3)})
    fits = {}
    for label, sel in (("all", table), ("a<=2", [r for r in table if r["a"] <= 2]),
                       ("a>=2", [r for r in table if r["a"] >= 2]),
                       ("a>=4", [r for r in table if r["a"] >= 4])):
        if len(sel) >= 2:
            aa, est = [r["a"] for r in sel], [r["estimate"]["value"] for r in sel]
            fits[label] = LAG.power_fit(aa, est)
            sig = [r["estimate"]["uncertainty"] for r in sel]
            if all(math.isfinite(v) and v > 0 for v in sig):
                fits[f"{label}:weighted"] = LAG.power_fit(aa, est, sig)
            fits[f"{label}:finest_level"] = LAG.power_fit(aa, [r["relative"][-1] for r in sel])
    lam1 = [r["lambda1"] for r in table if r["a"] < TRANSITION_A]
    lam2 = [r["lambda2"] for r in table if r["a"] > TRANSITION_A]
    return {"front": name, "table": table, "fits": fits,
            "lambda1_range": [min(lam1), max(lam1)] if lam1 else None,
            "lambda2_range": [min(lam2), max(lam2)] if lam2 else None}


def markdown(analysis: dict) -> str:
    def fmt(xs, f: str) -> str:
        return ", ".join("-" if v is None else format(v, f) for v in xs)
    lines = [f"front: {analysis['front']}", "",
             ("| a | N (cells over H0) | cells across L0 | (L_inf - L0)/L0 per level | estimate | +- | method "
             "(order) | lambda1 = est/a | lambda2 = est/a^(2/3) | t_rest per level [s] | steps | wall s |"),
             "|---:|---|---|---|---:|---:|---|---:|---:|---|---|---|"]
    for r in analysis["table"]:
        e = r["estimate"]
        order = "" if e["order"] is None else f" ({e['order']:.2f})"
        lines.append(f"| {r['a']:g} | {fmt(r['N'], '.1f')} | {fmt(r['cells_across_L0'], '.1f')} | "
                     f"{fmt(r['relative'], '.3f')} | {e['value']:.3f} | {e['uncertainty']:.3f} | "
                     f"{e['method']}{order} | {r['lambda1']:.2f} | {r['lambda2']:.2f} | {fmt(r['t_rest'], '.2f')} | "
                     f"{fmt(r['steps'], 'd')} | {fmt(r['wall_s'], '.0f')} |")
    lines += ["", "| a range | fitted exponent | +- (std. error) | prefactor | points |", "|---|---:|---:|---:|---:|"]
    for k, f in analysis["fits"].items():
        lines.append(f"| {k} | {f['exponent']:.3f} | {f['stderr']:.3f} | {f['prefactor']:.3f} | {f['n']} |")
    return "\n".join(lines)


def lagree_table() -> list[dict]:
    """Toe-front extrapolated run-outs of validation/lagree_column (mu(I)), for comparison."""
    if not LAGREE_RESULTS.exists():
        return []
    res = json.loads(LAGREE_RESULTS.read_text())
    return res.get("analysis", {}).get("toe", {}).get("table", [])


# --- figures -------------------------------------------------------------------------------------
def figure_runout(analyses: dict, path: Path = FIG_RUNOUT) -> Path:
    plt = LAG._plt()
    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    lo, hi = np.linspace(0.3, TRANSITION_A, 50), np.linspace(TRANSITION_A, 12, 50)
    ax.fill_between(lo, LAMBDA1_BAND[0] * lo, LAMBDA1_BAND[1] * lo, color="0.85",
                    label=f"lambda1 a, lambda1 = {LAMBDA1_BAND[0]}-{LAMBDA1_BAND[1]}")
    ax.fill_between(hi, LAMBDA2_BAND[0] * hi ** (2 / 3), LAMBDA2_BAND[1] * hi ** (2 / 3), color="0.7",
                    alpha=0.6, label=f"lambda2 a^(2/3), lambda2 = {LAMBDA2_BAND[0]}-{LAMBDA2_BAND[1]}")
    for (name, an), c, mk in zip(analyses.items(), ("C3", "C0"), ("o", "D")):
        rows = an["table"]
        a = np.array([r["a"] for r in rows]) * (1.0 if name == PRIMARY_FRONT else 1.05)
        ax.errorbar(a, [r["estimate"]["value"] for r in rows], yerr=[r["estimate"]["uncertainty"] for r in rows],
                    fmt=mk, color=c, capsize=3, label=f"DP glass beads, {name}: extrapolated")
        for j, (sym, lab) in enumerate((("v", "coarsest"), ("^", "finest"))):
            ax.plot(a, [r["relative"][0 if j == 0 else -1] for r in rows], sym, mfc="none", color=c, ms=6,
                    label=f"{name}: {lab} level")
        f = an["fits"].get("all")
        if f and name == PRIMARY_FRONT:
            aa = np.linspace(0.4, 10, 50)
            ax.plot(aa, f["prefactor"] * aa ** f["exponent"], color=c, lw=0.8,
                    label=f"fit {f['prefactor']:.2f} a^{f['exponent']:.2f}")
    lag = [r for r in lagree_table() if r["model"] == "mu_i"]
    if lag:
        ax.plot([r["a"] for r in lag], [r["estimate"]["value"] for r in lag], "x", color="k", ms=7,
                label="Lagree column, mu(I) (mu_i), toe, extrapolated")
    ax.set(xscale="log", yscale="log", xlabel="a = H0 / L0", ylabel="(L_inf - L0) / L0",
           title="dry run-out, glass beads (DP, sin delta = 0.45), H0 = 0.1 m")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def figure_convergence(results: dict, analyses: dict, datadir: Path = DATA, path: Path = FIG_CONVERGENCE) -> Path:
    plt = LAG._plt()
    aspects = sorted({r["a"] for r in results["runs"].values()})
    fig, axes = plt.subplots(1, 1 + len(aspects), figsize=(4 * (1 + len(aspects)), 4.2))
    an = analyses[PRIMARY_FRONT]
    for k, r in enumerate(an["table"]):
        c = f"C{k}"
        dxl = [1.0 / n * r["a"] for n in r["N"]]  # dx / L0
        axes[0].plot(dxl, np.array(r["relative"]) / r["a"], "o-", color=c, label=f"a = {r['a']:g}")
        e = r["estimate"]
        axes[0].errorbar([0.0], [e["value"] / r["a"]], yerr=[e["uncertainty"] / r["a"]], fmt="o", mfc="none",
                         color=c, capsize=3)
        thr = next(t for t in analyses["thr0.05"]["table"] if t["a"] == r["a"])
        axes[0].plot(dxl, np.array(thr["relative"]) / r["a"], "s:", color=c, mfc="none", ms=4)
    axes[0].set(xlabel="dx / L0", ylabel="(L_inf - L0) / (a L0)", xlim=(-0.02, None),
                title="run-out / a vs dx (toe: solid, thr0.05: dotted)")
    axes[0].legend(fontsize=7)
    for ax, a in zip(axes[1:], aspects):
        rs = sorted((r for r in results["runs"].values() if r["a"] == a), key=lambda r: r["level"])
        L0 = H0 / a
        ax.plot([0, 1, 1], [1, 1, 0], color="0.6", lw=0.8)
        for r in rs:
            arr = load_arrays(key(a, r["level"]), datadir)
            ax.plot(arr["x"] / L0, arr["h"][-1] / H0, color=f"C{r['level']}",
                    label=f"N = {r['N']:.1f}, t = {arr['t'][-1]:.2f} s")
            ax.axvline(r["toe"]["x_f_m"] / L0, color=f"C{r['level']}", lw=0.6, ls="--")
        ax.axhline(THRESHOLD, color="0.7", lw=0.6, ls=":")
        ax.set(xlabel="x / L0", ylabel="h / H0", title=f"deposit at rest, a = {a:g} (dashed: toe front)",
               xlim=(0, None), ylim=(0, 1.05))
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def run_table(results: dict) -> str:
    lines = [("| run | N | grid | cells across L0 | t_rest [s] | t_final [s] | steps | wall [s] | toe | thr0.05 | "
             "cell-edge | reach / Lx [m] | top / Lz [m] | tail beyond thr0.05 [mm, max h mm] | h at wall / H0 | "
             "slope [deg] | energy residual |"), "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|---:|---:|---:|"]
    for k, r in sorted(results["runs"].items(), key=lambda kv: (kv[1]["a"], kv[1]["level"])):
        tr = "-" if r["t_rest"] is None else f"{r['t_rest']:.2f}"
        lines.append(f"| {k} | {r['N']:.1f} | {r['nx']} x {r['nz']} | {r['cells_across_L0']:.1f} | {tr} | "
                     f"{r['t_final']:.2f} | {r['steps']} | {r['wall_s']:.0f} | {r['toe']['relative']:.3f} | "
                     f"{r['thr0.05']['relative']:.3f} | {r['runout_cell_edge_m'] / r['L0']:.3f} | "
                     f"{r['max_reach_m']:.3f} / {r['Lx']:.3f} {'ok' if r['east_wall_clear'] else 'NO'} | "
                     f"{r['max_top_m']:.3f} / {r['Lz']:.3f} {'ok' if r['lid_clear'] else 'NO'} | "
                     f"{r['tail']['length_m'] * 1e3:.1f}, {r['tail']['max_h_m'] * 1e3:.1f} | "
                     f"{r['final_height_at_wall_m'] / H0:.3f} | {r.get('deposit_slope_deg', math.nan):.1f} | "
                     f"{r['energy_residual_rel']:.3f} |")
    return "\n".join(lines)


def report(results: dict) -> dict:
    for name, r in results["runs"].items():  # lid check of records made before lid_check existed
        if "top_rise_m" not in r and (DATA / f"{name}.npz").exists():
            r.update(lid_check(load_arrays(name), r))
        if "tongue" in r:
            r["tail"] = r.pop("tongue")
        if (DATA / f"{name}.npz").exists():
            r["deposit_slope_deg"] = deposit_slope_deg(load_arrays(name))
    analyses = {name: analyse(results, name) for name in FRONTS}
    results["analysis"] = analyses
    save_results(results)
    print(run_table(results))
    for an in analyses.values():
        print("\n" + markdown(an))
        print(f"lambda1 range {an['lambda1_range']}, lambda2 range {an['lambda2_range']}")
    print("figures:", figure_runout(analyses).name, figure_convergence(results, analyses).name)
    return analyses


# --- driver --------------------------------------------------------------------------------------
def _floats(text: str) -> tuple[float, ...]:
    return tuple(float(v) for v in text.split(",") if v)


def _ints(text: str) -> tuple[int, ...]:
    return tuple(int(v) for v in text.split(",") if v)


def below_rule() -> dict:
    """Runs of :data:`BELOW_RULE` (a tongue thicker than the threshold) into a temporary directory;
    their records go to results.json["below_tongue_rule"] (not used by the analysis)."""
    import tempfile

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for j, (a, n) in enumerate(BELOW_RULE):
            res = Path(tmp) / "r.json"
            rec = run_single(a, j, workdir=Path(tmp), datadir=Path(tmp), results_path=res, n=n)
            rec["deposit_slope_deg"] = deposit_slope_deg(load_arrays(key(a, j), Path(tmp)))
            out[f"a{a:g}_N{n:.2f}"] = rec
    results = load_results()
    results["below_tongue_rule"] = out
    save_results(results)
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--aspects", type=_floats, default=ASPECTS)
    p.add_argument("--levels", type=_ints, default=tuple(range(N_LEVELS)), help="level indices, 0 = coarsest")
    p.add_argument("--timeout", type=float, default=TIMEOUT_S, help="wall limit per run [s]")
    p.add_argument("--force", action="store_true")
    p.add_argument("--plot-only", action="store_true")
    p.add_argument("--below-rule", action="store_true",
                   help="run the BELOW_RULE coarse levels (temporary files; ~25 s), store them in results.json")
    p.add_argument("--single", nargs=2, metavar=("A", "LEVEL"), help=argparse.SUPPRESS)
    p.add_argument("--quick", action="store_true",
                   help=f"smoke test: a = {QUICK_ASPECT:g}, level 0, {QUICK_STEPS} steps, temporary files")
    args = p.parse_args(argv)
    if args.quick:
        run(0, quick=True)
        return
    if args.single:
        run_single(float(args.single[0]), int(args.single[1]))
        return
    if args.below_rule:
        below_rule()
    elif not args.plot_only:
        for lev in args.levels:  # coarse levels of every a first
            for a in args.aspects:
                if key(a, lev) in load_results()["runs"] and not args.force:
                    continue
                cmd = ["timeout", f"{args.timeout:g}", sys.executable, str(Path(__file__).resolve()),
                       "--single", f"{a:g}", str(lev)]
                rc = subprocess.run(cmd, check=False).returncode
                if rc != 0:
                    print(f"{key(a, lev)}: exit code {rc} (124 = timeout)", flush=True)
    report(load_results())


if __name__ == "__main__":
    main()
