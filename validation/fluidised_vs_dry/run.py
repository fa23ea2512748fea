"""Fluidised against dry column collapses: run-out ratio across aspect ratios and initial states.

Issue 4, item 3, "fluidised against dry". Columns of 70 um glass beads (rho_s = 2500 kg/m^3,
Drucker-Prager closure sin(delta) = 0.45, linear gas law, paper eqs f-DP, syst4DP, syst2b),
H0 = 0.1 m, aspect ratios a = H0/L0 = 0.5, 1, 2 (L0 = 0.2, 0.1, 0.05 m) against the free-slip
(symmetry) west wall, rough impermeable base, released at t = 0 and run until at rest
(``time.stop_at_rest = 0.1`` s, ``time.stop_time`` an upper bound). Base files:
examples/column_collapse_{dry,fluidised,injected}.toml; the box is Lx = L0 + 0.5 m long (the
furthest grains stayed at least 0.18 m from the east wall) and Lz = 0.15 m high.

Initial states (``STATES``):

* ``dry``: phi0 = 0.6 = phi_max, no gas;
* ``b0.5_phi0.58``, ``b0.9_phi0.58``: p_f = b0 x lithostatic, expanded bed phi0 = 0.58;
* ``b0.9_phi0.60``: p_f = 0.9 x lithostatic, not expanded (phi0 = 0.6);
* ``injection``: prepared like the experiments (``setup.preparation = "injection"``, the
  reservoir fluidised at U = U_mf until steady, then released with the gas supply stopped);
* ``b0.0_phi0.58`` (a = 1 only): the expanded bed with the gas model but no initial pore
  pressure, which separates expansion from initial fluidisation.

Resolution: dx = dz = 1 cm for every run (the examples' grid), and dx = dz = 0.5 cm at a = 1
for the five main states (neither is converged). Reported per run: run-out (L_inf - L0)/L0 with
the front defined by a deposit thickness sum(phi) dz / phi_max > 5 mm (``FRONT_THRESHOLD``, the
same at both resolutions; the right edge of the last such column, so quantised by dx), the ratio
fluidised / dry at the same a and dx, t_rest (the phi-weighted rms granular speed below
10 eps Lz = 7.5 mm/s, held 0.1 s), the wall time (plus the preparation's for ``injection``), and
the furthest cell reached by any grain (phi > 1e-3; must stay clear of the east wall).

Basal pore pressure: ``output.probes_x`` at x = L0/2, L0 + H0/2, L0 + 1.5 H0 records p_f and p
of the bottom cell under each x at every output time; the figure shows p_f / p_lith0 with
p_lith0 = phi0 rho_s g (H0 - dz/2), the initial lithostatic pressure of the bottom cell under the
column (its centre is at z = dz/2), for the fluidised states at a = 1.

Run:   python validation/fluidised_vs_dry/run.py [--resume] [--only KEY ...] [--figures-only]
       python validation/fluidised_vs_dry/run.py --quick   # smoke test: a = 1, b0 = 0.9, 20 steps (~1 s)
Time:  ~19 min on a shared 2-core machine (1 cm runs 20-45 s each, 0.5 cm runs 1.5-3 min).
       Writes results.json, runout.png and basal_pressure.png next to this file; the run
       directories go to $TMPDIR/granflow_fluidised_vs_dry (not kept).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from granflow import diagnostics as dg
from granflow.casekit.runner import CaseRun
from granflow.config import load_case
from granflow.verification.scripts import load_json

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RESULTS = HERE / "results.json"
FIG_RUNOUT = HERE / "runout.png"
FIG_PRESSURE = HERE / "basal_pressure.png"
RUN_DIR = Path(os.environ.get("TMPDIR", tempfile.gettempdir())) / "granflow_fluidised_vs_dry"
EXAMPLES = ROOT / "examples"
BASE_FILES = {"dry": EXAMPLES / "column_collapse_dry.toml",
              "fluidised": EXAMPLES / "column_collapse_fluidised.toml",
              "injected": EXAMPLES / "column_collapse_injected.toml"}

H0 = 0.1
"""Column height [m]."""
ASPECT_RATIOS = (0.5, 1.0, 2.0)
"""a = H0 / L0 [-]."""
RUNOUT_ROOM = 0.5
"""Box length beyond the column: Lx = L0 + RUNOUT_ROOM [m]."""
LZ = 0.15
"""Box height [m]."""
DX_COARSE = 0.01
DX_FINE = 0.005
"""Cell sizes [m] (dx = dz)."""
FINE_ASPECT = 1.0
STOP_TIME = 2.0
"""Upper bound of the simulated time [s] (runs end at rest long before)."""
STOP_AT_REST = 0.1
"""Rest must hold this long [s]."""
FRONT_THRESHOLD = 5.0e-3
"""Deposit thickness defining the front [m] (docs/solver.md), the same at both resolutions."""
REACH_PHI = 1.0e-3
"""A cell with phi above this holds grains (for the east-wall check) [-]."""
SENSITIVITY_THRESHOLDS = (2.0e-3, 5.0e-3, 1.0e-2)
"""Deposit thicknesses [m] of the front-definition check (interpolated fronts, README)."""
WALL_MARGIN_CELLS = 2
"""The furthest grains must stay this many cells from the east wall."""
OUTPUT_INTERVAL = 0.02
"""[s]"""
G = 9.81
RHO_S = 2500.0
PHI_MAX = 0.6
GRAIN_D = 70e-6
"""Grain diameter [m] (the example files)."""
ETA_F = 1.8e-5
"""Air viscosity [Pa s] (the example files)."""
REFERENCE_B0 = 0.9
"""b0 of the rigid-column reference curve in basal_pressure.png."""
STATES = {
    "dry": ("dry", []),
    "b0.5_phi0.58": ("fluidised", ["setup.b0=0.5", "setup.phi0=0.58"]),
    "b0.9_phi0.58": ("fluidised", ["setup.b0=0.9", "setup.phi0=0.58"]),
    "b0.9_phi0.60": ("fluidised", ["setup.b0=0.9", "setup.phi0=0.6"]),
    "injection": ("injected", ["setup.U_prep_over_Umf=1.0"]),
    "b0.0_phi0.58": ("fluidised", ["setup.b0=0.0", "setup.phi0=0.58"]),
}
"""Initial state -> (base file, overrides)."""
MAIN_STATES = ("dry", "b0.5_phi0.58", "b0.9_phi0.58", "b0.9_phi0.60", "injection")
EXTRA_STATES_A1 = ("b0.0_phi0.58",)
"""Run at a = 1 and dx = 1 cm only."""
PROBE_TABLE_TIMES = (0.0, 0.1, 0.2, 0.3, 0.4, 0.6)
"""Times [s] of the probe table."""
FLUIDISED_STATES = tuple(s for s in STATES if s != "dry")
COLOURS = dict(zip(STATES, ("k", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:olive")))


def key(a: float, state: str, dx: float) -> str:
    return f"a{a:g}_{state}_dx{dx * 100:g}cm"


def plan() -> list[tuple[float, str, float]]:
    """Every run (a, state, dx), coarse first, the fine ones last."""
    runs = [(a, s, DX_COARSE) for a in ASPECT_RATIOS for s in MAIN_STATES]
    runs += [(FINE_ASPECT, s, DX_COARSE) for s in EXTRA_STATES_A1]
    runs += [(FINE_ASPECT, s, DX_FINE) for s in MAIN_STATES]
    return runs


def geometry(a: float, dx: float) -> dict:
    L0 = H0 / a
    Lx = L0 + RUNOUT_ROOM
    return {"L0": L0, "Lx": Lx, "nx": round(Lx / dx), "nz": round(LZ / dx),
            "probes_x": [L0 / 2, L0 + H0 / 2, L0 + 1.5 * H0]}


def overrides(a: float, state: str, dx: float) -> list[str]:
    geo = geometry(a, dx)
    base = [f"setup.H0={H0}", f"setup.L0={geo['L0']}", f"grid.Lx={geo['Lx']}", f"grid.Lz={LZ}",
            f"grid.nx={geo['nx']}", f"grid.nz={geo['nz']}", f"time.stop_time={STOP_TIME}",
            f"time.stop_at_rest={STOP_AT_REST}", f"output.interval={OUTPUT_INTERVAL}",
            f"output.front_threshold={FRONT_THRESHOLD}",
            "output.probes_x=[" + ", ".join(f"{x:.6g}" for x in geo["probes_x"]) + "]",
            "output.figures=false", "output.checkpoint_interval=100000"]
    return base + STATES[state][1]


QUICK_STATE, QUICK_STEPS = "b0.9_phi0.58", 20
"""The ``--quick`` smoke run: a = 1 at dx = 1 cm, this state, this many steps, temporary files."""


def run_one(a: float, state: str, dx: float, directory: Path | None = None, extra=()) -> dict:
    """One collapse; returns the numbers of results.json (module docstring). ``extra``: further
    ``--set`` overrides (the quick run's step limit)."""
    import xarray as xr

    cfg = load_case(BASE_FILES[STATES[state][0]], [*overrides(a, state, dx), *extra])
    directory = directory or RUN_DIR / key(a, state, dx)
    t0 = time.perf_counter()
    result = CaseRun(cfg, directory, overwrite=True).run()
    total_wall = time.perf_counter() - t0
    s = result.summary
    diag = s["case_diagnostics"]
    geo = geometry(a, dx)
    with xr.open_dataset(directory / "output.nc") as ds:
        t = ds["time"].values.astype(float)
        phi = ds["phi"].transpose("time", "x", "z").values  # by name: the file is (time, z, x)
        x = ds["x"].values
        dz = float(ds["z"].values[1] - ds["z"].values[0])
        reach = [float(x[np.flatnonzero(ph.max(axis=1) > REACH_PHI)[-1]] + dx / 2) for ph in phi]
        h_final = phi[-1].sum(axis=1) * dz / PHI_MAX
        probe_pf = ds["probe_p_f"].values.astype(float)
        probe_p = ds["probe_p"].values.astype(float)
        probe_x = ds["x_probe"].values.astype(float)
        x_front = ds["x_front"].values.astype(float)
    phi0 = diag["phi0"]  # injection: the bed before the injection (it stays at rest, docs/cases.md)
    p_lith0 = phi0 * RHO_S * G * (H0 - dz / 2)
    runout = s["runout_m"]
    return {
        "a": a, "state": state, "dx_m": dx, "nx": geo["nx"], "nz": geo["nz"], "L0_m": geo["L0"],
        "Lx_m": geo["Lx"], "phi0": diag["phi0"], "b0": diag["b0"], "status": s["status"],
        "stopped_at_rest": s["stopped_at_rest"], "t_rest_s": s["t_rest"], "t_final_s": s["t_final"],
        "steps": s["steps"], "rejected_steps": s["rejected_steps"],
        "wall_s": s["wall_s"], "prep_wall_s": diag.get("prep_wall_s", 0.0), "total_wall_s": total_wall,
        "runout_m": runout, "runout_over_L0": runout / geo["L0"] if runout is not None else None,
        "front_final_m": s["front_position"]["final_m"],
        "max_reach_m": max(reach), "east_wall_clear": max(reach) <= geo["Lx"] - WALL_MARGIN_CELLS * dx,
        "mass_rel_error": s["mass_rel_error"], "energy_residual_rel": s["energy_residual_rel"],
        "final_height_at_wall_m": s["final_height_at_wall"],
        "prep": {k: diag[k] for k in ("prep_time_s", "prep_steady", "prep_basal_pf_over_lithostatic",
                                      "prep_phi_mean", "U_mf_m_s") if k in diag},
        "t_s": t.tolist(), "x_front_m": x_front.tolist(), "h_final_m": h_final.tolist(),
        "x_m": x.tolist(), "probe_x_m": probe_x.tolist(), "p_lith0_Pa": p_lith0,
        "probe_p_f_Pa": probe_pf.tolist(), "probe_p_Pa": probe_p.tolist(),
    }


def run(resolution: float = DX_COARSE, quick: bool = False, a: float = FINE_ASPECT,
        state: str = QUICK_STATE) -> dict:
    """One collapse (:func:`run_one`) of ``state`` at aspect ``a`` on cells of ``resolution`` [m];
    ``quick``: :data:`QUICK_STEPS` steps into a temporary directory (nothing saved)."""
    if not quick:
        return run_one(a, state, resolution)
    with tempfile.TemporaryDirectory() as tmp:
        return run_one(a, state, resolution, Path(tmp), extra=[f"time.max_steps={QUICK_STEPS}"])


def load_results(path: Path = RESULTS) -> dict:
    return load_json(path, {"runs": {}})["runs"]


def save_results(runs: dict, path: Path = RESULTS) -> None:
    meta = {"description": __doc__.splitlines()[0], "front_threshold_m": FRONT_THRESHOLD,
            "H0_m": H0, "box": f"Lx = L0 + {RUNOUT_ROOM} m, Lz = {LZ} m",
            "total_wall_s": sum(r["total_wall_s"] for r in runs.values())}
    path.write_text(json.dumps({"meta": meta, "ratios": add_ratios(runs), "front_definition": sensitivity(runs),
                                "runs": runs}, indent=1,
                               allow_nan=False, default=float))


def add_ratios(runs: dict) -> dict:
    """Run-out ratio fluidised / dry at the same a and dx."""
    out = {}
    for k, r in runs.items():
        if r["state"] == "dry":
            continue
        dry = runs.get(key(r["a"], "dry", r["dx_m"]))
        if dry and dry["runout_m"] and r["runout_m"] is not None:
            out[k] = r["runout_m"] / dry["runout_m"]
    return out


def interpolated_front(r: dict, threshold: float) -> float:
    """x [m] where the final deposit thickness falls through ``threshold``, interpolated linearly
    between the cell centres on either side of the last column above it (a sub-cell front, so
    that ratios are not quantised by dx)."""
    h, x = np.asarray(r["h_final_m"], dtype=float), np.asarray(r["x_m"], dtype=float)
    edges = np.concatenate([x - 0.5 * r["dx_m"], x[-1:] + 0.5 * r["dx_m"]])
    return dg.front_from_thickness(edges, h, threshold, dg.FRONT_LINEAR)  # the one definition's sub-cell method


def sensitivity(runs: dict) -> dict:
    """Run-out / L0 and ratio to dry with interpolated fronts at each SENSITIVITY_THRESHOLDS."""
    out = {}
    for k, r in runs.items():
        dry = runs.get(key(r["a"], "dry", r["dx_m"]))
        row = {}
        for th in SENSITIVITY_THRESHOLDS:
            ro = (interpolated_front(r, th) - r["L0_m"]) / r["L0_m"]
            ro_dry = (interpolated_front(dry, th) - r["L0_m"]) / r["L0_m"] if dry else math.nan
            row[f"{th * 1000:g}mm"] = {"runout_over_L0": ro, "ratio": ro / ro_dry}
        out[k] = row
    return out


def sensitivity_table(runs: dict) -> str:
    sens = sensitivity(runs)
    cols = [f"{th * 1000:g}mm" for th in SENSITIVITY_THRESHOLDS]
    head = ("| a | state | dx [cm] | " + " | ".join(f"h > {c}: run-out, ratio" for c in cols) + " |\n"
            "|---:|---|---:|" + "---:|" * len(cols))
    lines = []
    for k, r in sorted(runs.items(), key=lambda kv: (kv[1]["dx_m"] < DX_COARSE, kv[1]["a"],
                                                      list(STATES).index(kv[1]["state"]))):
        vals = [f"{sens[k][c]['runout_over_L0']:.2f}, {sens[k][c]['ratio']:.2f}" for c in cols]
        lines.append(f"| {r['a']:g} | {r['state']} | {r['dx_m'] * 100:g} | " + " | ".join(vals) + " |")
    return "\n".join([head, *lines])


def fmt(v, spec: str) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


def table(runs: dict) -> str:
    ratios = add_ratios(runs)
    head = ("| a | state | dx [cm] | run-out (L_inf - L0)/L0 | ratio / dry | front [m] | t_rest [s] | "
            "t_final [s] | steps | wall [s] | east wall clear |\n"
            "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    rows = sorted(runs.items(), key=lambda kv: (kv[1]["dx_m"] < DX_COARSE, kv[1]["a"],
                                                 list(STATES).index(kv[1]["state"])))
    lines = []
    for k, r in rows:
        wall = r["wall_s"] + r["prep_wall_s"]
        lines.append(f"| {r['a']:g} | {r['state']} | {r['dx_m'] * 100:g} | {fmt(r['runout_over_L0'], '.2f')} | "
                     f"{fmt(ratios.get(k), '.2f')} | {fmt(r['front_final_m'], '.3f')} | "
                     f"{fmt(r['t_rest_s'], '.2f')} | {r['t_final_s']:.2f} | {r['steps']} | {wall:.0f} | "
                     f"{'yes' if r['east_wall_clear'] else 'NO'} ({r['max_reach_m']:.2f}/{r['Lx_m']:.2f}) |")
    return "\n".join([head, *lines])


