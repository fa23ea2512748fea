"""TOML parsing with limits: every TOML text granflow reads (case files, sweep files, ``--set``
values) goes through :func:`loads`, so that input the parser or the validation cannot handle is
bad input naming where it is, not a traceback:

* arrays or inline tables nested more than :data:`MAX_NESTING` levels (``tomllib`` itself
  overflows Python's stack near 500 levels; no granflow option is nested more than 3);
* integers of more than :data:`MAX_INT_DIGITS` digits (Python refuses to convert them), and
  integers that do not fit in 64 bits (:data:`MAX_INT`), which no option accepts.
"""
from __future__ import annotations

import re
import tomllib
from typing import Any

from granflow.errors import GranflowInputError

MAX_NESTING = 16
"""Deepest nesting of arrays and tables accepted (a case file needs 3)."""
MAX_INT = 2**63 - 1
"""Largest magnitude of an integer value (64-bit)."""
MAX_INT_DIGITS = 4300
"""Python's default limit of digits of an integer read from text (sys.get_int_max_str_digits)."""
_KEY_RE = re.compile(r"^\s*([A-Za-z0-9_\-.\"' ]+?)\s*=")
_LONG_INT_RE = re.compile(r"[0-9][0-9_]{%d,}" % (MAX_INT_DIGITS - 1))


def _where(lines: list[str], index: int) -> str:
    """``"line N (key K)"`` of the 0-based line ``index`` (the key of the last assignment)."""
    for j in range(index, -1, -1):
        m = _KEY_RE.match(lines[j])
        if m:
            return f"line {index + 1} (key {m.group(1).strip()})"
    return f"line {index + 1}"


def _deep_line(text: str) -> int:
    """0-based index of the first line where the bracket nesting exceeds MAX_NESTING (strings and
    comments skipped, roughly); the last line if none does."""
    depth, quote = 0, ""
    lines = text.splitlines() or [""]
    for i, line in enumerate(lines):
        k = 0
        while k < len(line):
            c = line[k]
            if quote:
                if c == "\\" and quote == '"':
                    k += 1
                elif c == quote:
                    quote = ""
            elif c in "\"'":
                quote = c
            elif c == "#":
                break
            elif c in "[{":
                depth += 1
                if depth > MAX_NESTING:
                    return i
            elif c in "]}":
                depth -= 1
            k += 1
    return len(lines) - 1


def check_structure(data: Any, path: tuple = ()) -> None:
    """Refuse nesting deeper than :data:`MAX_NESTING` and integers beyond 64 bits.

    Raises
    ------
    GranflowInputError
        ``"<key.path>: ..."``.
    """
    name = ".".join(str(p) for p in path) or "(top level)"
    if len(path) > MAX_NESTING:
        raise GranflowInputError(f"{name}: arrays or tables nested more than {MAX_NESTING} levels deep")
    if isinstance(data, bool):
        return
    if isinstance(data, int) and abs(data) > MAX_INT:
        raise GranflowInputError(f"{name}: integer with {len(str(abs(data)))} digits is out of range "
                                 f"(at most {MAX_INT} in magnitude)")
    if isinstance(data, dict):
        for k, v in data.items():
            check_structure(v, (*path, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            check_structure(v, (*path, i))


def loads(text: str, where: str) -> dict[str, Any]:
    """``tomllib.loads`` with the limits of this module.

    Parameters
    ----------
    text : str
        TOML text.
    where : str
        What the text is (a file name, ``--set KEY``), prefixed to every message.

    Raises
    ------
    tomllib.TOMLDecodeError
        For a syntax error (the caller words it).
    GranflowInputError
        For input beyond the limits, naming the line and key (or the key path).
    """
    lines = text.splitlines() or [""]
    m = _LONG_INT_RE.search(text)
    if m:
        index = text.count("\n", 0, m.start())
        raise GranflowInputError(f"{where}: {_where(lines, index)}: number with more than "
                                 f"{MAX_INT_DIGITS} digits")
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise GranflowInputError(f"{where}: {_where(lines, _deep_line(text))}: arrays or tables "
                                 f"nested more than {MAX_NESTING} levels deep") from None
    except ValueError as err:
        if isinstance(err, tomllib.TOMLDecodeError):
            raise
        raise GranflowInputError(f"{where}: unreadable value ({' '.join(str(err).split())})") from None
    try:
        check_structure(data)
    except GranflowInputError as err:
        raise GranflowInputError(f"{where}: {err}") from None
    return data


def loads_value(text: str, key: str) -> Any:
    """Parse the value of ``--set KEY=TEXT`` as a TOML value; a text that is not valid TOML is
    taken as a bare string. A line break in the value is refused (TOML would read what follows
    as further keys, which would be dropped silently).

    Raises
    ------
    GranflowInputError
        For a line break, or a value beyond the limits of :func:`loads`.
    """
    if any(c in text for c in "\n\r\x00"):
        raise GranflowInputError(f"--set {key}: the value contains a line break or NUL "
                                 f"({text[:40]!r}); give one value per --set")
    if _LONG_INT_RE.search(text):
        raise GranflowInputError(f"--set {key}: number with more than {MAX_INT_DIGITS} digits")
    try:
        data = tomllib.loads(f"v = {text}")
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:
        raise GranflowInputError(f"--set {key}: arrays or tables nested more than {MAX_NESTING} "
                                 "levels deep") from None
    except ValueError as err:
        raise GranflowInputError(f"--set {key}: unreadable value ({' '.join(str(err).split())})") from None
    if set(data) != {"v"}:  # pragma: no cover - only a line break can add keys
        raise GranflowInputError(f"--set {key}: {text!r} is more than one value")
    try:
        check_structure(data["v"], (key,))
    except GranflowInputError as err:
        raise GranflowInputError(f"--set {err}") from None
    return data["v"]
