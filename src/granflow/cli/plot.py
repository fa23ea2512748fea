"""``granflow plot RUN``: a snapshot (PNG) or an animation (GIF) of a run's ``output.nc``.

``RUN`` is a run directory (its ``output.nc``) or a NetCDF file written by ``granflow run``. The
snapshot shows ``--var`` at the record nearest to ``--time`` (default: the last record) with the
free surface, the phi = phi_c contour (``numerics.ambient.phi_c`` of the run); the colour bar
carries the variable's ``long_name`` and ``units`` attributes. ``--animate OUT.gif`` writes one
frame per record (matplotlib's PillowWriter). Bad input (missing, unreadable or truncated file
(:func:`granflow.output.integrity.check_complete`), an unwritable --out or --animate, a variable
the file does not hold, a time outside the records, an unsupported image format) exits with
code 2 and one line ``granflow: error: ...``.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from granflow.cli import ExitCode
from granflow.errors import GranflowInputError

OUTPUT_FILE = "output.nc"
"""File of a run directory that is plotted (:data:`granflow.casekit.runner.OUTPUT_FILE`)."""
GIF_SUFFIX = ".gif"
TIME_RTOL = 1e-9
"""Relative tolerance (of the time span, at least 1 s) on --time at the ends of the records."""
DIMS = ("time", "x", "z")
"""Dimensions a run output must have, in any order (the fields are (time, z, x) on disk, (time,
x, z) in files written before; the plotting reads them by name)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``granflow plot``."""
    from granflow.plot_variables import PLOT_VARIABLES

    p = sub.add_parser("plot", help="snapshot (PNG) or animation (GIF) of a run's output.nc",
                       description="Plot a variable of a granflow run with its free surface "
                       "(phi = phi_c contour).")
    p.add_argument("run", metavar="RUN_DIR_OR_NC", help="run directory or its output.nc")
    p.add_argument("--var", default="phi", choices=PLOT_VARIABLES,
                   help="variable (speed = sqrt(u^2 + w^2)); default phi")
    p.add_argument("--time", type=float, metavar="T", help="time [s]; the nearest record is "
                   "plotted (default: the last record)")
    p.add_argument("--out", metavar="PNG", help="snapshot file (default: RUN/<var>_t<time>s.png; "
                   "with --animate, no snapshot unless --out is given)")
    p.add_argument("--animate", metavar="OUT.gif", help="write an animation over all records")
    p.set_defaults(func=cmd_plot)


def resolve_output(path: str | Path) -> Path:
    """The NetCDF file of a run directory or file argument (must exist)."""
    p = Path(path)
    if p.is_dir():
        p = p / OUTPUT_FILE
    if not p.is_file():
        raise GranflowInputError(f"{p}: no such file (give a run directory or its {OUTPUT_FILE})")
    return p


def open_run(path: Path):
    """Load a run's NetCDF file into memory; an unreadable file is bad input."""
    import xarray as xr

    from granflow.output.integrity import check_complete

    check_complete(path)  # a truncated classic file opens with zeros for the missing records
    try:
        with xr.open_dataset(path) as ds:
            ds = ds.load()
    except (OSError, ValueError, RuntimeError) as err:
        text = " ".join(str(err).split())
        raise GranflowInputError(f"{path}: not a readable NetCDF file ({text})") from None
    missing = [d for d in DIMS if d not in ds.dims]
    if missing:
        raise GranflowInputError(f"{path}: not a granflow run output (no dimension(s) "
                                 f"{', '.join(missing)})")
    if ds.sizes["time"] == 0:
        raise GranflowInputError(f"{path}: holds no records")
    return ds


def check_variable(ds, var: str, path: Path) -> None:
    from granflow.plotting import SPEED

    need = ("u", "w") if var == SPEED else (var,)
    absent = [v for v in need if v not in ds.data_vars]
    if absent:
        have = [v for v in ds.data_vars if set(ds[v].dims) == set(DIMS)]
        raise GranflowInputError(f"--var {var}: {path} has no {', '.join(absent)} (it holds "
                                 f"{', '.join(have) or 'no fields'}; see output.fields)")


def record_index(times, t: float | None, path: Path) -> int:
    """Index of the record nearest to ``t`` (the last record for None).

    Raises
    ------
    GranflowInputError
        If ``t`` is not finite or lies outside [first, last] record time (tolerance
        :data:`TIME_RTOL` of max(span, 1 s)).
    """
    import numpy as np

    times = np.asarray(times, dtype=float)
    if t is None:
        return int(times.size - 1)
    lo, hi = float(times.min()), float(times.max())
    tol = TIME_RTOL * max(hi - lo, 1.0)
    if not math.isfinite(t) or not lo - tol <= t <= hi + tol:
        raise GranflowInputError(f"--time {t:g}: outside the records of {path} "
                                 f"(t = {lo:g} to {hi:g} s)")
    return int(np.argmin(np.abs(times - t)))


def _check_format(path: Path, what: str = "--out") -> None:
    from matplotlib.backend_bases import FigureCanvasBase

    fmt = path.suffix.lstrip(".").lower()
    supported = FigureCanvasBase.get_supported_filetypes()
    if fmt not in supported:
        raise GranflowInputError(f"{what} {path}: unsupported image format {fmt!r} (use one of: "
                                 f"{', '.join(sorted(supported))})")


def cmd_plot(args: argparse.Namespace) -> int:
    """``granflow plot``; prints the files written."""
    from granflow import plotting
    from granflow.output.paths import check_directory, check_file  # (imports xarray: not at --help)

    nc = resolve_output(args.run)
    if args.animate is not None:
        check_file(args.animate, "--animate")
        if Path(args.animate).suffix.lower() != GIF_SUFFIX:
            raise GranflowInputError(f"--animate {args.animate}: expected a {GIF_SUFFIX} file")
    if args.out is not None:
        check_file(args.out, "--out")
        _check_format(Path(args.out))
    elif args.animate is None:
        check_directory(nc.parent, "RUN (the default --out goes there)")
    ds = open_run(nc)
    check_variable(ds, args.var, nc)
    index = record_index(ds["time"].values, args.time, nc)
    t = float(ds["time"].values[index])
    written = []
    if args.out is not None or args.animate is None:
        out = Path(args.out) if args.out else nc.parent / f"{args.var}_t{t:.6g}s.png"
        _check_format(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        plotting.snapshot_figure(ds, args.var, index, out)
        written.append(f"{out} ({args.var} at t = {t:.6g} s, record {index + 1} of "
                       f"{ds.sizes['time']})")
    if args.animate is not None:
        gif = Path(args.animate)
        gif.parent.mkdir(parents=True, exist_ok=True)
        plotting.animate_run(ds, args.var, gif)
        written.append(f"{gif} ({args.var}, {ds.sizes['time']} frames)")
    for line in written:
        print(f"granflow: wrote {line}")
    return ExitCode.OK
