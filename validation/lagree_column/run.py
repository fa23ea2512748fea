"""Lagree-Staron-Popinet column collapse: deposit profiles, run-out against aspect ratio, mesh
convergence (issue 4, item 3).

Case ``lagree_column`` (docs/cases.md; Lagree, Staron & Popinet 2011, J. Fluid Mech. 686, 378-408),
dimensionless units H0 = g = rho = 1 (time sqrt(H0/g)): a half column ``[0, 1/a] x [0, 1]`` at
phi_max = 0.6 against a free-slip (symmetry) west wall, no-slip base, mu_s = 0.32,
Delta mu = 0.28, I0 = 0.4 (c_I = 2), d = 1/40, dt_max = 0.01, CFL 0.3, both models of the case:
``incompressible`` (granflow's incompressible mu(I) reference, the model of Lagree et al.) and
``mu_i`` (the paper's mu(I) closure with its dilatancy law, Chupin & Dubois §6.2).

Grids. Level ``n`` has square cells dx = dz = 5/n (the paper's n x n grid of the 5 x 5 box), but
the box is cut at ``Lz = 1.25`` (n x n/4 cells): the column (height 1) only falls, and the light,
pressureless ambient above it carries nothing (``--box-check`` runs the full 5 x 5 box for
comparison; README). Levels 32, 64, 128.

Run-out. Deposit thickness h(x) = sum_z phi dz / phi_max. Fronts (:data:`FRONTS`): ``thr0.05`` /
``thr0.1``, where the piecewise-linear interpolant of h through the cell centres falls below 0.05 H0
(the examples' ``output.front_threshold``) / 0.1 H0; ``toe``, where the straight line fitted to the
deposit's toe (h from 0.15 down to 0.05 H0) reaches h = 0 (where the deposit ends). A level is used
for a front only if the creeping one-cell tongue, h = (phi_c/phi_max) dz, is thinner than the
smallest h the front reads (README). L_inf is the front at the end of the run, which stops once the
rms granular speed has stayed below 0.01 sqrt(g H0) (``output.rest_speed``) for one time unit
(``time.stop_at_rest``) or at t = 8. Normalised run-out (L_inf - L0)/L0, L0 = 1/a.
Published planar scalings (docs/model.md §7): lambda1 a for a <~ 3 (lambda1 = 1.2-2.2), lambda2 a^(2/3)
above (lambda2 = 1.9-3.9); Lube et al. 2005, Lajeunesse et al. 2005; Balmforth & Kerswell 2005
exponent 0.9 +- 0.1.

Mesh convergence: Richardson extrapolation of the three levels (observed order from the three
values; GCI with safety factor 1.25, Roache 1998), or, when the three values do not converge
monotonically or with only two levels, the scheme's formal first order with safety factor 3
(labelled "2-level" / "1st-order fallback").

Run:   python validation/lagree_column/run.py [--levels 32,64] [--aspects 0.5,1.42] [--models mu_i]
       [--fine-aspects 1.42] [--box-check 32] [--plot-only] [--quick]
Time:  32: ~10 s per run; 64: ~15-45 s; 128: ~1-3.5 min (2-core machine under load). Every run is
       saved (results.json, data/<tag>.npz) and skipped when already there (``--force`` redoes);
       ``--plot-only`` re-analyses and re-plots from the saved data in seconds.
       ``--quick``: a = 1.42 at n = 16 for 20 steps into a temporary directory (smoke test).
"""
from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import netCDF4
import numpy as np

from granflow import diagnostics as dg
from granflow.casekit.runner import CaseRun
from granflow.config import CaseConfig
from granflow.output import ordered
from granflow.verification.convergence import richardson
from granflow.verification.scripts import load_json, save_json

HERE = Path(__file__).resolve().parent
PRE_V2_SETUP = {"d": 1.0 / 40.0}
PRE_V2_AMBIENT = {"rho_a": 1.0e-2, "eta_a": 1.0e-3}
"""The case as this study ran it (before scheme v2 the case's defaults were d = 1/40 and this
ambient; they are now Basilisk's, validation/basilisk_column): pinned so that results.json stays
reproducible."""
ROOT = HERE.parents[1]
RESULTS = HERE / "results.json"
DATA = HERE / "data"
WORKDIR = ROOT / "runs" / "validation_lagree_column"
FIG_PROFILES, FIG_RUNOUT, FIG_CONVERGENCE = (HERE / "profiles.png", HERE / "runout.png",
                                              HERE / "convergence.png")
