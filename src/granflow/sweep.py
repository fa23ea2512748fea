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
"""
from __future__ import annotations

import contextlib
import copy
import csv
import io
import itertools
import json
import math
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, ValidationError, model_validator

from granflow.errors import GranflowInputError
from granflow.output.summary import atomic_write, jsonable, write_json_atomic
from granflow.params import Params, format_validation_error
from granflow.safe_toml import MAX_NESTING

#: A member function: (full configuration, its output directory) -> summary (JSON-able dict).
MemberFunction = Callable[[dict[str, Any], Path], Mapping[str, Any]]

#: Files of a member directory and of the sweep directory.
SUMMARY_FILE = "summary.json"
ERROR_FILE = "error.json"
MEMBER_FILE = "member.json"
SPEC_FILE = "sweep.json"
TABLE_FILE = "sweep_summary.csv"
#: Minimum number of digits of member ids (m0000).
MAX_MEMBERS = 10_000
"""Most members of one sweep (a guard against ``n = 1000000000``, which never finished making the
member list); split a larger study into several sweeps."""
ID_DIGITS = 4
ID_PREFIX = "m"
#: Default number of workers of the local cluster.
DEFAULT_WORKERS = 2
#: HTTP/dashboard address of the local scheduler: any free port (8787 may be taken).
LOCAL_DASHBOARD = ":0"
#: Member statuses in the table.
STATUS_OK = "ok"
STATUS_FAILED = "failed"
STATUS_STOPPED = "stopped"
"""Status shown by the progress display for a member stopped by Ctrl-C (failed in the files)."""
#: Separator of nested keys (overrides and flattened summaries).
KEY_SEP = "."
#: Fixed leading columns of the table.
FIXED_COLUMNS = ("member_id", "status", "cached", "error")


class ParameterRange(Params):
    """One swept parameter: exactly one of ``values``, ``range`` (+ ``n``) or ``lhs``."""

    values: list[Any] | None = Field(default=None, min_length=1)
    range: tuple[float, float] | None = None
    n: int | None = Field(default=None, ge=1, le=MAX_MEMBERS)
    lhs: tuple[float, float] | None = None

    @model_validator(mode="after")
    def _one_kind(self) -> ParameterRange:
        kinds = [k for k in ("values", "range", "lhs") if getattr(self, k) is not None]
        if len(kinds) != 1:
            raise ValueError("give exactly one of 'values', 'range' (with 'n') or 'lhs'")
        if (self.range is None) != (self.n is None):
            raise ValueError("'range' and 'n' go together")
        interval = self.range or self.lhs
        if interval is not None and not interval[0] < interval[1]:
            raise ValueError(f"interval must have lo < hi, got {list(interval)}")
        return self

    def points(self) -> list[Any]:
        """The values of a ``values`` or ``range`` parameter (``range``: n points, ends included)."""
        if self.values is not None:
            return list(self.values)
        if self.range is not None:
            return [float(v) for v in np.linspace(self.range[0], self.range[1], self.n)]
        raise GranflowInputError("an 'lhs' parameter has no fixed points; use mode = 'lhs'")


class SweepSpec(Params):
    """A sweep: base configuration, swept parameters (dotted keys) and how to combine them.

    Parameters
    ----------
    base : dict
        The base configuration (e.g. a parsed case file).
    parameters : dict
        ``"a.b" -> {"values": [...]}``, ``{"range": [lo, hi], "n": k}`` or ``{"lhs": [lo, hi]}``.
    mode : {"grid", "zip", "lhs"}
        Cartesian product, element-wise pairing (equal lengths), or Latin hypercube.
    samples, seed : int
        Number of Latin-hypercube members and the seed; both required in ``"lhs"`` mode (a fixed
        seed makes member ids stable, which re-running a sweep relies on).

    Examples
    --------
    >>> spec = SweepSpec.from_dict({"base": {"material": {"d": 7e-5}},
    ...     "parameters": {"material.d": {"values": [6e-5, 8e-5]}, "slope": {"range": [0, 10], "n": 2}}})
    >>> [(m, o["slope"]) for m, o in spec.members()]
    [('m0000', 0.0), ('m0001', 10.0), ('m0002', 0.0), ('m0003', 10.0)]
    """

    base: dict[str, Any] = Field(default_factory=dict)
    parameters: dict[str, ParameterRange] = Field(min_length=1)
    mode: Literal["grid", "zip", "lhs"] = "grid"
    samples: int | None = Field(default=None, ge=1, le=MAX_MEMBERS)
    seed: int | None = Field(default=None, ge=0)

    @model_validator(mode="after")
    def _consistent(self) -> SweepSpec:
        is_lhs = {k: p.lhs is not None for k, p in self.parameters.items()}
        if self.mode == "lhs":
            if not all(is_lhs.values()):
                raise ValueError(f"mode 'lhs': every parameter needs 'lhs = [lo, hi]', not "
                                 f"{[k for k, v in is_lhs.items() if not v]}")
            if self.samples is None or self.seed is None:
                raise ValueError("mode 'lhs' needs 'samples' and 'seed'")
        else:
            if any(is_lhs.values()):
                raise ValueError(f"'lhs' parameters {[k for k, v in is_lhs.items() if v]} need "
                                 "mode = 'lhs'")
            if self.samples is not None or self.seed is not None:
                raise ValueError("'samples' and 'seed' apply to mode 'lhs' only")
        if self.mode == "grid":
            count = math.prod(len(p.values) if p.values is not None else p.n
                              for p in self.parameters.values())
            if count > MAX_MEMBERS:
                raise ValueError(f"mode 'grid' makes {count} members, more than {MAX_MEMBERS} "
                                 "(granflow.sweep.MAX_MEMBERS); split the sweep")
        if self.mode == "zip":
            lengths = {k: len(p.points()) for k, p in self.parameters.items()}
            if len(set(lengths.values())) != 1:
                raise ValueError(f"mode 'zip' needs equally long parameter lists, got {lengths}")
        for key in self.parameters:
            if not all(key.split(KEY_SEP)):
                raise ValueError(f"bad parameter key {key!r}")
            if len(key.split(KEY_SEP)) > MAX_NESTING:
                raise ValueError(f"parameter key {key[:40]!r}... of {len(key.split(KEY_SEP))} parts; "
                                 f"tables are nested at most {MAX_NESTING} levels deep")
            apply_overrides(self.base, {key: None})  # unknown section -> error now, not per member
        return self

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SweepSpec:
        """Validate ``data`` (e.g. a parsed ``[sweep]`` TOML table); errors name the key."""
        try:
            return cls.model_validate(dict(data))
        except ValidationError as err:
            raise GranflowInputError(format_validation_error(err, "sweep")) from None

    def _lhs_points(self) -> list[dict[str, float]]:
        from scipy.stats import qmc  # scipy.stats is slow to import; only needed here

        d = len(self.parameters)
        try:
            sampler = qmc.LatinHypercube(d=d, rng=self.seed)
        except TypeError:  # scipy < 1.15 calls it seed
            sampler = qmc.LatinHypercube(d=d, seed=self.seed)
        unit = sampler.random(self.samples)
        lo = np.array([p.lhs[0] for p in self.parameters.values()])
        hi = np.array([p.lhs[1] for p in self.parameters.values()])
        pts = qmc.scale(unit, lo, hi)
        return [{k: float(row[j]) for j, k in enumerate(self.parameters)} for row in pts]

    def members(self) -> list[tuple[str, dict[str, Any]]]:
        """``(member_id, overrides)`` for every member, in a deterministic order."""
        keys = list(self.parameters)
        if self.mode == "lhs":
            combos = self._lhs_points()
        else:
            lists = [self.parameters[k].points() for k in keys]
            rows = itertools.product(*lists) if self.mode == "grid" else zip(*lists, strict=True)
            combos = [dict(zip(keys, row, strict=True)) for row in rows]
        width = max(ID_DIGITS, len(str(len(combos) - 1)))
        return [(f"{ID_PREFIX}{i:0{width}d}", c) for i, c in enumerate(combos)]

    def config(self, overrides: Mapping[str, Any]) -> dict[str, Any]:
        """The base configuration with ``overrides`` applied (see :func:`apply_overrides`)."""
        return apply_overrides(self.base, overrides)


def apply_overrides(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """A deep copy of ``base`` with dotted keys set: ``{"material.d": 1e-4}``.

    Missing intermediate tables are created. If ``base`` has sections (dict values), the section
    of a dotted key (its first component) must be one of them, so that a misspelt section is an
    error naming it. Other keys (undotted new keys, deeper keys) are checked by the case's own
    strict configuration when the member runs, not here.

    Raises
    ------
    GranflowInputError
        For an unknown top-level section, or a key that descends into a non-table value.
    """
    out = copy.deepcopy(dict(base))
    has_sections = any(isinstance(v, Mapping) for v in out.values())
    for key, value in overrides.items():
        parts = key.split(KEY_SEP)
        if has_sections and len(parts) > 1 and parts[0] not in out:
            raise GranflowInputError(f"override {key!r}: unknown section {parts[0]!r}; base has "
                                     f"{sorted(out)}")
        node = out
        for i, part in enumerate(parts[:-1]):
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise GranflowInputError(f"override {key!r}: {KEY_SEP.join(parts[:i + 1])!r} "
                                         "is not a table")
        node[parts[-1]] = copy.deepcopy(value)
    return out


def run_member_task(run_member: MemberFunction, config: dict[str, Any],
                    member_dir: str) -> tuple[str, dict[str, Any]]:
    """Run one member in its directory (executed on a worker); never raises for member errors.

    Writes ``summary.json`` (atomically) on success, ``error.json`` with the message and traceback
    on failure, and returns ``(status, summary or error record)``.
    """
    out = Path(member_dir)
    if (out.parent / STOP_FILE).exists():  # queued when the sweep was interrupted: not started
        return STATUS_FAILED, {"error": "not run: the sweep was interrupted (Ctrl-C)"}
    out.mkdir(parents=True, exist_ok=True)
    (out / ERROR_FILE).unlink(missing_ok=True)
    try:
        summary = jsonable(dict(run_member(config, out)))
        write_json_atomic(out / SUMMARY_FILE, summary)
        return STATUS_OK, summary
    except Exception as err:  # noqa: BLE001 - any member error is recorded, not raised
        record = {"error": f"{type(err).__name__}: {err}", "traceback": traceback.format_exc()}
        write_json_atomic(out / ERROR_FILE, record)
        return STATUS_FAILED, record


def flatten_scalars(data: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Scalar leaves of nested dicts, keys joined with dots (lists are left out)."""
    flat: dict[str, Any] = {}
    for k, v in data.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            flat.update(flatten_scalars(v, key + KEY_SEP))
        elif v is None or isinstance(v, (bool, int, float, str)):
            flat[key] = v
    return flat


