"""``granflow export vtk RUN [--out DIR]``: a run's records as legacy VTK files for ParaView.

Writes ``DIR/output_<record>.vtk`` (default DIR = RUN/vtk), one file per NetCDF record, with the
cell-centred fields as cell data and the velocity as a vector (:mod:`granflow.output.vtk`).
Bad input (missing or unreadable run) exits 2 with one line.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from granflow.cli import ExitCode


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``granflow export``."""
    p = sub.add_parser("export", help="export a run to other formats (vtk)")
    p.add_argument("format", choices=["vtk"], help="output format")
    p.add_argument("run", metavar="RUN_DIR_OR_NC", help="run directory or its output.nc")
    p.add_argument("--out", metavar="DIR", help="output directory (default: RUN/vtk)")
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    from granflow.cli.plot import open_run, resolve_output
    from granflow.output.vtk import export_run

    from granflow.output.paths import check_directory

    nc = resolve_output(args.run)
    outdir = check_directory(args.out if args.out is not None else nc.parent / "vtk",
                             "--out" if args.out is not None else "output directory (default RUN/vtk)")
    ds = open_run(nc)
    paths = export_run(ds, outdir)
    print(f"wrote {len(paths)} VTK file(s) to {outdir}/ (open {paths[0].name} ... in ParaView as a series)")
    return ExitCode.OK
