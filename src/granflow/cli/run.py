"""``granflow run``, ``granflow list cases`` and ``granflow config show``.

The progress display lives here (library code does not print): with ``rich`` installed and a
terminal, a rich progress bar; on a terminal without ``rich``, one line rewritten in place; when
the output is not a terminal (a log file, a batch job), a plain line every
``output.log_interval`` seconds of wall time. Ctrl-C asks the simulation to stop after the current
step (a second Ctrl-C aborts the step); the run then writes its checkpoint, output and summary.
"""
from __future__ import annotations

import argparse
import contextlib
import enum
import json
import math
import shlex
import signal
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from granflow.cli import ExitCode
from granflow.errors import GranflowInputError

INTERRUPTED_EXIT = 130
"""Exit code of an interrupted run (128 + SIGINT, the shell convention)."""
DEFAULT_RUNS_DIR = "runs"
"""Parent of the default output directory ``runs/<case-file name>``."""
TTY_REFRESH_S = 0.2
"""Wall time between redraws of the in-place progress line [s]."""


class RunExit(enum.IntEnum):
    """Exit codes of ``granflow run``."""

    COMPLETED = ExitCode.OK
    STEP_FAILURE = ExitCode.FAILED
    BAD_INPUT = ExitCode.BAD_INPUT
    INTERNAL = ExitCode.INTERNAL
    INTERRUPTED = INTERRUPTED_EXIT


EXIT_CODES_HELP = f"""exit codes:
  {RunExit.COMPLETED:<4d} completed: reached time.stop_time (or time.max_steps)
  {RunExit.STEP_FAILURE:<4d} a step failed after every dt halving (NaN/Inf, phi out of bounds, Picard
       divergence, CFL): one line naming the quantity, time and step; the output so far,
       a final checkpoint of the last good state and summary.json are kept
  {RunExit.BAD_INPUT:<4d} bad input, before any computation: case-file error naming the key
       (unknown key, wrong type, NaN, out of range, unknown closure/case, TOML syntax with
       line/column), unreadable, insane (NaN, phi out of range) or mismatched (case, grid,
       physics) --restart checkpoint, existing output, an output directory that cannot be
       written, a grid beyond the memory available; nothing is written
  {RunExit.INTERNAL:<4d} internal error (a bug): traceback printed; output and summary.json kept
  {RunExit.INTERRUPTED:<4d} interrupted (Ctrl-C): stopped after the current step, checkpoint, output
       and summary.json written; continue with --restart DIR"""


def add_parsers(sub: argparse._SubParsersAction, parser_class: type) -> None:
    """Register ``run`` and ``config`` on the granflow sub-parsers."""
    p = sub.add_parser("run", help="run a case file (TOML)", description="Run a case file: NetCDF "
                       "output, summary.json, checkpoints.", epilog=EXIT_CODES_HELP,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("case", help="case file (TOML); see `granflow config show CASE`")
    p.add_argument("--out", metavar="DIR", help="output directory (default: output.directory, "
                   f"else {DEFAULT_RUNS_DIR}/<case-file name>)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", default=[],
                   help="override an option, value parsed as TOML, e.g. --set grid.nx=80")
    p.add_argument("--restart", metavar="CHECKPOINT", help="continue from a checkpoint file, or "
                   "from the newest checkpoint of a run directory")
    p.add_argument("--overwrite", action="store_true", help="replace the output of a previous run")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("config", help="case-file options")
    csub = p.add_subparsers(dest="config_command", required=True, parser_class=parser_class)
    s = csub.add_parser("show", help="every option of a case with default and units")
    s.add_argument("case", help="case registry key (granflow list cases) or a case file")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", default=[],
                   help="overrides (with a case file)")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=cmd_config_show)


# --------------------------------------------------------------------------------------------
# list cases / config show
# --------------------------------------------------------------------------------------------
def cmd_list(args: argparse.Namespace) -> int:
    """``granflow list closures|equilibria|cases``."""
    if args.what != "cases":
        from granflow.cli.commands import cmd_list as list_parts

        return list_parts(args)
    from granflow.cases import CASES
    from granflow.casekit.options import describe_options

    data = {n: {"summary": CASES.get(n).summary,
                "setup": {k: v for k, v in describe_options(n).items() if k.startswith("setup.")}}
            for n in CASES}
    if args.json:
        print(json.dumps(data, indent=2))
        return ExitCode.OK
    for name, info in data.items():
        print(f"{name}\n    {info['summary']}")
        for key, opt in info["setup"].items():
            print(f"    {key} = {_fmt(opt['default'])}  {opt['description']}")
    return ExitCode.OK


