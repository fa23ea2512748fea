"""Figures of the theory toolkit (docs/theory.md): closure curves, well-posedness maps, growth
rates against direction, and the Barker et al. (2015) window.

Run:  python validation/theory/make_figures.py [--out docs/figures] [--quick]
Time: about a minute (a few seconds with --quick, which CI runs as a smoke test).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from granflow import plotting
from granflow.rheology import CLOSURES, make_closure

#: Closures drawn, with the parameters used (paper's defaults unless stated).
CASES = {
    "drucker_prager": {"delta_deg": 25.0},
    "mu_i": {},
    "drucker_prager_dilatancy": {"delta_deg": 30.0},
    "mu_i_dilatancy": {},
    "power_law": {"exponents": (0.0, 1.0), "coefficients": (0.4, 0.2)},
    "roux_radjai": {"a": 1.0},
    "incompressible": {},
}
#: Representative base state of the stability figures.
P_BASE, I_BASE = 1000.0, 1e-2


def figure_closures(out: Path, n: int) -> Path:
    plt = plotting._pyplot()
    names = list(CASES)
    fig, axes = plt.subplots(2, len(names), figsize=(3.2 * len(names), 6), constrained_layout=True)
    for k, name in enumerate(names):
        c = make_closure(name, **CASES[name])
        plotting.closure_curves(c, axes[0, k], axes[1, k])
        axes[0, k].set_title(name, fontsize="small")
        if k:
            axes[0, k].get_legend().remove()
    path = out / "closures_Z_f.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def figure_maps(out: Path, n: int) -> Path:
    plt = plotting._pyplot()
    names = list(CASES)
    fig, axes = plt.subplots(2, (len(names) + 1) // 2, figsize=(5.5 * ((len(names) + 1) // 2), 8.5),
                             constrained_layout=True)
    for ax, name in zip(axes.flat, names):
        c = make_closure(name, **CASES[name])
        plotting.condition_map_axes(c, ax, n=n)
        ax.set_title(f"{name}: conditions at p = {plotting.DEFAULT_PRESSURE:g} Pa", fontsize="small")
    for ax in list(axes.flat)[len(names):]:
        ax.remove()
    path = out / "wellposedness_maps.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def figure_growth(out: Path, n: int) -> Path:
    from granflow.theory.dispersion import leading_order_growth

    plt = plotting._pyplot()
    thetas = np.linspace(0.0, np.pi, n, endpoint=False)
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    for name, params in CASES.items():
        c = make_closure(name, **params)
        phi = float(c.equilibrium.phi_eq(I_BASE))
        g = [leading_order_growth(c, phi, P_BASE, I_BASE, th) for th in thetas]
        ax.plot(np.degrees(thetas), g, label=name)
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_yscale("symlog", linthresh=1e-7)
    ax.set_xlabel("wave-vector direction theta [deg] (shear flow along x, gradient along z)")
    ax.set_ylabel("leading-order growth lambda/k^2 [m^2/s]")
    ax.set_title(f"high-wavenumber growth about simple shear, I = {I_BASE:g}, p = {P_BASE:g} Pa", fontsize="small")
    ax.legend(fontsize="small")
    path = out / "growth_vs_direction.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def figure_barker(out: Path, n: int) -> Path:
    from granflow.theory.barker import barker_criterion, barker_window

    plt = plotting._pyplot()
    mu1, mu2, I0 = np.tan(np.radians(21.0)), np.tan(np.radians(33.0)), 0.3
    I = np.logspace(-5, 2, 20 * n)
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    ax.semilogx(I, barker_criterion(I, mu1, mu2, I0))
    w = barker_window(mu1, mu2, I0)
    ax.axvspan(w.I_low, w.I_high, color="tab:green", alpha=0.2, label=f"well posed: {w.I_low:.3g} < I < {w.I_high:.3g}")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("I (literature convention, I0 = 0.3)")
    ax.set_ylabel("4 nu^2 - 4 nu + mu^2 (1 - nu/2)^2")
    ax.set_title("Barker et al. (2015): incompressible mu(I), mu1 = tan 21, mu2 = tan 33", fontsize="small")
    ax.legend(fontsize="small")
    path = out / "barker_window.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def run(out: Path = Path("docs/figures"), quick: bool = False) -> list[Path]:
    """Make every figure into ``out``; ``quick`` uses coarse sampling (CI smoke test). The
    documented equivalent of the validations' ``run(resolution, quick)``: figures, no levels, so
    the first argument is where they go."""
    out.mkdir(parents=True, exist_ok=True)
    n = 12 if quick else 120
    assert set(CASES) <= set(CLOSURES.names())
    return [figure_closures(out, n), figure_maps(out, n), figure_growth(out, max(n, 24)), figure_barker(out, n)]


def main(argv=None) -> list[Path]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path("docs/figures"))
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    paths = run(a.out, a.quick)
    for p in paths:
        print(f"wrote {p}")
    return paths


if __name__ == "__main__":
    main()
