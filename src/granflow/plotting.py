"""Figures (matplotlib, imported lazily, Agg backend): closure curves, well-posedness maps,
growth rates. Nothing in the core imports this module."""
from __future__ import annotations

from pathlib import Path

import numpy as np

#: Pressure [Pa] at which closure curves and maps are drawn unless told otherwise.
DEFAULT_PRESSURE = 1000.0


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def closure_curves(closure, ax_z, ax_f, phis=None, p: float = DEFAULT_PRESSURE, ratio=(1e-2, 1e2)):
    """Draw Z and f against I/I_eq(phi) for a few phi on the given axes."""
    if phis is None:
        phis = closure.equilibrium.phi_eq(np.array([1e-3, 1e-2, 1e-1]))
    r = np.logspace(np.log10(ratio[0]), np.log10(ratio[1]), 400)
    for phi in np.atleast_1d(phis):
        Ieq = float(closure.I_eq(phi))
        I = r * Ieq
        label = f"phi={float(phi):.4f} (I_eq={Ieq:.2g})"
        ax_z.semilogx(r, closure.Z(phi, I), label=label)
        ax_f.semilogx(r, closure.f(phi, p, I), label=label)
    for ax, name in ((ax_z, "Z"), (ax_f, "f")):
        ax.axhline(0.0, color="k", lw=0.5)
        ax.axvline(1.0, color="k", lw=0.5, ls=":")
        ax.set_xlabel("I / I_eq(phi)")
        ax.set_ylabel(name)
    ax_f.set_ylim(-2.0, 2.0)
    ax_z.legend(fontsize="small")


def condition_map_axes(closure, ax, p: float = DEFAULT_PRESSURE, n: int = 120):
    """Shade, on a (I, phi) mesh at pressure p, the region where every condition of the checker
    holds (white) and colour the failures by the first failing condition."""
    from granflow.theory.conditions import condition_map

    phi_max = closure.material.phi_max
    phi = np.linspace(phi_max - 0.5 * closure.material.delta_phi, phi_max * (1 - 1e-6), n)
    I = np.logspace(-5, 1, n)
    maps = condition_map(closure, phi, I, p)
    names = list(maps)
    code = np.zeros((phi.size, I.size))
    for k, name in enumerate(names, start=1):
        fail = ~np.asarray(maps[name], dtype=bool)
        code = np.where((code == 0) & fail, k, code)
    cmap = _pyplot().get_cmap("tab10", len(names) + 1)
    mesh = ax.pcolormesh(I, phi, code, cmap=cmap, vmin=-0.5, vmax=len(names) + 0.5, shading="auto")
    ax.set_xscale("log")
    ax.plot(I, closure.equilibrium.phi_eq(I), "k--", lw=1, label="phi_eq(I)")
    ax.set_xlabel("I")
    ax.set_ylabel("phi")
    ax.set_ylim(phi[0], phi_max)
    ax.set_title(f"conditions at p = {p:g} Pa (colour: first failing condition)", fontsize="small")
    cb = ax.figure.colorbar(mesh, ax=ax, ticks=range(len(names) + 1))
    cb.ax.set_yticklabels(["all hold"] + [f"fails {n}" for n in names], fontsize="x-small")
    ax.legend(fontsize="small", loc="lower left")


