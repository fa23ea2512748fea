"""Checks of a ``--restart`` checkpoint before anything is written (used by
:class:`granflow.casekit.runner.CaseRun`).

A checkpoint continues a run only if it is one of the same physics: the case name, the grid and
the :data:`PHYSICS_SECTIONS` of its effective configuration (``meta["config_effective"]``) must
equal those of the case being run -- a mu(I) checkpoint continued with Drucker-Prager, or a
fluidised one continued dry, is refused, naming the keys that differ. The time, output and
numerics options may change (the latter with a warning that the restart is not bit for bit). Its
state must be sane: a finite, non-negative time not beyond ``time.stop_time`` and step, finite
fields, phi within [0, phi_max (1 + :data:`PHI_TOLERANCE`)], p >= 0 and c within [0, 1], so that a corrupt or hand-edited checkpoint is bad input
(exit 2) rather than a step failure later.
"""
from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from granflow.errors import GranflowInputError
from granflow.output import CheckpointManager
from granflow.output.checkpoint import CHECKPOINT_GLOB

CHECKPOINT_DIR = "checkpoints"
PHYSICS_SECTIONS = ("material", "closure", "equilibrium", "gas", "gravity", "walls", "setup")
"""Sections of the effective configuration that define the physics of a run."""
PHI_TOLERANCE = 1e-6
"""Relative overshoot of phi_max accepted in a checkpoint's phi (the solver clips to phi_max)."""
NEGATIVE_TOLERANCE = 1e-9
"""Relative undershoot (of the largest magnitude) below 0 accepted in a checkpoint's p, and below
0 or above 1 in its material fraction c (the solver keeps p >= 0 and c in [0, 1])."""
MAX_DIFFERENCES = 3
"""Differing keys named in the message."""
STATE_PREFIX = "state."
SCHEDULE_PREFIX = "schedule."


def check_resume_output(path: Path, nx: int, nz: int) -> tuple[np.ndarray, np.ndarray]:
    """The record times and probe positions of the ``output.nc`` a restart appends to; refuse
    one that is truncated, unreadable or not a granflow run output (exit 3 before), before
    anything is written.

    Raises
    ------
    GranflowInputError
        Naming the file.
    """
    import netCDF4

    from granflow.output.integrity import check_complete
    from granflow.output.fields import PROBE_DIM

    check_complete(path)
    try:
        with netCDF4.Dataset(path) as ds:
            times = np.asarray(ds["time"][:], dtype=float)
            probes = np.asarray(ds[PROBE_DIM][:], dtype=float) if PROBE_DIM in ds.variables else np.empty(0)
            shape = (ds.dimensions["x"].size, ds.dimensions["z"].size)
    except (OSError, IndexError, KeyError, ValueError, RuntimeError) as err:
        raise GranflowInputError(f"--restart: {path}: not the output of a granflow run ("
                                 f"{' '.join(str(err).split())[:120]}); move it away to continue "
                                 "into a new output.nc") from None
    if not np.all(np.isfinite(times)):
        raise GranflowInputError(f"--restart: {path}: non-finite record times")
    if shape != (nx, nz):
        raise GranflowInputError(f"--restart: {path}: holds a grid of (nx, nz) = {shape}, not the "
                                 f"case's ({nx}, {nz}); continue into a new --out")
    return times, probes


def resolve_checkpoint(path: str | Path) -> Path:
    """A checkpoint file, or the newest checkpoint of a run directory (or of its checkpoints/)."""
    p = Path(path)
    if p.is_dir():
        for d in (p / CHECKPOINT_DIR, p):
            if any(d.glob(CHECKPOINT_GLOB)):
                latest = CheckpointManager(d, keep=None).latest()  # d exists: nothing created
                if latest is not None:
                    return latest
        raise GranflowInputError(f"--restart {p}: no {CHECKPOINT_GLOB} in this directory or its "
                                 f"{CHECKPOINT_DIR}/")
    return p


def _flat(data: Any, prefix: str) -> dict[str, Any]:
    if isinstance(data, dict):
        out: dict[str, Any] = {}
        for k, v in data.items():
            out.update(_flat(v, f"{prefix}.{k}"))
        return out
    return {prefix: data}


def physics_differences(meta: dict[str, Any], config) -> list[str]:
    """Keys of :data:`PHYSICS_SECTIONS` whose values differ between the checkpoint's effective
    configuration and ``config`` (``"key: checkpoint -> now"``); empty for an old checkpoint
    without ``config_effective``."""
    text = meta.get("config_effective")
    if not isinstance(text, str) or not text:
        return []
    try:
        then = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError, ValueError):
        return ["config_effective: unreadable"]
    now = tomllib.loads(config.to_toml())
    a: dict[str, Any] = {}
    b: dict[str, Any] = {}
    for section in PHYSICS_SECTIONS:
        a.update(_flat(then.get(section, {}), section))
        b.update(_flat(now.get(section, {}), section))
    missing = object()
    return [f"{k}: {a.get(k, '<unset>')!r} in the checkpoint, {b.get(k, '<unset>')!r} now"
            for k in sorted(set(a) | set(b)) if a.get(k, missing) != b.get(k, missing)]


