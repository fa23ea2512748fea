"""Fluidised against dry run-out with three-level mesh convergence (issue 4, item 3).

The fluidised counterpart of validation/dry_runout: the same glass beads (d = 70 um,
rho_s = 2500 kg/m^3, Drucker-Prager sin(delta) = 0.45, paper eqs f-DP, syst4DP), the same
column height H0 = 0.1 m, aspect ratios a = H0/L0, grids, rest criterion, fronts and extrapolation
(imported from validation/dry_runout/run.py), with the pore gas of the linear law (paper eq.
syst2b, examples/column_collapse_fluidised.toml). The dry run-outs at the same levels are read
from validation/dry_runout/results.json (run there), so that each fluidised level has its dry
partner on the same cells.

Initial states (:data:`STATES`):

* ``b0.9_phi0.58``: expanded bed phi0 = 0.58, p_f = 0.9 x lithostatic (the flagship example);
* ``b0.5_phi0.58``: the same bed at p_f = 0.5 x lithostatic (the b0 dependence);
* ``injection``: prepared like the experiments: gas injected through the base at U = U_mf until
  steady, then the gate opens and the supply stops (examples/column_collapse_injected.toml).

Grids: N = 14, 14 sqrt 2, 28 cells over H0 (dx = 7.1, 5.0, 3.6 mm; the dry study's levels for
a <= 2: above the tongue rule, see validation/dry_runout/README.md). The box is longer than the
dry one (:data:`LX_OVER_H0`; the furthest grain must stay two cells from the east wall) and
taller (:data:`LZ_OVER_H0`; an expanded bed can rise).

Reported per (a, state): the run-out (L_inf - L0)/L0 at each level with the 0.05 H0 threshold
front (``thr0.05``, primary, see :data:`PRIMARY_FRONT`) and the deposit-toe front (``toe``), its
mesh-converged estimate (:func:`estimate`, ratio sqrt 2), the ratio to the dry run-out at each
level, the ratio of the two estimates with its uncertainty propagated from both
(sigma_r / r = sigma_f / f + sigma_d / d, a bound, since the two errors are correlated through the
grid), and the estimate from the per-level ratios as a cross-check.

Run:   python validation/fluidised_vs_dry/convergence.py [--plan main|all] [--timeout 1800]
       python validation/fluidised_vs_dry/convergence.py --plot-only
       python validation/fluidised_vs_dry/convergence.py --quick   # smoke test: a = 1, level 0, 20 steps
Time:  ~40 min on one core of the 2-core machine (25-310 s per run). Each run is a subprocess
under ``timeout``; its record goes to convergence.json and its reduced arrays to
data/<key>.npz; runs already recorded are skipped (``--force`` redoes). NetCDF output in
runs/validation_fluidised_convergence/ (not kept).
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from granflow.verification.convergence import mesh_estimate, ratio_estimate
from granflow.verification.scripts import load_script

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RESULTS = HERE / "convergence.json"
DATA = HERE / "data"
WORKDIR = ROOT / "runs" / "validation_fluidised_convergence"
FIGURE = HERE / "convergence.png"
DRY_RUN = ROOT / "validation" / "dry_runout" / "run.py"
BASE_FILES = {"fluidised": ROOT / "examples" / "column_collapse_fluidised.toml",
              "injected": ROOT / "examples" / "column_collapse_injected.toml"}


DR = load_script(DRY_RUN)
"""validation/dry_runout/run.py as a module (grids, fronts, extraction, results files)."""
LAG = DR.LAG
H0 = DR.H0
STATES = {
    "b0.9_phi0.58": ("fluidised", ["setup.b0=0.9", "setup.phi0=0.58"]),
    "b0.5_phi0.58": ("fluidised", ["setup.b0=0.5", "setup.phi0=0.58"]),
    "injection": ("injected", ["setup.U_prep_over_Umf=1.0", 'setup.keep_injection="none"']),
}
"""Initial state -> (base file, overrides)."""
STATE_LEVELS = {"injection": (0, 2)}
"""Levels run per state (default all): with a preparation the gate is a cell face, so L0 must be a
whole number of cells, which the middle level (14 sqrt 2 cells over H0) is not."""
PLANS = {"main": [(0.5, "b0.9_phi0.58"), (1.0, "b0.9_phi0.58"), (2.0, "b0.9_phi0.58"),
                  (1.0, "b0.5_phi0.58"), (1.0, "injection")]}
PLANS["all"] = [(a, s) for s in STATES for a in (0.5, 1.0, 2.0)]
LX_OVER_H0 = {0.5: 8.0, 1.0: 6.5, 2.0: 5.0}
"""Box length [H0] per aspect ratio (fluidised columns run ~2x further than the dry ones)."""
LZ_OVER_H0 = 1.3
"""Box height [H0]."""
PRIMARY_FRONT = "thr0.05"
"""The threshold front, not the dry study's toe fit: fluidised deposits end in a long, nearly
flat sheet (h ~ 0.1 H0 over 1-2 L0), across which the toe fit (h from 0.15 to 0.05 H0, a
straight line extrapolated to h = 0) is ill-conditioned and lands up to 1.5 L0 beyond the last
grain (README)."""
FRONTS = ("thr0.05", "toe")
TIMEOUT_S = 1800
QUICK_ASPECT, QUICK_STATE, QUICK_STEPS = 1.0, "b0.9_phi0.58", 20
"""The ``--quick`` smoke run: a = 1, this state, level 0, this many steps, temporary files."""


def key(a: float, state: str, level: int) -> str:
    return f"a{a:g}_{state}_L{level}"


def geometry(a: float, n: float) -> dict:
    dx = H0 / n
    nx, nz = math.ceil(LX_OVER_H0[a] * n - 1e-9), math.ceil(LZ_OVER_H0 * n - 1e-9)
    return {"N": n, "dx": dx, "nx": nx, "nz": nz, "Lx": nx * dx, "Lz": nz * dx, "L0": H0 / a}


def overrides(a: float, state: str, n: float, max_steps: int | None = None) -> list[str]:
    """The dry study's options (rest speed, gravity blend, solver, outputs) on this box, plus the
    state's overrides."""
    g = geometry(a, n)
    out = [f"setup.H0={H0}", f"setup.L0={g['L0']!r}", f"grid.nx={g['nx']}", f"grid.nz={g['nz']}",
           f"grid.Lx={g['Lx']!r}", f"grid.Lz={g['Lz']!r}", f"time.stop_time={DR.STOP_TIME}",
           f"time.stop_at_rest={DR.STOP_AT_REST}", f"output.interval={DR.OUTPUT_INTERVAL}",
           f"output.rest_speed={DR.REST_SPEED}", f"numerics.gravity_blend_velocity={DR.GRAVITY_BLEND}",
           f"time.dt_max={DR.DT_MAX}",  # the dry partners' time step (validation/dry_runout)
           'numerics.linear_solver="auto"', 'output.fields=["phi", "p_f"]', "output.figures=false",
           "output.checkpoint_interval=1000000",
           "output.probes_x=[" + ", ".join(f"{x:.6g}" for x in (g["L0"] / 2, g["L0"] + H0 / 2)) + "]"]
    if max_steps is not None:
        out.append(f"time.max_steps={max_steps}")
    return out + STATES[state][1]