CASE = "lagree_column"
PAPER_BOX = 5.0
"""Side of the paper's square box [H0]; the paper's n x n grid has cells 5/n."""
REDUCED_LZ = 1.25
"""Height of the cut box [H0] (n/4 cells of 5/n)."""
PHI_MAX = 0.6
"""The case's packing (setup.phi_max default) [-]."""
PHI_C = 0.3
"""numerics.ambient.phi_c default: cells below it are the ambient [-]."""
ASPECTS = (0.5, 1.42, 3.0, 6.26, 10.0)
MODELS = ("incompressible", "mu_i")
LEVELS = (32, 64, 128)
DT_MAX = 0.01
STOP_TIME = 8.0
STOP_AT_REST = 1.0
"""Hold time at rest before the run ends [sqrt(H0/g)]."""
REST_SPEED = 0.01
"""rms granular speed of rest [sqrt(g H0)] (docs/cases.md, lagree_column)."""
OUTPUT_INTERVAL = 0.25
FIELD_TIMES = (0.5, 1.0, 2.0)
"""Times whose full fields (phi, u, w, p, |S|) are kept for a = 1.42 (validation/well_posedness)."""
FIELD_ASPECT = 1.42
PROFILE_TIMES = (1.0, 2.0, 4.0)
THRESHOLDS = (0.05, 0.1)
"""Deposit thicknesses defining a threshold front [H0] (0.05: the examples' output.front_threshold)."""
TOE_WINDOW = (0.05, 0.15)
"""Deposit thicknesses [H0] of the toe whose straight-line fit, extrapolated to h = 0, gives the
"toe" front (where the deposit ends)."""
FRONTS = {"toe": TOE_WINDOW[0], **{f"thr{t:g}": t for t in THRESHOLDS}}
"""Front definitions -> smallest deposit thickness they read [H0] (for the tongue rule)."""
PRIMARY_FRONT = "toe"
LAMBDA1_BAND = (1.2, 2.2)
LAMBDA2_BAND = (1.9, 3.9)
TRANSITION_A = 3.0
"""Aspect ratio separating the linear and the a^(2/3) regimes (Lajeunesse et al. 2005)."""
BK_EXPONENT = (0.9, 0.1)
"""Balmforth & Kerswell (2005): exponent 0.9 +- 0.1."""
QUICK_LEVEL, QUICK_STEPS = 16, 20


# --- runs ----------------------------------------------------------------------------------------
def tag(a: float, model: str, n: int, box: str = "reduced") -> str:
    return f"a{a:g}_{model}_n{n}_{box}"


def case_config(a: float, model: str, n: int, box: str = "reduced", stop_time: float = STOP_TIME,
                max_steps: int | None = None) -> CaseConfig:
    """The ``lagree_column`` config of one run (level ``n``: cells 5/n; ``box`` "reduced" cuts
    the box at :data:`REDUCED_LZ`, "paper" keeps 5 x 5)."""
    lz = REDUCED_LZ if box == "reduced" else PAPER_BOX
    nz = round(n * lz / PAPER_BOX)
    time_s = {"stop_time": stop_time, "dt_max": DT_MAX, "stop_at_rest": STOP_AT_REST}
    if max_steps is not None:
        time_s["max_steps"] = max_steps
    return CaseConfig.from_dict({
        "case": {"name": CASE}, "setup": {"a": a, "model": model, "Lx": PAPER_BOX, "Lz": lz, **PRE_V2_SETUP},
        "grid": {"nx": n, "nz": nz}, "time": time_s, "numerics": {"ambient": dict(PRE_V2_AMBIENT)},
        "output": {"interval": OUTPUT_INTERVAL, "front_threshold": THRESHOLDS[0],
                   "rest_speed": REST_SPEED, "figures": False,
                   "fields": ["phi", "u", "w", "p", "S"]}})


