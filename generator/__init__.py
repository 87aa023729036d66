"""s2gen: equations, variational integrators and C/NumPy code for mechanics on (S^2)^n.

The public API, for scripts and notebooks (each name is imported on first use, so that
`import s2gen` is instant):

- `load(spec, params=...)`: a `System` from a TOML file, TOML text or a built-in name;
- `define(...)`: a `System` from Python values (same rules as TOML; see `s2gen.spec`);
- `generate(system, lang, out=None)`: the emitted files of a language ({name: text}), written
  to `out` when given;
- `compile(system, backend="c")`: a `Model` (integrate, step, energy, gradient, momentum,
  parameters by name);
- `simulate(system, method, backend, h, T, ..., params={"g": 1.62})`: a `Trajectory` (its
  angular momentum filled in, its spec and parameters kept; a run whose relative energy error
  passes `Options.energy_warn` warns with an `EnergyDriftWarning`);
- `fmu(system, out, fmi=2, kind="both", method="vi")`: the system as a Functional Mock-up
  Unit (FMI 2 or 3, Co-Simulation and/or Model Exchange; FMPy's FMI headers are needed);
- `builtins()`: the names of the built-in systems;
- `METHODS` (the method table), `Options`, `Trajectory`, `IntegrationError`,
  `EnergyDriftWarning`, `SpecError`, `__version__`;
- modules: `ensemble` (`s2gen.ensemble`: ensembles of perturbed or swept members on Dask),
  `metrics` (energy and unit-length errors of a trajectory, observed orders), `paper` (the
  paper's systems as factories with their options, and their building blocks).

`s2gen.inspect` opens the pipeline (stages, op counts, builds) for the experiments; it is not
part of this API.

Example:
    >>> import s2gen
    >>> pendulum = s2gen.load("double_pendulum")
    >>> model = s2gen.compile(pendulum)
    >>> model.integrate("vi", h=0.01, T=1.0).energy.shape
    (101,)
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from s2gen import ensemble as ensemble
    from s2gen import metrics as metrics
    from s2gen.methods import METHODS as METHODS
    from s2gen.runtime import simulate as simulate
    from s2gen.runtime.model import Model
    from s2gen.runtime.options import Options as Options
    from s2gen.runtime.trajectory import IntegrationError as IntegrationError
    from s2gen.runtime.trajectory import Trajectory as Trajectory
    from s2gen.spec import define_system as define
    from s2gen.system import SpecError as SpecError
    from s2gen.system import System
    from s2gen.systems import paper as paper

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
    "builtins",
    "compile",
    "define",
    "ensemble",
    "fmu",
    "generate",
    "load",
    "metrics",
    "paper",
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


_MODULES = {
    "ensemble": "s2gen.ensemble",
    "metrics": "s2gen.metrics",
    "paper": "s2gen.systems.paper",
}


def __getattr__(name: str) -> Any:
    if name in _MODULES:
        return importlib.import_module(_MODULES[name])
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module 's2gen' has no attribute {name!r}")
    return getattr(importlib.import_module(where[0]), where[1])


def load(spec: str | Path, params: Mapping[str, float] | Sequence[str] = ()) -> System:
    """A validated `System` from a TOML file path, TOML text, or a built-in name (options and
    parameter values after a colon: ``"rope:n=4,g=1.62"``); `params` sets parameter values too,
    by name ({"g": 1.62}) or as the command line's ``"NAME=VALUE"`` strings.

    Example:
        >>> load("double_pendulum").n
        2
        >>> load("double_pendulum", {"g": 1.62}).parameters["g"]
        1.62
        >>> load('name = "p"\\nbodies = 1\\n[parameters]\\nm = 1.0\\n'
        ...      '[inertia]\\ndiagonal = ["m"]\\n[potential]\\nV = "-m*q1[2]"').name
        'p'
    """
    from s2gen.spec import load_spec_text
    from s2gen.systems import parameter_values, resolve, with_parameters

    text = str(spec)
    if not isinstance(spec, Path) and "\n" in text and "=" in text:
        system = load_spec_text(text)
    else:
        system = resolve(text)
    values = dict(params) if isinstance(params, Mapping) else parameter_values(system, params)
    return with_parameters(system, values) if values else system


def builtins() -> list[str]:
    """The names of the built-in systems (`load` takes each, with options after a colon).

    Example:
        >>> "double_pendulum" in builtins()
        True
    """
    from s2gen.systems import builtin_names

    return builtin_names()


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
    -march=native -fno-tree-slp-vectorize, for this processor only).

    Example:
        >>> compile(load("double_pendulum")).parameters["g"]
        9.81
    """
    from s2gen.runtime.model import Model

    return Model(system, backend, opt=opt)


def fmu(
    system: System,
    out: str | Path,
    fmi: int = 2,
    kind: str | None = None,
    method: str = "vi",
    h: float | None = None,
) -> Path:
    """Write `system` as a Functional Mock-up Unit to `out` and return its path: FMI `fmi`
    (2 or 3); `kind` "cs" (Co-Simulation), "me" (Model Exchange) or "both" (None: "both",
    "cs" for a driven system); Co-Simulation advances each communication interval by
    `method`'s steps of size `h` (default the spec's [run] h; the FMU's `stepSize` parameter
    changes it). A driven system (forces, inputs or time t) is Co-Simulation only, by one of
    `s2gen.methods.driven_methods()`: its inputs become FMI inputs held over each step, and
    the output `work` is the work done on it since the start. The archive holds the model
    description, the sources (emitted C and the FMI wrapper) and a binary for this machine;
    it is byte-reproducible apart from the binary. The FMI headers come from FMPy
    (``pip install fmpy``).

    Example:
        >>> import tempfile, zipfile
        >>> path = fmu(load("double_pendulum"), Path(tempfile.mkdtemp()) / "dp.fmu", fmi=3)
        >>> "sources/double_pendulum_fmi3.c" in zipfile.ZipFile(path).namelist()
        True
    """
    from s2gen.fmi import export

    return export(system, out, fmi=fmi, kind=kind, method=method, h=h)
