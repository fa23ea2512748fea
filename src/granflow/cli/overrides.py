"""``--set key=value`` overrides of the closure commands (``granflow check``, ``stability``, ...):
the dialect of the case files (:func:`granflow.config.parse_override`: values parsed as TOML, a
value that is not valid TOML is a bare string), with short keys: ``--set delta_deg=30`` is a
closure parameter, ``--set material.d=1e-4`` and ``--set equilibrium.a=0.2`` address the sections
the closure is built from."""
from __future__ import annotations

from typing import Any

from granflow.config.overrides import parse_override
from granflow.config.tomlfile import short
from granflow.errors import GranflowInputError

#: Top-level sections an override may address; anything else is a closure parameter.
SECTIONS = ("material", "equilibrium")


def parse_overrides(items: list[str] | None) -> dict[str, dict[str, Any]]:
    """Split ``key=value`` items into {"closure": {...}, "material": {...}, "equilibrium": {...}}.

    Raises
    ------
    GranflowInputError
        For an item without ``=``, an empty key, or a key with more than one dot.
    """
    out: dict[str, dict[str, Any]] = {"closure": {}, "material": {}, "equilibrium": {}}
    for item in items or []:
        parts, value = parse_override(item, form="key=value")
        if len(parts) == 1 and parts[0] in SECTIONS:
            raise GranflowInputError(f"--set {short(item)}: {parts[0]} is a section, not a value; "
                                     f"set one of its parameters: {parts[0]}.<name>=VALUE")
        if len(parts) == 1:
            section, name = "closure", parts[0]
        elif len(parts) == 2 and parts[0] in SECTIONS:
            section, name = parts
        else:
            raise GranflowInputError(
                f"--set {short(item)}: key must be a closure parameter or one of "
                f"{', '.join(s + '.<name>' for s in SECTIONS)}"
            )
        out[section][name] = value
    return out
