"""The files of a sweep directory: each member's ``member.json``, ``summary.json`` or
``error.json``, the sweep's ``sweep.json`` and ``sweep_summary.csv``, and the member task run on a
worker (:func:`run_member_task`). Split from :mod:`granflow.sweep` (which re-exports every name
here).
"""
from __future__ import annotations

import csv
import io
import json
import traceback
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from granflow.errors import GranflowInputError
from granflow.output.summary import atomic_write, jsonable, write_json_atomic
from granflow.sweep_spec import KEY_SEP, SweepSpec

#: A member function: (full configuration, its output directory) -> summary (JSON-able dict).
MemberFunction = Callable[[dict[str, Any], Path], Mapping[str, Any]]

#: Files of a member directory and of the sweep directory.
SUMMARY_FILE = "summary.json"
ERROR_FILE = "error.json"
MEMBER_FILE = "member.json"
SPEC_FILE = "sweep.json"
TABLE_FILE = "sweep_summary.csv"
MEMBER_PROGRESS_FILE = "progress.json"
STOP_FILE = "stop"
"""Written in the sweep directory on Ctrl-C: running members stop after their current step (their
progress callback reads it, :class:`granflow.casekit.sweep_member.MemberProgress`), queued ones do
not start; removed when the sweep runs again."""
#: Member statuses in the table.
STATUS_OK = "ok"
STATUS_FAILED = "failed"
STATUS_STOPPED = "stopped"
"""Status shown by the progress display for a member stopped by Ctrl-C (failed in the files)."""
#: Fixed leading columns of the table.
FIXED_COLUMNS = ("member_id", "status", "cached", "error")


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
