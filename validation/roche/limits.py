"""Roche's channel, issue 13 acceptance ("if not ≈ 2, what in the model or the set-up limits it"):
the injection protocol's fluidised/dry gain with one ingredient changed at a time.

The channel of examples/roche_channel.toml at a = 2 (0.2 m x 0.4 m column of 80 um glass beads
prepared by injection at U_mf, gas supply stopped at release, rough base, 3 m channel) and its dry
twin, on 2 cm cells at ``time.dt_max`` = :data:`DT_MAX` (the aspect study's, validation/roche/aspect.py),
with these variants of the fluidised run (each against the same dry run):

* ``protocol``: the example as it is (the reference);
* ``supply_reservoir``: the gas supply kept on under the reservoir after release
  (``setup.keep_injection = "reservoir"``): is the pore pressure lost from the source the limit?
* ``supply_base``: kept on under the whole base, channel included (``"base"``): a fluidised
  substrate, an upper bound on what an air supply from below could do (Chedeville & Roche 2015's
  autofluidisation acts only where the flow passes; this one acts everywhere);
* ``expanded``: prepared at 1.1 U_mf, so the bed expands to the model's homogeneous state
  (validation/roche/run.py's expansion table) before the gate opens;
* ``adiabatic``: the adiabatic gas (``gas.compressibility``, diffusivity 1.4x larger), as other
  codes model Roche's air.

Measured per run as in aspect.py: the run-out at rest (1 cm threshold front) and the mass-quantile
front x_0.9 beyond the gate (the bulk), their ratios to the dry run, and whether the run stopped
and stayed clear of the channel's end (a run that did not is a lower bound and says so). One
level (2 cm): these are sensitivities, to compare with each other and with the protocol's
converged ratios of aspect.json, not converged values themselves.

Run:   python validation/roche/limits.py [--quick] [--variants protocol,expanded] [--report]
Time:  ~2-5 min a run on one core (6 runs); ``--quick``: 4 cm cells, 0.4 s, protocol and
       supply_reservoir.
Output: limits.json beside this script (not with --quick; ``--variants`` replaces those rows and
keeps the others), the table on stdout.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import aspect  # noqa: E402  (validation/roche/aspect.py: its DT_MAX)
import run as channel  # noqa: E402  (validation/roche/run.py: the channel runs)

VARIANTS = {
    "protocol": (),
    "supply_reservoir": ('setup.keep_injection="reservoir"',),
    "supply_base": ('setup.keep_injection="base"',),
    "expanded": ("setup.U_prep_over_Umf=1.1",),
    "adiabatic": ('gas.compressibility="adiabatic"',),
}
"""Variant name: the --set items of its fluidised run (module docstring)."""
DRY = "dry"
DT_MAX = aspect.DT_MAX
"""time.dt_max of every run [s]: the aspect study's, so that the protocol row is its a = 2, 2 cm run."""
QUICK_VARIANTS = ("protocol", "supply_reservoir")
LIMITS_JSON = HERE / "limits.json"
KEEP = ("state", "dx_m", "L0_m", "status", "t_rest_s", "runout_rest_m", "wall_contact", "wall_s", "x_quantile_m",
        "phi0", "prep")


def limit_run(variant: str, dx: float, quick: bool) -> dict:
    """The fluidised run of ``variant`` (or the dry run, ``variant = DRY``) on cells ``dx`` [m]."""
    state = "dry" if variant == DRY else "fluidised"
    more = VARIANTS.get(variant, ()) + (() if quick else (f"time.dt_max={DT_MAX:g}",))
    r = channel.channel_run(state, dx, quick, more=more, tag=f"_limits_{variant}")
    out = {k: r[k] for k in KEEP if k in r}
    out.update(variant=variant, dt_max_s=None if quick else DT_MAX,
               beyond_gate_m={q: x - r["L0_m"] for q, x in r["x_quantile_m"].items()})
    return out


