"""Render printed modules into files with one strict jinja2 environment.

Input: a `PrintedModule` (strings, numbers, tuples only). Output: {relative path: text}. The
templates in `templates/c/` and `templates/numpy/` only lay text out; every decision arrives as
a value. Output is byte-reproducible: no dates, hosts or versions, only the spec hash.

Example:
    >>> sorted(TEMPLATES)
    ['c', 'numpy']
"""

from __future__ import annotations

import functools
from importlib import resources
from typing import Any

import jinja2

from s2gen.printing import PrintedModule

__all__ = ["ANGLE_TEMPLATES", "TEMPLATES", "environment", "render", "render_angles"]

#: Files emitted per language: (template, output name pattern).
TEMPLATES: dict[str, tuple[tuple[str, str], ...]] = {
    "c": (("c/system.h.jinja", "{name}.h"), ("c/system.c.jinja", "{name}.c")),
    "numpy": (("numpy/system.py.jinja", "{name}.py"),),
}


@functools.lru_cache(maxsize=1)
def environment() -> jinja2.Environment:
    """The cached Environment: StrictUndefined, trim/lstrip blocks, trailing newline kept."""
    root = resources.files("s2gen.templates")
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(root)),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )


def render(module: PrintedModule, lang: str) -> dict[str, str]:
    """Render every file of one language; keys are file names, values their text."""
    if lang not in TEMPLATES:
        raise ValueError(f"unknown language {lang!r}; choose one of {sorted(TEMPLATES)}")
    env = environment()
    return {
        pattern.format(name=module.name): env.get_template(template).render(m=module)
        for template, pattern in TEMPLATES[lang]
    }


#: Files of the angle-form comparison module (`angles.py`) per language.
ANGLE_TEMPLATES: dict[str, tuple[tuple[str, str], ...]] = {
    "c": (("c/angles.h.jinja", "{name}.h"), ("c/angles.c.jinja", "{name}.c")),
    "numpy": (("numpy/angles.py.jinja", "{name}.py"),),
}


def render_angles(module: Any, lang: str) -> dict[str, str]:
    """Render an `angles.PrintedAngles` for one language; keys are file names."""
    if lang not in ANGLE_TEMPLATES:
        raise ValueError(f"unknown language {lang!r}; choose one of {sorted(ANGLE_TEMPLATES)}")
    env = environment()
    return {
        pattern.format(name=module.name): env.get_template(template).render(m=module)
        for template, pattern in ANGLE_TEMPLATES[lang]
    }
