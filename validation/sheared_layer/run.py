"""Homogeneous sheared layer: the AP dilatancy step against the exact logistic solution (DP) and a
tight Radau integration (every other paper closure).

Verification item 9a of issue 3 (docs/model.md §7, NUMERICS.md §11 item 2 and §5.2). Under an imposed
strain-rate norm |S| = 200 1/s and granular pressure p = 1000 Pa (d = 80 um, rho_s = 2500 kg/m^3,
phi_max = 0.6, delta_phi = 0.2, c_I = 2: I = 0.0506, phi_eq = 0.5899), mass (paper eq. syst1b) and
the dilatancy law (eq. syst4b) reduce to dphi/dt = -phi R(phi; p, |S|), R = Closure.div_rate. For
Drucker-Prager (delta = 25 deg) this is the logistic equation

    dphi/dt = beta phi (phi_eq - phi),   beta = 2 sin(delta) sqrt(p) / (c_I delta_phi d sqrt(rho_s)),
    phi(t) = phi_eq / (1 + (phi_eq/phi0 - 1) exp(-beta phi_eq t)),

written again here from docs/model.md §7 (and compared with granflow.verification.sheared_layer). For
the other paper closures the reference is SciPy's Radau integration of the same ODE with
rtol = 1e-11, atol = 1e-13 (checked against the logistic solution for DP).

The integrator is granflow.physics.dilatancy.homogeneous_layer_step (the step the case
``sheared_layer`` runs): the solver's AP-linearised factor ``fac = 1/(1 + dt phi dR/dphi)``
(``ap_linearised``) and the exact scalar backward-Euler solve (``backward_euler``). Two starts:
compaction from phi0 = 0.55 and dilation from phi0 = 0.5999. The step is given as rate * dt, with
rate = phi_eq dR/dphi(phi_eq) the linearised relaxation rate (9.85e3 1/s for DP). Each run covers
max(3 relaxation times, 5 steps); the error is max |phi_n - phi_ref(t_n)| over the steps, relative
to |phi0 - phi_eq|; the overshoot is the largest excursion past phi_eq, relative to the same gap.
A step that raises (GranflowInputError) ends its run; the error then covers the steps done and the
failure is listed after the tables.

Run:   python validation/sheared_layer/run.py [--quick]
Time:  ~30 s on one core (``--quick``: DP only, rate * dt >= 1e-2, < 2 s, smoke test).
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from granflow.errors import GranflowInputError
from granflow.physics.dilatancy import (
    LayerScheme,
    ddiv_rate_dphi,
    homogeneous_layer_step,
)
from granflow.rheology import CLOSURES, make_closure
from granflow.verification.sheared_layer import drucker_prager_layer

HERE = Path(__file__).resolve().parent
FIGURE = HERE / "relaxation.png"
P = 1000.0                   # imposed granular pressure [Pa]
S = 200.0                    # imposed |S| [1/s]
STARTS = {"compaction": 0.55, "dilation": 0.5999}
EXACT = "drucker_prager"     # closure with the logistic solution
PAPER = tuple(n for n in CLOSURES.names() if not CLOSURES.get(n).reference)
RATE_DT = (1e-3, 3e-3, 1e-2, 3e-2, 1e-1, 3e-1, 1.0, 3.0, 10.0, 100.0, 1e3, 1e4)
OTHER_MIN_RATE_DT = 3e-3     # smallest rate * dt for the closures other than DP (cost)
QUICK_MIN_RATE_DT = 1e-2
FIT_MAX_RATE_DT = 3.1e-2     # the order is fitted over rate * dt <= this (asymptotic range)
STIFF_RATE_DT = 10.0         # the overshoot check covers rate * dt >= this
WINDOW = 3.0                 # relaxation times covered by every run
MIN_STEPS = 5                # ... and at least this many steps
RADAU_RTOL, RADAU_ATOL = 1e-11, 1e-13
FIGURE_RATE_DT = (0.1, 1.0, 10.0, 1e4)
DILATANCY_ANGLE = ("drucker_prager_dilatancy", "mu_i_dilatancy")
ERROR_AXIS_CAP = 1e2          # errors above this are drawn at the cap (runs past phi_max)


def logistic(t, phi0: float, closure) -> np.ndarray:
    """Exact DP solution (module docstring), written from docs/model.md §7 [-]."""
    m = closure.material
    beta = 2.0 * closure.sin_delta * math.sqrt(P) / (m.c_I * m.delta_phi * m.d * math.sqrt(m.rho_s))
    phi_eq = m.phi_max - m.delta_phi * m.c_I * m.d * S / math.sqrt(P / m.rho_s)
    return phi_eq / (1.0 + (phi_eq / phi0 - 1.0) * np.exp(-beta * phi_eq * np.asarray(t, dtype=float)))


def equilibrium(closure) -> tuple[float, float]:
    """(phi_eq(I) [-], linearised relaxation rate phi_eq dR/dphi(phi_eq) [1/s])."""
    phi_eq = float(closure.equilibrium.phi_eq(closure.material.inertial_number(S, P)))
    return phi_eq, phi_eq * float(ddiv_rate_dphi(closure, phi_eq, P, S))


def radau(closure, phi0: float, t_end: float):
    """Dense Radau solution of dphi/dt = -phi R(phi) on [0, t_end] (callable t -> phi)."""
    sol = solve_ivp(lambda _, y: -y * closure.div_rate(y, P, S), (0.0, t_end), [phi0], method="Radau",
                    rtol=RADAU_RTOL, atol=RADAU_ATOL, dense_output=True)
    if not sol.success:
        raise RuntimeError(f"Radau failed for {closure.name}: {sol.message}")
    return lambda t: sol.sol(np.asarray(t, dtype=float))[0]


def run_one(closure, phi0: float, rate_dt: float, scheme: LayerScheme, reference) -> dict:
    """One integration at ``rate_dt``; errors against ``reference(t)``."""
    phi_eq, rate = equilibrium(closure)
    dt = rate_dt / rate
    n = max(math.ceil(WINDOW / rate_dt), MIN_STEPS)
    phis, failure = [float(phi0)], ""
    with np.errstate(all="ignore"):
        for k in range(n):
            try:
                phis.append(float(homogeneous_layer_step(closure, phis[-1], P, S, dt, scheme)))
            except GranflowInputError as err:      # reported in the tables, not hidden
                failure = f"step {k + 1}: {err}"
                break
    phi = np.array(phis)
    t = dt * np.arange(len(phi))
    gap = abs(phi0 - phi_eq)
    towards = math.copysign(1.0, phi_eq - phi0)
    finite = bool(np.all(np.isfinite(phi)))
    return {"rate_dt": rate_dt, "steps": n, "t": t, "phi": phi, "finite": finite, "failure": failure,
            "err": float(np.max(np.abs(phi - reference(t)))) / gap if finite else math.nan,
            "overshoot": float(max(0.0, np.nanmax(towards * (phi - phi_eq)))) / gap,
            "phi_max_excess": float(max(0.0, np.nanmax(phi) - closure.material.phi_max)),
            "first_step": float(abs(phi[1] - phi_eq)) / gap,
            "final": float(abs(phi[-1] - phi_eq)) / gap}


def fitted_order(rows) -> float:
    """Least-squares slope of log(err) against log(rate dt) over rate dt <= FIT_MAX_RATE_DT."""
    pts = [(r["rate_dt"], r["err"]) for r in rows if r["rate_dt"] <= FIT_MAX_RATE_DT and r["err"] > 0]
    if len(pts) < 2:
        return math.nan
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def run(resolution: float = RATE_DT[0], quick: bool = False, closures=PAPER) -> dict:
    """Every closure, start and scheme over rate * dt from ``resolution`` to 1e4.

    Parameters
    ----------
    resolution : float
        Smallest rate * dt (DP; the other closures start at OTHER_MIN_RATE_DT or above).
    quick : bool
        DP only, from QUICK_MIN_RATE_DT (smoke test).
    closures : sequence of str
        Closure registry keys.

    Returns
    -------
    dict
        ``{closure: {"phi_eq", "rate", "reference", "ref_check", start: {scheme: [rows]}}}``; a row
        has ``rate_dt, steps, err, overshoot, phi_max_excess, first_step, final, finite, t, phi``.
        ``ref_check`` (DP) is max |Radau - logistic| / gap and max |logistic - module| over the
        longest window; the wall time is under the key ``"wall"``.
    """
    t0 = time.perf_counter()
    names = (EXACT,) if quick else tuple(closures)
    lowest = max(resolution, QUICK_MIN_RATE_DT) if quick else resolution
    out: dict = {}
    for name in names:
        c = make_closure(name)
        phi_eq, rate = equilibrium(c)
        floor = lowest if name == EXACT else max(lowest, OTHER_MIN_RATE_DT)
        levels = [x for x in RATE_DT if x >= floor * (1 - 1e-12)]
        t_long = max(WINDOW / levels[0], MIN_STEPS * levels[-1]) / rate
        res = {"phi_eq": phi_eq, "rate": rate, "ref_check": {}}
        for label, phi0 in STARTS.items():
            gap = abs(phi0 - phi_eq)
            if name == EXACT:
                m = c.material
                reference = lambda t, phi0=phi0, c=c: logistic(t, phi0, c)
                tt = np.linspace(0.0, 10.0 / rate, 2001)
                module = drucker_prager_layer(tt, phi0, P, S, sin_delta=c.sin_delta, d=m.d, rho_s=m.rho_s,
                                              phi_max=m.phi_max, delta_phi=m.delta_phi, c_I=m.c_I)
                res["ref_check"][label] = {
                    "radau": float(np.max(np.abs(radau(c, phi0, tt[-1])(tt) - reference(tt)))) / gap,
                    "module": float(np.max(np.abs(module - reference(tt))))}
                res["reference"] = "exact logistic"
            else:
                reference = radau(c, phi0, t_long)
                res["reference"] = "Radau"
            res[label] = {s.value: [run_one(c, phi0, x, s, reference) for x in levels] for s in LayerScheme}
        out[name] = res
    out["wall"] = time.perf_counter() - t0
    return out


def _fmt(x: float) -> str:
    return "nan" if not math.isfinite(x) else ("0" if x == 0 else f"{x:.2e}")


def dp_table(results) -> str:
    """DP, AP-linearised scheme: error and local order against rate * dt, both starts."""
    dp = results[EXACT]
    rows = {k: dp[k][LayerScheme.AP_LINEARISED.value] for k in STARTS}
    lines = ["| rate dt | steps | err compaction | order | overshoot | err dilation | order | overshoot | "
             "dist. after 1 step (comp.) |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for i, r in enumerate(rows["compaction"]):
        cells = [f"{r['rate_dt']:g}", f"{r['steps']}"]
        for k in STARTS:
            rr = rows[k]
            order = "-"
            if i:
                slope = math.log(rr[i - 1]["err"] / rr[i]["err"]) / math.log(rr[i - 1]["rate_dt"] / rr[i]["rate_dt"])
                order = f"{slope:.2f}"
            cells += [_fmt(rr[i]["err"]), order, _fmt(rr[i]["overshoot"])]
        cells.append(_fmt(r["first_step"]))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def closure_table(results) -> str:
    """Per closure, start and scheme: fitted order, errors at rate dt = 1e-2, 1, 1e2, overshoot."""
    lines = ["| closure | reference | start | scheme | fitted order | err (rate dt = 0.01) | err (1) | "
             "err (100) | max overshoot (rate dt >= 10) | max phi - phi_max | dist. after 5 steps at 1e4 |",
             "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, res in results.items():
        if name == "wall":
            continue
        for k in STARTS:
            for s in LayerScheme:
                rows = res[k][s.value]
                at = {r["rate_dt"]: r for r in rows}
                stiff = [r for r in rows if r["rate_dt"] >= STIFF_RATE_DT]
                lines.append(
                    f"| {name} | {res['reference']} | {k} | {s.value} | {fitted_order(rows):.3f} | "
                    f"{_fmt(at[1e-2]['err'])} | {_fmt(at[1.0]['err'])} | {_fmt(at[100.0]['err'])} | "
                    f"{_fmt(max(r['overshoot'] for r in stiff))} | {_fmt(max(r['phi_max_excess'] for r in stiff))} | "
                    f"{_fmt(at[1e4]['final'])} |")
    return "\n".join(lines)


def failures(results) -> list[str]:
    """One line per run that ended on an exception."""
    return [f"{name}, {k}, {s}, rate dt = {r['rate_dt']:g}: {r['failure']}"
            for name, res in results.items() if name != "wall"
            for k in STARTS for s, rows in res[k].items() for r in rows if r["failure"]]


def figure(results, path: Path = FIGURE) -> Path:
    """(a) DP phi(t) at several rate dt against the logistic solution (log time axis). (b), (c) error
    against rate dt: AP-linearised (solid), backward Euler (dashed); (c) the dilatancy-angle closures."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    ax = axes[0]
    dp = results[EXACT]
    c = make_closure(EXACT)
    rate = dp["rate"]
    tt = np.logspace(-2, 5, 400)
    for k, phi0 in STARTS.items():
        ax.semilogx(tt, logistic(tt / rate, phi0, c), "k-", lw=1.5,
                    label="exact logistic" if k == "compaction" else None)
        for j, x in enumerate(FIGURE_RATE_DT):
            r = next(r for r in dp[k][LayerScheme.AP_LINEARISED.value] if r["rate_dt"] == x)
            ax.semilogx(r["t"][1:] * rate, r["phi"][1:], "o-", ms=4, lw=0.8, color=f"C{j}",
                        label=f"rate dt = {x:g}" if k == "compaction" else None)
    ax.axhline(dp["phi_eq"], color="0.6", ls=":", label="phi_eq(I)")
    ax.set(xlabel=f"rate t   (rate = beta phi_eq = {rate:.3g} 1/s)", ylabel="phi",
           title="(a) Drucker-Prager, AP-linearised step")
    ax.legend(fontsize=8)
    groups = ([n for n in results if n != "wall" and n not in DILATANCY_ANGLE],
              [n for n in results if n in DILATANCY_ANGLE])
    titles = ("(b) error; AP-linearised solid, backward Euler dashed",
              "(c) dilatancy-angle closures (clipped: AP runs beyond phi_max)")
    for ax_err, names, title in zip(axes[1:], groups, titles):
        for i, name in enumerate(names):
            res = results[name]
            for k, mk in zip(STARTS, ("o", "s")):
                for s, ls in zip(LayerScheme, ("-", "--")):
                    rows = [r for r in res[k][s.value] if r["err"] > 0]
                    ax_err.loglog([r["rate_dt"] for r in rows], [min(r["err"], ERROR_AXIS_CAP) for r in rows],
                                  ls=ls, marker=mk, ms=3, color=f"C{i}", lw=0.9,
                                  label=f"{name}, {k}" if s is LayerScheme.AP_LINEARISED else None)
        x = np.array([1e-3, 1e-1])
        ax_err.loglog(x, 0.2 * x, "k:", label="first order")
        ax_err.set(xlabel="rate dt", ylabel="max |phi - phi_ref| / |phi0 - phi_eq|", title=title,
                   ylim=(1e-5, 2 * ERROR_AXIS_CAP))
        ax_err.title.set_fontsize(9)
        ax_err.legend(fontsize=6.5, ncol=1)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="DP only, rate dt >= 1e-2 (smoke test)")
    args = parser.parse_args(argv)
    results = run(quick=args.quick)
    dp = results[EXACT]
    print(f"p = {P} Pa, |S| = {S} 1/s: phi_eq = {dp['phi_eq']:.5f}, DP rate beta phi_eq = {dp['rate']:.1f} 1/s")
    for k, v in dp["ref_check"].items():
        print(f"  {k}: max|Radau - logistic|/gap = {v['radau']:.1e}, max|logistic here - "
              f"granflow.verification| = {v['module']:.1e}")
    print("\nDrucker-Prager, AP-linearised (the solver's dilatancy row), errors relative to |phi0 - phi_eq|:")
    print(dp_table(results))
    print("\nEvery paper closure:")
    print(closure_table(results))
    fails = failures(results)
    print("\nFailed runs:" if fails else "\nFailed runs: none")
    for line in fails:
        print(f"* {line}")
    print(f"\nwall {results['wall']:.1f} s")
    if not args.quick:
        print(f"figure: {figure(results)}")


if __name__ == "__main__":
    main()
