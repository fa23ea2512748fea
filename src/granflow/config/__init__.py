"""Case files: the strict, typed configuration of a run (STYLE.md idiom 9).

A package that depends on nothing above it (the numerical core, the registries of closures and
equilibrium laws, pydantic); the cases plug their ``[setup]`` models and checks in through
:func:`register_cases`.

* :mod:`~granflow.config.schema`: the sections and :class:`CaseConfig` (every option, its default,
  unit and range);
* :mod:`~granflow.config.tomlfile`: TOML reading (:func:`read_toml`) and writing (:func:`dumps_toml`);
* :mod:`~granflow.config.overrides`: the ``--set key=value`` dialect (:func:`parse_override`,
  :func:`apply_overrides`), shared with the command line;
* :mod:`~granflow.config.validation`: :func:`load_case` and the one-error-for-all-problems
  validation;
* :mod:`~granflow.config.checks`: the checks that span sections (any case).

>>> from granflow.config import CaseConfig
>>> cfg = CaseConfig.from_dict({"case": {"name": "column_collapse"}, "grid": {"nx": 20, "nz": 8}})
>>> cfg.grid.nx, cfg.closure.name, cfg.setup.H0
(20, 'drucker_prager', 0.1)
"""
from granflow._lazy import lazy_attributes

#: Public names and the submodule that defines each, imported on first access (PEP 562): the
#: command line's ``--set`` parser needs only :mod:`~granflow.config.overrides`, and importing the
#: schema pulls in the numerical core (SciPy, NumPy) -- ``granflow --help`` must not.
_LAZY = {
    "EXTRA_SET_ENV": "granflow.config.overrides",
    "apply_overrides": "granflow.config.overrides",
    "environment_overrides": "granflow.config.overrides",
    "parse_override": "granflow.config.overrides",
    "parse_value": "granflow.config.overrides",
    "AmbientSection": "granflow.config.schema",
    "COLUMN_KEYS": "granflow.config.schema",
    "CaseConfig": "granflow.config.schema",
    "CaseSection": "granflow.config.schema",
    "ClosureSection": "granflow.config.schema",
    "DEFAULT_GRAVITY": "granflow.config.schema",
    "EQUILIBRIUM_I": "granflow.config.schema",
    "EmptySetup": "granflow.config.schema",
    "EquilibriumSection": "granflow.config.schema",
    "GasLawName": "granflow.config.schema",
    "GasSection": "granflow.config.schema",
    "GravitySection": "granflow.config.schema",
    "GridSection": "granflow.config.schema",
    "KEY_SEP": "granflow.config.schema",
    "MAX_CELLS": "granflow.config.schema",
    "MAX_SLOPE_DEG": "granflow.config.schema",
    "MAX_STEPS": "granflow.config.schema",
    "MAX_RECORDS": "granflow.config.schema",
    "MAX_RETRIES": "granflow.config.schema",
    "MaterialSection": "granflow.config.schema",
    "NumericsSection": "granflow.config.schema",
    "OUTPUT_FIELDS": "granflow.config.schema",
    "OpenSection": "granflow.config.schema",
    "OutputSection": "granflow.config.schema",
    "PHYSICAL_RANGES": "granflow.config.schema",
    "NUMERICS_RANGES": "granflow.config.schema",
    "PicardSection": "granflow.config.schema",
    "Section": "granflow.config.schema",
    "TimeSection": "granflow.config.schema",
    "WallCondition": "granflow.config.schema",
    "WallsSection": "granflow.config.schema",
    "dumps_toml": "granflow.config.tomlfile",
    "read_toml": "granflow.config.tomlfile",
    "CaseCatalogue": "granflow.config.validation",
    "case_catalogue": "granflow.config.validation",
    "cases_changed": "granflow.config.validation",
    "config_model": "granflow.config.validation",
    "load_case": "granflow.config.validation",
    "register_cases": "granflow.config.validation",
    "validate": "granflow.config.validation",
}


__getattr__, __dir__ = lazy_attributes(__name__, globals(), _LAZY)

__all__ = [
    "COLUMN_KEYS", "DEFAULT_GRAVITY", "EQUILIBRIUM_I", "EXTRA_SET_ENV", "KEY_SEP", "MAX_CELLS",
    "MAX_SLOPE_DEG", "MAX_STEPS", "MAX_RECORDS", "MAX_RETRIES", "OUTPUT_FIELDS", "PHYSICAL_RANGES", "NUMERICS_RANGES",
    "AmbientSection", "CaseCatalogue", "CaseConfig", "CaseSection", "ClosureSection", "EmptySetup",
    "EquilibriumSection", "GasLawName", "GasSection", "GravitySection", "GridSection",
    "MaterialSection", "NumericsSection", "OpenSection", "OutputSection", "PicardSection",
    "Section", "TimeSection", "WallCondition", "WallsSection",
    "apply_overrides", "case_catalogue", "cases_changed", "config_model", "dumps_toml",
    "environment_overrides", "load_case", "parse_override", "parse_value", "read_toml",
    "register_cases", "validate",
]
