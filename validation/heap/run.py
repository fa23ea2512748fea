"""Static heap below the friction angle: the regularised solver keeps it "at rest", i.e. creeping
at a speed proportional to eps; and a heap above the friction angle flows.

Verification item 9e of issue 3 (NUMERICS.md §11 item 4, §4). A wedge of glass beads
(d = 70 um, rho_s = 2500 kg/m^3, phi_max = 0.6) against the free-slip west wall (a symmetry plane:
a symmetric heap of width 0.4 m) on a 2 cm layer, no-slip base, in a 0.2 m x 0.1 m box, surface
z = max(h_top - x tan(theta), 2 cm) with h_top = 8.5 cm (7 cm for theta <= 16 deg), as in
tests/integration/test_solver_dry.py but with headroom: the CI test's box is 8 cm tall, so its crest column
touches the free-slip lid (run here as the "CI box" row). Cells cut by the surface hold the
covered fraction of phi_max. Closures: Drucker-Prager with sin(delta) = 0.45 (delta = 26.74 deg)
at theta = 20 and 23 deg, mu(I) (mu1 = tan 21 deg) at theta = 15 deg.

Critical slope for DP: the 2-D yield condition |dev sigma| <= sin(delta) p is Mohr-Coulomb with
friction angle delta, so no stress field holds a free surface steeper than delta = 26.74 deg;
with isotropic normal stresses (sigma_xx = sigma_zz, the infinite-slope state of the regularised
solver) the surface yields at atan(sin delta) = 24.2 deg. 20 and 23 deg are below both, 30 deg
above both.

"At rest" for a regularised model: eta = Z p / (2 sqrt(|S|^2 + eps^2)) is a viscosity, so a region
below yield (stress ratio r = |tau|/(Z p) < 1) deforms at |S| = eps r / sqrt(1 - r^2): it creeps at
a speed ~ eps H, proportional to eps, steady, with no finite-time arrest (Frigaard & Nouar 2005).
The checks: the max speed of the granular faces (centred phi_face >= phi_c) against eps (expected
exponent 1), against time (steady: v(T)/v(T/2) ~ 1), over eps H, and the largest change of the
deposit height h(x) = sum(phi dz)/phi_max over the run.

Time stepping: granflow.simulation.Simulation, dt_max = 5 ms (CFL 0.3; the creep never limits
dt), to T = 1 s. The default dt_max = 1 ms gives the same speed to 3 % (the "checks" table).
Counter-check: theta = 30, 35, 40 deg (DP), T = 0.3 s: a heap that flows reaches v(0.3 s) >
FLOW_SPEED = 1 cm/s (24 times the creep scale eps h_top at the largest eps; the creep measured below
the friction angle is at most 2 eps h_top); a heap held by the regularisation has v ~ eps h_top,
proportional to eps.

Run:   python validation/heap/run.py [--quick]
Time:  ~4.5 min on one core (``--quick``: 20 x 10 cells, DP 20 deg, eps = 5e-3 and 1e-3 to
       0.2 s, < 3 s, smoke test).
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from granflow.grid import Grid
from granflow.model import Model
from granflow.rheology import make_closure
from granflow.simulation import Simulation, StepFailure, TimeInterval

HERE = Path(__file__).resolve().parent
FIGURE = HERE / "creep.png"
RHO_S = 2500.0
PHI_MAX = 0.6
D = 70e-6
DELTA_DEG = math.degrees(math.asin(0.45))     # 26.74 deg
LX, LZ = 0.2, 0.1                             # box [m]; nz = nx LZ/LX (square cells)
CI_LZ = 0.08                                  # the CI test's box height (crest touches the lid)
TAIL = 0.02                                   # layer beyond the toe [m]
TOP_STEEP, TOP_GENTLE, GENTLE_DEG = 0.085, 0.07, 16.0   # crest height [m] (slopes > / <= 16 deg)
LEVELS = (20, 40, 80)                         # nx
EPS = (5e-3, 1e-3, 2e-4)                      # regularisation strain rates [1/s]
T_END = 1.0
QUICK_T_END = 0.2
DT_MAX = 5e-3
DT_CHECK = 1e-3                               # the default dt_max, for the dt check
RECORD = 0.05                                 # speed record interval [s]
HEAPS = (("drucker_prager", 20.0), ("mu_i", 15.0), ("drucker_prager", 23.0))
FINEST_ALL_EPS = ("drucker_prager", 20.0)     # the only heap run at every eps on the finest level
COUNTER_SLOPES = (30.0, 35.0, 40.0)
COUNTER_T_END = 0.3
TALL = {"top": 0.16, "lx": 0.4, "lz": 0.2, "nx": 80}
"""The tall heap of the counter-check: crest 16 cm in a 0.4 x 0.2 m box at the 5 mm cells of the
40 x 20 level (its slope is 2.2 times as long: README, "the toe holds a short slope")."""
TALL_SLOPES = (30.0, 23.0)
"""Slopes of the tall heap: above delta (must flow) and below it (must creep)."""
FLOW_SPEED = 1e-2                             # "flows" if v(0.3 s) > this [m/s] (module docstring)
G = 9.81


def closure(name: str):
    params = {"delta_deg": DELTA_DEG} if name == "drucker_prager" else {}
    return make_closure(name, material={"d": D, "rho_s": RHO_S, "phi_max": PHI_MAX}, **params)


def crest(slope_deg: float, top: float | None = None) -> float:
    """Crest height [m]: ``top`` if given, else TOP_STEEP (slopes > GENTLE_DEG) or TOP_GENTLE."""
    if top is not None:
        return top
    return TOP_STEEP if slope_deg > GENTLE_DEG else TOP_GENTLE


def initial_packing(grid: Grid, slope_deg: float, top: float | None = None) -> np.ndarray:
    """phi of the wedge: the covered fraction of phi_max in every cell (module docstring)."""
    X, Z = grid.cell_coords()
    surface = np.maximum(crest(slope_deg, top) - X * math.tan(math.radians(slope_deg)), TAIL)
    return PHI_MAX * np.clip((surface - (Z - 0.5 * grid.dz)) / grid.dz, 0.0, 1.0)


def deposit_height(grid: Grid, phi) -> np.ndarray:
    """h(x) = sum_z phi dz / phi_max [m]."""
    return np.asarray(phi).sum(axis=1) * grid.dz / PHI_MAX


def run(resolution: int, quick: bool = False, name: str = "drucker_prager", slope_deg: float = 20.0,
        eps: float = EPS[0], t_end: float | None = None, dt_max: float = DT_MAX, lz: float = LZ,
        lx: float = LX, top: float | None = None) -> dict:
    """One heap: ``resolution`` cells along x (square cells), to ``t_end`` (default T_END, or
    QUICK_T_END with ``quick``), in an ``lx`` x ``lz`` box with crest height ``top`` (default
    :func:`crest`; the TALL heap of the counter-check: :data:`TALL`).

    Returns
    -------
    dict
        ``t``, ``v`` (max speed of the granular faces at every RECORD), ``v_end``, ``growth``
        (v(T)/v(T/2)), ``creep_ratio`` (v_end / (eps h_top)), ``dh`` (max |h(x, T) - h(x, 0)| [m]),
        ``travel`` (integral of v dt [m]: the distance covered at the maximum speed), ``accel`` (dv/dt over the
        second half [m/s^2]), ``steps``, ``rejected``, ``wall`` [s], ``failure``.
    """
    if t_end is None:
        t_end = QUICK_T_END if quick else T_END
    nz = round(resolution * lz / lx)
    grid = Grid(nx=resolution, nz=nz, Lx=lx, Lz=lz)
    model = Model(grid, closure(name), eps=eps)
    phi0 = initial_packing(grid, slope_deg, top)
    sim = Simulation(model, model.initial_state(phi0), stop_time=t_end, dt_max=dt_max)
    ts, vs = [], []

    def record(s: Simulation) -> None:
        granular = model.ops.cell_to_face @ np.ravel(s.state.phi) >= model.ambient.phi_c
        ts.append(float(s.state.t))
        vs.append(float(np.max(np.abs(s.state.vel[granular]))))

    sim.add_callback(record, TimeInterval(RECORD))
    failure = ""
    t0 = time.perf_counter()
    try:
        sim.run()
    except StepFailure as err:
        failure = f"t = {sim.state.t:.3f} s: {str(err)[:100]}"
    wall = time.perf_counter() - t0
    t, v = np.array(ts), np.array(vs)
    half = int(np.argmin(np.abs(t - 0.5 * t[-1])))
    v_end = float(v[-1])
    return {"name": name, "slope_deg": slope_deg, "eps": eps, "nx": resolution, "nz": nz, "lz": lz,
            "dt_max": dt_max, "t": t, "v": v, "v_end": v_end,
            "growth": v_end / v[half] if v[half] > 0 else math.nan,
            "creep_ratio": v_end / (eps * crest(slope_deg, top)),
            "dh": float(np.max(np.abs(deposit_height(grid, sim.state.phi) - deposit_height(grid, phi0)))),
            "travel": float(np.trapezoid(v, t)),
            "accel": float((v[-1] - v[half]) / (t[-1] - t[half])),
            "steps": sim.state.step, "rejected": sim.n_rejected, "wall": wall, "failure": failure}


def exponent(rows) -> float:
    """Least-squares slope of log(v_end) against log(eps)."""
    if len(rows) < 2:
        return math.nan
    return float(np.polyfit(np.log([r["eps"] for r in rows]), np.log([r["v_end"] for r in rows]), 1)[0])


def label(r) -> str:
    short = "DP" if r["name"] == "drucker_prager" else r["name"]
    return f"{short} {r['slope_deg']:g} deg"


def rest_table(rows) -> str:
    lines = ["| heap | grid | eps [1/s] | v(T) [m/s] | v(T)/(eps h_top) | v(T)/v(T/2) | max dh(x) [um] | "
             "int v dt [um] | steps | rejected | wall [s] |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {label(r)} | {r['nx']}x{r['nz']} | {r['eps']:.0e} | {r['v_end']:.3e} | "
                     f"{r['creep_ratio']:.3f} | {r['growth']:.4f} | {1e6 * r['dh']:.2f} | {1e6 * r['travel']:.1f} | "
                     f"{r['steps']} | {r['rejected']} | {r['wall']:.1f} |"
                     + (f" FAILED {r['failure']}" if r["failure"] else ""))
    return "\n".join(lines)


def exponent_table(groups) -> str:
    lines = ["| heap | grid | v(5e-3)/v(1e-3) | v(1e-3)/v(2e-4) | fitted exponent of v(T) in eps |",
             "|---|---|---:|---:|---:|"]
    for rows in groups:
        if len(rows) < len(EPS):
            continue
        v = {r["eps"]: r["v_end"] for r in rows}
        r0 = rows[0]
        lines.append(f"| {label(r0)} | {r0['nx']}x{r0['nz']} | {v[EPS[0]] / v[EPS[1]]:.3f} | "
                     f"{v[EPS[1]] / v[EPS[2]]:.3f} | {exponent(rows):.3f} |")
    return "\n".join(lines)


def counter_table(rows) -> str:
    lines = ["| slope | grid | eps [1/s] | v(0.15 s) [m/s] | v(0.3 s) [m/s] | v/(eps h_top) | dv/dt [m/s^2] | "
             "verdict | wall [s] |", "|---|---|---:|---:|---:|---:|---:|---|---:|"]
    for r in rows:
        half = int(np.argmin(np.abs(r["t"] - 0.5 * r["t"][-1])))
        verdict = "flows" if r["v_end"] > FLOW_SPEED else "held (creep)"
        lines.append(f"| {label(r)} | {r['nx']}x{r['nz']} | {r['eps']:.0e} | {r['v'][half]:.2e} | "
                     f"{r['v_end']:.2e} | {r['creep_ratio']:.1f} | {r['accel']:+.3f} | {verdict} | {r['wall']:.1f} |"
                     + (f" FAILED {r['failure']}" if r["failure"] else ""))
    return "\n".join(lines)


def figure(groups, counter, path: Path = FIGURE) -> Path:
    """(a) v(T) against eps, log-log, every heap and grid, with the slope-1 line. (b) v(t)/(eps
    h_top) for the DP 20 deg heap at every eps and grid. (c) the counter-check v(t), log scale."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax_t, ax_c) = plt.subplots(1, 3, figsize=(16, 4.6))
    markers = {20: "o", 40: "s", 80: "^"}
    colours = {}
    for rows in groups:
        r0 = rows[0]
        c = colours.setdefault(label(r0), f"C{len(colours)}")
        ax.loglog([r["eps"] for r in rows], [r["v_end"] for r in rows], "-", marker=markers.get(r0["nx"], "x"),
                  color=c, lw=0.9, label=f"{label(r0)}, {r0['nx']}x{r0['nz']}")
        if (r0["name"], r0["slope_deg"]) == FINEST_ALL_EPS:
            for r in rows:
                ax_t.plot(r["t"][1:], r["v"][1:] / (r["eps"] * crest(r["slope_deg"])), "-",
                          marker=markers.get(r["nx"], "x"), ms=3, lw=0.8,
                          label=f"{r['nx']}x{r['nz']}, eps = {r['eps']:.0e}")
    e = np.array([EPS[-1], EPS[0]])
    ref = groups[0][0]["v_end"] / EPS[0]
    ax.loglog(e, ref * e, "k:", label="v proportional to eps")
    ax.set(xlabel="eps [1/s]", ylabel="max speed of granular faces at T = 1 s [m/s]",
           title="(a) creep speed against the regularisation")
    ax.set_xticks(EPS, [f"{e:g}" for e in EPS])
    ax.minorticks_off()
    ax.legend(fontsize=7)
    ax_t.set(xlabel="t [s]", ylabel="v / (eps h_top)", title="(b) DP 20 deg: steady creep", ylim=(0, None))
    ax_t.legend(fontsize=7)
    for r in counter:
        ax_c.semilogy(r["t"][1:], r["v"][1:], "-", marker=markers.get(r["nx"], "x"), ms=3, lw=0.8,
                      label=f"{label(r)}, {r['nx']}x{r['nz']}, eps = {r['eps']:.0e}")
    for e, ls in zip(EPS[:2], ("--", ":")):
        ax_c.axhline(e * TOP_STEEP, color="0.5", ls=ls, lw=1, label=f"eps h_top, eps = {e:.0e}")
    ax_c.axhline(FLOW_SPEED, color="k", lw=1, label="flow threshold")
    ax_c.set(xlabel="t [s]", ylabel="max speed of granular faces [m/s]",
             title="(c) DP above the friction angle (delta = 26.7 deg)")
    ax_c.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="20 x 10, DP 20 deg, two eps, 0.2 s (smoke test)")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    if args.quick:
        rows = [run(LEVELS[0], quick=True, eps=e) for e in EPS[:2]]
        print(rest_table(rows))
        print(f"v(5e-3)/v(1e-3) = {rows[0]['v_end'] / rows[1]['v_end']:.3f}")
        return
    groups = []
    for nx in LEVELS:
        for name, slope in HEAPS:
            eps_list = EPS if (nx != LEVELS[-1] or (name, slope) == FINEST_ALL_EPS) else EPS[:1]
            groups.append([run(nx, name=name, slope_deg=slope, eps=e) for e in eps_list])
            print(rest_table(groups[-1]).splitlines()[-1], flush=True)
    checks = [run(LEVELS[0], eps=EPS[0], dt_max=DT_CHECK), run(LEVELS[0], eps=EPS[0], lz=CI_LZ)]
    counter = []
    for nx in LEVELS:
        for slope in (COUNTER_SLOPES if nx != LEVELS[-1] else COUNTER_SLOPES[:1]):
            counter.append(run(nx, slope_deg=slope, eps=EPS[0], t_end=COUNTER_T_END))
        counter.append(run(nx, slope_deg=COUNTER_SLOPES[0], eps=EPS[1], t_end=COUNTER_T_END))
        print(counter_table(counter).splitlines()[-1], flush=True)
    print(f"\nDP: delta = {DELTA_DEG:.2f} deg, atan(sin delta) = "
          f"{math.degrees(math.atan(math.sin(math.radians(DELTA_DEG)))):.2f} deg; box {LX} x {LZ} m, T = {T_END} s, "
          f"dt_max = {DT_MAX} s")
    print("\nHeaps below the friction angle:")
    print(rest_table([r for g in groups for r in g]))
    print("\nExponent of the creep speed in eps:")
    print(exponent_table(groups))
    print("\nChecks (DP 20 deg, 20 x 10, eps = 5e-3): default dt_max = 1 ms; the CI box (Lz = 8 cm, crest on the lid):")
    print(rest_table(checks))
    print("\nCounter-check above the friction angle (T = 0.3 s):")
    print(counter_table(counter))
    tall = [run(TALL["nx"], slope_deg=slope, eps=EPS[0], t_end=COUNTER_T_END, lz=TALL["lz"],
                lx=TALL["lx"], top=TALL["top"]) for slope in TALL_SLOPES]
    print(f"\nTall heap (crest {TALL['top']} m, box {TALL['lx']} x {TALL['lz']} m, the 5 mm cells of "
          f"{LEVELS[1]} x {LEVELS[1] // 2}; T = 0.3 s):")
    print(counter_table(tall))
    print(f"\nwall {time.perf_counter() - t0:.0f} s")
    print(f"figure: {figure(groups, counter)}")


if __name__ == "__main__":
    main()
