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

Run:   python validation/roche/run.py [--quick]
Time:  ~4 min on one core (``--quick``: the small bed at 1.3 U_mf only, ~5 s).
Output: results.json beside this script (not with --quick) and the table on stdout.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from granflow.casekit import preparation as prep
from granflow.config import CaseConfig

HERE = Path(__file__).resolve().parent
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


def main(argv: list[str] | None = None) -> list[dict]:
    """Run the table (module docstring); returns its rows."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small bed at 1.3 U_mf only")
    args = ap.parse_args(argv)
    runs = [QUICK] if args.quick else [(b, r) for b in BEDS for r in RATIOS]
    rows = []
    for bed, ratio in runs:
        d = run(bed, args.quick, ratio)
        row = {"bed": bed, "U_over_Umf": ratio, **{k: d[k] for k in (
            "prep_phi_expected", "prep_phi_mean", "prep_phi_error", "prep_steady", "prep_time_s",
            "prep_expansion_time_s", "prep_max_speed_m_s", "prep_height_drift_m_s", "prep_pf_rate_Pa_s",
            "prep_bed_height_m", "prep_wall_s")}}
        rows.append(row)
        print(f"{bed:8s} U/U_mf = {ratio}: analytic phi {row['prep_phi_expected']:.5f}, granflow "
              f"{row['prep_phi_mean']:.5f} ({100 * row['prep_phi_error']:+.2f} %), steady "
              f"{row['prep_steady']} at {row['prep_time_s']:.3f} s (t_s {row['prep_expansion_time_s']:.3f} s), "
              f"max speed {row['prep_max_speed_m_s']:.2e} m/s", flush=True)
    if not args.quick:
        (HERE / "results.json").write_text(json.dumps(rows, indent=1) + "\n")
    return rows


if __name__ == "__main__":
    main()
