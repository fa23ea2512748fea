"""Output of granflow runs: CF NetCDF files, atomic JSON summaries, checkpoints, xarray accessor,
and the output writers, checkpointers and diagnostics recorders a
:class:`~granflow.simulation.Simulation` runs on their schedules (:mod:`granflow.output.writers`,
:mod:`granflow.output.recorders`, :mod:`granflow.output.fields`; docs/scripting.md).

Importing this package registers the ``ds.granflow`` accessor on xarray Datasets
(:mod:`granflow.output.accessor`) without importing xarray (0.3-0.5 s with pandas, which a run
does not need: it writes with netCDF4): at once if xarray is already imported, else as soon as it
is (:mod:`granflow.output.xarray_hook`). ``Direction``, ``FrontMethod`` and ``GranflowAccessor``
are imported from the accessor module on first access (PEP 562), which imports xarray.
"""
from granflow._lazy import lazy_attributes
from granflow.output.checkpoint import (
    CheckpointError,
    CheckpointManager,
    load_checkpoint,
    save_checkpoint,
)
from granflow.output.netcdf import (
    ARRAY_DIMS,
    FIELD_DIMS,
    NetCDFFormat,
    NetCDFWriter,
    VariableSpec,
    git_revision,
    ordered,
)
from granflow.output.fields import BasalProbes, Output, field_outputs, kinetic_energy_output
from granflow.output.recorders import (
    EquilibriumRangeCheck,
    FrontRecorder,
    RestDetector,
    WallContactRecorder,
    front_output,
)
from granflow.output.summary import atomic_write, jsonable, write_json_atomic
from granflow.output.writers import Checkpointer, NetCDFOutputWriter
from granflow.output.xarray_hook import register_accessor_when_xarray_imported

register_accessor_when_xarray_imported()

_LAZY = {name: "granflow.output.accessor" for name in ("Direction", "FrontMethod", "GranflowAccessor")}
__getattr__, __dir__ = lazy_attributes(__name__, globals(), _LAZY)

__all__ = [
    "ARRAY_DIMS",
    "BasalProbes",
    "Checkpointer",
    "EquilibriumRangeCheck",
    "FrontRecorder",
    "NetCDFOutputWriter",
    "Output",
    "RestDetector",
    "WallContactRecorder",
    "field_outputs",
    "front_output",
    "kinetic_energy_output",
    "FIELD_DIMS",
    "CheckpointError",
    "CheckpointManager",
    "Direction",
    "FrontMethod",
    "GranflowAccessor",
    "NetCDFFormat",
    "NetCDFWriter",
    "VariableSpec",
    "atomic_write",
    "git_revision",
    "jsonable",
    "load_checkpoint",
    "ordered",
    "save_checkpoint",
    "write_json_atomic",
]
