"""``--set key=value`` overrides: the one dialect of ``granflow run``, ``granflow config show``,
the sweeps and the closure commands (``granflow check --set delta_deg=30``).

An item is ``dotted.key=value``; the value is parsed as a TOML value and a bare word that is not
valid TOML is a string (``--set closure.name=mu_i``, ``--set 'expression="I^2"'``; limits and
line breaks: :func:`granflow.safe_toml.loads_value`). :func:`apply_overrides` sets the items in a
parsed case file; the CLI maps its short keys to sections itself (granflow.cli.overrides).
"""
from __future__ import annotations

import copy
import os
from typing import Any

from granflow.config.tomlfile import KEY_SEP, short
from granflow.errors import GranflowInputError
from granflow.safe_toml import MAX_NESTING, loads_value

CASE_FILE_FORM = "section.key=value, e.g. grid.nx=80"
"""The form of an item, as said in the error for a malformed one (case files)."""
EXTRA_SET_ENV = "GRANFLOW_EXTRA_SET"
"""Environment variable of extra ``--set`` items applied after the command line's, for tests that
run the documentation's commands on small grids: ``;``-separated ``key=value`` items, each
optionally scoped to one case as ``case:key=value``. Unset in normal use."""
CONVERGED_LOOP = ("numerics.picard.max_sweeps=10", 'numerics.picard.predictor="previous"', "time.cfl=0.3",
                  "numerics.ambient.velocity_band_margin=0")
"""``--set`` items restoring the step that was the default from session 12 to 24: the Picard loop
iterated to ``tol`` from ``u^n``, CFL 0.3, the pattern rebuilt every step (docs/solver.md,
"Session 25: the switch"). Validations measured with it pin it (scheme v1's runs, benchmarks)."""


def parse_value(text: str, key: str = "value") -> Any:
    """Parse ``text`` as a TOML value; fall back to the bare string."""
    return loads_value(text, key)


def parse_override(item: str, form: str = CASE_FILE_FORM) -> tuple[list[str], Any]:
    """``"a.b=value"`` -> (["a", "b"], value parsed as a TOML value; a bare word is a string).

    Raises
    ------
    GranflowInputError
        ``"--set <item>: expected <form>"`` for an item without ``=`` or with an empty key part.
    """
    key, sep, text = item.partition("=")
    parts = [p.strip() for p in key.split(KEY_SEP)]
    if not sep or not all(parts):
        raise GranflowInputError(f"--set {short(item)}: expected {form}")
    if len(parts) > MAX_NESTING:
        raise GranflowInputError(f"--set {short(item)}: a key of {len(parts)} parts; tables are "
                                 f"nested at most {MAX_NESTING} levels deep")
    return parts, parse_value(text.strip(), key.strip())


def apply_overrides(data: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """Set each ``a.b=value`` of ``overrides`` in (a copy of) the nested dict ``data``."""
    out = copy.deepcopy(data)
    for item in overrides:
        parts, value = parse_override(item)
        node = out
        for i, part in enumerate(parts[:-1]):
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise GranflowInputError(f"--set {short(item)}: {KEY_SEP.join(parts[:i + 1])} is not a table")
        node[parts[-1]] = value
    return out


def environment_overrides(case_name: str | None) -> list[str]:
    """The items of :data:`EXTRA_SET_ENV` that apply to ``case_name``."""
    out = []
    for item in os.environ.get(EXTRA_SET_ENV, "").split(";"):
        item = item.strip()
        if not item:
            continue
        scope, sep, rest = item.partition(":")
        if sep and "=" not in scope:
            if scope == case_name:
                out.append(rest.strip())
        else:
            out.append(item)
    return out
