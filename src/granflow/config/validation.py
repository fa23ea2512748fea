"""Validation of a case file: read, override, check -- every problem in one error.

:func:`load_case` reads a TOML file (:mod:`granflow.config.tomlfile`), applies the ``--set`` items
(:mod:`granflow.config.overrides`) and validates the result (:func:`validate`): the schema
(:mod:`granflow.config.schema`), the closure and equilibrium law of the registries, the case's own
``[setup]`` model and check, and the checks across sections (:mod:`granflow.config.checks`).

The cases sit above this package: they plug in through :func:`register_cases`, which the case
registry (granflow.casekit.registry) calls with its catalogue when it is imported. A case file names
a case, so validating one needs the catalogue; if none is registered yet, the default catalogue
:data:`DEFAULT_CASES` is imported by name on first use (as an entry point would be) -- the one
place this package refers to a package above it, and by a string, not an import.
"""
from __future__ import annotations

import difflib
import functools
import importlib
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from pydantic import BaseModel, Field, ValidationError, create_model

from granflow.config.checks import common_problems
from granflow.config.overrides import apply_overrides, environment_overrides
from granflow.config.schema import (
    CaseConfig,
    ClosureSection,
    EquilibriumSection,
    MaterialSection,
    Section,
)
from granflow.config.tomlfile import KEY_SEP, one_line, read_toml, short, toml_key
from granflow.errors import GranflowInputError, UnknownNameError
from granflow.materials import Material
from granflow.params import accepts

MAX_SUGGESTIONS = 1
"""Number of "did you mean" suggestions for an unknown key."""
DEFAULT_CASES = "granflow.cases"
"""Module whose import registers the default case catalogue (see :func:`register_cases`)."""


class CaseEntry(Protocol):
    """What validation needs of a case: its ``[setup]`` model and its cross-section check."""

    setup_model: type[Section]
    check: Callable[[CaseConfig], list[tuple[str, str]]]


class CaseCatalogue(Protocol):
    """Name -> :class:`CaseEntry` (granflow.cases.CASES is one)."""

    def __contains__(self, name: object) -> bool: ...

    def names(self) -> list[str]: ...

    def get(self, name: str) -> CaseEntry: ...


_catalogue: CaseCatalogue | None = None


def register_cases(catalogue: CaseCatalogue) -> None:
    """Plug a case catalogue in: the names, ``[setup]`` models and checks of the cases."""
    global _catalogue
    _catalogue = catalogue
    config_model.cache_clear()


def cases_changed() -> None:
    """Forget the CaseConfig models built so far (a case was added or removed)."""
    config_model.cache_clear()


def case_catalogue() -> CaseCatalogue:
    """The registered case catalogue (the default one, :data:`DEFAULT_CASES`, imported if none)."""
    if _catalogue is None:
        importlib.import_module(DEFAULT_CASES)
    if _catalogue is None:  # pragma: no cover - the default catalogue registers itself
        raise RuntimeError(f"importing {DEFAULT_CASES} registered no case catalogue")
    return _catalogue


def load_case(path: str | Path, overrides: list[str] | None = None) -> CaseConfig:
    """Read, override and validate a case file.

    Parameters
    ----------
    path : path-like
        TOML case file.
    overrides : list of str, optional
        ``"section.key=value"`` items, values parsed as TOML (``grid.nx=80``,
        ``closure.name="mu_i"``; a bare word is taken as a string).

    Returns
    -------
    CaseConfig

    Raises
    ------
    GranflowInputError
        Unreadable file, TOML syntax error (with line and column), or invalid content (every
        problem, each naming its key path, in one message prefixed with the file name).
    """
    text, data = read_toml(path)
    section = data.get("case") if isinstance(data.get("case"), dict) else {}
    case_name = section.get("name", "column_collapse")  # the default of [case] name
    data = apply_overrides(data, list(overrides or []) + environment_overrides(case_name))
    try:
        data = _read_profile(data, Path(path))
        cfg = validate(data)
    except GranflowInputError as err:
        raise GranflowInputError(f"{path}: {err}") from None
    cfg._source_text = text
    cfg._source_path = str(path)
    cfg._overrides = tuple(overrides or ())
    return cfg