def closure_overview(closure, path: str | Path, p: float = DEFAULT_PRESSURE):
    """Write a three-panel figure: Z and f against I/I_eq, and the well-posedness map."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2), constrained_layout=True)
    closure_curves(closure, axes[0], axes[1], p=p)
    condition_map_axes(closure, axes[2], p=p)
    fig.suptitle(f"{closure.name} {closure.parameters()}", fontsize="small")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def growth_figure(lead, curve, path: str | Path, title: str = ""):
    """Two panels: leading-order growth lambda/k^2 against direction, and finite-k growth against k
    for the most unstable direction and a few others (``granflow stability dispersion --plot``)."""
    plt = _pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    a.plot(np.degrees(lead.thetas), np.asarray(lead.growths) / lead.scale)
    a.axhline(0.0, color="k", lw=0.5)
    a.axvline(np.degrees(lead.theta), color="tab:red", ls=":", label=f"max at {np.degrees(lead.theta):.1f} deg")
    a.set_xlabel("wave-vector direction theta [deg]")
    a.set_ylabel(f"leading-order (lambda/k^2) / (eta/(phi rho_s)),  scale = {lead.scale:.3g} m^2/s")
    a.legend(fontsize="small")
    g = curve.as_array()
    k = np.asarray(curve.k)
    thetas = np.asarray(curve.theta)
    i_best = int(np.argmax(g.max(axis=1)))
    for i in sorted({i_best, 0, len(thetas) // 4, len(thetas) // 2}):
        b.plot(k, g[i], label=f"theta = {np.degrees(thetas[i]):.0f} deg" + (" (most unstable)" if i == i_best else ""))
    b.set_xscale("log")
    b.set_yscale("symlog", linthresh=1.0)
    b.axhline(0.0, color="k", lw=0.5)
    b.set_xlabel("k [1/m]")
    b.set_ylabel("growth rate max Re lambda [1/s]")
    b.legend(fontsize="small")
    fig.suptitle(title, fontsize="small")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def run_figures(nc_path: str | Path, outdir: str | Path) -> list[Path]:
    """Figures of a ``granflow run`` output file: ``snapshots.png`` (phi, and p_f when non-zero,
    at the first, middle and last records, with the granular speed) and ``front.png`` (front
    position and kinetic energy against time)."""
    import xarray as xr

    plt = _pyplot()
    outdir = Path(outdir)
    with xr.open_dataset(nc_path) as ds:
        ds = ds.load()
    n = ds.sizes["time"]
    if n == 0:
        return []
    picks = sorted({0, n // 2, n - 1})
    has_pf = "p_f" in ds and float(abs(ds["p_f"]).max()) > 0
    rows = 2 if has_pf else 1
    x, z = ds["x"].values, ds["z"].values
    fig, axes = plt.subplots(rows, len(picks), figsize=(4.6 * len(picks), 2.4 * rows + 0.6),
                             squeeze=False, constrained_layout=True)
    for k, i in enumerate(picks):
        snap = ds.isel(time=i)
        ax = axes[0, k]
        m = ax.pcolormesh(x, z, snap["phi"].values.T, vmin=0.0, vmax=float(ds.attrs.get("phi_max", 0.6)),
                          cmap="YlOrBr", shading="auto")
        if "u" in snap and "w" in snap:
            speed = np.hypot(snap["u"].values, snap["w"].values).T
            if speed.max() > 0:
                ax.contour(x, z, speed, levels=4, colors="k", linewidths=0.5)
        ax.set_aspect("equal")
        ax.set_title(f"phi, t = {float(snap['time']):.3g} s (contours: speed)", fontsize="small")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("z [m]")
        fig.colorbar(m, ax=ax, shrink=0.8)
        if has_pf:
            ax = axes[1, k]
            m = ax.pcolormesh(x, z, snap["p_f"].values.T, cmap="viridis", shading="auto")
            ax.set_aspect("equal")
            ax.set_title(f"p_f [Pa], t = {float(snap['time']):.3g} s", fontsize="small")
            ax.set_xlabel("x [m]")
            fig.colorbar(m, ax=ax, shrink=0.8)
    snap_path = outdir / "snapshots.png"
    fig.savefig(snap_path, dpi=100)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    t = ds["time"].values
    if "x_front" in ds:
        ax.plot(t, ds["x_front"].values, "k-", label="front x_f")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("front position [m]")
    if "kinetic_energy" in ds:
        ax2 = ax.twinx()
        ax2.plot(t, ds["kinetic_energy"].values, "tab:red", label="kinetic energy")
        ax2.set_ylabel("kinetic energy [J/m]", color="tab:red")
    ax.set_title(f"{ds.attrs.get('case', '')} ({ds.attrs.get('closure', '')})", fontsize="small")
    front_path = outdir / "front.png"
    fig.savefig(front_path, dpi=100)
    plt.close(fig)
    return [snap_path, front_path]
