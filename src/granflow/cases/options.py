"""Case-file TOML input/output and the option reference.

* :func:`read_toml` (syntax errors with line and column, non-UTF-8 bytes located) and
  :func:`apply_overrides` (``--set a.b=value``, values parsed as TOML), used by
  :func:`granflow.config.load_case`;
* :func:`describe_options`: every option of a case with its default and description (units in
  brackets), for ``granflow config show``, ``granflow list cases`` and docs/cases.md;
* :func:`dumps_toml`: a minimal TOML writer for the effective configuration.
"""
from __future__ import annotations

import copy
import enum
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from granflow.config import (
    KEY_SEP,
    ClosureSection,
    EquilibriumSection,
    _config_model,
    _key,
    _one_line,
    _OpenSection,
)
from granflow.errors import GranflowInputError
from granflow.cli.overrides import _short
from granflow.safe_toml import loads, loads_value


def parse_override(item: str) -> tuple[list[str], Any]:
    """``"a.b=value"`` -> (["a", "b"], value parsed as a TOML value; a bare word is a string)."""
    key, sep, text = item.partition("=")
    parts = [p.strip() for p in key.split(KEY_SEP)]
    if not sep or not all(parts):
        raise GranflowInputError(f"--set {_short(item)}: expected section.key=value, e.g. grid.nx=80")
    return parts, loads_value(text.strip(), key.strip())


def apply_overrides(data: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """Set each ``a.b=value`` of ``overrides`` in (a copy of) the nested dict ``data``."""
    out = copy.deepcopy(data)
    for item in overrides:
        parts, value = parse_override(item)
        node = out
        for i, part in enumerate(parts[:-1]):
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise GranflowInputError(f"--set {_short(item)}: {KEY_SEP.join(parts[:i + 1])} is not a table")
        node[parts[-1]] = value
    return out


def read_toml(path: str | Path) -> tuple[str, dict[str, Any]]:
    """Text and parsed content of a TOML file; errors say where (line, column) and what."""
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as err:
        raise GranflowInputError(f"{p}: cannot read the case file ({err.strerror or err})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        line = raw[:err.start].count(b"\n") + 1
        raise GranflowInputError(f"{p}: not UTF-8 text (byte 0x{raw[err.start]:02x} at line {line}); "
                                 "case files are UTF-8 TOML") from None
    try:
        return text, loads(text, str(p))
    except tomllib.TOMLDecodeError as err:
        raise GranflowInputError(f"{p}: TOML syntax error: {_one_line(str(err))}") from None



def _default(field) -> Any:
    from pydantic_core import PydanticUndefined

    if field.default is not PydanticUndefined:
        value = field.default
    elif field.default_factory is not None:
        value = field.default_factory()
    else:
        return None
    if isinstance(value, enum.Enum):
        value = value.value
    return list(value) if isinstance(value, tuple) else value


def _walk(model: type[BaseModel], prefix: str, out: dict[str, dict[str, Any]]) -> None:
    for name, field in model.model_fields.items():
        ann = field.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel) and not issubclass(ann, _OpenSection):
            _walk(ann, f"{prefix}{name}{KEY_SEP}", out)
        elif not (isinstance(ann, type) and issubclass(ann, _OpenSection)):
            text = field.description or ""
            out[f"{prefix}{name}"] = {"default": _default(field),
                                      "description": text if "[" in text else f"{text} [-]"}


def describe_options(case_name: str, values: Mapping[str, Any] | None = None) -> dict[str, dict[str, Any]]:
    """Every option of a case file: ``"section.key" -> {"default", "description"[, "value"]}``.

    The ``[closure]`` and ``[equilibrium]`` entries are those of the closure and law named in
    ``values`` (an effective configuration, ``CaseConfig.model_dump(mode="json")``) or of the
    defaults; ``value`` entries are added when ``values`` is given.
    """
    from granflow.equilibrium import EQUILIBRIUM_LAWS
    from granflow.rheology import CLOSURES

    model = _config_model(case_name)
    out: dict[str, dict[str, Any]] = {}
    _walk(model, "", out)
    out["case.name"]["default"] = case_name
    vals = dict(values or {})
    closure = vals.get("closure", {}).get("name", ClosureSection.model_fields["name"].default)
    law = vals.get("equilibrium", {}).get("law", EquilibriumSection.model_fields["law"].default)
    opts = {"closure.name": {"default": ClosureSection.model_fields["name"].default,
                             "description": ClosureSection.model_fields["name"].description}}
    for name, field in CLOSURES.get(closure).model_fields.items():
        if name not in ("material", "equilibrium"):
            opts[f"closure.{name}"] = {"default": _default(field),
                                       "description": f"{closure}: {field.description or ''}"}
    opts["equilibrium.law"] = {"default": EquilibriumSection.model_fields["law"].default,
                               "description": EquilibriumSection.model_fields["law"].description}
    for name, field in EQUILIBRIUM_LAWS.get(law).model_fields.items():
        if name == "phi_max":
            continue
        note = " (default: material.delta_phi)" if name == "delta_phi" else ""
        opts[f"equilibrium.{name}"] = {"default": _default(field),
                                       "description": f"{law}: {field.description or ''}{note}"}
    ordered: dict[str, dict[str, Any]] = {}
    for key, opt in out.items():  # closure and equilibrium after material, in file order
        ordered[key] = opt
        if key == "material.c_I":
            ordered.update(opts)
    if values is not None:
        for key, opt in ordered.items():
            node: Any = vals
            for part in key.split(KEY_SEP):
                node = node.get(part) if isinstance(node, dict) else None
            opt["value"] = node
    return ordered


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise GranflowInputError(f"cannot write a {type(v).__name__} as a TOML value")


def dumps_toml(data: Mapping[str, Any], prefix: str = "") -> str:
    """Minimal TOML writer for nested dicts of scalars, strings and lists (no None)."""
    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, Mapping):
            tables.append((k, v))
        else:
            lines.append(f"{_key(k)} = {_toml_value(v)}")
    for k, v in tables:
        name = f"{prefix}{_key(k)}"
        lines += ["", f"[{name}]", dumps_toml(v, name + KEY_SEP).strip("\n")]
    return "\n".join(lines).strip("\n") + "\n"