def linear_front(x, h, threshold: float) -> float:
    """Sub-cell front [H0]: granflow.diagnostics.front_from_thickness(method="linear") -- where the
    piecewise-linear interpolant of h(x) (cell centres ``x``, uniform) falls through
    ``threshold`` after the last column above it; nan if h never exceeds it; the right edge of the
    box if the last column is above it. The front itself (summary.json, ``x_f_cell_edge``) is the
    same function's ``"edge"`` method."""
    x = np.asarray(x, dtype=float)
    dx = x[1] - x[0]
    edges = np.concatenate([x - 0.5 * dx, x[-1:] + 0.5 * dx])
    return dg.front_from_thickness(edges, np.asarray(h, dtype=float), threshold, dg.FRONT_LINEAR)


def toe_front(x, h, window=TOE_WINDOW) -> float:
    """x where the straight line fitted to the toe of h(x) reaches h = 0 [H0]:
    :func:`granflow.diagnostics.toe_front` with the toe between :data:`TOE_WINDOW` H0."""
    return dg.toe_front(x, h, window)


def front_of(arrays: dict, key: str, k: int = -1) -> float:
    """Front ``key`` (of :data:`FRONTS`) of record ``k`` [H0]."""
    h = arrays["h"][k].astype(float)
    return toe_front(arrays["x"], h) if key == "toe" else linear_front(arrays["x"], h, FRONTS[key])


def extract(run_dir: Path, keep_fields: bool) -> dict:
    """Arrays of a finished run from its output.nc: t, x, z, h(t, x), kinetic energy, and the
    fields at :data:`FIELD_TIMES` (those reached; the last record for a shorter run) if
    ``keep_fields`` (float32)."""
    with netCDF4.Dataset(run_dir / "output.nc") as ds:
        t = np.asarray(ds["time"][:], dtype=float)
        x, z = np.asarray(ds["x"][:], dtype=float), np.asarray(ds["z"][:], dtype=float)
        phi = ordered(ds["phi"]).astype(float)  # (time, x, z), whatever the order in the file
        out = {"t": t, "x": x, "z": z, "ke": np.asarray(ds["kinetic_energy"][:], dtype=float),
               "h": (phi.sum(axis=2) * (z[1] - z[0]) / PHI_MAX).astype(np.float32)}
        if keep_fields:
            wanted = [tf for tf in FIELD_TIMES if tf <= t[-1] + 1e-9] or [t[-1]]  # short run: its end
            idx = [int(np.argmin(np.abs(t - tf))) for tf in wanted]
            out["field_t"] = t[idx]
            for name in ("phi", "u", "w", "p", "S"):
                out[name] = ordered(ds[name])[idx].astype(np.float32)  # (time, x, z)
    return out


def value_at(t, values, t0: float) -> float | None:
    k = int(np.argmin(np.abs(np.asarray(t) - t0)))
    return float(values[k]) if abs(t[k] - t0) < 1e-6 else None


def record(a: float, model: str, n: int, box: str, summary: dict, arrays: dict, cpu_s: float) -> dict:
    """The results.json entry of one run."""
    rec = {"a": a, "model": model, "n": n, "box": box, "nx": summary["resolution"]["nx"],
           "nz": summary["resolution"]["nz"], "dx": summary["resolution"]["dx_m"],
           "steps": summary["steps"], "wall_s": summary["wall_s"], "cpu_s": cpu_s,
           "status": summary["status"], "message": summary["message"][:200],
           "t_final": summary["t_final"], "t_rest": summary["t_rest"],
           "stopped_at_rest": summary["stopped_at_rest"],
           "x_f_cell_edge": summary["case_diagnostics"]["runout"]["x_f"],
           "final_height_at_wall": summary["final_height_at_wall"],
           "mass_rel_error": summary["mass_rel_error"], "clipped_mass": summary["clipped_mass"],
           "energy_residual_rel": summary["energy_residual_rel"],
           "picard_not_converged_steps": summary["picard"]["not_converged_steps"],
           "ke_peak": float(arrays["ke"].max()), "ke_final_over_peak":
               float(arrays["ke"][-1] / arrays["ke"].max()) if arrays["ke"].max() > 0 else None}
    rec.update(front_records(arrays, a))
    return rec


