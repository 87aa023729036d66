"""Helpers shared by the reliability tests (bad-input catalog, literals, fuzzing)."""

from __future__ import annotations

import subprocess
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from s2gen.build import STRICT_FLAGS, compiler
from s2gen.system import System


def compile_strictly(files: dict[str, str], folder: Path) -> None:
    """Compile every emitted .c file with the strict flags (fails the test with gcc's output)."""
    cc, _ = compiler()
    for name, text in files.items():
        (folder / name).write_text(text)
    for name in sorted(n for n in files if n.endswith(".c")):
        proc = subprocess.run(
            [cc, *STRICT_FLAGS, "-c", name, "-o", f"{name}.o"],
            cwd=folder,
            capture_output=True,
            text=True,
            check=False,
        )
        if proc.returncode != 0:
            pytest.fail(f"{name} does not compile with {' '.join(STRICT_FLAGS)}:\n{proc.stderr}")


def random_state(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """n random unit vectors q and tangent velocities omega (one per row)."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = rng.normal(size=(n, 3))
    w -= np.einsum("ij,ij->i", w, q)[:, None] * q
    return q, w


def one_line_error(call: Callable[[], object], kind: type[Exception]) -> str:
    """Run `call`, which must raise `kind`; return its message after checking it is one line."""
    with pytest.raises(kind) as info:
        call()
    message = str(info.value)
    assert "\n" not in message and message.strip() == message, repr(message)
    assert "Traceback" not in message
    return message


def gradients(system: System, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The C backend's and the reference's gradient of V at q (the spec's parameters)."""
    from s2gen.runtime import get_backend

    p = np.array(system.parameter_values, dtype=float)
    c = get_backend(system, "c").gradient(q, p)
    ref = get_backend(system, "reference").gradient(q, p)
    return np.asarray(c), np.asarray(ref)
