"""``--set key=value`` overrides, values parsed as TOML (``--set delta_deg=30``,
``--set material.d=1e-4``, ``--set 'expression="I^2"'``; a value that is not valid TOML is taken
as a bare string)."""
from __future__ import annotations

from typing import Any

from granflow.errors import GranflowInputError
from granflow.safe_toml import loads_value

#: Top-level sections an override may address; anything else is a closure parameter.
SECTIONS = ("material", "equilibrium")


def parse_value(text: str, key: str = "value") -> Any:
    """Parse ``text`` as a TOML value; fall back to the bare string (limits and line breaks:
    :func:`granflow.safe_toml.loads_value`)."""
    return loads_value(text, key)


def parse_overrides(items: list[str] | None) -> dict[str, dict[str, Any]]:
    """Split ``key=value`` items into {"closure": {...}, "material": {...}, "equilibrium": {...}}.

    Raises
    ------
    GranflowInputError
        For an item without ``=``, an empty key, or a key with more than one dot.
    """
    out: dict[str, dict[str, Any]] = {"closure": {}, "material": {}, "equilibrium": {}}
    for item in items or []:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise GranflowInputError(f"--set {_short(item)}: expected key=value")
        parts = key.split(".")
        if len(parts) == 1 and parts[0] in SECTIONS:
            raise GranflowInputError(f"--set {_short(item)}: {parts[0]} is a section, not a value; "
                                     f"set one of its parameters: {parts[0]}.<name>=VALUE")
        if len(parts) == 1:
            section, name = "closure", parts[0]
        elif len(parts) == 2 and parts[0] in SECTIONS:
            section, name = parts
        else:
            raise GranflowInputError(
                f"--set {_short(item)}: key must be a closure parameter or one of "
                f"{', '.join(s + '.<name>' for s in SECTIONS)}"
            )
        out[section][name] = parse_value(value.strip(), key)
    return out


def _short(item: str) -> str:
    """An item for a one-line message (line breaks escaped, long text cut)."""
    text = repr(item)
    return text if len(text) <= 60 else text[:57] + "..."
