"""Roche's channel on a slope, issue 13 item 3e: run-out against slope angle, fluidised and dry.

The channel of examples/roche_channel.toml (a 0.2 m x 0.4 m column of 80 um glass beads fluidised
by injection at U_mf, gas supply stopped at release, rough base) and its dry twin
examples/roche_channel_dry.toml, with the whole box tilted by ``gravity.slope_deg`` = 0, 5, 10,
15, 20 deg, on 2 cm cells (validation/roche/run.py's ``channel_run``). Chedeville & Roche (2015,
Bull. Volcanol. 77:96) released such columns (d = 80 um) into a channel inclined at 0-30 deg and
found the run-out gain of the fluidised flows "reduced at slope angle higher than ~12 deg", which
they attribute to the flow head thinning and to the settling of particles into the interstices of
the rough substrate -- an air supply from the substrate ("autofluidisation") that the model does
not have. Their values were not digitised here: the comparison is with that statement only.

Measured per slope: the run-out at rest (the run's front, threshold 1 cm: ``runout_rest_m``),
the mass-quantile fronts x_0.5, x_0.9, x_0.99 of the final deposit beyond the gate (robust to the
one-cell distal tongue), their fluidised/dry ratios, and whether a run reached the channel's end.
Slopes at and above the closure's static friction angle atan(sin delta) = 24.2 deg are left out:
the dry flow would not stop there.

Run:   python validation/roche/slope.py [--quick] [--slopes 0,5,10,15,20] [--dx 0.02] [--report]
Time:  ~25 min on one core (10 runs of 1-3 min); ``--quick``: 4 cm cells, 0.4 s, slopes 0 and 10.
Output: slope.json and slope.png beside this script (not with --quick; ``--slopes`` replaces those
slopes' rows and keeps the others), the table on stdout.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import run as channel  # noqa: E402  (validation/roche/run.py: the channel runs)

SLOPES = (0.0, 5.0, 10.0, 15.0, 20.0)
CHANNEL_LENGTH_M = {15.0: 6.0, 20.0: 10.0}
"""Channel beyond the gate [m] where the examples' 3 m is too short (measured: at 15 deg both
runs reached its end); the other slopes keep 3 m."""
LONG_STOP_S = 8.0
"""Stop time of those runs [s] (an upper bound: they end at rest; the examples' 3 s is too short)."""
QUICK_SLOPES = (0.0, 10.0)
SLOPE_JSON, FIG_SLOPE = HERE / "slope.json", HERE / "slope.png"
KEEP = ("state", "dx_m", "H0_m", "L0_m", "status", "t_final_s", "t_rest_s", "runout_m", "runout_rest_m",
        "wall_contact", "wall_s", "front_speed_m_s", "front_speed_over_sqrt_2gH0", "t_stop_s", "x_quantile_m")


def slope_run(state: str, slope: float, dx: float, quick: bool) -> dict:
    """One run: the channel of ``state`` tilted by ``slope`` [deg]; the numbers of slope.json."""
    more = [f"gravity.slope_deg={slope:g}"]
    if slope in CHANNEL_LENGTH_M and not quick:
        lx = CHANNEL_LENGTH_M[slope] + 0.2  # the reservoir, 0.2 m
        more += [f"grid.Lx={lx:g}", f"grid.nx={round(lx / dx)}", f"time.stop_time={LONG_STOP_S:g}"]
    r = channel.channel_run(state, dx, quick, more=tuple(more), tag=f"_slope{slope:g}")
    out = {k: r[k] for k in KEEP if k in r}
    out["slope_deg"] = slope
    out["x_quantile_beyond_gate_m"] = {q: x - r["L0_m"] for q, x in r["x_quantile_m"].items()}
    return out


def ratios(rows: list[dict]) -> list[dict]:
    """Per slope: the fluidised/dry ratios of the run-out at rest and of the quantile fronts
    beyond the gate; ``cut`` when either run reached a wall (its run-out is a lower bound)."""
    out = []
    for slope in sorted({r["slope_deg"] for r in rows}):
        f, d = (next(r for r in rows if r["slope_deg"] == slope and r["state"] == s) for s in ("fluidised", "dry"))
        entry = {"slope_deg": slope, "cut": bool(f["wall_contact"] or d["wall_contact"]),
                 "runout_fluidised_m": f["runout_rest_m"], "runout_dry_m": d["runout_rest_m"],
                 "ratio_runout": f["runout_rest_m"] / d["runout_rest_m"] if d["runout_rest_m"] else None}
        for q, xf in f["x_quantile_beyond_gate_m"].items():
            xd = d["x_quantile_beyond_gate_m"][q]
            entry[f"ratio_x{q}"] = xf / xd if xd > 0 else None
        out.append(entry)
    return out


def table(rows: list[dict]) -> str:
    lines = ["| slope [deg] | run-out fluidised / dry [m] | ratio | x_0.9 beyond gate fl. / dry [m] | ratio | "
             "x_0.99 fl. / dry [m] | ratio | rest fl. / dry [s] | walls |", "|---|---|---|---|---|---|---|---|---|"]
    for e in ratios(rows):
        f, d = (next(r for r in rows if r["slope_deg"] == e["slope_deg"] and r["state"] == s)
                for s in ("fluidised", "dry"))
        qf, qd = f["x_quantile_beyond_gate_m"], d["x_quantile_beyond_gate_m"]
        lines.append(
            f"| {e['slope_deg']:g} | {f['runout_rest_m']:.3f} / {d['runout_rest_m']:.3f} | {_f(e['ratio_runout'])} | "
            f"{qf['0.9']:.3f} / {qd['0.9']:.3f} | {_f(e['ratio_x0.9'])} | {qf['0.99']:.3f} / {qd['0.99']:.3f} | "
            f"{_f(e['ratio_x0.99'])} | {_f(f['t_rest_s'], '.2f')} / {_f(d['t_rest_s'], '.2f')} | "
            f"{_state(e, f, d)} |")
    return "\n".join(lines)


def _state(e: dict, f: dict, d: dict) -> str:
    """The row's caveat: a run cut by the channel's end, or still moving at its stop time."""
    if e["cut"]:
        return "reached the end (lower bound)"
    moving = [r["state"] for r in (f, d) if r["t_rest_s"] is None]
    return f"clear; {' and '.join(moving)} still moving at {f['t_final_s']:g} s (not final)" if moving else "clear"


def _f(v, spec: str = ".3f") -> str:
    return "n/a" if v is None else format(v, spec)


def figure(rows: list[dict], path: Path = FIG_SLOPE) -> Path:
    """slope.png: run-out and x_0.99 against slope (left), their fluidised/dry ratios (right)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11.0, 4.2))
    for state, colour in (("fluidised", "C3"), ("dry", "C0")):
        sel = sorted((r for r in rows if r["state"] == state), key=lambda r: r["slope_deg"])
        s = [r["slope_deg"] for r in sel]
        ax[0].plot(s, [r["runout_rest_m"] for r in sel], "o-", color=colour, label=f"{state}: run-out at rest")
        ax[0].plot(s, [r["x_quantile_beyond_gate_m"]["0.99"] for r in sel], "s--", color=colour,
                   label=f"{state}: x_0.99 beyond the gate")
    e = ratios(rows)
    s = [r["slope_deg"] for r in e]
    ax[1].plot(s, [r["ratio_runout"] for r in e], "o-", color="k", label="run-out ratio")
    ax[1].plot(s, [r["ratio_x0.99"] for r in e], "s--", color="0.4", label="x_0.99 ratio")
    ax[1].axvline(12.0, ls=":", color="C2", label="gain drops above ~12 deg (Chedeville & Roche 2015)")
    for r in rows:  # runs cut off while moving: their points are not final
        if r["t_rest_s"] is None and r["state"] == "fluidised":
            ax[1].annotate(f"still moving at {r['t_final_s']:g} s", (r["slope_deg"], 1.0), fontsize=8,
                           ha="right", color="C3")
    ax[0].set(xlabel="slope [deg]", ylabel="distance beyond the gate [m]", title="granflow, Roche's channel, 2 cm cells")
    ax[1].set(xlabel="slope [deg]", ylabel="fluidised / dry", title="run-out gain (no digitised data)")
    for a in ax:
        a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def run(resolution: float = channel.CHANNEL_DX, quick: bool = False, slopes=None) -> list[dict]:
    """The rows (fluidised and dry per slope) on cells ``resolution`` [m] (the validations'
    common shape; ``quick``: 4 cm cells, 0.4 s, :data:`QUICK_SLOPES`)."""
    slopes = slopes or (QUICK_SLOPES if quick else SLOPES)
    dx = channel.QUICK_DX if quick else resolution
    rows = []
    for slope in slopes:
        for state in ("fluidised", "dry"):
            rows.append(slope_run(state, slope, dx, quick))
            r = rows[-1]
            print(f"slope {slope:g} {state}: run-out {r['runout_rest_m']:.3f} m, x_0.99 beyond the gate "
                  f"{r['x_quantile_beyond_gate_m']['0.99']:.3f} m, rest {r['t_rest_s']}, walls "
                  f"{r['wall_contact'] or 'clear'}, {r['wall_s']:.0f} s", flush=True)
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="4 cm cells, 0.4 s, slopes 0 and 10")
    ap.add_argument("--slopes", default=None, help="comma-separated slope angles [deg]")
    ap.add_argument("--dx", type=float, default=channel.CHANNEL_DX, help="cells [m]")
    ap.add_argument("--report", action="store_true", help="table and slope.png from the stored slope.json")
    args = ap.parse_args(argv)
    if args.report:
        rows = json.loads(SLOPE_JSON.read_text())["rows"]
        figure(rows)
        print(table(rows))
        return rows
    slopes = tuple(float(s) for s in args.slopes.split(",")) if args.slopes else None
    dx = channel.QUICK_DX if args.quick else args.dx
    rows = run(dx, args.quick, slopes)
    if not args.quick:
        rows = merged(rows, dx)
        SLOPE_JSON.write_text(json.dumps({"dx_m": dx, "rows": rows, "ratios": ratios(rows)}, indent=1) + "\n")
        figure(rows)
    print(table(rows))
    return rows


def merged(rows: list[dict], dx: float) -> list[dict]:
    """``rows`` and the stored rows of slope.json at the same ``dx`` for the other slopes (so
    that ``--slopes 15,20`` redoes those two only)."""
    if not SLOPE_JSON.exists():
        return rows
    stored = json.loads(SLOPE_JSON.read_text())
    if stored.get("dx_m") != dx:
        return rows
    done = {r["slope_deg"] for r in rows}
    return sorted([r for r in stored["rows"] if r["slope_deg"] not in done] + rows,
                  key=lambda r: (r["slope_deg"], r["state"] != "fluidised"))


if __name__ == "__main__":
    main()
