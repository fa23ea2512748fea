"""Defluidisation of static beds, issue 13 item 3d: the basal pore-pressure decay against bed
height and grain size, for beds at the maximum packing (rigid) and expanded.

The ``defluidisation_column`` case (examples/defluidisation_column.toml; docs/cases.md) through the
full solver: a layer of glass beads (rho_s = 2500 kg m^-3, air, phi_max = 0.6, Drucker-Prager) of
height H at packing phi0 on an impermeable base, at rest, its weight carried by the gas (b0 = 1:
p_f = the lithostatic pressure), the supply stopped at t = 0. H = 0.05, 0.1, 0.2, 0.4 m; d = 45
and 80 um (the range of the experiments quoted by issue 13); phi0 = 0.6 (rigid), 0.585 and 0.57
(expanded by 2.5 and 5 %, as the experiments' beds above minimum fluidisation).

The model's two answers (src/granflow/theory/fluidisation.py):

* **rigid bed** (phi0 = phi_max): the pore pressure diffuses, D = p_atm kappa(phi0)/(1 - phi0);
  basal half-life 0.4854 tau_1, tau_1 = 4 H^2/(pi^2 D) (the Fourier series of
  granflow.verification.defluidisation): ~ H^2 / d^2;
* **expanded bed** (phi0 < phi_max): the grains settle at U_mf(phi0) and a compaction front climbs
  from the base (Kynch 1952); the basal pressure, the weight still in suspension, falls
  *linearly* to 0 over t_c = H (phi_max - phi0)/(phi_max U_mf(phi0)) (incompressible gas):
  ~ H / d^2. The gas's storage (syst2b: it expands as p_f falls) slows this; a control run with
  p_atm x 100 (storage / 100) recovers the incompressible limit.

Measured per run: the basal half-life t_1/2 (case diagnostic ``half_life_s``), the slope of the
basal decay while 0.3 < p_f/p_f0 < 0.8 (expanded beds) against Kynch's -1/t_c, and the apparent
diffusivity ``D_app = 0.4854 * 4 H^2 / (pi^2 t_1/2)`` -- the D a rigid-bed diffusion model fitted
to the half-life would give (how the experiments are read). Per (d, phi0), the exponent of t_1/2
against H (least squares in log-log).

Published (no digitised data; the comparison is with these statements): Montserrat et al. (2012,
JGR 117, B01203; HAL hal-00720261): expanded mixtures (b0 > 0.8-0.9) "retarded the decay of pore
pressure" through continuous consolidation, and the non-expanded ones follow a diffusion law;
Roche (2012, Bull. Volcanol. 74:1807): initial expansion increases the diffusion time compared with
the non-expanded state; Breard, Elijas Parra & de' Michieli Vitturi (2026, arXiv:2604.18462): the
apparent diffusivity is not intrinsic but depends on the bed thickness through the competition of
diffusion and compaction.

Run:   python validation/roche/defluidisation.py [--quick] [--cells 20] [--report]
Time:  ~3 min on one core (25 runs of 2-10 s); ``--quick``: H = 0.1 m, d = 80 um, the rigid bed,
       the 2.5 % expanded one and its p_atm x 100 control on 10 cells (~10 s, nothing written).
Output: defluidisation.json and defluidisation.png beside this script (not with --quick), the
tables on stdout; ``--report`` redoes the tables and the figure from defluidisation.json.
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from granflow.casekit.runner import CaseRun
from granflow.config import load_case
from granflow.materials import Material
from granflow.theory import fluidisation as fl
from granflow.verification import defluidisation as dfl

HERE = Path(__file__).resolve().parent
CASE_FILE = HERE.parents[1] / "examples" / "defluidisation_column.toml"
RUN_DIR = Path(os.environ.get("TMPDIR", tempfile.gettempdir())) / "granflow_roche_defluidisation"
OUT_JSON, FIG = HERE / "defluidisation.json", HERE / "defluidisation.png"

HEIGHTS = (0.05, 0.1, 0.2, 0.4)
"""Bed heights [m]."""
GRAINS = (45e-6, 80e-6)
"""Grain diameters [m]."""
PACKINGS = (0.6, 0.585, 0.57)
"""Initial packings [-]: phi_max (rigid), 2.5 % and 5 % expanded."""
MATERIAL = {"rho_s": 2500.0, "eta_f": 1.8e-5, "phi_max": 0.6}
"""The example's beads and air (SI)."""
G = 9.81
"""Gravity [m s^-2]."""
B0 = 1.0
"""Initial basal p_f / lithostatic [-]: the weight carried by the gas."""
AMBIENT_CELLS = 2
"""Cells above the bed (the gas leaves through them)."""
FIT_RANGE = (0.3, 0.8)
"""Window of p_f/p_f0 for the slope of the linear decay [-]."""
STEPS = {"rigid": 150, "expanded": 1000}
"""Time steps per tau_1 (rigid) and per t_c (expanded)."""
QUICK_STEPS = {"rigid": 50, "expanded": 300}
STORAGE_CONTROL = 100.0
"""p_atm factor of the control run (the gas's storage term / 100)."""
QUICK = (0.1, 80e-6, (0.6, 0.585), 10)
"""--quick: H [m], d [m], packings, cells over H."""


