"""Atomic file replacement and JSON summaries (``summary.json``) that are never seen half-written.

A file written with :func:`atomic_write` is first written to a temporary file in the *same*
directory, flushed to disk (``fsync``) and then renamed over the target with :func:`os.replace`,
which POSIX and Windows perform atomically within one file system. A reader therefore sees either
the previous complete file or the new complete file, never a partial one, even if the writer is
killed (``kill -9``) or serialisation fails midway.
"""
from __future__ import annotations

import contextlib
import json
import math
import os
import stat
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np

from granflow.errors import GranflowInputError

#: Indentation of the JSON files written by :func:`write_json_atomic`.
JSON_INDENT = 2
#: Prefix and suffix of the temporary files (hidden, recognisable, removed on failure).
TMP_PREFIX = "."
TMP_SUFFIX = ".tmp"
#: Permissions of a new file before the umask is applied (as for open()).
DEFAULT_MODE = 0o666


def _fsync_directory(directory: Path) -> None:
    """Flush a directory entry (the rename) to disk; not supported everywhere, hence best effort."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _file_mode(target: Path) -> int:
    """Permissions for the new file: those of the file it replaces, else 0666 minus the umask."""
    try:
        return stat.S_IMODE(target.stat().st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return DEFAULT_MODE & ~umask


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "w") -> Iterator[IO[Any]]:
    """Open a temporary file next to ``path``; on a clean exit, fsync it and rename it to ``path``.

    If the body raises, the temporary file is removed and ``path`` is left untouched.

    Parameters
    ----------
    path : path-like
        Final file name. Its directory must exist.
    mode : {"w", "wb"}
        Text (UTF-8) or binary mode.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_write(p) as f:
    ...     _ = f.write("done")
    >>> p.read_text()
    'done'
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_write: mode must be 'w' or 'wb', got {mode!r}")
    target = Path(path)
    directory = target.parent if str(target.parent) else Path(".")
    fd, tmp_name = tempfile.mkstemp(dir=directory, prefix=TMP_PREFIX + target.name + ".",
                                    suffix=TMP_SUFFIX)
    tmp = Path(tmp_name)
    try:
        os.chmod(tmp, _file_mode(target))  # mkstemp creates 0600; give the usual permissions
        encoding = None if "b" in mode else "utf-8"
        with os.fdopen(fd, mode, encoding=encoding) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    _fsync_directory(directory)


def jsonable(obj: Any, where: str = "") -> Any:
    """Convert ``obj`` to plain JSON types.

    NumPy scalars become Python numbers, arrays become (nested) lists, tuples become lists,
    paths become strings, and non-finite floats (NaN, +-inf) become ``None`` (JSON ``null``),
    since strict JSON has no NaN.

    Raises
    ------
    GranflowInputError
        For an object with no JSON representation, naming its key path.
    """
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist(), where)
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v, f"{where}.{k}" if where else str(k)) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v, f"{where}[{i}]") for i, v in enumerate(obj)]
    raise GranflowInputError(
        f"{where or '(value)'}: cannot be written to JSON (type {type(obj).__name__})"
    )


def write_json_atomic(path: str | os.PathLike, data: Any) -> Path:
    """Write ``data`` as JSON to ``path`` atomically (temporary file + fsync + :func:`os.replace`).

    The whole document is serialised in memory first (see :func:`jsonable` for the conversions:
    NaN/inf -> null, NumPy scalars and arrays -> numbers and lists); only then is a file written.
    If anything fails, the previous content of ``path`` (if any) is left unchanged.

    Parameters
    ----------
    path : path-like
        Target file (e.g. ``run/summary.json``); its directory must exist.
    data : object
        JSON-convertible data.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile, pathlib, json, numpy as np
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "summary.json"
    >>> _ = write_json_atomic(p, {"runout": np.float64(0.25), "energy_error": float("nan")})
    >>> json.loads(p.read_text())
    {'runout': 0.25, 'energy_error': None}
    """
    text = json.dumps(jsonable(data), indent=JSON_INDENT, allow_nan=False) + "\n"
    with atomic_write(path, "w") as fh:
        fh.write(text)
    return Path(path)