def probe_table(runs: dict) -> str:
    """Basal p_f / p_lith0 at a = 1, dx = 1 cm, at a few times, for each probe."""
    times = PROBE_TABLE_TIMES
    head = ("| state | probe x [m] | " + " | ".join(f"t = {t:g} s" for t in times) + " | max (t) | min (t) |\n"
            "|---|---:|" + "---:|" * (len(times) + 2))
    lines = []
    for s in FLUIDISED_STATES:
        r = runs.get(key(FINE_ASPECT, s, DX_COARSE))
        if r is None:
            continue
        t = np.asarray(r["t_s"])
        pf = np.asarray(r["probe_p_f_Pa"]) / r["p_lith0_Pa"]
        for j, xp in enumerate(r["probe_x_m"]):
            vals = [fmt(float(np.interp(tt, t, pf[:, j])) if tt <= t[-1] else None, ".2f") for tt in times]
            i, m = int(np.argmax(pf[:, j])), int(np.argmin(pf[:, j]))
            lines.append(f"| {s} | {xp:.3f} | " + " | ".join(vals) + f" | {pf[i, j]:.2f} ({t[i]:.2f}) | "
                         f"{pf[m, j]:.2f} ({t[m]:.2f}) |")
    return "\n".join([head, *lines])


def rigid_column_pf(t, b0: float, phi: float, dz: float) -> np.ndarray:
    """p_f / p_lith0 at z = dz/2 of a static rigid 10 cm column at packing phi that starts at b0 x
    lithostatic and drains through its top: the Fourier series of granflow.verification.defluidisation
    (validation/defluidisation), diffusivity c = p_atm kappa(phi) / (1 - phi) (Carman-Kozeny)."""
    from granflow import Material
    from granflow.verification import defluidisation as dfl

    mat = Material(d=GRAIN_D, rho_s=RHO_S, phi_max=PHI_MAX, eta_f=ETA_F)
    c = mat.p_atm * float(mat.permeability(phi)) / (1.0 - phi)
    z = dz / 2
    return b0 * np.array([float(dfl.pressure(z, tt, H0, c)) for tt in t]) / ((H0 - z) / H0)


