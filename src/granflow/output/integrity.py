"""Is a classic-format NetCDF file whole? (``granflow plot`` and ``granflow export`` check it.)

A classic (CDF-1, 64-bit-offset CDF-2, CDF-5) file declares in its header the number of records
and where each variable's data begins; a file cut short (a copy that stopped, a full disk) still
opens, and the NetCDF library returns zeros for the missing bytes, so a truncated ``output.nc``
would be plotted and exported as if whole. :func:`check_complete` reads the header (format:
NetCDF Users Guide, "The NetCDF Classic Format Specification") and refuses a file shorter than
the data it declares. HDF5-based ``NETCDF4`` files are left to the HDF5 library, which refuses a
truncated file itself.
"""
from __future__ import annotations

import os
import struct
from pathlib import Path

from granflow.errors import GranflowInputError

MAGIC = b"CDF"
NC_DIMENSION, NC_VARIABLE, NC_ATTRIBUTE = 0x0A, 0x0B, 0x0C
TYPE_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 4, 6: 8, 7: 1, 8: 2, 9: 4, 10: 8, 11: 8}
"""Bytes per value of each nc_type (byte, char, short, int, float, double; CDF-5 unsigned/int64)."""
STREAMING = 0xFFFFFFFF
"""``numrecs`` of a file still being written in streaming mode (record count unknown)."""


class _Header:
    def __init__(self, fh, version: int) -> None:
        self.fh = fh
        self.big = version == 5  # CDF-5: 64-bit counts

    def _read(self, n: int) -> bytes:
        data = self.fh.read(n)
        if len(data) != n:
            raise EOFError("header cut short")
        return data

    def int32(self) -> int:
        return struct.unpack(">I", self._read(4))[0]

    def count(self) -> int:
        return struct.unpack(">Q", self._read(8))[0] if self.big else self.int32()

    def offset(self, version: int) -> int:
        return struct.unpack(">Q", self._read(8))[0] if version in (2, 5) else self.int32()

    def name(self) -> str:
        n = self.count()
        text = self._read(n)
        self._read(-n % 4)
        return text.decode("utf-8", "replace")

    def attributes(self) -> None:
        tag, n = self.int32(), self.count()
        if tag not in (0, NC_ATTRIBUTE):
            raise ValueError(f"bad attribute tag {tag}")
        for _ in range(n):
            self.name()
            nc_type, nelems = self.int32(), self.count()
            size = TYPE_SIZES.get(nc_type)
            if size is None:
                raise ValueError(f"bad nc_type {nc_type}")
            self._read(nelems * size + (-nelems * size) % 4)


def declared_size(path: str | os.PathLike) -> tuple[int, int, int] | None:
    """``(bytes declared, records, bytes per record)`` of a classic NetCDF file, ``None`` for
    another format or a streaming record count.

    Raises
    ------
    ValueError, EOFError
        If the header itself is corrupt or cut short.
    """
    with open(path, "rb") as fh:
        magic = fh.read(4)
        if len(magic) < 4 or magic[:3] != MAGIC or magic[3] not in (1, 2, 5):
            return None
        version = magic[3]
        h = _Header(fh, version)
        numrecs = h.count()
        if numrecs in (STREAMING, 2**64 - 1):
            return None
        tag, ndims = h.int32(), h.count()
        if tag not in (0, NC_DIMENSION):
            raise ValueError(f"bad dimension tag {tag}")
        lengths = []
        for _ in range(ndims):
            h.name()
            lengths.append(h.count())
        h.attributes()
        tag, nvars = h.int32(), h.count()
        if tag not in (0, NC_VARIABLE):
            raise ValueError(f"bad variable tag {tag}")
        end, records = fh.tell(), []
        for _ in range(nvars):
            h.name()
            dimids = [h.count() for _ in range(h.count())]
            h.attributes()
            h.int32()  # nc_type
            vsize = h.count()
            begin = h.offset(version)
            is_record = bool(dimids) and dimids[0] < len(lengths) and lengths[dimids[0]] == 0
            if is_record:
                records.append((begin, vsize))
            else:
                end = max(end, begin + vsize)
    recsize = sum(v for _, v in records)
    if records:
        first = min(b for b, _ in records)
        end = max(end, first + numrecs * recsize) if numrecs else end
    return end, numrecs, recsize


def check_complete(path: str | os.PathLike) -> None:
    """Refuse a classic NetCDF file shorter than the data its header declares.

    Raises
    ------
    GranflowInputError
        ``"<path>: truncated ..."`` naming the records declared and the bytes present.
    """
    p = Path(path)
    try:
        declared = declared_size(p)
    except (ValueError, EOFError, struct.error) as err:
        raise GranflowInputError(f"{p}: not a readable NetCDF file (corrupt header: {err})") from None
    if declared is None:
        return
    need, numrecs, recsize = declared
    have = p.stat().st_size
    if have < need:
        whole = max(0, numrecs - -(-(need - have) // recsize)) if recsize else 0
        raise GranflowInputError(f"{p}: truncated: {have} of the {need} bytes its header declares "
                                 f"({numrecs} records, only the first {whole} complete); "
                                 "re-run or restore the file")
