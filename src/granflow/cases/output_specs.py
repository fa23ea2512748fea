"""What a case run writes to output.nc: the NetCDF declarations (units, long_name) of the
cell fields, the time series and the basal probes, and the kinds of unit a dimensionless case
replaces (:class:`granflow.cases.runner.CaseRun`)."""
from __future__ import annotations

from granflow import diagnostics as dg

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
    "x_front": ("m", f"front position: {dg.FRONT_DEFINITION} (attribute front_threshold_m; resolution dx)"),
}
UNIT_KINDS = ("length", "time", "speed", "pressure", "rate", "energy")
SI_KIND = {"m": "length", "s": "time", "m s-1": "speed", "Pa": "pressure", "s-1": "rate", "J m-1": "energy"}
"""The SI units of the output and the kind of quantity each stands for (a dimensionless case
replaces them: :attr:`granflow.cases.registry.Case.units`)."""
