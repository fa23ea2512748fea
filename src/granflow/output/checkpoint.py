"""Checkpoints for exact restarts: named arrays, scalars (clock, step counter) and metadata.

A checkpoint is an uncompressed ``.npz`` archive written atomically (temporary file + fsync +
rename, :func:`granflow.output.summary.atomic_write`), so a run killed while checkpointing leaves
the previous checkpoint intact. Arrays are stored in NumPy's ``.npy`` format, which keeps dtype,
byte order, shape and every bit; scalars are stored as JSON, whose float text (Python ``repr``) is
the shortest string that reads back as the same double. Hence :func:`load_checkpoint` returns
*bit-identical* state, and a deterministic stepper restarted from a checkpoint reproduces the
uninterrupted run exactly.
"""
from __future__ import annotations

import datetime as _dt
import json
import os
import re
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from granflow.errors import GranflowInputError
from granflow.output.summary import atomic_write, jsonable

#: Version of the checkpoint layout; bump when it changes incompatibly.
SCHEMA_VERSION = 1
#: Name of the archive member holding the JSON header (scalars + meta).
HEADER_KEY = "__granflow_header__"
#: Keys the writer adds to ``meta``.
META_VERSION = "granflow_version"
META_SCHEMA = "checkpoint_schema"
META_CREATED = "created"
RESERVED_META = (META_VERSION, META_SCHEMA, META_CREATED)
#: File-name pattern of :class:`CheckpointManager` (step number zero-padded).
STEP_DIGITS = 8
CHECKPOINT_GLOB = "checkpoint_*.npz"
_STEP_RE = re.compile(r"checkpoint_(\d+)\.npz$")


class CheckpointError(GranflowInputError):
    """A checkpoint file is missing, unreadable, corrupt or of an unsupported schema."""


def _scalar(name: str, value: Any) -> int | float | bool | str | None:
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise GranflowInputError(f"checkpoint scalar {name!r}: must be int, float, bool, str or None, "
                             f"got {type(value).__name__}")


def save_checkpoint(path: str | os.PathLike, arrays: Mapping[str, np.ndarray],
                    scalars: Mapping[str, Any] | None = None,
                    meta: Mapping[str, Any] | None = None) -> Path:
    """Write a checkpoint atomically.

    Parameters
    ----------
    path : path-like
        Target file (suffix ``.npz`` recommended; used as given).
    arrays : mapping of str to ndarray
        State arrays (numeric or boolean dtypes; object arrays are refused).
    scalars : mapping, optional
        Exact scalars: int, float (NaN/inf allowed), bool, str, None; NumPy scalars are converted
        with ``.item()``, which keeps the value exactly (a float32 comes back as a Python float).
    meta : mapping, optional
        Descriptive metadata (JSON-converted: NaN -> null). The keys ``granflow_version``,
        ``checkpoint_schema`` and ``created`` are added and may not be given.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    GranflowInputError
        For a bad array name or dtype, a non-scalar in ``scalars``, or a reserved ``meta`` key.
    """
    from granflow import __version__

    store: dict[str, np.ndarray] = {}
    for name, arr in arrays.items():
        if not isinstance(name, str) or not name or name == HEADER_KEY or "/" in name:
            raise GranflowInputError(f"checkpoint array name {name!r} is not allowed")
        a = np.asarray(arr)
        if a.dtype.hasobject:
            raise GranflowInputError(f"checkpoint array {name!r}: object dtype cannot be stored")
        store[name] = a
    meta = dict(meta or {})
    clash = [k for k in meta if k in RESERVED_META]
    if clash:
        raise GranflowInputError(f"checkpoint meta key(s) {clash} are reserved")
    meta.update({
        META_VERSION: __version__,
        META_SCHEMA: SCHEMA_VERSION,
        META_CREATED: _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    })
    header = {
        "scalars": {str(k): _scalar(str(k), v) for k, v in (scalars or {}).items()},
        "meta": jsonable(meta),
        "arrays": sorted(store),
    }
    text = json.dumps(header, allow_nan=True)  # Python's json round-trips NaN/Infinity exactly
    store[HEADER_KEY] = np.frombuffer(text.encode("utf-8"), dtype=np.uint8)
    with atomic_write(path, "wb") as fh:
        np.savez(fh, **store)
    return Path(path)


