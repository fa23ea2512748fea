"""Defluidising column: rigid bed, implicit pore pressure against the Fourier series.

Verification item 1 of NUMERICS.md §11 (docs/model.md §7): a static column of glass beads
(d = 70 um, phi = phi_max = 0.6, H = 0.1 m) with an impermeable base and an open top, initial
pore pressure 0.9 x lithostatic (0.9 phi rho_s g (H - z)) or uniform (0.9 phi rho_s g H). The
basal pressure (bottom cell centre, z = dz/2) is compared with the series of
:mod:`granflow.verification.defluidisation` at t/tau_1 = 0.05, 0.1, 0.25, 0.5, 1, 2,
tau_1 = 4 H^2/(pi^2 c), c = p_atm kappa/(1 - phi).

Resolution ``nz`` cells over H (nx = 2), dt = tau_1/nz^2 (so the first-order time error and the
second-order space error both scale like dz^2). Two errors are reported (max over the sample
times, relative to the initial basal pressure):

* ``err``: the backward-Euler run as is;
* ``err_space``: time error removed by Richardson extrapolation ``2 p(dt/2) - p(dt)``, which
  isolates the spatial error.

The basal half-life is measured on the pressure extrapolated to z = 0 (series: 0.4854 tau_1).

Run:   python validation/defluidisation/run.py [--quick]
Time:  ~15 s on one core (``--quick``: < 2 s, the coarsest level only, smoke test).
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from granflow import Material
from granflow.grid import Grid
from granflow.operators import Operators
from granflow.physics.pore_pressure import PorePressureStep
from granflow.verification import defluidisation as dfl

HERE = Path(__file__).resolve().parent
MATERIAL = Material(d=70e-6)
H = 0.1                      # bed height [m]
PHI = 0.6                    # packing = phi_max (rigid, dense)
G = 9.81                     # gravity [m s^-2]
FRACTION = 0.9               # p_f0 = 0.9 x lithostatic
NX = 2
LEVELS = (10, 20, 40, 80)
SAMPLES = np.array([0.05, 0.1, 0.25, 0.5, 1.0, 2.0])   # t / tau_1
QUICK_END = 1.0                                        # t / tau_1 reached with quick=True
PROFILES = (dfl.InitialProfile.LITHOSTATIC, dfl.InitialProfile.UNIFORM)
FIGURE = HERE / "basal_pressure.png"
ERROR_AXIS_FLOOR = 1e-7      # lower limit of the error axis of the figure


def diffusivity() -> float:
    """c = p_atm kappa(phi)/(1 - phi) [m^2 s^-1] (0.0817 for these beads)."""
    return float(MATERIAL.gas_diffusivity(PHI))


def amplitude() -> float:
    """Initial basal pore pressure 0.9 phi rho_s g H [Pa] (1324 Pa)."""
    return FRACTION * PHI * MATERIAL.rho_s * G * H


def _march(profile, nz: int, dt: float, t_end: float):
    """p_f history at t = 0, dt, ..., t_end: (times, bottom-cell value, value at z = 0, zc0).

    The value at the base z = 0 is the quadratic extrapolation with zero slope there,
    ``(9 p_0 - p_1)/8`` (``p = a + b z^2`` through the two lowest cell centres).
    """
    grid = Grid(nx=NX, nz=nz, Lx=NX * H / nz, Lz=H)
    ops = Operators.build(grid)
    phi = np.full(grid.cell_shape, PHI)
    p = dfl.initial_profile(profile, grid.cell_coords()[1], H, amplitude())
    step = PorePressureStep(grid, MATERIAL, ops, open_top=True)
    n_steps = int(round(t_end / dt))
    basal, base = np.empty(n_steps + 1), np.empty(n_steps + 1)
    for n in range(n_steps + 1):
        if n:
            p = step(p, phi, dt)
        basal[n], base[n] = p[0, 0], (9.0 * p[0, 0] - p[0, 1]) / 8.0
    return dt * np.arange(n_steps + 1), basal, base, grid.zc[0]


def _half_life(times, values, initial: float) -> float:
    """First time at which ``values`` falls to ``initial/2`` (linear interpolation; NaN if never).

    ``initial`` is the exact initial basal pressure: the extrapolated discrete value at t = 0 is off
    by O(dz) because the lithostatic profile has a slope at the impermeable base."""
    target = 0.5 * initial
    if values[-1] > target:
        return math.nan
    k = int(np.argmax(values <= target))       # first sample at or below the target (k >= 1)
    v0, v1 = values[k - 1], values[k]
    return float(times[k - 1] + (v0 - target) / (v0 - v1) * (times[k] - times[k - 1]))


def run(resolution: int, quick: bool = False) -> dict:
    """Run both initial profiles with ``resolution`` cells over the bed height.

    Parameters
    ----------
    resolution : int
        nz (a multiple of 10 keeps the sample times on the time grid).
    quick : bool
        Stop at t = 0.5 tau_1 and skip the Richardson (dt/2) run.

    Returns
    -------
    dict
        ``nz, dz, dt, tau1, c, amplitude`` and per profile value ``{profile: {...}}`` with ``times``,
        ``basal`` (numerical history), ``series`` (at the bottom cell centre), ``err``,
        ``err_space`` (NaN if quick) and ``half_life`` (numerical, of the pressure extrapolated
        to z = 0, in units of tau_1; series: 0.4854).
    """
    nz = int(resolution)
    c = diffusivity()
    tau1 = dfl.first_time_constant(H, c)
    dt = tau1 / nz**2
    samples = SAMPLES[SAMPLES <= QUICK_END] if quick else SAMPLES
    out = {"nz": nz, "dz": H / nz, "dt": dt, "tau1": tau1, "c": c, "amplitude": amplitude()}
    for profile in PROFILES:
        times, basal, base, z0 = _march(profile, nz, dt, samples[-1] * tau1)
        idx = np.rint(samples * tau1 / dt).astype(int)
        series = dfl.pressure(z0, times[1:], H, c, profile, amplitude())
        exact = series[idx - 1]
        err = np.abs(basal[idx] - exact).max() / amplitude()
        err_space = math.nan
        if not quick:
            _, fine, _, _ = _march(profile, nz, dt / 2, samples[-1] * tau1)
            extrap = 2.0 * fine[2 * idx] - basal[idx]
            err_space = np.abs(extrap - exact).max() / amplitude()
        out[profile.value] = {
            "times": times, "basal": basal, "series": np.concatenate([[basal[0]], series]),
            "err": err, "err_space": err_space, "half_life": _half_life(times, base, amplitude()) / tau1,
        }
    return out


def _order(errors) -> list[str]:
    return ["-"] + [f"{math.log2(a / b):.2f}" for a, b in zip(errors[:-1], errors[1:])]


def table(results) -> str:
    """Markdown table of the errors and observed orders."""
    lit, uni = (dfl.InitialProfile.LITHOSTATIC.value, dfl.InitialProfile.UNIFORM.value)
    cols = {k: [r[p][e] for r in results] for k, p, e in
            [("l", lit, "err"), ("u", uni, "err"), ("ls", lit, "err_space"), ("us", uni, "err_space")]}
    orders = {k: _order(v) for k, v in cols.items()}
    lines = ["| nz | dz [mm] | dt [ms] | err lith. | order | err unif. | order | err_space lith. | order "
             "| err_space unif. | order | t_1/2 / tau_1 (lith.) |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for i, r in enumerate(results):
        cells = [f"{r['nz']}", f"{1e3 * r['dz']:.2f}", f"{1e3 * r['dt']:.4f}"]
        for k in ("l", "u", "ls", "us"):
            cells += [f"{cols[k][i]:.2e}", orders[k][i]]
        cells.append(f"{r[lit]['half_life']:.4f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def figure(results, path: Path = FIGURE) -> Path:
    """Left: basal p_f against t/tau_1, series (lines) and the coarsest/finest runs (markers, bottom
    cell centre). Right: |p_num - p_series|/p_f0 at the bottom cell centre for every resolution."""
    from granflow import plotting

    plt = plotting._pyplot()
    fig, (ax, ax_err) = plt.subplots(1, 2, figsize=(12, 4.4), constrained_layout=True)
    for profile, colour, ls in zip(PROFILES, ("C0", "C3"), ("-", "--")):
        ref = results[-1][profile.value]
        ax.plot(ref["times"] / results[-1]["tau1"], ref["series"], color=colour, lw=1.5,
                label=f"series, {profile.value}")
        for r, m in zip((results[0], results[-1]), ("o", "x")):
            res = r[profile.value]
            tt = res["times"] / r["tau1"]
            every = max(1, len(tt) // 40)
            ax.plot(tt[::every], res["basal"][::every], m, ms=4, mfc="none", color=colour,
                    label=f"nz = {r['nz']}, {profile.value}")
        for k, r in enumerate(results):
            res = r[profile.value]
            ax_err.semilogy(res["times"][1:] / r["tau1"],
                            np.abs(res["basal"] - res["series"])[1:] / amplitude(), ls=ls,
                            color=plt.cm.viridis(k / max(1, len(results) - 1)),
                            label=f"nz = {r['nz']}, {profile.value}")
    ax.axvline(dfl.basal_half_life(H, results[-1]["c"]) / results[-1]["tau1"], color="0.6", ls=":",
               label="t_1/2 = 0.4854 tau_1 (lith.)")
    ax.axhline(0.5 * amplitude(), color="0.8", ls=":")
    for a in (ax, ax_err):
        a.set_xlabel("t / tau_1   (tau_1 = 4H^2/(pi^2 c) = %.1f ms)" % (1e3 * results[-1]["tau1"]))
    ax.set_ylabel("basal pore pressure p_f [Pa]")
    ax_err.set_ylabel("|p_num - p_series| / p_f0 at z = dz/2   (dt = tau_1/nz^2)")
    ax.set_title("Defluidising column, d = 70 um, H = 0.1 m, phi = 0.6", fontsize="medium")
    ax_err.set_title("error: lithostatic (solid), uniform (dashed)", fontsize="medium")
    ax_err.set_ylim(ERROR_AXIS_FLOOR, None)   # the uniform-profile error changes sign near 0.4 tau_1
    ax.legend(fontsize="small")
    ax_err.legend(fontsize="x-small", ncol=2)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="coarsest level only (smoke test)")
    args = parser.parse_args(argv)
    levels = LEVELS[:1] if args.quick else LEVELS
    results = [run(nz, quick=args.quick) for nz in levels]
    print(f"c = {results[0]['c']:.4f} m^2/s, tau_1 = {1e3 * results[0]['tau1']:.2f} ms, "
          f"p_f0(base) = {amplitude():.1f} Pa, series t_1/2 = "
          f"{dfl.basal_half_life(H, results[0]['c']) / results[0]['tau1']:.4f} tau_1")
    print(table(results))
    if not args.quick:
        print(f"figure: {figure(results)}")


if __name__ == "__main__":
    main()
