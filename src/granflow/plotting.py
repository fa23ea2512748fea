"""Figures (matplotlib, imported lazily, Agg backend) of a run's ``output.nc``: snapshots, the
front and kinetic energy, basal probes, single-variable snapshots and animations
(``granflow plot``). The closure and stability figures are :mod:`granflow.closure_figures`,
re-exported here. Nothing in the core imports this module."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from granflow.closure_figures import (  # noqa: F401  (re-exported)
    DEFAULT_PRESSURE,
    THEORY_DPI,
    closure_curves,
    closure_overview,
    condition_map_axes,
    growth_figure,
)
from granflow.figure_layout import pyplot as _pyplot
from granflow.figure_layout import save_figure
from granflow.terrain_figure import draw_terrain, solid_mask, x_name

LINE_FIGURE_IN = (7.0, 4.0)
"""Size [in] of the figures of time series (``front.png``, ``probes.png``)."""
SNAPSHOT_PANEL_IN = (4.6, 2.4)
"""Width and height [in] of a panel of ``snapshots.png``; a box drawn to scale that is taller
than wide gets narrower panels (its height ratio, plus :data:`SNAPSHOT_BAR_IN` for the colour
bar, at least :data:`SNAPSHOT_MIN_WIDTH_IN`)."""
SNAPSHOT_BAR_IN, SNAPSHOT_MIN_WIDTH_IN, SNAPSHOT_TITLE_IN = 1.6, 2.4, 0.6
SNAPSHOT_MIN_FIGURE_IN = 7.2
"""Least width [in] of ``snapshots.png``: its one-line suptitle fits."""
NOTE_XY = (0.02, 0.02)
"""Position (axes fraction) of the notes of ``front.png``."""


#: Relative speed levels of the snapshot contours (fractions of the record's largest grain speed).
SPEED_LEVEL_FRACTIONS = (0.1, 0.3, 0.5, 0.7, 0.9)
SPEED_CONTOUR_GID = "speed"


def rest_speed_of(ds) -> float:
    """The run's rest speed (global attribute ``rest_speed``, else ``output.rest_speed`` or its
    default 10 eps Lz from ``config_effective``) [speed units]: grain speeds below it are noise
    for the figures, as for the rest criterion of the run."""
    import tomllib

    if "rest_speed" in ds.attrs:
        return float(ds.attrs["rest_speed"])
    try:
        cfg = tomllib.loads(str(ds.attrs.get("config_effective", "")))
        rest = cfg.get("output", {}).get("rest_speed")
        if rest is not None:
            return float(rest)
        from granflow.casekit.runner import REST_SPEED_FACTOR  # the run's default, one definition

        return REST_SPEED_FACTOR * float(cfg["numerics"]["eps"]) * float(cfg["grid"]["Lz"])
    except (tomllib.TOMLDecodeError, KeyError, TypeError, ValueError):
        return 0.0


SURFACE_FRACTION = 0.5
"""Material fraction of the drawn free surface (indicator runs: the c = 1/2 contour; a cell's
material fills it from below, so its centre is on the surface at c = 1/2)."""


def grain_rule(ds) -> str:
    """How :func:`grain_cells` tells grains from air, for labels: ``"c > 0"`` (a run with the
    material fraction c, the indicator surface) or ``"phi >= phi_c"``."""
    return "c > 0" if "c" in ds else f"phi >= {free_surface_level(ds):g}"


def grain_cells(ds, index: int | None = None):
    """Boolean mask over (time, x, z) (or (x, z) for one record) of the cells holding grains:
    material fraction c > 0 when the run wrote c (indicator surface), else phi >= phi_c (the
    ambient below phi_c is air, whose velocity is not grain motion); None without either."""
    if "c" in ds:
        mask = np.asarray(ds["c"].transpose("time", "x", "z").values, dtype=float) > 0.0
    elif "phi" in ds:
        phi = ds["phi"].transpose("time", "x", "z")
        mask = np.asarray(phi.values, dtype=float) >= free_surface_level(ds)
    else:
        return None
    return mask if index is None else mask[index]


def speed_contours(ax, ds, index: int):
    """Labelled contours of the grain speed |u| of record ``index`` (:func:`grain_cells` only), at :data:`SPEED_LEVEL_FRACTIONS` of its largest value, each level above the run's rest
    speed; nothing where the grains are at rest (a static layer's 1e-12 m/s is not drawn).
    Returns the ContourSet or None."""
    speed = np.asarray(run_field(ds, SPEED).values[index], dtype=float)
    finite = speed[np.isfinite(speed)]
    if finite.size == 0:
        return None
    top = float(finite.max())
    floor = rest_speed_of(ds)
    levels = [f * top for f in SPEED_LEVEL_FRACTIONS if f * top > floor and f * top > 0.0]
    if not levels:
        return None
    cs = ax.contour(ds["x"].values, ds["z"].values, np.ma.masked_invalid(speed).T, levels=levels,
                    colors="k", linewidths=0.5)
    cs.set_gid(SPEED_CONTOUR_GID)
    ax.clabel(cs, fmt=lambda v: f"{v:.2g}", fontsize="xx-small", inline=True)
    return cs


AT_REST_KE = 1e-20
"""Kinetic energies below this [J m-1] are drawn as "at rest", not as a flat line at 1e-30."""
AT_REST_DECADES = 1e3
MAX_EQUAL_ASPECT = 4.0
"""Snapshots keep x and z to scale unless the box is more than this much taller than wide (or
wider than tall): the 4 x 22 inclined layer was a sliver."""


def equal_aspect(ds) -> bool:
    x, z = ds["x"].values, ds["z"].values
    if x.size < 2 or z.size < 2:
        return False
    ratio = (z[-1] - z[0] + (z[1] - z[0])) / (x[-1] - x[0] + (x[1] - x[0]))
    return 1.0 / MAX_EQUAL_ASPECT <= ratio <= MAX_EQUAL_ASPECT


def mesh_xz(ds) -> tuple[np.ndarray, np.ndarray]:
    """The cell edges (x, z) of a run for ``pcolormesh``, with an exact 0 at the origin: the
    edges matplotlib derives from the centres start at 8.7e-19, and its tick locator then
    crowded a narrow axis ("0.00.010.0203")."""
    from granflow.output.vtk import cell_edges

    return cell_edges(ds["x"].values), cell_edges(ds["z"].values)


def units_of(ds, name: str, default: str) -> str:
    """The ``units`` attribute of ``ds[name]`` (the case's units: H0, sqrt(H0/g) for a
    dimensionless case), else ``default``."""
    if name in ds.variables:
        return str(ds[name].attrs.get("units", default))
    return default


def run_figures(nc_path: str | Path, outdir: str | Path) -> list[Path]:
    """Figures of a ``granflow run`` output file: ``snapshots.png`` (phi, and p_f when non-zero,
    at the first, middle and last records, with the granular speed), ``front.png`` (front
    position and kinetic energy against time, :func:`front_figure`; not written when neither
    moves) and, with basal probes, ``probes.png`` (basal p_f and p against time)."""
    import xarray as xr

    plt = _pyplot()
    outdir = Path(outdir)
    with xr.open_dataset(nc_path) as ds:
        ds = ds.load()
    n = ds.sizes["time"]
    if n == 0:
        return []
    picks = sorted({0, n // 2, n - 1})
    lu, tu = units_of(ds, "x", "m"), units_of(ds, "time", "s")
    has_pf = "p_f" in ds and float(abs(ds["p_f"]).max()) > 0
    rows = 2 if has_pf else 1
    x, z = ds["x"].values, ds["z"].values
    panel_w = SNAPSHOT_PANEL_IN[0]
    if equal_aspect(ds) and x.size > 1 and z.size > 1:  # a tall box to scale: narrower panels
        ratio = (x[-1] - x[0]) / (z[-1] - z[0])
        panel_w = min(panel_w, max(SNAPSHOT_MIN_WIDTH_IN, SNAPSHOT_PANEL_IN[1] * ratio + SNAPSHOT_BAR_IN))
    width = max(panel_w * len(picks), SNAPSHOT_MIN_FIGURE_IN)  # room for the suptitle
    fig, axes = plt.subplots(rows, len(picks), squeeze=False, constrained_layout=True,
                             figsize=(width, SNAPSHOT_PANEL_IN[1] * rows + SNAPSHOT_TITLE_IN))
    for k, i in enumerate(picks):
        snap = ds.isel(time=i)
        ax = axes[0, k]
        m = ax.pcolormesh(*mesh_xz(ds), snap["phi"].transpose("z", "x").values, vmin=0.0,
                          vmax=float(ds.attrs.get("phi_max", 0.6)), cmap="YlOrBr")
        if "u" in snap and "w" in snap:
            speed_contours(ax, ds, i)
        draw_terrain(ax, ds)
        draw_front(ax, ds, i)
        ax.set_aspect("equal" if equal_aspect(ds) else "auto")
        ax.set_title(f"phi, t = {float(snap['time']):.3g} {tu}", fontsize="small")
        ax.set_xlabel(f"{x_name(ds)} [{lu}]")
        ax.set_ylabel(f"z [{lu}]")
        fig.colorbar(m, ax=ax, shrink=0.8)
        if has_pf:
            ax = axes[1, k]
            m = ax.pcolormesh(*mesh_xz(ds), snap["p_f"].transpose("z", "x").values, cmap="viridis")
            draw_terrain(ax, ds)
            ax.set_aspect("equal" if equal_aspect(ds) else "auto")
            ax.set_title(f"p_f [{units_of(ds, 'p_f', 'Pa')}], t = {float(snap['time']):.3g} {tu}", fontsize="small")
            ax.set_xlabel(f"{x_name(ds)} [{lu}]")
            ax.set_ylabel(f"z [{lu}]")
            fig.colorbar(m, ax=ax, shrink=0.8)
    fig.suptitle(f"packing phi; labelled contours: grain speed [{units_of(ds, 'u', 'm s-1')}] where "
                 f"{grain_rule(ds)}, above the rest speed; dashed: front x_f", fontsize="small")
    paths = [save_figure(fig, outdir / "snapshots.png", FIGURE_DPI)]
    front = front_figure(ds, outdir / "front.png")
    if front is not None:
        paths.append(front)
    t = ds["time"].values
    if "probe_p_f" in ds:
        fig, ax = plt.subplots(figsize=LINE_FIGURE_IN, constrained_layout=True)
        for k, xp in enumerate(ds["x_probe"].values):
            line, = ax.plot(t, ds["probe_p_f"].values[:, k], "-", label=f"p_f, x = {xp:.3g} m")
            ax.plot(t, ds["probe_p"].values[:, k], "--", color=line.get_color(), label=f"p, x = {xp:.3g} m")
        ax.set_xlabel(f"t [{tu}]")
        ax.set_ylabel(f"basal pressure [{units_of(ds, 'probe_p_f', 'Pa')}]")
        ax.legend(fontsize="small")
        ax.set_title("basal probes: pore pressure p_f (solid), granular pressure p (dashed)", fontsize="small")
        paths.append(save_figure(fig, outdir / "probes.png", FIGURE_DPI))
    return paths


def front_figure(ds, path: str | Path) -> Path | None:
    """``front.png``: the front position and the kinetic energy against time. Without a front (NaN:
    a periodic layer) a note (gid ``no_front``) and the energy on the main axis; energies below
    :data:`AT_REST_KE` are the note "grains at rest" (gid ``at_rest``), not a flat line at
    1e-30 J/m; an energy spanning decades is on a log axis (its zero at release is not drawn).
    Nothing to show -- a front that never moves and grains at rest (static, sheared, defluidising
    layers) -- writes no figure: None."""
    t = ds["time"].values
    lu, tu = units_of(ds, "x", "m"), units_of(ds, "time", "s")
    xf = np.asarray(ds["x_front"].values, dtype=float) if "x_front" in ds else np.array([])
    xf_finite = xf[np.isfinite(xf)]
    front_moves = xf_finite.size > 0 and float(np.ptp(xf_finite)) > 0.0
    ke = np.asarray(ds["kinetic_energy"].values, dtype=float) if "kinetic_energy" in ds else None
    positive = ke[np.isfinite(ke) & (ke > 0)] if ke is not None else np.array([])
    ke_moves = positive.size > 0 and positive.max() >= AT_REST_KE
    if not front_moves and not ke_moves:
        return None
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=LINE_FIGURE_IN, constrained_layout=True)
    ax.set_xlabel(f"t [{tu}]")
    if xf_finite.size:
        ax.plot(t, xf, "k-", label="front x_f")
        ax.set_ylabel(f"front position [{lu}]")
        ke_ax = ax.twinx() if ke is not None else None
    else:  # e.g. a periodic layer
        ax.text(NOTE_XY[0], NOTE_XY[1], "no front (the grains reach both sides)", transform=ax.transAxes,
                ha="left", va="bottom", fontsize="small", gid="no_front")
        ke_ax = ax
    if ke_ax is not None:
        ke_unit = units_of(ds, "kinetic_energy", "J m-1")
        if not ke_moves:  # no flat line at 1e-30
            ke_ax.set_yticks([])
            ke_ax.text(0.5, 0.9, f"grains at rest: kinetic energy <= {np.nanmax(ke):.1e} {ke_unit}",
                       transform=ke_ax.transAxes, ha="center", va="top", color="tab:red", fontsize="small",
                       bbox={"facecolor": "white", "edgecolor": "none"}, gid="at_rest")
        elif positive.max() > AT_REST_DECADES * positive.min():  # release to rest: many decades
            ke_ax.plot(t, np.where(ke > 0, ke, np.nan), "tab:red", label="kinetic energy (log axis)")
            ke_ax.set_yscale("log")
        else:
            ke_ax.plot(t, ke, "tab:red", label="kinetic energy")
        ke_ax.set_ylabel(f"kinetic energy [{ke_unit}]", color="tab:red")
    ax.set_title(f"{ds.attrs.get('case', '')} ({ds.attrs.get('closure', '')})", fontsize="small")
    return save_figure(fig, path, FIGURE_DPI)


# --------------------------------------------------------------------------------------------
# Snapshots and animations of a run's output.nc (granflow plot)
# --------------------------------------------------------------------------------------------
from granflow.plot_variables import PLOT_VARIABLES, SPEED  # noqa: E402  (one definition, NumPy-free)
#: Colour maps: packing, signed velocities (centred on zero), everything else.
PHI_CMAP, SIGNED_CMAP, DEFAULT_CMAP = "YlOrBr", "RdBu_r", "viridis"
SIGNED_VARIABLES = ("u", "w")
#: Grain quantities, blanked in the ambient (phi < phi_c) by :func:`run_field`.
GRAIN_VARIABLES = ("u", "w", "speed", "S")
#: Frames per second of ``--animate`` GIFs and resolution of the figures.
GIF_FPS = 5
FIGURE_DPI = 100
#: Figure width [in]; the height follows the aspect ratio of the box (within limits).
FIGURE_WIDTH_IN = 7.0
MIN_HEIGHT_IN, MAX_HEIGHT_IN = 2.0, 7.0
#: Extra height for the title, the axis labels and the colour bar below the axes [in].
FIGURE_MARGIN_IN = 1.6


def free_surface_level(ds) -> float:
    """phi_c of the run (``numerics.ambient.phi_c`` of the ``config_effective`` attribute): cells
    with phi < phi_c are the light ambient (NUMERICS.md §7), so the phi = phi_c contour is the free
    surface. Falls back to the default of :class:`granflow.model.AmbientParams`."""
    import tomllib

    from granflow.model import AmbientParams

    if "phi_c" in ds.attrs:  # written by granflow run
        return float(ds.attrs["phi_c"])
    try:
        config = tomllib.loads(str(ds.attrs.get("config_effective", "")))
        return float(config["numerics"]["ambient"]["phi_c"])
    except (tomllib.TOMLDecodeError, KeyError, TypeError, ValueError):
        return float(AmbientParams.model_fields["phi_c"].default)


def run_field(ds, var: str):
    """The field ``var`` of a run dataset over (time, x, z), with ``units`` and ``long_name``
    (``"speed"``: sqrt(u^2 + w^2) of the cell-centred velocities, in the units of ``u``). The
    grain quantities (:data:`GRAIN_VARIABLES`) are NaN in the ambient cells (phi < phi_c), whose
    velocity is the air's, not the grains'.

    Raises
    ------
    KeyError
        If the dataset does not hold the variable (or ``u`` and ``w`` for the speed).
    """
    if var == SPEED:
        u, w = ds["u"], ds["w"]
        field = np.hypot(u, w)
        field.attrs = {"units": u.attrs.get("units", ""), "long_name": "grain speed |u|"}
    else:
        field = ds[var]
    field = field.transpose("time", "x", "z")
    mask = grain_cells(ds) if var in GRAIN_VARIABLES else None
    if mask is not None:  # grain quantities only where there are grains (the ambient is air)
        attrs = dict(field.attrs)
        field = field.where(mask)
        attrs["long_name"] = f"{attrs.get('long_name', var)}, grains only ({grain_rule(ds)})"
        field.attrs = attrs
    field.name = var
    return field


def field_label(field) -> str:
    """Colour-bar label ``long_name [units]`` from the variable's attributes."""
    name = field.attrs.get("long_name", field.name)
    units = field.attrs.get("units")
    return f"{name} [{units}]" if units else str(name)


def colour_limits(field, var: str, phi_max: float | None = None) -> tuple[float, float]:
    """Colour range over every record: [0, phi_max] for phi, symmetric about 0 for u and w,
    the finite data range otherwise (widened when constant)."""
    if var == "phi" and phi_max is not None:
        return 0.0, float(phi_max)
    values = np.asarray(field.values, dtype=float)
    finite = values[np.isfinite(values)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)
    if var in SIGNED_VARIABLES:
        hi = max(abs(lo), abs(hi))
        lo = -hi
    if not hi > lo:  # constant field: any non-empty range around it
        pad = abs(hi) if hi != 0.0 else 1.0
        lo, hi = lo - pad, hi + pad
    return lo, hi


def _cmap(var: str) -> str:
    return PHI_CMAP if var == "phi" else SIGNED_CMAP if var in SIGNED_VARIABLES else DEFAULT_CMAP


def _title(ds, var: str, index: int) -> str:
    n = ds.sizes["time"]
    t = float(ds["time"].values[index])
    return (f"{ds.attrs.get('case', 'granflow')}: {var}, t = {t:.4g} {units_of(ds, 'time', 's')} "
            f"(record {index + 1}/{n})")


def _surface(ax, ds, index: int, phi_c: float):
    """The free surface of record ``index``: the c = :data:`SURFACE_FRACTION` contour when the run
    wrote c, else the phi = phi_c one (None if the field is absent or does not cross the level)."""
    name, level = ("c", SURFACE_FRACTION) if "c" in ds else ("phi", phi_c)
    if name not in ds:
        return None
    q = np.asarray(ds[name].transpose("time", "x", "z").values[index], dtype=float)
    rock = solid_mask(ds)
    if rock is not None:  # the rock under a base profile is no free surface: read it as material
        q = np.where(rock, np.nanmax(q), q)
    if not (np.nanmin(q) < level < np.nanmax(q)):
        return None
    return ax.contour(ds["x"].values, ds["z"].values, q.T, levels=[level], colors="k",
                      linewidths=1.0)


FRONT_GID = "front"
"""``gid`` of the front marker drawn on snapshots (the ``x_front`` of the run)."""


def front_at(ds, index: int) -> float:
    """The front of record ``index`` [m]: the run's ``x_front`` if written, else
    ``ds.granflow.front_position()`` -- the same definition (docs/cases.md, "Front position")."""
    if "x_front" in ds:
        return float(ds["x_front"].values[index])
    try:
        import granflow.output  # noqa: F401 - registers the accessor

        return float(ds.granflow.front_position().values[index])
    except Exception:  # noqa: BLE001 - no phi or no phi_max: no front to show
        return float("nan")


def draw_front(ax, ds, index: int):
    """Mark the front x_f of record ``index`` with a dashed vertical line (gid ``front``); None if
    there is no front."""
    x_f = front_at(ds, index)
    if not np.isfinite(x_f):
        return None
    return ax.axvline(x_f, color="tab:blue", ls="--", lw=1.0, gid=FRONT_GID,
                      label=f"front x_f = {x_f:.4g}")


def _figure(ds):
    plt = _pyplot()
    x, z = ds["x"].values, ds["z"].values
    lx = float(x[-1] - x[0]) if x.size > 1 else 1.0
    lz = float(z[-1] - z[0]) if z.size > 1 else 1.0
    height = min(max(FIGURE_WIDTH_IN * lz / lx, MIN_HEIGHT_IN), MAX_HEIGHT_IN) + FIGURE_MARGIN_IN
    fig, ax = plt.subplots(figsize=(FIGURE_WIDTH_IN, height), constrained_layout=True)
    return plt, fig, ax


def snapshot_axes(ax, ds, var: str, index: int, limits: tuple[float, float] | None = None):
    """Draw ``var`` at record ``index`` on ``ax`` with the free surface (phi = phi_c contour).

    Parameters
    ----------
    ax : matplotlib Axes
    ds : xarray.Dataset
        A ``granflow run`` output (``output.nc``).
    var : str
        One of :data:`PLOT_VARIABLES`.
    index : int
        Record (time index).
    limits : (float, float), optional
        Colour range; default :func:`colour_limits` of this record.

    Returns
    -------
    mesh, contour, colorbar
        The ``pcolormesh``, the free-surface ``ContourSet`` (None if there is none) and the
        colour bar (label ``long_name [units]``).
    """
    field = run_field(ds, var)
    vmin, vmax = limits or colour_limits(field[index], var, ds.attrs.get("phi_max"))
    mesh = ax.pcolormesh(*mesh_xz(ds), np.asarray(field.values[index], dtype=float).T, vmin=vmin,
                         vmax=vmax, cmap=_cmap(var))
    contour = _surface(ax, ds, index, free_surface_level(ds))
    draw_terrain(ax, ds)
    draw_front(ax, ds, index)
    bar = ax.figure.colorbar(mesh, ax=ax, location="bottom", shrink=0.9, aspect=40)
    bar.set_label(field_label(field))
    ax.set_aspect("equal")
    ax.set_xlabel(f"{x_name(ds)} [{ds['x'].attrs.get('units', 'm')}]")
    ax.set_ylabel(f"z [{ds['z'].attrs.get('units', 'm')}]")
    ax.set_title(_title(ds, var, index) + f"; line: phi = {free_surface_level(ds):g}, dashed: front",
                 fontsize="small")
    return mesh, contour, bar


def snapshot_figure(ds, var: str, index: int, path: str | Path) -> Path:
    """Write the snapshot of ``var`` at record ``index`` (:func:`snapshot_axes`) to ``path``."""
    plt, fig, ax = _figure(ds)
    snapshot_axes(ax, ds, var, index)
    return save_figure(fig, path, FIGURE_DPI)


def animate_run(ds, var: str, path: str | Path, fps: int = GIF_FPS) -> Path:
    """Write a GIF of ``var`` over every record of ``ds`` (one frame per record, fixed colour
    range over the run, the free surface redrawn in each frame) with
    :class:`matplotlib.animation.PillowWriter`."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    plt, fig, ax = _figure(ds)
    field = run_field(ds, var)
    limits = colour_limits(field, var, ds.attrs.get("phi_max"))
    mesh, contour, _ = snapshot_axes(ax, ds, var, 0, limits)
    phi_c = free_surface_level(ds)
    values = np.asarray(field.values, dtype=float)
    state = {"contour": contour}

    def update(i: int):
        mesh.set_array(values[i].T)
        if state["contour"] is not None:
            state["contour"].remove()
        state["contour"] = _surface(ax, ds, i, phi_c)
        for line in [ln for ln in ax.lines if ln.get_gid() == FRONT_GID]:
            line.remove()
        draw_front(ax, ds, i)
        ax.set_title(_title(ds, var, i) + f"; line: phi = {phi_c:g}, dashed: front", fontsize="small")
        return (mesh,)

    anim = FuncAnimation(fig, update, frames=ds.sizes["time"], blit=False, repeat=False)
    anim.save(path, writer=PillowWriter(fps=fps), dpi=FIGURE_DPI)
    plt.close(fig)
    return Path(path)
