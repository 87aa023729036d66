"""Emit generated files for a system: derive, lower, print and render, once per system.

Input: a `System` and a language ("c" or "numpy"). Output: {file name: text}, byte-reproducible
(the same spec always gives the same bytes), and optionally written to a folder.

Example:
    >>> from s2gen.systems import builtin
    >>> sorted(emit(builtin("double_pendulum"), "c"))
    ['double_pendulum.c', 'double_pendulum.h']
"""

from __future__ import annotations

import functools
from pathlib import Path

from s2gen.passes import lower_system
from s2gen.printing import PrintedModule, print_module
from s2gen.render import render
from s2gen.system import System

__all__ = ["LANGUAGES", "emit", "printed", "write_files"]

LANGUAGES = ("c", "numpy")


@functools.lru_cache(maxsize=32)
def _printed_cached(system: System) -> PrintedModule:
    return print_module(lower_system(system))


def printed(system: System) -> PrintedModule:
    """The printed module of a system (derived once per distinct system, then cached)."""
    return _printed_cached(system)


def emit(system: System, lang: str) -> dict[str, str]:
    """All files of one language for a system."""
    return render(printed(system), lang)


def write_files(files: dict[str, str], out_dir: str | Path) -> list[Path]:
    """Write files into out_dir (created if needed); returns the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in sorted(files):
        path = out / name
        path.write_text(files[name])
        paths.append(path)
    return paths
