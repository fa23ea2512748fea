"""Self-describing, crash-safe NetCDF output (CF-1.10 attributes), written one time level at a time.

The file has an UNLIMITED ``time`` dimension (seconds since the start of the run). A 2-D field is
stored with dimensions :data:`FIELD_DIMS` = (time, z, x), the CF/COARDS order (T, Z, Y, X: x
varies fastest) that ncview, Panoply and cdo expect; the solver's arrays are (x, z), and readers
take the fields by dimension name (:func:`ordered`), so files written before with (time, x, z)
still read. Every coordinate and variable carries ``units`` and ``long_name``; the global
attributes hold the provenance: granflow version, git revision, the full case-file text, creation
time and history (STYLE.md idiom 8).

Crash safety: after each :meth:`NetCDFWriter.append` the file is synced (``nc_sync``), so a run that
is killed, even by ``kill -9``, leaves a file that ``xarray.open_dataset`` reads up to the last
appended time level. The default format is the classic 64-bit-offset format
(:attr:`NetCDFFormat.CLASSIC_64BIT`): unlike the HDF5-based ``NETCDF4`` format it can also be read
*while* the run is still writing (HDF5 file locking refuses readers of an open file), and it has no
HDF5 metadata that a kill could leave inconsistent. ``NETCDF4`` remains available (compression,
int64) for runs that do not need to be watched.
"""
from __future__ import annotations

import datetime as _dt
import enum
import functools
import os
import subprocess
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import netCDF4
import numpy as np

from granflow.errors import GranflowInputError

#: Name of the unlimited record dimension and coordinate.
TIME_DIM = "time"
#: Attributes of the time coordinate: elapsed simulation time in seconds (a dimensionless case
#: replaces the units, and the writer then drops the CF ``standard_name``).
TIME_ATTRS = {"units": "s", "long_name": "time since the start of the run", "axis": "T",
              "standard_name": "time"}
#: Dimensions of a 2-D field on disk: CF/COARDS order (time, z, x), x varying fastest.
FIELD_DIMS = (TIME_DIM, "z", "x")
#: Order of the solver's arrays (x, z) with time first, in which readers usually want a field.
ARRAY_DIMS = (TIME_DIM, "x", "z")
#: CF version whose attribute conventions the files follow.
CONVENTIONS = "CF-1.10"
#: Seconds allowed for each ``git`` call of :func:`git_revision`.
GIT_TIMEOUT_S = 5.0
#: Value of ``git_revision`` when it cannot be determined.
UNKNOWN_REVISION = "unknown"
#: Attributes every coordinate and variable must have.
REQUIRED_ATTRS = ("units", "long_name")
#: Global attributes set by the writer that callers may not override.
RESERVED_GLOBALS = ("Conventions", "granflow_version", "git_revision", "created", "case_file")


class NetCDFFormat(str, enum.Enum):
    """On-disk formats accepted by :class:`NetCDFWriter` (netCDF4-python format names)."""

    CLASSIC_64BIT = "NETCDF3_64BIT_OFFSET"
    CDF5 = "NETCDF3_64BIT_DATA"
    NETCDF4 = "NETCDF4"


@dataclass(frozen=True)
class VariableSpec:
    """Declaration of one output variable.

    Parameters
    ----------
    dims : tuple of str
        Dimension names, ``"time"`` first, then names of coordinates given to the writer,
        e.g. :data:`FIELD_DIMS` ``("time", "z", "x")``; the arrays given to
        :meth:`NetCDFWriter.append` are shaped as the dims after ``"time"``.
    units : str
        UDUNITS-compatible units (``"1"`` for dimensionless, e.g. the packing fraction).
    long_name : str
        Human-readable description.
    dtype : str
        NumPy dtype of the stored values (``"f8"``, ``"f4"``, ``"i4"``...).
    standard_name : str or None
        CF standard name, where one exists.
    attrs : mapping, optional
        Further attributes (e.g. ``{"phi_max": 0.6}``).
    """

    dims: tuple[str, ...]
    units: str
    long_name: str
    dtype: str = "f8"
    standard_name: str | None = None
    attrs: Mapping[str, Any] | None = None


@functools.lru_cache(maxsize=1)
def git_revision() -> str:
    """Short git hash of the granflow source tree, ``-dirty`` appended if tracked files are modified.

    Returns ``"unknown"`` when granflow is not run from a git checkout of its own source (e.g. an
    installed wheel), when git is missing, or on any error: this function never fails.
    """
    package_dir = Path(__file__).resolve().parents[1]

    def git(*args: str) -> str:
        out = subprocess.run(["git", *args], cwd=package_dir, capture_output=True, text=True,
                             timeout=GIT_TIMEOUT_S, check=True)
        return out.stdout.strip()

    try:
        top, short = git("rev-parse", "--show-toplevel", "--short", "HEAD").splitlines()
        # Only trust a repository that contains this very package (not an enclosing repo).
        if (Path(top) / "src" / "granflow").resolve() != package_dir:
            return UNKNOWN_REVISION
        dirty = git("status", "--porcelain", "--untracked-files=no")
        return f"{short}-dirty" if dirty else short
    except Exception:  # noqa: BLE001 - by contract this never fails
        return UNKNOWN_REVISION


