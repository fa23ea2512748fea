"""Well-posedness under grid refinement: the Lagree column (a = 1.42) with the incompressible
mu(I) reference closure and with the paper's mu(I) model (issue 4, item 3), in the spirit of
Barker et al. (2015, J. Fluid Mech. 779, 794-818) and Martin et al. (2017).

Barker et al. (2015): incompressible mu(I) is linearly ill-posed (growth rate unbounded in the
wavenumber) where 4 nu^2 - 4 nu + mu^2 (1 - nu/2)^2 > 0, nu = I mu'(I)/mu, i.e. outside a window
I_low < I < I_high (docs/model.md §7; ``granflow stability window``); there, a simulation should show
features whose size follows the grid (shear bands one cell wide, |S| growing without bound,
grid-scale oscillations of p). The paper's mu(I) closure with its dilatancy law is claimed well
posed (Chupin & Dubois; docs/model.md §8).

Data: the a = 1.42 runs of validation/lagree_column (levels 32, 64, 128; cells 5/n, box cut at
Lz = 1.25; fields phi, u, w, p, |S| at t = 0.5, 1, 2), plus optional short runs at a finer level
to t = 0.5 (``--extra 256``; saved in data/ here). Measured per model, level and time:

* ``S_max``: max |S| over the dense cells (phi >= phi_c) with p > 0; ``S_max_bulk``: the same over
  *bulk* cells (their 3 x 3 neighbourhood dense with p > 0, and not in the first row above the base),
  which leaves out the toe corner and the surface band (``z_S_max_bulk``: its height);
  ``S_max_interior``: over bulk cells at z >= 0.25 H0 (out of the basal shear layer);
  ``S_p99``: 99th percentile (bulk).
* ``chk_p``, ``chk_S``: rms checkerboard amplitude |f00 - f10 - f01 + f11| / 4 over the 2 x 2 blocks
  of bulk cells (p in units of rho g H0; |S| relative to S_p99); ``chk_p_interior``: over the
  blocks of interior cells (z >= 0.25 H0). A smooth field gives
  (dx dz / 4) |f_xz| = O(dx^2) (falls 4x per level); a grid-scale oscillation keeps its amplitude.
* ``tv_p``: total variation sum |Delta p| x face length over the faces between bulk cells, per unit
  bulk area (tends to the mean of |p_x| + |p_z|, about 1 for a lithostatic p, for a smooth p;
  grows like 1/dx with grid-scale oscillations).
* ``band``: width of the shear band bounding the static wedge, on horizontal cuts at
  z = 0.1, 0.2, 0.3 H0: twice the distance from the |S| maximum of the cut (bulk cells) to the
  half-maximum on the wall side (the wedge); a band that follows the grid halves per level.
* ``I`` classes: fraction of the dense cells with p > 0 that flow (|S| >= 10 eps) with I below the
  Barker window, inside it, above it; the rest is quasi-static (|S| < 10 eps, eps = 5e-3 the
  regularisation rate). I = c_I d |S| / sqrt(p / rho_s), c_I = 2, d = 1/40, rho_s = 1/phi_max.

Run:   python validation/well_posedness/run.py [--extra 256 [--force]] [--plot-only] [--quick]
Time:  seconds (analysis of saved data); ``--extra 256``: ~2 min per model (50 steps at 256 x 64).
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from granflow.theory.barker import barker_window
from granflow.verification.scripts import load_json, load_script, save_json

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RESULTS = HERE / "results.json"
DATA = HERE / "data"
FIG_METRICS, FIG_MAPS = HERE / "refinement.png", HERE / "fields.png"
PHI_C = 0.3
"""numerics.ambient.phi_c default: cells below are the ambient."""
EPS = 5.0e-3
"""numerics.eps default, the regularisation strain rate [sqrt(g/H0)]."""
FLOWING_FACTOR = 10.0
"""A bulk cell flows if |S| >= FLOWING_FACTOR eps."""
P_MIN = 1.0e-3
"""p above which a dense cell counts as pressurised [rho g H0] (the case's delta_p)."""
CUT_HEIGHTS = (0.1, 0.2, 0.3)
"""Heights of the horizontal cuts across the failure plane [H0]."""
Z_INTERIOR = 0.25
"""Interior cells are bulk cells at least this high above the base [H0] (out of the basal layer)."""
EXTRA_TIME = 0.5
SMOOTH_RATIO = 4.0
"""Checkerboard amplitude ratio per halving of dx for a smooth field (second order)."""


def _lagree():
    """validation/lagree_column/run.py as a module (its runs, tags and data), loaded on first use."""
    return load_script(ROOT / "validation" / "lagree_column" / "run.py")


def window(mu_s: float = 0.32, delta_mu: float = 0.28, I0: float = 0.4) -> dict:
    """The Barker window of the Lagree parameters (= ``granflow stability window --mu1 0.32
    --mu2 0.6 --I0 0.4 --json``; c_I = 2)."""
    return barker_window(mu_s, mu_s + delta_mu, I0).to_dict()


# --- field metrics -------------------------------------------------------------------------------
def masks(phi, p) -> tuple[np.ndarray, np.ndarray]:
    """(dense with p > 0, bulk): bulk cells have their whole 3 x 3 neighbourhood dense with p > 0
    and are not in the first row above the base (shape (nx, nz), axis 0 = x)."""
    dense = (phi >= PHI_C) & (p > P_MIN)
    pad = np.pad(dense, 1, constant_values=False)
    nx, nz = dense.shape
    bulk = np.ones_like(dense)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            bulk &= pad[1 + di:1 + di + nx, 1 + dj:1 + dj + nz]
    bulk[:, 0] = False
    return dense, bulk


def checkerboard(f, mask) -> float:
    """rms of |f00 - f10 - f01 + f11| / 4 over the 2 x 2 blocks whose four cells are in ``mask``
    (all overlapping blocks); nan if none."""
    blocks = mask[:-1, :-1] & mask[1:, :-1] & mask[:-1, 1:] & mask[1:, 1:]
    c = (f[:-1, :-1] - f[1:, :-1] - f[:-1, 1:] + f[1:, 1:]) / 4.0
    return float(np.sqrt(np.mean(c[blocks] ** 2))) if blocks.any() else float("nan")


def total_variation(f, mask, dx: float, dz: float) -> float:
    """sum |Delta f| x face length over the faces between two cells of ``mask``."""
    fx = np.abs(np.diff(f, axis=0))[mask[1:] & mask[:-1]].sum() * dz
    fz = np.abs(np.diff(f, axis=1))[mask[:, 1:] & mask[:, :-1]].sum() * dx
    return float(fx + fz)


def band_width(x, z, S, bulk, height: float) -> float | None:
    """Width of the |S| band on the cut z = ``height``: 2 x (x_peak - x_half), x_peak and the
    maximum from the parabola through the largest |S| of the cut and its neighbours, x_half the
    half-maximum crossing on the wall side (linear interpolation); None if the cut has no bulk
    cell or no crossing."""
    j = int(np.argmin(np.abs(z - height)))
    cols = np.flatnonzero(bulk[:, j])
    if cols.size < 3:
        return None
    s = S[cols, j]
    k = int(np.argmax(s))
    x_pk, s_pk = float(x[cols[k]]), float(s[k])
    if 0 < k < cols.size - 1 and cols[k + 1] - cols[k - 1] == 2:  # parabolic vertex (sub-cell)
        curv = s[k - 1] - 2.0 * s[k] + s[k + 1]
        if curv < 0:
            shift = 0.5 * (s[k - 1] - s[k + 1]) / curv
            x_pk += shift * (x[1] - x[0])
            s_pk -= 0.25 * (s[k - 1] - s[k + 1]) * shift
    half = 0.5 * s_pk
    below = np.flatnonzero(s[:k] < half)
    if below.size == 0:
        return None
    i = int(below[-1])
    if cols[i + 1] != cols[i] + 1:  # not contiguous: no clean crossing
        return None
    xh = x[cols[i]] + (half - s[i]) / (s[i + 1] - s[i]) * (x[cols[i + 1]] - x[cols[i]])
    return float(2.0 * (x_pk - xh))


def inertial_number(S, p, d: float, phi_max: float, c_I: float = 2.0):
    """I = c_I d |S| / sqrt(p / rho_s), rho_s = 1/phi_max (dimensionless units)."""
    return c_I * d * S / np.sqrt(np.maximum(p, P_MIN) * phi_max)


def metrics(fields: dict, k: int, x, z, win: dict, d: float = 0.025, phi_max: float = 0.6) -> dict:
    """Every measure of the module docstring for record ``k`` of ``fields``."""
    phi, p, S = (np.asarray(fields[n][k], dtype=float) for n in ("phi", "p", "S"))
    dx, dz = float(x[1] - x[0]), float(z[1] - z[0])
    dense, bulk = masks(phi, p)
    sb = S[bulk]
    interior = bulk & (np.asarray(z)[None, :] >= Z_INTERIOR)
    p99 = float(np.percentile(sb, 99)) if sb.size else float("nan")
    flowing = dense & (S >= FLOWING_FACTOR * EPS)
    I = inertial_number(S, p, d, phi_max)
    nd = max(int(dense.sum()), 1)
    area = bulk.sum() * dx * dz
    return {
        "S_max": float(S[dense].max()) if dense.any() else float("nan"),
        "S_max_bulk": float(sb.max()) if sb.size else float("nan"),
        "z_S_max_bulk": float(z[np.unravel_index(np.argmax(np.where(bulk, S, -1.0)), S.shape)[1]]),
        "S_max_interior": float(S[interior].max()) if interior.any() else float("nan"),
        "S_p99": p99,
        "chk_p": checkerboard(p, bulk),
        "chk_p_interior": checkerboard(p, interior),
        "chk_S": checkerboard(S, bulk) / p99 if p99 > 0 else float("nan"),
        "tv_p": total_variation(p, bulk, dx, dz) / area if area > 0 else float("nan"),
        "band": {f"{h:g}": band_width(x, z, S, bulk, h) for h in CUT_HEIGHTS},
        "bulk_cells": int(bulk.sum()), "dense_cells": int(dense.sum()),
        "frac_static": float((dense & ~flowing).sum() / nd),
        "frac_below_window": float((flowing & (I < win["I_low"])).sum() / nd),
        "frac_in_window": float((flowing & (I >= win["I_low"]) & (I <= win["I_high"])).sum() / nd),
        "frac_above_window": float((flowing & (I > win["I_high"])).sum() / nd),
        "I_max": float(I[dense].max()) if dense.any() else float("nan"),
    }


def analyse_run(name: str, datadir: Path, win: dict) -> dict:
    """Metrics at every stored field time of one run."""
    arr = _lagree().load_arrays(name, datadir)
    return {f"{t:g}": metrics(arr, k, arr["x"], arr["z"], win) for k, t in enumerate(arr["field_t"])}


# --- runs and tables -----------------------------------------------------------------------------
def available(results: dict) -> list[tuple[str, int, str, Path]]:
    """(model, level, tag, data dir) of every a = 1.42 run with fields: the lagree_column runs
    (reduced box) and the extra runs of this folder."""
    L = _lagree()
    out = []
    for name, r in L.load_results()["runs"].items():
        if r["a"] == L.FIELD_ASPECT and r["box"] == "reduced" and (L.DATA / f"{name}.npz").exists():
            out.append((r["model"], r["n"], name, L.DATA))
    for name, r in results.get("extra_runs", {}).items():
        if (DATA / f"{name}.npz").exists():
            out.append((r["model"], r["n"], name, DATA))
    return sorted(out, key=lambda v: (v[0], v[1]))


def run_extra(level: int, results: dict, models=None, t_end: float = EXTRA_TIME,
              workdir: Path | None = None, datadir: Path = DATA, force: bool = False) -> None:
    """Short runs at ``level`` to ``t_end`` with the fields kept (saved in ``datadir``); runs
    already in ``results`` are kept unless ``force``."""
    L = _lagree()
    workdir = workdir or ROOT / "runs" / "validation_well_posedness"
    for model in models or L.MODELS:
        name = L.tag(L.FIELD_ASPECT, model, level)
        if name in results.setdefault("extra_runs", {}) and not force:
            continue
        rec = L.run_one(L.FIELD_ASPECT, model, level, workdir=workdir, datadir=datadir,
                        stop_time=t_end, keep_fields=True)
        results["extra_runs"][name] = rec
        save(results)


def run(resolution: int, quick: bool = False, model: str | None = None) -> dict:
    """The measures of one level: a run of lagree_column's a = 1.42 column at ``resolution`` (cells
    5/n) to t = :data:`EXTRA_TIME` with the fields kept, in a temporary directory, analysed with
    :func:`analyse_run`; ``quick``: lagree_column's :data:`QUICK_STEPS` steps only. Returns
    ``{"window", "metrics"}``."""
    L = _lagree()
    model = model or L.MODELS[0]
    win = window()
    with tempfile.TemporaryDirectory() as tmp:
        L.run_one(L.FIELD_ASPECT, model, resolution, workdir=Path(tmp), datadir=Path(tmp),
                  max_steps=L.QUICK_STEPS if quick else None, keep_fields=True, stop_time=EXTRA_TIME)
        return {"window": win, "metrics": analyse_run(L.tag(L.FIELD_ASPECT, model, resolution), Path(tmp), win)}


def save(results: dict, path: Path = RESULTS) -> None:
    save_json(results, path)


def _fmt(v, f: str = ".3g") -> str:
    return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) else format(v, f)


