"""Parameter sweeps on Dask: a base configuration, parameter ranges, one run per member.

A :class:`SweepSpec` holds a base configuration (the nested dict of a case file) and, for dotted
keys such as ``"material.d"``, either a list of ``values``, a ``range`` ``[lo, hi]`` with ``n``
points (linspace) or, in ``"lhs"`` mode, an interval ``lhs = [lo, hi]`` sampled by a Latin
hypercube of ``samples`` points with a fixed ``seed``. ``mode = "grid"`` takes the cartesian
product, ``"zip"`` pairs equal-length lists. :meth:`SweepSpec.members` gives deterministic ids
``m0000, m0001, ...``, so a sweep can be re-run to finish it.

:func:`run_sweep` runs every member on a Dask cluster (a local one by default, or an existing one
given its scheduler address; its workers must see ``outdir``, i.e. a shared file system). Each
member gets ``outdir/<id>/`` holding ``member.json`` (its overrides and full configuration), then
``summary.json`` on success or ``error.json`` (message + traceback) on failure. A failed member does
not stop the others; a member whose ``summary.json`` exists is not run again. The summaries are
collected into ``outdir/sweep_summary.csv``.

Dask (``pip install granflow[sweep]``) is imported only by :func:`run_sweep`.

The sweep definition is :mod:`granflow.sweep_spec`, the files of a sweep directory and the member
task :mod:`granflow.sweep_files`; both are re-exported here (``from granflow.sweep import
SweepSpec`` keeps working).
"""
from __future__ import annotations

import contextlib
import json
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from granflow.errors import GranflowInputError
from granflow.output.summary import jsonable, write_json_atomic
from granflow.sweep_files import (  # noqa: F401  (re-exported)
    ERROR_FILE,
    FIXED_COLUMNS,
    MEMBER_FILE,
    MEMBER_PROGRESS_FILE,
    SPEC_FILE,
    STATUS_FAILED,
    STATUS_OK,
    STATUS_STOPPED,
    STOP_FILE,
    SUMMARY_FILE,
    TABLE_FILE,
    MemberFunction,
    _check_member_dir,
    _check_spec_file,
    _write_table,
    check_sweep_directory,
    flatten_scalars,
    run_member_task,
)
from granflow.sweep_spec import (  # noqa: F401  (re-exported)
    ID_DIGITS,
    ID_PREFIX,
    KEY_SEP,
    MAX_MEMBERS,
    ParameterRange,
    SweepSpec,
    apply_overrides,
)

#: Default number of workers of the local cluster.
DEFAULT_WORKERS = 2
#: HTTP/dashboard address of the local scheduler: any free port (8787 may be taken).
LOCAL_DASHBOARD = ":0"


@dataclass(frozen=True)
class SweepProgress:
    """What a sweep's progress display gets: after each member finishes (``member_id``,
    ``status``) and every :data:`POLL_S` seconds meanwhile (``member_id`` None), with the
    running members' own progress (``running``: member id -> ``{"t", "stop_time", ...}``)."""

    member_id: str | None
    status: str | None
    done: int
    total: int
    elapsed_s: float
    running: dict[str, dict[str, Any]]
    summary: dict[str, Any]


