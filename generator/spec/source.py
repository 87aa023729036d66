"""The text of one expression: which characters it may hold, and where a token is in it.

Input: the user's expression text (and the text handed to `ast.parse`, which may differ by
leading whitespace or added parentheses). Output: a `SpecError` for a character the language
refuses or a number too long to be a double, and `_Context`, which turns an `ast` node's
position back into the line and column of the user's text for messages (1-based, in
characters).

Example:
    >>> _text_position("m*g + #", 6)
    'column 7'
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass

from s2gen.errors import SpecError
from s2gen.spec.names import _Names

__all__: list[str] = []

_MAX_LITERAL_DIGITS = 400  # digits of one number as written
#: Characters an expression may contain: printable ASCII and line breaks, but no '#'.
_ALLOWED = frozenset(chr(c) for c in range(0x20, 0x7F)) | {"\t", "\n", "\r"}
_LONG_DIGITS = re.compile(f"[0-9_]{{{_MAX_LITERAL_DIGITS + 1},}}")


@dataclass(frozen=True)
class _Context:
    """What a parse may see, plus what it needs to point at the offending token."""

    body: str  # the text given to ast.parse
    where: str
    names: _Names
    line_shift: int  # lines and first-line columns of `body` -> of the user's text
    col_shift: int

    def fail(self, node: ast.AST | None, message: str) -> SpecError:
        """A SpecError for `message` located at `node` (or without position)."""
        if node is None or not hasattr(node, "lineno"):
            return SpecError(f"{self.where}: {message}")
        line, byte_col = node.lineno, node.col_offset  # type: ignore[attr-defined]
        source = self.lines[min(line, len(self.lines)) - 1].encode()
        col = len(source[:byte_col].decode(errors="ignore"))
        return SpecError(f"{self.where}: {message} at {self.position(line, col)}")

    @property
    def lines(self) -> list[str]:
        """`body` split the way the tokenizer counts lines."""
        return re.split(r"\r\n|\r|\n", self.body)

    def position(self, line: int, col: int) -> str:
        """'column C' or 'line L, column C' in the original text (1-based, characters)."""
        if line == 1:
            col += self.col_shift
        line += self.line_shift
        return f"column {col + 1}" if line == 1 else f"line {line}, column {col + 1}"

    def token(self, node: ast.AST) -> str:
        """The source text of `node`, shortened for messages."""
        segment = ast.get_source_segment(self.body, node) or type(node).__name__
        return segment if len(segment) <= 40 else segment[:37] + "..."

    def operator(self, node: ast.BinOp) -> ast.AST:
        """A stand-in node located at the operator of `node` (ast does not record it)."""
        line, byte_col = node.left.end_lineno or 1, node.left.end_col_offset or 0
        rest = self.lines[line - 1].encode()[byte_col:].decode(errors="ignore")
        skip = len(rest) - len(rest.lstrip(" \t)"))
        marker = ast.Constant(value=None)
        marker.lineno = line
        marker.col_offset = byte_col + len(rest[:skip].encode())
        return marker


def _check_characters(text: str, where: str) -> None:
    """Refuse what Python's tokenizer would read differently from the language: '#' (a
    comment that silently drops the rest of the line), characters outside printable ASCII
    (identifiers are NFKC-normalized, so a full-width 'ｍ' would read as 'm') and numbers too
    long to be a double (Python refuses to convert more than 4300 digits)."""
    bad = next((k for k, ch in enumerate(text) if ch == "#" or ch not in _ALLOWED), None)
    if bad is not None:
        ch = text[bad]
        if ch == "#":
            why = "'#' is not allowed (expressions have no comments; it would end the expression)"
        else:
            why = f"character {ch!r} (U+{ord(ch):04X}) is not allowed (expressions are ASCII)"
        raise SpecError(f"{where}: {why} at {_text_position(text, bad)}")
    long = _LONG_DIGITS.search(text)
    if long is not None:
        raise SpecError(
            f"{where}: number {long.group()[:12] + '...'!r} has more than the limit of "
            f"{_MAX_LITERAL_DIGITS} digits (a double is at most about 1.8e308) at "
            f"{_text_position(text, long.start())}"
        )


def _text_position(text: str, index: int) -> str:
    """'column C' or 'line L, column C' (1-based) of `text[index]`, lines split as ast does."""
    lines = re.split(r"\r\n|\r|\n", text[:index])
    line, col = len(lines), len(lines[-1])
    return f"column {col + 1}" if line == 1 else f"line {line}, column {col + 1}"