def _check_member_dir(member_dir: Path, member_id: str, overrides: Mapping[str, Any]) -> None:
    """Refuse to reuse a directory that belongs to a different member definition (or that is
    not a directory)."""
    if (member_dir.exists() or member_dir.is_symlink()) and not member_dir.is_dir():
        raise GranflowInputError(f"{member_dir}: exists and is not a directory (the directory of "
                                 f"member {member_id}); use a new output directory")
    path = member_dir / MEMBER_FILE
    if path.exists() or path.is_symlink():
        try:
            previous = json.loads(path.read_text(encoding="utf-8")).get("overrides")
        except (OSError, UnicodeDecodeError, ValueError, AttributeError, RecursionError):
            raise GranflowInputError(f"{path}: exists and is not the member.json of a granflow "
                                     "sweep; use a new output directory") from None
        if previous != jsonable(dict(overrides)):
            raise GranflowInputError(
                f"{member_dir}: holds member {member_id} of a different sweep (overrides "
                f"{previous} != {jsonable(dict(overrides))}); use a new output directory")


def check_sweep_directory(spec: SweepSpec, outdir: str | Path) -> None:
    """Refuse a sweep directory that holds something else than this sweep: a ``sweep.json`` not
    written by :func:`run_sweep`, or a member directory of another member definition.

    Raises
    ------
    GranflowInputError
        Naming the file.
    """
    out = Path(outdir)
    _check_spec_file(out / SPEC_FILE)
    for member_id, overrides in spec.members():
        _check_member_dir(out / member_id, member_id, overrides)


