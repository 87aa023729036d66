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

import contextlib
import functools
import hashlib
import json
import logging
import os
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

from s2gen.build import cache_dir
from s2gen.methods import LANGUAGES
from s2gen.system import SpecWarning, System
from s2gen.version import fingerprint

if TYPE_CHECKING:
    from s2gen.printing import PrintedModule

__all__ = [
    "GENERATED",
    "LANGUAGES",
    "clear_caches",
    "emit",
    "emit_angles",
    "emit_key",
    "initial_key",
    "printed",
    "regenerate",
    "write_files",
]

log = logging.getLogger("s2gen.emit")

_MANIFEST = "manifest.json"


@functools.lru_cache(maxsize=32)
def _printed_cached(system: System, initial: str) -> PrintedModule:
    from s2gen.passes import lower_system
    from s2gen.printing import print_module

    return print_module(lower_system(system))


def initial_key(system: System) -> str:
    """A digest of the spec's initial state, which the emitted modules carry but the spec
    digest leaves out (so that the same system from other states shares its spec hash): a key
    of the caches of emitted code beside that digest.

    Example:
        >>> from s2gen.systems import builtin
        >>> len(initial_key(builtin("double_pendulum")))
        16
    """
    h = hashlib.sha256()
    for a in (system.q0, system.omega0):
        h.update(b"-" if a is None else a.astype("<f8").tobytes())
    return h.hexdigest()[:16]


@functools.lru_cache(maxsize=16)
def _printed_angles(system: System, simplify: bool) -> PrintedModule:
    from s2gen.equations.angles import derive_angles
    from s2gen.passes import lower_angles
    from s2gen.printing import print_module

    return print_module(lower_angles(derive_angles(system, simplify)))


def printed(system: System) -> PrintedModule:
    """The printed module of a system (derived once per distinct system, then cached)."""
    return _printed_cached(system, initial_key(system))


def clear_caches() -> None:
    """Forget every in-process derivation (printed modules, generic kernels, SymPy's cache),
    so that the next `emit(..., cache=False)` measures a derivation from scratch."""
    from sympy.core.cache import clear_cache

    from s2gen.passes import clear_caches as clear_lowered

    clear_cache()
    _printed_cached.cache_clear()
    _printed_angles.cache_clear()
    clear_lowered()


def emit_key(system: System, lang: str, form: str = "sphere") -> str:
    """The cache key of a system's emitted files in one language and form."""
    initial = initial_key(system) if form == "sphere" else ""  # only that module carries it
    text = f"{system.spec_digest()}\0{initial}\0{lang}\0{form}\0{fingerprint()}"
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _emit(system: System, lang: str, form: str, cache: bool) -> dict[str, str]:
    if lang not in LANGUAGES:
        raise ValueError(f"unknown language {lang!r}; choose one of {', '.join(LANGUAGES)}")
    if system.driven and form != "sphere":
        system.refuse_driven(f"emitting {lang} code ({form} form)")
    folder = cache_dir() / "emitted" / emit_key(system, lang, form)
    files = _read_cached(folder) if cache else None
    if files is not None:
        log.info("reused emitted %s (%s, %s)", system.name, form, lang)
        return files
    from s2gen.derivations import uncached
    from s2gen.render import render

    _warn_if_unstructured(system)
    with contextlib.nullcontext() if cache else uncached():
        if form == "sphere":
            module = printed(system)
        else:
            module = _printed_angles(system, form == "angles-simplified")
        files = render(module, lang)
    if cache:
        _write_cached(folder, files)
    return files


def _warn_if_unstructured(system: System) -> None:
    """Before a derivation: warn (SpecWarning) when the general potential is a long sum of
    one-body or pair terms that a structured term would derive once (`s2gen.spec.hints`)."""
    from s2gen.spec.hints import structure_hint

    hint = structure_hint(system.potential, system.n)
    if hint is not None:
        warnings.warn(f"{system.origin}: {hint}", SpecWarning, stacklevel=4)


def emit(system: System, lang: str, cache: bool = True) -> dict[str, str]:
    """All files of one language for a system's (S^2)^n module; with `cache`, read from and
    written to the disk cache of emitted files and of derivations (`s2gen.derivations`);
    without it, derived again (apart from what this process keeps)."""
    return _emit(system, lang, "sphere", cache)


def emit_angles(
    system: System, lang: str, simplify: bool = False, cache: bool = True
) -> dict[str, str]:
    """All files of one language for a system's angle-form module (file stem
    ``<system>_angles``), derived with `sympy.simplify` on every entry when `simplify`.

    Example:
        >>> from s2gen.systems import builtin
        >>> sorted(emit_angles(builtin("double_pendulum"), "c"))
        ['double_pendulum_angles.c', 'double_pendulum_angles.h']
    """
    return _emit(system, lang, "angles-simplified" if simplify else "angles", cache)


#: Modules kept in the repository's generated/ folder, one of each kind (folder, built-in,
#: form): coupled inertia (dense solves), diagonal inertia with term loops and a quadratic
#: term, a cutoff term, a chain with max-index inertia (structured O(n) solves) and an
#: angle-form module.
GENERATED = (
    ("double_pendulum", "double_pendulum", "sphere"),
    ("rope", "rope", "sphere"),
    ("four_pendula", "four_pendula", "sphere"),
    ("lj_cutoff", "lj_cutoff", "sphere"),
    ("double_pendulum_angles", "double_pendulum", "angles"),
)


def regenerate(out: str | Path) -> list[Path]:
    """Write the C and NumPy code of `GENERATED` under out/<folder>/<lang>/."""
    from s2gen.systems import builtin

    paths: list[Path] = []
    for folder, name, form in GENERATED:
        system = builtin(name)
        for lang in LANGUAGES:
            files = emit(system, lang) if form == "sphere" else emit_angles(system, lang)
            paths += write_files(files, Path(out) / folder / lang)
    return paths


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
