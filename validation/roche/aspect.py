"""Roche's channel at other aspect ratios, issue 13 item 3a: the run-out ratio fluidised/dry of the
injection protocol at a = H0/L0 = 0.5, 1, 2, 4, on the mass-quantile fronts.

The channel of examples/roche_channel.toml (column height H0 = 0.4 m of 80 um glass beads,
fluidised by injection at U_mf, gas supply stopped at release, rough base) and its dry twin, with
the reservoir length L0 = H0/a (0.8, 0.4, 0.2, 0.1 m) and the same 3 m channel beyond the gate
(validation/roche/run.py's ``channel_run``). Measured per run: the thickness-threshold run-out at
rest (the run's front, 1 cm) and the mass-quantile fronts x_0.9 (bulk) and x_0.99 (sheet) of the
final deposit beyond the gate, normalised by L0; their fluidised/dry ratios per level, and across
the levels the change of each ratio (the uncertainty quoted is the difference between the two
finest levels: with two levels no order can be fitted). Roche (2012) reports fluidised run-outs
about twice the dry ones (as quoted in issue 13; no data digitised here).

Every level runs at ``time.dt_max`` = :data:`DT_MAX` (0.25 ms; not ``--quick``).

Run:   python validation/roche/aspect.py [--quick] [--dx 0.02,0.01] [--aspects 0.5,1,2,4] [--report]
Time:  (at 0.25 ms) see validation/roche/README.md; ``--quick``: 4 cm cells, 0.4 s, a = 1, the
       examples' dt_max.
Output: aspect.json beside this script (not with --quick; new levels and aspects are merged into
the stored ones at the same dt_max after each aspect ratio, under a lock, so that two calls with
different aspects can run side by side; an (a, dx) whose L0 is not a whole number of cells is
skipped), the table on stdout.
"""
from __future__ import annotations

import argparse
import fcntl
import json
import sys
from pathlib import Path

from granflow.verification.convergence import mesh_estimate

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import run as channel  # noqa: E402  (validation/roche/run.py: the channel runs)

ASPECTS = (0.5, 1.0, 2.0, 4.0)
H0, CHANNEL_M = 0.4, 3.0
"""Column height [m] (the example's) and channel length beyond the gate [m]."""
ASPECT_JSON = HERE / "aspect.json"
DT_MAX = 2.5e-4
"""time.dt_max of every level [s] (the examples' 1e-3 until session 26). With one solve per step
(the defaults since session 25) the coarse levels, which run at dt_max, carried an O(dt) error as
large as the mesh error: at a = 4 the 1 ms bulk ratios 1.363, 1.352, 1.340 (2, 1, 0.5 cm) fell
~0.9 % a halving, at 0.25 ms they are 1.354, 1.347, 1.349 (validation/roche/README.md; as
validation/dry_runout's ``DT_MAX``)."""
STORED_DT_MAX = 1e-3
"""dt_max [s] of stored rows that do not record theirs (those of sessions 20-25)."""
KEEP = ("state", "dx_m", "L0_m", "status", "t_rest_s", "runout_rest_m", "wall_contact", "wall_s", "x_quantile_m")


def aspect_run(state: str, a: float, dx: float, quick: bool) -> dict:
    """One run at aspect ratio ``a`` on cells ``dx`` [m]."""
    L0 = H0 / a
    lx = L0 + CHANNEL_M
    more = (f"setup.L0={L0:g}", f"grid.Lx={lx:g}", f"grid.nx={round(lx / dx)}")
    more += () if quick else (f"time.dt_max={DT_MAX:g}",)
    r = channel.channel_run(state, dx, quick, more=more, tag=f"_a{a:g}")
    out = {k: r[k] for k in KEEP if k in r}
    out.update(a=a, beyond_gate_m={q: x - L0 for q, x in r["x_quantile_m"].items()})
    if not quick:
        out["dt_max_s"] = DT_MAX
    return out


def whole_cells(length: float, dx: float) -> bool:
    """Whether ``length`` [m] is a whole number of cells ``dx`` [m] (to 1e-9 of a cell)."""
    return abs(length / dx - round(length / dx)) < 1e-9 and round(length / dx) >= 1


def run(resolution: float = channel.CHANNEL_DX, quick: bool = False, aspects=None) -> list[dict]:
    """The rows (fluidised and dry per aspect ratio) on cells ``resolution`` [m]."""
    aspects = aspects or ((1.0,) if quick else ASPECTS)
    dx = channel.QUICK_DX if quick else resolution
    rows = []
    for a in aspects:
        if not quick and not whole_cells(H0 / a, dx):
            print(f"a = {a:g} skipped at dx {dx * 100:g} cm: L0 = {H0 / a:g} m is not a whole number of "
                  "cells (the gate is a cell face)", flush=True)
            continue
        for state in ("fluidised", "dry"):
            rows.append(aspect_run(state, a, dx, quick))
            r = rows[-1]
            print(f"a = {a:g} {state} dx {dx * 100:g} cm: run-out {r['runout_rest_m']:.3f} m, x_0.9 / x_0.99 "
                  f"beyond the gate {r['beyond_gate_m']['0.9']:.3f} / {r['beyond_gate_m']['0.99']:.3f} m, "
                  f"rest {r['t_rest_s']}, walls {r['wall_contact'] or 'clear'}, {r['wall_s']:.0f} s", flush=True)
    return rows


