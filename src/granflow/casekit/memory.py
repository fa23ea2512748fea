"""Up-front memory estimate of a run: a grid that fits under :data:`granflow.config.MAX_CELLS`
may still not fit in the machine (``2000 x 2000`` cells died with a MemoryError after 40 s), so
:class:`granflow.casekit.runner.CaseRun` refuses a grid whose estimate exceeds the memory available,
naming both, before anything is computed. The limit is the memory available, or the environment
variable :data:`MEMORY_LIMIT_ENV` (in GB) where it is set: lower it on a shared machine, raise it to
run past the estimate.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

from granflow.errors import GranflowInputError

BYTES_PER_CELL = 10_000
"""Estimated peak memory per grid cell [bytes]: measured 2.7-3.6 kB per cell after the set-up and
3.8-6.4 kB per cell for the first steps (column_collapse, 100^2 to 400^2 and 2e4 x 2 to 2e5 x 2,
velocity band on), with a margin for whole-grid solves and the output."""
BASE_BYTES = 300_000_000
"""Memory of the interpreter and its libraries before the grid [bytes] (measured ~190 MB)."""
MEMORY_LIMIT_ENV = "GRANFLOW_MEMORY_LIMIT"
"""Environment variable of the memory limit of a run [GB], replacing the memory available."""
BYTES_PER_GB = 1e9
MEMINFO = Path("/proc/meminfo")
CGROUP_LIMIT = Path("/sys/fs/cgroup/memory.max")


def available_memory() -> int | None:
    """Memory available to this process [bytes]: Linux's MemAvailable, capped by a cgroup (v2)
    limit; ``None`` where neither can be read."""
    found = []
    try:
        for line in MEMINFO.read_text().splitlines():
            if line.startswith("MemAvailable:"):
                found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        text = CGROUP_LIMIT.read_text().strip()
        if text.isdigit():
            found.append(int(text))
    except OSError:
        pass
    if not found:
        try:
            found.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            return None
    return min(found)


def estimate_bytes(cells: int) -> int:
    """Estimated peak memory of a run on ``cells`` grid cells [bytes]."""
    return BASE_BYTES + BYTES_PER_CELL * cells


def memory_limit() -> tuple[int | None, str]:
    """(limit [bytes], where it comes from): :data:`MEMORY_LIMIT_ENV` if set, else
    :func:`available_memory`.

    Raises
    ------
    GranflowInputError
        For a :data:`MEMORY_LIMIT_ENV` that is not a positive finite number of GB.
    """
    text = os.environ.get(MEMORY_LIMIT_ENV, "").strip()
    if not text:
        return available_memory(), "of memory available"
    try:
        gb = float(text)
    except ValueError:
        gb = math.nan
    if not (math.isfinite(gb) and gb > 0):
        raise GranflowInputError(f"{MEMORY_LIMIT_ENV} = {text[:40]!r}: expected a memory limit in GB > 0")
    return int(gb * BYTES_PER_GB), f"of the limit {MEMORY_LIMIT_ENV}"


def check_memory(config, available: int | None = None) -> None:
    """Refuse a grid whose estimated memory exceeds what is available (or the limit
    :data:`MEMORY_LIMIT_ENV`).

    Raises
    ------
    GranflowInputError
        ``"grid: nx * nz = ... cells need about X GB ..., Y GB available"``.
    """
    g = config.grid
    cells = g.nx * g.nz
    need = estimate_bytes(cells)
    have, source = memory_limit() if available is None else (available, "of memory available")
    if have is not None and need > have:
        raise GranflowInputError(
            f"grid: nx * nz = {g.nx} * {g.nz} = {cells} cells need about {need / BYTES_PER_GB:.3g} GB "
            f"(estimate: {BYTES_PER_CELL / 1e3:g} kB per cell, granflow.casekit.memory), more than "
            f"the {have / BYTES_PER_GB:.3g} GB {source}; reduce grid.nx or grid.nz (or set "
            f"{MEMORY_LIMIT_ENV} to a limit in GB)")
