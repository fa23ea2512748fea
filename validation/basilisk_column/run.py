"""granflow against Basilisk on the same column collapse (issue 12, acceptance 1).

Case ``lagree_column`` (docs/cases.md) with its default parameters, which reproduce Basilisk's
public ``granular_column.c`` (Lagree, Staron & Popinet 2011, J. Fluid Mech. 686, 378-408;
sandbox/M1EMN/Exemples in Basilisk's source): incompressible mu(I) (mu_s = 0.32, Delta mu = 0.28,
I0 = 0.4), half column of aspect ratio a against a symmetry wall in a 5 x 5 box, no-slip base,
dt_max = 0.01, to t = 4, the grain size mapped to granflow's inertial number
(``d = sqrt(phi_max) D``, D = 1/30 at a = 0.5 and 1/65 at a = 1.42, 6.26), with scheme v2's
momentum transport and material-indicator surface (:data:`NUMERICS`). Grids n x n on the whole 5 x 5 box, as Basilisk's
``N = 1 << LEVEL``.

The same deposit rule on both codes: h(x) = sum_z phi dz / phi_max per column (Basilisk: the VOF
fraction), front = right edge of the last column with h > 0.05 H0 (``output.front_threshold``).

Reference values (:data:`BASILISK`): Basilisk's granular_column.c built and run by the project
(benchmarks/vs_basilisk.py) at 64^2, 128^2, 256^2: fronts by granflow's rule and by the VOF
interface's extent (the rule of issue 12's a = 0.5 and 6.26 fronts, which therefore are not
comparable with an h > 0.05 front), h(x) at t = 4. Contact-dynamics final fronts
(:data:`CONTACT_DYNAMICS`) are those of the discrete simulations Lagree et al. (2011) compare with,
as plotted by granular_column.c's gnuplot scripts.

Acceptance (issue 12): fronts at t = 1..4 within 5 % of Basilisk at the same resolution, h(x)
within 0.03 H0, and the converged t = 4 front (three levels 64, 128, 256; Richardson,
:func:`granflow.verification.convergence.richardson`) stated against the contact-dynamics band.

Run:   python validation/basilisk_column/run.py                 # a = 0.5, 1.42, 6.26 at 64, 128, 256
       python validation/basilisk_column/run.py --levels 64,128 --aspects 0.5
       python validation/basilisk_column/run.py --report        # tables from results.json only
       python validation/basilisk_column/run.py --quick         # a = 1.42 at 16^2 to t = 0.2 (smoke)
Time:  64^2 ~10-20 s, 128^2 ~40-60 s, 256^2 ~2-4 min per run (one core; results.json keeps every
       run, rerun with --force).
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from granflow import diagnostics as dg
from granflow.cases import CASES
from granflow.config import CaseConfig
from granflow.verification.convergence import richardson
from granflow.verification.scripts import load_json

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results.json"
CASE = "lagree_column"
TIMES = (1.0, 2.0, 3.0, 4.0)
LEVELS = (64, 128, 256)
ASPECTS = (0.5, 1.42, 6.26)
FRONT_THRESHOLD = 0.05
"""Deposit thickness defining the front on both codes [H0]."""
FRONT_TOL = 0.05
"""Acceptance: |granflow - Basilisk| / Basilisk for the fronts at the same resolution."""
PROFILE_TOL = 0.03
"""Acceptance: |h_granflow - h_Basilisk| [H0]."""
QUANTILES = (0.9, 0.99)
"""Fractions q of the deposit volume of the mass-quantile fronts x_q
(:func:`granflow.diagnostics.mass_quantile_front`: the x left of which q of the volume lies) [-]."""
BASILISK = {
    0.5: {64: {"fronts": (2.344, 3.125, 3.672, 3.984), "facet": (2.391, 3.192, 3.698, 4.011),
               "h": (0.999, 0.948, 0.802, 0.633, 0.465, 0.319, 0.196, 0.104)},
          128: {"fronts": (2.383, 3.086, 3.594, 3.828), "facet": (2.393, 3.165, 3.635, 3.862),
                "h": (1.000, 0.953, 0.805, 0.633, 0.465, 0.321, 0.207, 0.087),
                "quantiles": {"0.9": (1.936, 2.206, 2.454, 2.617), "0.99": (2.256, 2.914, 3.346, 3.608)}},
          256: {"fronts": (2.383, 3.223, 3.770, 4.062), "facet": (2.424, 3.246, 3.821, 4.125),
                "h": (1.000, 0.952, 0.801, 0.627, 0.456, 0.309, 0.181, 0.112),
                "quantiles": {"0.9": (1.936, 2.212, 2.482, 2.677), "0.99": (2.261, 3.004, 3.554, 3.829)}}},
    1.42: {64: {"fronts": (1.094, 2.031, 2.969, 3.750), "facet": (1.145, 2.082, 3.016, 3.790),
                "h": (0.552, 0.429, 0.293, 0.189, 0.107, 0.055, 0.000, 0.000)},
           128: {"fronts": (1.094, 1.953, 2.461, 2.656), "facet": (1.153, 1.993, 2.610, 2.919),
                 "h": (0.560, 0.432, 0.298, 0.202, 0.127, 0.063, 0.000, 0.000),
                 "quantiles": {"0.9": (0.848, 1.362, 1.760, 1.967), "0.99": (1.044, 1.868, 2.436, 2.725)}},
           256: {"fronts": (1.094, 2.051, 2.559, 3.027), "facet": (1.163, 2.093, 2.819, 3.203),
                 "h": (0.560, 0.429, 0.297, 0.198, 0.111, 0.085, 0.057, 0.000),
                 "quantiles": {"0.9": (0.848, 1.369, 1.788, 2.032), "0.99": (1.043, 1.957, 2.620, 3.007)}},
           512: {"fronts": (1.123, 2.041, 2.705, 3.018),
                 "quantiles": {"0.9": (0.849, 1.397, 1.877, 2.165), "0.99": (1.051, 1.952, 2.655, 3.042)}}},
    6.26: {64: {"fronts": (0.469, 1.250, 2.109, 2.734), "facet": (0.530, 1.286, 2.117, 2.768),
                "h": (0.204, 0.103, 0.050, 0.000, 0.000, 0.000, 0.000, 0.000)},
           128: {"fronts": (0.469, 1.133, 1.250, 1.172), "facet": (0.527, 1.187, 1.615, 1.804),
                 "h": (0.218, 0.121, 0.062, 0.034, 0.000, 0.000, 0.000, 0.000),
                 "quantiles": {"0.9": (0.347, 0.921, 1.223, 1.292), "0.99": (0.478, 1.143, 1.558, 1.735)}},
           256: {"fronts": (0.469, 1.191, 1.523, 1.035), "facet": (0.543, 1.264, 1.801, 1.966),
                 "h": (0.218, 0.120, 0.055, 0.045, 0.000, 0.000, 0.000, 0.000),
                 "quantiles": {"0.9": (0.357, 0.955, 1.357, 1.464), "0.99": (0.481, 1.212, 1.732, 1.907)}},
           512: {"fronts": (0.498, 1.270, 1.494, 1.094),
                 "quantiles": {"0.9": (0.360, 0.995, 1.418, 1.552), "0.99": (0.497, 1.235, 1.767, 1.988)}}},
}
"""Basilisk granular_column.c (one aspect ratio per process, output events emptied; built with
qcc -O2 from the comphy-lab/basilisk-C snapshot, qcc.c of 2025-04-22, sandbox files of 2025-05-12;
benchmarks/README.md, benchmarks/vs_basilisk.py), per a and n: ``fronts`` at t = 1, 2, 3, 4 by the
same rule as granflow's (right edge of the last column with h > 0.05 H0), ``facet`` the largest x
of any point of the VOF interface (thin sheet and detached fragments included) -- the rule of the
fronts quoted in issue 12 for a = 0.5 and 6.26 --, and h at t = 4 at x = 0, 0.5, ..., 3.5 (linear
between column centres) [H0]. The issue's a = 1.42 fronts (2.656, 3.027) and every h it quotes
are reproduced exactly. ``quantiles``: the mass-quantile fronts x_0.9 and x_0.99 at t = 1, 2, 3, 4
(:data:`QUANTILES`), computed from the printed deposits h(x) with granflow's
:func:`granflow.diagnostics.mass_quantile_front`; ``512``: Basilisk's finer level (fronts and
quantiles only), from the rebuild of session 12 (same source and recipe; its 128^2 and 256^2
fronts and h reproduce the values above)."""
NUMERICS = {"advection": "consistent", "surface": "indicator"}
"""Scheme v2: mass-consistent momentum transport and the material-indicator surface (with its
default base friction at the wall pressure; docs/solver.md "Scheme v2"); every other numerical
option at the case's default."""
CONTACT_DYNAMICS = {0.5: (3.9, 4.0), 1.42: (3.1, 3.3), 6.26: (2.16, 2.25)}
"""Final fronts of the contact-dynamics simulations (Lagree et al. 2011) [H0]."""