def ratios(rows: list[dict]) -> list[dict]:
    """Per (a, dx): fluidised/dry ratios of the threshold run-out, x_0.9 and x_0.99 beyond the gate."""
    out = []
    for a, dx in sorted({(r["a"], r["dx_m"]) for r in rows}):
        f, d = (next(r for r in rows if r["a"] == a and r["dx_m"] == dx and r["state"] == s)
                for s in ("fluidised", "dry"))
        out.append({"a": a, "dx_m": dx, "cut": bool(f["wall_contact"] or d["wall_contact"]),
                    "moving": f["t_rest_s"] is None or d["t_rest_s"] is None,
                    "runout": f["runout_rest_m"] / d["runout_rest_m"],
                    "x0.9": f["beyond_gate_m"]["0.9"] / d["beyond_gate_m"]["0.9"],
                    "x0.99": f["beyond_gate_m"]["0.99"] / d["beyond_gate_m"]["0.99"]})
    return out


def table(rows: list[dict]) -> str:
    lines = ["| a | dx [cm] | run-out/L0 fl. / dry | ratio | x_0.9/L0 fl. / dry | ratio | x_0.99/L0 fl. / dry | ratio | note |",
             "|---|---|---|---|---|---|---|---|---|"]
    for e in ratios(rows):
        f, d = (next(r for r in rows if r["a"] == e["a"] and r["dx_m"] == e["dx_m"] and r["state"] == s)
                for s in ("fluidised", "dry"))
        L0 = f["L0_m"]
        note = "reached the end" if e["cut"] else "still moving" if e["moving"] else "clear"
        lines.append(f"| {e['a']:g} | {e['dx_m'] * 100:g} | {f['runout_rest_m'] / L0:.2f} / {d['runout_rest_m'] / L0:.2f} | "
                     f"{e['runout']:.3f} | {f['beyond_gate_m']['0.9'] / L0:.2f} / {d['beyond_gate_m']['0.9'] / L0:.2f} | "
                     f"{e['x0.9']:.3f} | {f['beyond_gate_m']['0.99'] / L0:.2f} / {d['beyond_gate_m']['0.99'] / L0:.2f} | "
                     f"{e['x0.99']:.3f} | {note} |")
    return "\n".join(lines)


CONVERGED_KEYS = ("x0.9", "runout", "x0.99")
LEVELS = 3
"""Levels of the mesh estimate: the three finest cell sizes of each aspect ratio."""


def converged(rows: list[dict]) -> list[dict]:
    """Per aspect ratio with at least two levels: the mesh estimate of each fluidised/dry ratio
    over its three finest levels (coarse to fine; granflow.verification.convergence.mesh_estimate:
    3-level Richardson with Roache's GCI if monotone, the finest +- half the range if oscillatory,
    first order with safety factor 3 on two levels)."""
    out = []
    for a in sorted({e["a"] for e in ratios(rows)}):
        levels = sorted((e for e in ratios(rows) if e["a"] == a), key=lambda e: -e["dx_m"])[-LEVELS:]
        if len(levels) < 2:
            continue
        out.append({"a": a, "dx_m": [e["dx_m"] for e in levels],
                    **{k: mesh_estimate([e[k] for e in levels]) for k in CONVERGED_KEYS}})
    return out


def converged_table(rows: list[dict]) -> str:
    lines = ["| a | levels [cm] | x_0.9 ratio | run-out ratio | x_0.99 ratio |", "|---|---|---|---|---|"]
    for c in converged(rows):
        cells = [f"{c[k]['value']:.3f} ± {c[k]['uncertainty']:.3f} ({c[k]['method']})" for k in CONVERGED_KEYS]
        lines.append(f"| {c['a']:g} | {', '.join(f'{d * 100:g}' for d in c['dx_m'])} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def merged(rows: list[dict]) -> list[dict]:
    """``rows`` and the stored rows of aspect.json for the other (a, dx) run at the same
    :data:`DT_MAX` (rows at another dt_max are dropped: a table mixing time steps is no study)."""
    if not ASPECT_JSON.exists():
        return rows
    done = {(r["a"], r["dx_m"]) for r in rows}
    old = [r for r in json.loads(ASPECT_JSON.read_text())["rows"]
           if (r["a"], r["dx_m"]) not in done and r.get("dt_max_s", STORED_DT_MAX) == DT_MAX]
    return sorted(old + rows, key=lambda r: (r["a"], -r["dx_m"], r["state"] != "fluidised"))


def store(new: list[dict]) -> list[dict]:
    """Merge ``new`` into aspect.json and write it, holding an exclusive lock on a lock file in
    the runs' directory (two calls with different aspects may store at the same moment); the
    merged rows."""
    channel.RUN_DIR.mkdir(parents=True, exist_ok=True)
    with open(channel.RUN_DIR / "aspect.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        rows = merged(new)  # this call's rows over the stored ones (each (a, dx) once)
        ASPECT_JSON.write_text(json.dumps({"rows": rows, "ratios": ratios(rows), "converged": converged(rows)},
                                          indent=1) + "\n")
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="4 cm cells, 0.4 s, a = 1")
    ap.add_argument("--dx", default="0.02", help="comma-separated cell sizes [m]")
    ap.add_argument("--aspects", default=None, help="comma-separated aspect ratios")
    ap.add_argument("--report", action="store_true", help="the tables from aspect.json (no runs)")
    args = ap.parse_args(argv)
    if args.report:
        rows = json.loads(ASPECT_JSON.read_text())["rows"]
        print(table(rows) + "\n\n" + converged_table(rows))
        return rows
    aspects = tuple(float(a) for a in args.aspects.split(",")) if args.aspects else None
    rows = new = []
    for dx in ([None] if args.quick else [float(v) for v in args.dx.split(",")]):
        for a in aspects or ASPECTS if not args.quick else (None,):
            new = new + run(dx, args.quick, None if a is None else (a,))
            rows = new
            if not args.quick:  # stored after each aspect ratio: a later failure loses nothing
                rows = store(new)
    print(table(rows) + "\n\n" + converged_table(rows))
    return rows


if __name__ == "__main__":
    main()