def markdown(results: dict) -> str:
    """One table per stored time: every measure per model and level."""
    m = results["metrics"]
    lines = []
    times = sorted({t for model in m.values() for lv in model.values() for t in lv}, key=float)
    for t in times:
        lines += ["", f"t = {t}", "",
                  ("| model | n | dx | S_max | S_max bulk (z) | ratio | S_max interior | ratio | chk_p | ratio | "
                   "chk_p interior | ratio | chk_S/S_p99 | tv_p | band z=0.1, 0.2, 0.3 | static | below | in | "
                   "above window | I_max |"),
                  "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|"]
        for model, levels in m.items():
            prev = None
            for n in sorted(levels, key=int):
                v = levels[n].get(t)
                if v is None:
                    continue
                r_s = v["S_max_bulk"] / prev["S_max_bulk"] if prev else None
                r_i = v["S_max_interior"] / prev["S_max_interior"] if prev else None
                r_c = prev["chk_p"] / v["chk_p"] if prev and v["chk_p"] > 0 else None
                r_ci = (prev["chk_p_interior"] / v["chk_p_interior"]
                        if prev and v["chk_p_interior"] > 0 else None)
                band = ", ".join(_fmt(b, ".2f") for b in v["band"].values())
                lines.append(
                    f"| {model} | {n} | {5.0 / int(n):.4f} | {_fmt(v['S_max'])} | {_fmt(v['S_max_bulk'])} "
                    f"({v['z_S_max_bulk']:.3f}) | {_fmt(r_s, '.2f')} | {_fmt(v['S_max_interior'])} | "
                    f"{_fmt(r_i, '.2f')} | {_fmt(v['chk_p'], '.2e')} | {_fmt(r_c, '.2f')} | "
                    f"{_fmt(v['chk_p_interior'], '.2e')} | {_fmt(r_ci, '.2f')} | "
                    f"{_fmt(v['chk_S'], '.2e')} | {_fmt(v['tv_p'], '.3f')} | {band} | {v['frac_static']:.3f} | "
                    f"{v['frac_below_window']:.3f} | {v['frac_in_window']:.3f} | {v['frac_above_window']:.3f} | "
                    f"{_fmt(v['I_max'], '.3f')} |")
                prev = v
    return "\n".join(lines)


