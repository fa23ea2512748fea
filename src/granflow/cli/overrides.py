"""``--set key=value`` overrides, values parsed as TOML (``--set delta_deg=30``,
``--set material.d=1e-4``, ``--set 'expression="I^2"'``; a value that is not valid TOML is taken
as a bare string)."""
from __future__ import annotations

import tomllib
from typing import Any

from granflow.errors import GranflowInputError

#: Top-level sections an override may address; anything else is a closure parameter.
SECTIONS = ("material", "equilibrium")


def parse_value(text: str) -> Any:
    """Parse ``text`` as a TOML value; fall back to the bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


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
            raise GranflowInputError(f"--set {item!r}: expected key=value")
        parts = key.split(".")
        if len(parts) == 1:
            section, name = "closure", parts[0]
        elif len(parts) == 2 and parts[0] in SECTIONS:
            section, name = parts
        else:
            raise GranflowInputError(
                f"--set {item!r}: key must be a closure parameter or one of "
                f"{', '.join(s + '.<name>' for s in SECTIONS)}"
            )
        out[section][name] = parse_value(value.strip())
    return out