def material(d: float) -> Material:
    return Material(d=d, **MATERIAL)


def predictions(H: float, d: float, phi0: float) -> dict:
    """The rigid bed's (phi_max, same H and d) D [m^2 s^-1], tau_1 [s] and series half-life [s] --
    for an expanded bed the non-expanded reference --, D at phi0, and Kynch's t_c [s] (0 for a
    rigid bed)."""
    m = material(d)
    D = float(m.gas_diffusivity(m.phi_max))
    tau_1 = dfl.first_time_constant(H, D)
    t_c = fl.consolidation_time(m, phi0, H, G)
    return {"D_m2_s": D, "D_phi0_m2_s": float(m.gas_diffusivity(phi0)), "tau_1_s": tau_1,
            "series_half_life_s": dfl.basal_half_life(H, D), "t_c_s": t_c, "kynch_half_life_s": t_c / 2.0}


def one_run(H: float, d: float, phi0: float, cells: int, quick: bool = False, p_atm_factor: float = 1.0) -> dict:
    """One bed; the numbers of defluidisation.json."""
    pred = predictions(H, d, phi0)
    steps = QUICK_STEPS if quick else STEPS
    rigid = pred["t_c_s"] == 0.0
    dt = pred["tau_1_s"] / steps["rigid"] if rigid else pred["t_c_s"] / steps["expanded"]
    stop = 1.5 * pred["tau_1_s"] if rigid else 2.0 * pred["t_c_s"]
    nz = cells + AMBIENT_CELLS
    extra = [f"setup.H={H!r}", f"setup.phi0={phi0!r}", f"setup.b0={B0!r}", f"material.d={d!r}",
             f"grid.nz={nz}", f"grid.Lz={H * nz / cells!r}", f"time.stop_time={stop!r}", f"time.dt_max={dt!r}",
             f"output.interval={stop / 200!r}", "output.figures=false"]
    if p_atm_factor != 1.0:
        extra.append(f"material.p_atm={101300.0 * p_atm_factor!r}")
    cfg = load_case(CASE_FILE, extra)
    tag = f"H{H:g}_d{d * 1e6:g}_phi{phi0:g}_n{cells}_patm{p_atm_factor:g}"
    s = CaseRun(cfg, RUN_DIR / tag, overwrite=True).run().summary
    diag = s["case_diagnostics"]
    rec = diag["basal_record"]
    t, p = np.asarray(rec["t_s"]), np.asarray(rec["p_f_Pa"]) / diag["p_f0_base_Pa"]
    window = (p > FIT_RANGE[0]) & (p < FIT_RANGE[1])
    slope = float(np.polyfit(t[window], p[window], 1)[0]) if np.count_nonzero(window) >= 3 else None
    half = diag["half_life_s"]
    out = {"H_m": H, "d_m": d, "phi0": phi0, "cells": cells, "p_atm_factor": p_atm_factor, "status": s["status"],
           "steps": s["steps"], "half_life_s": half, "slope_per_s": slope, "rigid": diag["rigid"],
           "D_app_m2_s": None if half is None else pred["D_m2_s"] * pred["series_half_life_s"] / half,
           "record_t_s": t.tolist(), "record_p_over_p0": p.tolist()}
    out.update(pred)
    out["half_life_over_series"] = None if half is None else half / pred["series_half_life_s"]
    out["slope_over_kynch"] = None if (rigid or slope is None) else -slope * pred["t_c_s"]
    return out


def run(resolution: int = 20, quick: bool = False) -> list[dict]:
    """Every bed (or the --quick three) on ``resolution`` cells over H."""
    if quick:
        H, d, packings, cells = QUICK
        rows = [one_run(H, d, phi0, cells, quick=True) for phi0 in packings]
        return rows + [one_run(H, d, packings[-1], cells, quick=True, p_atm_factor=STORAGE_CONTROL)]
    rows = [one_run(H, d, phi0, resolution) for d in GRAINS for phi0 in PACKINGS for H in HEIGHTS]
    return rows + [one_run(0.1, 80e-6, 0.585, resolution, p_atm_factor=STORAGE_CONTROL)]


def exponents(rows: list[dict]) -> list[dict]:
    """Per (d, phi0): the least-squares exponent of t_1/2 against H."""
    out = []
    for d in sorted({r["d_m"] for r in rows}):
        for phi0 in sorted({r["phi0"] for r in rows}, reverse=True):
            sel = [r for r in rows if r["d_m"] == d and r["phi0"] == phi0 and r["p_atm_factor"] == 1.0
                   and r["half_life_s"]]
            if len(sel) >= 2:
                k = np.polyfit(np.log([r["H_m"] for r in sel]), np.log([r["half_life_s"] for r in sel]), 1)[0]
                out.append({"d_m": d, "phi0": phi0, "heights": len(sel), "exponent": float(k)})
    return out