def config(a: float, n: int, stop_time: float = TIMES[-1]) -> CaseConfig:
    return CaseConfig.from_dict({
        "case": {"name": CASE}, "setup": {"a": a}, "grid": {"nx": n, "nz": n},
        "walls": {"west": "free_slip", "bottom": "no_slip"},
        "time": {"stop_time": stop_time, "dt_max": 0.01},
        "numerics": dict(NUMERICS),
        "output": {"front_threshold": FRONT_THRESHOLD, "figures": False}})


def run_one(a: float, n: int, stop_time: float = TIMES[-1]) -> dict:
    """One granflow run: fronts and mass-quantile fronts at :data:`TIMES`, the t = 4 deposit,
    energy residual, cost. The run is advanced from one time of :data:`TIMES` to the next (the
    time step lands on them either way: the case's front record is due there)."""
    cfg = config(a, n, stop_time)
    case = CASES.get(CASE)
    sim = case.setup(cfg)
    quantiles: dict[str, list] = {f"{q:g}": [] for q in QUANTILES}
    t0, c0 = time.perf_counter(), time.process_time()
    for t in [t for t in TIMES if t < stop_time] + [stop_time]:
        sim.stop_time = t
        sim.run()
        if t in TIMES:
            g = sim.model.grid
            h = dg.deposit_thickness(g, sim.state.phi, sim.model.material.phi_max)
            for q in QUANTILES:
                quantiles[f"{q:g}"].append(dg.mass_quantile_front(g.xf, h, q))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    diag = case.diagnostics(sim, cfg)
    b = sim.budget
    return {"a": a, "n": n, "t_end": float(sim.state.t), "steps": int(sim.state.step),
            "fronts": [diag["front_at"].get(f"{t:g}") for t in TIMES], "quantiles": quantiles,
            "profile_x": diag["final_profile"]["x"], "profile_h": diag["final_profile"]["h"],
            "h0": diag["final_height_at_wall"], "d": diag["d"],
            "energy_residual_rel": b.residual / b.released if b.released > 0 else None,
            "picard_not_converged": int(sim.totals.not_converged), "wall_s": wall, "cpu_s": cpu,
            "advection": sim.model.advection.value}


