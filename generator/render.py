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
from pathlib import Path

import jinja2

from s2gen.build import cache_dir
from s2gen.derivations import enabled, entry_path, read_payload, write_payload
from s2gen.printing import PrintedModule

__all__ = ["TEMPLATES", "TemplateCache", "environment", "render"]

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


class TemplateCache(jinja2.BytecodeCache):
    """Compiled templates kept on disk beside the derivations (`s2gen.derivations`: entries
    with a checksum, written atomically, under the cache folder of the moment), so that a
    process does not compile the templates again; jinja2 checks each entry against its
    template's source and its own version, and compiles again when they differ."""

    def _path(self, bucket: jinja2.bccache.Bucket) -> Path:
        return entry_path(cache_dir(), "templates", bucket.key)

    def load_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        payload = read_payload(self._path(bucket)) if enabled() else None
        if payload is not None:
            bucket.bytecode_from_string(payload)

    def dump_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        if enabled():
            write_payload(self._path(bucket), bucket.bytecode_to_string())


@functools.lru_cache(maxsize=1)
def environment() -> jinja2.Environment:
    """The cached Environment: StrictUndefined, trim/lstrip blocks, trailing newline kept;
    compiled templates kept on disk (`TemplateCache`)."""
    root = resources.files("s2gen.templates")
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(root)),
        bytecode_cache=TemplateCache(),
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