def _read_profile(data: dict, path: Path) -> dict:
    """``topography.file`` (relative to the case file) read into ``topography.x`` and ``.z``."""
    topo = data.get("topography")
    if not isinstance(topo, dict) or not isinstance(topo.get("file"), str):
        return data
    if topo.get("x") or topo.get("z"):
        return data  # the schema reports "not both"
    from granflow.topography import Topography

    csv = Path(topo["file"])
    try:
        profile = Topography.from_csv(csv if csv.is_absolute() else path.parent / csv)
    except GranflowInputError as err:
        raise GranflowInputError(f"topography.file: {err}") from None
    rest = {k: v for k, v in topo.items() if k != "file"}
    return {**data, "topography": {**rest, "x": profile.x.tolist(), "z": profile.z.tolist()}}


def _path(loc) -> str:
    return KEY_SEP.join(toml_key(p) for p in loc) or "(case file)"


@functools.cache
def config_model(case_name: str | None) -> type[CaseConfig]:
    """CaseConfig whose ``setup`` is the case's own model (plain dict for ``None``)."""
    if case_name is None:
        return create_model("CaseConfigAnyCase", __base__=CaseConfig, setup=(dict[str, Any], {}))
    model = case_catalogue().get(case_name).setup_model
    return create_model(f"CaseConfig_{case_name}", __base__=CaseConfig,
                        setup=(model, Field(default_factory=model)))


def _fields_at(model: type[BaseModel], loc) -> list[str]:
    """Allowed keys of the section at ``loc`` (for "unknown key" messages)."""
    for part in loc:
        field = model.model_fields.get(str(part))
        ann = getattr(field, "annotation", None)
        if not (isinstance(ann, type) and issubclass(ann, BaseModel)):
            return []
        model = ann
    return list(model.model_fields)


def _pydantic_errors(err: ValidationError, model: type[BaseModel]) -> list[str]:
    out = []
    for e in err.errors():
        loc = e["loc"]
        if e["type"] == "extra_forbidden":
            allowed = _fields_at(model, loc[:-1])
            near = difflib.get_close_matches(str(loc[-1]), allowed, n=MAX_SUGGESTIONS)
            hint = f"; did you mean {near[0]!r}?" if near else ""
            out.append(f"{_path(loc)}: unknown key (expected one of: {', '.join(allowed)}){hint}")
            continue
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] == "missing":
            out.append(f"{_path(loc)}: missing")
        elif isinstance(e.get("input"), dict):  # a whole-section validator: do not echo the section
            out.append(f"{_path(loc)}: {msg}")
        else:
            out.append(f"{_path(loc)}: {msg} (got {short(e.get('input'))})")
    return out


def _nonfinite(data: Any, loc: tuple) -> list[str]:
    if isinstance(data, float) and not math.isfinite(data):
        return [f"{_path(loc)}: Input should be a finite number (got {data!r})"]
    if isinstance(data, dict):
        return [m for k, v in data.items() for m in _nonfinite(v, (*loc, k))]
    if isinstance(data, list):
        return [m for i, v in enumerate(data) for m in _nonfinite(v, (*loc, i))]
    return []