def storage_number(r: dict) -> float:
    """``eps = (1 - phi0) (p_f0/p_atm) phi_max/(phi_max - phi0)`` [-], p_f0 = b0 phi0 rho_s g H: the
    gas's storage against Kynch's settling (theory.fluidisation, module docstring); 0 for a rigid
    bed. Measured: the linear decay's slope is about Kynch's / (1 + eps) (README)."""
    phi_max = MATERIAL["phi_max"]
    if r["phi0"] >= phi_max:
        return 0.0
    p0 = B0 * r["phi0"] * MATERIAL["rho_s"] * G * r["H_m"]
    return (1 - r["phi0"]) * p0 / (101300.0 * r["p_atm_factor"]) * phi_max / (phi_max - r["phi0"])


def _f(v, spec: str) -> str:
    return "–" if v is None else format(v, spec)


def table(rows: list[dict]) -> str:
    lines = ["| d [um] | phi0 | H [m] | p_atm x | t_1/2 [s] | rigid-bed series [s] | t_1/2 / series | Kynch t_c/2 [s] "
             "| slope / Kynch | 1/(1 + eps) | D_app [m2/s] | D(phi_max) [m2/s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['d_m'] * 1e6:g} | {r['phi0']:g} | {r['H_m']:g} | {r['p_atm_factor']:g} | "
                     f"{_f(r['half_life_s'], '.4g')} | {r['series_half_life_s']:.4g} | {_f(r['half_life_over_series'], '.3f')} | "
                     f"{_f(r['kynch_half_life_s'] or None, '.4g')} | {_f(r['slope_over_kynch'], '.3f')} | "
                     f"{_f(1 / (1 + storage_number(r)) if r['phi0'] < MATERIAL['phi_max'] else None, '.3f')} | "
                     f"{_f(r['D_app_m2_s'], '.3g')} | {r['D_m2_s']:.3g} |")
    ex = exponents(rows)
    if ex:
        lines += ["", "| d [um] | phi0 | heights | t_1/2 ~ H^k: k |", "|---|---|---|---|"]
        lines += [f"| {e['d_m'] * 1e6:g} | {e['phi0']:g} | {e['heights']} | {e['exponent']:.3f} |" for e in ex]
    return "\n".join(lines)


def figure(rows: list[dict], path: Path = FIG) -> Path:
    """defluidisation.png: basal p_f/p_f0 against t/tau_1 of the 10 cm, 80 um beds (left) and t_1/2
    against H (right, log-log), granflow alone (no digitised data)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(12.0, 4.4))
    for r in rows:
        if r["H_m"] == 0.1 and r["d_m"] == 80e-6:
            tau = predictions(0.1, 80e-6, 0.6)["tau_1_s"]
            label = f"phi0 = {r['phi0']:g}" + ("" if r["p_atm_factor"] == 1.0 else f", p_atm x {r['p_atm_factor']:g}")
            line, = ax[0].plot(np.asarray(r["record_t_s"]) / tau, r["record_p_over_p0"], label=label)
            if r["t_c_s"] and r["p_atm_factor"] == 1.0:  # Kynch: 1 - t/t_c (incompressible gas)
                ax[0].plot([0.0, r["t_c_s"] / tau], [1.0, 0.0], ls="--", lw=0.8, color=line.get_color())
    ax[0].set(xlabel="t / tau_1 (rigid bed)", ylabel="basal p_f / p_f0",
              title="H = 0.1 m, d = 80 um, b0 = 1 (dashed: Kynch, incompressible gas)")
    for d, marker in zip(GRAINS, ("o", "s")):
        for phi0 in PACKINGS:
            sel = [r for r in rows if r["d_m"] == d and r["phi0"] == phi0 and r["p_atm_factor"] == 1.0 and r["half_life_s"]]
            if sel:
                ax[1].loglog([r["H_m"] for r in sel], [r["half_life_s"] for r in sel], marker=marker,
                             label=f"d = {d * 1e6:g} um, phi0 = {phi0:g}")
    ax[1].set(xlabel="H [m]", ylabel="basal half-life [s]", title="granflow (rigid: ~H^2; expanded: Kynch ~H)")
    for a in ax:
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="H = 0.1 m, d = 80 um, 10 cells, 3 runs, nothing written")
    ap.add_argument("--cells", type=int, default=20, help="cells over the bed height")
    ap.add_argument("--report", action="store_true", help="table and figure from defluidisation.json (no runs)")
    args = ap.parse_args(argv)
    if args.report:
        rows = json.loads(OUT_JSON.read_text())["rows"]
        print(table(rows), flush=True)
        figure(rows)
        return rows
    rows = run(args.cells, quick=args.quick)
    print(table(rows), flush=True)
    if not args.quick:
        figure(rows)
        kept = [r if (r["H_m"] == 0.1 and r["d_m"] == 80e-6) else
                {k: v for k, v in r.items() if not k.startswith("record_")} for r in rows]  # the figure's series only
        OUT_JSON.write_text(json.dumps({"rows": kept, "exponents": exponents(rows)}, indent=1) + "\n")
    return rows


if __name__ == "__main__":
    main()