POLL_S = 1.0
"""Seconds between progress reports while members run."""
WORKER_CLOSE_TIMEOUT_S = 60.0
"""Time a worker process gets to exit at the end (distributed's default, 5 s, is shorter than a
worker that imported the solver needs on a loaded machine: it was killed, with a warning)."""
STOP_WAIT_S = 120.0
"""How long an interrupted sweep waits for its running members to stop; a second Ctrl-C stops
waiting (the members' workers are then killed)."""
ABANDON_CLOSE_TIMEOUT_S = 2.0
"""Time a worker gets to exit after a second Ctrl-C."""


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`run_sweep`: the running members were stopped after their current step
    (``abandoned``: not waited for, after a second Ctrl-C). ``done`` of ``total`` members have a
    summary; running the sweep again runs the others."""

    def __init__(self, done: int, total: int, abandoned: bool) -> None:
        super().__init__(f"{done} of {total} member(s) done")
        self.done, self.total, self.abandoned = done, total, abandoned


def dask_setup(worker) -> None:
    """Preload of the local cluster's worker processes (``LocalCluster(preload=["granflow.sweep"])``):
    they ignore SIGINT, so a Ctrl-C on the terminal -- sent to every process of the foreground
    group -- reaches only ``granflow sweep``, which stops the members cleanly (the workers used to
    receive it too and die mid-member, with pages of tracebacks and "Worker process still alive
    ... killing" 48 s later)."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _sigint_ignored():
    """Ignore SIGINT in this process while the local cluster starts: the worker processes
    spawned meanwhile inherit the disposition from birth (before :func:`dask_setup` runs, a Ctrl-C
    killed them mid-import with pages of tracebacks), and the cluster is not left half started
    (distributed's atexit close then failed: "AssertionError: Status.init"). A Ctrl-C in these
    few seconds is lost; the next one stops the sweep."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _close_cluster(cluster, timeout: float = WORKER_CLOSE_TIMEOUT_S) -> None:
    """Close the local cluster's workers with a generous timeout, then the cluster: no
    "Worker process still alive ... killing" warnings."""
    import asyncio

    async def stop_workers():
        await asyncio.gather(*(w.close(timeout=timeout) for w in list(cluster.workers.values())),
                             return_exceptions=True)

    try:
        cluster.sync(stop_workers)
    finally:
        cluster.close()


class _Execution:
    """The members of one :func:`run_sweep` call: their table rows (the cached ones read from
    their ``summary.json``), the ones left to run, their futures and the progress reports."""

    def __init__(self, spec: SweepSpec, out: Path,
                 progress: Callable[[SweepProgress], None] | None) -> None:
        self.spec, self.out, self.progress = spec, out, progress
        self.members = spec.members()
        self.total = len(self.members)
        self.rows: dict[str, dict[str, Any]] = {}
        self.todo: list[tuple[str, dict[str, Any], Path]] = []
        for member_id, overrides in self.members:
            mdir = out / member_id
            row = {"member_id": member_id, "overrides": jsonable(overrides), "cached": False}
            self.rows[member_id] = row
            if (mdir / SUMMARY_FILE).is_file():
                summary = json.loads((mdir / SUMMARY_FILE).read_text())
                row.update(status=STATUS_OK, cached=True, summary=flatten_scalars(summary))
                continue
            self.todo.append((member_id, overrides, mdir))
        self.t_start = time.monotonic()
        self.finished_ids: set[str] = set()
        self.futures: dict[Any, str] = {}
        self.pending: set = set()
        self.done_count = self.ok_count = self.total - len(self.todo)
        self.abandoned = False

    def member_progress(self) -> dict[str, dict[str, Any]]:
        """The running members' progress files (simulated time / stop time)."""
        out_p = {}
        for mid, _, mdir in self.todo:
            path = Path(mdir) / MEMBER_PROGRESS_FILE
            if mid in self.finished_ids or not path.is_file():
                continue
            try:
                out_p[mid] = json.loads(path.read_text())
            except (OSError, ValueError):
                continue
        return out_p

    def report(self, member_id: str | None, status: str | None = None, done: int | None = None) -> None:
        if self.progress is None:
            return
        if member_id is not None:
            self.finished_ids.add(member_id)
        count = done if done is not None else len(self.finished_ids) + (self.total - len(self.todo))
        self.progress(SweepProgress(
            member_id=member_id, status=status, done=count, total=self.total,
            elapsed_s=time.monotonic() - self.t_start, running=self.member_progress(),
            summary=self.rows[member_id].get("summary", {}) if member_id else {}))

    def collect(self, future, mid: str) -> str:
        """The member's status and row from its finished future (a worker that died is a failed
        member with an ``error.json``)."""
        try:
            status, result = future.result()
        except Exception as err:  # noqa: BLE001 - e.g. a worker died (KilledWorker)
            status = STATUS_FAILED
            result = {"error": f"{type(err).__name__}: {err}",
                      "traceback": traceback.format_exc()}
            write_json_atomic(self.out / mid / ERROR_FILE, result)
        if status == STATUS_OK:
            self.rows[mid].update(status=status, summary=flatten_scalars(result))
        else:
            self.rows[mid].update(status=status, summary={}, error=result["error"])
        return status

    def prepare(self) -> list[tuple[str, dict[str, Any], str]]:
        """Write ``sweep.json`` and each member's ``member.json``; the tasks to submit."""
        self.out.mkdir(parents=True, exist_ok=True)
        (self.out / STOP_FILE).unlink(missing_ok=True)
        write_json_atomic(self.out / SPEC_FILE, self.spec.model_dump(mode="json"))
        tasks = []
        for member_id, overrides, mdir in self.todo:
            mdir.mkdir(exist_ok=True)
            config = self.spec.config(overrides)
            write_json_atomic(mdir / MEMBER_FILE, {"member_id": member_id, "overrides": overrides,
                                                   "config": config})
            tasks.append((member_id, config, str(mdir)))
        return tasks

    def drain(self, wait, deadline: float, stopping: bool = False) -> None:
        """Collect finished members until none is pending or ``deadline`` (monotonic clock);
        report the running ones every :data:`POLL_S` seconds."""
        while self.pending and time.monotonic() < deadline:
            try:
                finished, self.pending = wait(self.pending, timeout=POLL_S, return_when="FIRST_COMPLETED")
            except TimeoutError:  # none finished within POLL_S: report the running ones
                finished = set()
            for future in finished:
                mid = self.futures[future]
                status = self.collect(future, mid)
                self.done_count += 1
                self.ok_count += status == STATUS_OK
                self.report(mid, STATUS_STOPPED if stopping and status == STATUS_FAILED else status,
                            self.done_count)
            if not finished:
                self.report(None, done=self.done_count)

    def run(self, client, wait, run_member: MemberFunction, tasks) -> None:
        """Submit ``tasks`` and wait for them; Ctrl-C stops the running members after their step
        (:data:`STOP_FILE`), waits up to :data:`STOP_WAIT_S` (a second Ctrl-C: not at all) and
        raises :class:`SweepInterrupted`."""
        self.futures = {client.submit(run_member_task, run_member, config, mdir, pure=False): mid
                        for mid, config, mdir in tasks}
        self.pending = set(self.futures)
        self.report(None)
        try:
            self.drain(wait, float("inf"))
        except KeyboardInterrupt:  # stop the running members after their step, start no other
            (self.out / STOP_FILE).write_text("Ctrl-C\n", encoding="utf-8")
            try:
                self.drain(wait, time.monotonic() + STOP_WAIT_S, stopping=True)
            except KeyboardInterrupt:  # a second Ctrl-C: do not wait
                self.abandoned = True
            raise SweepInterrupted(self.ok_count, self.total, self.abandoned or bool(self.pending)) from None


def _check_cluster_options(scheduler: str | None, workers: int | None) -> None:
    if scheduler is not None and workers is not None:
        raise GranflowInputError("'workers' sets the size of the local cluster; it cannot be "
                                 "combined with 'scheduler'")
    if workers is not None and workers < 1:
        raise GranflowInputError(f"workers must be >= 1, got {workers}")


def run_sweep(spec: SweepSpec | Mapping[str, Any], run_member: MemberFunction,
              outdir: str | Path, scheduler: str | None = None,
              workers: int | None = None, started: Callable[[], None] | None = None,
              progress: Callable[[SweepProgress], None] | None = None) -> Path:
    """Run every member of ``spec`` with ``run_member`` on a Dask cluster; return the CSV table.

    Parameters
    ----------
    spec : SweepSpec or mapping
        The sweep.
    run_member : callable
        ``run_member(config, outdir) -> summary dict``; must be importable by the workers (a
        module-level function), since Dask pickles it by reference.
    outdir : path-like
        Sweep directory (created); must be visible to the workers.
    scheduler : str, optional
        Address of an existing Dask scheduler (``"tcp://host:8786"``). Default: start a
        ``distributed.LocalCluster`` of ``workers`` single-threaded processes, closed at the end.
    workers : int, optional
        Worker processes of the local cluster (default 2); not allowed with ``scheduler``.
    started : callable, optional
        Called once the cluster is reached (before anything is written), e.g. to announce the
        sweep: an unreachable scheduler raises ``OSError`` before it, with nothing written.
    progress : callable, optional
        ``progress(SweepProgress)``: at the start, after each member and every second.

    Returns
    -------
    Path
        ``outdir/sweep_summary.csv``: one row per member with ``member_id``, ``status`` (``ok`` or
        ``failed``), ``cached`` (``True`` if finished by an earlier run and not re-run),
        ``error``, the overrides, and the scalar entries of the summary (nested keys dotted).
    """
    if not isinstance(spec, SweepSpec):
        spec = SweepSpec.from_dict(spec)
    _check_cluster_options(scheduler, workers)
    try:
        from distributed import Client, LocalCluster, wait
    except ImportError as err:
        raise ImportError("sweeps need Dask: pip install 'granflow[sweep]'") from err

    out = Path(outdir)
    check_sweep_directory(spec, out)
    execution = _Execution(spec, out, progress)
    cluster = client = None
    try:
        if execution.todo:  # connect first: an unreachable scheduler must not leave files behind
            if scheduler is None:
                with _sigint_ignored():  # and dask_setup: the workers ignore Ctrl-C
                    cluster = LocalCluster(n_workers=workers or DEFAULT_WORKERS, threads_per_worker=1,
                                           processes=True, dashboard_address=LOCAL_DASHBOARD,
                                           preload=[__name__])
            client = Client(cluster if cluster is not None else scheduler)
        if started is not None:
            started()
        tasks = execution.prepare()
        if tasks:
            execution.run(client, wait, run_member, tasks)
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            _close_cluster(cluster, ABANDON_CLOSE_TIMEOUT_S if execution.abandoned
                           else WORKER_CLOSE_TIMEOUT_S)

    table = out / TABLE_FILE
    _write_table(table, [execution.rows[mid] for mid, _ in execution.members], list(spec.parameters))
    return table