# --- figures -------------------------------------------------------------------------------------
def figure_refinement(results: dict, path: Path = FIG_METRICS) -> Path:
    """S_max (bulk), chk_p and the band width against dx, per model and time."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.4))
    for i, (model, levels) in enumerate(results["metrics"].items()):
        ns = sorted(levels, key=int)
        for j, t in enumerate(("0.5", "1", "2")):
            pts = [(5.0 / int(n), levels[n][t]) for n in ns if t in levels[n]]
            if not pts:
                continue
            dx = np.array([p[0] for p in pts])
            style = {"color": f"C{j}", "ls": "-" if i == 0 else "--", "marker": "o" if i == 0 else "s"}
            lab = f"{model}, t = {t}"
            ax[0].loglog(dx, [p[1]["S_max_bulk"] for p in pts], label=lab + " (bulk)", **style)
            ax[0].loglog(dx, [p[1]["S_max_interior"] for p in pts], lw=0.8, alpha=0.6,
                         **{**style, "marker": "x"}, label=lab + " (z >= 0.25)")
            ax[1].loglog(dx, [p[1]["chk_p"] for p in pts], label=lab + " (bulk)", **style)
            ax[1].loglog(dx, [p[1]["chk_p_interior"] for p in pts], lw=0.8, alpha=0.6,
                         **{**style, "marker": "x"}, label=lab + " (z >= 0.25)")
            bw = [np.nanmean([b if b is not None else np.nan for b in p[1]["band"].values()]) for p in pts]
            ax[2].loglog(dx, bw, label=lab, **style)
    ref = np.array([5 / 256, 5 / 32])
    ax[0].loglog(ref, 1.5 * ref[0] / ref, "k:", label="~ 1/dx (grid-scale band)")
    ax[1].loglog(ref, 2e-3 * (ref / ref[-1]) ** 2, "k:", label="~ dx^2 (smooth p)")
    ax[2].loglog(ref, 2 * ref, "k:", label="2 dx")
    ax[0].set(xlabel="dx / H0", ylabel="max |S|", title="max |S|: bulk (basal layer) and z >= 0.25 H0")
    ax[1].set(xlabel="dx / H0", ylabel="rms checkerboard of p [rho g H0]", title="p checkerboard")
    ax[2].set(xlabel="dx / H0", ylabel="band width [H0] (mean of the cuts)", title="shear band at the wedge")
    for a in ax:
        a.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def figure_fields(results: dict, t: float = 0.5, path: Path = FIG_MAPS) -> Path:
    """|S| at time ``t`` for every level and model, with the contour I = I_low of the window."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    runs = available(results)
    models = sorted({r[0] for r in runs})
    levels = sorted({r[1] for r in runs})
    fig, axes = plt.subplots(len(models), len(levels), figsize=(3.6 * len(levels), 3.0 * len(models)),
                             squeeze=False)
    win = results["window"]
    for model, n, name, datadir in runs:
        ax = axes[models.index(model), levels.index(n)]
        arr = _lagree().load_arrays(name, datadir)
        k = int(np.argmin(np.abs(arr["field_t"] - t)))
        phi, p, S = (arr[f][k].astype(float) for f in ("phi", "p", "S"))
        dense = (phi >= PHI_C)
        Sm = np.ma.masked_where(~dense, np.maximum(S, 1e-3))
        im = ax.pcolormesh(arr["x"], arr["z"], Sm.T, norm=LogNorm(1e-2, 5), cmap="viridis", shading="nearest")
        I = np.ma.masked_where(~dense | (p <= P_MIN), inertial_number(S, p, 0.025, 0.6))
        ax.contour(arr["x"], arr["z"], I.T, levels=[win["I_low"]], colors="w", linewidths=0.8)
        ax.set(xlim=(0, 1.6), ylim=(0, 1.05), aspect="equal", title=f"{model} {n}², t = {t:g}")
        fig.colorbar(im, ax=ax, shrink=0.7, label="|S|")
    fig.suptitle(f"|S| (log) with the contour I = I_low = {win['I_low']:.4f} (Barker window)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--extra", type=int, default=0, help="also run this level to t = 0.5 (e.g. 256)")
    p.add_argument("--plot-only", action="store_true", help="(default behaviour) analyse saved data")
    p.add_argument("--quick", action="store_true", help="smoke test: metrics of a 16-cell, 20-step run")
    p.add_argument("--force", action="store_true", help="redo the --extra runs already saved")
    args = p.parse_args(argv)
    win = window()
    if args.quick:
        return run(_lagree().QUICK_LEVEL, quick=True)
    results = load_json(RESULTS, {})
    results["window"] = win
    if args.extra:
        run_extra(args.extra, results, force=args.force)
    metrics: dict = {}
    for model, n, name, datadir in available(results):
        metrics.setdefault(model, {})[str(n)] = analyse_run(name, datadir, win)
    results["metrics"] = metrics
    save(results)
    print(f"Barker window (mu1 = 0.32, mu2 = 0.6, I0 = 0.4, c_I = 2): I_low = {win['I_low']:.5f}, "
          f"I_high = {win['I_high']:.4f}")
    print(markdown(results))
    print("figures: " + ", ".join(f.name for f in (figure_refinement(results), figure_fields(results))))
    return results


if __name__ == "__main__":
    main()