def record(a: float, state: str, level: int, n: float, summary: dict, arrays: dict, cpu_s: float,
           wall_s: float) -> dict:
    g = geometry(a, n)
    diag = summary.get("case_diagnostics", {})
    rec = {"a": a, "state": state, "level": level, **g, "steps": summary["steps"],
           "rejected_steps": summary.get("rejected_steps"), "wall_s": summary["wall_s"],
           "prep_wall_s": diag.get("prep_wall_s", 0.0), "total_wall_s": wall_s, "cpu_s": cpu_s,
           "status": summary["status"], "stopped_at_rest": summary["stopped_at_rest"],
           "t_rest": summary["t_rest"], "t_final": summary["t_final"],
           "mass_rel_error": summary["mass_rel_error"], "energy_residual_rel": summary["energy_residual_rel"],
           "final_height_at_wall_m": summary["final_height_at_wall"], "phi0": diag.get("phi0"),
           "b0": diag.get("b0"), "max_reach_m": float(arrays["reach"].max()),
           "tongue_thickness_m": DR.PHI_C / DR.PHI_MAX * g["dx"]}
    rec["east_wall_clear"] = rec["max_reach_m"] <= g["Lx"] - DR.WALL_MARGIN_CELLS * g["dx"] + 1e-12
    rec.update(DR.lid_check(arrays, g))
    for name in FRONTS:
        xf = DR.front(arrays, name)
        rec[name] = {"x_f_m": xf, "relative": (xf - g["L0"]) / g["L0"]}
    return rec


