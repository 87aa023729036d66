"""Render printed modules into files with one strict jinja2 environment.

Input: a `PrintedModule` (strings, numbers, tuples, small dicts). Output: {file name: text}.
Each kind of module has one top-level template per file; they lay out the partial templates
Python chose (`m.c_parts`, `m.py_parts`: the algorithm variants, in order). Templates only lay
text out; every decision arrives as a value. Output is byte-reproducible: no dates, hosts or
versions, only the spec hash.

Example:
    >>> sorted(TEMPLATES["sphere"])
    ['c', 'numpy']
"""

from __future__ import annotations

import functools
from importlib import resources

import jinja2

from s2gen.printing import PrintedModule

__all__ = ["TEMPLATES", "environment", "render"]

#: Files emitted per module kind and language: (template, output name pattern).
TEMPLATES: dict[str, dict[str, tuple[tuple[str, str], ...]]] = {
    "sphere": {
        "c": (("c/sphere.h.jinja", "{name}.h"), ("c/module.c.jinja", "{name}.c")),
        "numpy": (("numpy/module.py.jinja", "{name}.py"),),
    },
    "angles": {
        "c": (("c/angles.h.jinja", "{name}.h"), ("c/module.c.jinja", "{name}.c")),
        "numpy": (("numpy/module.py.jinja", "{name}.py"),),
    },
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
    files = TEMPLATES[module.kind]
    if lang not in files:
        raise ValueError(f"unknown language {lang!r}; choose one of {sorted(files)}")
    env = environment()
    return {
        pattern.format(name=module.name): env.get_template(template).render(m=module)
        for template, pattern in files[lang]
    }