def front_records(arrays: dict, a: float) -> dict:
    """Per front definition: final x_f, (x_f - L0)/L0, drift over the last time unit, x_f at
    :data:`PROFILE_TIMES`."""
    t, L0, out = arrays["t"], 1.0 / a, {}
    earlier = t <= t[-1] - 1.0 + 1e-9
    for key in FRONTS:
        xf = np.array([front_of(arrays, key, k) for k in range(t.size)])
        out[key] = {"x_f": float(xf[-1]), "relative": float((xf[-1] - L0) / L0),
                    "drift_last_unit": float(xf[-1] - xf[earlier][-1]) if earlier.any() else None,
                    "front_at": {f"{tp:g}": value_at(t, xf, tp) for tp in PROFILE_TIMES}}
    return out


def load_results(path: Path = RESULTS) -> dict:
    return load_json(path, {"runs": {}})


def save_results(results: dict, path: Path = RESULTS) -> None:
    save_json(results, path)


def run_one(a: float, model: str, n: int, box: str = "reduced", workdir: Path = WORKDIR,
            datadir: Path = DATA, stop_time: float = STOP_TIME, max_steps: int | None = None,
            keep_fields: bool | None = None) -> dict:
    """Run one configuration through :class:`CaseRun` (output in ``workdir/<tag>``), save its
    arrays to ``datadir/<tag>.npz`` and return its record."""
    name = tag(a, model, n, box)
    keep = (a == FIELD_ASPECT) if keep_fields is None else keep_fields
    cfg = case_config(a, model, n, box, stop_time, max_steps)
    cpu0 = time.process_time()
    result = CaseRun(cfg, workdir / name, overwrite=True).run()
    cpu = time.process_time() - cpu0
    arrays = extract(workdir / name, keep)
    datadir.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(datadir / f"{name}.npz", **arrays)
    rec = record(a, model, n, box, result.summary, arrays, cpu)
    print(f"{name}: {rec['status']}, t_final {rec['t_final']:.2f}, t_rest {rec['t_rest']}, steps "
          f"{rec['steps']}, wall {rec['wall_s']:.0f} s, x_f(0.05) {rec['thr0.05']['x_f']:.3f}, "
          f"rel {rec['thr0.05']['relative']:.3f}", flush=True)
    return rec


def run(resolution: int = QUICK_LEVEL, quick: bool = False, a: float = FIELD_ASPECT,
        model: str = MODELS[0]) -> dict:
    """One level (:func:`run_one`, cells 5/``resolution``) of aspect ``a``, to rest; ``quick``:
    :data:`QUICK_STEPS` steps into a temporary directory (nothing saved)."""
    if quick:
        with tempfile.TemporaryDirectory() as tmp:
            return run_one(a, model, resolution, workdir=Path(tmp), datadir=Path(tmp), max_steps=QUICK_STEPS)
    return run_one(a, model, resolution)


def load_arrays(name: str, datadir: Path = DATA) -> dict:
    with np.load(datadir / f"{name}.npz") as f:
        return {k: f[k] for k in f.files}


# --- analysis ------------------------------------------------------------------------------------
def power_fit(a, y, sigma=None) -> dict:
    """Least-squares fit of log y = log k + b log a; returns exponent b, prefactor k and the
    standard error of b (from the scatter of the residuals, numpy.polyfit ``cov=True``); with
    ``sigma`` (uncertainties of y) the points are weighted by y/sigma, the inverse uncertainty of
    log y."""
    la, ly = np.log(np.asarray(a, float)), np.log(np.asarray(y, float))
    w = None if sigma is None else np.asarray(y, float) / np.maximum(np.asarray(sigma, float), 1e-12)
    if la.size < 2:
        return {"exponent": math.nan, "prefactor": math.nan, "stderr": math.nan, "n": int(la.size)}
    coef, cov = np.polyfit(la, ly, 1, w=w, cov=True) if la.size > 2 else (np.polyfit(la, ly, 1, w=w), None)
    se = float(math.sqrt(cov[0, 0])) if cov is not None else math.nan
    return {"exponent": float(coef[0]), "prefactor": float(math.exp(coef[1])), "stderr": se,
            "n": int(la.size)}