def run_single(a: float, state: str, level: int, max_steps: int | None = None, workdir: Path = WORKDIR,
               datadir: Path = DATA, results_path: Path = RESULTS, n: float | None = None) -> dict:
    """One collapse at level ``level`` of the dry study's :func:`levels` (or ``n`` cells over H0:
    tests); saves ``datadir``/<key>.npz and the record in ``results_path``."""
    from granflow.casekit.runner import CaseRun
    from granflow.config import load_case

    name = key(a, state, level)
    n = DR.levels(a)[level] if n is None else n
    cfg = load_case(BASE_FILES[STATES[state][0]], overrides(a, state, n, max_steps))
    cpu0, wall0 = time.process_time(), time.perf_counter()
    result = CaseRun(cfg, workdir / name, overwrite=True).run()
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    arrays = DR.extract(workdir / name)
    arrays["dz"] = np.float64(geometry(a, n)["dx"])
    import netCDF4
    with netCDF4.Dataset(workdir / name / "output.nc") as ds:
        arrays["probe_p_f"] = np.asarray(ds["probe_p_f"][:], dtype=float)
        arrays["x_probe"] = np.asarray(ds["x_probe"][:], dtype=float)
    datadir.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(datadir / f"{name}.npz", **arrays)
    rec = record(a, state, level, n, result.summary, arrays, cpu, wall)
    res = DR.load_results(results_path)
    res["runs"][name] = rec
    DR.save_results(res, results_path)
    print(f"{name}: N = {n:.2f} ({rec['nx']} x {rec['nz']}), {rec['status']}, t_rest {rec['t_rest']}, "
          f"steps {rec['steps']}, wall {rec['wall_s']:.0f} s, toe {rec['toe']['relative']:.3f}, "
          f"thr0.05 {rec['thr0.05']['relative']:.3f}, reach {rec['max_reach_m']:.3f}/{rec['Lx']:.3f} m, "
          f"top {rec['max_top_m']:.3f}/{rec['Lz']:.3f} m", flush=True)
    return rec


def run(resolution: int = 0, quick: bool = False, a: float = QUICK_ASPECT, state: str = QUICK_STATE) -> dict:
    """Level ``resolution`` (an index of the dry study's levels) of ``state`` at aspect ``a``:
    :func:`run_single` in this process, recorded in convergence.json; ``quick``:
    :data:`QUICK_STEPS` steps into a temporary directory (nothing saved)."""
    if not quick:
        return run_single(a, state, resolution)
    with tempfile.TemporaryDirectory() as tmp:
        return run_single(a, state, resolution, max_steps=QUICK_STEPS, workdir=Path(tmp), datadir=Path(tmp),
                          results_path=Path(tmp) / RESULTS.name)


# --- analysis ------------------------------------------------------------------------------------
estimate = mesh_estimate
"""Mesh-converged value of coarse-to-fine values (:func:`granflow.verification.convergence.mesh_estimate`:
Richardson + GCI, the finest value +- half the range for oscillatory levels)."""


