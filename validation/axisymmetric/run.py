"""Dry axisymmetric column collapses against aspect ratio, on three grids, beside the published fit
(issue 14 item 4, acceptance: "the axisymmetric dry run-out against aspect ratio tabulated beside
the published fits").

The case: examples/column_collapse_axisymmetric.toml (glass beads, Drucker-Prager sin(delta) =
0.45, no-slip base, the west side the axis) with the column height fixed at H0 = 0.1 m and its
radius R0 = H0 / a, a = 0.5, 1, 2, 4, 8 (the set-up of validation/dry_runout, whose plane runs the
same grains). Square cells dx = dz = H0 / N on three levels N = N0 (1, sqrt 2, 2), N0 = 14 for
a <= 2 and 4 a for a >= 4 (at least 3.5 cells across R0), as the plane study. Box: radius
R0 + 3 x the run-out of Lube et al.'s fit plus 4 cm, height 1.1 H0 (checked: no grain reaches the
east wall, ``wall_contact`` empty).

Measured per run (through :class:`granflow.casekit.runner.CaseRun`, to rest): the run-out
(R_inf - R0)/R0 with R_inf the front at the case's threshold, a deposit 0.05 H0 thick (5 mm);
the deposit's height on the axis h_inf / R0; mass and energy budget. The three levels give a
Richardson estimate (first order assumed when the observed order is not in [0.5, 3]) with the
difference between the two finest levels as its uncertainty.

Published fit (experiments on sand, salt, sugar, rice, couscous on rough and smooth bases): Lube,
Huppert, Sparks & Hallworth (2004, J. Fluid Mech. 508, 175-199), (R_inf - R0)/R0 = 1.24 a for
a < 1.7 and 1.6 a^(1/2) above. Lajeunesse, Mangeney-Castelnau & Vilotte (2004, Phys. Fluids 16,
2371; glass beads) report the same two regimes (linear, then a^(1/2)) with the transition at a
lower a (~0.74); their prefactors are not reproduced here (not checked against the paper).

Run:   python validation/axisymmetric/run.py [--quick] [--fluidised] [--aspect 0.5 1 2 4] [--levels 0 1 2]
Time:  ~4.5 min on one core for the 15 dry runs, ~5 min more with --fluidised (``--quick``: a = 1 on a 7-cell grid to t = 0.05 s,
       seconds; the smoke test of tests/validation_smoke/test_validation_axisymmetric.py).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
EXAMPLE = ROOT / "examples" / "column_collapse_axisymmetric.toml"
RESULTS = HERE / "results.json"
H0 = 0.1
PHI_MAX = 0.6         # the example's material.phi_max
ASPECTS = (0.5, 1.0, 2.0, 4.0, 8.0)
LEVEL_FACTORS = (1.0, math.sqrt(2.0), 2.0)
QUICK = {"aspect": 1.0, "n": 7, "t_end": 0.05}
FLUIDISED = ['gas.law="linear"', "setup.b0=0.9", "setup.phi0=0.58"]
"""``--fluidised``: the settings of examples/column_collapse_fluidised.toml (an expanded column
whose pore pressure carries 90 % of its weight at release; closed top, no injection)."""


def lube_fit(a: float) -> float:
    """(R_inf - R0)/R0 of Lube et al. (2004): 1.24 a for a < 1.7, 1.6 a^(1/2) above."""
    return 1.24 * a if a < 1.7 else 1.6 * math.sqrt(a)


def cells_over_h0(a: float, level: int) -> int:
    """N = H0/dx of a level (module docstring)."""
    n0 = 14 if a <= 2 else 4 * a
    return int(round(n0 * LEVEL_FACTORS[level]))


def box(a: float, n: int) -> tuple[int, int, float, float]:
    """(nx, nz, Lx, Lz): radius R0 + 3 x the fit's run-out + 4 cm, height 1.1 H0, square cells."""
    r0, dx = H0 / a, H0 / n
    nx = int(math.ceil((r0 * (1.0 + 3.0 * lube_fit(a)) + 0.04) / dx))
    nz = int(math.ceil(1.1 * n))
    return nx, nz, nx * dx, nz * dx


