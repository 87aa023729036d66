"""Reading the documentation's reStructuredText pages from the tests: a page's text, a section
of it, its code blocks and its list tables, so that a test can run or check what a page shows
as it stands (the pages under docs/ hold what the README held before it became a front page)."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

_UNDERLINE = re.compile(r"^([=\-~^\"'`#*+<>])\1{3,}$")


def page(name: str) -> str:
    """The text of docs/NAME (e.g. "user_guide/cli.rst")."""
    return (DOCS / name).read_text(encoding="utf-8")


def section(text: str, title: str) -> str:
    """The section of a page headed `title`, up to the next heading of the same or a higher
    level (its subsections included)."""
    lines = text.splitlines()
    levels: list[str] = []
    start = level = None
    for k in range(len(lines) - 1):
        underline = _UNDERLINE.match(lines[k + 1])
        if not (underline and lines[k].strip() and len(lines[k + 1]) >= len(lines[k].rstrip())):
            continue
        char = underline.group(1)
        if char not in levels:
            levels.append(char)
        depth = levels.index(char)
        if start is None and lines[k].strip() == title:
            start, level = k, depth
        elif start is not None and level is not None and depth <= level:
            return "\n".join(lines[start:k]) + "\n"
    if start is None:
        raise KeyError(f"no section {title!r}")
    return "\n".join(lines[start:]) + "\n"


def code_blocks(text: str, language: str) -> list[str]:
    """The contents of every ``.. code-block:: language`` of `text`, dedented, in order."""
    lines = text.splitlines()
    blocks = []
    for k, line in enumerate(lines):
        if line.strip() != f".. code-block:: {language}":
            continue
        indent = len(line) - len(line.lstrip())
        body: list[str] = []
        for later in lines[k + 1 :]:
            if later.strip() and len(later) - len(later.lstrip()) <= indent:
                break
            body.append(later)
        while body and not body[0].strip():
            body.pop(0)
        while body and not body[-1].strip():
            body.pop()
        blocks.append(textwrap.dedent("\n".join(body)) + "\n")
    return blocks


def list_table_rows(text: str) -> list[list[str]]:
    """The rows of every ``.. list-table::`` of `text`, each a list of its cells (a cell's
    continuation lines joined by spaces), header rows included."""
    rows: list[list[str]] = []
    inside = False
    for line in text.splitlines():
        if line.startswith(".. list-table::"):
            inside = True
            continue
        if inside and line.strip() and not line.startswith(" "):
            inside = False
        if not inside:
            continue
        row = re.match(r"^   \* - ?(.*)$", line)
        cell = re.match(r"^     - ?(.*)$", line)
        if row:
            rows.append([row.group(1)])
        elif cell and rows:
            rows[-1].append(cell.group(1))
        elif rows and line.startswith("       ") and line.strip():
            rows[-1][-1] += " " + line.strip()
    return rows