def _check_spec_file(path: Path) -> None:
    """Refuse a sweep directory whose ``sweep.json`` was not written by :func:`run_sweep`."""
    if not (path.exists() or path.is_symlink()):
        return
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        SweepSpec.from_dict(data)
    except (OSError, UnicodeDecodeError, ValueError, TypeError, RecursionError):
        raise GranflowInputError(f"{path}: exists and is not the sweep.json of a granflow sweep; "
                                 "use a new output directory") from None


def _write_table(path: Path, rows: list[dict[str, Any]], override_keys: list[str]) -> None:
    taken = {*FIXED_COLUMNS, *override_keys}

    def column(key: str) -> str:  # a summary key that clashes with a fixed/override column
        return f"summary{KEY_SEP}{key}" if key in taken else key

    summary_keys: list[str] = []
    for row in rows:
        summary_keys += [column(k) for k in row["summary"] if column(k) not in summary_keys]
    columns = [*FIXED_COLUMNS, *override_keys, *summary_keys]
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({"member_id": row["member_id"], "status": row["status"],
                         "cached": row["cached"], "error": row.get("error", ""),
                         **row["overrides"], **{column(k): v for k, v in row["summary"].items()}})
    with atomic_write(path, "w") as fh:
        fh.write(buf.getvalue())


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
MEMBER_PROGRESS_FILE = "progress.json"
STOP_FILE = "stop"
"""Written in the sweep directory on Ctrl-C: running members stop after their current step (their
progress callback reads it, :class:`granflow.cases.sweep_member.MemberProgress`), queued ones do
not start; removed when the sweep runs again."""
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
    if scheduler is not None and workers is not None:
        raise GranflowInputError("'workers' sets the size of the local cluster; it cannot be "
                                 "combined with 'scheduler'")
    if workers is not None and workers < 1:
        raise GranflowInputError(f"workers must be >= 1, got {workers}")
    try:
        from distributed import Client, LocalCluster, wait
    except ImportError as err:
        raise ImportError("sweeps need Dask: pip install 'granflow[sweep]'") from err

    out = Path(outdir)
    check_sweep_directory(spec, out)
    members = spec.members()
    rows: dict[str, dict[str, Any]] = {}
    todo = []
    for member_id, overrides in members:
        mdir = out / member_id
        row = {"member_id": member_id, "overrides": jsonable(overrides), "cached": False}
        rows[member_id] = row
        if (mdir / SUMMARY_FILE).is_file():
            summary = json.loads((mdir / SUMMARY_FILE).read_text())
            row.update(status=STATUS_OK, cached=True, summary=flatten_scalars(summary))
            continue
        todo.append((member_id, overrides, mdir))

    t_start = time.monotonic()
    total = len(members)

    def member_progress() -> dict[str, dict[str, Any]]:
        """The running members' progress files (simulated time / stop time)."""
        out_p = {}
        for mid, _, mdir in todo:
            path = Path(mdir) / MEMBER_PROGRESS_FILE
            if mid in finished_ids or not path.is_file():
                continue
            try:
                out_p[mid] = json.loads(path.read_text())
            except (OSError, ValueError):
                continue
        return out_p

    finished_ids: set[str] = set()

    def report(member_id: str | None, status: str | None = None, done: int | None = None) -> None:
        if progress is None:
            return
        if member_id is not None:
            finished_ids.add(member_id)
        count = done if done is not None else len(finished_ids) + (total - len(todo))
        progress(SweepProgress(member_id=member_id, status=status, done=count, total=total,
                               elapsed_s=time.monotonic() - t_start, running=member_progress(),
                               summary=rows[member_id].get("summary", {}) if member_id else {}))

    def _collect(future, mid: str) -> str:
        try:
            status, result = future.result()
        except Exception as err:  # noqa: BLE001 - e.g. a worker died (KilledWorker)
            status = STATUS_FAILED
            result = {"error": f"{type(err).__name__}: {err}",
                      "traceback": traceback.format_exc()}
            write_json_atomic(out / mid / ERROR_FILE, result)
        if status == STATUS_OK:
            rows[mid].update(status=status, summary=flatten_scalars(result))
        else:
            rows[mid].update(status=status, summary={}, error=result["error"])
        return status

    cluster = client = None
    abandoned = False
    try:
        if todo:  # connect first: an unreachable scheduler must not leave files behind
            if scheduler is None:
                with _sigint_ignored():  # and dask_setup: the workers ignore Ctrl-C
                    cluster = LocalCluster(n_workers=workers or DEFAULT_WORKERS, threads_per_worker=1,
                                           processes=True, dashboard_address=LOCAL_DASHBOARD,
                                           preload=[__name__])
            client = Client(cluster if cluster is not None else scheduler)
        if started is not None:
            started()
        out.mkdir(parents=True, exist_ok=True)
        (out / STOP_FILE).unlink(missing_ok=True)
        write_json_atomic(out / SPEC_FILE, spec.model_dump(mode="json"))
        tasks = []
        for member_id, overrides, mdir in todo:
            mdir.mkdir(exist_ok=True)
            config = spec.config(overrides)
            write_json_atomic(mdir / MEMBER_FILE, {"member_id": member_id, "overrides": overrides,
                                                   "config": config})
            tasks.append((member_id, config, str(mdir)))
        if tasks:
            futures = {client.submit(run_member_task, run_member, config, mdir, pure=False): mid
                       for mid, config, mdir in tasks}
            pending = set(futures)
            done_count = len(members) - len(todo)
            report(None)
            ok_count = done_count

            def drain(deadline: float, stopping: bool = False) -> None:
                nonlocal pending, done_count, ok_count
                while pending and time.monotonic() < deadline:
                    try:
                        finished, pending = wait(pending, timeout=POLL_S, return_when="FIRST_COMPLETED")
                    except TimeoutError:  # none finished within POLL_S: report the running ones
                        finished = set()
                    for future in finished:
                        mid = futures[future]
                        status = _collect(future, mid)
                        done_count += 1
                        ok_count += status == STATUS_OK
                        report(mid, STATUS_STOPPED if stopping and status == STATUS_FAILED else status,
                               done_count)
                    if not finished:
                        report(None, done=done_count)

            try:
                drain(float("inf"))
            except KeyboardInterrupt:  # stop the running members after their step, start no other
                (out / STOP_FILE).write_text("Ctrl-C\n", encoding="utf-8")
                try:
                    drain(time.monotonic() + STOP_WAIT_S, stopping=True)
                except KeyboardInterrupt:  # a second Ctrl-C: do not wait
                    abandoned = True
                raise SweepInterrupted(ok_count, total, abandoned or bool(pending)) from None
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            _close_cluster(cluster, ABANDON_CLOSE_TIMEOUT_S if abandoned else WORKER_CLOSE_TIMEOUT_S)

    table = out / TABLE_FILE
    _write_table(table, [rows[mid] for mid, _ in members], list(spec.parameters))
    return table


