"""Writability of output locations, checked before anything is computed or written.

Every command that writes (``run``, ``sweep``, ``plot``, ``export``, ``check --plot``,
``stability dispersion --plot``) checks its output location with :func:`check_directory` or
:func:`check_file` first, so that a location that cannot be written (a file where a directory is
needed, a directory where a file is needed, a read-only or virtual file system such as ``/proc``,
a device such as ``/dev/null``, an empty path) is bad input (exit 2, one line naming the option
and the path) instead of a traceback after the computation. The checks create nothing: the
nearest existing ancestor is probed with a temporary directory that is removed at once.
"""
from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from pathlib import Path

from granflow.errors import GranflowInputError

PROBE_PREFIX = ".granflow-probe-"
"""Prefix of the temporary directory created (and removed) to probe a directory's writability."""
DEFAULT_NAME_MAX = 255
"""Longest file name (one path component) in bytes where the file system does not say
(``os.pathconf(..., "PC_NAME_MAX")``): Linux's ext4, XFS, tmpfs and most others."""
DEFAULT_PATH_MAX = 4096
"""Longest whole path in bytes where the file system does not say (Linux's PATH_MAX)."""


def _fail(what: str, path: Path, why: str) -> GranflowInputError:
    return GranflowInputError(f"{what} {str(path)!r}: {why}")


def _probe(directory: Path, what: str, path: Path) -> None:
    """Create and remove a temporary directory in ``directory`` (raises if that fails)."""
    try:
        os.rmdir(tempfile.mkdtemp(prefix=PROBE_PREFIX, dir=directory))
    except OSError as err:
        raise _fail(what, path, f"cannot write in {str(directory)!r} "
                    f"({err.strerror or type(err).__name__})") from None


def _limit(directory: Path, name: str, default: int) -> int:
    try:
        return int(os.pathconf(directory, name))
    except (OSError, ValueError, TypeError):
        return default


def _check_names(p: Path, what: str) -> None:
    """Refuse a path with a component or a total length the file system cannot hold (the write
    would fail with "File name too long" after the computation; ``exists()`` itself fails)."""
    parent = Path(os.path.abspath(p)).parent
    while not os.path.isdir(parent) and parent.parent != parent:
        parent = parent.parent
    full = os.fsencode(os.path.abspath(p))
    path_max = _limit(parent, "PC_PATH_MAX", DEFAULT_PATH_MAX)
    if len(full) >= path_max:
        raise _fail(what, p, f"path of {len(full)} bytes is too long (at most {path_max - 1})")
    name_max = _limit(parent, "PC_NAME_MAX", DEFAULT_NAME_MAX)
    for part in p.parts:
        if len(os.fsencode(part)) > name_max:
            raise _fail(what, p, f"the name {part[:40]!r}... of {len(os.fsencode(part))} bytes is too "
                                 f"long (at most {name_max})")


def _check_entries(p: Path, what: str, files: Iterable[str], subdirs: Iterable[str],
                   file_globs: Iterable[str]) -> None:
    """The entries of the existing directory ``p`` that will be written must have the right kind."""
    for name in subdirs:
        sub = p / name
        if (sub.exists() or sub.is_symlink()) and not sub.is_dir():
            raise _fail(what, p, f"{str(sub)!r} exists and is not a directory")
    for name in files:
        f = p / name
        if (f.exists() or f.is_symlink()) and not f.is_file():
            raise _fail(what, p, f"{str(f)!r} exists and is not a regular file")
    for pattern in file_globs:
        for f in sorted(p.glob(pattern)):
            if not f.is_file():
                raise _fail(what, p, f"{str(f)!r} exists and is not a regular file")


def _existing_ancestor(path: Path) -> Path:
    parent = path
    while not (parent.exists() or parent.is_symlink()):
        if parent.parent == parent:
            break
        parent = parent.parent
    return parent


def check_directory(path: str | os.PathLike, what: str = "output directory", *,
                    files: Iterable[str] = (), subdirs: Iterable[str] = (),
                    file_globs: Iterable[str] = ()) -> Path:
    """Check that ``path`` is, or can be created as, a writable directory; create nothing.

    Parameters
    ----------
    path : path-like
        The directory.
    what : str
        How the location was given (``"--out"``, ``"output.directory"``), for the message.
    files, subdirs : iterable of str
        Entries of the directory that will be written as files (must not be directories or
        devices if they exist) or as directories (must be directories if they exist).
    file_globs : iterable of str
        Glob patterns (relative to ``path``, e.g. ``"checkpoints/*.npz"``) of entries that may be
        overwritten: each existing match must be a regular file.

    Returns
    -------
    Path

    Raises
    ------
    GranflowInputError
        ``"<what> '<path>': <why>"``.
    """
    if not str(path).strip():
        raise GranflowInputError(f"{what}: empty path")
    p = Path(path)
    _check_names(p, what)
    if p.exists() or p.is_symlink():
        if not p.is_dir():
            raise _fail(what, p, "exists and is not a directory")
        _check_entries(p, what, files, subdirs, file_globs)
        _probe(p, what, p)
        return p
    parent = _existing_ancestor(p)
    if not parent.is_dir():
        raise _fail(what, p, f"{str(parent)!r} is not a directory")
    _probe(parent, what, p)
    return p


def check_file(path: str | os.PathLike, what: str = "output file") -> Path:
    """Check that the file ``path`` can be written (its directory created); create nothing.

    Raises
    ------
    GranflowInputError
        For an empty path, a path that is a directory or not a regular file (a device), or a
        directory that cannot be written.
    """
    if not str(path).strip():
        raise GranflowInputError(f"{what}: empty path")
    p = Path(path)
    _check_names(p, what)
    if p.exists() or p.is_symlink():
        if p.is_dir():
            raise _fail(what, p, "is a directory")
        if not p.is_file():
            raise _fail(what, p, "exists and is not a regular file")
        if not os.access(p, os.W_OK):
            raise _fail(what, p, "is not writable")
    parent = p.parent if str(p.parent) else Path(".")
    check_directory(parent, what)
    return p
