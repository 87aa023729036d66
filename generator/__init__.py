"""s2gen: equations, variational integrators and C/NumPy code for mechanics on (S^2)^n.

The public API, for scripts and notebooks (each name is imported on first use, so that
`import s2gen` is instant):

- `load(spec)`: a `System` from a TOML file, TOML text or a built-in name;
- `define(...)`: a `System` from Python values (same rules as TOML; see `s2gen.spec`);
- `generate(system, lang, out=None)`: the emitted files of a language ({name: text}), written
  to `out` when given;
- `compile(system, backend="c")`: a `Model` (integrate, step, energy, gradient, momentum,
  parameters by name);
- `simulate(system, method, backend, h, T, ..., params={"g": 1.62})`: a `Trajectory` (its
  angular momentum filled in, its spec and parameters kept; a run whose relative energy error
  passes `Options.energy_warn` warns with an `EnergyDriftWarning`);
- `METHODS` (the method table), `Options`, `Trajectory`, `IntegrationError`,
  `EnergyDriftWarning`, `SpecError`, `__version__`.

Example:
    >>> import s2gen
    >>> pendulum = s2gen.load("double_pendulum")
    >>> model = s2gen.compile(pendulum)
    >>> model.integrate("vi", h=0.01, T=1.0).energy.shape
    (101,)
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from s2gen.runtime.model import Model
    from s2gen.system import System

__all__ = [
    "METHODS",
    "EnergyDriftWarning",
    "IntegrationError",
    "Model",
    "Options",
    "SpecError",
    "System",
    "Trajectory",
    "__version__",
    "compile",
    "define",
    "generate",
    "load",
    "simulate",
]

_WHERE = {
    "METHODS": ("s2gen.methods", "METHODS"),
    "EnergyDriftWarning": ("s2gen.runtime.diagnostics", "EnergyDriftWarning"),
    "IntegrationError": ("s2gen.runtime.trajectory", "IntegrationError"),
    "Model": ("s2gen.runtime.model", "Model"),
    "Options": ("s2gen.runtime.options", "Options"),
    "SpecError": ("s2gen.system", "SpecError"),
    "System": ("s2gen.system", "System"),
    "Trajectory": ("s2gen.runtime.trajectory", "Trajectory"),
    "define": ("s2gen.spec", "define_system"),
    "simulate": ("s2gen.runtime", "simulate"),
    "__version__": ("s2gen.version", "__version__"),
}


def __getattr__(name: str) -> Any:
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module 's2gen' has no attribute {name!r}")
    return getattr(importlib.import_module(where[0]), where[1])


def load(spec: str | Path) -> System:
    """A validated `System` from a TOML file path, TOML text, or a built-in name.

    Example:
        >>> load("double_pendulum").n
        2
        >>> load('name = "p"\\nbodies = 1\\n[parameters]\\nm = 1.0\\n'
        ...      '[inertia]\\ndiagonal = ["m"]\\n[potential]\\nV = "-m*q1[2]"').name
        'p'
    """
    from s2gen.spec import load_spec_text
    from s2gen.systems import resolve

    text = str(spec)
    if not isinstance(spec, Path) and "\n" in text and "=" in text:
        return load_spec_text(text)
    return resolve(text)


def generate(system: System, lang: str = "c", out: str | Path | None = None) -> dict[str, str]:
    """The emitted files of `system` in `lang` ("c" or "numpy"), written to `out` if given.

    Example:
        >>> sorted(generate(load("double_pendulum"), "c"))
        ['double_pendulum.c', 'double_pendulum.h']
    """
    from s2gen.emit import emit, write_files

    files = emit(system, lang)
    if out is not None:
        write_files(files, out)
    return files


def compile(system: System, backend: str = "c", opt: str | None = None) -> Model:
    """`system` compiled for `backend` ("c", "numpy" or "reference") as a `Model`; `opt`
    picks the C library's gcc flags: "portable" (the default) or "native" (-O3
    -march=native, for this processor only).

    Example:
        >>> compile(load("double_pendulum")).parameters["g"]
        9.81
    """
    from s2gen.runtime.model import Model

    return Model(system, backend, opt=opt)
