"""What a simulation can write to NetCDF: the declarations (units, long_name) of the cell fields,
the time series and the basal probes, and :class:`Output` -- a variable's values as a function of
the :class:`~granflow.simulation.Simulation` plus its :class:`~granflow.output.VariableSpec` --
for :class:`granflow.output.writers.NetCDFOutputWriter`.

Units are SI; a dimensionless case renames them through a ``unit(si_unit) -> str`` function
(:data:`UNIT_KINDS`, :data:`SI_KIND`; :attr:`granflow.casekit.registry.Case.units`).
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import diagnostics as dg
from granflow.errors import GranflowInputError
from granflow.output.netcdf import FIELD_DIMS, TIME_DIM, VariableSpec
from granflow.schedules import Schedule, check_schedule

if TYPE_CHECKING:
    from granflow.grid import Grid
    from granflow.model import Model
    from granflow.simulation import Simulation

#: NetCDF declarations of the cell-centred fields (name -> units, long_name), stored (time, z, x);
#: long_name only: no CF standard name describes a grain-phase quantity (solid fraction, pressure...).
FIELD_SPECS = {
    "phi": ("1", "solid volume fraction"),
    "c": ("1", "material fraction of the cell (indicator surface; packing inside the material = phi / c)"),
    "u": ("m s-1", "horizontal solid velocity (cell-centred mean of the face values)"),
    "w": ("m s-1", "vertical solid velocity (cell-centred mean of the face values)"),
    "p": ("Pa", "granular pressure"),
    "p_f": ("Pa", "pore-gas over-pressure (zero in the dry model)"),
    "S": ("s-1", "norm of the deviatoric strain rate |S|, |S|^2 = S:S/2"),
}
PROBE_DIM = "x_probe"
PROBE_SPECS = {
    "probe_p_f": ("Pa", "pore-gas pressure p_f of the bottom cell at each basal probe"),
    "probe_p": ("Pa", "granular pressure p of the bottom cell at each basal probe"),
}
"""Time series at the basal probes (``output.probes_x``)."""
SERIES_SPECS = {
    "kinetic_energy": ("J m-1", "kinetic energy per unit width"),
    "outflow_volume": ("m2", "solid volume per unit width that left through the outflow wall since t = 0"),
    "inflow_volume": ("m2", "solid volume per unit width the source supplied since t = 0"),
    "x_front": ("m", f"front position: {dg.FRONT_DEFINITION} (attribute front_threshold_m; resolution dx)"),
}
UNIT_KINDS = ("length", "time", "speed", "pressure", "rate", "energy")
SI_KIND = {"m": "length", "s": "time", "m s-1": "speed", "Pa": "pressure", "s-1": "rate", "J m-1": "energy"}
"""The SI units of the output and the kind of quantity each stands for (a dimensionless case
replaces them: :attr:`granflow.casekit.registry.Case.units`)."""


def si_unit(unit: str) -> str:
    """The default ``unit`` function: SI units kept as they are."""
    return unit


@dataclass(frozen=True)
class Output:
    """One variable of a :class:`~granflow.output.writers.NetCDFOutputWriter`.

    Parameters
    ----------
    values : callable
        ``values(simulation) -> array`` shaped as ``spec.dims[1:]`` (a scalar for ``("time",)``),
        in ``spec.units``.
    spec : VariableSpec
    """

    values: Callable[[Simulation], Any]
    spec: VariableSpec

    def __post_init__(self) -> None:
        if not callable(self.values):
            raise GranflowInputError(f"Output: values must be callable as values(simulation), got {self.values!r}")
        if not isinstance(self.spec, VariableSpec):
            raise GranflowInputError(f"Output: spec must be a VariableSpec, got {self.spec!r}")


def grid_coords(grid: Grid, length_unit: str = "m") -> dict[str, tuple[np.ndarray, dict[str, Any]]]:
    """The ``x`` and ``z`` coordinates of the cell centres (in ``length_unit``), with their CF
    attributes, for :class:`~granflow.output.NetCDFWriter`."""
    x_name = "radius r of the cell centres (axisymmetric)" if grid.axisymmetric else "x of the cell centres"
    return {"x": (np.asarray(grid.xc), {"units": length_unit, "long_name": x_name, "axis": "X"}),
            "z": (np.asarray(grid.zc), {"units": length_unit, "long_name": "height z of the cell centres",
                                        "axis": "Z", "positive": "up",
                                        **({"standard_name": "height"} if length_unit == "m" else {})})}


def _cell_values(name: str) -> Callable[[Simulation], np.ndarray]:
    """``values(simulation)`` of the cell field ``name``, transposed to the (z, x) of the file."""

    def values(sim: Simulation) -> np.ndarray:
        g, st, model = sim.model.grid, sim.state, sim.model
        if name in ("phi", "p", "p_f"):
            field = getattr(st, name)
        elif name == "c":
            field = st.c if st.c is not None else model.material_of(st.phi)
        elif name == "S":
            ops = getattr(model, "axisymmetric_operators", None) or model.ops  # (|S| with the hoop strain)
            field = ops.strain_rate_norm(st.vel).reshape(g.cell_shape)
        else:  # u, w: cell-centred means of the face values
            u, w = g.unpack_velocity(st.vel)
            field = 0.5 * (u[1:, :] + u[:-1, :]) if name == "u" else 0.5 * (w[:, 1:] + w[:, :-1])
        return field.T

    return values


def field_outputs(model: Model, names: Iterable[str] = tuple(FIELD_SPECS),
                  unit: Callable[[str], str] = si_unit) -> dict[str, Output]:
    """The cell fields ``names`` (keys of :data:`FIELD_SPECS`) as outputs on (time, z, x); ``c``
    is left out when the model has no material indicator (it would be phi > 0).

    Raises
    ------
    GranflowInputError
        For a name that is not a field.
    """
    out = {}
    for name in names:
        if name not in FIELD_SPECS:
            raise GranflowInputError(f"output field {name!r}: not a field; expected any of {list(FIELD_SPECS)}")
        if name == "c" and not model.indicator:
            continue
        units, long_name = FIELD_SPECS[name]
        attrs = {"phi_max": model.material.phi_max} if name == "phi" else None
        out[name] = Output(_cell_values(name), VariableSpec(FIELD_DIMS, unit(units), long_name, attrs=attrs))
    return out


def kinetic_energy_output(unit: Callable[[str], str] = si_unit) -> Output:
    """The kinetic energy per unit width of the energy budget [J m-1], a time series."""
    units, long_name = SERIES_SPECS["kinetic_energy"]
    return Output(lambda sim: np.float64(sim.budget.e_k), VariableSpec((TIME_DIM,), unit(units), long_name))


def boundary_outputs(model, unit: Callable[[str], str] = si_unit) -> dict[str, Output]:
    """The cumulative solid volumes through the open boundaries the model has [m2], time series
    (``outflow_volume``: an outflow east wall; ``inflow_volume``: a source; the run totals
    :class:`granflow.simulation.RunTotals`)."""
    out = {}
    for name, present, total in (("outflow_volume", getattr(model, "outflow", False), "outflow_mass"),
                                 ("inflow_volume", getattr(model, "source", None) is not None, "inflow_mass")):
        if present:
            units, long_name = SERIES_SPECS[name]
            out[name] = Output(lambda sim, total=total: np.float64(getattr(sim.totals, total)),
                               VariableSpec((TIME_DIM,), unit(units), long_name))
    return out


class BasalProbes:
    """Pressures p_f and p [Pa] of the bottom cell under given x positions (the cell containing
    each x): variables of a writer (:meth:`outputs`, :meth:`coords`) and, given a schedule, a
    recorder of their history (``simulation.diagnostics["probes"] = probes``; :attr:`t`,
    :attr:`p_f`, :attr:`p`, kept in checkpoints).

    Parameters
    ----------
    grid : Grid
    x : sequence of float
        Probe positions [m] (outside the box: the first or last column).
    schedule : TimeInterval or IterationInterval, optional
        When to record (needed only as a recorder).
    """

    KEYS = ("probes.t", "probes.p_f", "probes.p")
    """Checkpoint arrays of the history: times [s], then p_f and p [Pa] (record, probe)."""

    def __init__(self, grid: Grid, x: Iterable[float], schedule: Schedule | None = None) -> None:
        xs = np.asarray(list(x), dtype=float)
        if xs.ndim != 1 or not np.all(np.isfinite(xs)):
            raise GranflowInputError(f"BasalProbes: x must be finite positions [m], got {xs.tolist()!r}")
        self.cells = np.clip(np.floor((xs - grid.x0) / grid.dx), 0, grid.nx - 1).astype(int)
        self.x = np.asarray(grid.xc[self.cells], dtype=float)
        """x of the cell centre of each probe [m]."""
        self.schedule = None if schedule is None else check_schedule(schedule, "BasalProbes")
        self.t: list[float] = []
        self.p_f: list[np.ndarray] = []
        self.p: list[np.ndarray] = []

    def __call__(self, sim: Simulation) -> None:
        """Record the pressures at the probes (once per time)."""
        if self.t and sim.state.t <= self.t[-1]:
            return
        self.t.append(sim.state.t)
        self.p_f.append(sim.state.p_f[self.cells, 0].copy())
        self.p.append(sim.state.p[self.cells, 0].copy())

    def checkpoint_payload(self, sim: Simulation) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        shape = (len(self.t), self.cells.size)
        t_key, pf_key, p_key = self.KEYS
        return {t_key: np.asarray(self.t, dtype=float), pf_key: np.asarray(self.p_f, dtype=float).reshape(shape),
                p_key: np.asarray(self.p, dtype=float).reshape(shape)}, {}

    def restore_checkpoint(self, arrays: Mapping[str, np.ndarray], scalars: Mapping[str, Any]) -> None:
        t_key, pf_key, p_key = self.KEYS
        self.t = [float(v) for v in arrays[t_key]]
        self.p_f = [np.array(row) for row in arrays[pf_key]]
        self.p = [np.array(row) for row in arrays[p_key]]

    def coords(self, length_unit: str = "m") -> dict[str, tuple[np.ndarray, dict[str, Any]]]:
        """The ``x_probe`` coordinate (none without probes)."""
        if not self.cells.size:
            return {}
        return {PROBE_DIM: (self.x, {"units": length_unit,
                                     "long_name": "x of the cell centre of each basal probe"})}

    def outputs(self, unit: Callable[[str], str] = si_unit) -> dict[str, Output]:
        """``probe_p_f`` and ``probe_p`` on (time, x_probe) (none without probes)."""
        if not self.cells.size:
            return {}
        out = {}
        for name, (units, long_name) in PROBE_SPECS.items():
            field = name.removeprefix("probe_")
            out[name] = Output(lambda sim, f=field: getattr(sim.state, f)[self.cells, 0],
                               VariableSpec((TIME_DIM, PROBE_DIM), unit(units), long_name))
        return out


def check_outputs(outputs: Mapping[str, Any]) -> dict[str, Output]:
    """``outputs`` as a dict of :class:`Output`, or a GranflowInputError naming the bad entry."""
    if not isinstance(outputs, Mapping) or not outputs:
        raise GranflowInputError(f"outputs must be a non-empty mapping name -> Output, got {outputs!r}")
    for name, output in outputs.items():
        if not isinstance(output, Output):
            raise GranflowInputError(f"outputs[{name!r}]: must be an Output(values, spec), got {output!r}")
    return dict(outputs)
