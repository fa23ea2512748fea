"""Typed, strict parameter models and the conversion of validation failures into clear errors.

All parameter sets of granflow are frozen pydantic models with ``extra="forbid"``: a misspelt key
is an error naming it, a value out of range is an error naming the key and the allowed range.
"""
from __future__ import annotations

from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError

from granflow.errors import GranflowInputError

M = TypeVar("M", bound=BaseModel)


class Params(BaseModel):
    """Base class of granflow's parameter models: frozen, strict about unknown keys, validated on
    construction and on copy."""

    model_config = ConfigDict(frozen=True, extra="forbid", validate_default=True)


def format_validation_error(err: ValidationError, context: str = "") -> str:
    """One line naming each offending key path and what was expected."""
    parts = []
    for e in err.errors():
        loc = ".".join(str(x) for x in e["loc"])
        loc = ".".join(part for part in (context, loc) if part) or "(value)"
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] == "extra_forbidden":
            msg = "unknown parameter"
        inp = e.get("input")
        # Whole-model validators (empty loc) receive the whole input: do not echo it.
        shown = "" if e["type"] in ("extra_forbidden", "missing") or not e["loc"] else f" (got {inp!r})"
        parts.append(f"{loc}: {msg}{shown}")
    return "; ".join(parts)


def build(cls: type[M], params: dict[str, Any] | None = None, context: str = "") -> M:
    """Construct ``cls(**params)``, turning validation failures into :class:`GranflowInputError`.

    Parameters
    ----------
    cls : type
        A pydantic model class.
    params : dict, optional
        Keyword parameters.
    context : str
        Prefix for key paths in error messages (e.g. ``"closure"``).
    """
    try:
        return cls(**(params or {}))
    except ValidationError as err:
        raise GranflowInputError(format_validation_error(err, context)) from None