def run(resolution: int, quick: bool = False, aspect: float = 1.0, fluidised: bool = False) -> dict:
    """One collapse of aspect ratio ``aspect`` with ``resolution`` cells over H0 (``quick``: to
    t = 0.05 s only; ``fluidised``: with :data:`FLUIDISED`), through :class:`CaseRun` in a
    scratch directory; returns its record."""
    from granflow.casekit.runner import CaseRun
    from granflow.config import load_case

    nx, nz, lx, lz = box(aspect, resolution)
    sets = [f"setup.H0={H0}", f"setup.L0={H0 / aspect!r}", f"grid.nx={nx}", f"grid.nz={nz}",
            f"grid.Lx={lx!r}", f"grid.Lz={lz!r}", "output.figures=false", "output.interval=0.05",
            "output.rest_speed=0.0075"]
    if quick:
        sets.append(f"time.stop_time={QUICK['t_end']}")
    if fluidised:
        sets += FLUIDISED
    cfg = load_case(EXAMPLE, overrides=sets)
    t0 = time.process_time()
    with tempfile.TemporaryDirectory() as tmp:
        s = CaseRun(cfg, Path(tmp) / "run", overwrite=True).run().summary
        with xr.open_dataset(Path(tmp) / "run" / "output.nc") as ds:
            phi = ds["phi"].values[-1].T  # (x, z) at the last record
        cpu = time.process_time() - t0
    r0, dz = H0 / aspect, lz / nz
    h = phi.sum(axis=1) * dz / PHI_MAX  # deposit thickness per column [m]
    return {"a": aspect, "n": resolution, "fluid": fluidised, "nx": nx, "nz": nz, "dx_mm": 1e3 * H0 / resolution,
            "status": s["status"], "t_rest": s["t_rest"], "t_final": s["t_final"], "steps": s["steps"],
            "runout_rel": s["runout_m"] / r0, "h_axis_rel": s["final_height_at_wall"] / r0,
            **fronts(h, lx / nx, r0), "h_m": [round(float(v), 7) for v in h],
            "wall_contact": s["wall_contact"], "mass_rel_error": s["mass_rel_error"],
            "energy_residual_rel": s["energy_residual_rel"], "cpu_s": cpu}


TOE_WINDOWS = {"runout_toe": (0.1, 0.3), "runout_toe_upper": (0.2, 0.5)}
"""Toe fronts: the straight line fitted to the deposit's toe where h falls from ``hi`` to ``lo``
times the deposit's height on the axis, extrapolated to h = 0 (where the deposit ends, as the
plane study's toe, whose 0.05-0.15 H0 window is 0.06-0.18 of its wall height at a = 1); the upper
window measures how much the definition moves the answer."""


def fronts(h, dx: float, r0: float) -> dict:
    """Run-outs (R - R0)/R0 of a deposit h(r) [m] on columns of width ``dx``: the toe fronts of
    :data:`TOE_WINDOWS` (:func:`granflow.diagnostics.toe_front`), the thickness falling through
    0.05 H0 and 0.01 H0 (linear between column centres, :func:`front_from_thickness`), and the
    radius holding 99 % of the grains (``int_0^R h 2 pi r dr``, linear within the column)."""
    from granflow.diagnostics import front_from_thickness, toe_front

    h = np.asarray(h, dtype=float)
    edges = dx * np.arange(h.size + 1)
    centres = edges[:-1] + 0.5 * dx
    out = {key: (toe_front(centres, h, (lo * h[0], hi * h[0])) - r0) / r0 for key, (lo, hi) in TOE_WINDOWS.items()}
    for key, thr in (("runout_5pc", 0.05 * H0), ("runout_1pc", 0.01 * H0)):
        out[key] = (float(front_from_thickness(edges, h, thr, "linear")) - r0) / r0
    mass = np.concatenate([[0.0], np.cumsum(h * np.pi * (edges[1:] ** 2 - edges[:-1] ** 2))])
    out["runout_m99"] = (float(np.interp(0.99 * mass[-1], mass, edges)) - r0) / r0
    return out


