"""The option reference of a case: :func:`describe_options`, every option with its default and
description (units in brackets), for ``granflow config show``, ``granflow list cases`` and
docs/cases.md. (TOML reading and writing and the ``--set`` items: :mod:`granflow.config`.)
"""
from __future__ import annotations

import enum
from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

from granflow.config import KEY_SEP, ClosureSection, EquilibriumSection, OpenSection, config_model


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
        if isinstance(ann, type) and issubclass(ann, BaseModel) and not issubclass(ann, OpenSection):
            _walk(ann, f"{prefix}{name}{KEY_SEP}", out)
        elif not (isinstance(ann, type) and issubclass(ann, OpenSection)):
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

    model = config_model(case_name)
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