QUICK_ASPECT, QUICK_N, QUICK_STOP = 1.42, 16, 0.2
"""The ``--quick`` smoke run: a = 1.42 on 16^2 cells to t = 0.2 (nothing saved)."""


def run(resolution: int = QUICK_N, quick: bool = False, a: float = QUICK_ASPECT) -> dict:
    """One level (:func:`run_one`): the column of aspect ``a`` on ``resolution``^2 cells to t = 4,
    or to :data:`QUICK_STOP` with ``quick``."""
    return run_one(a, resolution, stop_time=QUICK_STOP if quick else TIMES[-1])


def compare(run: dict) -> dict:
    """Relative front differences and profile differences against Basilisk at the same n."""
    ref = BASILISK.get(run["a"], {}).get(run["n"])
    if ref is None:
        return {}
    rel = [None if (b is None or g is None) else (g - b) / b for g, b in zip(run["fronts"], ref["fronts"])]
    out = {"front_rel": rel}
    if "quantiles" in ref and "quantiles" in run:
        out["quantile_rel"] = {q: [(g - b) / b for g, b in zip(run["quantiles"][q], ref["quantiles"][q])]
                               for q in ref["quantiles"] if q in run["quantiles"]}
    if "h" in ref:
        out["profile_diff"] = [g - b for g, b in zip(run["profile_h"], ref["h"])]
    return out


def analyse(results: dict) -> dict:
    """Per a: comparisons per level and the Richardson estimate of the t = 4 front."""
    out = {}
    for a in sorted({r["a"] for r in results.values()}):
        runs = sorted((r for r in results.values() if r["a"] == a), key=lambda r: r["n"])
        finals = [r["fronts"][-1] for r in runs if r["fronts"][-1] is not None]
        levels = [r["n"] for r in runs if r["fronts"][-1] is not None]
        ok = len(levels) >= 2 and all(b == 2 * c for c, b in zip(levels, levels[1:]))
        qruns = [r for r in runs if "quantiles" in r]
        qok = len(qruns) >= 2 and all(b["n"] == 2 * c["n"] for c, b in zip(qruns, qruns[1:]))
        out[f"{a:g}"] = {"levels": levels, "compare": {str(r["n"]): compare(r) for r in runs},
                         "front4_extrapolated": richardson(finals) if ok else None,
                         "quantile4_extrapolated": {f"{q:g}": richardson([r["quantiles"][f"{q:g}"][-1] for r in qruns])
                                                    for q in QUANTILES} if qok else None,
                         "contact_dynamics": CONTACT_DYNAMICS.get(a)}
    return out


