"""``granflow sweep SWEEP.toml``: an ensemble of runs of one case on a Dask cluster.

A sweep file has two tables::

    [sweep]
    base = "column_collapse_fluidised.toml"   # case file, relative to the sweep file
    mode = "grid"                              # "grid" | "zip" | "lhs"
    # samples = 20, seed = 1                   # "lhs" only

    [parameters]
    "setup.b0" = { values = [0.0, 0.5, 0.9] }
    "material.d" = { range = [6e-5, 8e-5], n = 3 }    # n points, ends included
    # "gravity.slope_deg" = { lhs = [0.0, 20.0] }     # mode = "lhs"

Unquoted dotted keys (``setup.b0 = {...}``) and sub-tables (``[parameters.setup]``) mean the same.
Everything is checked before any member runs: unknown keys of the sweep file, the parameter
definitions (:class:`granflow.sweep.SweepSpec`), the base case file, and the case configuration of
every member (an error names the member, its overrides and the key). The members then run with
:func:`granflow.sweep.run_sweep` and :func:`granflow.casekit.sweep_member.run_member`; a table of
members is printed and ``DIR/sweep_summary.csv`` written.
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from granflow.cli import INTERRUPTED, ExitCode
from granflow.errors import GranflowInputError

SWEEP_TABLE = "sweep"
PARAMETERS_TABLE = "parameters"
SWEEP_KEYS = ("base", "mode", "samples", "seed")
"""Keys of the ``[sweep]`` table."""
KIND_KEYS = ("values", "range", "lhs")
"""Keys that make a table of ``[parameters]`` a parameter definition (else a namespace)."""
PARAMETER_KEYS = (*KIND_KEYS, "n")
LOCAL_WORKERS = 2
"""Worker processes of the local cluster when neither --workers nor --scheduler is given."""
WORKERS_PER_CORE = 4
"""--workers may be at most this many times the machine's cores (``--workers 100000`` never
finished starting its cluster)."""
DEFAULT_RUNS_DIR = "runs"
"""Parent of the default sweep directory ``runs/<sweep-file name>``."""
MAX_MEMBER_ERRORS = 3
"""Invalid members named in the error message (the count of the others is given)."""
KEY_SEP = "."
COLUMN_GAP = "  "
ERASE_LINE = "\x1b[K"
"""ANSI: erase to the end of the line (the in-place progress line on a terminal)."""

EXIT_CODES_HELP = f"""exit codes:
  {ExitCode.OK:<4d} every member completed (now or in an earlier invocation)
  {ExitCode.FAILED:<4d} at least one member failed (its error is in the table, in DIR/<id>/error.json
       and in sweep_summary.csv); the other members ran. Run the same command again to retry
       the failed members only (finished members are skipped).
  {ExitCode.BAD_INPUT:<4d} bad input, before any member runs: sweep-file or base-case errors, an invalid
       member configuration (named), --workers with --scheduler, a base that is a sweep
       file, DIR holding another sweep or a foreign sweep.json, an unwritable --out; also an
       unreachable --scheduler (after Dask's connect timeout, 30 s by default); nothing written
  {ExitCode.INTERNAL:<4d} internal error (a bug): traceback printed
  {INTERRUPTED:<4d} interrupted (Ctrl-C): the running members stop after their current step (a
       second Ctrl-C stops waiting), no other member starts; run the same command again to
       finish the sweep (the interrupted members run again from their start)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``granflow sweep`` (without importing Dask or xarray: keeps ``granflow`` fast)."""
    p = sub.add_parser("sweep", help="run an ensemble of a case on a Dask cluster",
                       description="Run every member of a sweep file (a base case plus parameter "
                       "values, ranges or a Latin hypercube) on a local Dask cluster or an "
                       "existing one; see docs/sweeps.md.", epilog=EXIT_CODES_HELP,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("sweep_file", metavar="SWEEP.toml", help="sweep file ([sweep] and [parameters])")
    p.add_argument("--out", metavar="DIR", help="sweep directory, visible to every worker "
                   f"(default {DEFAULT_RUNS_DIR}/<sweep-file name>)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="address of an existing Dask scheduler, "
                   "e.g. tcp://10.0.0.1:8786 (default: start a local cluster)")
    p.add_argument("--workers", type=int, metavar="N", help="worker processes of the local "
                   f"cluster (default {LOCAL_WORKERS}); not with --scheduler")
    p.set_defaults(func=cmd_sweep)


# --------------------------------------------------------------------------------------------
# reading and checking the sweep file
# --------------------------------------------------------------------------------------------
def _unknown(keys, allowed, where: str) -> None:
    bad = [k for k in keys if k not in allowed]
    if bad:
        raise GranflowInputError(f"{where}: unknown key(s) {', '.join(map(repr, bad))} (expected "
                                 f"any of: {', '.join(allowed)})")


def flatten_parameters(table: Mapping[str, Any], prefix: str = "") -> dict[str, dict[str, Any]]:
    """``[parameters]`` as ``{"a.b": {"values": [...]}, ...}``, accepting nested tables.

    A table is a parameter definition if it has one of :data:`KIND_KEYS`; otherwise it is a
    namespace (``[parameters.setup]``) whose entries are parameters.

    Raises
    ------
    GranflowInputError
        For a definition with unknown keys or an entry that is not a table.
    """
    out: dict[str, dict[str, Any]] = {}
    for key, value in table.items():
        name = f"{prefix}{key}"
        where = f"{PARAMETERS_TABLE}.{name!r}" if KEY_SEP in name else f"{PARAMETERS_TABLE}.{name}"
        if not isinstance(value, Mapping):
            raise GranflowInputError(f"{where}: expected a table such as {{values = [...]}}, "
                                     "{range = [lo, hi], n = k} or {lhs = [lo, hi]} "
                                     f"(got {value!r})")
        if any(k in value for k in KIND_KEYS):
            _unknown(value, PARAMETER_KEYS, where)
            out[name] = dict(value)
        elif not value:
            raise GranflowInputError(f"{where}: empty table; give values, range or lhs")
        else:
            out.update(flatten_parameters(value, name + KEY_SEP))
    return out


def with_all_sections(case: Mapping[str, Any]) -> dict[str, Any]:
    """The case file ``case`` with an empty table for every section it leaves at its defaults.

    :class:`granflow.sweep.SweepSpec` accepts an override only in a section of its base (so that a
    misspelt section is an error); the empty tables let a sweep set e.g. ``numerics.picard.tol``
    of a case file without ``[numerics]``. They do not change the case (every option has a
    default).
    """
    from granflow.config import CaseConfig

    out = dict(case)
    for section, field in CaseConfig.model_fields.items():
        if field.is_required():
            continue
        out.setdefault(section, {})
    return out


def load_sweep(path: str | Path):
    """Read a sweep file: ``(SweepSpec, base case path)``; every problem is a
    :class:`GranflowInputError` naming the file and the key."""
    from granflow.config import read_toml
    from granflow.sweep import SweepSpec

    path = Path(path)
    _, data = read_toml(path)
    _unknown(data, (SWEEP_TABLE, PARAMETERS_TABLE), f"{path}")
    sweep = data.get(SWEEP_TABLE)
    if not isinstance(sweep, Mapping):
        raise GranflowInputError(f"{path}: missing [{SWEEP_TABLE}] table (with base = \"case.toml\")")
    _unknown(sweep, SWEEP_KEYS, f"{path}: [{SWEEP_TABLE}]")
    base = sweep.get("base")
    if not isinstance(base, str) or not base:
        raise GranflowInputError(f"{path}: {SWEEP_TABLE}.base: expected the path of a case file "
                                 f"relative to the sweep file (got {base!r})")
    params = data.get(PARAMETERS_TABLE)
    if not isinstance(params, Mapping) or not params:
        raise GranflowInputError(f"{path}: missing or empty [{PARAMETERS_TABLE}] table")
    parameters = flatten_parameters(params)
    base_path = path.parent / base
    if base_path.resolve() == path.resolve():
        raise GranflowInputError(f"{path}: {SWEEP_TABLE}.base = {base!r} is this sweep file; give "
                                 "the case file the members are made from")
    _, base_data = read_toml(base_path)
    if SWEEP_TABLE in base_data or PARAMETERS_TABLE in base_data:
        raise GranflowInputError(f"{path}: {SWEEP_TABLE}.base = {base!r} is a sweep file, not a "
                                 "case file")
    base_data = with_all_sections(base_data)
    spec_data = {k: v for k, v in sweep.items() if k != "base"}
    try:
        spec = SweepSpec.from_dict({**spec_data, "base": base_data, "parameters": parameters})
    except GranflowInputError as err:
        raise GranflowInputError(f"{path}: {err}") from None
    return spec, base_path


def _describe(overrides: Mapping[str, Any]) -> str:
    return " ".join(f"{k}={_value(v)}" for k, v in overrides.items())


def _value(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v).replace(" ", "")


def validate_members(spec) -> int:
    """Validate the case configuration of every member; return the number of members.

    Raises
    ------
    GranflowInputError
        Naming the first :data:`MAX_MEMBER_ERRORS` invalid members, their overrides and the key.
    """
    from granflow.casekit.sweep_member import validate_member

    members = spec.members()
    errors = []
    for member_id, overrides in members:
        try:
            validate_member(spec.config(overrides))
        except GranflowInputError as err:
            errors.append(f"member {member_id} ({_describe(overrides)}): {err}")
    if errors:
        more = len(errors) - MAX_MEMBER_ERRORS
        tail = f"; and {more} more invalid member(s)" if more > 0 else ""
        raise GranflowInputError(f"{len(errors)} of {len(members)} member(s) invalid, nothing run: "
                                 + "; ".join(errors[:MAX_MEMBER_ERRORS]) + tail)
    return len(members)


# --------------------------------------------------------------------------------------------
# the command
# --------------------------------------------------------------------------------------------
def _runout(text: str) -> str:
    try:
        value = float(text)
    except ValueError:
        return "-"
    return f"{value:.4g}" if math.isfinite(value) else "-"


def _cell(text: str) -> str:
    """An override as read from the CSV, floats shortened (Latin-hypercube values)."""
    try:
        value = float(text)
    except ValueError:
        return text
    return f"{value:.6g}" if "." in text or "e" in text.lower() else text


def format_table(rows: list[dict[str, str]], override_keys: list[str]) -> list[str]:
    """Lines of the member table: id, overrides, status, run-out [m]."""
    from granflow.sweep import STATUS_OK

    head = ["member", "overrides", "status", "run-out [m]"]
    body = []
    for r in rows:
        status = r["status"] + (" (cached)" if r["cached"] == "True" else "")
        runout = _runout(r.get("runout_m", "")) if r["status"] == STATUS_OK else "-"
        body.append([r["member_id"], " ".join(f"{k}={_cell(r[k])}" for k in override_keys),
                     status, runout])
    widths = [max(len(line[i]) for line in [head, *body]) for i in range(len(head))]
    return [COLUMN_GAP.join(c.ljust(w) for c, w in zip(line, widths, strict=True)).rstrip()
            for line in [head, *body]]


class SweepDisplay:
    """Progress of a sweep on ``stream``: on a terminal with ``rich``, a bar per running member
    (its simulated time against its stop time) and one overall (members done); on a terminal
    without it, a line when a member finishes (``sweep: m0001 ok (2/3 done, 0:01:10 elapsed):
    run-out ...``) below one line of the running members' simulated times, rewritten every
    second; otherwise (a log file) the finished members' lines and, every :data:`LOG_INTERVAL_S`,
    the running members' times."""

    LOG_INTERVAL_S = 10.0

    def __init__(self, stream, tty: bool | None = None) -> None:
        self.stream = stream
        self.tty = stream.isatty() if tty is None else tty
        self._rich = None
        self._tasks: dict[str, Any] = {}
        self._last = 0.0
        self._open_line = False
        if self.tty:
            try:
                from rich.console import Console
                from rich.progress import Progress as RichProgress

                self._rich = RichProgress(console=Console(file=stream), transient=False)
                self._overall = self._rich.add_task("members done", total=None)
                self._rich.start()
            except ImportError:
                self._rich = None

    @staticmethod
    def member_line(p) -> str:
        from granflow.cli.run import _duration

        runout = p.summary.get("runout_m")
        what = f": run-out {_runout(str(runout))} m" if runout not in (None, "") else ""
        if p.summary.get("still_moving"):
            what += " (still moving: not final)"
        not_converged = p.summary.get("picard.not_converged_steps") or 0
        if p.summary.get("picard.max_sweeps") == 1:  # as on the end-of-run line of granflow run
            what += "; one solve per step"
        elif not_converged:
            what += f"; Picard not converged in {not_converged} of {p.summary.get('steps')} steps"
        return (f"{p.member_id} {p.status} ({p.done}/{p.total} done, "
                f"{_duration(p.elapsed_s)} elapsed){what}")

    @staticmethod
    def running_line(p) -> str:
        from granflow.cli.run import _duration

        parts = [f"{mid} t = {r.get('t', 0):.3g}/{r.get('stop_time', 0):.3g}"
                 + (" (compiling kernels, once)" if r.get("warming_up") else "")
                 for mid, r in sorted(p.running.items())]
        idle = "; starting the workers" if p.done == 0 else "; starting the next member(s)"
        return (f"{p.done}/{p.total} done, {_duration(p.elapsed_s)} elapsed"
                + (f"; running: {', '.join(parts)}" if parts else idle))

    def __call__(self, p) -> None:
        import time

        if self._rich is not None:
            self._rich.update(self._overall, total=p.total, completed=p.done)
            for mid, r in p.running.items():
                if mid not in self._tasks:
                    self._tasks[mid] = self._rich.add_task(mid, total=r.get("stop_time") or None)
                self._rich.update(self._tasks[mid], completed=r.get("t", 0.0),
                                  description=mid + (" (compiling kernels, once)" if r.get("warming_up") else ""))
            if p.member_id is not None:
                if p.member_id in self._tasks:
                    task = self._tasks[p.member_id]
                    total = next((t.total for t in self._rich.tasks if t.id == task), None)
                    self._rich.update(task, completed=total or 1.0, description=f"{p.member_id} {p.status}")
                self._rich.console.print(f"granflow: sweep: {self.member_line(p)}", markup=False,
                                         highlight=False)  # the run-out, warnings: kept above the bars
            return
        now = time.monotonic()
        if self.tty:  # a terminal without rich: the running line rewritten in place
            head = "\r" + ERASE_LINE
            if p.member_id is not None:
                self.stream.write(f"{head}granflow: sweep: {self.member_line(p)}\n")
                self._open_line = False
            if p.done < p.total:
                self.stream.write(f"{head}granflow: sweep: {self.running_line(p)}")
                self._open_line = True
        elif p.member_id is not None:
            self.stream.write(f"granflow: sweep: {self.member_line(p)}\n")
        elif now - self._last >= self.LOG_INTERVAL_S:
            self.stream.write(f"granflow: sweep: {self.running_line(p)}\n")
        else:
            return
        self._last = now
        self.stream.flush()

    def close(self) -> None:
        if self._rich is not None:
            self._rich.stop()
            self._rich = None
        if self._open_line:  # leave the terminal on a fresh line
            self.stream.write("\r" + ERASE_LINE)
            self.stream.flush()
            self._open_line = False


def cmd_sweep(args: argparse.Namespace) -> int:
    """``granflow sweep``; returns 0 if every member completed, 1 if any failed."""
    from granflow.casekit.sweep_member import run_member
    from granflow.sweep import STATUS_FAILED, SweepInterrupted, run_sweep

    if args.workers is not None and args.scheduler is not None:
        raise GranflowInputError("--workers sets the size of the local cluster; it cannot be "
                                 "combined with --scheduler")
    if args.workers is not None and args.workers < 1:
        raise GranflowInputError(f"--workers must be >= 1 (got {args.workers})")
    most = WORKERS_PER_CORE * (os.cpu_count() or 1)
    if args.workers is not None and args.workers > most:
        raise GranflowInputError(f"--workers {args.workers}: more than {most} ({WORKERS_PER_CORE} per "
                                 f"core on this machine of {os.cpu_count() or 1})")
    workers = None if args.scheduler is not None else (args.workers or LOCAL_WORKERS)
    spec, base_path = load_sweep(args.sweep_file)
    n = validate_members(spec)
    from granflow.output.paths import check_directory
    from granflow.sweep import SPEC_FILE, TABLE_FILE, check_sweep_directory

    if args.out is not None:
        out, what = args.out, "--out"
    else:
        out, what = Path(DEFAULT_RUNS_DIR) / Path(args.sweep_file).stem, "output directory (default)"
    out = check_directory(out, what, files=(SPEC_FILE, TABLE_FILE)).resolve()  # the workers
    # may not share our working directory
    check_sweep_directory(spec, out)
    where = f"scheduler {args.scheduler}" if args.scheduler else "a local Dask cluster"

    def started() -> None:
        print(f"granflow: sweep of {n} member(s) of {base_path} on {where}; output in {out}/",
              file=sys.stderr, flush=True)

    display = SweepDisplay(sys.stderr)
    try:
        table = run_sweep(spec, run_member, out, scheduler=args.scheduler, workers=workers,
                          started=started, progress=display)
    except OSError as err:  # e.g. the scheduler cannot be reached, out not writable
        hint = f" (--scheduler {args.scheduler})" if args.scheduler else ""
        raise GranflowInputError(f"sweep{hint}: {type(err).__name__}: {err}") from None
    except SweepInterrupted as stop:
        display.close()
        how = ("not waited for (second Ctrl-C)" if stop.abandoned
               else "stopped after their current step")
        print(f"granflow: sweep interrupted (Ctrl-C): {stop.done} of {stop.total} member(s) done, the "
              f"running ones {how}; run the same command again to finish it", file=sys.stderr)
        return INTERRUPTED
    finally:
        display.close()
    with open(table, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    for line in format_table(rows, list(spec.parameters)):
        print(line)
    failed = [r for r in rows if r["status"] == STATUS_FAILED]
    for r in failed:
        first = (r["error"].splitlines() or [""])[0]
        print(f"granflow: member {r['member_id']} failed: {first}", file=sys.stderr)
    print(f"granflow: {len(rows) - len(failed)} of {len(rows)} member(s) completed; table in {table}",
          file=sys.stderr)
    return ExitCode.FAILED if failed else ExitCode.OK