def figures(runs: dict) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ratios = add_ratios(runs)
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.4))
    for s in MAIN_STATES:
        rs = [runs[key(a, s, DX_COARSE)] for a in ASPECT_RATIOS if key(a, s, DX_COARSE) in runs]
        line, = ax[0].plot([r["a"] for r in rs], [r["runout_over_L0"] for r in rs], "o-", color=COLOURS[s],
                           label=s)
        fine = runs.get(key(FINE_ASPECT, s, DX_FINE))
        if fine:
            ax[0].plot([FINE_ASPECT], [fine["runout_over_L0"]], "s", mfc="none", ms=9, color=line.get_color())
        if s != "dry":
            ax[1].plot([r["a"] for r in rs], [ratios.get(key(r["a"], s, DX_COARSE)) for r in rs], "o-",
                       color=line.get_color(), label=s)
            if fine:
                ax[1].plot([FINE_ASPECT], [ratios.get(key(FINE_ASPECT, s, DX_FINE))], "s", mfc="none",
                           ms=9, color=line.get_color())
    ax[0].set(xlabel="a = H0/L0", ylabel="(L_inf - L0)/L0", title="run-out (dots 1 cm, squares 0.5 cm)")
    ax[0].legend(fontsize=8)
    ax[1].axhspan(1.8, 2.2, color="0.85", label="Roche 2012: ~2")
    ax[1].set(xlabel="a = H0/L0", ylabel="run-out fluidised / dry", title="ratio to the dry run-out")
    ax[1].legend(fontsize=8)
    for s in (*MAIN_STATES, *EXTRA_STATES_A1):
        for dx, style in ((DX_COARSE, "-"), (DX_FINE, ":")):
            r = runs.get(key(FINE_ASPECT, s, dx))
            if r:
                ax[2].plot(r["x_m"], r["h_final_m"], style, color=COLOURS[s], label=f"{s}, {dx * 100:g} cm")
    ax[2].set(xlabel="x [m]", ylabel="deposit thickness [m]", title="final deposits, a = 1", xlim=(0, 0.6))
    ax[2].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(FIG_RUNOUT, dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2), sharey=True)
    for s in FLUIDISED_STATES:
        for dx, style in ((DX_COARSE, "-"), (DX_FINE, ":")):
            r = runs.get(key(FINE_ASPECT, s, dx))
            if not r:
                continue
            pf = np.asarray(r["probe_p_f_Pa"]) / r["p_lith0_Pa"]
            for j, xp in enumerate(r["probe_x_m"]):
                ax[j].plot(r["t_s"], pf[:, j], style, color=COLOURS[s], label=f"{s}, {dx * 100:g} cm")
                ax[j].set(title=f"basal p_f, x = {xp:.3f} m (a = 1, L0 = 0.1 m)", xlabel="t [s]")
    for a_ in ax:
        a_.axhline(0.0, color="0.6", lw=0.8)
        a_.set_xlim(0.0, 0.7)
    t_ref = np.linspace(0.0, 0.7, 281)
    ax[0].plot(t_ref, rigid_column_pf(t_ref, REFERENCE_B0, PHI_MAX, DX_COARSE), "k--", lw=1,
               label=f"static rigid column, b0 = {REFERENCE_B0}, phi = {PHI_MAX} (series)")
    ax[0].set(ylabel="p_f / p_lith0 (bottom cell)")
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(FIG_PRESSURE, dpi=110)
    plt.close(fig)
    return [FIG_RUNOUT, FIG_PRESSURE]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke test: a = {FINE_ASPECT:g}, {QUICK_STATE}, dx = {DX_COARSE} m, "
                        f"{QUICK_STEPS} steps, temporary files")
    parser.add_argument("--resume", action="store_true", help="skip runs already in results.json")
    parser.add_argument("--only", nargs="*", default=None, help="run only these keys")
    parser.add_argument("--figures-only", action="store_true")
    args = parser.parse_args(argv)
    if args.quick:
        r = run(DX_COARSE, quick=True)
        print(f"quick: {r['status']}, {r['steps']} steps, reach {r['max_reach_m']:.3f} m")
        return
    runs = load_results() if (args.resume or args.figures_only or args.only) else {}
    if not args.figures_only:
        for a, s, dx in plan():
            k = key(a, s, dx)
            if (args.only is not None and k not in args.only) or (args.resume and k in runs):
                continue
            r = run_one(a, s, dx)
            runs[k] = r
            save_results(runs)
            print(f"{k}: run-out/L0 {fmt(r['runout_over_L0'], '.3f')}, t_rest {fmt(r['t_rest_s'], '.2f')}, "
                  f"{r['status']}, reach {r['max_reach_m']:.3f}/{r['Lx_m']:.2f} m, "
                  f"wall {r['total_wall_s']:.0f} s", flush=True)
    if runs:
        save_results(runs)
    print(table(runs))
    print()
    print(sensitivity_table(runs))
    print()
    print(probe_table(runs))
    print("figures:", *figures(runs))


if __name__ == "__main__":
    main()