def _fmt(x, spec=".3f"):
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def report(results: dict) -> str:
    lines = ["| a | n | granflow front t = 1, 2, 3, 4 | Basilisk (same n) | worst | h(0) granflow / Basilisk "
             "| energy residual | CPU s |", "|---|---:|---|---|---:|---|---:|---:|"]
    ana = analyse(results)
    for r in sorted(results.values(), key=lambda r: (r["a"], r["n"])):
        ref = BASILISK.get(r["a"], {}).get(r["n"], {})
        cmp_ = compare(r)
        worst = max((abs(v) for v in cmp_.get("front_rel", []) if v is not None), default=None)
        h0b = ref["h"][0] if ref.get("h") else None
        lines.append(f"| {r['a']:g} | {r['n']} | {', '.join(_fmt(f) for f in r['fronts'])} | "
                     f"{', '.join(_fmt(f) for f in ref.get('fronts', ())) or '–'} | "
                     f"{_fmt(None if worst is None else 100 * worst, '.1f')} % | {_fmt(r['h0'])} / {_fmt(h0b)} | "
                     f"{_fmt(100 * r['energy_residual_rel'] if r['energy_residual_rel'] is not None else None, '+.1f')} % | "
                     f"{r['cpu_s']:.0f} |")
    lines += ["", "Mass-quantile fronts x_q (the x left of which q of the deposit volume lies) at t = 1, 2, 3, 4:",
              "", "| a | n | q | granflow | Basilisk (same n) | worst |", "|---|---:|---:|---|---|---:|"]
    for r in sorted(results.values(), key=lambda r: (r["a"], r["n"])):
        ref = BASILISK.get(r["a"], {}).get(r["n"], {})
        rel = compare(r).get("quantile_rel", {})
        for q, xs in r.get("quantiles", {}).items():
            b = ref.get("quantiles", {}).get(q, ())
            worst = max((abs(v) for v in rel.get(q, [])), default=None)
            lines.append(f"| {r['a']:g} | {r['n']} | {q} | {', '.join(_fmt(x) for x in xs)} | "
                         f"{', '.join(_fmt(x) for x in b) or '–'} | "
                         f"{_fmt(None if worst is None else 100 * worst, '.1f')} % |")
    lines += ["", "| a | t = 4 front, Richardson (levels) | contact dynamics (final) |", "|---|---|---|"]
    for a, v in ana.items():
        est = v["front4_extrapolated"]
        txt = "–" if est is None else f"{est['value']:.3f} ± {est['uncertainty']:.3f} ({est['method']}, {v['levels']})"
        cd = v["contact_dynamics"]
        lines.append(f"| {a} | {txt} | {cd[0]}–{cd[1]} |" if cd else f"| {a} | {txt} | – |")
    lines += ["", "| a | t = 4 x_q, Richardson (granflow's levels) | Basilisk's x_q at 128, 256, 512 |", "|---|---|---|"]
    for a, v in ana.items():
        for q, est in (v.get("quantile4_extrapolated") or {}).items():
            ref = BASILISK.get(float(a), {})
            bas = ", ".join(_fmt(ref[n]["quantiles"][q][-1]) for n in sorted(ref) if "quantiles" in ref[n])
            lines.append(f"| {a} | x_{q} = {est['value']:.3f} ± {est['uncertainty']:.3f} ({est['method']}) | {bas} |")
    for a, v in ana.items():
        for n, c in v["compare"].items():
            if "profile_diff" in c:
                lines.append(f"\nh(x) - h_Basilisk at t = 4, a = {a}, n = {n} (x = 0, 0.5, ..., 3.5): "
                             + ", ".join(f"{d:+.3f}" for d in c["profile_diff"])
                             + f"; largest {max(abs(d) for d in c['profile_diff']):.3f} H0")
    return "\n".join(lines)


def load_results(path: Path = RESULTS) -> dict:
    return load_json(path, {"runs": {}})["runs"]


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default=",".join(map(str, LEVELS)))
    ap.add_argument("--aspects", default=",".join(f"{a:g}" for a in ASPECTS))
    ap.add_argument("--force", action="store_true", help="redo runs already in results.json")
    ap.add_argument("--report", action="store_true", help="only print the tables")
    ap.add_argument("--quick", action="store_true", help="a = 1.42 at 16^2 to t = 0.2, nothing saved")
    args = ap.parse_args(argv)
    if args.quick:
        r = run(QUICK_N, quick=True)
        print(f"quick: a = {QUICK_ASPECT}, {QUICK_N}^2, t = {r['t_end']:.2f}: {r['steps']} steps, "
              f"h(0) = {r['h0']:.3f}")
        return {"quick": r}
    results = load_results()
    if not args.report:
        for a in (float(s) for s in args.aspects.split(",") if s):
            for n in (int(s) for s in args.levels.split(",") if s):
                key = f"{a:g}:{n}"
                if key in results and not args.force:
                    continue
                results[key] = run_one(a, n)
                RESULTS.write_text(json.dumps({"runs": results, "analysis": analyse(results)}, indent=1))
                print(f"{key}: fronts {results[key]['fronts']}, {results[key]['cpu_s']:.0f} s CPU", flush=True)
    print(report(results))
    return results


if __name__ == "__main__":
    main()
