"""Compile emitted C into a shared library, cached by content, and load it with ctypes.

Input: emitted C files ({name: text}). Output: a loaded `ctypes.CDLL` whose functions have
declared argument types. The cache key is the sha256 of the sources, the compiler's identity
(path and `--version`), the flags and the generator version; the library is compiled in a
private temporary folder and moved into place with `os.replace`, so concurrent builds of the
same key never expose a partial file. The cache folder is `$S2GEN_CACHE`, else
`~/.cache/s2gen`. Each build is logged (logger "s2gen.build") as built or reused, with timings.

A cached library is trusted only if it matches the sha256 stored beside it (`<lib>.sha256`,
written after the library, both moved into place atomically): a truncated or overwritten
library (which would be mapped and crash with SIGBUS or SIGILL) or a missing checksum is
logged and rebuilt, and `load_library` also rebuilds once a cached library the dynamic loader
refuses.

Example:
    >>> key = cache_key({"a.c": "int f(void) { return 1; }"}, ("-O2",))
    >>> len(key)
    64
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from s2gen.version import __version__

__all__ = [
    "DEFAULT_FLAGS",
    "FLAG_SETS",
    "STRICT_FLAGS",
    "BuildError",
    "BuildResult",
    "build_flags",
    "cache_dir",
    "cache_key",
    "compile_shared",
    "compiler",
    "load_library",
]

log = logging.getLogger("s2gen.build")

GENERATOR_VERSION = __version__
#: Flags of the cached shared library, chosen by `python -m s2gen.experiments.flags`
#: (docs/user_guide/c_code.rst, "Build flags"): -O2 with the emitted loops' SIMD hints
#: honoured (-fopenmp-simd) and sqrt as one instruction (-fno-math-errno: no errno on a
#: negative argument, which the emitted code checks itself) ran the VI 0.6-0.8x as long as
#: plain -O2 on three of the four built-ins; -O3 compiled 1.7x as long for little more.
#: -std=c99 (ISO mode) keeps gcc from contracting a*b+c into fused multiply-adds, so results
#: match NumPy's operation order closely.
DEFAULT_FLAGS: tuple[str, ...] = (
    "-std=c99",
    "-O2",
    "-fno-math-errno",
    "-fopenmp-simd",
    "-fPIC",
    "-shared",
)
#: Flag sets the runtime builds with, by name (S2GEN_OPT selects one; see `build_flags`):
#: "portable" runs on any x86-64 (or other) machine the library is copied to, "native" uses
#: every instruction set of this machine's processor (the library may not run elsewhere).
#: -fno-math-errno lets sqrt be one instruction (no errno on negative input: the emitted code
#: checks its inputs itself); -fopenmp-simd honours the emitted loops' SIMD hints.
#: -fno-tree-slp-vectorize: with -march=native on a processor with FMA, gcc 12's basic-block
#: (SLP) vectoriser fuses a*b+c into vfmadd/vfmaddsub/vfmsubadd although -std=c99 (and even
#: -ffp-contract=off) forbids contraction: every built-in's one-member code held 3-13 of them
#: (the double pendulum's vi_advance, rhs_cx, angular_momentum), so its results depended on
#: how the vectoriser grouped statements and integrate_batch()'s lane loops could not match
#: integrate() bit for bit. Its cost is within noise: `python -m s2gen.experiments.flags
#: --launches 7` (AMD EPYC, load 1.3-1.9) gave per VI step double pendulum 0.882 -> 0.888 us,
#: rod 6.10 -> 6.15 us, dipoles 0.353 -> 0.335 us, molecular 102 -> 100 us without it; the
#: loop vectoriser, which keeps the operation order, still runs.
FLAG_SETS: dict[str, tuple[str, ...]] = {
    "portable": DEFAULT_FLAGS,
    "native": (
        "-std=c99",
        "-O3",
        "-march=native",
        "-fno-tree-slp-vectorize",
        "-fno-math-errno",
        "-fopenmp-simd",
        "-fPIC",
        "-shared",
    ),
}


def build_flags(name: str | None = None) -> tuple[str, ...]:
    """The flags of flag set `name` (default: the environment's S2GEN_OPT, else "portable")."""
    name = name or os.environ.get("S2GEN_OPT", "portable")
    if name not in FLAG_SETS:
        raise ValueError(f"S2GEN_OPT={name!r}: choose one of {', '.join(FLAG_SETS)}")
    return FLAG_SETS[name]


#: Flags every emitted file must pass (tests use them).
STRICT_FLAGS: tuple[str, ...] = ("-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror")


class BuildError(RuntimeError):
    """gcc failed; the message holds its output."""


@dataclass(frozen=True)
class BuildResult:
    """Where the library is, whether it came from the cache, and how long it took."""

    path: Path
    reused: bool
    seconds: float


@functools.lru_cache(maxsize=1)
def compiler() -> tuple[str, str]:
    """(path, first line of --version) of the C compiler ($CC, else gcc)."""
    cc = os.environ.get("CC", "gcc")
    path = shutil.which(cc)
    if path is None:
        raise BuildError(f"C compiler {cc!r} not found on PATH (set $CC)")
    out = subprocess.run([path, "--version"], capture_output=True, text=True, check=False)
    return path, (out.stdout.splitlines() or ["unknown"])[0]


def cache_dir() -> Path:
    """The build cache folder ($S2GEN_CACHE or ~/.cache/s2gen), created if needed."""
    root = Path(os.environ.get("S2GEN_CACHE", Path.home() / ".cache" / "s2gen"))
    root.mkdir(parents=True, exist_ok=True)
    return root


def cache_key(sources: dict[str, str], flags: tuple[str, ...]) -> str:
    """sha256 over sources (sorted by name), compiler identity, flags and generator version."""
    h = hashlib.sha256()
    for name in sorted(sources):
        h.update(name.encode() + b"\0" + sources[name].encode() + b"\0")
    cc_path, cc_version = compiler() if shutil.which(os.environ.get("CC", "gcc")) else ("", "")
    h.update(f"{cc_path}\0{cc_version}\0{' '.join(flags)}\0{GENERATOR_VERSION}".encode())
    return h.hexdigest()


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def checksum_path(library: Path) -> Path:
    """Where the sha256 of a cached library is kept (beside it)."""
    return library.with_name(library.name + ".sha256")


def _intact(library: Path) -> bool:
    """True if `library` exists and matches the checksum stored beside it."""
    try:
        expected = checksum_path(library).read_text().strip()
        return len(expected) == 64 and _sha256(library) == expected
    except OSError:
        return False


def compile_shared(
    sources: dict[str, str], flags: tuple[str, ...] = DEFAULT_FLAGS, rebuild: bool = False
) -> BuildResult:
    """Compile the .c files among `sources` (headers alongside) into a cached shared library;
    a cached one is reused only if it matches its stored sha256 (and `rebuild` is False)."""
    start = time.perf_counter()
    key = cache_key(sources, flags)
    target = cache_dir() / f"s2gen-{key[:32]}.so"
    if target.exists() and not rebuild:
        if _intact(target):
            secs = time.perf_counter() - start
            log.info("reused %s (%.3f s)", target.name, secs)
            return BuildResult(target, True, secs)
        log.warning(
            "cached library %s does not match its sha256 (damaged, or no checksum); rebuilding",
            target.name,
        )
    cc, _ = compiler()
    with tempfile.TemporaryDirectory(dir=cache_dir(), prefix="build-") as tmp:
        tmpdir = Path(tmp)
        for name, text in sources.items():
            (tmpdir / name).write_text(text)
        c_files = [str(tmpdir / n) for n in sorted(sources) if n.endswith(".c")]
        out = tmpdir / "lib.so"
        proc = subprocess.run(
            [cc, *flags, "-o", str(out), *c_files, "-lm"],
            capture_output=True,
            text=True,
            check=False,
        )
        if proc.returncode != 0:
            raise BuildError(f"gcc failed ({' '.join(flags)}):\n{proc.stderr}")
        digest = tmpdir / "lib.so.sha256"
        digest.write_text(_sha256(out) + "\n")
        os.replace(out, target)
        os.replace(digest, checksum_path(target))
    secs = time.perf_counter() - start
    log.info("built %s (%.3f s)", target.name, secs)
    return BuildResult(target, False, secs)


def load_library(
    sources: dict[str, str], flags: tuple[str, ...] = DEFAULT_FLAGS
) -> tuple[ctypes.CDLL, BuildResult]:
    """The library of `sources` built (or reused from the cache) and loaded with ctypes; a
    cached library the dynamic loader refuses is rebuilt once (logged).

    Example:
        >>> lib, build = load_library({"one.c": "int one(void) { return 1; }"})
        >>> lib.one()
        1
    """
    build = compile_shared(sources, flags)
    try:
        return ctypes.CDLL(str(build.path)), build
    except OSError as exc:
        if not build.reused:
            raise BuildError(f"cannot load the library just built, {build.path}: {exc}") from None
        log.warning("cached library %s does not load (%s); rebuilding", build.path.name, exc)
    build = compile_shared(sources, flags, rebuild=True)
    try:
        return ctypes.CDLL(str(build.path)), build
    except OSError as exc:
        raise BuildError(f"cannot load the library just built, {build.path}: {exc}") from None


def header_macro(header: str, prefix: str, suffix: str) -> int:
    """The integer value of the macro `<PREFIX>_<suffix>` in the emitted header of module
    `prefix` (the whole name: a module called `x_batch` defines X_BATCH_WORK_SIZE, which is
    its WORK_SIZE, not a BATCH_WORK_SIZE).

    Example:
        >>> header_macro("#define DP_WORK_SIZE 120\\n", "dp", "WORK_SIZE")
        120
        >>> header_macro("#define X_BATCH_WORK_SIZE 9\\n", "x_batch", "WORK_SIZE")
        9
        >>> header_macro("#define X_BATCH_WORK_SIZE 9\\n", "x_batch", "BATCH_WORK_SIZE")
        Traceback (most recent call last):
        ...
        s2gen.build.BuildError: macro X_BATCH_BATCH_WORK_SIZE missing from the emitted header
    """
    name = f"{prefix.upper()}_{suffix}"
    for line in header.splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[0] == "#define" and parts[1] == name:
            return int(parts[2])
    raise BuildError(f"macro {name} missing from the emitted header")
