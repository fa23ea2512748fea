"""Figures of a closure and of its stability (matplotlib, imported lazily, Agg backend): the
curves Z(phi, I) and f(phi, p, I) (paper eqs def:Z, def:f), the map of the well-posedness
conditions C1-C3 over (I, phi) (MODEL.md §8), and the growth rates of
:mod:`granflow.theory.dispersion` (``granflow check|stability ... --plot``). Split from
:mod:`granflow.plotting`, which re-exports every name here. Nothing in the core imports this
module.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from granflow.figure_layout import pyplot as _pyplot
from granflow.figure_layout import save_figure

#: Pressure [Pa] at which closure curves and maps are drawn unless told otherwise.
DEFAULT_PRESSURE = 1000.0
THEORY_DPI = 110
"""Resolution of the closure and stability figures (``granflow check|stability ... --plot``)."""


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
    phi_eq = np.asarray(closure.equilibrium.phi_eq(I), dtype=float)
    ax.plot(I, np.where(phi_eq >= phi[0], phi_eq, np.nan), "k--", lw=1, label="phi_eq(I)")  # in the map
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
    return save_figure(fig, path, THEORY_DPI)


def growth_figure(lead, curve, path: str | Path, title: str = ""):
    """Two panels: leading-order growth lambda/k^2 against direction, and finite-k growth against k
    for the most unstable direction and a few others (``granflow stability dispersion --plot``)."""
    plt = _pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    a.plot(np.degrees(lead.thetas), np.asarray(lead.growths) / lead.scale)
    a.axhline(0.0, color="k", lw=0.5)
    a.axvline(np.degrees(lead.theta), color="tab:red", ls=":", label=f"max at {np.degrees(lead.theta):.1f} deg")
    a.set_xlabel("wave-vector direction theta [deg]")
    a.set_ylabel("leading-order growth (lambda/k^2) / scale [-]")
    a.set_title(f"scale = eta/(phi rho_s) = {lead.scale:.3g} m^2/s", fontsize="small")
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
    return save_figure(fig, path, THEORY_DPI)