FRONT_KEYS = ("runout_toe", "runout_toe_upper", "runout_5pc", "runout_1pc", "runout_m99")


def figure(rows: list[dict], estimates: list[dict], path: Path) -> None:
    """Run-out against a: every level of the toe front, its estimate, the 99 % mass radius, and
    Lube et al.'s fit."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 4.0))
    a_fit = np.linspace(0.3, 5.0, 200)
    ax.plot(a_fit, [lube_fit(a) for a in a_fit], "k-", label="Lube et al. 2004 fit")
    for key, style, label in (("runout_toe", "o", "toe (0.1-0.3 h_axis)"), ("runout_toe_upper", "s", "toe (0.2-0.5 h_axis)"),
                              ("runout_m99", "^", "99 % mass radius")):
        for r in rows:
            ax.plot(r["a"], r[key], style, color="C0" if key == "runout_toe" else "C1" if key == "runout_m99" else "C2",
                    alpha=0.35 + 0.3 * (r["n"] / max(q["n"] for q in rows if q["a"] == r["a"])) / 1.0, ms=4)
        est = [e for e in estimates if e["front"] == key]
        ax.errorbar([e["a"] for e in est], [e["estimate"] for e in est], yerr=[e["uncertainty"] for e in est],
                    fmt=style, color="C0" if key == "runout_toe" else "C1" if key == "runout_m99" else "C2",
                    mfc="none", capsize=3, label=f"{label}: estimate")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xticks(ASPECTS, [f"{a:g}" for a in ASPECTS])
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("aspect ratio a = H0/R0")
    ax.set_ylabel("(R_inf - R0)/R0")
    ax.set_title("dry axisymmetric collapse (glass beads, DP)", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def richardson(values: list[float], ratio: float = math.sqrt(2.0)) -> tuple[float, float, float | None]:
    """``(estimate, uncertainty, order)`` from three levels (coarse to fine) refined by ``ratio``:
    the observed order if it lies in [0.5, 3], else first order (order None)."""
    f1, f2, f3 = values
    d1, d2 = f2 - f1, f3 - f2
    order = math.log(d1 / d2) / math.log(ratio) if d1 * d2 > 0 and d2 != 0 else None
    p = order if order is not None and 0.5 <= order <= 3.0 else 1.0
    est = f3 + d2 / (ratio ** p - 1.0)
    return est, abs(est - f3) + abs(d2), (order if order is not None and 0.5 <= order <= 3.0 else None)


def table(rows: list[dict]) -> str:
    lines = ["| a | N (cells over H0) | grid | run-out: case front | toe | toe (upper) | 5 % H0 | 1 % H0 "
             "| 99 % mass | h_axis/R0 | t_rest [s] | mass error | energy residual | CPU [s] |",
             "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['a']:g}{' fluidised' if r.get('fluid') else ''} | {r['n']} | {r['nx']} x {r['nz']} "
                     f"| {r['runout_rel']:.3f} | {r['runout_toe']:.3f} | {r['runout_toe_upper']:.3f} | {r['runout_5pc']:.3f} | {r['runout_1pc']:.3f} | {r['runout_m99']:.3f} "
                     f"| {r['h_axis_rel']:.3f} | {r['t_rest'] if r['t_rest'] is None else round(r['t_rest'], 3)} "
                     f"| {r['mass_rel_error']:.1e} | {100 * r['energy_residual_rel']:.1f} % | {r['cpu_s']:.0f} |")
    return "\n".join(lines)


def summary_table(rows: list[dict]) -> tuple[str, list[dict]]:
    """Per aspect ratio: the Richardson estimate of the run-out beside Lube et al.'s fit."""
    out, lines = [], ["| a | run-out | 3 levels | estimate +- | observed order | Lube et al. 2004 | ratio |",
                      "|---:|---|---|---|---|---:|---:|"]
    for a in sorted({r["a"] for r in rows}):
        levels = sorted((r for r in rows if r["a"] == a), key=lambda r: r["n"])
        if len(levels) != 3:
            continue
        fit = lube_fit(a)
        for key in FRONT_KEYS:
            vals = [r[key] for r in levels]
            if not all(np.isfinite(vals)):
                continue
            est, err, order = richardson(vals)
            out.append({"a": a, "front": key, "estimate": est, "uncertainty": err, "order": order, "lube_fit": fit})
            lines.append(f"| {a:g} | {key} | {', '.join(f'{v:.3f}' for v in vals)} | {est:.2f} +- {err:.2f} "
                         f"| {'-' if order is None else f'{order:.2f}'} | {fit:.2f} | {est / fit:.2f} |")
    return "\n".join(lines), out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a = 1 on a coarse grid to t = 0.05 s (smoke test)")
    ap.add_argument("--aspect", type=float, nargs="+", default=list(ASPECTS), help="aspect ratios H0/R0")
    ap.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2], help="levels (0 coarsest)")
    ap.add_argument("--fluidised", action="store_true", help="also the fluidised columns (FLUIDISED)")
    args = ap.parse_args(argv)
    if args.quick:
        rows = [run(QUICK["n"], quick=True, aspect=QUICK["aspect"])]
        print(table(rows))
        return {"runs": rows}
    old = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    done = {key(r): r for r in old.get("runs", [])}
    for fluid in ((False, True) if args.fluidised else (False,)):
        for a in args.aspect:
            for level in args.levels:
                n = cells_over_h0(a, level)
                if (a, n, fluid) not in done:
                    done[(a, n, fluid)] = run(n, aspect=a, fluidised=fluid)
                    print(table([done[(a, n, fluid)]]), flush=True)
                    RESULTS.write_text(json.dumps({"runs": sorted(done.values(), key=key)}, indent=1))
    rows = sorted(done.values(), key=key)
    for r in rows:  # the front definitions, recomputed from the stored deposits
        r.update(fronts(r["h_m"], H0 / r["n"], H0 / r["a"]))
    dry = [r for r in rows if not r.get("fluid", False)]
    text, estimates = summary_table(dry)
    print(table(rows))
    print(text)
    ratios = ratio_table(rows)
    print(ratios)
    RESULTS.write_text(json.dumps({"runs": rows, "estimates": estimates}, indent=1))
    figure(dry, estimates, HERE / "runout.png")
    return {"runs": rows, "estimates": estimates}


