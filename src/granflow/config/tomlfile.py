"""Case-file TOML reading and writing, and the text helpers of the input messages.

* :func:`read_toml`: text and content of a case file (syntax errors with line and column,
  non-UTF-8 bytes located);
* :func:`dumps_toml`: a minimal TOML writer for the effective configuration;
* :func:`toml_key`, :func:`one_line`, :func:`short`: key paths and values in one-line messages.
"""
from __future__ import annotations

import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from granflow.errors import GranflowInputError
from granflow.safe_toml import loads

KEY_SEP = "."
"""Separator of the parts of a key path (``grid.nx``)."""
MAX_TOML_BYTES = 10_000_000
"""Largest case or sweep file read [bytes] (a case file is a few kB; ``/dev/zero`` never ended)."""


def one_line(text: str) -> str:
    """``text`` with its runs of white space (line breaks included) as single spaces."""
    return " ".join(str(text).split())


def toml_key(part: Any) -> str:
    """A key path component, quoted if it is not a plain identifier (one line, printable)."""
    s = str(part)
    return s if s.replace("_", "").isalnum() and s.isascii() else repr(s)


def short(item: Any) -> str:
    """A value or ``--set`` item for a one-line message (line breaks escaped, long text cut)."""
    text = repr(item)
    return text if len(text) <= 60 else text[:57] + "..."


def read_toml(path: str | Path) -> tuple[str, dict[str, Any]]:
    """Text and parsed content of a TOML file; errors say where (line, column) and what."""
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            raw = fh.read(MAX_TOML_BYTES + 1)
    except OSError as err:
        raise GranflowInputError(f"{p}: cannot read the case file ({err.strerror or err})") from None
    if len(raw) > MAX_TOML_BYTES:
        raise GranflowInputError(f"{p}: more than {MAX_TOML_BYTES} bytes, not a case file "
                                 "(granflow.config.tomlfile.MAX_TOML_BYTES)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        line = raw[:err.start].count(b"\n") + 1
        raise GranflowInputError(f"{p}: not UTF-8 text (byte 0x{raw[err.start]:02x} at line {line}); "
                                 "case files are UTF-8 TOML") from None
    try:
        return text, loads(text, str(p))
    except tomllib.TOMLDecodeError as err:
        raise GranflowInputError(f"{p}: TOML syntax error: {one_line(str(err))}") from None


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
            lines.append(f"{toml_key(k)} = {_toml_value(v)}")
    for k, v in tables:
        name = f"{prefix}{toml_key(k)}"
        lines += ["", f"[{name}]", dumps_toml(v, name + KEY_SEP).strip("\n")]
    return "\n".join(lines).strip("\n") + "\n"
