"""Exceptions raised by granflow.

Every error caused by user input derives from :class:`GranflowInputError`, so the command-line
interface can turn it into a one-line message and exit code 2 without a traceback.
"""
from __future__ import annotations


class GranflowError(Exception):
    """Base class of granflow's own exceptions."""


class GranflowInputError(GranflowError, ValueError):
    """Bad user input: unknown registry name, unknown or invalid parameter, unparsable expression.

    The message names the offending item and what was expected.
    """


class UnknownNameError(GranflowInputError, KeyError):
    """A registry key that is not registered (e.g. a misspelt closure name)."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it readable
        return str(self.args[0]) if self.args else ""