def _granflow_version() -> str:
    from granflow import (
        __version__,  # late import: granflow/__init__ may import this package
    )

    return __version__


def _check_attrs(kind: str, name: str, attrs: Mapping[str, Any]) -> None:
    missing = [a for a in REQUIRED_ATTRS if not attrs.get(a)]
    if missing:
        raise GranflowInputError(f"{kind} {name!r}: missing attribute(s) {', '.join(missing)}")


def _attr_value(key: str, value: Any) -> Any:
    """A value netCDF can store as an attribute (str, number, 1-D numeric array)."""
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (str, int, float, np.integer, np.floating)):
        return value
    arr = np.asarray(value)
    if arr.ndim == 1 and arr.dtype.kind in "iuf":
        return arr
    raise GranflowInputError(f"attribute {key!r}: cannot store a {type(value).__name__} in NetCDF")


def _dims_of(var: Any) -> tuple[str, ...]:
    """Dimension names of a netCDF4 ``Variable`` (``dimensions``) or an xarray ``DataArray``."""
    dims = getattr(var, "dimensions", None)
    return tuple(dims if dims is not None else var.dims)


def axis_order(have: tuple[str, ...], want: tuple[str, ...], name: str = "variable") -> list[int]:
    """Axes of an array with dimensions ``have`` that put them in the order ``want`` (by name).

    Raises
    ------
    GranflowInputError
        If ``have`` and ``want`` are not the same dimension names.
    """
    if sorted(have) != sorted(want):
        raise GranflowInputError(f"{name}: dimensions {tuple(have)}, expected {tuple(want)} in any order")
    return [have.index(d) for d in want]


def ordered(var: Any, dims: tuple[str, ...] = ARRAY_DIMS) -> np.ndarray:
    """The values of a netCDF4 ``Variable`` or an xarray ``DataArray`` with their axes in the
    order ``dims``, matched by name, in the variable's units.

    The default :data:`ARRAY_DIMS` gives a 2-D field as (time, x, z) from a file written in the
    CF order (time, z, x) and from an older one written in (time, x, z) alike.

    Raises
    ------
    GranflowInputError
        If the variable's dimensions are not those of ``dims``.

    Examples
    --------
    >>> import xarray as xr
    >>> da = xr.DataArray(np.arange(6.0).reshape(1, 2, 3), dims=("time", "z", "x"))
    >>> ordered(da).shape
    (1, 3, 2)
    """
    have = _dims_of(var)
    axes = axis_order(have, tuple(dims), str(getattr(var, "name", "variable")))
    values = var.values if hasattr(var, "dims") else var[...]
    return np.transpose(np.asarray(values), axes)


