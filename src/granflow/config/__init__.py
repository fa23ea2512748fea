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

>>> cfg = CaseConfig.from_dict({"case": {"name": "column_collapse"}, "grid": {"nx": 20, "nz": 8}})
>>> cfg.grid.nx, cfg.closure.name, cfg.setup.H0
(20, 'drucker_prager', 0.1)
"""
from granflow.config.overrides import (
    EXTRA_SET_ENV,
    apply_overrides,
    environment_overrides,
    parse_override,
    parse_value,
)
from granflow.config.schema import (
    COLUMN_KEYS,
    DEFAULT_GRAVITY,
    EQUILIBRIUM_I,
    KEY_SEP,
    MAX_CELLS,
    MAX_SLOPE_DEG,
    MAX_STEPS,
    OUTPUT_FIELDS,
    PHYSICAL_RANGES,
    AmbientSection,
    CaseConfig,
    CaseSection,
    ClosureSection,
    EmptySetup,
    EquilibriumSection,
    GasLawName,
    GasSection,
    GravitySection,
    GridSection,
    MaterialSection,
    NumericsSection,
    OpenSection,
    OutputSection,
    PicardSection,
    Section,
    TimeSection,
    WallCondition,
    WallsSection,
)
from granflow.config.tomlfile import dumps_toml, read_toml
from granflow.config.validation import (
    CaseCatalogue,
    case_catalogue,
    cases_changed,
    config_model,
    load_case,
    register_cases,
    validate,
)

__all__ = [
    "COLUMN_KEYS", "DEFAULT_GRAVITY", "EQUILIBRIUM_I", "EXTRA_SET_ENV", "KEY_SEP", "MAX_CELLS",
    "MAX_SLOPE_DEG", "MAX_STEPS", "OUTPUT_FIELDS", "PHYSICAL_RANGES",
    "AmbientSection", "CaseCatalogue", "CaseConfig", "CaseSection", "ClosureSection", "EmptySetup",
    "EquilibriumSection", "GasLawName", "GasSection", "GravitySection", "GridSection",
    "MaterialSection", "NumericsSection", "OpenSection", "OutputSection", "PicardSection",
    "Section", "TimeSection", "WallCondition", "WallsSection",
    "apply_overrides", "case_catalogue", "cases_changed", "config_model", "dumps_toml",
    "environment_overrides", "load_case", "parse_override", "parse_value", "read_toml",
    "register_cases", "validate",
]
