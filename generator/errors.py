"""The errors and warnings of spec validation, and how a value is echoed in their messages.

Input: nothing. Output: `SpecError` (a specification is invalid; the message names the origin,
key and item), `SpecWarning` (accepted after a small correction) and `shown` (a value cut to a
one-line message). Every front door and validation module raises these.

Example:
    >>> shown("x" * 100, 12)
    "'xxxxxxx...'"
"""

from __future__ import annotations

__all__ = ["SpecError", "SpecWarning", "shown"]


class SpecError(ValueError):
    """A system specification is invalid. The message names file/origin, key and item."""


def shown(value: object, limit: int = 60) -> str:
    """repr(value) for a one-line message, cut to `limit` characters (a value echoed in an
    error may be a 1000-digit string or a whole table)."""
    text = repr(value)
    if len(text) <= limit:
        return text
    close = text[-1] if text[0] in "'\"" else ""  # a cut string keeps its closing quote
    return text[: limit - 3 - len(close)] + "..." + close


class SpecWarning(UserWarning):
    """A system specification was accepted after a small correction (e.g. normalization)."""