def analyse(results: dict, dry_results: dict, front: str = PRIMARY_FRONT) -> list[dict]:
    """Per (a, state): per-level run-outs and dry partners, their extrapolations, the ratio."""
    runs = [r for r in results["runs"].values() if r["status"] == "completed"]
    dry_runs = {(r["a"], r["level"]): r for r in dry_results.get("runs", {}).values() if r["status"] == "completed"}
    table = []
    for a, state in sorted({(r["a"], r["state"]) for r in runs}, key=lambda p: (list(STATES).index(p[1]), p[0])):
        rs = sorted((r for r in runs if r["a"] == a and r["state"] == state), key=lambda r: r["level"])
        levels = [r["level"] for r in rs]
        fl = [r[front]["relative"] for r in rs]
        dr = [dry_runs[(a, lev)][front]["relative"] if (a, lev) in dry_runs else math.nan for lev in levels]
        ratio = DR.REFINEMENT ** (levels[-1] - levels[-2]) if len(levels) > 1 else DR.REFINEMENT
        est_f = estimate(fl, ratio)
        row = {"a": a, "state": state, "levels": levels, "N": [r["N"] for r in rs], "fluidised": fl, "dry": dr,
               "ratio_per_level": [f / d for f, d in zip(fl, dr)], "estimate_fluidised": est_f,
               "wall_s": [r["wall_s"] + r["prep_wall_s"] for r in rs],
               "dry_wall_s": [dry_runs[(a, lev)]["wall_s"] if (a, lev) in dry_runs else math.nan for lev in levels],
               "t_rest": [r["t_rest"] for r in rs], "steps": [r["steps"] for r in rs],
               "checks_ok": all(r["east_wall_clear"] and r["lid_clear"] and r["stopped_at_rest"] for r in rs)}
        if not any(math.isnan(d) for d in dr):
            est_d = estimate(dr, ratio)
            row["estimate_dry"] = est_d
            row["ratio"] = ratio_estimate(est_f, est_d)
            row["ratio_richardson"] = estimate(row["ratio_per_level"], ratio)
        table.append(row)
    return table


def markdown(table: list[dict], front: str) -> str:
    def fl(xs, f=".3f"):
        return ", ".join(format(v, f) for v in xs)

    def est(e):
        return "-" if e is None else f"{e['value']:.2f} +- {e['uncertainty']:.2f}"
    lines = [f"front: {front}", "",
             "| a | state | N | dry per level | fluidised per level | ratio per level | dry extrapolated | "
             "fluidised extrapolated | **ratio** | ratio (Richardson of per-level) | wall s fluidised (dry) | checks |",
             "|---:|---|---|---|---|---|---:|---:|---:|---:|---|---|"]
    for r in table:
        walls = ", ".join(f"{w:.0f} ({d:.0f})" for w, d in zip(r["wall_s"], r["dry_wall_s"]))
        lines.append(f"| {r['a']:g} | {r['state']} | {fl(r['N'], '.1f')} | {fl(r['dry'])} | {fl(r['fluidised'])} | "
                     f"{fl(r['ratio_per_level'], '.2f')} | {est(r.get('estimate_dry'))} | "
                     f"{est(r['estimate_fluidised'])} | **{est(r.get('ratio'))}** | "
                     f"{est(r.get('ratio_richardson'))} | {walls} | {'ok' if r['checks_ok'] else 'NO'} |")
    return "\n".join(lines)