class NetCDFWriter:
    """Write time levels of declared fields to a NetCDF file, syncing after every level.

    Parameters
    ----------
    path : path-like
        Output file; overwritten if it exists.
    coords : mapping
        ``name -> (values, attrs)`` for each spatial coordinate (1-D, dimension of the same name).
        ``attrs`` must contain ``units`` and ``long_name``. ``"time"`` is created by the writer.
    variables : mapping
        ``name -> VariableSpec``: the fields passed to every :meth:`append`.
    global_attrs : mapping, optional
        Extra global attributes (e.g. ``{"phi_max": 0.6}``); may set ``title`` and ``history``
        but not the provenance attributes written by the writer.
    case_file : str
        Full text of the TOML case file, stored in the ``case_file`` global attribute.
    title : str
        The ``title`` global attribute.
    format : NetCDFFormat or str
        On-disk format; see the module docstring for why the classic format is the default.

    Raises
    ------
    GranflowInputError
        For a coordinate or variable without units/long_name, a variable whose dims are not
        ``("time", <coordinates>...)``, a reserved global attribute, or a dtype the format cannot
        store.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np, xarray as xr
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run.nc"
    >>> x = np.linspace(0.0, 1.0, 3)
    >>> spec = {"h": VariableSpec(("time", "x"), "m", "deposit thickness")}
    >>> with NetCDFWriter(path, {"x": (x, {"units": "m", "long_name": "x"})}, spec) as w:
    ...     _ = w.append(0.0, {"h": np.ones(3)})
    ...     _ = w.append(0.5, {"h": 2 * np.ones(3)})
    >>> xr.open_dataset(path).h.values.tolist()
    [[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]
    """

    def __init__(self, path: str | os.PathLike, coords: Mapping[str, tuple[Any, Mapping[str, Any]]],
                 variables: Mapping[str, VariableSpec], global_attrs: Mapping[str, Any] | None = None,
                 *, case_file: str = "", title: str = "granflow run",
                 format: NetCDFFormat | str = NetCDFFormat.CLASSIC_64BIT, time_units: str = "s") -> None:
        self.path = Path(path)
        fmt = NetCDFFormat(format)
        shapes: dict[str, int] = {}
        for name, (values, attrs) in coords.items():
            if name == TIME_DIM:
                raise GranflowInputError(f"coordinate {TIME_DIM!r} is created by the writer")
            arr = np.asarray(values)
            if arr.ndim != 1:
                raise GranflowInputError(f"coordinate {name!r}: must be 1-D, got shape {arr.shape}")
            _check_attrs("coordinate", name, attrs)
            shapes[name] = arr.size
        self._shapes: dict[str, tuple[int, ...]] = {}
        for name, spec in variables.items():
            if name in coords or name == TIME_DIM:
                raise GranflowInputError(f"variable {name!r}: clashes with a coordinate name")
            if not spec.dims or spec.dims[0] != TIME_DIM:
                raise GranflowInputError(f"variable {name!r}: dims must start with {TIME_DIM!r}, "
                                         f"got {spec.dims}")
            unknown = [d for d in spec.dims[1:] if d not in shapes]
            if unknown:
                raise GranflowInputError(f"variable {name!r}: unknown dimension(s) {unknown}; "
                                         f"coordinates are {sorted(shapes)}")
            _check_attrs("variable", name, {"units": spec.units, "long_name": spec.long_name})
            self._shapes[name] = tuple(shapes[d] for d in spec.dims[1:])
        extra = dict(global_attrs or {})
        clash = [k for k in extra if k in RESERVED_GLOBALS]
        if clash:
            raise GranflowInputError(f"global attribute(s) {clash} are written by granflow itself")

        created = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
        version = _granflow_version()
        attrs: dict[str, Any] = {
            "Conventions": CONVENTIONS,
            "title": title,
            "history": f"{created}: written by granflow {version}",
            "granflow_version": version,
            "git_revision": git_revision(),
            "created": created,
            "case_file": case_file,
        }
        attrs.update(extra)

        self._ds = netCDF4.Dataset(self.path, "w", format=fmt.value)
        try:
            self._ds.setncatts({k: _attr_value(k, v) for k, v in attrs.items()})
            self._ds.createDimension(TIME_DIM, None)
            tvar = self._ds.createVariable(TIME_DIM, "f8", (TIME_DIM,))
            tattrs = {**TIME_ATTRS, "units": time_units}
            if time_units != TIME_ATTRS["units"]:  # a dimensionless time has no CF standard name
                tattrs.pop("standard_name")
            tvar.setncatts(tattrs)
            for name, (values, cattrs) in coords.items():
                arr = np.asarray(values)
                self._ds.createDimension(name, arr.size)
                var = self._ds.createVariable(name, arr.dtype, (name,))
                var.setncatts({k: _attr_value(k, v) for k, v in cattrs.items()})
                var[:] = arr
            for name, spec in variables.items():
                try:
                    var = self._ds.createVariable(name, np.dtype(spec.dtype), spec.dims)
                except (TypeError, RuntimeError, ValueError) as err:
                    raise GranflowInputError(
                        f"variable {name!r}: dtype {spec.dtype!r} not storable in {fmt.value}: {err}"
                    ) from None
                vattrs = {"units": spec.units, "long_name": spec.long_name, **(spec.attrs or {})}
                if spec.standard_name:
                    vattrs["standard_name"] = spec.standard_name
                var.setncatts({k: _attr_value(k, v) for k, v in vattrs.items()})
            self._ds.sync()  # header on disk before the first record
        except BaseException:
            self._ds.close()
            raise
        self._last_t = -np.inf

    @classmethod
    def resume(cls, path: str | os.PathLike, t_restart: float,
               coords: Mapping[str, tuple[Any, Mapping[str, Any]]],
               variables: Mapping[str, VariableSpec], global_attrs: Mapping[str, Any] | None = None,
               **kwargs: Any) -> NetCDFWriter:
        """Continue the output of a run restarted from a checkpoint at time ``t_restart`` [s].

        The records of the existing file ``path`` with time <= ``t_restart`` are copied (bit for
        bit, transposed by dimension name when the file has another order, e.g. (time, x, z)
        written before :data:`FIELD_DIMS`) into a new file with the given declarations (same
        arguments as the constructor); the new file then replaces ``path`` atomically, so an
        interrupted resume leaves the old file intact. Records written after the checkpoint by
        the killed run are dropped, since the restarted run writes them again; its next
        :meth:`append` must have time > ``t_restart``.

        Raises
        ------
        GranflowInputError
            If ``path`` cannot be read or lacks a declared variable, or a variable's dimensions
            there are not the declared ones (in some order).
        """
        path = Path(path)
        try:
            old = netCDF4.Dataset(path, "r")
        except OSError as err:
            raise GranflowInputError(f"cannot resume output {path}: {err}") from None
        tmp = path.with_name(f".{path.name}.resume.tmp")
        writer = None
        try:
            old.set_auto_maskandscale(False)
            missing = [v for v in (TIME_DIM, *variables) if v not in old.variables]
            if missing:
                raise GranflowInputError(f"cannot resume output {path}: no variable(s) {missing}")
            times = np.asarray(old.variables[TIME_DIM][:], dtype=float)
            keep = int(np.count_nonzero(times <= t_restart))
            axes = {v: axis_order(old.variables[v].dimensions[1:], spec.dims[1:], f"{path}: {v}")
                    for v, spec in variables.items()}  # non-time axes, old file -> declared order
            created = getattr(old, "created", "?")
            writer = cls(tmp, coords, variables, global_attrs, **kwargs)
            writer._ds.history = (f"{writer._ds.history}\n{writer._ds.created}: restarted at "
                                  f"t = {t_restart!r} s (output first created {created})")
            for i in range(keep):
                writer.append(times[i], {v: np.transpose(old.variables[v][i, ...], axes[v])
                                         for v in variables})
        except BaseException:
            if writer is not None:
                writer.close()
            tmp.unlink(missing_ok=True)
            raise
        finally:
            old.close()
        os.replace(tmp, path)
        writer.path = path
        return writer

    @property
    def n_records(self) -> int:
        """Number of time levels written so far."""
        return len(self._ds.dimensions[TIME_DIM])

    @property
    def times(self) -> np.ndarray:
        """Times of the records written so far (including those a resume copied) [s]."""
        return np.asarray(self._ds.variables[TIME_DIM][:], dtype=float)

    @property
    def closed(self) -> bool:
        return not self._ds.isopen()

    def append(self, t: float, fields: Mapping[str, Any]) -> int:
        """Write one time level and sync the file to disk.

        Parameters
        ----------
        t : float
            Time [s]; finite and strictly increasing.
        fields : mapping
            ``name -> array`` for every declared variable, shaped as its non-time dims.

        Returns
        -------
        int
            Index of the written time level.

        Raises
        ------
        GranflowInputError
            For an unknown or missing field, a wrong shape, or a non-increasing time.
        """
        if self.closed:
            raise GranflowInputError(f"{self.path}: writer is closed")
        unknown = sorted(set(fields) - set(self._shapes))
        if unknown:
            raise GranflowInputError(f"unknown output field(s) {unknown}; declared: "
                                     f"{sorted(self._shapes)}")
        missing = sorted(set(self._shapes) - set(fields))
        if missing:
            raise GranflowInputError(f"missing output field(s) {missing}")
        t = float(t)
        if not np.isfinite(t) or t <= self._last_t:
            raise GranflowInputError(f"output time {t!r} must be finite and > previous {self._last_t}")
        arrays = {}
        for name, values in fields.items():
            arr = np.asarray(values)
            if arr.shape != self._shapes[name]:
                raise GranflowInputError(f"output field {name!r}: shape {arr.shape}, "
                                         f"expected {self._shapes[name]}")
            if arr.dtype.kind not in "biuf":
                raise GranflowInputError(f"output field {name!r}: non-numeric dtype {arr.dtype}")
            arrays[name] = arr
        i = self.n_records
        for name, arr in arrays.items():
            self._ds.variables[name][i, ...] = arr
        self._ds.variables[TIME_DIM][i] = t
        self._ds.sync()
        self._last_t = t
        return i

    def set_attributes(self, attrs: Mapping[str, Any]) -> None:
        """Set (or replace) global attributes of the open file, e.g. a flag found during the run."""
        if not self.closed:
            self._ds.setncatts({k: _attr_value(k, v) for k, v in attrs.items()})
            self._ds.sync()

    def sync(self) -> None:
        """Flush everything written so far to disk."""
        if not self.closed:
            self._ds.sync()

    def close(self) -> None:
        """Close the file (idempotent)."""
        if not self.closed:
            self._ds.close()

    def __enter__(self) -> NetCDFWriter:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