def tongue_thickness(n: int) -> float:
    """Deposit thickness of a one-cell layer at phi_c, (phi_c/phi_max) dz [H0]: the thin tongue
    that creeps ahead of the deposit (README); a level is used for a front threshold only if its
    tongue is thinner than the threshold."""
    return PHI_C / PHI_MAX * PAPER_BOX / n


def analyse(results: dict, key: str = PRIMARY_FRONT) -> dict:
    """Per (a, model): relative run-out per level, the extrapolated value, lambda1, lambda2; and
    the power-law fits of the extrapolated relative run-out against a, for the front ``key`` of
    :data:`FRONTS`. Levels whose :func:`tongue_thickness` reaches the smallest deposit thickness
    the front reads are left out (listed in ``excluded``)."""
    done = [r for r in results["runs"].values() if r["box"] == "reduced" and r["status"] == "completed"]
    runs = [r for r in done if tongue_thickness(r["n"]) < FRONTS[key]]
    table = []
    for a in sorted({r["a"] for r in runs}):
        for model in MODELS:
            rs = sorted((r for r in runs if r["a"] == a and r["model"] == model), key=lambda r: r["n"])
            if not rs:
                continue
            rel = [r[key]["relative"] for r in rs]
            est = richardson(rel)
            excluded = {r["n"]: r[key]["relative"] for r in done
                        if r["a"] == a and r["model"] == model and r not in rs}
            table.append({"a": a, "model": model, "levels": [r["n"] for r in rs], "relative": rel,
                          "excluded": excluded,
                          "x_f": [r[key]["x_f"] for r in rs], "wall_s": [r["wall_s"] for r in rs],
                          "t_rest": [r["t_rest"] for r in rs], "t_final": [r["t_final"] for r in rs],
                          "drift": [r[key]["drift_last_unit"] for r in rs], "estimate": est,
                          "lambda1": est["value"] / a, "lambda2": est["value"] / a ** (2 / 3)})
    fits = {}
    for model in MODELS:
        rows = [r for r in table if r["model"] == model]
        for name, sel in (("all", rows), ("a<=3", [r for r in rows if r["a"] <= TRANSITION_A]),
                          ("a>=3", [r for r in rows if r["a"] >= TRANSITION_A])):
            if len(sel) >= 2:
                fits[f"{model}:{name}"] = power_fit([r["a"] for r in sel],
                                                    [r["estimate"]["value"] for r in sel])
                fits[f"{model}:{name}:weighted"] = power_fit(
                    [r["a"] for r in sel], [r["estimate"]["value"] for r in sel],
                    [r["estimate"]["uncertainty"] for r in sel])
                finest = power_fit([r["a"] for r in sel], [r["relative"][-1] for r in sel])
                fits[f"{model}:{name}:finest_level"] = finest
    return {"front": key, "table": table, "fits": fits}


def markdown(analysis: dict) -> str:
    """The README tables of one threshold."""
    lines = [f"front: {analysis['front']}", "",
             ("| a | model | levels | (L_inf - L0)/L0 per level | t_rest per level | wall s per level | "
              "estimate | +- | method (order) | lambda1 = est/a | lambda2 = est/a^(2/3) | excluded levels |"),
             "|---:|---|---|---|---|---|---:|---:|---|---:|---:|---|"]

    def fmt(xs, f: str) -> str:
        return ", ".join("-" if v is None else format(v, f) for v in xs)
    for r in analysis["table"]:
        e = r["estimate"]
        order = "" if e["order"] is None else f" ({e['order']:.2f})"
        lines.append(f"| {r['a']:g} | {r['model']} | {fmt(r['levels'], 'd')} | {fmt(r['relative'], '.3f')} | "
                     f"{fmt(r['t_rest'], '.2f')} | {fmt(r['wall_s'], '.0f')} | {e['value']:.3f} | "
                     f"{e['uncertainty']:.3f} | {e['method']}{order} | {r['lambda1']:.2f} | {r['lambda2']:.2f} | "
                     + ", ".join(f"{n}: {v:.3f}" for n, v in r["excluded"].items()) + " |")
    lines += ["", "| model | a range | fitted exponent | +- (std. error) | prefactor | points |",
              "|---|---|---:|---:|---:|---:|"]
    for k, f in analysis["fits"].items():
        lines.append(f"| {k.split(':')[0]} | {':'.join(k.split(':')[1:])} | {f['exponent']:.3f} | "
                     f"{f['stderr']:.3f} | {f['prefactor']:.3f} | {f['n']} |")
    return "\n".join(lines)


