"""The figure a referee asks of each verification case, drawn from ``summary.json`` (and output.nc)
at the end of ``granflow run`` (``output.figures``), beside :func:`granflow.plotting.run_figures`:

* ``basal_pressure.png`` (defluidisation_column): basal p_f against the Fourier series, and the
  error;
* ``profile.png`` (inclined_layer): u(z) of the grain cells against the Bagnold profile, u_s(t)
  against Bagnold's u_s;
* ``relaxation.png`` (sheared_layer): phi(t) against its reference solution;
* ``pressure.png`` (static_layer): p(z) against the lithostatic pressure, and the error.

Other cases: none. matplotlib is imported lazily (Agg backend), as in :mod:`granflow.plotting`.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from granflow.figure_layout import save_figure
from granflow.plotting import FIGURE_DPI, _pyplot, run_field

NAN = float("nan")
LEGEND_SIZE = TITLE_SIZE = "small"
MARKER_SIZE = 4
BAGNOLD_POINTS = 200
"""Points of the drawn Bagnold profile."""
PERCENT = 100.0
TWO_PANELS_TALL, TWO_PANELS_WIDE, ONE_PANEL = (7, 6), (10, 4), (7, 4)
"""Figure sizes [in]."""


def _defluidisation(nc_path: Path, summary: dict, outdir: Path) -> Path | None:
    d = summary.get("case_diagnostics") or {}
    rec = d.get("basal_record")
    if not rec:
        return None
    t = np.asarray(rec["t_s"], dtype=float)
    pf, series = np.asarray(rec["p_f_Pa"], dtype=float), np.asarray(rec["series_Pa"], dtype=float)
    fig, (a, b) = _pyplot().subplots(2, 1, figsize=TWO_PANELS_TALL, sharex=True, constrained_layout=True)
    a.plot(t, series, "k-", label="Fourier series (rigid column)")
    a.plot(t, pf, "o", color="tab:blue", ms=MARKER_SIZE,
           label=f"granflow, bottom cell (z = {rec['z_m']:.3g} m)")
    a.set_ylabel("basal pore pressure p_f [Pa]")
    a.legend(fontsize=LEGEND_SIZE)
    a.set_title(f"defluidisation: half-life {d.get('half_life_s') or NAN:.4g} s, series "
                f"{d.get('series_half_life_s') or NAN:.4g} s (tau_1 = {d.get('tau_1_s', NAN):.3g} s)",
                fontsize=TITLE_SIZE)
    amp = float(d.get("p_f0_base_Pa") or 1.0)
    b.plot(t, (pf - series) / amp, "o-", color="tab:blue", ms=MARKER_SIZE - 1)
    b.axhline(0.0, color="k", lw=0.5)
    b.set_xlabel("t [s]")
    b.set_ylabel("(p_f - series) / p_f0 [-]")
    return save_figure(fig, outdir / "basal_pressure.png", FIGURE_DPI)


def _inclined(nc_path: Path, summary: dict, outdir: Path) -> Path | None:
    d = summary.get("case_diagnostics") or {}
    if not d.get("u_surface_record"):
        return None
    import xarray as xr

    fig, (a, b) = _pyplot().subplots(1, 2, figsize=TWO_PANELS_WIDE, constrained_layout=True)
    with xr.open_dataset(nc_path) as ds:
        u = run_field(ds.load(), "u").isel(time=-1).mean("x", skipna=True)
        z = ds["z"].values
    a.plot(u.values, z, "o", color="tab:blue", ms=MARKER_SIZE, label="granflow (grain cells, mean over x)")
    bagnold = d.get("u_surface_bagnold_m_s")
    if bagnold is not None:
        h = float(d["h_m"])
        zz = np.linspace(0.0, h, BAGNOLD_POINTS)
        a.plot(bagnold * (1.0 - (1.0 - zz / h) ** 1.5), zz, "k-", label="Bagnold")
    a.set_xlabel("u [m s-1]")
    a.set_ylabel("z [m]")
    a.legend(fontsize=LEGEND_SIZE)
    a.set_title("velocity profile at the last record", fontsize=TITLE_SIZE)
    rec = d["u_surface_record"]
    b.plot(rec["t_s"], rec["u_m_s"], "-", color="tab:blue", label="surface speed u_s")
    if bagnold is not None:
        b.axhline(bagnold, color="k", ls="--", label="Bagnold u_s")
    b.set_xlabel("t [s]")
    b.set_ylabel("u_s [m s-1]")
    b.legend(fontsize=LEGEND_SIZE)
    b.set_title(f"u_s error {PERCENT * (d.get('u_surface_rel_error') or NAN):+.2f} %", fontsize=TITLE_SIZE)
    return save_figure(fig, outdir / "profile.png", FIGURE_DPI)


def _sheared(nc_path: Path, summary: dict, outdir: Path) -> Path | None:
    d = summary.get("case_diagnostics") or {}
    rec = d.get("phi_record")
    if not rec:
        return None
    fig, ax = _pyplot().subplots(figsize=ONE_PANEL, constrained_layout=True)
    ax.plot(rec["t_s"], rec["reference"], "k-", label=str(d.get("reference", "reference")))
    ax.plot(rec["t_s"], rec["phi"], "o", color="tab:blue", ms=MARKER_SIZE, label="granflow")
    ax.axhline(d.get("phi_eq", NAN), color="k", ls=":", lw=0.8, label="phi_eq(I)")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("packing fraction phi [-]")
    ax.legend(fontsize=LEGEND_SIZE)
    ax.set_title(f"homogeneous shear: max error {d.get('max_error_rel') or NAN:.2e} of |phi0 - phi_eq|",
                 fontsize=TITLE_SIZE)
    return save_figure(fig, outdir / "relaxation.png", FIGURE_DPI)


def _static(nc_path: Path, summary: dict, outdir: Path) -> Path | None:
    d = summary.get("case_diagnostics") or {}
    rec = d.get("pressure_profile")
    if not rec:
        return None
    z = np.asarray(rec["z_m"], dtype=float)
    p, ref = np.asarray(rec["p_Pa"], dtype=float), np.asarray(rec["reference_Pa"], dtype=float)
    full = np.asarray(rec["full"], dtype=bool)
    fig, (a, b) = _pyplot().subplots(1, 2, figsize=TWO_PANELS_WIDE, sharey=True, constrained_layout=True)
    a.plot(ref, z, "k-", label="lithostatic phi0 rho_s |g_z| (H - z)")
    a.plot(p, z, "o", color="tab:blue", ms=MARKER_SIZE, label="granflow (mean over x)")
    a.axhline(float(d.get("H_m", NAN)), color="k", ls=":", lw=0.8, label="layer top z = H")
    a.set_xlabel("granular pressure p [Pa]")
    a.set_ylabel("z [m]")
    a.legend(fontsize=LEGEND_SIZE)
    a.set_title("pressure profile at the last record", fontsize=TITLE_SIZE)
    scale = float(np.max(ref)) if ref.size and np.max(ref) > 0 else 1.0
    b.plot((p[full] - ref[full]) / scale, z[full], "o-", color="tab:blue", ms=MARKER_SIZE - 1)
    b.axvline(0.0, color="k", lw=0.5)
    b.set_xlabel("(p - lithostatic) / p_base [-]")
    b.set_title(f"completely filled cells: largest error {d.get('pressure_rel_error') or NAN:.2e}",
                fontsize=TITLE_SIZE)
    return save_figure(fig, outdir / "pressure.png", FIGURE_DPI)


FIGURES: dict[str, Callable[[Path, dict, Path], Path | None]] = {
    "defluidisation_column": _defluidisation, "inclined_layer": _inclined,
    "sheared_layer": _sheared, "static_layer": _static}
"""Case name -> the function drawing its reference figure (None when the summary lacks the data)."""


def case_figures(nc_path: str | Path, summary: dict, outdir: str | Path) -> list[Path]:
    """The reference figure of the case of ``summary`` (:data:`FIGURES`), written to ``outdir``;
    empty for a case without one."""
    draw = FIGURES.get(summary.get("case"))
    path = draw(Path(nc_path), summary, Path(outdir)) if draw is not None else None
    return [] if path is None else [path]
