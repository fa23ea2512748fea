"""Typed, strict parameter models and the conversion of validation failures into clear errors.

All parameter sets of granflow are frozen pydantic models with ``extra="forbid"``: a misspelt key
is an error naming it, a value out of range is an error naming the key and the allowed range.
"""
from __future__ import annotations

import enum
import types
import typing
from typing import Any, Literal, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError, ValidationInfo, field_validator

from granflow.errors import GranflowInputError

M = TypeVar("M", bound=BaseModel)


def accepts(annotation: Any, kind: type) -> bool:
    """Whether a field annotation accepts values of ``kind`` (``str`` or ``bool``) as they are."""
    if annotation is kind or annotation is Any:
        return True
    if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
        return any(isinstance(m.value, kind) for m in annotation)
    origin = typing.get_origin(annotation)
    if origin is Literal:
        return any(isinstance(a, kind) for a in typing.get_args(annotation))
    if origin in (typing.Union, types.UnionType):
        return any(accepts(a, kind) for a in typing.get_args(annotation))
    return False


def _element_type(annotation: Any) -> Any:
    """The element annotation of ``tuple[X, ...]`` / ``list[X]`` (None for anything else)."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        found = [e for e in map(_element_type, typing.get_args(annotation)) if e is not None]
        return found[0] if found else None
    if origin in (tuple, list):
        args = [a for a in typing.get_args(annotation) if a is not Ellipsis]
        return args[0] if len(set(args)) == 1 else None
    return None


def refuse_text_numbers(value: Any, annotation: Any) -> None:
    """Raise ``ValueError`` for a string given where the annotation wants a number (no silent
    conversion of ``"0.2"`` to 0.2), a boolean where it wants a number (``true`` is not 1), or
    a float where it wants an integer (``n = 2.0``), also for the elements of a tuple or list."""
    if isinstance(value, str) and not accepts(annotation, str):
        raise ValueError(f"Input should be a number, not the text {value!r}")
    if isinstance(value, bool) and not accepts(annotation, bool):
        raise ValueError(f"Input should be a number, not the boolean {str(value).lower()}")
    if isinstance(value, float) and accepts(annotation, int) and not accepts(annotation, float):
        raise ValueError(f"Input should be an integer, not the float {value!r}")
    element = _element_type(annotation)
    if element is not None and isinstance(value, (list, tuple)):
        for item in value:
            refuse_text_numbers(item, element)


class Params(BaseModel):
    """Base class of granflow's parameter models: frozen, strict about unknown keys, validated on
    construction and on copy; a number given as text (``"0.2"``) is refused, not converted."""

    model_config = ConfigDict(frozen=True, extra="forbid", validate_default=True)

    @field_validator("*", mode="before")
    @classmethod
    def _no_text_numbers(cls, value: Any, info: ValidationInfo) -> Any:
        field = cls.model_fields.get(info.field_name) if info.field_name else None
        if field is not None:
            refuse_text_numbers(value, field.annotation)
        return value


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