def _fmt(v: Any) -> str:
    return "<unset>" if v is None else json.dumps(v)


def cmd_config_show(args: argparse.Namespace) -> int:
    """Print every option (TOML-like: ``key = default  # description [units]``)."""
    from granflow.casekit.options import describe_options
    from granflow.config import load_case

    values = None
    name = args.case
    if name.endswith(".toml") or Path(name).is_file():
        cfg = load_case(name, args.set)
        values, name = cfg.model_dump(mode="json"), cfg.case.name
    elif args.set:
        raise GranflowInputError("config show: --set needs a case file, not a case name")
    options = describe_options(name, values)
    if args.json:
        print(json.dumps(options, indent=2))
        return ExitCode.OK
    section = None
    for key, opt in options.items():
        head, _, leaf = key.rpartition(".")
        if head != section:
            section = head
            print(f"\n[{head}]" if head else "")
        line = f"{leaf} = {_fmt(opt['default'] if opt.get('value') is None else opt['value'])}"
        print(f"{line:<40} # {opt['description']}")
    return ExitCode.OK


# --------------------------------------------------------------------------------------------
# progress
# --------------------------------------------------------------------------------------------
def _duration(s: float) -> str:
    if not math.isfinite(s):
        return "?"
    s = round(s)
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


class ProgressPrinter:
    """Progress display (see the module docstring). Call with a :class:`Progress`; :meth:`close`."""

    def __init__(self, stream: IO[str], log_interval: float, tty: bool | None = None) -> None:
        self.stream = stream
        self.tty = stream.isatty() if tty is None else tty
        self.log_interval = log_interval
        self._last = -math.inf
        self._rich = None
        if self.tty:
            try:
                from rich.console import Console  # optional dependency
                from rich.progress import Progress as RichProgress

                self._rich = RichProgress(console=Console(file=stream), transient=False)
                self._task = self._rich.add_task("granflow", total=None)
                self._rich.start()
            except ImportError:
                self._rich = None

    @staticmethod
    def line(p) -> str:
        if getattr(p, "warming_up", False):  # the first step's time is the kernels' compilation
            return (f"t = {p.t:.4g}/{p.stop_time:.4g} s  step {p.step}  dt = {p.dt:.3g} s  "
                    f"compiling kernels (once)  wall {_duration(p.wall_s)}")
        return (f"t = {p.t:.4g}/{p.stop_time:.4g} s  step {p.step}  dt = {p.dt:.3g} s  "
                f"{p.steps_per_s:.1f} steps/s  wall {_duration(p.wall_s)}  ETA {_duration(p.eta_s)}")

    def starting(self, t: float, stop_time: float) -> None:
        """Before the first step, which compiles the Numba kernels (seconds, once per
        installation): say so instead of leaving the terminal silent or showing an absurd ETA."""
        text = f"t = {t:.4g}/{stop_time:.4g} s  step 0  compiling kernels (once)"
        if self._rich is not None:
            self._rich.update(self._task, total=stop_time, completed=t, description=text)
        elif self.tty:
            self.stream.write("\r" + text + "\x1b[K")
            self.stream.flush()
        else:
            self.stream.write(f"granflow: {text}\n")
            self.stream.flush()

    def __call__(self, p) -> None:
        now = time.monotonic()
        if now - self._last < (TTY_REFRESH_S if self.tty else self.log_interval):
            return
        self._last = now
        if self._rich is not None:
            self._rich.update(self._task, total=p.stop_time, completed=p.t, description=self.line(p))
        elif self.tty:
            self.stream.write("\r" + self.line(p) + "\x1b[K")
            self.stream.flush()
        else:
            self.stream.write(f"granflow: {self.line(p)}\n")
            self.stream.flush()

    def close(self) -> None:
        if self._rich is not None:
            self._rich.stop()
        elif self.tty and self._last > -math.inf:
            self.stream.write("\n")
            self.stream.flush()


