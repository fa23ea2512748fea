"""Up-front memory estimate of a run: a grid that fits under :data:`granflow.config.MAX_CELLS`
may still not fit in the machine (``2000 x 2000`` cells died with a MemoryError after 40 s), so
:class:`granflow.cases.runner.CaseRun` refuses a grid whose estimate exceeds the memory available,
naming both, before anything is computed.
"""
from __future__ import annotations

import os
from pathlib import Path

from granflow.errors import GranflowInputError

BYTES_PER_CELL = 10_000
"""Estimated peak memory per grid cell [bytes]: measured 2.7-3.6 kB per cell after the set-up and
3.8-6.4 kB per cell for the first steps (column_collapse, 100^2 to 400^2 and 2e4 x 2 to 2e5 x 2,
velocity band on), with a margin for whole-grid solves and the output."""
BASE_BYTES = 300_000_000
"""Memory of the interpreter and its libraries before the grid [bytes] (measured ~190 MB)."""
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


def check_memory(config, available: int | None = None) -> None:
    """Refuse a grid whose estimated memory exceeds what is available.

    Raises
    ------
    GranflowInputError
        ``"grid: nx * nz = ... cells need about X GB ..., Y GB available"``.
    """
    g = config.grid
    cells = g.nx * g.nz
    need = estimate_bytes(cells)
    have = available_memory() if available is None else available
    if have is not None and need > have:
        raise GranflowInputError(
            f"grid: nx * nz = {g.nx} * {g.nz} = {cells} cells need about {need / 1e9:.3g} GB "
            f"(estimate: {BYTES_PER_CELL / 1e3:g} kB per cell, granflow.cases.memory), more than "
            f"the {have / 1e9:.3g} GB of memory available; reduce grid.nx or grid.nz")
