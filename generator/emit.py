"""Emit generated files for a system: derive, lower, print and render, once per system.

Input: a `System` and a language ("c" or "numpy"). Output: {file name: text}, byte-reproducible
(the same spec always gives the same bytes), and optionally written to a folder.

Emitted files are cached on disk (under the build cache folder, `emitted/`) by the spec's
digest, the language and the generator's fingerprint (`s2gen.version.fingerprint`), each file
with its sha256 in a manifest: a later process that emits the same system reads them back
without any SymPy work, and a damaged entry is derived again and rewritten.

Example:
    >>> from s2gen.systems import builtin
    >>> sorted(emit(builtin("double_pendulum"), "c"))
    ['double_pendulum.c', 'double_pendulum.h']
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import shutil
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from s2gen.build import cache_dir
from s2gen.methods import LANGUAGES
from s2gen.system import System
from s2gen.version import fingerprint

if TYPE_CHECKING:
    from s2gen.printing import PrintedModule

__all__ = ["LANGUAGES", "clear_caches", "emit", "emit_key", "printed", "write_files"]

log = logging.getLogger("s2gen.emit")

_MANIFEST = "manifest.json"


@functools.lru_cache(maxsize=32)
def _printed_cached(system: System) -> PrintedModule:
    from s2gen.passes import lower_system
    from s2gen.printing import print_module

    return print_module(lower_system(system))


def printed(system: System) -> PrintedModule:
    """The printed module of a system (derived once per distinct system, then cached)."""
    return _printed_cached(system)


def clear_caches() -> None:
    """Forget every in-process derivation (printed modules, generic kernels, SymPy's cache),
    so that the next `emit(..., cache=False)` measures a derivation from scratch."""
    from sympy.core.cache import clear_cache

    from s2gen.passes import generic_kernels

    clear_cache()
    _printed_cached.cache_clear()
    generic_kernels.cache_clear()


def emit_key(system: System, lang: str) -> str:
    """The cache key of a system's emitted files in one language."""
    text = f"{system.spec_digest()}\0{lang}\0{fingerprint()}"
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def emit(system: System, lang: str, cache: bool = True) -> dict[str, str]:
    """All files of one language for a system; with `cache`, read from and written to the
    disk cache of emitted files."""
    if lang not in LANGUAGES:
        raise ValueError(f"unknown language {lang!r}; choose one of {', '.join(LANGUAGES)}")
    folder = cache_dir() / "emitted" / emit_key(system, lang)
    files = _read_cached(folder) if cache else None
    if files is not None:
        log.info("reused emitted %s (%s)", system.name, lang)
        return files
    from s2gen.render import render

    files = render(printed(system), lang)
    if cache:
        _write_cached(folder, files)
    return files


def _sha(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def _read_cached(folder: Path) -> dict[str, str] | None:
    """The files of a cache entry if its manifest and every checksum agree, else None."""
    try:
        manifest = json.loads((folder / _MANIFEST).read_text())
        files = {name: (folder / name).read_text() for name in manifest}
    except (OSError, ValueError, TypeError):
        return None
    if not files or any(_sha(files[name]) != digest for name, digest in manifest.items()):
        log.warning("emitted-file cache entry %s is damaged; deriving again", folder.name)
        return None
    return files


def _write_cached(folder: Path, files: dict[str, str]) -> None:
    """Write a cache entry atomically (a private folder renamed into place); best effort."""
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=folder.parent, prefix=".tmp-"))
    except OSError as exc:  # a read-only cache: emitting still works, nothing is kept
        log.info("emitted files not cached (%s)", exc)
        return
    try:
        for name, text in files.items():
            (tmp / name).write_text(text)
        (tmp / _MANIFEST).write_text(json.dumps({n: _sha(t) for n, t in sorted(files.items())}))
        if folder.exists():  # a damaged entry (a sound one is never rewritten)
            shutil.rmtree(folder, ignore_errors=True)
        os.replace(tmp, folder)
    except OSError as exc:  # another process won the race: its entry is as good as ours
        log.info("emitted files not cached (%s)", exc)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_files(files: dict[str, str], out_dir: str | Path) -> list[Path]:
    """Write files into out_dir (created if needed); returns the paths written. Every target
    is checked before any is written, and each is written atomically; a symbolic link at a
    target is refused, never followed (`s2gen.paths.OutputPathError`)."""
    from s2gen.paths import check_output_file, write_text_atomic

    out = Path(out_dir)
    targets = [check_output_file(out / name) for name in sorted(files)]
    return [write_text_atomic(path, files[path.name]) for path in targets]