def figure(results: dict, dry_results: dict, table: list[dict], datadir: Path = DATA, path: Path = FIGURE) -> Path:
    plt = LAG._plt()
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.4))
    for k, r in enumerate(table):
        c, dxl = f"C{k}", [r["a"] / n for n in r["N"]]  # dx / L0
        ax[0].plot(dxl, r["fluidised"], "o-", color=c, label=f"a = {r['a']:g}, {r['state']}")
        ax[0].plot(dxl, r["dry"], "s:", color=c, mfc="none")
        ax[1].plot(dxl, r["ratio_per_level"], "o-", color=c, label=f"a = {r['a']:g}, {r['state']}")
        if "ratio" in r:
            ax[1].errorbar([0.0], [r["ratio"]["value"]], yerr=[r["ratio"]["uncertainty"]], fmt="o", mfc="none",
                           color=c, capsize=3)
    ax[0].set(xlabel="dx / L0", ylabel="(L_inf - L0) / L0", xlim=(-0.01, None),
              title="run-out per level (solid fluidised, dotted dry)")
    ax[0].legend(fontsize=7)
    ax[1].axhspan(1.8, 2.2, color="0.88", label="Roche 2012: ~2")
    ax[1].set(xlabel="dx / L0", ylabel="fluidised / dry", xlim=(-0.01, None), ylim=(0.5, 3.2),
              title="run-out ratio (open: extrapolated)")
    ax[1].legend(fontsize=7)
    for r in results["runs"].values():
        if r["a"] != 1.0 or not (datadir / f"{key(1.0, r['state'], r['level'])}.npz").exists():
            continue
        arr = DR.load_arrays(key(1.0, r["state"], r["level"]), datadir)
        ax[2].plot(arr["x"] / r["L0"], arr["h"][-1] / H0, color=f"C{list(STATES).index(r['state'])}",
                   lw=0.6 + 0.5 * r["level"], label=f"{r['state']} N = {r['N']:.0f}")
    for name, r in dry_results.get("runs", {}).items():
        if r["a"] == 1.0 and (DR.DATA / f"{name}.npz").exists():
            arr = DR.load_arrays(name)
            ax[2].plot(arr["x"] / r["L0"], arr["h"][-1] / H0, "k", lw=0.6 + 0.5 * r["level"],
                       label=f"dry N = {r['N']:.0f}")
    ax[2].set(xlabel="x / L0", ylabel="h / H0", title="deposits, a = 1", xlim=(0, 4.5), ylim=(0, 1.05))
    ax[2].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=105)
    plt.close(fig)
    return path


def report(results: dict) -> dict:
    dry = DR.load_results()
    analyses = {front: analyse(results, dry, front) for front in FRONTS}
    results["analysis"] = analyses
    DR.save_results(results, RESULTS)
    for front, table in analyses.items():
        print("\n" + markdown(table, front))
    print("figure:", figure(results, dry, analyses[PRIMARY_FRONT]).name)
    return analyses


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--plan", choices=sorted(PLANS), default="main")
    p.add_argument("--levels", default="0,1,2", help="level indices, 0 = coarsest")
    p.add_argument("--timeout", type=float, default=TIMEOUT_S, help="wall limit per run [s]")
    p.add_argument("--force", action="store_true")
    p.add_argument("--plot-only", action="store_true")
    p.add_argument("--single", nargs=3, metavar=("A", "STATE", "LEVEL"), help=argparse.SUPPRESS)
    p.add_argument("--quick", action="store_true",
                   help=f"smoke test: a = {QUICK_ASPECT:g}, {QUICK_STATE}, level 0, {QUICK_STEPS} steps, temporary files")
    args = p.parse_args(argv)
    if args.quick:
        run(0, quick=True)
        return
    if args.single:
        run_single(float(args.single[0]), args.single[1], int(args.single[2]))
        return
    if not args.plot_only:
        for lev in (int(v) for v in args.levels.split(",") if v):
            for a, state in PLANS[args.plan]:
                if lev not in STATE_LEVELS.get(state, (lev,)):
                    continue
                if key(a, state, lev) in DR.load_results(RESULTS)["runs"] and not args.force:
                    continue
                cmd = ["timeout", f"{args.timeout:g}", sys.executable, str(Path(__file__).resolve()),
                       "--single", f"{a:g}", state, str(lev)]
                rc = subprocess.run(cmd, check=False).returncode
                if rc != 0:
                    print(f"{key(a, state, lev)}: exit code {rc} (124 = timeout)", flush=True)
    report(DR.load_results(RESULTS))


if __name__ == "__main__":
    main()