def load_checkpoint(path: str | os.PathLike
                    ) -> tuple[dict[str, np.ndarray], dict[str, Any], dict[str, Any]]:
    """Read a checkpoint written by :func:`save_checkpoint`.

    Returns
    -------
    arrays : dict of str to ndarray
        Bit-identical to the saved arrays (dtype, shape, bytes).
    scalars : dict
        The saved scalars, exactly.
    meta : dict
        The saved metadata plus ``granflow_version``, ``checkpoint_schema``, ``created``.

    Raises
    ------
    CheckpointError
        If the file does not exist, is not a granflow checkpoint, is truncated or corrupt, or has
        a newer schema than this granflow supports.
    """
    p = Path(path)
    if not p.is_file():
        raise CheckpointError(f"checkpoint {p}: file does not exist")
    try:
        with open(p, "rb") as fh, np.load(fh, allow_pickle=False) as npz:
            if HEADER_KEY not in npz.files:
                raise CheckpointError(f"checkpoint {p}: not a granflow checkpoint (no header)")
            header = json.loads(npz[HEADER_KEY].tobytes().decode("utf-8"))
            schema = header["meta"].get(META_SCHEMA)
            if not isinstance(schema, int) or schema > SCHEMA_VERSION:
                raise CheckpointError(f"checkpoint {p}: schema {schema!r} not supported "
                                      f"(this granflow reads <= {SCHEMA_VERSION})")
            missing = [k for k in header["arrays"] if k not in npz.files]
            if missing:
                raise CheckpointError(f"checkpoint {p}: arrays {missing} missing")
            arrays = {k: npz[k] for k in header["arrays"]}
    except CheckpointError:
        raise
    except (OSError, ValueError, EOFError, KeyError, TypeError, AttributeError,
            zipfile.BadZipFile) as err:
        raise CheckpointError(f"checkpoint {p}: unreadable or corrupt ({err})") from None
    return arrays, dict(header["scalars"]), dict(header["meta"])


class CheckpointManager:
    """Periodic checkpoints ``checkpoint_<step>.npz`` in one directory, keeping the newest few.

    Parameters
    ----------
    directory : path-like
        Created if missing.
    keep : int or None
        Number of newest checkpoints kept after each save (``None``: keep all).
    """

    def __init__(self, directory: str | os.PathLike, keep: int | None = 2) -> None:
        if keep is not None and keep < 1:
            raise GranflowInputError(f"checkpoint keep must be >= 1 or None, got {keep}")
        self.directory = Path(directory)
        self.keep = keep
        self.directory.mkdir(parents=True, exist_ok=True)

    def path(self, step: int) -> Path:
        """File name of the checkpoint at time step ``step``."""
        if step < 0:
            raise GranflowInputError(f"checkpoint step must be >= 0, got {step}")
        return self.directory / f"checkpoint_{step:0{STEP_DIGITS}d}.npz"

    def steps(self) -> list[int]:
        """Steps of the checkpoints present, ascending."""
        found = (_STEP_RE.search(p.name) for p in self.directory.glob(CHECKPOINT_GLOB))
        return sorted(int(m.group(1)) for m in found if m)

    def latest(self) -> Path | None:
        """The newest checkpoint, or ``None`` if there is none."""
        steps = self.steps()
        return self.path(steps[-1]) if steps else None

    def save(self, step: int, arrays: Mapping[str, np.ndarray],
             scalars: Mapping[str, Any] | None = None,
             meta: Mapping[str, Any] | None = None) -> Path:
        """Save the checkpoint of ``step`` (see :func:`save_checkpoint`), then prune old ones."""
        out = save_checkpoint(self.path(step), arrays, scalars, meta)
        if self.keep is not None:
            for old in self.steps()[:-self.keep]:
                self.path(old).unlink(missing_ok=True)
        return out
