"""The built-in systems: the paper's examples and the rope, by name (with options).

Input: a name (``double_pendulum``), a name with options (``elastic_rod:n=1000``,
``rope:n=200,kappa=0.1``, ``molecular:subdivisions=4``) or a path to a TOML spec file, each
optionally with parameter values after the colon (``double_pendulum:g=5``, ``my.toml:k=2``).
Output: a validated `System`, whose `source` is what rebuilds it (the built-in name with its
options, or the TOML text; parameter values given after the colon are the run's, not the
source's).

Built-ins come from two places, merged into one registry of loader callables: the TOML files
shipped in the ``s2gen.systems.examples`` package folder (one system per file, named by the
file stem) and Python factories listed in `_FACTORIES` (for systems whose size is a
parameter). A factory's keyword arguments are its options: `builtin_options` lists them with
their defaults, `resolve` parses ``name:key=value,...`` by each option's type (int, float, str,
bool), and an unknown option or a value of the wrong type is a one-line `SpecError`.

Example:
    >>> "double_pendulum" in builtin_names()
    True
    >>> builtin("double_pendulum").n
    2
    >>> resolve("elastic_rod:n=12,inertia=physical").n
    12
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Any

from s2gen.spec import load_spec, load_spec_text
from s2gen.system import SpecError, System
from s2gen.systems import chains, paper

__all__ = [
    "Option",
    "builtin",
    "builtin_names",
    "builtin_options",
    "parameter_values",
    "resolve",
    "with_parameters",
]

_EXAMPLES = "s2gen.systems.examples"

#: Built-ins written in Python, name -> factory. A TOML example of the same name is an error.
_FACTORIES: dict[str, Callable[..., System]] = {
    "three_bodies": paper.three_bodies,
    "four_pendula": paper.four_pendula,
    "elastic_rod": paper.elastic_rod,
    "dipoles": paper.dipoles,
    "molecular": paper.molecular,
    "rope": chains.rope,
}

#: Option types settable from a command line (annotation text -> description).
_TYPES = {
    "int": "an integer",
    "float": "a number",
    "str": "a string",
    "bool": "true or false",
    "str | float": "a number or a string",
}


@dataclass(frozen=True)
class Option:
    """One option of a built-in: its name, default and type (annotation text).

    Example:
        >>> [str(o) for o in builtin_options("elastic_rod")]
        ['n=10', "inertia='paper'", "solver='auto'"]
    """

    name: str
    default: Any
    annotation: str

    def __str__(self) -> str:
        return f"{self.name}={self.default!r}"

    @property
    def settable(self) -> bool:
        """True when a command line can set it (a scalar type)."""
        return self.annotation in _TYPES

    def parse(self, text: str, where: str) -> Any:
        """The value of `text` for this option (SpecError when it has the wrong type)."""
        kind = self.annotation
        if not self.settable:
            raise SpecError(
                f"{where}: option {self.name} ({kind}) cannot be set from a spec string; "
                "use the Python API"
            )
        try:
            if kind == "int":
                return int(text)
            if kind == "float":
                return float(text)
            if kind == "bool":
                if text.lower() not in ("true", "false", "1", "0"):
                    raise ValueError(text)
                return text.lower() in ("true", "1")
            if kind == "str | float":
                try:
                    return float(text)
                except ValueError:
                    return text
        except ValueError:
            raise SpecError(
                f"{where}: option {self.name} expects {_TYPES[kind]}, got {text!r}"
            ) from None
        return text


def builtin_options(name: str) -> list[Option]:
    """The options of a built-in (none for TOML examples), with defaults, in signature order.

    Example:
        >>> [o.name for o in builtin_options("rope")][:3]
        ['n', 'mass', 'length']
    """
    factory = _FACTORIES.get(name)
    if factory is None:
        if name not in _registry():
            raise SpecError(f"unknown built-in system {name!r}; built-ins are: {_listing()}")
        return []
    return [
        Option(p.name, p.default, str(p.annotation))
        for p in inspect.signature(factory).parameters.values()
        if p.default is not inspect.Parameter.empty
    ]


def _toml_stems() -> list[str]:
    """Stems of the TOML files shipped in the examples package folder."""
    folder = files(_EXAMPLES)
    return sorted(p.name[: -len(".toml")] for p in folder.iterdir() if p.name.endswith(".toml"))


def _toml_loader(stem: str) -> Callable[[], System]:
    """A loader for a shipped TOML example; its origin is package-relative (reproducible)."""

    def load() -> System:
        text = files(_EXAMPLES).joinpath(f"{stem}.toml").read_text(encoding="utf-8")
        return load_spec_text(text, origin=f"{_EXAMPLES}/{stem}.toml")

    return load


@functools.cache
def _registry() -> dict[str, Callable[..., System]]:
    """Every built-in name mapped to the callable that builds it."""
    registry = {stem: _toml_loader(stem) for stem in _toml_stems()}
    clash = sorted(set(registry) & set(_FACTORIES))
    if clash:
        raise RuntimeError(f"built-in systems defined twice (TOML and Python): {clash}")
    registry.update(_FACTORIES)
    return dict(sorted(registry.items()))


def builtin_names() -> list[str]:
    """The names of the built-in systems, sorted.

    Example:
        >>> "double_pendulum" in builtin_names()
        True
    """
    return list(_registry())


def builtin(name: str, **options: Any) -> System:
    """Build the built-in system `name` with `options` (its factory's keyword arguments;
    raises SpecError listing the names if unknown, or naming a bad option).

    Example:
        >>> builtin("double_pendulum").parameter_names
        ('m1', 'm2', 'l1', 'l2', 'g')
        >>> builtin("rope", n=50).n
        50
    """
    loader = _registry().get(name)
    if loader is None:
        raise SpecError(f"unknown built-in system {name!r}; built-ins are: {_listing()}")
    if not options:
        return dataclasses.replace(loader(), source=name)
    known = {o.name for o in builtin_options(name)}
    unknown = sorted(set(options) - known)
    if unknown:
        shown = ", ".join(str(o) for o in builtin_options(name)) or "none"
        raise SpecError(f"{name}: unknown option {unknown[0]!r} (options: {shown})")
    try:
        system = loader(**options)
    except SpecError:
        raise
    except ValueError as exc:
        raise SpecError(f"{name}: {exc}") from None
    given = ",".join(f"{k}={v}" for k, v in options.items())
    return dataclasses.replace(system, source=f"{name}:{given}")


def with_parameters(system: System, values: Mapping[str, float]) -> System:
    """`system` with the parameter defaults in `values` (by name) replaced, validated anew
    (M positive definite at the new values; SpecError naming an unknown parameter).

    Example:
        >>> with_parameters(builtin("double_pendulum"), {"g": 5.0}).parameters["g"]
        5.0
    """
    unknown = sorted(set(values) - set(system.parameter_names))
    if unknown:
        known = ", ".join(system.parameter_names) or "none"
        raise SpecError(f"{system.name}: unknown parameter {unknown[0]!r} (parameters: {known})")
    if not values:
        return system
    changed = System.create(
        name=system.name,
        n=system.n,
        parameters={**system.parameters, **values},
        inertia=system.chain if system.chain is not None else system.inertia,
        potential=system.potential,
        q0=system.q0,
        omega0=system.omega0,
        run=system.run,
        origin=system.origin,
        terms=system.terms,
        inertia_solver=system.inertia_solver,
        inputs=system.inputs.defaults,
        forces=system.forces,
    )
    return dataclasses.replace(changed, source=system.source, source_folder=system.source_folder)


def resolve(spec: str, params: Sequence[str] = ()) -> System:
    """A spec file path if one exists, else a built-in name, each optionally followed by
    ``:key=value,...``: a built-in's options (`builtin_options`) and, for every spec, parameter
    values (`with_parameters`); `params` adds ``NAME=VALUE`` parameter values (the command
    line's ``--param``). Raises SpecError otherwise; a folder is named as one.

    Example:
        >>> resolve("double_pendulum").name
        'double_pendulum'
        >>> resolve("double_pendulum:g=5").parameters["g"]
        5.0
        >>> resolve("rope:n=4", ["g=1.62"]).parameters["g"]
        1.62
    """
    system = _resolve(spec)
    if not params:
        return system
    return with_parameters(system, parameter_values(system, params))


def parameter_values(system: System, params: Sequence[str]) -> dict[str, float]:
    """The command line's ``NAME=VALUE`` parameter values by name (SpecError on a bad one).

    Example:
        >>> parameter_values(builtin("double_pendulum"), ["g=1.62"])
        {'g': 1.62}
    """
    if not params:
        return {}
    items = _items(f"--param {' '.join(params)}", ",".join(params))
    where = f"{system.name}: --param"
    return {k: _number(v, f"{where} {k}") for k, v in items.items()}


def _resolve(spec: str) -> System:
    """`resolve` without the --param values."""
    path = Path(spec)
    if path.is_file():
        return load_spec(path)
    if spec in _registry():
        return builtin(spec)
    base, colon, text = spec.rpartition(":") if ":" in spec else (spec, "", "")
    if colon and (base in _registry() or Path(base).is_file()):
        where = f"{base}:{text}"
        items = _items(where, text)
        if base in _registry():
            known = {o.name: o for o in builtin_options(base)}
            options = {k: known[k].parse(v, where) for k, v in items.items() if k in known}
            system = builtin(base, **options)
        else:
            known, system = {}, load_spec(base)
        names = system.parameter_names
        unknown = [k for k in items if k not in known and k not in names]
        if unknown:
            shown = ", ".join([str(o) for o in known.values()] + list(names)) or "none"
            raise SpecError(f"{where}: unknown option or parameter {unknown[0]!r} (known: {shown})")
        params = {k: _number(v, f"{where}: parameter {k}") for k, v in items.items() if k in names}
        return with_parameters(system, params)
    if path.is_dir():
        raise SpecError(f"{spec}: is a folder, not a spec file (give a .toml file or a built-in)")
    if path.suffix == ".toml" or len(path.parts) > 1:
        raise SpecError(f"{spec}: no such spec file (built-ins are: {_listing()})")
    raise SpecError(
        f"{spec!r} is neither a spec file nor a built-in system; built-ins are: {_listing()}"
    )


def _items(where: str, text: str) -> dict[str, str]:
    """The ``key=value,...`` pairs after a spec, in order (SpecError for a malformed item)."""
    items: dict[str, str] = {}
    for item in text.split(","):
        key, eq, value = (part.strip() for part in item.partition("="))
        if not eq or not key or not value:
            raise SpecError(f"{where}: expected key=value, got {item!r}")
        if key in items:
            raise SpecError(f"{where}: option {key!r} given twice")
        items[key] = value
    return items


def _number(text: str, where: str) -> float:
    """A finite number written in `text` (SpecError otherwise)."""
    try:
        value = float(text)
    except ValueError:
        raise SpecError(f"{where}: expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise SpecError(f"{where}: {text} is not a finite number")
    return value


def _listing() -> str:
    return ", ".join(builtin_names())