@contextlib.contextmanager
def stop_on_sigint(sim) -> Iterator[None]:
    """First Ctrl-C: ``sim.request_stop`` (finish the step, then stop cleanly); second: abort the
    step (``KeyboardInterrupt``; the state of the step's start is kept). Main thread only."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        if sim.stop_requested:
            raise KeyboardInterrupt
        sim.request_stop("interrupted (Ctrl-C)")
        print("\ngranflow: Ctrl-C: stopping after this step (Ctrl-C again to abort the step)",
              file=sys.stderr, flush=True)

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


# --------------------------------------------------------------------------------------------
# run
# --------------------------------------------------------------------------------------------
def output_directory(args: argparse.Namespace, config) -> Path:
    """The run directory, checked for writability (nothing created): ``--out``, else
    ``output.directory``, else ``runs/<case-file name>``."""
    from granflow.casekit.runner import CHECKPOINT_DIR, RUN_FILES, run_file_globs
    from granflow.output.paths import check_directory

    if args.out is not None:
        out, what = args.out, "--out"
    elif config.output.directory:
        out, what = config.output.directory, "output.directory"
    else:
        out, what = Path(DEFAULT_RUNS_DIR) / Path(args.case).stem, "output directory (default)"
    return check_directory(out, what, files=RUN_FILES, subdirs=(CHECKPOINT_DIR,),
                           file_globs=run_file_globs(config))


def completion_line(case, s: dict) -> str:
    """``completed t = 0.585 s in 585 steps (11.8 s wall); <the case's headline>`` in the case's
    units; ``(still moving: not final)`` when a settling flow ended before coming to rest."""
    from granflow.casekit import headlines

    headline = (case.headline or headlines.column_collapse)(s)
    if s.get("still_moving"):
        headline += " (still moving: not final)"
    picard = s.get("picard") or {}
    unconverged = picard.get("not_converged_steps")
    if picard.get("max_sweeps") == 1:  # by choice: a linearly implicit step (docs/solver.md)
        headline += "; one solve per step (numerics.picard.max_sweeps = 1)"
    elif unconverged:
        headline += f"; Picard not converged in {unconverged} of {s['steps']} steps"
    return (f"completed t = {s['t_final']:.6g} {case.unit('time')} in {s['steps']} steps "
            f"({s['wall_s']:.1f} s wall); {headline}")


def cmd_run(args: argparse.Namespace) -> int:
    """``granflow run CASE.toml``; returns a :class:`RunExit` code."""
    from granflow.casekit.runner import CaseRun, RunStatus
    from granflow.config import load_case

    config = load_case(args.case, args.set)
    out = output_directory(args, config)
    printer = None if args.quiet else ProgressPrinter(sys.stderr, config.output.log_interval)
    try:
        run = CaseRun(config, out, restart=args.restart, progress=printer, overwrite=args.overwrite)
        if printer is not None:
            printer.starting(run.sim.state.t, run.sim.stop_time)
        with stop_on_sigint(run.sim):
            result = run.run()
    finally:
        if printer is not None:
            printer.close()
    s = result.summary
    where = f"output in {out}/ (output.nc, summary.json" + (
        f", {s['files']['checkpoint']})" if s["files"]["checkpoint"] else ")")
    if result.status is RunStatus.COMPLETED:  # (a failed or interrupted run keeps its one line)
        for warning in s.get("warnings", []):
            print(f"granflow: warning: {warning}", file=sys.stderr)
        print(f"granflow: {completion_line(run.case, s)}; {where}")
        return RunExit.COMPLETED
    if result.status is RunStatus.FAILED:
        print(f"granflow: run failed: {result.message}; {where}", file=sys.stderr)
        return RunExit.STEP_FAILURE
    again = shlex.join(["granflow", "run", args.case, "--out", str(out), "--restart", str(out),
                        *[f"--set={item}" for item in args.set]])
    print(f"granflow: {result.message} at t = {s['t_final']:.6g} s, step {s['steps']}; {where}; "
          f"continue with: {again}", file=sys.stderr)
    return RunExit.INTERRUPTED