def _registry_errors(data: Any, material: Material) -> list[str]:
    """Build the closure (or check the equilibrium law) of the raw section; errors named."""
    from granflow.equilibrium import EQUILIBRIUM_LAWS
    from granflow.rheology import CLOSURES, make_closure

    closure_raw = data.get("closure", {}) if isinstance(data.get("closure", {}), dict) else {}
    eq_raw = data.get("equilibrium", {}) if isinstance(data.get("equilibrium", {}), dict) else {}
    name = closure_raw.get("name", ClosureSection.model_fields["name"].default)
    law = eq_raw.get("law", EquilibriumSection.model_fields["law"].default)
    if not isinstance(name, str) or not isinstance(law, str):
        return []  # reported as a type error by pydantic
    params = {k: v for k, v in closure_raw.items() if k != "name"}
    eq_params = {k: v for k, v in eq_raw.items() if k != "law"}
    errors = []
    if name not in CLOSURES:
        near = difflib.get_close_matches(name, CLOSURES.names(), n=MAX_SUGGESTIONS)
        errors.append(f"closure.name: unknown closure {name!r} (expected one of: "
                      f"{', '.join(CLOSURES.names())})" + (f"; did you mean {near[0]!r}?" if near else ""))
    if law not in EQUILIBRIUM_LAWS:
        errors.append(f"equilibrium.law: unknown equilibrium law {law!r} (expected one of: "
                      f"{', '.join(EQUILIBRIUM_LAWS.names())})")
    if errors:
        return errors
    cls = CLOSURES.get(name)
    for key, value in params.items():
        field = cls.model_fields.get(key)
        if key in ("material", "equilibrium"):
            errors.append(f"closure.{toml_key(key)}: not a closure parameter; use the [{key}] section")
        elif field is not None and isinstance(value, (str, bool)) and not accepts(field.annotation, type(value)):
            errors.append(f"closure.{toml_key(key)}: Input should be a number (got {short(value)})")
    if errors:
        return errors
    try:
        make_closure(name, material=material, equilibrium=law, equilibrium_params=eq_params, **params)
    except UnknownNameError as err:  # pragma: no cover - names checked above
        errors.append(str(err))
    except GranflowInputError as err:
        allowed = {"closure": (f"closure {name!r}", [k for k in cls.model_fields
                                                     if k not in ("material", "equilibrium")]),
                   "equilibrium": (f"equilibrium law {law!r}", [k for k in EQUILIBRIUM_LAWS.get(law).model_fields
                                                               if k != "phi_max"])}
        for part in one_line(str(err)).split("; "):
            head = part.split(KEY_SEP, 1)[0]
            if head in allowed and part.endswith("unknown parameter"):
                what, keys = allowed[head]
                part += f" of {what} (expected one of: {', '.join(keys)})"
            errors.append(part if head in allowed else f"closure: {part}")
    return errors


def validate(data: dict[str, Any]) -> CaseConfig:
    """The :class:`CaseConfig` of a parsed case file; every problem in one GranflowInputError."""
    cases = case_catalogue()
    errors: list[str] = []
    case_raw = data.get("case")
    case_name = case_raw.get("name") if isinstance(case_raw, dict) else None
    if isinstance(case_name, str) and case_name not in cases:
        near = difflib.get_close_matches(case_name, cases.names(), n=MAX_SUGGESTIONS)
        errors.append(f"case.name: unknown case {case_name!r} (expected one of: {', '.join(cases.names())})"
                      + (f"; did you mean {near[0]!r}?" if near else ""))
    model = config_model(case_name if isinstance(case_name, str) and case_name in cases else None)
    errors += _nonfinite({k: data.get(k) for k in ("closure", "equilibrium") if k in data}, ())
    cfg = None
    try:
        cfg = model.model_validate(data)
    except ValidationError as err:
        errors += _pydantic_errors(err, model)
    if not any(e.startswith(("closure", "equilibrium")) for e in errors):
        try:
            material = MaterialSection.model_validate(data.get("material", {}))
        except ValidationError:
            material = Material()
        errors += _registry_errors(data, material)
    if errors:
        raise GranflowInputError("; ".join(dict.fromkeys(errors)))
    errors = [f"{path}: {msg}" for path, msg in cases.get(cfg.case.name).check(cfg) + common_problems(cfg)]
    if errors:
        raise GranflowInputError("; ".join(errors))
    return cfg