def ratios(rows: list[dict]) -> list[dict]:
    """Per fluidised variant: run-out and x_0.9 ratios to the dry row; ``bounded`` when the variant
    or the dry run is still moving or reached the channel's end (its ratio is then a lower bound)."""
    dry = next(r for r in rows if r["variant"] == DRY)
    out = []
    for f in (r for r in rows if r["variant"] != DRY):
        out.append({"variant": f["variant"],
                    "bounded": bool(f["wall_contact"] or dry["wall_contact"] or f["t_rest_s"] is None
                                    or dry["t_rest_s"] is None),
                    "runout": f["runout_rest_m"] / dry["runout_rest_m"],
                    "x0.9": f["beyond_gate_m"]["0.9"] / dry["beyond_gate_m"]["0.9"]})
    return out


def table(rows: list[dict]) -> str:
    dry = next(r for r in rows if r["variant"] == DRY)
    lines = [f"dry: run-out {dry['runout_rest_m']:.3f} m, x_0.9 beyond the gate {dry['beyond_gate_m']['0.9']:.3f} m, "
             f"rest {dry['t_rest_s']}", "",
             "| variant | run-out [m] | ratio | x_0.9 beyond gate [m] | ratio | rest [s] | note |",
             "|---|---|---|---|---|---|---|"]
    for e in ratios(rows):
        f = next(r for r in rows if r["variant"] == e["variant"])
        note = ("reached the end" if f["wall_contact"] else "still moving" if f["t_rest_s"] is None
                else "clear") + (" (ratios: lower bounds)" if e["bounded"] else "")
        lines.append(f"| {e['variant']} | {f['runout_rest_m']:.3f} | {e['runout']:.3f} | "
                     f"{f['beyond_gate_m']['0.9']:.3f} | {e['x0.9']:.3f} | {f['t_rest_s']} | {note} |")
    return "\n".join(lines)


def run(resolution: float = channel.CHANNEL_DX, quick: bool = False, variants=None) -> list[dict]:
    """The dry row and one row per variant (default: all; ``quick``: :data:`QUICK_VARIANTS` on
    4 cm cells) on cells ``resolution`` [m]."""
    dx = channel.QUICK_DX if quick else resolution
    rows = [limit_run(DRY, dx, quick)]
    for name in variants or (QUICK_VARIANTS if quick else tuple(VARIANTS)):
        rows.append(limit_run(name, dx, quick))
        r = rows[-1]
        print(f"{name}: run-out {r['runout_rest_m']:.3f} m, x_0.9 beyond the gate {r['beyond_gate_m']['0.9']:.3f} m, "
              f"rest {r['t_rest_s']}, walls {r['wall_contact'] or 'clear'}, {r['wall_s']:.0f} s", flush=True)
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="4 cm cells, 0.4 s, protocol and supply_reservoir")
    ap.add_argument("--variants", default=None, help=f"comma-separated, of {', '.join(VARIANTS)}")
    ap.add_argument("--report", action="store_true", help="the table from limits.json (no runs)")
    args = ap.parse_args(argv)
    if args.report:
        rows = json.loads(LIMITS_JSON.read_text())["rows"]
        print(table(rows))
        return rows
    names = tuple(args.variants.split(",")) if args.variants else None
    unknown = [n for n in names or () if n not in VARIANTS]
    if unknown:
        ap.error(f"--variants: unknown {unknown}; expected some of {list(VARIANTS)}")
    rows = run(quick=args.quick, variants=names)
    if not args.quick:
        done = {r["variant"] for r in rows}
        old = json.loads(LIMITS_JSON.read_text())["rows"] if LIMITS_JSON.exists() else []
        rows = rows + [r for r in old if r["variant"] not in done]
        LIMITS_JSON.write_text(json.dumps({"rows": rows, "ratios": ratios(rows)}, indent=1) + "\n")
    print(table(rows))
    return rows


if __name__ == "__main__":
    main()
