"""Output of granflow runs: CF NetCDF files, atomic JSON summaries, checkpoints, xarray accessor.

Importing this package registers the ``ds.granflow`` accessor on xarray Datasets
(:mod:`granflow.output.accessor`).
"""
from granflow.output import accessor  # noqa: F401  (registers ds.granflow)
from granflow.output.accessor import Direction, FrontMethod, GranflowAccessor
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
from granflow.output.summary import atomic_write, jsonable, write_json_atomic

__all__ = [
    "ARRAY_DIMS",
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