def box_table(results: dict) -> str:
    """The paper's 5 x 5 box against the reduced box, same level (``--box-check``)."""
    runs = results["runs"]
    lines = [("| a | model | n | box | x_f(0.05) at t = 1, 2, 4 | final x_f(0.05) | t_final | t_rest | "
              "peak KE | wall s |"), "|---:|---|---:|---|---|---:|---:|---:|---:|---:|"]
    for r in sorted(runs.values(), key=lambda r: (r["a"], r["model"], r["n"], r["box"])):
        if not any(o["box"] == "paper" and (o["a"], o["model"], o["n"]) == (r["a"], r["model"], r["n"])
                   for o in runs.values()):
            continue
        fa = ", ".join("-" if v is None else f"{v:.3f}" for v in r["thr0.05"]["front_at"].values())
        lines.append(f"| {r['a']:g} | {r['model']} | {r['n']} | {r['box']} | {fa} | {r['thr0.05']['x_f']:.3f} | "
                     f"{r['t_final']:.2f} | {'-' if r['t_rest'] is None else format(r['t_rest'], '.2f')} | "
                     f"{r['ke_peak']:.5f} | {r['wall_s']:.0f} |")
    return "\n".join(lines)


# --- figures -------------------------------------------------------------------------------------
def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def figure_profiles(results: dict, levels=None, a: float = FIELD_ASPECT, datadir: Path = DATA,
                    path: Path = FIG_PROFILES) -> Path:
    """h(x) at t = 1, 2, 4 and at the end of the run (the deposit, L_inf) for both models at two
    levels (default: the two finest run)."""
    plt = _plt()
    if levels is None:
        ran = sorted({r["n"] for r in results["runs"].values() if r["a"] == a and r["box"] == "reduced"})
        levels = tuple(ran[-2:]) or LEVELS[-2:]
    times = (*PROFILE_TIMES, None)
    fig, axes = plt.subplots(len(MODELS), len(times), figsize=(16, 6), sharex=True, sharey=True)
    styles = {levels[0]: {"ls": "--", "lw": 1.2}, levels[-1]: {"ls": "-", "lw": 1.6}}
    for i, model in enumerate(MODELS):
        for j, tp in enumerate(times):
            ax = axes[i, j]
            ax.plot([0, 1 / a, 1 / a], [1, 1, 0], color="0.6", lw=0.8, label="t = 0")
            for n in levels:
                name = tag(a, model, n)
                if name not in results["runs"]:
                    continue
                arr = load_arrays(name, datadir)
                k = len(arr["t"]) - 1 if tp is None else int(np.argmin(np.abs(arr["t"] - tp)))
                if tp is not None and abs(arr["t"][k] - tp) > 1e-6:
                    continue
                when = "" if tp is not None else f", t = {arr['t'][k]:.2f}"
                ax.plot(arr["x"], arr["h"][k], color="C0" if model == MODELS[0] else "C3",
                        label=f"{n}² (dx = {PAPER_BOX / n:.3f}){when}", **styles.get(n, {}))
                ls = styles.get(n, {}).get("ls", "-")
                ax.axvline(front_of(arr, "thr0.05", k), color="k", lw=0.6, ls=ls)
                ax.axvline(front_of(arr, "toe", k), color="g", lw=0.6, ls=ls)
            ax.axhline(THRESHOLDS[0], color="0.7", lw=0.6, ls=":")
            ax.set_title(f"{model}, " + (f"t = {tp:g}" if tp is not None else "end of run (at rest)"),
                         fontsize=10)
            ax.set_xlim(0, 3.2)
            if i == len(MODELS) - 1:
                ax.set_xlabel("x / H0")
            if j == 0:
                ax.set_ylabel("deposit h / H0")
            ax.legend(fontsize=7)
    fig.suptitle(f"Lagree column a = {a:g}: deposit thickness (vertical lines: front at h = "
                 f"{THRESHOLDS[0]:g} H0, black; toe extrapolated to h = 0, green)", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def figure_runout(analysis: dict, others=(), path: Path = FIG_RUNOUT) -> Path:
    """(L_inf - L0)/L0 against a with the published planar bands and the fits; the extrapolated
    values of the ``others`` analyses (other front definitions) as small markers."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 5.2))
    lo = np.linspace(0.3, TRANSITION_A, 50)
    hi = np.linspace(TRANSITION_A, 14, 50)
    ax.fill_between(lo, LAMBDA1_BAND[0] * lo, LAMBDA1_BAND[1] * lo, color="0.85",
                    label=f"lambda1 a, lambda1 = {LAMBDA1_BAND[0]}-{LAMBDA1_BAND[1]}")
    ax.fill_between(hi, LAMBDA2_BAND[0] * hi ** (2 / 3), LAMBDA2_BAND[1] * hi ** (2 / 3), color="0.7",
                    alpha=0.6, label=f"lambda2 a^(2/3), lambda2 = {LAMBDA2_BAND[0]}-{LAMBDA2_BAND[1]}")
    for c, model, mk in (("C0", MODELS[0], "o"), ("C3", MODELS[1], "s")):
        rows = [r for r in analysis["table"] if r["model"] == model]
        if not rows:
            continue
        a = np.array([r["a"] for r in rows]) * (1.0 if c == "C0" else 1.04)
        est = np.array([r["estimate"]["value"] for r in rows])
        err = np.array([r["estimate"]["uncertainty"] for r in rows])
        ax.errorbar(a, est, yerr=err, fmt=mk, color=c, capsize=3, label=f"{model}: extrapolated")
        ax.plot(a, [r["relative"][-1] for r in rows], mk, mfc="none", color=c, ms=9,
                label=f"{model}: finest level")
        f = analysis["fits"].get(f"{model}:all")
        if f:
            aa = np.linspace(0.4, 12, 50)
            ax.plot(aa, f["prefactor"] * aa ** f["exponent"], color=c, lw=0.8,
                    label=f"fit {f['prefactor']:.2f} a^{f['exponent']:.2f}")
    for k, other in enumerate(others):
        rows = [r for r in other["table"] if r["model"] == MODELS[0]]
        ax.plot([r["a"] for r in rows], [r["estimate"]["value"] for r in rows], "x^"[k % 2], color="0.3",
                ms=5, label=f"{MODELS[0]}, front {other['front']}: extrapolated")
    ax.set(xscale="log", yscale="log", xlabel="a = H0 / L0", ylabel="(L_inf - L0) / L0",
           title=f"run-out (front: {analysis['front']})")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def figure_convergence(results: dict, analysis: dict, datadir: Path = DATA,
                       path: Path = FIG_CONVERGENCE) -> Path:
    """Relative run-out against dx with the extrapolated value at dx = 0; front and kinetic
    energy histories of a = 1.42."""
    plt = _plt()
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.4))
    for k, r in enumerate(analysis["table"]):
        c = f"C{k % 10}"
        dx = [PAPER_BOX / n for n in r["levels"]]
        ax[0].plot(dx, r["relative"], "o-" if r["model"] == MODELS[0] else "s--", color=c,
                   label=f"a = {r['a']:g}, {r['model']}")
        e = r["estimate"]
        ax[0].errorbar([0.0], [e["value"]], yerr=[e["uncertainty"]], fmt="o" if r["model"] == MODELS[0]
                       else "s", mfc="none", color=c, capsize=3)
    ax[0].set(xlabel="dx / H0", ylabel="(L_inf - L0) / L0", yscale="log", xlim=(-0.01, 0.17),
              title="run-out against dx (open: extrapolated)")
    ax[0].legend(fontsize=6, ncol=2)
    for model, ls in zip(MODELS, ("-", "--")):
        for j, n in enumerate(LEVELS):
            name = tag(FIELD_ASPECT, model, n)
            if name not in results["runs"]:
                continue
            arr = load_arrays(name, datadir)
            xf = [front_of(arr, "thr0.05", k) for k in range(arr["t"].size)]
            ax[1].plot(arr["t"], xf, ls, color=f"C{j}", label=f"{model} {n}²")
            ax[2].semilogy(arr["t"], arr["ke"] / arr["ke"].max(), ls, color=f"C{j}", label=f"{model} {n}²")
    ax[1].set(xlabel="t / sqrt(H0/g)", ylabel="x_f / H0", title=f"front (h = {THRESHOLDS[0]:g}), a = 1.42")
    ax[2].set(xlabel="t / sqrt(H0/g)", ylabel="E_k / max E_k", title="kinetic energy, a = 1.42")
    ax[1].legend(fontsize=7)
    ax[2].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# --- driver --------------------------------------------------------------------------------------
def _floats(text: str) -> tuple[float, ...]:
    return tuple(float(v) for v in text.split(",") if v)


def _ints(text: str) -> tuple[int, ...]:
    return tuple(int(v) for v in text.split(",") if v)


def report(results: dict) -> None:
    """Analyse, print the tables, draw the figures, store the analysis in results.json."""
    for name, r in results["runs"].items():  # records made before a front definition existed
        if any(key not in r for key in FRONTS) and (DATA / f"{name}.npz").exists():
            r.update(front_records(load_arrays(name), r["a"]))
    analyses = [analyse(results, key) for key in FRONTS]
    results["analysis"] = {a["front"]: a for a in analyses}
    for a in analyses:
        print("\n" + markdown(a))
    print("\n" + box_table(results))
    save_results(results)
    paths = [figure_profiles(results), figure_runout(analyses[0], analyses[1:]),
             figure_convergence(results, analyses[0])]
    print("figures: " + ", ".join(p.name for p in paths))


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", type=_ints, default=(32, 64), help="levels n (cells 5/n), e.g. 32,64")
    p.add_argument("--aspects", type=_floats, default=ASPECTS)
    p.add_argument("--models", type=lambda s: tuple(s.split(",")), default=MODELS)
    p.add_argument("--fine-aspects", type=_floats, default=(),
                   help=f"aspect ratios also run at the finest level {LEVELS[-1]}")
    p.add_argument("--box-check", type=_ints, default=(), help="levels to run in the 5 x 5 box (a = 1.42)")
    p.add_argument("--stop-time", type=float, default=STOP_TIME)
    p.add_argument("--force", action="store_true", help="redo runs already in results.json")
    p.add_argument("--plot-only", action="store_true")
    p.add_argument("--quick", action="store_true", help="smoke test: n = 16, 20 steps, temporary files")
    args = p.parse_args(argv)
    if args.quick:
        return {"runs": {tag(FIELD_ASPECT, MODELS[0], QUICK_LEVEL): run(QUICK_LEVEL, quick=True)}}
    results = load_results()
    if not args.plot_only:
        todo = [(a, m, n, "reduced") for a in args.aspects for m in args.models for n in args.levels]
        todo += [(a, m, LEVELS[-1], "reduced") for a in args.fine_aspects for m in args.models]
        todo += [(FIELD_ASPECT, m, n, "paper") for n in args.box_check for m in args.models]
        for a, m, n, box in todo:
            name = tag(a, m, n, box)
            if name in results["runs"] and not args.force:
                continue
            if 1.0 / a < PAPER_BOX / n:
                print(f"{name}: skipped, L0 = {1 / a:.3g} is below one cell ({PAPER_BOX / n:.3g})")
                continue
            results["runs"][name] = run_one(a, m, n, box, stop_time=args.stop_time)
            save_results(results)
    report(results)
    return results


if __name__ == "__main__":
    main()
