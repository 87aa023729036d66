"""Our docstrings as reStructuredText: a bar is an absolute value, never a substitution.

The package's docstrings write |x| for absolute values and norms (``max over bodies of
| |q_i| - 1 |``, ``|E - E_0|``) and use no reStructuredText substitutions, which docutils would
read ``|q_i|`` as (an undefined substitution, an error). This hook escapes the bars of prose
lines; code spans, doctest blocks and literal blocks are left as written.

A second hook, after napoleon, undoes napoleon's reading of a property's first line as
``type: description`` (Google style's inline attribute type, which our docstrings never use):
"M as a SymPy matrix (built from `chain` on first use: n^2 entries)" would become the type "M
as a SymPy matrix (built ... use" and the text "n^2 entries)". Such a property keeps its own
docstring, bars escaped.

A third hook, before napoleon, drops the docstring autodoc gives a module constant that has
none of its own: the docstring of its built-in type (``int([x]) -> integer``, a dict's
constructor forms, which are not even valid reStructuredText). What such a constant is, is
said in its ``autodata`` directive's body in api.rst.
"""

from __future__ import annotations

import inspect
import re
from typing import Any

_CODE_SPAN = re.compile(r"(``.*?``|`[^`]*`)")


def escape_bars(lines: list[str]) -> list[str]:
    """The docstring lines with prose bars escaped (in place and returned).

    Example:
        >>> escape_bars(["the error |E - E_0| of `a|b`", ">>> abs(-1) | 0", "1"])
        ['the error \\\\|E - E_0\\\\| of `a|b`', '>>> abs(-1) | 0', '1']
    """
    in_doctest = False
    literal_indent: int | None = None
    for k, line in enumerate(lines):
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None:
            if stripped and indent <= literal_indent:
                literal_indent = None
            else:
                continue
        if stripped.startswith(">>>"):
            in_doctest = True
        elif stripped == "":
            in_doctest = False
        if in_doctest:
            continue
        parts = _CODE_SPAN.split(line)
        lines[k] = "".join(p if i % 2 else p.replace("|", "\\|") for i, p in enumerate(parts))
        if stripped.endswith("::"):
            literal_indent = indent
    return lines


def is_type_docstring(lines: list[str], obj: Any) -> bool:
    """Whether `lines` are only the docstring of `obj`'s type (what autodoc finds for a
    constant without a docstring of its own).

    Example:
        >>> is_type_docstring(inspect.getdoc(int).splitlines(), 10**6)
        True
        >>> is_type_docstring(["Most members of one ensemble."], 10**6)
        False
    """
    inherited = inspect.getdoc(type(obj)) or ""
    text = "\n".join(lines).strip()
    return bool(text) and " ".join(text.split()) == " ".join(inherited.split())


def _type_docstring(
    app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]
) -> None:
    if what == "data" and is_type_docstring(lines, obj):
        lines[:] = []


def _bars(app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    escape_bars(lines)


def _property(app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    doc = inspect.getdoc(obj) if what == "property" else None
    if doc and ":" in doc.splitlines()[0]:
        lines[:] = escape_bars(doc.splitlines())


def setup(app: Any) -> dict[str, Any]:
    app.connect("autodoc-process-docstring", _type_docstring, priority=300)
    app.connect("autodoc-process-docstring", _bars, priority=400)  # napoleon's is 500
    app.connect("autodoc-process-docstring", _property, priority=600)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