def check_state(path: Path, arrays: dict[str, np.ndarray], scalars: dict[str, Any],
                phi_max: float, stop_time: float | None = None) -> None:
    """Refuse a checkpoint whose state is not finite, whose phi is outside [0, phi_max], p < 0,
    c outside [0, 1], or whose time is beyond ``stop_time`` (nothing left to run).

    Raises
    ------
    GranflowInputError
        Naming the checkpoint and the entry.
    """
    where = f"--restart {path}"
    t, step = scalars.get("state.t"), scalars.get("state.step")
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t) or t < 0:
        raise GranflowInputError(f"{where}: state.t = {t!r} is not a finite time >= 0")
    if stop_time is not None and t > stop_time:
        raise GranflowInputError(f"{where}: state.t = {t:g} s is beyond time.stop_time = {stop_time:g} s "
                                 "(nothing to run); raise time.stop_time to continue the run")
    if isinstance(step, bool) or not isinstance(step, int) or step < 0:
        raise GranflowInputError(f"{where}: state.step = {step!r} is not a step number >= 0")
    for name, value in scalars.items():  # run totals, budgets, the output schedule
        if isinstance(value, float) and not math.isfinite(value):
            raise GranflowInputError(f"{where}: {name} = {value!r} is not finite")
        if name.startswith(SCHEDULE_PREFIX) and isinstance(value, (int, float)) and value < 0:
            raise GranflowInputError(f"{where}: {name} = {value!r} is not a time >= 0")
    for name, a in arrays.items():
        if not name.startswith(STATE_PREFIX):
            continue
        if a.dtype.kind not in ("b" if name == f"{STATE_PREFIX}free" else "fiu"):  # free: a mask
            raise GranflowInputError(f"{where}: {name} has dtype {a.dtype}, not a number")
        bad = ~np.isfinite(a)
        if np.any(bad):
            raise GranflowInputError(f"{where}: {name} holds {int(bad.sum())} non-finite value(s) "
                                     f"(first {float(a.ravel()[np.flatnonzero(bad.ravel())[0]])!r})")
    phi = arrays.get(f"{STATE_PREFIX}phi")
    if phi is not None and phi.size:
        lo, hi = float(phi.min()), float(phi.max())
        if lo < 0 or hi > phi_max * (1 + PHI_TOLERANCE):
            raise GranflowInputError(f"{where}: state.phi spans [{lo:g}, {hi:g}], outside "
                                     f"[0, material.phi_max = {phi_max:g}]")
    for name, upper in (("p", None), ("c", 1.0)):
        a = arrays.get(f"{STATE_PREFIX}{name}")
        if a is None or not a.size:
            continue
        lo, hi = float(a.min()), float(a.max())
        slack = NEGATIVE_TOLERANCE * max(1.0, abs(lo), abs(hi))
        if lo < -slack or (upper is not None and hi > upper + slack):
            bounds = f"[0, {upper:g}]" if upper is not None else ">= 0"
            raise GranflowInputError(f"{where}: state.{name} spans [{lo:g}, {hi:g}], not {bounds}")


def check_checkpoint(path: Path, arrays: dict[str, np.ndarray], scalars: dict[str, Any],
                     meta: dict[str, Any], config, grid, phi_max: float) -> None:
    """Every check of a restart: case, grid, physics, state (see the module docstring)."""
    if meta.get("case") != config.case.name:
        raise GranflowInputError(f"--restart {path}: checkpoint of case {meta.get('case')!r}, "
                                 f"not {config.case.name!r}")
    g = grid
    if meta.get("grid") != [g.nx, g.nz, g.Lx, g.Lz]:
        raise GranflowInputError(f"--restart {path}: checkpoint grid (nx, nz, Lx, Lz) = "
                                 f"{meta.get('grid')} differs from the case's {[g.nx, g.nz, g.Lx, g.Lz]}")
    diff = physics_differences(meta, config)
    if diff:
        more = f"; and {len(diff) - MAX_DIFFERENCES} more" if len(diff) > MAX_DIFFERENCES else ""
        raise GranflowInputError(f"--restart {path}: the checkpoint is of other physics: "
                                 + "; ".join(diff[:MAX_DIFFERENCES]) + more
                                 + " (restart with the case file and --set options of the original run)")
    check_state(path, arrays, scalars, phi_max, config.time.stop_time)
