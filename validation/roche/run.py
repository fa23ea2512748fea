"""Roche's fluidised columns, issue 13 item 1: the injected bed against the model's homogeneous
expansion law.

A column of 70 um glass beads poured at phi0 = phi_max = 0.6 is fluidised by air injected through
its porous base at U = 1.1, 1.3, 1.6 U_mf, with the preparation of ``column_collapse``
(``setup.preparation = "injection"``, :mod:`granflow.casekit.preparation`: the reservoir alone, gate
closed, linear gas law, Drucker-Prager closure). Compared, for each U/U_mf:

* analytic: the root phi_e of the model's drag/weight balance kappa(phi) phi rho_s g = U and the
  kinematic-wave time t_s at which a bed released at phi0 reaches it
  (:mod:`granflow.theory.fluidisation`);
* granflow: ``prep_phi_mean`` (mass per unit area over the centre-of-mass height), whether and
  when the preparation declared the bed steady (height drift and p_f criteria,
  docs/cases.md), the largest granular speed at the end;

on two beds: "small" (H0 = 2 cm, 20 cells over the bed, reservoir 2 cells wide; the slow test of
tests/validation_smoke/test_expansion.py) and "example" (H0 = 10 cm, 1 cm cells, reservoir 10 cells wide: the
geometry of examples/column_collapse_injected.toml), the latter run to 6 s (t_s ~ 3.5 s).

Issue 13 item 3 (b), (c), at one resolution: the channel of examples/roche_channel.toml (a 0.2 m x
0.4 m column of 80 um beads prepared by injection at U_mf, gas supply stopped, released into a 3 m
channel with a rough base) and its dry twin examples/roche_channel_dry.toml, on 2 cm cells:

* (b) the front x_f(t) (the run's definition, sub-cell "linear" estimate,
  granflow.output.accessor): the speed of its constant-velocity phase, a least-squares line over
  the records where the front has travelled :data:`FIT_WINDOW_H0` H0, against
  sqrt(2 g H0) (Roche et al. 2008, as quoted in issue 13: the fronts of initially fluidised
  dam-break flows move at about that speed; no digitised data here); the front and run-out when
  the flow comes to rest and the stopping time (the first record from which the front stays within
  one cell of its position at rest);
* (c) basal p_f against time at the example's stations (``output.probes_x``), over the initial
  lithostatic pressure of the bottom cell; the head's under-pressure is read as p_f < 0 (below
  atmospheric) at a channel station while the front passes it. Model alone: no published series
  was digitised.

Run:   python validation/roche/run.py [--quick] [--part expansion|channel] [--dx 0.01]
Time:  ~4 min on one core for the expansion table, ~1.5 min for the channel (``--quick``: the
       small bed at 1.3 U_mf, and the channel on 4 cm cells for 0.4 s, ~20 s).
Output: results.json (expansion) and channel.json, front.png, basal_pressure.png (channel) beside
this script (not with --quick; with --dx other than 0.02 m only channel_<dx>cm.json: the 1 cm check,
~7 min), the tables on stdout; run directories in
$TMPDIR/granflow_roche (not kept).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

from granflow import diagnostics as dg
from granflow.casekit import preparation as prep
from granflow.casekit.runner import CaseRun
from granflow.config import CaseConfig, load_case

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RATIOS = (1.1, 1.3, 1.6)
MATERIAL = {"d": 70e-6, "rho_s": 2500.0, "eta_f": 1.8e-5, "phi_max": 0.6}
BEDS = {  # name: (H0 [m], cells over the box height 1.5 H0, reservoir cells, dt_max [s], max time [s])
    "small": (0.02, 30, 2, 2e-3, 3.0),
    "example": (0.1, 15, 10, 1e-3, 6.0),
}


def config(ratio: float, H0: float, nz: int, ncol: int, dt_max: float, max_time: float) -> CaseConfig:
    Lz = 1.5 * H0
    dz = Lz / nz
    return CaseConfig.from_dict({
        "case": {"name": "column_collapse"},
        "setup": {"H0": H0, "L0": ncol * dz, "preparation": "injection", "U_prep_over_Umf": ratio,
                  "prep_max_time": max_time},
        "material": MATERIAL, "closure": {"name": "drucker_prager", "delta_deg": 26.74},
        "gas": {"law": "linear"},
        "grid": {"nx": ncol + 2, "nz": nz, "Lx": (ncol + 2) * dz, "Lz": Lz},
        "time": {"stop_time": 0.003, "dt_max": dt_max}})


QUICK = ("small", 1.3)
"""The ``--quick`` smoke run: the small bed at 1.3 U_mf."""


def run(resolution: str = QUICK[0], quick: bool = False, ratio: float = QUICK[1]) -> dict:
    """One preparation (the validations' common shape, ``run(resolution, quick)``): the bed
    ``resolution`` (a key of :data:`BEDS`, which fixes H0 and the cells) at ``ratio`` U_mf; its
    preparation diagnostics. ``quick`` changes nothing here (the small bed is the quick one)."""
    return prep.prepare(config(ratio, *BEDS[resolution])).diagnostics()


CHANNEL_FILES = {"fluidised": ROOT / "examples" / "roche_channel.toml",
                 "dry": ROOT / "examples" / "roche_channel_dry.toml"}
CHANNEL_DX = 0.02
"""Cell size of the channel runs [m] (the examples' grid)."""
QUICK_DX, QUICK_STOP, QUICK_PREP = 0.04, 0.4, 0.1
"""``--quick`` channel: cells [m], flow time [s], preparation time [s]."""
RECORD_INTERVAL = 0.005
"""Output (and probe) interval of the channel runs [s]: the head passes a station in ~0.01 s (the
examples' 0.02 s caught its under-pressure on single records)."""
FIT_WINDOW_H0 = (0.5, 1.5)
"""Front travel [H0] over which its constant-velocity phase is fitted (0.2-0.6 m here: straight in
both runs; not a fraction of the final run-out, which a one-cell distal tongue makes jump)."""
QUANTILES = (0.5, 0.9, 0.99)
"""Mass fractions of the deposit's quantile fronts (``x_quantile_m``)."""
G = 9.81
RUN_DIR = Path(os.environ.get("TMPDIR", tempfile.gettempdir())) / "granflow_roche"
CHANNEL_JSON, FIG_FRONT, FIG_PRESSURE = HERE / "channel.json", HERE / "front.png", HERE / "basal_pressure.png"


def channel_overrides(dx: float, quick: bool) -> list[str]:
    """Grid of cells ``dx`` [m] on the examples' box, records every :data:`RECORD_INTERVAL`; the
    quick run's short times."""
    cfg = load_case(CHANNEL_FILES["dry"])
    out = [f"grid.nx={round(cfg.grid.Lx / dx)}", f"grid.nz={round(cfg.grid.Lz / dx)}",
           f"output.interval={RECORD_INTERVAL}", "output.figures=false", "output.checkpoint_interval=100000"]
    return out + ([f"time.stop_time={QUICK_STOP}"] if quick else [])


def read_channel(directory: Path) -> dict:
    """Front (edge and sub-cell), probes and lithostatic reference of one run's output.nc."""
    import xarray as xr

    import granflow.output  # noqa: F401  (the ds.granflow accessor)

    with xr.open_dataset(directory / "output.nc") as ds:
        out = {"t_s": ds["time"].values.astype(float).tolist(),
               "x_front_m": ds["x_front"].values.astype(float).tolist(),
               "x_front_linear_m": ds.granflow.front_position(method="linear").values.astype(float).tolist()}
        h = ds.granflow.deposit_thickness(float(ds["time"][-1])).values.astype(float)
        x = ds["x"].values.astype(float)
        dx = float(x[1] - x[0])
        edges = np.concatenate([x - dx / 2, [x[-1] + dx / 2]])
        # mass-quantile fronts of the last record (diagnostics.mass_quantile_front): robust to the
        # one-cell distal tongue that makes the thickness-threshold front jump
        out["x_quantile_m"] = {str(q): dg.mass_quantile_front(edges, h, q) for q in QUANTILES}
        if "probe_p_f" in ds:
            out.update(probe_x_m=ds["x_probe"].values.astype(float).tolist(),
                       probe_p_f_Pa=ds["probe_p_f"].values.astype(float).tolist(),
                       probe_p_Pa=ds["probe_p"].values.astype(float).tolist())
    return out


def channel_run(state: str, dx: float = CHANNEL_DX, quick: bool = False, more: tuple[str, ...] = (),
                tag: str = "") -> dict:
    """One channel run of ``state`` ("fluidised" or "dry"), with the overrides ``more`` (run
    directory suffix ``tag``); the numbers of channel.json."""
    extra = channel_overrides(dx, quick) + list(more)
    if quick and state == "fluidised":
        extra.append(f"setup.prep_max_time={QUICK_PREP}")
    cfg = load_case(CHANNEL_FILES[state], extra)
    directory = RUN_DIR / f"{state}_{dx * 100:g}cm{tag}{'_quick' if quick else ''}"
    s = CaseRun(cfg, directory, overwrite=True).run().summary
    d = s["case_diagnostics"]
    out = {"state": state, "dx_m": dx, "H0_m": d["H0_m"], "L0_m": d["L0_m"], "status": s["status"],
           "t_final_s": s["t_final"], "t_rest_s": s["t_rest"], "runout_m": s["runout_m"],
           "wall_contact": s["wall_contact"], "wall_s": s["wall_s"] + d.get("prep_wall_s", 0.0),
           "phi0": d["phi0"], "prep": {k: v for k, v in d.items() if k.startswith(("prep_", "U_"))}}
    out.update(read_channel(directory))
    out["p_lith0_Pa"] = d["phi0"] * cfg.material.rho_s * G * (d["H0_m"] - cfg.grid.Lz / cfg.grid.nz / 2)
    out.update(front_analysis(out))
    if "probe_x_m" in out:
        out["under_pressure"] = under_pressure(out)
    return out


def front_analysis(r: dict) -> dict:
    """(b): the constant-velocity speed (least squares over the records where the sub-cell front
    has travelled :data:`FIT_WINDOW_H0` H0 beyond its start), its ratio to sqrt(2 g H0), the
    front and run-out when the flow comes to rest (``t_rest``; the thin distal tongue may still
    cross the front threshold later), and the stopping time: the first record from which the
    front stays within one cell of its position at t_rest [SI]."""
    t, xf = np.asarray(r["t_s"]), np.asarray(r["x_front_linear_m"])
    travel = (xf - xf[0]) / r["H0_m"]
    sel = (travel >= FIT_WINDOW_H0[0]) & (travel <= FIT_WINDOW_H0[1]) & np.isfinite(xf)
    ref = math.sqrt(2 * G * r["H0_m"])
    t_rest = r.get("t_rest_s") or t[-1]
    x_rest = float(np.interp(t_rest, t, xf))
    before = t <= t_rest
    away = np.flatnonzero(before & (np.abs(xf - x_rest) > r["dx_m"]))
    out = {"sqrt_2gH0_m_s": ref, "fit_points": int(np.count_nonzero(sel)), "x_front_rest_m": x_rest,
           "runout_rest_m": x_rest - float(xf[0]),
           "t_stop_s": float(t[away[-1] + 1]) if away.size and away[-1] + 1 < t.size else float(t[0])}
    if out["fit_points"] < 3:
        return {**out, "front_speed_m_s": None, "front_speed_over_sqrt_2gH0": None}
    slope, intercept = np.polyfit(t[sel], xf[sel], 1)
    return {**out, "front_speed_m_s": float(slope), "front_speed_over_sqrt_2gH0": float(slope / ref),
            "fit_t_s": [float(t[sel][0]), float(t[sel][-1])], "fit_intercept_m": float(intercept)}


def under_pressure(r: dict) -> list[dict]:
    """(c): per station, the front's arrival time (first record with x_front beyond it) and the
    lowest p_f [Pa] and p_f / p_lith0 within 0.1 s after it (negative: below atmospheric)."""
    t, xf = np.asarray(r["t_s"]), np.asarray(r["x_front_m"])
    pf = np.asarray(r["probe_p_f_Pa"])
    out = []
    for j, xp in enumerate(r["probe_x_m"]):
        passed = np.flatnonzero(xf > xp)
        if xp < r["L0_m"] or not passed.size:
            out.append({"x_m": xp, "t_arrival_s": None, "min_pf_Pa": None, "min_pf_over_plith0": None})
            continue
        t0 = t[passed[0]]
        win = (t >= t0) & (t <= t0 + 0.1)
        low = float(pf[win, j].min())
        out.append({"x_m": xp, "t_arrival_s": float(t0), "min_pf_Pa": low,
                    "min_pf_over_plith0": low / r["p_lith0_Pa"]})
    return out


def channel(resolution: float = CHANNEL_DX, quick: bool = False) -> dict:
    """(b) and (c): the fluidised and the dry channel runs at cells ``resolution`` [m]."""
    return {state: channel_run(state, resolution, quick) for state in CHANNEL_FILES}


def channel_table(runs: dict) -> str:
    lines = []
    for state, r in runs.items():
        lines.append(f"{state:9s} dx {r['dx_m'] * 100:g} cm: run-out {r['runout_m']:.3f} m at the end, "
                     f"{r['runout_rest_m']:.3f} m at rest ((L-L0)/L0 = {r['runout_rest_m'] / r['L0_m']:.2f}), front speed "
                     f"{_fmt(r['front_speed_m_s'], '.3f')} m/s = {_fmt(r['front_speed_over_sqrt_2gH0'], '.3f')} "
                     f"sqrt(2 g H0) ({r['sqrt_2gH0_m_s']:.3f} m/s), stop {_fmt(r['t_stop_s'], '.2f')} s, "
                     f"rest {_fmt(r['t_rest_s'], '.2f')} s, walls {r['wall_contact'] or 'clear'}, "
                     f"wall {r['wall_s']:.0f} s")
        for u in r.get("under_pressure", []):
            if u["t_arrival_s"] is not None:
                lines.append(f"    station x = {u['x_m']:.2f} m: front at {u['t_arrival_s']:.2f} s, lowest p_f "
                             f"{u['min_pf_Pa']:.1f} Pa ({u['min_pf_over_plith0']:+.3f} p_lith0) in 0.1 s after")
    if all(runs[s]["runout_rest_m"] for s in runs):
        lines.append(f"run-out ratio fluidised/dry at rest: "
                     f"{runs['fluidised']['runout_rest_m'] / runs['dry']['runout_rest_m']:.3f}")
    return "\n".join(lines)


def _fmt(v, spec: str) -> str:
    return "n/a" if v is None else format(v, spec)


def channel_figures(runs: dict, front_path: Path = FIG_FRONT, pressure_path: Path = FIG_PRESSURE) -> list[Path]:
    """front.png (b) and basal_pressure.png (c)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for state, colour in (("fluidised", "C3"), ("dry", "C0")):
        r = runs[state]
        t = np.asarray(r["t_s"])
        ax.plot(t, np.asarray(r["x_front_linear_m"]) - r["L0_m"], color=colour, label=f"{state} (granflow)")
        if r["front_speed_m_s"] is not None:
            tt = np.asarray(r["fit_t_s"])
            ax.plot(tt, r["fit_intercept_m"] + r["front_speed_m_s"] * tt - r["L0_m"], "k:", lw=2)
    r = runs["fluidised"]
    tt = np.linspace(0.0, 0.5, 2)
    ax.plot(tt, r["sqrt_2gH0_m_s"] * tt, "--", color="0.5", label="slope sqrt(2 g H0) (Roche et al. 2008)")
    ax.set(xlabel="t [s]", ylabel="x_f - L0 [m]", ylim=(0, None),
           title=f"front, H0 = {r['H0_m']} m, L0 = {r['L0_m']} m, dx = {r['dx_m'] * 100:g} cm (dotted: fit)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(front_path, dpi=110)
    plt.close(fig)
    pressure_figure(runs["fluidised"], pressure_path)
    return [front_path, pressure_path]


def pressure_figure(r: dict, path: Path) -> None:
    """basal_pressure.png: every station over p_lith0 (left); the channel stations in Pa with the
    front's arrival (dotted) to show the head's under-pressure (right)."""
    import matplotlib.pyplot as plt

    pf = np.asarray(r["probe_p_f_Pa"])
    fig, ax = plt.subplots(1, 2, figsize=(12.0, 4.4))
    for j, xp in enumerate(r["probe_x_m"]):
        line, = ax[0].plot(r["t_s"], pf[:, j] / r["p_lith0_Pa"], label=f"x = {xp:.2f} m")
        if xp > r["L0_m"]:
            ax[1].plot(r["t_s"], pf[:, j], color=line.get_color(), label=f"x = {xp:.2f} m")
    for u in r["under_pressure"]:
        if u["t_arrival_s"] is not None:
            ax[1].axvline(u["t_arrival_s"], ls=":", color="0.5", lw=0.8)
    for a in ax:
        a.axhline(0.0, color="0.6", lw=0.8)
        a.legend(fontsize=8)
    ax[0].set(xlabel="t [s]", ylabel="basal p_f / p_lith0",
              title=f"basal p_f, p_lith0 = {r['p_lith0_Pa']:.0f} Pa (granflow alone: no digitised data)")
    channel_pf = pf[:, np.asarray(r["probe_x_m"]) > r["L0_m"]]
    ax[1].set(xlabel="t [s]", ylabel="basal p_f [Pa]", title="channel stations (dotted: front arrives)",
              ylim=(min(1.2 * float(channel_pf.min()), -10.0), 150.0))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def expansion_rows(quick: bool) -> list[dict]:
    """The expansion table (module docstring, item 1); results.json unless ``quick``."""
    runs = [QUICK] if quick else [(b, r) for b in BEDS for r in RATIOS]
    rows = []
    for bed, ratio in runs:
        d = run(bed, quick, ratio)
        row = {"bed": bed, "U_over_Umf": ratio, **{k: d[k] for k in (
            "prep_phi_expected", "prep_phi_mean", "prep_phi_error", "prep_steady", "prep_time_s",
            "prep_expansion_time_s", "prep_max_speed_m_s", "prep_height_drift_m_s", "prep_pf_rate_Pa_s",
            "prep_bed_height_m", "prep_wall_s")}}
        rows.append(row)
        print(f"{bed:8s} U/U_mf = {ratio}: analytic phi {row['prep_phi_expected']:.5f}, granflow "
              f"{row['prep_phi_mean']:.5f} ({100 * row['prep_phi_error']:+.2f} %), steady "
              f"{row['prep_steady']} at {row['prep_time_s']:.3f} s (t_s {row['prep_expansion_time_s']:.3f} s), "
              f"max speed {row['prep_max_speed_m_s']:.2e} m/s", flush=True)
    if not quick:
        (HERE / "results.json").write_text(json.dumps(rows, indent=1) + "\n")
    return rows


def save_channel(runs: dict, dx: float) -> None:
    """channel.json and the figures at :data:`CHANNEL_DX`; channel_<dx>cm.json at another dx."""
    if dx == CHANNEL_DX:
        CHANNEL_JSON.write_text(json.dumps(runs, indent=1) + "\n")
        channel_figures(runs)
    else:
        (HERE / f"channel_{dx * 100:g}cm.json").write_text(json.dumps(runs, indent=1) + "\n")


def main(argv: list[str] | None = None) -> dict:
    """Run the expansion table and the channel (module docstring); returns their rows."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small bed at 1.3 U_mf, the channel on 4 cm cells for 0.4 s")
    ap.add_argument("--part", choices=("expansion", "channel"), help="run only this part")
    ap.add_argument("--dx", type=float, default=CHANNEL_DX,
                    help=f"channel cells [m] (default {CHANNEL_DX}; another value writes channel_<dx>cm.json only)")
    args = ap.parse_args(argv)
    out = {}
    if args.part in (None, "expansion"):
        out["expansion"] = expansion_rows(args.quick)
    if args.part in (None, "channel"):
        runs = channel(QUICK_DX if args.quick else args.dx, args.quick)
        print(channel_table(runs), flush=True)
        if not args.quick:
            save_channel(runs, args.dx)
        out["channel"] = runs
    return out


if __name__ == "__main__":
    main()