def key(r: dict) -> tuple:
    return r["a"], r["n"], r.get("fluid", False)


def ratio_table(rows: list[dict]) -> str:
    """Fluidised over dry run-out (toe front and 99 % mass radius) per aspect ratio and level."""
    pairs = {(r["a"], r["n"]): {} for r in rows}
    for r in rows:
        pairs[(r["a"], r["n"])][r.get("fluid", False)] = r
    lines = ["| a | N | toe: dry, fluidised, ratio | 99 % mass: dry, fluidised, ratio | fluidised t_rest [s] "
             "| energy residual |", "|---:|---:|---|---|---:|---:|"]
    for (a, n), pr in sorted(pairs.items()):
        if len(pr) != 2:
            continue
        d, f = pr[False], pr[True]
        lines.append(f"| {a:g} | {n} | {d['runout_toe']:.3f}, {f['runout_toe']:.3f}, "
                     f"{f['runout_toe'] / d['runout_toe']:.2f} | {d['runout_m99']:.3f}, {f['runout_m99']:.3f}, "
                     f"{f['runout_m99'] / d['runout_m99']:.2f} | {f['t_rest']:.3f} | {100 * f['energy_residual_rel']:.1f} % |")
    return "\n".join(lines)


if __name__ == "__main__":
    main(sys.argv[1:])
