"""The build cache heals (issue 8, item 7).

Before the fix a cached library was loaded without any check: truncated to half it crashed
every later run with SIGBUS, its code overwritten with SIGILL, truncated to 0 it raised an
OSError traceback, until someone deleted it by hand. Now each library has its sha256 beside it;
a mismatch (or a missing checksum, or a library the loader refuses) is logged and rebuilt.
Damaged libraries are loaded only in child processes, so that a crash fails a test instead of
killing the test run.
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from s2gen.build import checksum_path, compile_shared, load_library


def _truncate_half(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _overwrite_code(path: Path) -> None:
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle - 256 : middle + 256] = b"\xff" * 512
    path.write_bytes(bytes(data))


def _truncate_empty(path: Path) -> None:
    path.write_bytes(b"")


def _drop_checksum(path: Path) -> None:
    checksum_path(path).unlink()


def _garbage_checksum(path: Path) -> None:
    checksum_path(path).write_text("0" * 64 + "\n")


DAMAGE: dict[str, Callable[[Path], None]] = {
    "truncated to half": _truncate_half,
    "code overwritten": _overwrite_code,
    "truncated to 0": _truncate_empty,
    "checksum missing": _drop_checksum,
    "checksum wrong": _garbage_checksum,
}


def _source(tag: str) -> dict[str, str]:
    """A small library, unique per tag (so its cache entry is the test's own)."""
    body = " + ".join(f"x * {k}.0" for k in range(200))  # some code to damage
    return {f"lib_{tag}.c": f"double f_{tag}(double x) {{ return {body}; }}\n"}


def _call_in_child(path: Path, tag: str) -> subprocess.CompletedProcess[str]:
    code = (
        "import ctypes, sys\n"
        f"lib = ctypes.CDLL({str(path)!r})\n"
        f"f = lib.f_{tag}\n"
        "f.restype = ctypes.c_double\n"
        "f.argtypes = [ctypes.c_double]\n"
        "print(f(1.0))\n"
    )
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )


@pytest.fixture
def private_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("S2GEN_CACHE", str(tmp_path))
    return tmp_path


@pytest.mark.parametrize("damage", sorted(DAMAGE))
def test_a_damaged_cached_library_is_rebuilt(
    damage: str, private_cache: Path, caplog: pytest.LogCaptureFixture
) -> None:
    tag = damage.replace(" ", "_")
    sources = _source(tag)
    first = compile_shared(sources)
    assert not first.reused
    digest = hashlib.sha256(first.path.read_bytes()).hexdigest()
    assert checksum_path(first.path).read_text().strip() == digest
    assert compile_shared(sources).reused

    DAMAGE[damage](first.path)
    with caplog.at_level(logging.WARNING, logger="s2gen.build"):
        again = compile_shared(sources)
    assert not again.reused and again.path == first.path
    assert "does not match its sha256" in caplog.text and first.path.name in caplog.text
    assert hashlib.sha256(again.path.read_bytes()).hexdigest() == digest
    assert checksum_path(again.path).read_text().strip() == digest
    proc = _call_in_child(again.path, tag)
    assert proc.returncode == 0, (proc.returncode, proc.stderr)
    assert float(proc.stdout) == sum(range(200))


def test_a_library_the_loader_refuses_is_rebuilt_once(
    private_cache: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Damage the checksum agrees with (written by something else) still fails to load:
    load_library rebuilds it."""
    sources = _source("unloadable")
    built = compile_shared(sources)
    built.path.write_bytes(b"not a shared object")
    checksum_path(built.path).write_text(hashlib.sha256(b"not a shared object").hexdigest())
    with caplog.at_level(logging.WARNING, logger="s2gen.build"):
        lib, build = load_library(sources)
    assert "does not load" in caplog.text and not build.reused
    f = lib.f_unloadable
    f.restype = ctypes.c_double
    f.argtypes = [ctypes.c_double]
    assert f(2.0) == 2.0 * sum(range(200))


def test_simulate_survives_a_damaged_cached_library(tmp_path: Path) -> None:
    """The issue's scenario end to end: every later run of the system crashed. Each run is a
    fresh process on the same private cache; after each kind of damage the next run must
    give the first run's numbers."""
    env = {**os.environ, "S2GEN_CACHE": str(tmp_path)}
    code = (
        "import s2gen\n"
        "from s2gen.runtime.c import CBackend\n"
        "s = s2gen.load('three_bodies')\n"
        "print(CBackend(s).build.path)\n"
        "tr = s2gen.simulate(s, 'vi', 'c', h=0.01, T=0.5)\n"
        "print(repr(float(tr.energy[-1])), repr(float(tr.q[-1, 0, 0])))\n"
    )

    def run() -> list[str]:
        proc = subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
            env=env,
        )
        assert proc.returncode == 0, (proc.returncode, proc.stderr[-2000:])
        return proc.stdout.splitlines()

    path, numbers = run()
    for damage in ("truncated to half", "code overwritten", "truncated to 0"):
        DAMAGE[damage](Path(path))
        assert run() == [path, numbers], damage
