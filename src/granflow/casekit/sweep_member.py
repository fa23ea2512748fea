"""One member of a ``granflow sweep``: a case configuration run with :class:`CaseRun`.

:func:`run_member` is the member function handed to :func:`granflow.sweep.run_sweep`
(``run_member(config, outdir) -> summary``). It runs on a Dask worker, so it is a module-level
function that Dask pickles by reference. The member directory ``outdir`` is laid out as::

    outdir/member.json        overrides and full configuration   (written by run_sweep)
    outdir/summary.json       scalars of the run's summary       (run_sweep, on success only)
    outdir/error.json         message and traceback              (run_sweep, on failure only)
    outdir/run/case.toml      the member's effective case file (runnable with `granflow run`)
    outdir/run/output.nc, outdir/run/summary.json, outdir/run/checkpoints/, figures
                              the output of the run, exactly as `granflow run` writes it

The run lives in the sub-directory ``run/`` because :class:`CaseRun` writes its own
``summary.json`` even for a failed run, whereas ``outdir/summary.json`` is what tells
:func:`~granflow.sweep.run_sweep` that a member is finished.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from granflow.config import CaseConfig, load_case
from granflow.errors import GranflowInputError
from granflow.sweep import flatten_scalars

RUN_SUBDIR = "run"
"""Sub-directory of a member directory holding the run's own output."""
CASE_FILE = "case.toml"
"""Name of the member's effective case file inside :data:`RUN_SUBDIR`."""
EXCLUDED_SECTIONS = ("units", "files", "closure")
"""Summary entries left out of the member's scalars: units and file names are the same for every
member, and the closure description repeats the configuration (its swept values are override
columns of the sweep table)."""
STATUS_COMPLETED = "completed"
"""``status`` of the summary of a run that reached its stop time (:class:`RunStatus.COMPLETED`)."""


class MemberRunFailed(RuntimeError):
    """A member's run ended without completing (step failure or interruption)."""


def validate_member(config: Mapping[str, Any]) -> CaseConfig:
    """Validate a member's configuration (a case file as a nested dict, overrides applied).

    Raises
    ------
    GranflowInputError
        Every problem, each naming its key path (see :meth:`CaseConfig.from_dict`).
    """
    from granflow.casekit.memory import check_memory

    cfg = CaseConfig.from_dict(config)
    check_memory(cfg)
    return cfg


def summary_scalars(summary: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Scalar leaves (numbers, strings, booleans, None) of a run summary, nested keys dotted;
    lists and the :data:`EXCLUDED_SECTIONS` are left out."""
    kept = {k: v for k, v in summary.items() if prefix or k not in EXCLUDED_SECTIONS}
    return flatten_scalars(kept, prefix)


def write_case_file(config: Mapping[str, Any], path: Path) -> Path:
    """Write ``config`` as a TOML case file (so that the run's NetCDF records the case file)."""
    from granflow.config import dumps_toml

    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(dumps_toml(config), encoding="utf-8")
    return path


PROGRESS_FILE = "progress.json"
"""Written in the member directory while it runs (simulated time, stop time, wall time), read by
the sweep's progress display."""
PROGRESS_INTERVAL_S = 1.0


class MemberProgress:
    """Progress callback of a member's run: ``outdir/progress.json`` at most every second; then
    also, when the sweep was interrupted (its directory holds :data:`granflow.sweep.STOP_FILE`),
    ``request_stop``: the run stops after the current step, as ``granflow run`` on Ctrl-C."""

    def __init__(self, outdir: Path, request_stop=None) -> None:
        from granflow.sweep import STOP_FILE

        self.path = Path(outdir) / PROGRESS_FILE
        self.stop_file = Path(outdir).parent / STOP_FILE
        self.request_stop = request_stop
        self._last = -float("inf")

    def __call__(self, p) -> None:
        import time

        from granflow.output import write_json_atomic

        now = time.monotonic()
        if now - self._last < PROGRESS_INTERVAL_S:
            return
        self._last = now
        if self.request_stop is not None and self.stop_file.exists():
            self.request_stop("the sweep was stopped (Ctrl-C)")
        try:
            write_json_atomic(self.path, {"t": p.t, "stop_time": p.stop_time, "step": p.step,
                                          "wall_s": p.wall_s, "warming_up": p.warming_up})
        except OSError:  # progress is best effort
            pass


def run_member(config: dict[str, Any], outdir: Path) -> dict[str, Any]:
    """Run one sweep member; the member function of :func:`granflow.sweep.run_sweep`.

    Parameters
    ----------
    config : dict
        The member's case configuration (the base case file with the member's overrides).
    outdir : Path
        The member directory; the run writes into ``outdir/run/`` (replacing the output of an
        earlier, failed attempt).

    Returns
    -------
    dict
        The scalar entries of the run's ``summary.json`` (:func:`summary_scalars`), plus
        ``run_dir`` (the run's directory relative to ``outdir``).

    Raises
    ------
    GranflowInputError
        The configuration is invalid (normally caught before the sweep starts).
    MemberRunFailed
        The run stopped before its stop time (a step failed after every dt halving, or it was
        interrupted); its output, checkpoint and ``run/summary.json`` are kept.
    """
    from granflow.casekit.runner import CaseRun

    validate_member(config)  # a clear error before anything is written
    run_dir = Path(outdir) / RUN_SUBDIR
    case_file = write_case_file(config, run_dir / CASE_FILE)
    try:
        case = load_case(case_file)
    except GranflowInputError as err:  # pragma: no cover - validated above; a TOML round-trip bug
        raise GranflowInputError(f"member case file {case_file}: {err}") from None
    progress = MemberProgress(Path(outdir))
    run = CaseRun(case, run_dir, overwrite=True, progress=progress)
    progress.request_stop = run.sim.request_stop
    result = run.run()
    summary = result.summary
    if summary.get("status") != STATUS_COMPLETED:
        raise MemberRunFailed(f"run {summary.get('status')}: {result.message}")
    return {**summary_scalars(summary), "run_dir": RUN_SUBDIR}
